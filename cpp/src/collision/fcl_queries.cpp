// Everything that touches FCL 0.7: the broad phase (DynamicAABBTreeCollisionManager) and the
// candidate triangles of static triangle meshes (BVHModel<OBBRSS>). FCL's signed distance is not
// used: the narrow phase is exact without it (docs/conventions.md, "Contacts", says what FCL and
// libccd did).
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <variant>

#include <fcl/fcl.h>

#include "collision/collision.hpp"
#include "collision/ray.hpp"
#include "parallel/pool.hpp"

namespace signorini::collision {
namespace {

/// World bounds lo, hi (m) of points x = R v + p over the rows v of V, grown into lo, hi.
void grow_by_points(const Points& V, const Mat3& R, const Vec3& p, Vec3& lo, Vec3& hi) {
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const Vec3 x = R * V.row(i).transpose() + p;
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
}

/// lo, hi grown by the box of half extents e about p.
void grow_about(const Vec3& p, const Vec3& e, Vec3& lo, Vec3& hi) {
  lo = lo.cwiseMin(p - e);
  hi = hi.cwiseMax(p + e);
}

/// Grows lo, hi by the tight world box of a convex primitive at pose (p, R), taken as its own
/// kind by reference: made into a Primitive, a box or a hull would be copied with its shared
/// polytope (an atomic count that two threads boxing identical bodies fought over) and a hull with
/// its vertices (two allocations), for every body in every step.
void grow_by(const Sphere& s, const Mat3&, const Vec3& p, Vec3& lo, Vec3& hi) {
  grow_about(p, Vec3::Constant(s.radius), lo, hi);
}
void grow_by(const Box& b, const Mat3& R, const Vec3& p, Vec3& lo, Vec3& hi) {
  grow_about(p, R.cwiseAbs() * b.half_extents, lo, hi);
}
void grow_by(const Capsule& c, const Mat3& R, const Vec3& p, Vec3& lo, Vec3& hi) {
  grow_about(p, c.half_length * R.col(2).cwiseAbs() + Vec3::Constant(c.radius), lo, hi);
}
void grow_by(const Cylinder& c, const Mat3& R, const Vec3& p, Vec3& lo, Vec3& hi) {
  // the caps are disks of normal a: along axis i a disk reaches r sqrt(1 - a_i^2)
  const Vec3 a = R.col(2);
  Vec3 e;
  for (int i = 0; i < 3; ++i)
    e[i] = c.half_height * std::abs(a[i]) + c.radius * std::sqrt(std::max(0.0, 1.0 - a[i] * a[i]));
  grow_about(p, e, lo, hi);
}
void grow_by(const ConvexHull& h, const Mat3& R, const Vec3& p, Vec3& lo, Vec3& hi) {
  grow_by_points(h.vertices, R, p, lo, hi);
}
void grow_by_primitive(const Primitive& shape, const Mat3& R, const Vec3& p, Vec3& lo, Vec3& hi) {
  std::visit([&](const auto& s) { grow_by(s, R, p, lo, hi); }, shape);
}

/// The tight world box of a shape at pose (p, R): the rotated shape's own extent, not the box of
/// its bounding sphere (which FCL 0.7 takes for any rotated geometry, and which makes a long thin
/// body pair with everything within its length).
void tight_aabb(const Shape& shape, const Mat3& R, const Vec3& p, Vec3& lo, Vec3& hi) {
  lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  hi = -lo;
  if (const auto* c = std::get_if<Compound>(&shape)) {
    for (const Compound::Part& part : c->parts) grow_by_primitive(part.shape, R * part.rotation, R * part.position + p, lo, hi);
  } else if (const auto* m = std::get_if<Mesh>(&shape)) {
    grow_by_points(m->vertices, R, p, lo, hi);
  } else if (const auto* t = std::get_if<TriangleMesh>(&shape)) {
    grow_by_points(t->vertices, R, p, lo, hi);
  } else if (std::holds_alternative<Plane>(shape)) {
    throw std::logic_error("broad phase: a plane has no bounding box");
  } else {
    std::visit(
        [&](const auto& s) {
          using T = std::decay_t<decltype(s)>;
          if constexpr (is_primitive_v<T>)
            grow_by(s, R, p, lo, hi);
        },
        shape);
  }
}

/// A CollisionObject whose world AABB is set by signorini (tight, and grown by a margin); the
/// base keeps it protected.
class Proxy : public fcl::CollisionObjectd {
 public:
  Proxy(const std::shared_ptr<fcl::CollisionGeometryd>& geometry, BodyIndex index)
      : fcl::CollisionObjectd(geometry), index_(index) {}
  void set_pose(const Shape& shape, const Vec3& p, const Mat3& R) {
    setTransform(R, p);
    Vec3 lo, hi;
    tight_aabb(shape, R, p, lo, hi);
    aabb.min_ = lo;
    aabb.max_ = hi;
  }
  void grow_aabb(double by) {
    aabb.min_ -= Vec3::Constant(by);
    aabb.max_ += Vec3::Constant(by);
  }
  /// The box [lo, hi] (world, m) as the tree's leaf will hold it at the next update.
  void set_box(const Vec3& lo, const Vec3& hi) {
    aabb.min_ = lo;
    aabb.max_ = hi;
  }
  /// Out of the way: a 1 m box of its own, far from anything a world holds, at z = side * 1e9 m
  /// (side +1 in the awake tree, -1 in the sleeping one, so parked boxes of the two never meet).
  void park(double side) {
    const Vec3 c(4.0 * index_, 0.0, side * kParkedAt);
    aabb.min_ = c - Vec3::Constant(0.5);
    aabb.max_ = c + Vec3::Constant(0.5);
  }
  static constexpr double kParkedAt = 1e9;
  BodyIndex index() const { return index_; }

