// The narrow phase: the dispatch table over item kinds, the world-free collide(), and the contact
// list of a state in the order of docs/conventions.md (pairs by index, features in id order, a
// static-only shape always A).
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <variant>

#include "collision/collision.hpp"
#include "math/rotation.hpp"
#include "parallel/pool.hpp"
#include "parallel/prefetch.hpp"
#include "signorini/collide.hpp"

namespace signorini::collision {
namespace {

bool is_plane(const Shape& s) { return std::holds_alternative<Plane>(s); }


/// Normals reversed and ids swapped for the contacts from index `from` on (A and B exchanged).
void flip(std::vector<Contact>& out, std::size_t from) {
  for (std::size_t k = from; k < out.size(); ++k) {
    out[k].normal = -out[k].normal;
    std::swap(out[k].feature_a, out[k].feature_b);
  }
}

// ---- the dispatch table -------------------------------------------------------------------------
// One test per pair of item kinds, named contact_<a>_<b> (A's kind, then B's); the normal points
// from A to B. Every slot starts as contact_unsupported, which throws naming both kinds, and only
// the pairs listed in make_table() are filled in, so a kind added without its tests fails loudly
// instead of giving no contacts. The same table, with the tests' methods, is in docs/conventions.md
// ("Contact generation").
//              Sphere   Capsule        Cylinder   Polytope (box, hull, mesh piece)
// Sphere       exact    exact          exact      exact (closest point)
// Capsule      exact    exact          GJK/EPA    exact + separating axes
// Cylinder     exact    GJK/EPA        GJK/EPA    GJK/EPA + feature clipping
// Polytope     exact    exact + SAT    GJK/EPA    separating axes + face clipping
using ContactFn = void (*)(const Item&, const Item&, double, const PairContext&, Scratch&, std::vector<Contact>&);

void contact_unsupported(const Item& a, const Item& b, double, const PairContext&, Scratch&, std::vector<Contact>&) {
  throw std::logic_error(std::string("narrow phase: unsupported item pair ") + item_kind_name(a.kind) + " - " +
                         item_kind_name(b.kind) + " (no contact test in the dispatch table)");
}

/// Any item (A) against a sphere (B): the item's closest point (item_sphere).
void contact_item_sphere(const Item& a, const Item& b, double, const PairContext&, Scratch&,
                         std::vector<Contact>& out) {
  const std::size_t first = out.size();
  item_sphere(a, b.pose.p, b.sphere->radius, out);
  for (std::size_t k = first; k < out.size(); ++k) out[k].feature_b = feature_id(FeatureKind::Shape, 0, b.part);
}

/// Separating axes and face clipping, with the separating-face cache of a detection (pair):
/// a pair that a face proved apart last time is first tried along that face alone.
void contact_polytope_polytope(const Item& a, const Item& b, double threshold, const PairContext& pair,
                               Scratch& scratch, std::vector<Contact>& out) {
  const bool cached = pair.body_a >= 0 && pair.separating_last != nullptr && pair.separating_next != nullptr;
  SeparatingFace key;
  if (cached) {
    key.body_a = pair.body_a, key.body_b = pair.body_b, key.part_a = a.part, key.part_b = b.part;
    const std::vector<SeparatingFace>& last = *pair.separating_last;
    const auto it = std::lower_bound(last.begin(), last.end(), key);
    if (it != last.end() && !(key < *it)) {
      const Polytope& P = it->of_b ? *b.polytope : *a.polytope;
      if (it->face >= 0 && static_cast<std::size_t>(it->face) < P.normals.size()) {
        const double s = it->of_b ? face_separation(*b.polytope, b.pose, it->face, *a.polytope, a.pose)
                                  : face_separation(*a.polytope, a.pose, it->face, *b.polytope, b.pose);
        // rounding between this and the full test's value of the same face stays far below slack;
        // given the motion, the test runs to a nearer threshold (polytope_threshold)
        const double slack = 1e-9 * (a.ball_radius + b.ball_radius) + 1e-12 * (a.pose.p.norm() + b.pose.p.norm());
        const double reach = pair.motion ? polytope_threshold(*a.polytope, a.pose, *b.polytope, b.pose, a.box && b.box,
                                                              threshold, *pair.motion)
                                         : threshold;
        if (s >= reach + slack) {
          pair.separating_next->push_back(*it);
          return;
        }
      }
    }
  }
  polytope_polytope(*a.polytope, a.pose, a.part, *b.polytope, b.pose, b.part, threshold, *scratch.polytope, out,
                    a.box && b.box, cached ? &key : nullptr, pair.motion);
  if (cached && key.face >= 0) pair.separating_next->push_back(key);
}

void contact_capsule_capsule(const Item& a, const Item& b, double threshold, const PairContext&, Scratch&,
                             std::vector<Contact>& out) {
  capsule_capsule(*a.capsule, a.pose, a.part, *b.capsule, b.pose, b.part, threshold, out);
}

void contact_polytope_capsule(const Item& a, const Item& b, double threshold, const PairContext&, Scratch&,
                              std::vector<Contact>& out) {
  polytope_capsule(*a.polytope, a.pose, a.part, *b.capsule, b.pose, b.part, threshold, out);
}

/// Pairs with a cylinder and no closed form: GJK/EPA on the support mappings, then clipping.
void contact_by_support(const Item& a, const Item& b, double threshold, const PairContext&, Scratch& scratch,
                        std::vector<Contact>& out) {
  convex_by_support(a, b, threshold, scratch, out);
}

/// The test of (B, A) run with the items exchanged, its normals reversed and ids swapped.
template <ContactFn f>
void swapped(const Item& a, const Item& b, double threshold, const PairContext& pair, Scratch& scratch,
             std::vector<Contact>& out) {
  const std::size_t first = out.size();
  f(b, a, threshold, pair.swapped(), scratch, out);
  flip(out, first);
}

using Table = std::array<std::array<ContactFn, kItemKinds>, kItemKinds>;

Table make_table() {
  Table t;
  for (auto& row : t) row.fill(&contact_unsupported);
  auto set = [&t](ItemKind a, ItemKind b, ContactFn f) { t[static_cast<int>(a)][static_cast<int>(b)] = f; };
  using K = ItemKind;
  for (K a : {K::Sphere, K::Capsule, K::Cylinder, K::Polytope}) set(a, K::Sphere, &contact_item_sphere);
  set(K::Sphere, K::Capsule, &swapped<contact_item_sphere>);
  set(K::Sphere, K::Cylinder, &swapped<contact_item_sphere>);
  set(K::Sphere, K::Polytope, &swapped<contact_item_sphere>);
  set(K::Capsule, K::Capsule, &contact_capsule_capsule);
  set(K::Polytope, K::Capsule, &contact_polytope_capsule);
  set(K::Capsule, K::Polytope, &swapped<contact_polytope_capsule>);
  set(K::Polytope, K::Polytope, &contact_polytope_polytope);
  set(K::Cylinder, K::Capsule, &contact_by_support);
  set(K::Capsule, K::Cylinder, &contact_by_support);
  set(K::Cylinder, K::Cylinder, &contact_by_support);
  set(K::Cylinder, K::Polytope, &contact_by_support);
  set(K::Polytope, K::Cylinder, &contact_by_support);
  return t;
}

const Table kTable = make_table();

}  // namespace

namespace {

/// Sets the item's bounding ball: about the centroid for a polytope (O(vertices), cheap beside the
/// separating axes it can save), about the origin for the round shapes.
void set_ball(Item& it) {
  if (it.box) {
    // centroid 0 and every vertex at |h|: the same ball as the loop below gives
    it.ball_centre = it.pose.p;
    it.ball_radius = it.box->half_extents.norm();
  } else if (it.polytope) {
    const Polytope& P = *it.polytope;
    double r2 = 0.0;
    for (Eigen::Index i = 0; i < P.vertices.rows(); ++i)
      r2 = std::max(r2, (P.vertex(static_cast<int>(i)) - P.centroid).squaredNorm());
    it.ball_centre = it.pose.R * P.centroid + it.pose.p;
    it.ball_radius = std::sqrt(r2);
  } else {
    it.ball_centre = it.pose.p;
    it.ball_radius = it.radius();
  }
}

void add_primitive(const Primitive& p, const Pose& pose, std::uint32_t part, std::vector<Item>& items) {
  Item it;
  it.pose = pose;
  it.part = part;
  std::visit(
      [&](const auto& s) {
        using T = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<T, Sphere>) it.kind = ItemKind::Sphere, it.sphere = &s;
        if constexpr (std::is_same_v<T, Capsule>) it.kind = ItemKind::Capsule, it.capsule = &s;
        if constexpr (std::is_same_v<T, Cylinder>) it.kind = ItemKind::Cylinder, it.cylinder = &s;
        if constexpr (std::is_same_v<T, Box>) it.kind = ItemKind::Polytope, it.box = &s, it.polytope = s.polytope.get();
        if constexpr (std::is_same_v<T, ConvexHull>)
          it.kind = ItemKind::Polytope, it.hull = &s, it.polytope = s.polytope.get();
      },
      p);
  set_ball(it);
  items.push_back(it);
}

}  // namespace

