// What contact detection remembers from step to step (collision.hpp, ContactMemory).
#include <algorithm>
#include <stdexcept>

#include "collision/collision.hpp"
#include "serial/byte_stream.hpp"

namespace signorini::collision {

void ContactMemory::add_body(const Vec3& p) {
  previous_p.push_back(p);
  crossing.emplace_back();
  crossing_next.clear();  // sized (empty) again by the next detection
}

void ContactMemory::placed(BodyIndex i, const Vec3& p) {
  previous_p[i] = p;
  crossing[i] = Crossing();
}

void ContactMemory::commit(const std::vector<Vec3>& p_start, const std::vector<BodyIndex>* bodies) {
  if (bodies) {
    for (const BodyIndex i : *bodies) previous_p[i] = p_start[i];
  } else {
    std::copy(p_start.begin(), p_start.end(), previous_p.begin());
  }
  crossing.swap(crossing_next);
  std::swap(manifolds.last, manifolds.next);
  std::swap(manifolds.last_points, manifolds.next_points);
}

void ContactMemory::remove(const std::vector<BodyIndex>& to) {
  const auto n = static_cast<BodyIndex>(to.size());
  BodyIndex kept = 0;
  for (BodyIndex j = 0; j < n; ++j) {
    if (to[j] < 0) continue;
    previous_p[to[j]] = previous_p[j];
    crossing[to[j]] = crossing[j];
    ++kept;
  }
  previous_p.erase(previous_p.begin() + kept, previous_p.end());
  crossing.erase(crossing.begin() + kept, crossing.end());
  crossing_next.clear();  // sized (empty) again by the next detection
  // the kept manifolds of the bodies that stay, renumbered (to is increasing over them, so the
  // order by pair stays), their points moved up; the others' dropped
  std::size_t kept_count = 0, points = 0;
  for (const KeptManifold& m : manifolds.last) {
    if (to[m.body_a] < 0 || to[m.body_b] < 0) continue;
    KeptManifold moved = m;
    moved.body_a = to[m.body_a];
    moved.body_b = to[m.body_b];
    moved.first = static_cast<std::uint32_t>(points);
    std::copy(manifolds.last_points.begin() + m.first, manifolds.last_points.begin() + m.first + m.count,
              manifolds.last_points.begin() + static_cast<std::ptrdiff_t>(points));
    points += m.count;
    manifolds.last[kept_count++] = moved;
  }
  manifolds.last.resize(kept_count);
  manifolds.last_points.resize(points);
  manifolds.next.clear();
  manifolds.next_points.clear();
  for (Crossing& c : crossing) {
    if (c.mesh >= 0 && to[c.mesh] < 0) c = Crossing();
    else if (c.mesh >= 0) c.mesh = to[c.mesh];
  }
}

void ContactMemory::save(serial::Writer& w) const {
  w.mats(previous_p);
  for (const Crossing& c : crossing) {
    w.pod(static_cast<std::int32_t>(c.mesh));
    w.pod(static_cast<std::int32_t>(c.triangle));
  }
  w.pod(static_cast<std::uint64_t>(manifolds.last.size()));
  for (const KeptManifold& m : manifolds.last) {
    w.pod(static_cast<std::int32_t>(m.body_a));
    w.pod(static_cast<std::int32_t>(m.body_b));
    w.mat(m.d0);
    w.mat(m.R_a0);
    w.mat(m.R_b0);
    w.pod(m.first);
    w.pod(m.count);
  }
  w.pod(static_cast<std::uint64_t>(manifolds.last_points.size()));
  for (const KeptPoint& q : manifolds.last_points) {
    w.mat(q.on_a);
    w.mat(q.on_b);
    w.mat(q.normal);
    w.mat(q.arm_a);
    w.mat(q.arm_b);
    w.pod(q.feature_a);
    w.pod(q.feature_b);
  }
}

void ContactMemory::load(serial::Reader& r, const Model& model, char version) {
  const std::size_t n = model.size();
  r.mats(previous_p, n);
  crossing.assign(n, Crossing());
  for (Crossing& c : crossing) {
    c.mesh = r.pod<std::int32_t>();
    c.triangle = r.pod<std::int32_t>();
  }
  for (const Crossing& c : crossing) {
    if (c.mesh == -1 && c.triangle == -1) continue;
    const bool in_range = c.mesh >= 0 && static_cast<std::size_t>(c.mesh) < n;
    const TriangleMesh* mesh = in_range ? std::get_if<TriangleMesh>(&model.shape[static_cast<std::size_t>(c.mesh)]) : nullptr;
    if (!mesh || c.triangle < 0 || c.triangle >= mesh->faces.rows())
      throw std::invalid_argument("restore_state: the saved state is damaged (crossing memory)");
  }
  for (const Vec3& x : previous_p)
    if (!x.allFinite()) throw std::invalid_argument("restore_state: the saved state is damaged (previous centres)");
  manifolds = ManifoldCache();
  if (version < '5') return;  // none kept: every pair is collided anew at the next detection
  const auto damaged = [] { return std::invalid_argument("restore_state: the saved state is damaged (kept manifolds)"); };
  // format 5 kept a manifold's pose and normal in A's frame and no lever arms: read past, and found anew
  const bool rows_kept = version >= '6';
  manifolds.last.resize(r.count(2 * sizeof(std::int32_t)));
  for (KeptManifold& m : manifolds.last) {
    m.body_a = r.pod<std::int32_t>();
    m.body_b = r.pod<std::int32_t>();
    r.mat(m.d0);
    r.mat(m.R_a0);
    if (rows_kept) r.mat(m.R_b0);
    m.first = r.pod<std::uint32_t>();
    m.count = r.pod<std::uint32_t>();
  }
  manifolds.last_points.resize(r.count(9 * sizeof(double)));
  for (KeptPoint& q : manifolds.last_points) {
    r.mat(q.on_a);
    r.mat(q.on_b);
    r.mat(q.normal);
    if (rows_kept) {
      r.mat(q.arm_a);
      r.mat(q.arm_b);
    }
    q.feature_a = r.pod<FeatureId>();
    q.feature_b = r.pod<FeatureId>();
  }
  const auto body = [n](BodyIndex k) { return k >= 0 && static_cast<std::size_t>(k) < n; };
  for (std::size_t k = 0; k < manifolds.last.size(); ++k) {
    const KeptManifold& m = manifolds.last[k];
    if (!body(m.body_a) || !body(m.body_b) || m.body_a == m.body_b || !m.d0.allFinite() || !m.R_a0.allFinite() || !m.R_b0.allFinite() ||
        std::uint64_t(m.first) + m.count > manifolds.last_points.size() || (k > 0 && !(manifolds.last[k - 1] < m)))
      throw damaged();
  }
  for (const KeptPoint& q : manifolds.last_points)
    if (!q.on_a.allFinite() || !q.on_b.allFinite() || !q.normal.allFinite() || !q.arm_a.allFinite() || !q.arm_b.allFinite())
      throw damaged();
  if (!rows_kept) manifolds = ManifoldCache();
}

}  // namespace signorini::collision