 private:
  BodyIndex index_;
};

std::shared_ptr<fcl::Convexd> convex_of(const Polytope& P) {
  auto vertices = std::make_shared<std::vector<Vec3>>();
  for (Eigen::Index i = 0; i < P.vertices.rows(); ++i) vertices->push_back(P.vertex(static_cast<int>(i)));
  auto faces = std::make_shared<std::vector<int>>();
  for (const auto& loop : P.faces) {
    faces->push_back(static_cast<int>(loop.size()));
    faces->insert(faces->end(), loop.begin(), loop.end());
  }
  return std::make_shared<fcl::Convexd>(vertices, static_cast<int>(P.faces.size()), faces);
}

std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> bvh_of(const Points& vertices, const Triangles& faces) {
  auto model = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  model->beginModel();
  for (Eigen::Index k = 0; k < faces.rows(); ++k)
    model->addTriangle(vertices.row(faces(k, 0)).transpose(), vertices.row(faces(k, 1)).transpose(),
                       vertices.row(faces(k, 2)).transpose());
  model->endModel();
  return model;
}

/// FCL geometry of a whole body for the broad phase (only its bounding box matters).
std::shared_ptr<fcl::CollisionGeometryd> make_geometry(const Shape& shape) {
  if (const auto* s = std::get_if<Sphere>(&shape)) return std::make_shared<fcl::Sphered>(s->radius);
  if (const auto* b = std::get_if<Box>(&shape)) return std::make_shared<fcl::Boxd>(2.0 * b->half_extents);
  if (const auto* c = std::get_if<Capsule>(&shape)) return std::make_shared<fcl::Capsuled>(c->radius, 2.0 * c->half_length);
  if (const auto* c = std::get_if<Cylinder>(&shape)) return std::make_shared<fcl::Cylinderd>(c->radius, 2.0 * c->half_height);
  if (const auto* h = std::get_if<ConvexHull>(&shape)) return convex_of(*h->polytope);
  if (const auto* m = std::get_if<Mesh>(&shape)) return bvh_of(m->vertices, m->faces);
  if (const auto* t = std::get_if<TriangleMesh>(&shape)) return bvh_of(t->vertices, t->faces);
  // a compound: the sphere that bounds it (its AABB is all the broad phase reads)
  return std::make_shared<fcl::Sphered>(bounding_radius(shape));
}

bool collect_pair(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* data) {
  auto* pairs = static_cast<std::vector<std::pair<BodyIndex, BodyIndex>>*>(data);
  const BodyIndex i = static_cast<Proxy*>(o1)->index();
  const BodyIndex j = static_cast<Proxy*>(o2)->index();
  pairs->emplace_back(std::min(i, j), std::max(i, j));
  return false;  // keep going
}

/// Where the ray o + t u, t in [0, bound], enters the box [lo, hi] padded by 1e-9 (1 + its largest
/// coordinate) m (boxes are tight; the pad keeps a ray grazing a face from being culled by
/// rounding): false when it does not.
bool ray_enters_box(const Vec3& lo, const Vec3& hi, const Vec3& o, const Vec3& u, double bound, double& t_enter) {
  const double pad = 1e-9 * (1.0 + std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff()));
  double t_in = 0.0, t_out = bound;
  for (int i = 0; i < 3; ++i) {
    const double a = lo[i] - pad, b = hi[i] + pad;
    if (u[i] == 0.0) {
      if (o[i] < a || o[i] > b) return false;
      continue;
    }
    double t0 = (a - o[i]) / u[i], t1 = (b - o[i]) / u[i];
    if (t0 > t1) std::swap(t0, t1);
    t_in = std::max(t_in, t0);
    t_out = std::min(t_out, t1);
    if (t_in > t_out) return false;
  }
  t_enter = t_in;
  return true;
}

using TreeNode = fcl::detail::NodeBase<fcl::AABBd>;

}  // namespace

