// Contact events (issue 24, "Events"): after each step, the body pairs that began and ended
// touching, and the beginnings faster than hit_speed (hits), as lists in a deterministic order
// (docs/conventions.md, "Contact events"). Box2D v3 reports its events the same way: arrays read
// after the step, not callbacks during it.
//
// Which pairs touched before a step is a function of the reported contacts alone (kept in
// touching_), so a restored state, a pickled world and a world whose bodies were renumbered give
// the events a world that had gone on would have given.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "signorini/world.hpp"
#include "world/checks.hpp"
#include "solver/contact_solver.hpp"
#include "world/islands.hpp"
#include "world/step_guard.hpp"

namespace signorini {
namespace {

/// An event of the pair (a, b) in the step, with contact c's point and normal when given (else zero).
ContactEvent event_of(int step, BodyIndex a, BodyIndex b, const Contact* c) {
  ContactEvent e;
  e.step = step;
  e.body_a = a;
  e.body_b = b;
  if (c != nullptr) {
    e.point = c->point;
    e.normal = c->normal;
  }
  return e;
}

}  // namespace

void World::touching_pairs(const std::vector<Contact>& contacts, std::vector<Touch>& out, const BodyIndex* bodies,
                           const char* touches) {
  out.clear();
  const std::size_t K = contacts.size();
  if (bodies != nullptr) {  // the compact copies: 9 bytes a contact instead of its record
    for (std::size_t i = 0, j = 0; i < K; i = j) {
      const BodyIndex a = bodies[2 * i], b = bodies[2 * i + 1];
      bool touching = false;
      for (j = i; j < K && bodies[2 * j] == a && bodies[2 * j + 1] == b; ++j) touching = touching || touches[j];
      if (touching) out.push_back({a, b, i, 0.0});
    }
  } else {
    for (std::size_t i = 0, j = 0; i < K; i = j) {
      const Contact& c = contacts[i];
      bool touching = false;
      for (j = i; j < K && contacts[j].body_a == c.body_a && contacts[j].body_b == c.body_b; ++j)
        touching = touching || contacts[j].impulse > 0.0 || contacts[j].gap < 0.0;
      if (touching) out.push_back({c.body_a, c.body_b, i, 0.0});
    }
  }
  // by pair, as the merge in record_events walks them (the contact list usually is already: the
  // narrow phase lists pairs in order; sleeping islands' contacts are merged in)
  const auto by_pair = [](const Touch& x, const Touch& y) { return x.a < y.a || (x.a == y.a && x.b < y.b); };
  if (!std::is_sorted(out.begin(), out.end(), by_pair)) std::sort(out.begin(), out.end(), by_pair);
}

void World::record_events(const std::vector<Contact>& now) {
  // the solver's compact copies of the step's contacts when they are the reported ones (no
  // sleeping island's contacts merged in)
  const bool compact = islands_->contacts().empty() && solver_->touches.size() == now.size() &&
                       solver_->contact_body.size() == 2 * now.size();
  if (compact) touching_pairs(now, touching_next_, solver_->contact_body.data(), solver_->touches.data());
  else touching_pairs(now, touching_next_);
  const State& start = guard_->start();  // the velocities the step started from
  const auto approach = [&](const Touch& t) {
    double speed = 0.0;
    for (std::size_t k = t.first; k < now.size() && now[k].body_a == t.a && now[k].body_b == t.b; ++k) {
      const Contact& c = now[k];
      const Vec3 v_a = start.v[t.a] + start.omega[t.a].cross(c.point - start.p[t.a]);
      const Vec3 v_b = start.v[t.b] + start.omega[t.b].cross(c.point - start.p[t.b]);
      speed = std::max(speed, -c.normal.dot(v_b - v_a));
    }
    return speed;
  };
  const auto begin = [&](const Touch& t) {
    ContactEvent e = event_of(event_step_, t.a, t.b, &now[t.first]);
    e.speed = approach(t);
    for (std::size_t k = t.first; k < now.size() && now[k].body_a == t.a && now[k].body_b == t.b; ++k)
      e.impulse += now[k].impulse;  // the pair's, summed in contact order
    events_.begin.push_back(e);
    if (e.speed > hit_speed_) events_.hits.push_back(e);
  };
  const auto end = [&](const Touch& t) { events_.end.push_back(event_of(event_step_, t.a, t.b, nullptr)); };
  // both lists by pair: a merge
  std::size_t i = 0, j = 0;
  const std::vector<Touch>& was = touching_;
  const std::vector<Touch>& is = touching_next_;
  while (i < was.size() || j < is.size()) {
    if (j == is.size() || (i < was.size() && (was[i].a < is[j].a || (was[i].a == is[j].a && was[i].b < is[j].b)))) {
      end(was[i++]);
    } else if (i == was.size() || is[j].a < was[i].a || (is[j].a == was[i].a && is[j].b < was[i].b)) {
      begin(is[j++]);
    } else {
      ++i, ++j;
    }
  }
  touching_.swap(touching_next_);
  touching_known_ = true;
}

void World::split_sensors(std::vector<Contact>& contacts) const {
  sensing_next_.clear();
  sensed_contacts_.clear();
  if (std::none_of(model_.is_sensor.begin(), model_.is_sensor.end(), [](bool x) { return x; })) return;
  const std::size_t K = contacts.size();
  std::size_t kept = 0;
  for (std::size_t i = 0, j = 0; i < K; i = j) {
    const BodyIndex a = contacts[i].body_a, b = contacts[i].body_b;
    for (j = i; j < K && contacts[j].body_a == a && contacts[j].body_b == b; ++j) {}
    const bool sensor_a = model_.is_sensor[a], sensor_b = model_.is_sensor[b];
    if (!sensor_a && !sensor_b) {  // a pair that collides: kept, in order
      for (std::size_t k = i; k < j; ++k, ++kept)
        if (kept != k) contacts[kept] = std::move(contacts[k]);
      continue;
    }
    if (sensor_a && sensor_b) continue;  // sensors do not sense each other
    std::size_t deepest = i;
    for (std::size_t k = i + 1; k < j; ++k)
      if (contacts[k].gap < contacts[deepest].gap) deepest = k;
    if (!(contacts[deepest].gap < 0.0)) continue;  // near, not overlapping
    Contact c = contacts[deepest];
    if (sensor_b) c.normal = -c.normal;  // from the sensor towards the visitor
    sensed_contacts_.push_back(c);
    sensing_next_.push_back({sensor_a ? a : b, sensor_a ? b : a, sensed_contacts_.size() - 1, 0.0});
  }
  contacts.resize(kept);
  const auto by_pair = [](const Touch& x, const Touch& y) { return x.a < y.a || (x.a == y.a && x.b < y.b); };
  if (!std::is_sorted(sensing_next_.begin(), sensing_next_.end(), by_pair))
    std::sort(sensing_next_.begin(), sensing_next_.end(), by_pair);
}

void World::record_sensor_events() {
  if (sensing_.empty() && sensing_next_.empty()) return;
  const auto before = [](const Touch& x, const Touch& y) { return x.a < y.a || (x.a == y.a && x.b < y.b); };
  // the pairs overlapping now: those detected, and those whose visitor sleeps (not detected)
  sensing_merged_.clear();
  std::size_t i = 0, j = 0;
  const std::vector<Touch>& was = sensing_;
  const std::vector<Touch>& is = sensing_next_;
  constexpr std::size_t kCarried = static_cast<std::size_t>(-1);  // no contact of this step
  while (i < was.size() || j < is.size()) {
    if (j == is.size() || (i < was.size() && before(was[i], is[j]))) {
      const Touch& t = was[i++];
      if (state_.asleep(t.b) && model_.enabled[t.b] && model_.enabled[t.a] && model_.is_sensor[t.a]) {
        sensing_merged_.push_back({t.a, t.b, kCarried, 0.0});
      } else {
        events_.sensor_end.push_back(event_of(event_step_, t.a, t.b, nullptr));
      }
    } else if (i == was.size() || before(is[j], was[i])) {
      const Touch& t = is[j++];
      events_.sensor_begin.push_back(event_of(event_step_, t.a, t.b, &sensed_contacts_[t.first]));
      sensing_merged_.push_back({t.a, t.b, kCarried, 0.0});
    } else {
      sensing_merged_.push_back({is[j].a, is[j].b, kCarried, 0.0});
      ++i, ++j;
    }
  }
  sensing_.swap(sensing_merged_);
}

ContactEvents World::events() const {
  const Lock lock(mutex_);
  return events_;
}

void World::set_hit_speed(double speed) {
  const Lock lock(mutex_);
  checks::require(std::isfinite(speed) && speed >= 0.0, "hit_speed must be finite and >= 0, got " + std::to_string(speed));
  hit_speed_ = speed;
}

double World::hit_speed() const {
  const Lock lock(mutex_);
  return hit_speed_;
}

}  // namespace signorini
