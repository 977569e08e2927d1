// The narrow phase: which shape pairs are supported, and the contact list for a state in the
// order of docs/conventions.md (pairs by index, features in order, a plane always A).
#include <algorithm>
#include <variant>

#include "collision/collision.hpp"

namespace signorini::collision {
namespace {

bool is_plane(const Shape& s) { return std::holds_alternative<Plane>(s); }

bool is_nonconvex_mesh(const Shape& s) {
  const auto* m = std::get_if<Mesh>(&s);
  return m && !m->is_convex();
}

}  // namespace

std::string unsupported_pair(const Shape& a, const Shape& b) {
  // the dispatch table:
  //            Plane   Sphere  Box     convex Mesh  non-convex Mesh
  // Plane      static  plane   plane   plane        plane
  // Sphere             exact   exact   exact        unsupported
  // Box                        FCL     FCL          unsupported
  // convex                             FCL          unsupported
  // non-convex                                      unsupported
  if (is_plane(a) || is_plane(b)) return {};
  if (is_nonconvex_mesh(a) || is_nonconvex_mesh(b)) {
    return "unsupported pair " + shape_name(a) + (is_nonconvex_mesh(a) ? " (non-convex)" : "") +
           " - " + shape_name(b) + (is_nonconvex_mesh(b) ? " (non-convex)" : "") +
           ": a non-convex mesh collides only with planes so far";
  }
  return {};
}

std::vector<double> speculative_reach(const Model& model, const State& state, double dt, const Vec3& gravity) {
  std::vector<double> reach(model.size(), 0.0);
  for (std::size_t i = 0; i < model.size(); ++i) {
    if (model.is_static[i]) continue;
    reach[i] = dt * (state.v[i].norm() + dt * gravity.norm() + state.omega[i].norm() * model.rho[i]);
  }
  return reach;
}

double plane_reach(const Model& model, const State& state, BodyIndex b, const Vec3& n, double dt,
                   const Vec3& gravity) {
  if (model.is_static[b]) return 0.0;
  return dt * (std::max(0.0, -n.dot(state.v[b])) + dt * std::max(0.0, -n.dot(gravity)) +
               state.omega[b].norm() * model.rho[b]);
}

void detect_contacts(const Model& model, const State& state, double dt, const Vec3& gravity,
                     double margin, BroadPhase& broad_phase, std::vector<Contact>& contacts) {
  const std::vector<double> reach = speculative_reach(model, state, dt, gravity);
  // candidate pairs: the broad phase's, plus every plane against every dynamic body
  std::vector<std::pair<BodyIndex, BodyIndex>> pairs = broad_phase.pairs(model, state, reach, margin);
  const BodyIndex n = static_cast<BodyIndex>(model.size());
  for (BodyIndex k = 0; k < n; ++k) {
    if (!is_plane(model.shape[k])) continue;
    for (BodyIndex b = 0; b < n; ++b)
      if (!model.is_static[b]) pairs.emplace_back(std::min(k, b), std::max(k, b));
  }
  std::sort(pairs.begin(), pairs.end());

  contacts.clear();
  for (const auto& [i, j] : pairs) {
    const Shape& si = model.shape[i];
    const Shape& sj = model.shape[j];
    if (is_plane(si) || is_plane(sj)) {
      // a plane is always A; the body's reach counts only towards the plane
      const BodyIndex a = is_plane(si) ? i : j;
      const BodyIndex b = is_plane(si) ? j : i;
      const Plane& plane = std::get<Plane>(model.shape[a]);
      const double threshold = margin + plane_reach(model, state, b, state.R[a] * plane.normal, dt, gravity);
      plane_contacts(a, plane, state.p[a], state.R[a], b, model.shape[b], state.p[b], state.R[b],
                     threshold, contacts);
      continue;
    }
    const double threshold = margin + reach[i] + reach[j];
    const auto* sphere_i = std::get_if<Sphere>(&si);
    const auto* sphere_j = std::get_if<Sphere>(&sj);
    const auto* box_i = std::get_if<Box>(&si);
    const auto* box_j = std::get_if<Box>(&sj);
    Contact c;
    if (sphere_i && sphere_j) {
      c = sphere_sphere(i, state.p[i], sphere_i->radius, j, state.p[j], sphere_j->radius);
    } else if (box_i && sphere_j) {
      c = box_sphere(i, state.p[i], state.R[i], box_i->half_extents, j, state.p[j], sphere_j->radius, true);
    } else if (sphere_i && box_j) {
      c = box_sphere(j, state.p[j], state.R[j], box_j->half_extents, i, state.p[i], sphere_i->radius, false);
    } else if (const auto* mesh_i = std::get_if<Mesh>(&si); mesh_i && sphere_j) {
      c = convex_sphere(i, state.p[i], state.R[i], *mesh_i, j, state.p[j], sphere_j->radius, true);
    } else if (const auto* mesh_j = std::get_if<Mesh>(&sj); sphere_i && mesh_j) {
      c = convex_sphere(j, state.p[j], state.R[j], *mesh_j, i, state.p[i], sphere_i->radius, false);
    } else if (!broad_phase.signed_distance(i, j, c)) {
      continue;
    }
    if (c.gap < threshold) contacts.push_back(c);
  }
}

}  // namespace signorini::collision