void shape_aabb(const Shape& shape, const Pose& pose, Vec3& lo, Vec3& hi) { tight_aabb(shape, pose.R, pose.p, lo, hi); }

struct TriangleQuery::Impl {
  std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> bvh;
  std::unique_ptr<fcl::CollisionObjectd> mesh;  ///< the BVH at the identity pose, built once
};

TriangleQuery::TriangleQuery(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()) {
  impl_->bvh = bvh_of(mesh.vertices, mesh.faces);
  impl_->mesh = std::make_unique<fcl::CollisionObjectd>(impl_->bvh);
  impl_->mesh->computeAABB();
}

TriangleQuery::~TriangleQuery() = default;

void TriangleQuery::overlapping(const Vec3& lo, const Vec3& hi, std::vector<int>& out,
                                std::vector<int>& stack) const {
  out.clear();
  // FCL's tree, walked here with an explicit stack: fcl::collide() allocates its result and
  // contact lists on every call, and a step must not allocate. Leaves hold one triangle each; the
  // per-triangle tests that follow are exact, so the leaf's box overlap is test enough.
  fcl::OBBRSSd box;
  box.obb.axis.setIdentity();
  box.obb.To = 0.5 * (lo + hi);
  box.obb.extent = 0.5 * (hi - lo);
  const fcl::BVHModel<fcl::OBBRSSd>& bvh = *impl_->bvh;
  if (bvh.getNumBVs() == 0) return;
  stack.clear();
  stack.push_back(0);
  while (!stack.empty()) {
    const auto& node = bvh.getBV(stack.back());
    stack.pop_back();
    if (!node.bv.obb.overlap(box.obb)) continue;
    if (node.isLeaf()) {
      out.push_back(node.primitiveId());
    } else {
      stack.push_back(node.rightChild());
      stack.push_back(node.leftChild());
    }
  }
  std::sort(out.begin(), out.end());
}

bool TriangleQuery::cast_ray(const TriangleMesh& mesh, const Vec3& o, const Vec3& u, double t_max, double& t,
                             int& triangle, bool& front, std::vector<int>& stack) const {
  // FCL's OBBRSS tree walked with the ray in each node's box frame; a node entered beyond the
  // best hit so far is skipped (entered exactly there is kept: a lower triangle index may tie)
  const fcl::BVHModel<fcl::OBBRSSd>& bvh = *impl_->bvh;
  if (bvh.getNumBVs() == 0) return false;
  double best = t_max;
  triangle = -1;
  stack.clear();
  stack.push_back(0);
  while (!stack.empty()) {
    const auto& node = bvh.getBV(stack.back());
    stack.pop_back();
    const fcl::OBBd& box = node.bv.obb;
    const Vec3 ob = box.axis.transpose() * (o - box.To), ub = box.axis.transpose() * u;
    double t_enter;
    if (!ray_enters_box(-box.extent, box.extent, ob, ub, best, t_enter)) continue;
    if (!node.isLeaf()) {
      stack.push_back(node.rightChild());
      stack.push_back(node.leftChild());
      continue;
    }
    const int k = node.primitiveId();
    double tk;
    bool fk;
    if (!ray_triangle(o, u, mesh.vertex(mesh.faces(k, 0)), mesh.vertex(mesh.faces(k, 1)), mesh.vertex(mesh.faces(k, 2)),
                      best, tk, fk))
      continue;
    if (triangle < 0 || tk < best || (tk == best && k < triangle)) best = tk, triangle = k, front = fk;
  }
  t = best;
  return triangle >= 0;
}

/// Sorts pairs (i, j) of bodies i, j < N as std::sort does (by i, then j) in O(P + N): counted into
/// a bucket per first body (bucket and out are scratch), then each bucket (a body's neighbours: a
/// handful) sorted by j. A walk of the trees hands on every candidate pair in the trees' order, and
/// std::sort of those took 3 % of rain's step (4,200 falling capsules); the standard library has no
/// sort by buckets of bounded integers, hence this one.
static void sort_pairs(std::vector<std::pair<BodyIndex, BodyIndex>>& pairs, std::size_t N, std::vector<int>& bucket,
                       std::vector<std::pair<BodyIndex, BodyIndex>>& out) {
  bucket.assign(N + 1, 0);
  for (const auto& ij : pairs) ++bucket[static_cast<std::size_t>(ij.first) + 1];
  for (std::size_t i = 0; i < N; ++i) bucket[i + 1] += bucket[i];
  out.resize(pairs.size());
  for (const auto& ij : pairs) out[static_cast<std::size_t>(bucket[static_cast<std::size_t>(ij.first)]++)] = ij;
  // bucket[i] is now where body i's pairs end
  for (std::size_t i = 0, first = 0; i < N; ++i) {
    const std::size_t end = static_cast<std::size_t>(bucket[i]);
    const auto at = [&](std::size_t k) { return out.begin() + static_cast<std::ptrdiff_t>(k); };
    if (end - first > 1) std::sort(at(first), at(end));
    first = end;
  }
  pairs.swap(out);
}