Scratch::Scratch() : polytope(new_polytope_scratch()), epa(new_epa_scratch()) {}

void grow_workers(Scratch& s, std::size_t threads) {
  while (s.workers.size() < threads) s.workers.push_back(std::make_unique<Scratch>());
}

Scratch& worker_scratch(Scratch& s, std::size_t threads) {
  return *s.workers[static_cast<std::size_t>(parallel::Pool::thread_index()) % threads];
}

const char* item_kind_name(ItemKind kind) {
  switch (kind) {
    case ItemKind::Sphere: return "Sphere";
    case ItemKind::Capsule: return "Capsule";
    case ItemKind::Cylinder: return "Cylinder";
    case ItemKind::Polytope: return "Polytope";
    case ItemKind::Unset: break;
  }
  return "unknown item kind";
}

void contact_items(const Item& a, const Item& b, double threshold, Scratch& scratch, std::vector<Contact>& out,
                   const PairContext& pair) {
  const int i = static_cast<int>(a.kind), j = static_cast<int>(b.kind);
  if (i < 0 || i >= kItemKinds || j < 0 || j >= kItemKinds) contact_unsupported(a, b, threshold, pair, scratch, out);
  kTable[i][j](a, b, threshold, pair, scratch, out);
}

double Item::radius() const {
  if (sphere) return sphere->radius;
  if (capsule) return capsule->radius + capsule->half_length;
  if (cylinder) return std::hypot(cylinder->radius, cylinder->half_height);
  return polytope->vertices.rowwise().norm().maxCoeff();
}

void items_of(const Shape& shape, const Pose& pose, std::vector<Item>& items,
              std::vector<std::shared_ptr<const Polytope>>& keep) {
  if (const auto* c = std::get_if<Compound>(&shape)) {
    for (std::size_t k = 0; k < c->parts.size(); ++k) {
      const auto& part = c->parts[k];
      add_primitive(part.shape, {pose.R * part.position + pose.p, pose.R * part.rotation},
                    static_cast<std::uint32_t>(k), items);
    }
  } else if (const auto* m = std::get_if<Mesh>(&shape)) {
    if (m->pieces.empty()) {
      // a convex mesh that the world has not prepared (collide() on user shapes): built here
      keep.push_back(std::make_shared<const Polytope>(polytope_from_triangles(m->vertices, m->faces)));
      Item it;
      it.kind = ItemKind::Polytope;
      it.polytope = keep.back().get();
      it.pose = pose;
      set_ball(it);
      items.push_back(it);
    } else {
      for (std::size_t k = 0; k < m->pieces.size(); ++k) {
        Item it;
        it.kind = ItemKind::Polytope;
        it.polytope = m->pieces[k].get();
        it.pose = pose;
        it.part = static_cast<std::uint32_t>(k);
        set_ball(it);
        items.push_back(it);
      }
    }
  } else {
    std::visit(
        [&](const auto& s) {
          using T = std::decay_t<decltype(s)>;
          Item it;
          it.pose = pose;
          if constexpr (std::is_same_v<T, Sphere>) it.kind = ItemKind::Sphere, it.sphere = &s;
          if constexpr (std::is_same_v<T, Capsule>) it.kind = ItemKind::Capsule, it.capsule = &s;
          if constexpr (std::is_same_v<T, Cylinder>) it.kind = ItemKind::Cylinder, it.cylinder = &s;
          if constexpr (std::is_same_v<T, Box>) it.kind = ItemKind::Polytope, it.box = &s, it.polytope = s.polytope.get();
          if constexpr (std::is_same_v<T, ConvexHull>)
            it.kind = ItemKind::Polytope, it.hull = &s, it.polytope = s.polytope.get();
          // planes and triangle meshes are static-only: collide() handles them before items
          if (!(it.sphere || it.capsule || it.cylinder || it.polytope))
            throw std::logic_error("items_of: a " + shape_name(shape) + " has no convex items");
          set_ball(it);
          items.push_back(it);
        },
        shape);
  }
}

bool is_bare_nonconvex_mesh(const Shape& s) {
  const auto* m = std::get_if<Mesh>(&s);
  return m && m->pieces.empty() && (!m->is_convex() || !m->closedness_problem().empty());
}

