// Islands and sleeping: the islands stage at the end of a step, waking, and the sleeping part of a
// saved state (islands.hpp says how islands are found and kept).
#include "world/islands.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

#include "parallel/pool.hpp"
#include "serial/byte_stream.hpp"
#include "solver/contact_solver.hpp"

namespace signorini {
namespace {

using solver::key_less;  // the warm-start cache's order (keys are unique in it)

/// Contact order between pairs: by (smaller index, larger index) (docs/conventions.md, "Order").
bool pair_before(const Contact& x, const Contact& y) {
  const auto kx = std::minmax(x.body_a, x.body_b), ky = std::minmax(y.body_a, y.body_b);
  return kx < ky;
}

/// A kinematic body that moves this step (it wakes what it touches and keeps it awake).
bool moving_kinematic(const Model& model, const State& state, std::size_t i) {
  return model.is_kinematic[i] && model.enabled[i] &&
         (state.v[i].squaredNorm() > 0.0 || state.omega[i].squaredNorm() > 0.0);
}

/// true when body i sleeps in an island (asleep and not static).
bool sleeping(const Model& model, const State& state, std::size_t i) {
  return !model.is_static[i] && state.asleep(i);
}

}  // namespace

void Islands::mark(const State& state, BodyIndex i) {
  if (state.island.empty() || state.island[i] < 0) return;
  if (marked_.size() < state.island.size()) marked_.resize(state.island.size(), 0);
  const std::int32_t label = state.island[i];
  if (!marked_[label]) marked_[label] = 1, marked_labels_.push_back(label);
  any_marked_ = true;
}

void Islands::mark_touching(const State& state, BodyIndex i) {
  for (const Contact& c : contacts_) {
    if (c.body_a == i) mark(state, c.body_b);
    if (c.body_b == i) mark(state, c.body_a);
  }
}

void Islands::mark_all(const Model& model, const State& state) {
  for (std::size_t i = 0; i < model.size(); ++i) mark(state, static_cast<BodyIndex>(i));
}

bool Islands::mark_touched(const Model& model, const State& state, const std::vector<Contact>& contacts) {
  bool any = false;
  const auto moves = [&](int k) { return awake_dynamic(model, state, k) || moving_kinematic(model, state, k); };
  for (const Contact& c : contacts) {
    if (sleeping(model, state, c.body_a) && moves(c.body_b)) mark(state, c.body_a), any = true;
    if (sleeping(model, state, c.body_b) && moves(c.body_a)) mark(state, c.body_b), any = true;
  }
  if (joints_ != nullptr)
    for (const Joint& j : *joints_) {
      if (j.broken) continue;
      if (sleeping(model, state, j.a) && moves(j.b)) mark(state, j.a), any = true;
      if (sleeping(model, state, j.b) && moves(j.a)) mark(state, j.b), any = true;
    }
  return any;
}

bool Islands::wake_marked(const Model& model, State& state, std::vector<CachedContact>& cache, bool purge_now,
                          const std::vector<BodyIndex>* bodies) {
  if (!any_marked_) return false;
  any_marked_ = false;
  // the woken islands' forces back into the warm-start cache (keys are unique: a stashed pair is
  // never detected while it sleeps); an entry's island is the label of its sleeping body
  bool added = false;
  for (const CachedContact& c : stash_) {
    const std::int32_t label = state.island[c.body_a] >= 0 ? state.island[c.body_a] : state.island[c.body_b];
    if (label >= 0 && marked_[label]) cache.push_back(c), added = true;
  }
  if (added) std::sort(cache.begin(), cache.end(), key_less);
  bool woke = false;
  parallel::each_body(bodies, model.size(), [&](std::size_t i) {
    const std::int32_t label = state.island[i];
    if (label < 0 || !marked_[label]) return;
    state.awake[i] = 1;
    state.sleep_time[i] = 0.0;
    state.island[i] = -1;
    woke = true;
  });
  for (const std::int32_t label : marked_labels_) marked_[label] = 0;
  marked_labels_.clear();
  to_purge_ = to_purge_ || woke;
  if (purge_now) purge(model, state);
  return woke;
}

void Islands::purge(const Model& /*model*/, const State& state) {
  if (!to_purge_) return;
  to_purge_ = false;
  // an entry stays while a body of it sleeps (its other body is static, kinematic or asleep too)
  const auto awake_pair = [&](const auto& c) { return state.island[c.body_a] < 0 && state.island[c.body_b] < 0; };
  stash_.erase(std::remove_if(stash_.begin(), stash_.end(), awake_pair), stash_.end());
  contacts_.erase(std::remove_if(contacts_.begin(), contacts_.end(), awake_pair), contacts_.end());
  // (every non-zero entry is listed in forced_)
  for (const BodyIndex i : forced_)
    if (state.island[i] < 0) force_[i].setZero(), torque_[i].setZero();
  sum_outside(state);
  list_forced(false);
}

void Islands::sum_outside(const State& state) {
  // the force on B is c.force, A gets the opposite, each with its torque about its own centre; the
  // bodies in the island keep the sums the solver made when it fell asleep
  for (const Contact& c : contacts_) {
    const Vec3 spin = c.spin_torque * c.normal;
    if (state.island[c.body_a] < 0) {
      force_[c.body_a] -= c.force;
      torque_[c.body_a] -= (c.point - state.p[c.body_a]).cross(c.force) + spin;
    }
    if (state.island[c.body_b] < 0) {
      force_[c.body_b] += c.force;
      torque_[c.body_b] += (c.point - state.p[c.body_b]).cross(c.force) + spin;
    }
  }
}

void Islands::merge_contacts(const std::vector<Contact>& solved, std::vector<Contact>& out) const {
  // grown geometrically (a plain copy or resize allocates the exact size)
  const std::size_t K = solved.size() + contacts_.size();
  if (out.capacity() < K) out.reserve(2 * K);
  out.resize(K);
  std::merge(solved.begin(), solved.end(), contacts_.begin(), contacts_.end(), out.begin(), pair_before);
}

void Islands::list_forced(bool scan_all) {
  // the candidates: every body (scan_all), or those listed before and those of the sleeping
  // contacts (a sum changes only at the bodies of contacts that join or leave)
  listing_.clear();
  if (scan_all) {
    for (std::size_t i = 0; i < force_.size(); ++i) listing_.push_back(static_cast<BodyIndex>(i));
  } else {
    listing_.insert(listing_.end(), forced_.begin(), forced_.end());
    for (const Contact& c : contacts_) listing_.push_back(c.body_a), listing_.push_back(c.body_b);
    std::sort(listing_.begin(), listing_.end());
    listing_.erase(std::unique(listing_.begin(), listing_.end()), listing_.end());
  }
  forced_.clear();
  for (const BodyIndex i : listing_)
    if (!force_[i].isZero(0.0) || !torque_[i].isZero(0.0)) forced_.push_back(i);
}

void Islands::add_forces(solver::SolverData& solver) const {
  if (contacts_.empty()) return;
  // the bodies with a non-zero sum (adding the others' zeros would change nothing)
  for (const BodyIndex i : forced_) {
    solver.body_force[i] += force_[i];
    solver.body_torque[i] += torque_[i];
    solver::mark_forced(solver, i);
  }
}

int Islands::find(int i) {
  while (parent_[i] != i) {
    parent_[i] = parent_[parent_[i]];
    i = parent_[i];
  }
  return i;
}

void Islands::link(const Model& model, const State& state, const std::vector<Contact>& contacts,
                   const std::vector<BodyIndex>* bodies) {
  const std::size_t n = model.size();
  // only awake dynamic bodies are linked and looked up: the listed entries are enough
  parent_.resize(n);
  parallel::each_body(bodies, n, [&](std::size_t i) { parent_[i] = static_cast<int>(i); });
  for (const Contact& c : contacts) {
    if (!awake_dynamic(model, state, c.body_a) || !awake_dynamic(model, state, c.body_b)) continue;
    const int ra = find(c.body_a), rb = find(c.body_b);
    if (ra < rb) parent_[rb] = ra;
    if (rb < ra) parent_[ra] = rb;  // the root is the island's smallest index
  }
  if (joints_ == nullptr) return;
  for (const Joint& j : *joints_) {  // a joint links as a contact does (a broken one not at all)
    if (j.broken) continue;
    if (!awake_dynamic(model, state, j.a) || !awake_dynamic(model, state, j.b)) continue;
    const int ra = find(j.a), rb = find(j.b);
    if (ra < rb) parent_[rb] = ra;
    if (rb < ra) parent_[ra] = rb;
  }
}

void Islands::end_step(const Model& model, State& state, const SleepSettings& settings, double dt,
                       const std::vector<Contact>& contacts, std::vector<CachedContact>& cache,
                       const std::vector<Vec3>& body_force, const std::vector<Vec3>& body_torque,
                       const std::vector<BodyIndex>* bodies) {
  if (!settings.enabled) return;
  const std::size_t n = model.size();
  // sleep timers: time below both thresholds, reset by any faster motion
  const double v2 = settings.linear_velocity * settings.linear_velocity;
  const double w2 = settings.angular_velocity * settings.angular_velocity;
  parallel::fit(ready_, n, std::uint8_t(1));
  parallel::each_body(bodies, n, [&](std::size_t i) {
    if (!awake_dynamic(model, state, i)) return;
    const bool rest = state.v[i].squaredNorm() <= v2 && state.omega[i].squaredNorm() <= w2;
    state.sleep_time[i] = rest ? state.sleep_time[i] + dt : 0.0;
  });
  // a body touching a moving kinematic body stays awake (the kinematic body is in no island)
  for (const Contact& c : contacts) {
    if (moving_kinematic(model, state, c.body_a) && awake_dynamic(model, state, c.body_b)) state.sleep_time[c.body_b] = 0.0;
    if (moving_kinematic(model, state, c.body_b) && awake_dynamic(model, state, c.body_a)) state.sleep_time[c.body_a] = 0.0;
  }
  if (joints_ != nullptr)
    for (const Joint& j : *joints_) {
      if (j.broken) continue;
      if (moving_kinematic(model, state, j.a) && awake_dynamic(model, state, j.b)) state.sleep_time[j.b] = 0.0;
      if (moving_kinematic(model, state, j.b) && awake_dynamic(model, state, j.a)) state.sleep_time[j.a] = 0.0;
    }
  // islands of this step's contacts; one that is not ready keeps all its bodies awake (roots are
  // awake dynamic bodies, so only the listed entries of ready_ are read)
  link(model, state, contacts, bodies);
  parallel::each_body(bodies, n, [&](std::size_t i) { ready_[i] = 1; });
  parallel::each_body(bodies, n, [&](std::size_t i) {
    if (!awake_dynamic(model, state, i)) return;
    const bool ready = model.can_sleep[i] && state.sleep_time[i] > 0.0 && state.sleep_time[i] >= settings.time_to_sleep;
    if (!ready) ready_[find(static_cast<int>(i))] = 0;
  });
  sleep_ready(model, state, cache, contacts, body_force, body_torque, bodies);
}

void Islands::sleep_ready(const Model& model, State& state, std::vector<CachedContact>& cache,
                          const std::vector<Contact>& contacts, const std::vector<Vec3>& body_force,
                          const std::vector<Vec3>& body_torque, const std::vector<BodyIndex>* bodies) {
  bool any = false;
  // fresh_ is set for awake dynamic bodies only: the listed entries start at 0 (the others stay 0)
  parallel::fit(fresh_, model.size(), std::uint8_t(0));
  parallel::each_body(bodies, model.size(), [&](std::size_t i) { fresh_[i] = 0; });
  parallel::each_body(bodies, model.size(), [&](std::size_t i) {
    if (!awake_dynamic(model, state, i)) return;
    const int root = find(static_cast<int>(i));
    if (!ready_[root]) return;
    state.awake[i] = 0;
    state.island[i] = root;
    state.v[i].setZero();
    state.omega[i].setZero();
    force_[i] = body_force[i];
    torque_[i] = body_torque[i];
    fresh_[i] = 1;
    any = true;
  });
  if (!any) return;
  // the new sleepers' warm-start forces wait in the stash (both lists stay sorted by key)
  const auto asleep = [&](const CachedContact& c) {
    return state.island[c.body_a] >= 0 || state.island[c.body_b] >= 0;
  };
  const std::size_t before = stash_.size();
  for (const CachedContact& c : cache)
    if (asleep(c)) stash_.push_back(c);
  cache.erase(std::remove_if(cache.begin(), cache.end(), asleep), cache.end());
  if (stash_.size() > before) std::sort(stash_.begin(), stash_.end(), key_less);
  // and their contacts join the sleeping ones, in contact order (a new sleeper's contacts are all
  // with its own island or with static and kinematic bodies, never with an older sleeper)
  merged_.clear();
  std::size_t k = 0;
  for (const Contact& c : contacts) {
    if (!fresh_[c.body_a] && !fresh_[c.body_b]) continue;
    while (k < contacts_.size() && pair_before(contacts_[k], c)) merged_.push_back(contacts_[k++]);
    merged_.push_back(c);
  }
  merged_.insert(merged_.end(), contacts_.begin() + static_cast<std::ptrdiff_t>(k), contacts_.end());
  contacts_.swap(merged_);
  // (every non-zero entry is listed in forced_)
  for (const BodyIndex i : forced_)
    if (state.island[i] < 0) force_[i].setZero(), torque_[i].setZero();
  sum_outside(state);
  list_forced(false);
}

BodyIndex Islands::sleep_island_of(const Model& model, State& state, BodyIndex i, const std::vector<Contact>& contacts,
                                   std::vector<CachedContact>& cache, const std::vector<Vec3>& body_force,
                                   const std::vector<Vec3>& body_torque) {
  link(model, state, contacts, nullptr);
  const std::size_t n = model.size();
  const int root = find(i);
  for (std::size_t k = 0; k < n; ++k)
    if (awake_dynamic(model, state, k) && find(static_cast<int>(k)) == root && !model.can_sleep[k])
      return static_cast<BodyIndex>(k);
  ready_.assign(n, 0);
  ready_[root] = 1;
  sleep_ready(model, state, cache, contacts, body_force, body_torque, nullptr);
  return -1;
}

void Islands::renumber(State& state, const std::vector<BodyIndex>& to) {
  for (std::int32_t& label : state.island)
    if (label >= 0) label = to[label];
  stash_.erase(std::remove_if(stash_.begin(), stash_.end(),
                              [&](const CachedContact& c) { return to[c.body_a] < 0 || to[c.body_b] < 0; }),
               stash_.end());
  for (CachedContact& c : stash_) c.body_a = to[c.body_a], c.body_b = to[c.body_b];
  contacts_.erase(std::remove_if(contacts_.begin(), contacts_.end(),
                                 [&](const Contact& c) { return to[c.body_a] < 0 || to[c.body_b] < 0; }),
                  contacts_.end());
  for (Contact& c : contacts_) c.body_a = to[c.body_a], c.body_b = to[c.body_b];
  std::size_t kept = 0;
  for (std::size_t j = 0; j < to.size(); ++j)
    if (to[j] >= 0) force_[kept] = force_[j], torque_[kept] = torque_[j], ++kept;
  force_.resize(kept);
  torque_.resize(kept);
  list_forced(true);
  marked_.assign(state.island.size(), 0);
  marked_labels_.clear();
  fresh_.clear();  // sized and zeroed again by the next sleep_ready
}

void Islands::save(serial::Writer& w, const State& state) const {
  for (std::size_t i = 0; i < state.awake.size(); ++i) {
    w.pod(state.awake[i]);
    w.pod(state.sleep_time[i]);
    w.pod(state.island[i]);
  }
  solver::save_cache(w, stash_);
  w.mats(force_);
  w.mats(torque_);
}

void Islands::load(serial::Reader& r, std::size_t n, std::vector<std::uint8_t>& awake, std::vector<double>& sleep_time,
                   std::vector<std::int32_t>& island, std::vector<CachedContact>& stash, std::vector<Vec3>& force,
                   std::vector<Vec3>& torque) {
  awake.resize(n);
  sleep_time.resize(n);
  island.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    awake[i] = r.pod<std::uint8_t>();
    sleep_time[i] = r.pod<double>();
    island[i] = r.pod<std::int32_t>();
  }
  solver::load_cache(r, '4', stash);  // format 4: with spin torques
  r.mats(force, n);
  r.mats(torque, n);
}

}  // namespace signorini
