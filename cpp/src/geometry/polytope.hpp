// Internal polytope helpers: the box's fixed numbering, topology from face loops, translation.
// The public Polytope struct and polytope_from_triangles are in signorini/shapes.hpp.
#pragma once

#include <vector>

#include "signorini/shapes.hpp"

namespace signorini::geometry {

/// The polytope of a box with half extents h (m), numbered as in docs/polytope_numbering.md:
/// vertex k = (sx h_x, sy h_y, sz h_z) (sx = +1 if k & 1, sy from k & 2, sz from k & 4), face 2 i
/// with normal -e_i and 2 i + 1 with +e_i, edges in order of first appearance. Exact normals
/// (+-e_i) and offsets (h_i); centroid 0.
Polytope box_polytope(const Vec3& h);

/// Fills edges and face_edges of p from its vertices and face loops: faces are walked 0, 1, ...,
/// side k of face f running loop[k] -> loop[k + 1]; an undirected edge is numbered when first met
/// (Edge{v0, v1, f0 = f, f1}), and the face that meets it second becomes f1. Throws
/// std::invalid_argument ("<who>: ...") if an edge is used by other than exactly two faces in
/// opposite directions (an open, non-manifold or inconsistently oriented surface).
void build_edges(Polytope& p, const char* who);

/// polytope_from_triangles without its convexity test (which costs triangles x vertices), for
/// triangles that are convex by construction (Qhull's hull). Still checks closedness and merges.
Polytope polytope_from_hull_triangles(const Points& vertices, const Triangles& faces);

/// p moved by t (m): vertices + t, offsets + n . t, centroid + t; topology unchanged.
Polytope translated(const Polytope& p, const Vec3& t);

}  // namespace signorini::geometry