std::string unsupported_pair(const Shape& a, const Shape& b) {
  // the dispatch table (docs/conventions.md):
  //              Plane   TriMesh  Sphere  Capsule  Box/Hull/piece  Cylinder
  // Plane        static  static   exact   exact    exact           exact
  // TriMesh              static   exact   exact    SAT/triangle    GJK/EPA + clip
  // Sphere                        exact   exact    exact           exact
  // Capsule                               exact    exact + SAT     GJK/EPA + clip
  // Box/Hull/piece                                 SAT + clip      GJK/EPA + clip
  // Cylinder                                                       GJK/EPA + clip
  // A non-convex Mesh without pieces collides with planes only. Compounds: part by part.
  if (is_plane(a) || is_plane(b)) return {};
  if (static_only(a) && static_only(b)) return {};
  auto label = [](const Shape& s) {
    return shape_name(s) + (is_bare_nonconvex_mesh(s) ? " (non-convex or open)" : "");
  };
  if (is_bare_nonconvex_mesh(a) || is_bare_nonconvex_mesh(b))
    return "unsupported pair " + label(a) + " - " + label(b) +
           ": such a mesh collides only with planes unless it is decomposed into convex pieces "
           "(signorini does this with CoACD when a closed one is added as a dynamic body); "
           "use a TriangleMesh for static scenery";
  return {};
}

namespace {

/// Drops the candidates the pair cannot close in this step (none without a motion).
void keep_closable(const PairMotion* motion, std::vector<Contact>& candidates) {
  if (!motion) return;
  const PairMotion& m = *motion;
  candidates.erase(std::remove_if(candidates.begin(), candidates.end(), [&](const Contact& c) { return !m.can_close(c); }),
                   candidates.end());
}

}  // namespace

void collide(const Shape& a, const Pose& pose_a, const Shape& b, const Pose& pose_b, double threshold,
             const Services& services, std::vector<Contact>& out, const PairContext& pair) {
  const std::string problem = unsupported_pair(a, b);
  if (!problem.empty()) throw std::invalid_argument(problem);
  if (static_only(a) && static_only(b)) return;
  if (static_only(b)) {
    // the static-only shape is always A inside; the caller's A and B are restored after
    const std::size_t first = out.size();
    std::optional<PairMotion> seen_from_b;
    PairContext swapped = pair.swapped();
    if (pair.motion) swapped.motion = &seen_from_b.emplace(pair.motion->swapped());
    collide(b, pose_b, a, pose_a, threshold, {services.triangles_b, services.triangles_a, services.scratch}, out,
            swapped);
    flip(out, first);
    return;
  }
  std::unique_ptr<Scratch> own_scratch;
  if (!services.scratch) own_scratch = std::make_unique<Scratch>();
  Scratch& s = services.scratch ? *services.scratch : *own_scratch;
  std::vector<Contact>& candidates = s.candidates;
  std::vector<Item>& items_a = s.items_a;
  std::vector<Item>& items_b = s.items_b;
  std::vector<std::shared_ptr<const Polytope>> keep;  // a convex Mesh the world has not prepared
  candidates.clear();
  if (const auto* plane = std::get_if<Plane>(&a)) {
    plane_contacts(*plane, pose_a, b, pose_b, threshold, s, candidates);
    keep_closable(pair.motion, candidates);
    finish_manifold(candidates, threshold, pair.scale > 0.0 ? pair.scale : pair_scale(a, b), out, s.candidate_index,
                    pair.motion);
    return;
  }
  items_b.clear();
  items_of(b, pose_b, items_b, keep);
  if (const auto* mesh = std::get_if<TriangleMesh>(&a)) {
    std::unique_ptr<TriangleQuery> own;
    const TriangleQuery* query = services.triangles_a;
    if (!query) {
      own = std::make_unique<TriangleQuery>(*mesh);
      query = own.get();
    }
    TrianglePast nothing_known;
    TrianglePast& past = pair.past ? *pair.past : nothing_known;
    for (const Item& ib : items_b) trimesh_item(*mesh, pose_a, *query, ib, threshold, past, s, candidates);
  } else {
    items_a.clear();
    items_of(a, pose_a, items_a, keep);
    // the mid phase: item pairs whose bounding balls are farther apart than the threshold are
    // skipped (they give no contact); compounds and decomposed meshes have many such pairs
    const double reach = std::max(threshold, 0.0);
    for (const Item& ia : items_a)
      for (const Item& ib : items_b)
        if ((ib.ball_centre - ia.ball_centre).norm() <= ia.ball_radius + ib.ball_radius + reach)
          contact_items(ia, ib, threshold, s, candidates, pair);
  }
  keep_closable(pair.motion, candidates);
  // ranked by gap: the end-gap ranking is the plane's only (docs/conventions.md, "Manifolds")
  finish_manifold(candidates, threshold, pair.scale > 0.0 ? pair.scale : pair_scale(a, b), out, s.candidate_index);
}

void speculative_reach(const Model& model, const State& state, double dt, const Vec3& gravity,
                       std::vector<double>& reach, const std::vector<BodyIndex>* bodies) {
  if (bodies == nullptr) reach.assign(model.size(), 0.0);
  parallel::fit(reach, model.size(), 0.0);
  parallel::each_body(bodies, model.size(), [&](std::size_t i) {
    reach[i] = body_reach(model, state, static_cast<BodyIndex>(i), dt, gravity);
  });
}

double body_reach(const Model& model, const State& state, BodyIndex i, double dt, const Vec3& gravity) {
  // a static or sleeping body does not move
  return model.is_static[i] || state.asleep(i)
             ? 0.0
             : dt * (state.v[i].norm() + dt * gravity.norm() + turn_speed(state.omega[i].norm(), model.rho[i], dt));
}

PairMotion::PairMotion(const Model& model, const State& state, BodyIndex a, BodyIndex b, double dt_,
                       const Vec3& gravity, double margin_)
    : p_a(state.p[a]), v_a(state.v[a]), omega_a(state.omega[a]), p_b(state.p[b]), v_b(state.v[b]),
      omega_b(state.omega[b]), dt(dt_), margin(margin_), inner(std::min(model.inner[a], model.inner[b])) {
  auto moved_by_gravity = [&](BodyIndex i) { return !model.is_static[i] && !model.is_kinematic[i]; };
  auto turn = [&](BodyIndex i) { return model.is_static[i] ? 0.0 : state.omega[i].squaredNorm() * model.rho[i]; };
  g_a = moved_by_gravity(a) ? gravity : Vec3::Zero();
  g_b = moved_by_gravity(b) ? gravity : Vec3::Zero();
  g_rel = g_b - g_a;
  stoppable_a = moved_by_gravity(a);
  stoppable_b = moved_by_gravity(b);
  turning = 0.5 * (turn(a) + turn(b));
}

PairMotion PairMotion::swapped() const {
  PairMotion m = *this;
  std::swap(m.p_a, m.p_b);
  std::swap(m.v_a, m.v_b);
  std::swap(m.omega_a, m.omega_b);
  m.g_rel = -g_rel;
  std::swap(m.g_a, m.g_b);
  std::swap(m.stoppable_a, m.stoppable_b);
  return m;
}

