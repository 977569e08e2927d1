// Static triangle meshes against convex items: the BVH (fcl_queries.cpp) names the candidate
// triangles, each is tested as a one-sided convex piece, and all points go into one manifold.
// Interior edges of flat or concave regions are inactive: they never produce edge normals, so a box
// sliding over a tessellated floor meets no ghost contacts (capsules and cylinders, whose tests see
// a lone triangle, get a ghost replaced by the face's own contact). Triangles are one-sided: no contact
// pulls a body towards a triangle's back, and a body whose centre has crossed a triangle inside its
// prism while still reaching its front (a small fast or fast-turning body that went through in one
// step) is pushed back out along the face normal instead of being let go.
#include <algorithm>
#include <cmath>
#include <limits>

#include "collision/collision.hpp"
#include "collision/gjk_epa.hpp"

namespace signorini::collision {

void triangle_polytope_of(const TriangleMesh& mesh, Eigen::Index t, Polytope& P) {
  if (P.faces.empty()) {
    P.vertices.resize(3, 3);
    P.faces = {{0, 1, 2}, {0, 2, 1}};
    P.face_edges = {{0, 1, 2}, {2, 1, 0}};
    P.edges = {{0, 1, 0, 1}, {1, 2, 0, 1}, {2, 0, 0, 1}};
    P.normals.resize(2);
    P.offsets.resize(2);
  }
  for (int c = 0; c < 3; ++c) P.vertices.row(c) = mesh.vertices.row(mesh.faces(t, c));
  const Vec3& n = mesh.normals[t];
  P.normals[0] = n;
  P.normals[1] = -n;
  P.offsets[0] = n.dot(P.vertex(0));
  P.offsets[1] = -P.offsets[0];
  P.centroid = (P.vertex(0) + P.vertex(1) + P.vertex(2)) / 3.0;
}

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Whether a feature of a triangle, by region (-1 the face, 0..2 edge k from v_k to v_k+1, 3..5
/// vertex k - 3), is where the mesh goes on flat or bends up: an inactive edge (flat or concave),
/// or a vertex between two. There this face's plane extended is not the surface, and a normal
/// from the feature is a ghost of the tessellation. The one rule for spheres (exact regions) and
/// for the other items' witnesses (ghost_of_inactive_edge, regions within a tolerance).
bool inactive_feature(const std::array<bool, 3>& active, int region) {
  if (region < 0) return false;
  if (region < 3) return !active[region];
  return !active[region - 3] && !active[(region - 3 + 2) % 3];
}

/// Sphere (centre c_l, radius r, mesh frame) against triangle t: the closest point, with the face
/// normal wherever the closest feature is an inactive edge or a vertex between inactive edges.
void triangle_sphere(const TriangleMesh& mesh, Eigen::Index t, const Pose& pa, const Vec3& c_l, double r,
                     std::uint32_t part_b, std::vector<Contact>& out) {
  const Vec3 v[3] = {mesh.vertex(mesh.faces(t, 0)), mesh.vertex(mesh.faces(t, 1)), mesh.vertex(mesh.faces(t, 2))};
  const Vec3& n = mesh.normals[t];
  const double height = n.dot(c_l - v[0]);
  if (height < 0.0) return;  // one-sided: a centre behind the face is left alone
  // closest point by barycentric region
  Vec3 q = c_l - height * n;
  int region = -1;  // -1 face, 0..2 edge k (v_k -> v_k+1), 3..5 vertex k
  for (int k = 0; k < 3; ++k) {
    const Vec3 a = v[k], b = v[(k + 1) % 3];
    if ((b - a).cross(n).dot(q - a) > 0.0) region = k;
  }
  if (region >= 0) {
    double best = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      const Vec3 a = v[k], b = v[(k + 1) % 3];
      const double s = std::clamp((c_l - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      const Vec3 x = a + s * (b - a);
      if ((c_l - x).squaredNorm() < best) {
        best = (c_l - x).squaredNorm();
        q = x;
        region = s <= 0.0 ? 3 + k : s >= 1.0 ? 3 + (k + 1) % 3 : k;
      }
    }
  }
  // beyond an inactive edge (flat or concave), or a vertex between two, the closest point of the
  // mesh lies on a neighbouring face, which makes the contact: this face's plane extended there
  // is not the surface (the next face may bend away), so this triangle makes none
  if (inactive_feature(mesh.active_edge[t], region)) return;
  const bool use_face = region < 0;
  Vec3 n_l;
  double gap;
  Vec3 w = q;
  if (use_face) {
    n_l = n;
    gap = height - r;
    w = c_l - height * n;
  } else {
    const double dist = (c_l - q).norm();
    n_l = dist > 0.0 ? Vec3((c_l - q) / dist) : n;
    gap = dist - r;
  }
  Contact c;
  c.normal = pa.R * n_l;
  c.gap = gap;
  c.point = pa.R * (0.5 * (w + (c_l - r * n_l))) + pa.p;
  const auto tri = static_cast<std::uint32_t>(t);
  c.feature_a = region < 0 ? feature_id(FeatureKind::Face, 0, tri)
                : region < 3 ? feature_id(FeatureKind::Edge, region, tri)
                             : feature_id(FeatureKind::Vertex, region - 3, tri);
  c.feature_b = feature_id(FeatureKind::Shape, 0, part_b);
  out.push_back(c);
}

/// Whether an item whose centre is c_l (mesh frame) and whose surface lies within r of it has
/// crossed triangle t: its centre is behind the triangle's plane and inside the triangle's prism
/// (its projection onto the plane lies in the triangle), and
/// - it was pushed back through this triangle last step (remembered) and is not out yet; or
/// - the body's centre (body_l, bounding radius body_r; a compound's parts cross as one body) was in
///   front of the plane at the start of the previous step (body_l - travel_l) and met the plane
///   where t has no rim: it went through in one step; or
/// - it, or its body, is behind by less than its radius (it still reaches the front side), and the
///   body is being pushed back through another of the mesh's triangles (pushed: it slid from under
///   that one to under this one), or its travel is unknown (no memory, or just placed). A body
///   behind the plane a step ago that nothing pushed never came through the front.
/// A body resting on a one-sided mesh never has its centre behind the face it rests on; one that
/// does has gone through it (a fast or fast-turning body), and the mesh keeps pushing until it is
/// back in front. A body that came round the mesh's rim (beyond a boundary edge, from beside an
/// open mesh to under it, through no face) is behind a one-sided face and left alone.
bool crossed_triangle(const TriangleMesh& mesh, Eigen::Index t, const Vec3& c_l, double r, const Vec3& travel_l,
                      bool remembered, bool pushed, const Vec3& body_l, double body_r) {
  const Vec3 v[3] = {mesh.vertex(mesh.faces(t, 0)), mesh.vertex(mesh.faces(t, 1)), mesh.vertex(mesh.faces(t, 2))};
  const Vec3& n = mesh.normals[t];
  const double height = n.dot(c_l - v[0]);
  if (!(height < 0.0)) return false;
  const auto beyond = [&](int k, const Vec3& x) { return (v[(k + 1) % 3] - v[k]).cross(n).dot(x - v[k]) > 0.0; };
  for (int k = 0; k < 3; ++k)
    if (beyond(k, c_l)) return false;  // outside the prism
  if (remembered) return true;
  const double body_height = n.dot(body_l - v[0]);
  const Vec3 body_before = body_l - travel_l;
  const double height_before = n.dot(body_before - v[0]);
  const auto beyond_rim = [&](const Vec3& x) {
    for (int k = 0; k < 3; ++k)
      if (mesh.boundary_edge[static_cast<std::size_t>(t)][static_cast<std::size_t>(k)] && beyond(k, x)) return true;
    return false;
  };
  if (height_before >= 0.0) {
    // where the body's centre met the plane (where it was, if it has not met it)
    const Vec3 met = height_before > body_height
                         ? Vec3(body_before + height_before / (height_before - body_height) * travel_l)
                         : body_before;
    return !beyond_rim(met);
  }
  const bool straddles = height > -r || (body_height < 0.0 && body_height > -body_r);
  if (!straddles) return false;
  return pushed || travel_l.squaredNorm() == 0.0;
}

/// Largest distance of a triangle's vertices from its first (m): a scale for its tolerances.
double radius_of_triangle(const Polytope& tri) {
  return std::max((tri.vertex(1) - tri.vertex(0)).norm(), (tri.vertex(2) - tri.vertex(0)).norm());
}

/// True when the world point x projects into triangle t (mesh pose pa).
bool projects_into(const TriangleMesh& mesh, Eigen::Index t, const Pose& pa, const Vec3& x) {
  const Vec3 x_l = pa.R.transpose() * (x - pa.p);
  const Vec3& n = mesh.normals[t];
  for (int k = 0; k < 3; ++k) {
    const Vec3 a = mesh.vertex(mesh.faces(t, k)), b = mesh.vertex(mesh.faces(t, (k + 1) % 3));
    if ((b - a).cross(n).dot(x_l - a) > 0.0) return false;
  }
  return true;
}

/// Contacts that push an item which has crossed triangle t back to its front side: the item's
/// points against the triangle's plane (plane_item: corners, ends, rims, vertices), normal the
/// face normal, gap their height above the plane; those whose foot lies in the triangle are kept
/// (all of them when none does, so that the item is never let go).
void crossed_contacts(const TriangleMesh& mesh, Eigen::Index t, const Pose& pa, const Item& b,
                      std::vector<Contact>& out) {
  const Vec3 n = pa.R * mesh.normals[t];
  const double offset = n.dot(pa.R * mesh.vertex(mesh.faces(t, 0)) + pa.p);
  const std::size_t first = out.size();
  plane_item(n, offset, b, out);
  const auto tri = static_cast<std::uint32_t>(t);
  std::size_t kept = first;
  for (std::size_t k = first; k < out.size(); ++k) {
    out[k].feature_a = feature_id(FeatureKind::Face, 0, tri);
    const Vec3 foot = out[k].point - 0.5 * out[k].gap * n;
    if (projects_into(mesh, t, pa, foot)) out[kept++] = out[k];
  }
  if (kept > first) out.resize(kept);
}

/// Whether a contact of B with triangle t, of normal n (world) and witness w on the triangle
/// (world), is a ghost of the tessellation: a normal other than the face's, from an inactive edge
/// (flat or concave) or a vertex between two, where the mesh goes on flat or bends up. The capsule
/// and cylinder tests see a lone triangle and make them; the sphere and polytope tests never do.
bool ghost_of_inactive_edge(const TriangleMesh& mesh, Eigen::Index t, const Pose& pa, const Vec3& n,
                            const Vec3& w) {
  const Vec3& n_t = mesh.normals[t];
  if ((pa.R.transpose() * n).dot(n_t) >= 1.0 - 1e-12) return false;
  const auto& active = mesh.active_edge[t];
  if (active[0] && active[1] && active[2]) return false;
  const Vec3 v[3] = {mesh.vertex(mesh.faces(t, 0)), mesh.vertex(mesh.faces(t, 1)), mesh.vertex(mesh.faces(t, 2))};
  const Vec3 x = pa.R.transpose() * (w - pa.p);
  // a witness within this of a feature lies on it (EPA's witnesses are within 1e-6 of the pair's
  // scale, the clip's exact; a face point taken for an edge's only gets the face normal)
  const double scale = (v[1] - v[0]).norm() + (v[2] - v[1]).norm() + (v[0] - v[2]).norm();
  const double tol2 = std::pow(1e-6 * scale, 2);
  for (int j = 0; j < 3; ++j)  // vertex j, between edges j - 1 and j
    if ((x - v[j]).squaredNorm() <= tol2) return inactive_feature(active, 3 + j);
  for (int e = 0; e < 3; ++e) {
    const Vec3 a = v[e], d = v[(e + 1) % 3] - v[e];
    const double s = std::clamp((x - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
    if ((x - (a + s * d)).squaredNorm() <= tol2) return inactive_feature(active, e);
  }
  return false;  // inside the face: a feature of B faces it
}

/// The face's own contact with B, in place of ghosts: B's supporting feature along -n_t clipped to
/// triangle t (gaps along n_t), plus B's support point along -n_t when it lies over the triangle
/// and deeper than those (a cylinder's cap is sampled at 8 rim points), as in convex_by_support;
/// none when all of it lies beside the triangle, where a neighbouring face makes the contact (as
/// for spheres). Every point lies inside the triangle (on the mesh) and on B (hence the clip:
/// docs/conventions.md, "Contacts", static triangle mesh).
void face_contact(const TriangleMesh& mesh, Eigen::Index t, const Pose& pa, const Item& b, double threshold,
                  Scratch& scratch, std::vector<Contact>& out) {
  const auto index = static_cast<std::uint32_t>(t);
  const Vec3 n_t = pa.R * mesh.normals[t];
  SupportFeature& face = scratch.feature_a;
  face.points.clear();
  face.ids.clear();
  for (int j = 0; j < 3; ++j) {
    face.points.push_back(pa.R * mesh.vertex(mesh.faces(t, j)) + pa.p);
    face.ids.push_back(feature_id(FeatureKind::Vertex, static_cast<std::uint32_t>(j), index));
  }
  face.normal = n_t;
  face.is_face = true;
  support_feature(b, -n_t, scratch.feature_b);
  const std::size_t first = out.size();
  clip_features(face, scratch.feature_b, true, index, b.part, threshold, scratch, out);
  const Vec3 w_b = support_point(b, -n_t);
  const double gap = n_t.dot(w_b - face.points[0]);
  double least = std::numeric_limits<double>::infinity();
  for (std::size_t k = first; k < out.size(); ++k) least = std::min(least, out[k].gap);
  bool inside = gap < threshold && gap < least - 1e-9 * b.radius();
  for (int j = 0; j < 3 && inside; ++j)
    inside = (face.points[(j + 1) % 3] - face.points[j]).cross(n_t).dot(w_b - face.points[j]) <= 0.0;
  if (inside) {
    Contact& c = out.emplace_back();
    c.normal = n_t;
    c.gap = gap;
    c.point = w_b - 0.5 * gap * n_t;
    c.feature_a = feature_id(FeatureKind::Face, 0, index);
    c.feature_b = feature_id(FeatureKind::Shape, 0, b.part);
  }
}

/// Inactive-edge filtering for the contacts from index `first` that a capsule or a polytope B got
/// from triangle t: if one is a ghost (ghost_of_inactive_edge, its witness y - gap/2 n), the ghosts
/// and the face-normal points give way to the face's own contact, made by face_only(out); a point on
/// an active edge stays. A polytope needs it too: its test offers only the triangle's active edges,
/// but B's own faces as references. For B whose centre (centre_l, mesh frame) is behind the
/// triangle's plane, only a ghost pushing out of the front side counts: one pointing behind is
/// dropped (keep_front) and never becomes a face contact pushing B up through the one-sided mesh
/// (a body come round an open rim, under it).
template <class FaceOnly>
void without_ghosts(const TriangleMesh& mesh, Eigen::Index t, const Pose& pa, const Vec3& centre_l, std::size_t first,
                    std::vector<Contact>& out, FaceOnly face_only) {
  const Vec3 n_t = pa.R * mesh.normals[t];
  const bool in_front = mesh.normals[t].dot(centre_l - mesh.vertex(mesh.faces(t, 0))) >= 0.0;
  const auto ghost = [&](const Contact& c) {
    return (in_front || c.normal.dot(n_t) > 0.0) &&
           ghost_of_inactive_edge(mesh, t, pa, c.normal, c.point - 0.5 * c.gap * c.normal);
  };
  const auto begin = out.begin() + static_cast<std::ptrdiff_t>(first);
  if (std::none_of(begin, out.end(), ghost)) return;
  const auto replaced = [&](const Contact& c) { return ghost(c) || c.normal.dot(n_t) >= 1.0 - 1e-12; };
  out.erase(std::remove_if(begin, out.end(), replaced), out.end());
  face_only(out);
}

/// Drops the contacts from index `first` on whose normal does not push B out of the front side of
/// triangle t (a one-sided face never pulls a body through to its back).
void keep_front(const TriangleMesh& mesh, Eigen::Index t, const Pose& pa, std::size_t first,
                std::vector<Contact>& out) {
  const Vec3 n_world = pa.R * mesh.normals[t];
  out.erase(std::remove_if(out.begin() + static_cast<std::ptrdiff_t>(first), out.end(),
                           [&](const Contact& c) { return c.normal.dot(n_world) <= 0.0; }),
            out.end());
}

}  // namespace

void trimesh_item(const TriangleMesh& mesh, const Pose& pa, const TriangleQuery& query, const Item& b,
                  double threshold, TrianglePast& past, Scratch& scratch, std::vector<Contact>& out) {
  // B's bounding box in the mesh frame, grown by the threshold
  const Vec3 centre = pa.R.transpose() * (b.pose.p - pa.p);
  const double reach = b.radius() + std::max(threshold, 0.0);
  std::vector<int>& triangles = scratch.triangles;
  query.overlapping(centre - Vec3::Constant(reach), centre + Vec3::Constant(reach), triangles, scratch.bvh_stack);
  Polytope& tri = scratch.triangle;
  const double radius = b.radius();
  const Vec3 travel = pa.R.transpose() * past.travel;
  // the body's centre (the item's own when the query knows no body)
  const bool body_known = past.body_radius > 0.0;
  const Vec3 body = body_known ? Vec3(pa.R.transpose() * (past.body_centre - pa.p)) : centre;
  const double body_radius = body_known ? past.body_radius : radius;
  // the triangle a body is being pushed back through stays a candidate however deep the body is
  if (past.remembered >= 0 && past.remembered < mesh.faces.rows() &&
      !std::binary_search(triangles.begin(), triangles.end(), past.remembered))
    triangles.push_back(past.remembered);
  for (int t : triangles) {
    const auto index = static_cast<std::uint32_t>(t);
    if (crossed_triangle(mesh, t, centre, radius, travel, t == past.remembered, past.remembered >= 0, body,
                         body_radius)) {
      // gone through: pushed back out along the face normal, and remembered until it is out
      crossed_contacts(mesh, t, pa, b, out);
      if (past.found < 0 || t == past.remembered) past.found = t;
    } else if (b.polytope) {
      triangle_polytope_of(mesh, t, tri);
      const std::size_t first = out.size();
      const Vec3 n_t = pa.R * mesh.normals[t];
      const double tiny = 1e-9 * (radius + radius_of_triangle(tri));
      auto contacts_at = [&](const Pose& pose) {
        triangle_polytope(tri, mesh.active_edge[t], pa, index, *b.polytope, pose, b.part, threshold,
                          *scratch.polytope, out);
        without_ghosts(mesh, t, pa, centre, first, out, [&](std::vector<Contact>& o) {
          triangle_polytope(tri, mesh.active_edge[t], pa, index, *b.polytope, pose, b.part, threshold,
                            *scratch.polytope, o, true);
        });
        const bool touching_behind = std::any_of(out.begin() + static_cast<std::ptrdiff_t>(first), out.end(),
                                                 [&](const Contact& c) {
                                                   return std::abs(c.gap) <= tiny && !(c.normal.dot(n_t) > 0.0);
                                                 });
        keep_front(mesh, t, pa, first, out);
        return touching_behind;
      };
      if (contacts_at(b.pose) && out.size() == first) {
        // touching at a vertex or an edge, the separating axis may point behind the triangle: B
        // raised by a hair (1e-9 L, 1e-8 L, 1e-7 L) has a unique normal, as for cylinders below
        for (double hair = tiny; hair <= 1.01e2 * tiny && out.size() == first; hair *= 10.0) {
          Pose raised = b.pose;
          raised.p += hair * n_t;
          contacts_at(raised);
          for (std::size_t k = first; k < out.size(); ++k) {
            out[k].gap -= hair * out[k].normal.dot(n_t);
            out[k].point -= 0.5 * hair * n_t;
          }
        }
      }
    } else if (const Sphere* s = b.sphere) {
      triangle_sphere(mesh, t, pa, centre, s->radius, b.part, out);
    } else if (const Capsule* cap = b.capsule) {
      triangle_polytope_of(mesh, t, tri);
      const std::size_t first = out.size();
      polytope_capsule(tri, pa, index, *cap, b.pose, b.part, threshold, out);
      without_ghosts(mesh, t, pa, centre, first, out,
                     [&](std::vector<Contact>& o) { face_contact(mesh, t, pa, b, threshold, scratch, o); });
      keep_front(mesh, t, pa, first, out);
      // both ends of the segment, each as a ball against the triangle (as against a plane): a
      // capsule that lands tilted has its upper end among the contacts when an impact swings it down
      const Vec3 axis_l = pa.R.transpose() * b.pose.R.col(2);
      for (int end = 0; end < 2; ++end) {
        const std::size_t before = out.size();
        triangle_sphere(mesh, t, pa, centre + (end ? 1.0 : -1.0) * cap->half_length * axis_l, cap->radius, b.part, out);
        for (std::size_t k = before; k < out.size(); ++k) out[k].feature_b = feature_id(FeatureKind::Vertex, end, b.part);
      }
    } else if (b.cylinder) {
      // no closed form: GJK / EPA on the support mappings, the triangle as a flat polytope; only
      // contacts pushing out of the front side, and none for a centre behind the triangle
      triangle_polytope_of(mesh, t, tri);
      if (mesh.normals[t].dot(centre - tri.vertex(0)) < 0.0) continue;
      Item face;
      face.kind = ItemKind::Polytope;
      face.polytope = &tri;
      face.pose = pa;
      face.part = index;
      const std::size_t first = out.size();
      // a ghost normal (from an inactive edge) gives way to the face's own contact
      Distance dist = gjk_epa(face, b, *scratch.epa);
      if (!(dist.gap < threshold)) continue;
      const Vec3 n_t = pa.R * mesh.normals[t];
      const double L = radius + radius_of_triangle(tri);
      if (!(dist.normal.dot(n_t) > 0.0) && std::abs(dist.gap) <= 1e-9 * L) {
        // touching at a vertex or an edge, EPA's normal may point behind the triangle: B raised
        // by a hair (1e-9 L, 1e-8 L, 1e-7 L) has a unique one (docs/conventions.md, "Contacts")
        for (double hair = 1e-9 * L; hair <= 1.01e-7 * L; hair *= 10.0) {
          Item raised = b;
          raised.pose.p += hair * n_t;
          const Distance up = gjk_epa(face, raised, *scratch.epa);
          if (up.gap > 0.0 && up.normal.dot(n_t) > 0.0) {
            dist = {up.gap - hair * up.normal.dot(n_t), up.normal, up.w_a, Vec3(up.w_b - hair * n_t)};
            break;
          }
        }
      }
      if (ghost_of_inactive_edge(mesh, t, pa, dist.normal, dist.w_a))
        face_contact(mesh, t, pa, b, threshold, scratch, out);
      else
        convex_by_support(face, b, dist, threshold, scratch, out);
      keep_front(mesh, t, pa, first, out);
      // the 8 rim points of each cap over the triangle's face and in or on it, each against the
      // face's plane (as against a plane): the support clip gives one rim point for a disc tilted
      // into the face, which a turning disc pivots about and sinks through. Speculative ones are
      // left to the clip: the manifold's area rule would take far rim points over near ones
      // (measured: cylinders falling fast onto a height field went deeper)
      const Vec3& n_l = mesh.normals[t];
      const Mat3 R_l = pa.R.transpose() * b.pose.R;
      const auto tri_id = static_cast<std::uint32_t>(t);
      for (int cap = 0; cap < 2; ++cap) {
        const Vec3 c_s = centre + (cap ? 1.0 : -1.0) * b.cylinder->half_height * R_l.col(2);
        for (int k = 0; k < 8; ++k) {
          const double phi = k * kPi / 4.0;
          const Vec3 x = c_s + b.cylinder->radius * (std::cos(phi) * R_l.col(0) + std::sin(phi) * R_l.col(1));
          const double height = n_l.dot(x - tri.vertex(0));
          if (!(height <= 0.0 && height < threshold)) continue;
          bool inside = true;
          for (int e = 0; e < 3 && inside; ++e) {
            const Vec3 a = tri.vertex(e), c = tri.vertex((e + 1) % 3);
            inside = !((c - a).cross(n_l).dot(x - a) > 0.0);
          }
          if (!inside) continue;
          Contact contact;
          contact.normal = pa.R * n_l;
          contact.gap = height;
          contact.point = pa.R * (x - 0.5 * height * n_l) + pa.p;
          contact.feature_a = feature_id(FeatureKind::Face, 0, tri_id);
          contact.feature_b = feature_id(FeatureKind::Vertex, static_cast<std::uint32_t>(8 * cap + k), b.part);
          out.push_back(contact);
        }
      }
    }
  }
}

}  // namespace signorini::collision