struct BroadPhase::Impl {
  std::vector<std::unique_ptr<Proxy>> proxy;  ///< by body index; null for planes
  std::vector<std::unique_ptr<TriangleQuery>> triangles;  ///< by body index; set for triangle meshes
  std::vector<BodyIndex> dynamic_bodies;
  std::vector<BodyIndex> planes;  ///< bodies whose shape is a Plane, ascending
  fcl::DynamicAABBTreeCollisionManagerd dynamic_tree;
  fcl::DynamicAABBTreeCollisionManagerd static_tree;
  /// sleeping bodies, their AABBs grown by margin/2 only. Every non-static body is registered in
  /// both dynamic_tree and sleep_tree once, as it is added, with a proxy in each; the tree it is not
  /// in at the moment holds its proxy parked (Proxy::park), so falling asleep or waking moves two
  /// leaves (FCL re-inserts a leaf in place, allocating nothing) instead of registering anew
  /// (which allocates FCL's table entry and tree nodes)
  fcl::DynamicAABBTreeCollisionManagerd sleep_tree;
  std::vector<std::unique_ptr<Proxy>> sleep_proxy;  ///< by body index; null for static bodies and planes
  std::vector<char> in_sleep_tree;  ///< by body index: its sleep_proxy holds its box (else parked)
  /// the proxies that moved in or out of parking in this call (scratch, reserved to the body count)
  std::vector<fcl::CollisionObjectd*> moved_awake, moved_asleep;
  /// Fat boxes (Box2D's idea; FCL's manager has none): an awake dynamic body's leaf holds its box
  /// grown by fat[i] more, and is moved only when the body's box (grown by reach + margin/2, kept
  /// in box) leaves it. While no leaf moves, the pairs of leaves that overlap (candidates) stay the
  /// same, so a pile at rest costs no tree update and no tree walk: only the candidates' boxes are
  /// tested again. Every pair whose boxes overlap is a candidate (each box lies in its leaf), so
  /// pairs() gives what a walk over the exact boxes would.
  std::vector<double> fat;                    ///< by body index (m): 1/10 of the shape's bounding radius
  std::vector<fcl::AABBd> box;                ///< by body index: an awake dynamic body's box this step
  std::vector<fcl::CollisionObjectd*> moved_fat;  ///< leaves given a new fat box in this call (scratch)
  std::vector<char> moved_flag;               ///< by body index: in moved_fat (scratch, all 0 between calls)
  std::vector<std::pair<BodyIndex, BodyIndex>> candidates;  ///< leaf pairs that overlap, sorted
  std::vector<std::pair<BodyIndex, BodyIndex>> merged;      ///< scratch: candidates merged with new pairs
  std::vector<int> bucket;  ///< scratch: where each body's pairs start in a counting sort (sort_pairs)
  bool fat_valid = false;  ///< false: every awake leaf gets its fat box and the trees are walked anew
  bool static_dirty = false;
  double static_margin = -1.0;  ///< margin the static AABBs were last grown by
  double sleep_margin = -1.0;   ///< margin the sleeping AABBs were last grown by
  std::size_t sleeping = 0;     ///< bodies in sleep_tree