Vec3 PairMotion::relative_velocity(const Vec3& y) const {
  return (v_b + omega_b.cross(y - p_b)) - (v_a + omega_a.cross(y - p_a));
}

bool PairMotion::can_close(const Contact& c) const {
  if (c.gap < margin) return true;
  const Vec3& n = c.normal;
  const Vec3& y = c.point;
  // the approach at their velocities, or at one body's own with the other stopped: a body's
  // velocity is not known to hold for the step, since a third body can stop it
  double closing = std::max(0.0, -n.dot(relative_velocity(y))) + dt * std::max(0.0, -n.dot(g_rel));
  if (stoppable_a)
    closing = std::max(closing, std::max(0.0, -n.dot(v_b + omega_b.cross(y - p_b))) + dt * std::max(0.0, -n.dot(g_b)));
  if (stoppable_b)
    closing = std::max(closing, std::max(0.0, n.dot(v_a + omega_a.cross(y - p_a))) + dt * std::max(0.0, n.dot(g_a)));
  return c.gap < margin + dt * (closing + dt * turning);
}

namespace {

/// The largest m . w over unit m in the cone m . k >= c (k unit, 0 <= c <= 1): |w| when w lies in
/// it, else on its rim, c (w . k) + sqrt(1 - c^2) |w - (w . k) k|.
double cone_max(const Vec3& w, const Vec3& k, double c) {
  const double along = w.dot(k), length = w.norm();
  if (along >= c * length) return length;
  return c * along + std::sqrt(std::max(0.0, 1.0 - c * c)) * (w - along * k).norm();
}

/// can_close's closing speed bounded over its points (within r_a, r_b of the centres) and normals:
/// largest(w) bounds n . w over the normals considered (m/s).
template <class Largest>
double closing_bound(const PairMotion& m, double r_a, double r_b, Largest&& largest) {
  const double turn_a = m.omega_a.norm() * r_a, turn_b = m.omega_b.norm() * r_b;
  const auto toward = [&](const Vec3& v, const Vec3& g) {
    return std::max(0.0, largest(v)) + m.dt * std::max(0.0, largest(g));
  };
  double u = toward(m.v_a - m.v_b, -m.g_rel) + turn_a + turn_b;
  if (m.stoppable_a) u = std::max(u, toward(-m.v_b, -m.g_b) + turn_b);
  if (m.stoppable_b) u = std::max(u, toward(m.v_a, m.g_a) + turn_a);
  return u;
}

}  // namespace

double PairMotion::closable_gap(double r_a, double r_b) const {
  const double u = closing_bound(*this, r_a, r_b, [](const Vec3& w) { return w.norm(); });
  return margin + dt * (u + dt * turning);
}

double PairMotion::closable_gap(double r_a, double r_b, const Vec3& k, double c) const {
  const double u = closing_bound(*this, r_a, r_b, [&](const Vec3& w) { return cone_max(w, k, c); });
  return margin + dt * (u + dt * turning);
}

double PairMotion::end_gap(const Contact& c) const {
  return c.gap + dt * c.normal.dot(relative_velocity(c.point) + dt * g_rel);
}

double plane_reach(const Model& model, const State& state, BodyIndex b, const Vec3& n, double dt,
                   const Vec3& gravity) {
  if (model.is_static[b]) return 0.0;
  return dt * (std::max(0.0, -n.dot(state.v[b])) + dt * std::max(0.0, -n.dot(gravity)) +
               turn_speed(state.omega[b].norm(), model.rho[b], dt));
}

void carry_contacts(const Model& model, const std::vector<Contact>& at_detection, const State& detected,
                    const State& now, std::vector<Contact>& out, std::vector<Vec3>& anchor_a,
                    std::vector<Vec3>& anchor_b, const std::vector<Vec3>* from_a, const std::vector<Vec3>* from_b,
                    const parallel::Pool* pool) {
  if (out.capacity() < at_detection.size()) out.reserve(2 * at_detection.size());  // grown geometrically
  out.resize(at_detection.size());  // (each entry copied below, by the thread that carries it)
  anchor_a.resize(out.size());
  anchor_b.resize(out.size());
  // the first-order motion of the point x of body i since detection: dp + dtheta x (x - p_0)
  auto moved = [&](int i, const Vec3& x) -> Vec3 {
    const Mat3 turn = now.R[i] * detected.R[i].transpose();
    const Vec3 dtheta(0.5 * (turn(2, 1) - turn(1, 2)), 0.5 * (turn(0, 2) - turn(2, 0)), 0.5 * (turn(1, 0) - turn(0, 1)));
    return (now.p[i] - detected.p[i]) + dtheta.cross(x - detected.p[i]);
  };
  // how far the point x of body i has moved since detection with the body's whole turn:
  // dp + (R R_0^T - I) (x - p_0)
  auto turned = [&](int i, const Vec3& x) -> Vec3 {
    const Vec3 r = x - detected.p[i];
    return (now.p[i] - detected.p[i]) + (now.R[i] * (detected.R[i].transpose() * r) - r);
  };
  // each contact carried on its own (it writes only its own entries): over the pool's threads
  parallel::for_ranges(pool, out.size(), 1024, [&](std::size_t first, std::size_t end) {
    for (std::size_t k = first; k < end; ++k) {
      Contact& c = out[k];
      c = at_detection[k];
      const Vec3 half = 0.5 * c.gap * c.normal;
      const int a = c.body_a, b = c.body_b;
      // a round side carries its core, rho beyond its witness, with the whole turn (the witness stays
      // under the core however the body turns); any other side its witness point, to first order
      const double rho_a = rounding_radius(model.shape[static_cast<std::size_t>(a)], feature_part(c.feature_a));
      const double rho_b = rounding_radius(model.shape[static_cast<std::size_t>(b)], feature_part(c.feature_b));
      // each side's witness from where its force acts, given its anchor (a contact carried before:
      // its point, the anchors' midpoint, lags a fast body by half its travel, and a spinning round
      // side's core taken from it would swing with the turn)
      const Vec3 y_a = from_a ? (*from_a)[k] : c.point, y_b = from_b ? (*from_b)[k] : c.point;
      const Vec3 moved_b = rho_b > 0.0 ? turned(b, y_b + half + rho_b * c.normal) : moved(b, y_b + half);
      const Vec3 moved_a = rho_a > 0.0 ? turned(a, y_a - half - rho_a * c.normal) : moved(a, y_a - half);
      const double gap0 = c.gap;
      c.gap += c.normal.dot(moved_b - moved_a);
      // a round side's anchor half the new gap beyond its witness, as a contact point is: the next
      // carry and the soft step's rows take its core from its anchor and the gap (kept half the old
      // gap beyond, a spinning ball's core, off its centre by half what the gap had closed, swung
      // with its turn and read the ball as never closing: fuzz 1:729's 6.7 mm ball went through a box
      // at 30 m/s with the soft step). A flat side's witness is carried to first order, which a shift
      // along n does not change; its anchor stays its rows' lever arm.
      const Vec3 shift = 0.5 * (c.gap - gap0) * c.normal;
      const Vec3 shift_a = rho_a > 0.0 ? shift : Vec3(Vec3::Zero()), shift_b = rho_b > 0.0 ? shift : Vec3(Vec3::Zero());
      anchor_a[k] = y_a + (now.p[a] - detected.p[a]) + shift_a;
      anchor_b[k] = y_b + (now.p[b] - detected.p[b]) - shift_b;
      c.point = 0.5 * (anchor_a[k] + anchor_b[k]);
      if (c.kept) {  // its rows keep the lever arms of the detection that found its manifold
        anchor_a[k] = now.p[a] + c.arm_a + shift_a;
        anchor_b[k] = now.p[b] + c.arm_b - shift_b;
      }
    }
  });
}

