// Islands and sleeping (docs/conventions.md, "Sleeping"). An island is a set of dynamic bodies
// linked by the step's contacts; static and kinematic bodies never join one (they link nothing), so
// a floor under many piles leaves them separate islands.
//
// Awake islands are not kept between steps: they are found again at the end of each step by a
// union-find over that step's contacts, in contact order, with the smaller index as the root (so
// the root is the island's smallest body index). That costs O(N + K) with no allocation once the
// arrays have grown, needs no bookkeeping when contacts begin or end (merging and splitting are the
// next step's union-find), and cannot drift from the contacts. Results do not depend on it: the
// islands only decide when bodies sleep, and they are a function of the step's contacts.
//
// Sleeping islands are kept: each sleeping body carries its island's label (State::island, the
// smallest body index in it) and the island's warm-start forces wait here, in stash_, until it
// wakes. Nothing of a sleeping island is detected, solved or integrated, so its contacts cannot
// tell who belongs together any more; the label does. Waking an island puts its forces back into
// the solver's cache, so that a woken pile starts from the forces that held it. The island's
// contacts as they were solved in the step it fell asleep are kept too (contacts_, in contact
// order), with the contact force and torque they put on each body (force_, torque_), and reported
// beside each step's own (merge_contacts, add_forces): a sleeping pile still shows what holds it.
//
// Inputs and outputs of each member are in its comment; none allocates once its buffers have grown
// except the stash, which grows with the number of sleeping contacts.
#pragma once

#include <cstdint>
#include <vector>

#include "signorini/contact.hpp"
#include "signorini/joint.hpp"
#include "signorini/model.hpp"
#include "signorini/state.hpp"
#include "signorini/world.hpp"

namespace signorini::serial { struct Writer; struct Reader; }
namespace signorini::solver { struct SolverData; }

namespace signorini {

class Islands {
 public:
  /// The sleeping arrays of a new body i (awake 1, or 0 for a static body; timer 0; no island),
  /// appended to state (awake with `push`, which keeps a NumPy view's storage alive).
  template <class Push>
  static void add_body(const Model& model, State& state, std::size_t i, Push&& push) {
    push(state.awake, static_cast<std::uint8_t>(model.is_static[i] ? 0 : 1));
    state.sleep_time.push_back(0.0);
    state.island.push_back(-1);
  }

  /// Wakes the sleeping islands labelled in marks_ (see mark): their bodies awake with timers 0,
  /// their stashed forces copied into `cache` (then sorted by key). `purge`: drop them from the
  /// stash now (a user call); else at the end of the step (purge()), so that a step the guard
  /// undoes finds them still stashed. Returns whether any body woke.
  /// bodies: those that may sleep (the World's non-static ones, ascending; null: all), the only ones visited.
  bool wake_marked(const Model& model, State& state, std::vector<CachedContact>& cache, bool purge,
                   const std::vector<BodyIndex>* bodies = nullptr);
  /// Marks the island body i sleeps in to be woken (nothing for a static or awake body).
  void mark(const State& state, BodyIndex i);
  /// Marks the sleeping islands whose kept contacts touch body i (a static or kinematic body that
  /// moves or changes: the islands resting on it wake).
  void mark_touching(const State& state, BodyIndex i);
  /// Marks every sleeping island.
  void mark_all(const Model& model, const State& state);

  /// After contact detection: marks every sleeping island a contact links to a moving body (an
  /// awake dynamic body, or a kinematic one with a velocity). Returns whether any was marked.
  bool mark_touched(const Model& model, const State& state, const std::vector<Contact>& contacts);

  /// The end of a kept step of dt (the islands stage): sleep timers, the islands of `contacts` (the
  /// step's), and the islands whose bodies have all been at rest for time_to_sleep go to sleep:
  /// velocities zeroed, label set, their entries of `cache` (the next step's warm start) moved to
  /// the stash. Nothing happens when sleeping is off.
  /// body_force, body_torque (N): the step's contact forces and torques, the sleepers' kept.
  /// bodies: the bodies that can be awake and dynamic (the World's non-static ones, ascending;
  /// null: all), the only ones visited.
  void end_step(const Model& model, State& state, const SleepSettings& settings, double dt,
                const std::vector<Contact>& contacts, std::vector<CachedContact>& cache,
                const std::vector<Vec3>& body_force, const std::vector<Vec3>& body_torque,
                const std::vector<BodyIndex>* bodies = nullptr);

  /// The step's solved contacts and the sleeping islands' in contact order (pairs by their indices),
  /// written into out (its capacity reused).
  void merge_contacts(const std::vector<Contact>& solved, std::vector<Contact>& out) const;
  /// Adds the sleeping contacts' forces and torques to the step's per-body sums (solver.body_force,
  /// body_torque, N), listing the bodies it adds to as forced.
  void add_forces(solver::SolverData& solver) const;
  /// The sleeping islands' contacts, in contact order.
  const std::vector<Contact>& contacts() const { return contacts_; }

  /// Drops the stashed entries and contacts of bodies that are awake again (after a kept step, or
  /// at once for a user call); nothing to do when nothing woke.
  void purge(const Model& model, const State& state);