  /// The proxies added since the trees were last used, by tree (static_tree, dynamic_tree,
  /// sleep_tree), registered together by flush() before a tree is used. FCL's tree inserts a leaf
  /// where it fits and never rebalances while inserting, so bodies added one by one in a row (a
  /// pyramid's boxes, or the parked proxies, laid out along a line) grow a chain as deep as the
  /// tree is large: registering a 5,050-box pyramid that way took most of a second and grew as
  /// N^2. Registered together into an empty tree, FCL builds it balanced from all the leaves at
  /// once (N log N).
  std::vector<fcl::CollisionObjectd*> pending[3];
  fcl::DynamicAABBTreeCollisionManagerd* tree(int k) { return k == 0 ? &static_tree : k == 1 ? &dynamic_tree : &sleep_tree; }
  /// A tree that already holds leaves is built anew with the pending ones when they are at least
  /// this many, else takes them one at a time (a body or two added to a running world).
  static constexpr std::size_t kRebuildFrom = 32;
  void flush() {
    for (int k = 0; k < 3; ++k) {
      std::vector<fcl::CollisionObjectd*>& added = pending[k];
      if (added.empty()) continue;
      fcl::DynamicAABBTreeCollisionManagerd& t = *tree(k);
      if (t.size() > 0 && added.size() < kRebuildFrom) {
        for (fcl::CollisionObjectd* proxy : added) t.registerObject(proxy);
      } else {
        if (t.size() > 0) {
          std::vector<fcl::CollisionObjectd*> held;
          t.getObjects(held);
          t.clear();
          added.insert(added.begin(), held.begin(), held.end());
        }
        t.registerObjects(added);
      }
      added.clear();
    }
  }
  bool flushed() const { return pending[0].empty() && pending[1].empty() && pending[2].empty(); }
};

BroadPhase::BroadPhase() : impl_(std::make_unique<Impl>()) {
  // FCL's manager rebuilds its whole tree top-down after an update that left it deeper than
  // log2(N) + this (10 by default, else a few leaves rebalanced). Leaves moved a few hundred at a
  // time (the 5,050-cube pyramid settling onto its springs, 300 boxes a step leaving their fat
  // boxes) reach that every few steps, and each rebuild cost more than the deeper tree's queries
  // saved: at 18 its detection took 6.5 ms a step against 7.0 over its first 60 steps, rain's the
  // same 3.6 (no bound at all let rain's tree grow into a chain 435 deep)
  impl_->dynamic_tree.max_tree_nonbalanced_level = 18;
}
BroadPhase::~BroadPhase() = default;

void BroadPhase::add_body(BodyIndex i, const Shape& shape, bool is_static, const Vec3& p, const Mat3& R) {
  if (static_cast<std::size_t>(i) != impl_->proxy.size())
    throw std::logic_error("BroadPhase::add_body: bodies must be added in index order");
  impl_->triangles.emplace_back(nullptr);
  impl_->in_sleep_tree.push_back(0);
  impl_->fat.push_back(std::holds_alternative<Plane>(shape) ? 0.0 : 0.1 * bounding_radius(shape));
  impl_->box.emplace_back();
  impl_->moved_flag.push_back(0);
  impl_->fat_valid = false;
  impl_->sleep_proxy.emplace_back(nullptr);
  if (const auto* mesh = std::get_if<TriangleMesh>(&shape)) impl_->triangles.back() = std::make_unique<TriangleQuery>(*mesh);
  if (std::holds_alternative<Plane>(shape)) {
    impl_->proxy.emplace_back(nullptr);
    impl_->planes.push_back(i);
    return;
  }
  const std::shared_ptr<fcl::CollisionGeometryd> geometry = make_geometry(shape);
  auto proxy = std::make_unique<Proxy>(geometry, i);
  proxy->set_pose(shape, p, R);
  if (is_static) {
    impl_->pending[0].push_back(proxy.get());
    impl_->static_dirty = true;
  } else {
    impl_->pending[1].push_back(proxy.get());
    impl_->dynamic_bodies.push_back(i);
    auto parked = std::make_unique<Proxy>(geometry, i);
    parked->setTransform(R, p);
    parked->park(-1.0);
    impl_->pending[2].push_back(parked.get());
    impl_->sleep_proxy.back() = std::move(parked);
    impl_->moved_awake.reserve(impl_->dynamic_bodies.size());
    impl_->moved_asleep.reserve(impl_->dynamic_bodies.size());
  }
  impl_->proxy.push_back(std::move(proxy));
}

void BroadPhase::move_static(BodyIndex i, const Vec3& p, const Mat3& R) {
  Proxy* proxy = impl_->proxy.at(i).get();
  if (!proxy) return;
  proxy->setTransform(R, p);  // the box is refitted from the shape at the next pairs()
  impl_->static_dirty = true;
  impl_->fat_valid = false;
}

void BroadPhase::refit_static(const Model& model, const State& state, double margin) {
  Impl& m = *impl_;
  m.flush();
  for (BodyIndex i = 0; i < static_cast<BodyIndex>(m.proxy.size()); ++i) {
    if (!m.proxy[i] || !model.is_static[i]) continue;
    m.proxy[i]->set_pose(model.shape[i], state.p[i], state.R[i]);
    m.proxy[i]->grow_aabb(0.5 * margin);
  }
  m.static_tree.update();
  m.static_dirty = false;
  m.static_margin = margin;
}