/// Pairs per chunk of a detection split over threads (about the cost of a task's scheduling).
constexpr std::size_t kPairsPerChunk = 64;

PairContext PairContext::swapped() const {
  PairContext c = *this;
  std::swap(c.body_a, c.body_b);
  return c;
}

bool recycles(const Shape& a, const Shape& b) {
  const auto recyclable = [](const Shape& s) { return !static_only(s) && !std::holds_alternative<Sphere>(s); };
  return recyclable(a) && recyclable(b);
}

namespace {

/// Contacts ahead of the one being written whose slot a pair writing recycled contacts asks for.
constexpr std::size_t kWriteAhead = 8;

/// Asks the memory for the cache lines of a contact's slot, to be written: the step's list is
/// written over slot by slot, and each recycled contact's write (four cache lines) waited on its
/// lines (two thirds of generate_contacts' own time on the 5,050-cube pyramid). Always inlined
/// (parallel/prefetch.hpp).
[[gnu::always_inline]] inline void ask_to_write(const Contact* slot) {
  parallel::prefetch_write(slot, sizeof(Contact));
}

/// Pair (a, b)'s manifold of the last detection (memory.last, sorted), or null. hint: where the
/// caller's last search ended (0 at first), updated: the pairs come in nearly sorted order (by body
/// indices, a static-only shape put first), so the search walks on from there a few entries before
/// it falls back to a binary search; the same entry as std::lower_bound, without its 14 scattered
/// reads per pair on a 15,000-pair pile.
const KeptManifold* kept_manifold(const ManifoldCache& memory, BodyIndex a, BodyIndex b, std::size_t& hint) {
  constexpr std::size_t kWalk = 8;
  KeptManifold key;
  key.body_a = a;
  key.body_b = b;
  const std::vector<KeptManifold>& last = memory.last;
  const std::size_t n = last.size();
  std::size_t j = std::min(hint, n);
  if (j > 0 && !(last[j - 1] < key)) {  // at or before the hint: searched for below it
    j = static_cast<std::size_t>(std::lower_bound(last.begin(), last.begin() + static_cast<std::ptrdiff_t>(j), key) - last.begin());
  } else {  // after it: last[j - 1] < key
    for (std::size_t steps = 0; j < n && last[j] < key && steps < kWalk; ++steps) ++j;
    if (j < n && last[j] < key)
      j = static_cast<std::size_t>(std::lower_bound(last.begin() + static_cast<std::ptrdiff_t>(j), last.end(), key) - last.begin());
  }
  hint = j;
  return j < n && last[j].body_a == a && last[j].body_b == b ? &last[j] : nullptr;
}

/// How far the kept rows may be from the bodies now (m), at most, counting the step of dt at the
/// current velocities. The rows keep the detection's world lever arms, so every motion counts, not
/// only B's relative to A: B's centre relative to A's, |d - d_0| with d = p_B - p_A, and each
/// body's turn, ||R_X - R_X0||_F rho_X (how far it has moved any point of X about its centre; the
/// Frobenius norm bounds the spectral one); and in the coming step |v_B - v_A| + |omega_A| rho_A +
/// |omega_B| rho_B. A pair turning together (a stack carried round) is found anew.
double pair_drift(const Model& model, const State& state, BodyIndex a, BodyIndex b, const KeptManifold& kept, double dt) {
  const Vec3 d = state.p[b] - state.p[a];
  const double rho_a = model.rho[a], rho_b = model.rho[b];
  const double moved = (d - kept.d0).norm() + (state.R[a] - kept.R_a0).norm() * rho_a + (state.R[b] - kept.R_b0).norm() * rho_b;
  const double speed = (state.v[b] - state.v[a]).norm() + state.omega[a].norm() * rho_a + state.omega[b].norm() * rho_b;
  return moved + dt * speed;
}

/// A kept manifold's point q as a contact of the bodies now: each witness point carried with its
/// body, the normal with A, gap = n . (w_B - w_A), y the witness points' midpoint, and the rows'
/// lever arms as found (kept).
Contact recycled_contact(const State& state, BodyIndex a, BodyIndex b, const KeptPoint& q) {
  Contact c;
  c.body_a = a;
  c.body_b = b;
  const Vec3 w_a = state.R[a] * q.on_a + state.p[a];
  const Vec3 w_b = state.R[b] * q.on_b + state.p[b];
  c.normal = state.R[a] * q.normal;
  c.gap = c.normal.dot(w_b - w_a);
  // the point half the gap from a vertex's witness along the normal: a vertex is a point of its
  // body and its gap to the other's face is exact however far the pair has slid, while the face's
  // material witness has slid with it, so the midpoint of the two would leave both surfaces by
  // half the slide (docs/conventions.md, "Contact recycling"); otherwise that midpoint
  if (feature_kind(q.feature_b) == FeatureKind::Vertex) c.point = w_b - 0.5 * c.gap * c.normal;
  else if (feature_kind(q.feature_a) == FeatureKind::Vertex) c.point = w_a + 0.5 * c.gap * c.normal;
  else c.point = 0.5 * (w_a + w_b);
  c.feature_a = q.feature_a;
  c.feature_b = q.feature_b;
  c.kept = true;
  c.arm_a = q.arm_a;
  c.arm_b = q.arm_b;
  return c;
}

/// Keeps the manifold out[first, end) just found for pair (a, b): appended to kept and points.
void keep_manifold(const State& state, BodyIndex a, BodyIndex b, const std::vector<Contact>& out, std::size_t first,
                   std::vector<KeptManifold>& kept, std::vector<KeptPoint>& points) {
  const Mat3& R_a = state.R[a];
  const Mat3& R_b = state.R[b];
  KeptManifold m;
  m.body_a = a;
  m.body_b = b;
  m.d0 = state.p[b] - state.p[a];
  m.R_a0 = R_a;
  m.R_b0 = R_b;
  m.first = static_cast<std::uint32_t>(points.size());
  m.count = static_cast<std::uint32_t>(out.size() - first);
  for (std::size_t k = first; k < out.size(); ++k) {
    const Contact& c = out[k];
    const Vec3 half = 0.5 * c.gap * c.normal;
    KeptPoint q;
    q.on_a = R_a.transpose() * (c.point - half - state.p[a]);
    q.on_b = R_b.transpose() * (c.point + half - state.p[b]);
    q.normal = R_a.transpose() * c.normal;
    q.arm_a = c.arm_a;
    q.arm_b = c.arm_b;
    q.feature_a = c.feature_a;
    q.feature_b = c.feature_b;
    points.push_back(q);
  }
  kept.push_back(m);
}

/// Candidate pair (i, j) as collide() takes it: a static-only shape (plane, triangle mesh) is A.
std::pair<BodyIndex, BodyIndex> collided_order(const Model& model, BodyIndex i, BodyIndex j) {
  const bool swap = static_only(model.shape[j]) && !static_only(model.shape[i]);
  return swap ? std::make_pair(j, i) : std::make_pair(i, j);
}

/// Pair (a, b), in collided order, collided at `state`: its contacts appended to out, with their
/// bodies and lever arms (y - p_X). threshold: margin + reach_a + reach_b (m), or, against a
/// plane, margin + plane_reach. A triangle mesh A gets B's past from memory (past: its crossing
/// found); separating: the separating-face cache (last, next), or nulls for none.
void collide_pair(const Model& model, const State& state, BodyIndex a, BodyIndex b, double reach_a, double reach_b,
                  double dt, const Vec3& gravity, double margin, const BroadPhase& broad_phase,
                  const ContactMemory& memory, Scratch& buffers, std::vector<Contact>& out, TrianglePast& past,
                  const std::vector<SeparatingFace>* separating_last, std::vector<SeparatingFace>* separating_next) {
  double threshold = margin + reach_a + reach_b;
  if (const auto* plane = std::get_if<Plane>(&model.shape[a]))
    threshold = margin + plane_reach(model, state, b, state.R[a] * plane->normal, dt, gravity);
  const std::size_t first = out.size();
  // a triangle mesh remembers which side of it the body belongs on (trimesh_item)
  if (std::holds_alternative<TriangleMesh>(model.shape[a])) {
    if (memory.previous_p.size() == model.size()) {
      past.travel = state.p[b] - memory.previous_p[b];
      if (memory.crossing[b].mesh == a) past.remembered = memory.crossing[b].triangle;
    }
    past.body_centre = state.p[b];
    past.body_radius = model.rho[b];
  }
  const PairMotion motion(model, state, a, b, dt, gravity, margin);
  PairContext context{a, b, &motion, &past};
  context.scale = pair_scale(model.shape[a], model.rho[a], model.shape[b], model.rho[b]);
  context.separating_last = separating_last;
  context.separating_next = separating_next;
  collide(model.shape[a], {state.p[a], state.R[a]}, model.shape[b], {state.p[b], state.R[b]}, threshold,
          {broad_phase.triangles(a), broad_phase.triangles(b), &buffers}, out, context);
  for (std::size_t k = first; k < out.size(); ++k) {
    out[k].body_a = a;
    out[k].body_b = b;
    out[k].arm_a = out[k].point - state.p[a];
    out[k].arm_b = out[k].point - state.p[b];
  }
}

}  // namespace

