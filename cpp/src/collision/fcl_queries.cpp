// Everything that touches FCL 0.7: the broad phase (DynamicAABBTreeCollisionManager) and signed
// distance for body-body pairs (GST_LIBCCD; GST_INDEP returns wrong signs, see DESIGN.md).
#include <algorithm>
#include <stdexcept>

#include <fcl/fcl.h>

#include "collision/collision.hpp"

namespace signorini::collision {
namespace {

/// A CollisionObject whose world AABB can be grown by a margin (the base keeps it protected).
class Proxy : public fcl::CollisionObjectd {
 public:
  Proxy(const std::shared_ptr<fcl::CollisionGeometryd>& geometry, BodyIndex index)
      : fcl::CollisionObjectd(geometry), index_(index) {}
  void set_pose(const Vec3& p, const Mat3& R) {
    setTransform(R, p);
    computeAABB();
  }
  void grow_aabb(double by) {
    aabb.min_ -= Vec3::Constant(by);
    aabb.max_ += Vec3::Constant(by);
  }
  BodyIndex index() const { return index_; }

 private:
  BodyIndex index_;
};

std::shared_ptr<fcl::CollisionGeometryd> make_geometry(const Shape& shape) {
  if (const auto* s = std::get_if<Sphere>(&shape)) return std::make_shared<fcl::Sphered>(s->radius);
  if (const auto* b = std::get_if<Box>(&shape))
    return std::make_shared<fcl::Boxd>(2.0 * b->half_extents);
  const auto& mesh = std::get<Mesh>(shape);
  if (mesh.is_convex()) {
    auto vertices = std::make_shared<std::vector<Vec3>>();
    for (Eigen::Index i = 0; i < mesh.vertices.rows(); ++i) vertices->push_back(mesh.vertex(i));
    auto faces = std::make_shared<std::vector<int>>();
    for (Eigen::Index k = 0; k < mesh.faces.rows(); ++k) {
      faces->push_back(3);
      for (int c = 0; c < 3; ++c) faces->push_back(static_cast<int>(mesh.faces(k, c)));
    }
    return std::make_shared<fcl::Convexd>(vertices, static_cast<int>(mesh.faces.rows()), faces);
  }
  // non-convex: a bounding-volume hierarchy, used for candidate pairs only
  auto model = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  model->beginModel();
  for (Eigen::Index k = 0; k < mesh.faces.rows(); ++k)
    model->addTriangle(mesh.vertex(mesh.faces(k, 0)), mesh.vertex(mesh.faces(k, 1)),
                       mesh.vertex(mesh.faces(k, 2)));
  model->endModel();
  return model;
}

struct PairCollector {
  std::vector<std::pair<BodyIndex, BodyIndex>> pairs;
};

bool collect_pair(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* data) {
  auto* collector = static_cast<PairCollector*>(data);
  const BodyIndex i = static_cast<Proxy*>(o1)->index();
  const BodyIndex j = static_cast<Proxy*>(o2)->index();
  collector->pairs.emplace_back(std::min(i, j), std::max(i, j));
  return false;  // keep going
}

}  // namespace

struct BroadPhase::Impl {
  std::vector<std::unique_ptr<Proxy>> proxy;  ///< by body index; null for planes
  std::vector<BodyIndex> dynamic_bodies;
  fcl::DynamicAABBTreeCollisionManagerd dynamic_tree;
  fcl::DynamicAABBTreeCollisionManagerd static_tree;
  bool static_dirty = false;
  double static_margin = -1.0;  ///< margin the static AABBs were last grown by
};

BroadPhase::BroadPhase() : impl_(std::make_unique<Impl>()) {}
BroadPhase::~BroadPhase() = default;

void BroadPhase::add_body(BodyIndex i, const Shape& shape, bool is_static, const Vec3& p, const Mat3& R) {
  if (static_cast<std::size_t>(i) != impl_->proxy.size())
    throw std::logic_error("BroadPhase::add_body: bodies must be added in index order");
  if (std::holds_alternative<Plane>(shape)) {
    impl_->proxy.emplace_back(nullptr);
    return;
  }
  auto proxy = std::make_unique<Proxy>(make_geometry(shape), i);
  proxy->set_pose(p, R);
  if (is_static) {
    impl_->static_tree.registerObject(proxy.get());
    impl_->static_dirty = true;
  } else {
    impl_->dynamic_tree.registerObject(proxy.get());
    impl_->dynamic_bodies.push_back(i);
  }
  impl_->proxy.push_back(std::move(proxy));
}

void BroadPhase::move_static(BodyIndex i, const Vec3& p, const Mat3& R) {
  Proxy* proxy = impl_->proxy.at(i).get();
  if (!proxy) return;
  proxy->set_pose(p, R);
  impl_->static_dirty = true;
}

std::vector<std::pair<BodyIndex, BodyIndex>> BroadPhase::pairs(const Model& model, const State& state,
                                                              const std::vector<double>& reach,
                                                              double margin) {
  Impl& m = *impl_;
  // static bodies: grown once by margin/2, refitted only when one moved or the margin changed
  if (m.static_dirty || m.static_margin != margin) {
    for (BodyIndex i = 0; i < static_cast<BodyIndex>(m.proxy.size()); ++i) {
      if (!m.proxy[i] || !model.is_static[i]) continue;
      m.proxy[i]->set_pose(state.p[i], state.R[i]);
      m.proxy[i]->grow_aabb(0.5 * margin);
    }
    m.static_tree.update();
    m.static_dirty = false;
    m.static_margin = margin;
  }
  // dynamic bodies: new pose, AABB grown by their reach, incremental tree refit
  for (BodyIndex i : m.dynamic_bodies) {
    m.proxy[i]->set_pose(state.p[i], state.R[i]);
    m.proxy[i]->grow_aabb(reach[i] + 0.5 * margin);
  }
  m.dynamic_tree.update();
  PairCollector collector;
  m.dynamic_tree.collide(&collector, collect_pair);
  m.dynamic_tree.collide(&m.static_tree, &collector, collect_pair);
  std::sort(collector.pairs.begin(), collector.pairs.end());
  collector.pairs.erase(std::unique(collector.pairs.begin(), collector.pairs.end()), collector.pairs.end());
  return collector.pairs;
}

bool BroadPhase::signed_distance(BodyIndex a, BodyIndex b, Contact& out) const {
  const Proxy* pa = impl_->proxy.at(a).get();
  const Proxy* pb = impl_->proxy.at(b).get();
  fcl::DistanceRequestd request;
  request.enable_signed_distance = true;
  request.enable_nearest_points = true;
  request.gjk_solver_type = fcl::GST_LIBCCD;
  fcl::DistanceResultd result;
  fcl::distance(pa, pb, request, result);
  const double gap = result.min_distance;  // the return value is not the signed distance
  if (!std::isfinite(gap)) return false;
  const Vec3 w_a = result.nearest_points[0];
  const Vec3 w_b = result.nearest_points[1];
  out.body_a = a;
  out.body_b = b;
  out.gap = gap;
  out.point = 0.5 * (w_a + w_b);
  // GJK's witness points carry ~1e-5 m of tangential error (measured on box-sphere), so their
  // direction is a good normal only when the gap is much larger than that. Closer pairs take the
  // normal of fcl::collide, whose box-box and primitive tests are exact: overlapping pairs as they
  // are (depth and point too), pairs a hair apart after B is moved into A along the approximate
  // normal by the gap plus a small probe depth (the gap itself stays the distance query's).
  const double size = std::max(pa->collisionGeometry()->aabb_radius, pb->collisionGeometry()->aabb_radius);
  Vec3 approx = w_b - w_a;
  if (approx.norm() > 1e-12) {
    if (gap < 0.0) approx = -approx;  // witnesses of an overlap point from B's surface to A's
  } else {
    approx = pb->getTranslation() - pa->getTranslation();  // touching: between the origins
    if (!(approx.norm() > 0.0)) approx = Vec3::UnitZ();
  }
  approx.normalize();
  if (gap > 1e-3 * size) {
    out.normal = approx;
    return true;
  }
  const double shift = gap > 0.0 ? gap + 1e-4 * size : 0.0;
  fcl::CollisionObjectd probe(std::const_pointer_cast<fcl::CollisionGeometryd>(pb->collisionGeometry()),
                              pb->getRotation(), pb->getTranslation() - shift * approx);
  probe.computeAABB();
  fcl::CollisionRequestd creq(1, true);
  creq.gjk_solver_type = fcl::GST_LIBCCD;
  fcl::CollisionResultd cres;
  fcl::collide(pa, &probe, creq, cres);
  if (cres.numContacts() == 0 || !Vec3(cres.getContact(0).normal).allFinite()) {
    out.normal = approx;
    return true;
  }
  const auto& contact = cres.getContact(0);
  out.normal = Vec3(contact.normal).normalized();
  if (shift == 0.0) {
    out.gap = -contact.penetration_depth;
    out.point = contact.pos;
  } else {
    out.point = Vec3(contact.pos) + 0.5 * shift * approx;
  }
  return true;
}

}  // namespace signorini::collision