void BroadPhase::pairs(const Model& model, const State& state, const std::vector<double>& reach, double margin,
                       std::vector<std::pair<BodyIndex, BodyIndex>>& out, const parallel::Pool* pool) {
  Impl& m = *impl_;
  m.flush();
  // static bodies: grown once by margin/2, refitted only when one moved or the margin changed
  if (m.static_dirty || m.static_margin != margin) {
    refit_static(model, state, margin);
    m.fat_valid = false;
  }
  // sleeping bodies: moved to their own tree as they fall asleep, back as they wake (their poses
  // are frozen, so their boxes are set once); the other tree's proxy is parked
  const bool sleep_refit = m.sleeping > 0 && m.sleep_margin != margin;
  m.moved_awake.clear();
  m.moved_asleep.clear();
  for (BodyIndex i : m.dynamic_bodies) {
    const bool asleep = state.asleep(i);
    if (asleep == static_cast<bool>(m.in_sleep_tree[i]) && !(asleep && sleep_refit)) continue;
    Proxy* awake_proxy = m.proxy[i].get();
    Proxy* sleeping_proxy = m.sleep_proxy[i].get();
    if (asleep && m.in_sleep_tree[i]) {  // the margin changed
      sleeping_proxy->set_pose(model.shape[i], state.p[i], state.R[i]);
      sleeping_proxy->grow_aabb(0.5 * margin);
      continue;
    }
    if (asleep) {
      awake_proxy->park(1.0);
      sleeping_proxy->set_pose(model.shape[i], state.p[i], state.R[i]);
      sleeping_proxy->grow_aabb(0.5 * margin);
    } else {
      sleeping_proxy->park(-1.0);
      awake_proxy->set_pose(model.shape[i], state.p[i], state.R[i]);
      awake_proxy->grow_aabb(reach[i] + 0.5 * margin);
    }
    m.moved_awake.push_back(awake_proxy);
    m.moved_asleep.push_back(sleeping_proxy);
    m.in_sleep_tree[i] = asleep;
    m.sleeping += asleep ? 1 : std::size_t(-1);
  }
  // the moved leaves re-inserted where their new boxes are (a refit alone would stretch their old
  // neighbours' boxes out to the parking place)
  bool walk = !m.fat_valid || sleep_refit || !m.moved_awake.empty();
  if (!m.moved_awake.empty()) {
    m.dynamic_tree.update(m.moved_awake);
    m.sleep_tree.update(m.moved_asleep);
  }
  if (sleep_refit) m.sleep_tree.update();
  m.sleep_margin = margin;
  // awake dynamic bodies: the box at the new pose, grown by their reach; the leaf moves (with its
  // fat box) only when the box has left it. Each body touches its own box and leaf only: over the
  // threads, the leaves that moved flagged, then listed in body order
  parallel::for_bodies(pool, &m.dynamic_bodies, 0, 512, [&](std::size_t i) {
    if (m.in_sleep_tree[i]) return;
    Vec3 lo, hi;
    tight_aabb(model.shape[i], state.R[i], state.p[i], lo, hi);
    const Vec3 grow = Vec3::Constant(reach[i] + 0.5 * margin);
    fcl::AABBd& b = m.box[i];
    b.min_ = lo - grow;
    b.max_ = hi + grow;
    Proxy& leaf = *m.proxy[i];
    if (m.fat_valid && leaf.getAABB().contain(b)) return;
    leaf.setTransform(state.R[i], state.p[i]);
    leaf.set_box(b.min_ - Vec3::Constant(m.fat[i]), b.max_ + Vec3::Constant(m.fat[i]));
    m.moved_flag[i] = 1;
  });
  m.moved_fat.clear();
  for (BodyIndex i : m.dynamic_bodies) {
    if (!m.moved_flag[i]) continue;
    m.moved_flag[i] = 0;  // all 0 again between calls
    m.moved_fat.push_back(m.proxy[i].get());
  }
  // many leaves moved (a pile falling): every box read anew, the tree refitted and walked whole;
  // a few (a pile at rest, a body or two rolling): those leaves re-inserted and, unless the trees
  // are walked whole anyway, only they looked up
  // sorted, each pair once, none of a leaf with itself; the pairs from `from` on are new, those
  // before sorted already: only the new ones are sorted, then merged in (a few leaves moved: a
  // few new pairs beside thousands)
  const auto tidy = [&](std::size_t from) {
    const auto itself = [](const std::pair<BodyIndex, BodyIndex>& ij) { return ij.first == ij.second; };
    const auto added = [&] { return m.candidates.begin() + static_cast<std::ptrdiff_t>(from); };
    m.candidates.erase(std::remove_if(added(), m.candidates.end(), itself), m.candidates.end());
    if (from == 0) sort_pairs(m.candidates, model.size(), m.bucket, m.merged);  // a walk: all of them
    else std::sort(added(), m.candidates.end());
    if (from > 0 && added() != m.candidates.end()) {
      m.merged.resize(m.candidates.size());
      std::merge(m.candidates.begin(), added(), added(), m.candidates.end(), m.merged.begin());
      m.candidates.swap(m.merged);
    }
    m.candidates.erase(std::unique(m.candidates.begin(), m.candidates.end()), m.candidates.end());
  };
  if (!m.fat_valid || 4 * m.moved_fat.size() > m.dynamic_bodies.size()) {
    m.dynamic_tree.update();
    walk = true;
  } else if (!m.moved_fat.empty()) {
    m.dynamic_tree.update(m.moved_fat);
    if (!walk) {
      for (fcl::CollisionObjectd* leaf : m.moved_fat) m.moved_flag[static_cast<Proxy*>(leaf)->index()] = 1;
      const auto stale = [&](const std::pair<BodyIndex, BodyIndex>& ij) {
        return m.moved_flag[ij.first] || m.moved_flag[ij.second];
      };
      m.candidates.erase(std::remove_if(m.candidates.begin(), m.candidates.end(), stale), m.candidates.end());
      const std::size_t kept = m.candidates.size();  // sorted, without the moved leaves' pairs
      for (fcl::CollisionObjectd* leaf : m.moved_fat) {
        m.moved_flag[static_cast<Proxy*>(leaf)->index()] = 0;
        m.dynamic_tree.collide(leaf, &m.candidates, collect_pair);  // finds the leaf itself too
        m.static_tree.collide(leaf, &m.candidates, collect_pair);
        if (m.sleeping > 0) m.sleep_tree.collide(leaf, &m.candidates, collect_pair);
      }
      tidy(kept);
    }
  }
  m.fat_valid = true;
  if (walk) {
    m.candidates.clear();
    m.dynamic_tree.collide(&m.candidates, collect_pair);
    m.dynamic_tree.collide(&m.static_tree, &m.candidates, collect_pair);
    if (m.sleeping > 0) m.dynamic_tree.collide(&m.sleep_tree, &m.candidates, collect_pair);
    tidy(0);
  }
  // the candidates whose boxes overlap now (a static or sleeping body's box is its leaf's)
  const auto box_of = [&](BodyIndex i) -> const fcl::AABBd& {
    if (model.is_static[i]) return m.proxy[i]->getAABB();
    if (m.in_sleep_tree[i]) return m.sleep_proxy[i]->getAABB();
    return m.box[i];
  };
  out.clear();
  for (const auto& ij : m.candidates)
    if (box_of(ij.first).overlap(box_of(ij.second))) out.push_back(ij);
}