void generate_contacts(const Model& model, const State& state, double dt, const Vec3& gravity, double margin,
                       BroadPhase& broad_phase, ContactMemory& memory, Scratch& scratch, std::vector<Contact>& contacts,
                       const parallel::Pool* pool, const std::vector<BodyIndex>* bodies, double recycle) {
  // crossings are found for bodies that move only: the others' entries stay empty
  if (bodies == nullptr) memory.crossing_next.assign(model.size(), Crossing());
  parallel::fit(memory.crossing_next, model.size(), Crossing());
  parallel::each_body(bodies, model.size(), [&](std::size_t i) { memory.crossing_next[i] = Crossing(); });
  std::vector<double>& reach = scratch.reach;
  speculative_reach(model, state, dt, gravity, reach, bodies);
  // candidate pairs: the broad phase's, plus every plane against every dynamic body
  std::vector<std::pair<BodyIndex, BodyIndex>>& pairs = scratch.pairs;
  broad_phase.pairs(model, state, reach, margin, pairs, pool);
  for (const BodyIndex k : broad_phase.planes()) {
    parallel::each_body(bodies, model.size(), [&](std::size_t i) {
      const auto b = static_cast<BodyIndex>(i);
      if (!model.is_static[b] && !state.asleep(b)) pairs.emplace_back(std::min(k, b), std::max(k, b));
    });
  }
  // (the broad phase's are sorted: without planes, as in most large scenes, nothing to do)
  if (!std::is_sorted(pairs.begin(), pairs.end())) std::sort(pairs.begin(), pairs.end());
  // collision filtering: disabled bodies, filter bits, excluded pairs, two infinite masses
  // and pairs where nothing moves: a sleeping body against a sleeping, static or still kinematic one
  const auto still = [&](BodyIndex k) {
    return state.asleep(k) || (model.is_kinematic[k] && state.v[k].squaredNorm() == 0.0 && state.omega[k].squaredNorm() == 0.0);
  };
  const auto resting = [&](BodyIndex i, BodyIndex j) { return (state.asleep(i) && still(j)) || (state.asleep(j) && still(i)); };
  pairs.erase(std::remove_if(pairs.begin(), pairs.end(),
                             [&](const auto& p) { return !model.can_collide(p.first, p.second) || resting(p.first, p.second); }),
              pairs.end());

  const bool chunked = pool != nullptr && pool->threads() > 1 && pairs.size() > kPairsPerChunk;
  if (!chunked) contacts.clear();  // chunked: resized to the joined length below
  memory.separating.next.clear();
  ManifoldCache& manifolds = memory.manifolds;
  manifolds.next.clear();
  if (!chunked) manifolds.next_points.clear();
  // a candidate pair (i, j) as collide() takes it: a static-only shape (plane, triangle mesh) is A
  const auto ordered = [&](BodyIndex i, BodyIndex j) { return collided_order(model, i, j); };
  // whether pair (a, b) keeps its manifolds from step to step (docs/conventions.md, "Contact recycling")
  const auto keeps = [&](BodyIndex a, BodyIndex b) { return recycle > 0.0 && recycles(model.shape[a], model.shape[b]); };
  // the last detection's manifold of (a, b) when the pair keeps it this step (it has hardly moved
  // since), else null
  const auto kept_for = [&](BodyIndex a, BodyIndex b, std::size_t& hint) -> const KeptManifold* {
    if (!keeps(a, b)) return nullptr;
    const KeptManifold* last = kept_manifold(manifolds, a, b, hint);
    const double tolerance = std::min(recycle, kRecycleInnerFraction * std::min(model.inner[a], model.inner[b]));
    return last && pair_drift(model, state, a, b, *last, dt) <= tolerance ? last : nullptr;
  };
  // candidate pair (i, j) found anew: its contacts appended to out, its separating faces to
  // separating, its crossing (a body pushed back through a mesh triangle) to crossings, its
  // manifold (when it may be kept) to kept
  const auto collide_anew = [&](BodyIndex i, BodyIndex j, Scratch& buffers, std::vector<Contact>& out,
                                std::vector<SeparatingFace>& separating, auto&& crossed, std::vector<KeptManifold>& kept,
                                std::vector<KeptPoint>& kept_points) {
    const auto [a, b] = ordered(i, j);
    const std::size_t first = out.size();
    TrianglePast past;
    collide_pair(model, state, a, b, reach[a], reach[b], dt, gravity, margin, broad_phase, memory, buffers, out, past,
                 &memory.separating.last, &separating);
    if (past.found >= 0) crossed(b, Crossing{a, past.found});
    if (keeps(a, b) && out.size() > first) keep_manifold(state, a, b, out, first, kept, kept_points);
  };
  const std::size_t P = pairs.size();
  int recycled = 0;
  if (!chunked) {
    std::size_t hint = 0;  // where the last search of the memory ended
    for (const auto& [i, j] : pairs) {
      const auto [a, b] = ordered(i, j);
      if (const KeptManifold* last = kept_for(a, b, hint)) {
        for (std::uint32_t k = last->first; k < last->first + last->count; ++k) {
          if (contacts.size() + kWriteAhead < contacts.capacity())
            ask_to_write(contacts.data() + contacts.size() + kWriteAhead);
          contacts.push_back(recycled_contact(state, a, b, manifolds.last_points[k]));
        }
        KeptManifold m = *last;  // found where it was: its drift is still measured from there
        m.first = static_cast<std::uint32_t>(manifolds.next_points.size());
        manifolds.next_points.insert(manifolds.next_points.end(), manifolds.last_points.begin() + last->first,
                                     manifolds.last_points.begin() + last->first + last->count);
        manifolds.next.push_back(m);
        ++recycled;
        continue;
      }
      collide_anew(i, j, scratch, contacts, memory.separating.next,
                   [&](BodyIndex x, const Crossing& c) { memory.crossing_next[x] = c; }, manifolds.next,
                   manifolds.next_points);
    }
  } else {
    // chunks of pairs on the pool's threads, in two passes. The first finds which pairs keep their
    // manifold (their contacts are then as many as its points) and collides the others, each chunk
    // into lists of its own; once every pair's place in the step's lists is summed, the second
    // writes the kept pairs' contacts and points straight there and copies the others' from their
    // chunk. The same contacts, separating faces, crossings and kept manifolds, in the same order,
    // as on one thread (a pair recycled or found anew writes nothing else)
    const std::size_t chunks = (P + kPairsPerChunk - 1) / kPairsPerChunk;
    if (scratch.chunks.size() < chunks) scratch.chunks.resize(std::max(chunks, 2 * scratch.chunks.size()));
    if (scratch.places.size() < P) scratch.places.resize(std::max(P, 2 * scratch.places.size()));
    const std::size_t workers = static_cast<std::size_t>(pool->threads());
    grow_workers(scratch, workers);
    const auto pairs_of = [&](std::size_t c) { return std::make_pair(c * kPairsPerChunk, std::min(P, (c + 1) * kPairsPerChunk)); };
    pool->for_ranges(chunks, 1, [&](std::size_t first, std::size_t end) {
      Scratch& buffers = worker_scratch(scratch, workers);
      for (std::size_t c = first; c < end; ++c) {
        Scratch::PairChunk& chunk = scratch.chunks[c];
        chunk.contacts.clear();
        chunk.separating.clear();
        chunk.crossings.clear();
        chunk.kept.clear();
        chunk.kept_points.clear();
        chunk.recycled = 0;
        const auto [from, to] = pairs_of(c);
        std::size_t hint = 0;  // where the chunk's last search of the memory ended
        for (std::size_t k = from; k < to; ++k) {
          const auto [a, b] = ordered(pairs[k].first, pairs[k].second);
          Scratch::PairPlace& place = scratch.places[k];
          if (const KeptManifold* last = kept_for(a, b, hint)) {
            place.last = static_cast<int>(last - manifolds.last.data());
            place.count = place.points = last->count;
            place.points_from = last->first;
            ++chunk.recycled;
            continue;
          }
          const std::size_t before = chunk.contacts.size(), kept_before = chunk.kept.size();
          collide_anew(pairs[k].first, pairs[k].second, buffers, chunk.contacts, chunk.separating,
                       [&](BodyIndex x, const Crossing& y) { chunk.crossings.emplace_back(x, y); }, chunk.kept,
                       chunk.kept_points);
          place.last = -1;
          place.count = static_cast<std::uint32_t>(chunk.contacts.size() - before);
          const bool kept = chunk.kept.size() > kept_before;
          place.points = kept ? chunk.kept.back().count : 0;
          place.points_from = kept ? chunk.kept.back().first : 0;
        }
      }
    });
    // every pair's places, in pair order; the small lists joined here
    std::size_t at = 0, points_at = 0;
    for (std::size_t c = 0; c < chunks; ++c) {
      const Scratch::PairChunk& chunk = scratch.chunks[c];
      std::size_t fresh_kept = 0;  // the chunk's kept manifolds of pairs found anew, in pair order
      const auto [from, to] = pairs_of(c);
      for (std::size_t k = from; k < to; ++k) {
        Scratch::PairPlace& place = scratch.places[k];
        place.at = at;
        place.points_at = points_at;
        at += place.count;
        if (place.points == 0) continue;
        // a kept manifold found where it was (its drift is still measured from there), or anew
        KeptManifold m = place.last >= 0 ? manifolds.last[static_cast<std::size_t>(place.last)] : chunk.kept[fresh_kept++];
        m.first = static_cast<std::uint32_t>(points_at);
        manifolds.next.push_back(m);
        points_at += place.points;
      }
      memory.separating.next.insert(memory.separating.next.end(), chunk.separating.begin(), chunk.separating.end());
      for (const auto& [b, x] : chunk.crossings) memory.crossing_next[b] = x;
      recycled += chunk.recycled;
    }
    // (a list of the last step's length is only overwritten: no element is made)
    contacts.resize(at);
    manifolds.next_points.resize(points_at);
    pool->for_ranges(chunks, 1, [&](std::size_t first, std::size_t end) {
      for (std::size_t c = first; c < end; ++c) {
        const Scratch::PairChunk& chunk = scratch.chunks[c];
        std::size_t fresh = 0;  // the chunk's contacts of pairs found anew so far
        const auto [from, to] = pairs_of(c);
        for (std::size_t k = from; k < to; ++k) {
          const Scratch::PairPlace& place = scratch.places[k];
          const std::vector<KeptPoint>& points = place.last >= 0 ? manifolds.last_points : chunk.kept_points;
          std::copy(points.begin() + place.points_from, points.begin() + place.points_from + place.points,
                    manifolds.next_points.begin() + static_cast<std::ptrdiff_t>(place.points_at));
          if (place.last >= 0) {
            const auto [a, b] = ordered(pairs[k].first, pairs[k].second);
            for (std::uint32_t q = 0; q < place.count; ++q) {
              if (place.at + q + kWriteAhead < contacts.size()) ask_to_write(&contacts[place.at + q + kWriteAhead]);
              contacts[place.at + q] = recycled_contact(state, a, b, points[place.points_from + q]);
            }
          } else {
            std::copy(chunk.contacts.begin() + static_cast<std::ptrdiff_t>(fresh),
                      chunk.contacts.begin() + static_cast<std::ptrdiff_t>(fresh + place.count),
                      contacts.begin() + static_cast<std::ptrdiff_t>(place.at));
            fresh += place.count;
          }
        }
      }
    });
  }
  // kept in pair order, so sorted: a pair that keeps its manifold has no static-only shape, so it
  // is never swapped (a = i < b = j); they become the memory when the step is kept
  // (ContactMemory::commit)
  manifolds.pairs = static_cast<int>(P);
  manifolds.recycled = recycled;
  // keys were written in pair order, parts in order within a pair: sorted (a static-only shape
  // taken as A can reorder two pairs' keys, so sort to be sure; it is nearly sorted)
  if (!std::is_sorted(memory.separating.next.begin(), memory.separating.next.end()))
    std::sort(memory.separating.next.begin(), memory.separating.next.end());
  std::swap(memory.separating.last, memory.separating.next);
}