  /// set_awake(i, false): the island of body i by `contacts` (the last step's) goes to sleep now.
  /// Returns -1, or the first body of that island that cannot sleep (nothing changed then).
  BodyIndex sleep_island_of(const Model& model, State& state, BodyIndex i, const std::vector<Contact>& contacts,
                            std::vector<CachedContact>& cache, const std::vector<Vec3>& body_force,
                            const std::vector<Vec3>& body_torque);

  /// Before bodies are removed (`gone(k)` true for them): marks the islands of removed sleeping
  /// bodies and of sleeping bodies whose stashed contacts touch a removed body (a support taken away).
  template <class Gone>
  void mark_removed(const State& state, Gone&& gone) {
    for (std::size_t k = 0; k < state.island.size(); ++k)
      if (gone(static_cast<BodyIndex>(k))) mark(state, static_cast<BodyIndex>(k));
    for (const CachedContact& c : stash_) {
      if (gone(c.body_a)) mark(state, c.body_b);
      if (gone(c.body_b)) mark(state, c.body_a);
    }
  }
  /// After removal: labels and stashed entries renumbered by `to` (new index, -1 removed).
  void renumber(State& state, const std::vector<BodyIndex>& to);

  /// The sleeping part of a saved state: per body awake, timer and label, then the stash, then the
  /// sleeping contacts' per-body force and torque (the contacts themselves are the World's to write).
  void save(serial::Writer& w, const State& state) const;
  /// Reads save()'s bytes for n bodies into awake, sleep_time, island, stash, force and torque.
  static void load(serial::Reader& r, std::size_t n, std::vector<std::uint8_t>& awake, std::vector<double>& sleep_time,
                   std::vector<std::int32_t>& island, std::vector<CachedContact>& stash, std::vector<Vec3>& force,
                   std::vector<Vec3>& torque);
  /// Replaces what is kept of sleeping islands (restore_state).
  void assign(std::vector<CachedContact> stash, std::vector<Contact> contacts, std::vector<Vec3> force,
              std::vector<Vec3> torque) {
    stash_ = std::move(stash), contacts_ = std::move(contacts), force_ = std::move(force), torque_ = std::move(torque);
    list_forced(true);
  }
  /// A new body (no sleeping contacts).
  void add_body() { force_.emplace_back(Vec3::Zero()), torque_.emplace_back(Vec3::Zero()), fresh_.clear(); }
  const std::vector<CachedContact>& stash() const { return stash_; }
  /// The World's joints: a joint links its two bodies' islands as a contact does (they sleep and
  /// wake together), and a body jointed to a moving kinematic body stays awake. Null: none.
  void set_joints(const std::vector<Joint>* joints) { joints_ = joints; }

 private:
  /// The island root of body i (path halving).
  int find(int i);
  /// Union-find over the contacts between two awake, enabled dynamic bodies (parent_, sized N; the
  /// entries of `bodies` set, null: all).
  void link(const Model& model, const State& state, const std::vector<Contact>& contacts,
            const std::vector<BodyIndex>* bodies);
  /// Bodies (of `bodies`, null: all) whose root r has ready_[r] fall asleep with label r; their
  /// cache entries move to the stash.
  void sleep_ready(const Model& model, State& state, std::vector<CachedContact>& cache,
                   const std::vector<Contact>& contacts, const std::vector<Vec3>& body_force,
                   const std::vector<Vec3>& body_torque, const std::vector<BodyIndex>* bodies);
  /// forced_ <- the bodies whose force_ or torque_ is not zero (after they change), found among
  /// every body (scan_all) or among forced_ and the bodies of contacts_.
  void list_forced(bool scan_all);
  /// force_, torque_ of the bodies outside sleeping islands (static, kinematic) summed again over contacts_.
  void sum_outside(const State& state);

  std::vector<CachedContact> stash_;  ///< sleeping islands' warm-start forces, sorted by key
  std::vector<Contact> contacts_;     ///< sleeping islands' contacts, in contact order
  std::vector<Contact> merged_;       ///< scratch of sleep_ready
  std::vector<Vec3> force_, torque_;  ///< per body: the force and torque of its sleeping contacts (N)
  std::vector<BodyIndex> forced_;     ///< the bodies whose force_ or torque_ is not zero, ascending
  std::vector<BodyIndex> listing_;    ///< scratch of list_forced
  std::vector<std::int32_t> marked_labels_;  ///< the labels set in marked_
  std::vector<std::uint8_t> fresh_;   ///< per body: fell asleep in this call of sleep_ready (N)
  std::vector<int> parent_;           ///< union-find (N)
  std::vector<std::uint8_t> ready_;   ///< per root: every body of its island may sleep now (N)
  std::vector<std::uint8_t> marked_;  ///< per label: the sleeping island is to be woken (N)
  const std::vector<Joint>* joints_ = nullptr;  ///< the World's joints (links, like contacts)
  bool any_marked_ = false;
  bool to_purge_ = false;  ///< something woke since the last purge
};

/// true when body i is dynamic (not static, not kinematic), enabled and awake.
inline bool awake_dynamic(const Model& model, const State& state, std::size_t i) {
  return !model.is_static[i] && !model.is_kinematic[i] && model.enabled[i] && !state.asleep(i);
}

}  // namespace signorini