const TriangleQuery* BroadPhase::triangles(BodyIndex i) const { return impl_->triangles.at(i).get(); }

const std::vector<BodyIndex>& BroadPhase::planes() const { return impl_->planes; }

void BroadPhase::refresh(const Model& model, const State& state) {
  Impl& m = *impl_;
  m.flush();
  if (m.static_dirty) refit_static(model, state, std::max(m.static_margin, 0.0));
  for (BodyIndex i : m.dynamic_bodies) {
    if (m.in_sleep_tree[i]) {
      m.sleep_proxy[i]->set_pose(model.shape[i], state.p[i], state.R[i]);
      m.sleep_proxy[i]->grow_aabb(0.5 * m.sleep_margin);
    } else {
      m.proxy[i]->set_pose(model.shape[i], state.p[i], state.R[i]);
    }
  }
  if (!m.dynamic_bodies.empty()) m.dynamic_tree.update();
  if (m.sleeping > 0) m.sleep_tree.update();
  m.fat_valid = false;  // the awake leaves are tight now: the next pairs() fattens them again
}

void BroadPhase::cast_ray(const Vec3& o, const Vec3& u, double bound, RayVisitor& visitor,
                          std::vector<const void*>& stack, std::int64_t& nodes) const {
  const Impl& m = *impl_;
  if (!m.flushed()) throw std::logic_error("BroadPhase::cast_ray: bodies were added since the last pairs() or refresh()");
  // sleep: which tree holds a body's box (the other holds it parked, and is skipped)
  const fcl::DynamicAABBTreeCollisionManagerd* trees[3] = {&m.static_tree, &m.dynamic_tree, &m.sleep_tree};
  for (int k = 0; k < 3; ++k) {
    if (bound < 0.0) return;
    const TreeNode* root = trees[k]->getTree().getRoot();
    if (!root) continue;
    stack.clear();
    stack.push_back(root);
    while (!stack.empty() && bound >= 0.0) {
      const TreeNode* node = static_cast<const TreeNode*>(stack.back());
      stack.pop_back();
      ++nodes;
      double t_enter;
      if (!ray_enters_box(node->bv.min_, node->bv.max_, o, u, bound, t_enter)) continue;
      if (!node->isLeaf()) {
        stack.push_back(node->children[1]);
        stack.push_back(node->children[0]);
        continue;
      }
      const BodyIndex i = static_cast<const Proxy*>(static_cast<const fcl::CollisionObjectd*>(node->data))->index();
      if (k > 0 && static_cast<bool>(m.in_sleep_tree[i]) != (k == 2)) continue;  // parked here
      bound = visitor.visit(i, bound);
    }
  }
}