bool any_turned(const Model& model, const std::vector<std::pair<BodyIndex, BodyIndex>>& pairs,
                const std::vector<double>& turned) {
  return std::any_of(pairs.begin(), pairs.end(),
                     [&](const auto& p) { return turned_far(model, p.first, p.second, turned); });
}

void redetect_turned(const Model& model, const State& now, double dt, const Vec3& gravity, double margin,
                     const BroadPhase& broad_phase, const ContactMemory& memory, Scratch& scratch,
                     const std::vector<double>& turned, const std::vector<Contact>& carried,
                     const std::vector<Vec3>& carried_a, const std::vector<Vec3>& carried_b, std::vector<Contact>& out,
                     std::vector<Vec3>& anchor_a, std::vector<Vec3>& anchor_b,
                     const std::vector<std::pair<BodyIndex, BodyIndex>>* extra) {
  out.clear();
  anchor_a.clear();
  anchor_b.clear();
  const std::size_t K = carried.size();
  const auto& listed = scratch.pairs;
  static const std::vector<std::pair<BodyIndex, BodyIndex>> none;
  const auto& added = extra ? *extra : none;
  std::size_t i = 0;  // the carried contacts, in pair order: a pair's run starts at i
  // the step's candidate pairs and the escaped bodies' pairs at `now`, merged in pair order (a
  // pair in both once)
  for (std::size_t u = 0, w = 0; u < listed.size() || w < added.size();) {
    const bool from_listed = w == added.size() || (u < listed.size() && listed[u] <= added[w]);
    const auto [first, second] = from_listed ? listed[u] : added[w];
    const bool in_added = w < added.size() && added[w] == std::make_pair(first, second);
    if (from_listed) ++u;
    if (in_added) ++w;
    const auto [a, b] = collided_order(model, first, second);
    const std::size_t from = i;
    while (from_listed && i < K && carried[i].body_a == a && carried[i].body_b == b) ++i;
    // an escaped body's pair without a carried contact whose boxes meet now (`extra`): the step's
    // detection did not reach it (a candidate new to the step, or one whose points it found out of
    // reach)
    const bool lost = in_added && i == from;
    if (turned_far(model, a, b, turned) || lost) {
      const std::size_t before = out.size();
      TrianglePast past;  // (the crossing it finds is the next detection's to find)
      collide_pair(model, now, a, b, body_reach(model, now, a, dt, gravity), body_reach(model, now, b, dt, gravity), dt,
                   gravity, margin, broad_phase, memory, scratch, out, past, nullptr, nullptr);
      for (std::size_t k = before; k < out.size(); ++k) {  // found here: the lever arms are the point's now
        anchor_a.push_back(out[k].point);
        anchor_b.push_back(out[k].point);
      }
    } else {
      out.insert(out.end(), carried.begin() + static_cast<std::ptrdiff_t>(from), carried.begin() + static_cast<std::ptrdiff_t>(i));
      anchor_a.insert(anchor_a.end(), carried_a.begin() + static_cast<std::ptrdiff_t>(from), carried_a.begin() + static_cast<std::ptrdiff_t>(i));
      anchor_b.insert(anchor_b.end(), carried_b.begin() + static_cast<std::ptrdiff_t>(from), carried_b.begin() + static_cast<std::ptrdiff_t>(i));
    }
  }
  if (i != K)
    throw std::logic_error("redetect_turned: the step's contacts are not in the order of its candidate pairs");
}

}  // namespace signorini::collision

namespace signorini {

std::vector<Contact> collide(const Shape& shape_a, const Vec3& p_a, const Quat4& q_a, const Shape& shape_b,
                             const Vec3& p_b, const Quat4& q_b, double margin) {
  // the one check of user quaternions (math::unit_quaternion), as for bodies
  auto rotation = [](const char* who, const Vec3& p, const Quat4& q) {
    if (!p.allFinite()) throw std::invalid_argument(std::string("collide: position of ") + who + " must be finite");
    try {
      return math::quat_to_matrix(math::unit_quaternion(q));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("collide: shape ") + who + ": " + e.what());
    }
  };
  const Mat3 R_a = rotation("A", p_a, q_a), R_b = rotation("B", p_b, q_b);
  if (!(std::isfinite(margin) && margin >= 0.0))
    throw std::invalid_argument("collide: margin must be finite and >= 0, got " + std::to_string(margin));
  std::vector<Contact> out;
  collision::collide(shape_a, {p_a, R_a}, shape_b, {p_b, R_b}, margin, {}, out);
  for (Contact& c : out) {
    c.body_a = 0;
    c.body_b = 1;
    c.arm_a = c.point - p_a;
    c.arm_b = c.point - p_b;
  }
  return out;
}

}  // namespace signorini
