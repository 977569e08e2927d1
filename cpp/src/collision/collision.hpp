// Contact generation: broad phase (FCL dynamic AABB tree), narrow phase (own plane and sphere
// tests, FCL signed distance for the rest), in the contact order of docs/conventions.md.
// FCL types never appear in this header; they stay in cpp/src/collision/*.cpp.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "signorini/contact.hpp"
#include "signorini/shapes.hpp"
#include "signorini/world.hpp"

namespace signorini::collision {

/// Empty when the narrow phase can collide shapes a and b; otherwise why not ("unsupported pair
/// Mesh (non-convex) - Sphere: ..."). Two planes count as supported: both are static and never
/// collide.
std::string unsupported_pair(const Shape& a, const Shape& b);

/// Candidate pairs from bounding volumes. Holds one FCL object per non-plane body: dynamic ones in
/// a DynamicAABBTree updated incrementally each step, static ones in a second tree built once.
class BroadPhase {
 public:
  BroadPhase();
  ~BroadPhase();
  /// Registers body i (after the Model has it). Planes are not registered (they are unbounded and
  /// tested against every dynamic body directly).
  void add_body(BodyIndex i, const Shape& shape, bool is_static, const Vec3& p, const Mat3& R);
  /// Moves static body i (rare; rebuilds its tree entry).
  void move_static(BodyIndex i, const Vec3& p, const Mat3& R);
  /// Pairs (i, j), i < j, whose AABBs, grown by reach[i] + margin/2 and reach[j] + margin/2,
  /// overlap; at least one of them dynamic; planes excluded. Sorted lexicographically.
  std::vector<std::pair<BodyIndex, BodyIndex>> pairs(const Model& model, const State& state,
                                                     const std::vector<double>& reach, double margin);
  /// Signed distance between two registered bodies at their current proxy poses (FCL, GST_LIBCCD):
  /// fills gap, normal (A -> B), point (midpoint of witnesses). Returns false if FCL gave nothing.
  bool signed_distance(BodyIndex a, BodyIndex b, Contact& out) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Contacts of a static plane (body a, world pose p_a, R_a) against body b, for every feature with
/// gap < threshold, appended to out in feature order (sphere: 1; box: corners 0..7; mesh: vertices).
void plane_contacts(BodyIndex a, const Plane& plane, const Vec3& p_a, const Mat3& R_a, BodyIndex b,
                    const Shape& shape_b, const Vec3& p_b, const Mat3& R_b, double threshold,
                    std::vector<Contact>& out);

/// Exact sphere-sphere contact (A centre c_a radius r_a, B likewise). Written here rather than
/// through FCL because FCL's penetrating witness points carry ~1e-5 m of EPA error (measured).
Contact sphere_sphere(BodyIndex a, const Vec3& c_a, double r_a, BodyIndex b, const Vec3& c_b, double r_b);

/// Exact box-sphere contact: box (A or B) with pose (p_box, R_box) and half extents h, sphere with
/// centre c and radius r. The closest box point is the sphere centre clamped into the box; a centre
/// inside the box is pushed out through the nearest face (lowest axis on ties). `box_is_a` says
/// which body is A, so the normal points from A to B either way. Written here rather than through
/// FCL because FCL's box-sphere witness points carry ~1e-5 m of tangential error (measured), which
/// ruins the normal of a shallow contact.
Contact box_sphere(BodyIndex box, const Vec3& p_box, const Mat3& R_box, const Vec3& h, BodyIndex sphere,
                   const Vec3& c, double r, bool box_is_a);

/// Exact convex-mesh-sphere contact: mesh (A or B) with pose (p_mesh, R_mesh), sphere centre c and
/// radius r. Outside the mesh the closest point over its triangles; inside, out through the face
/// plane nearest the centre. `mesh_is_a` says which is A. Needs a convex, outward-oriented mesh.
Contact convex_sphere(BodyIndex mesh_body, const Vec3& p_mesh, const Mat3& R_mesh, const Mesh& mesh,
                      BodyIndex sphere, const Vec3& c, double r, bool mesh_is_a);

/// Speculative reach of every body for a step of dt: s_b = dt (|v| + dt |g| + |omega| rho) for a
/// dynamic body, 0 for a static one (m).
std::vector<double> speculative_reach(const Model& model, const State& state, double dt, const Vec3& gravity);

/// Speculative reach of body b towards a plane of world normal n: only the approach speed counts,
/// dt (max(0, -n . v) + dt max(0, -n . g) + |omega| rho) (m), so a body sliding along a plane does
/// not gather contacts it cannot reach.
double plane_reach(const Model& model, const State& state, BodyIndex b, const Vec3& n, double dt,
                   const Vec3& gravity);

/// All contacts for the current state, in the order of docs/conventions.md, written into out
/// (cleared first).
void detect_contacts(const Model& model, const State& state, double dt, const Vec3& gravity,
                     double margin, BroadPhase& broad_phase, std::vector<Contact>& out);

}  // namespace signorini::collision