void BroadPhase::overlap_box(const Vec3& lo, const Vec3& hi, std::vector<BodyIndex>& out,
                             std::vector<const void*>& stack, std::int64_t& nodes, bool statics_only) const {
  const Impl& m = *impl_;
  if (!m.flushed()) throw std::logic_error("BroadPhase::overlap_box: bodies were added since the last pairs() or refresh()");
  const fcl::DynamicAABBTreeCollisionManagerd* trees[3] = {&m.static_tree, &m.dynamic_tree, &m.sleep_tree};
  for (int k = 0; k < (statics_only ? 1 : 3); ++k) {
    const TreeNode* root = trees[k]->getTree().getRoot();
    if (!root) continue;
    stack.clear();
    stack.push_back(root);
    while (!stack.empty()) {
      const TreeNode* node = static_cast<const TreeNode*>(stack.back());
      stack.pop_back();
      ++nodes;
      if ((node->bv.min_.array() > hi.array()).any() || (node->bv.max_.array() < lo.array()).any()) continue;
      if (!node->isLeaf()) {
        stack.push_back(node->children[1]);
        stack.push_back(node->children[0]);
        continue;
      }
      const BodyIndex i = static_cast<const Proxy*>(static_cast<const fcl::CollisionObjectd*>(node->data))->index();
      if (k > 0 && static_cast<bool>(m.in_sleep_tree[i]) != (k == 2)) continue;
      out.push_back(i);
    }
  }
}

void BroadPhase::escaped_pairs(const Model& model, const State& now, const std::vector<BodyIndex>& escaped,
                               const std::vector<double>& reach, double reach_bound, double margin,
                               std::vector<std::pair<BodyIndex, BodyIndex>>& out, std::vector<BodyIndex>& met,
                               std::vector<const void*>& stack) const {
  out.clear();
  // each body's box at `now`, grown by its reach and half the margin (and `extra`)
  const auto grown = [&](BodyIndex i, double extra, Vec3& lo, Vec3& hi) {
    tight_aabb(model.shape[i], now.R[i], now.p[i], lo, hi);
    const Vec3 grow = Vec3::Constant(reach[i] + 0.5 * margin + extra);
    lo -= grow;
    hi += grow;
  };
  const auto overlap = [](const Vec3& lo_a, const Vec3& hi_a, const Vec3& lo_b, const Vec3& hi_b) {
    return !((lo_a.array() > hi_b.array()).any() || (lo_b.array() > hi_a.array()).any());
  };
  const auto pair = [](BodyIndex i, BodyIndex j) { return std::make_pair(std::min(i, j), std::max(i, j)); };
  std::int64_t nodes = 0;
  for (std::size_t e = 0; e < escaped.size(); ++e) {
    const BodyIndex i = escaped[e];
    Vec3 lo, hi, wide_lo, wide_hi;
    grown(i, 0.0, lo, hi);
    grown(i, reach_bound + 0.5 * margin, wide_lo, wide_hi);
    // the other bodies, each inside its leaf: those whose leaves meet the box grown once more,
    // then tested with their boxes now
    met.clear();
    overlap_box(wide_lo, wide_hi, met, stack, nodes);
    for (const BodyIndex j : met) {
      if (j == i || std::binary_search(escaped.begin(), escaped.end(), j)) continue;  // (below, at its box now)
      Vec3 lo_j, hi_j;
      grown(j, 0.0, lo_j, hi_j);
      if (overlap(lo, hi, lo_j, hi_j)) out.push_back(pair(i, j));
    }
    // the escaped bodies after it, at their boxes now
    for (std::size_t f = e + 1; f < escaped.size(); ++f) {
      Vec3 lo_j, hi_j;
      grown(escaped[f], 0.0, lo_j, hi_j);
      if (overlap(lo, hi, lo_j, hi_j)) out.push_back(pair(i, escaped[f]));
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

}  // namespace signorini::collision
