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
}

void ContactMemory::load(serial::Reader& r, const Model& model) {
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
}

}  // namespace signorini::collision
