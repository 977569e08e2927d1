// Model: the static description of the bodies (mjModel's role). Written by World::add_body and the
// material setter, read by every stage of the step (collision, dynamics, solver).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "signorini/shapes.hpp"
#include "signorini/types.hpp"

namespace signorini {

/// Material of one body. The pair values a contact uses (docs/conventions.md, "Materials"):
/// friction mu = sqrt(mu_A mu_B), restitution e = max(e_A, e_B), spinning friction
/// mu_spin = max(mu_spin_A, mu_spin_B).
struct Material {
  double friction = 0.5;     ///< Coulomb coefficient mu >= 0 (dimensionless)
  double restitution = 0.0;  ///< Newton's coefficient e in [0, 1] (dimensionless)
  /// Torsional coefficient mu_spin >= 0 (m): at a contact that is its body pair's only point, the
  /// torque about the normal is bounded by mu_spin alpha_n (N m). 0 (the default): no such torque,
  /// and no row is made (docs/conventions.md, "Materials" and step 3).
  double spinning_friction = 0.0;
};

/// Which bodies may touch (Box2D's category and mask bits, Bullet's group and mask): bodies i and
/// j collide when (group_i & mask_j) != 0 and (group_j & mask_i) != 0. The defaults collide with
/// everything.
struct CollisionFilter {
  std::uint32_t group = 1;            ///< the categories the body belongs to (bits)
  std::uint32_t mask = 0xFFFFFFFFu;   ///< the categories it collides with (bits)
};

/// One entry per body, in the order added (static bodies included).
struct Model {
  std::vector<Shape> shape;      ///< body frame; a dynamic mesh is re-centred on its com
  std::vector<bool> is_static;
  std::vector<double> mass;      ///< kg (infinity for static)
  std::vector<double> inv_mass;  ///< 1/kg (0 for static)
  std::vector<Mat3> I_body;      ///< inertia about the com, body axes (kg m^2; zero for static)
  std::vector<Mat3> I_body_inv;  ///< its inverse (zero for static)
  std::vector<double> rho;       ///< bounding radius about the body origin (m; inf for a plane)
  std::vector<double> inner;     ///< radius of a ball the shape contains (m; inner_radius(), inf for a plane)
  std::vector<Material> material;///< friction, restitution, spinning friction
  /// moved by its own velocity only (no gravity, no forces, no contact impulses): infinite mass in
  /// the solver (inv_mass and I_body_inv zero while kinematic; mass and I_body keep the body's own,
  /// infinity and zero when it was added without a mass)
  std::vector<bool> is_kinematic;
  std::vector<bool> enabled;     ///< a disabled body neither moves nor collides
  /// false: the body never falls asleep, nor does any island it is in (docs/conventions.md, "Sleeping")
  std::vector<bool> can_sleep;
  /// a sensor's contacts are found but never solved or reported: its overlaps with non-sensor
  /// bodies are its sensor events (docs/conventions.md, "Sensors")
  std::vector<bool> is_sensor;
  /// swept against the static bodies after every step, however slowly it moves (docs/conventions.md,
  /// "Shape casts and continuous collision"; other dynamic bodies only when fast)
  std::vector<bool> bullet;
  std::vector<CollisionFilter> filter;
  std::vector<std::string> name; ///< "" when unnamed; otherwise unique in the world
  /// pairs (i, j), i < j, that never collide whatever their filters say; sorted
  std::vector<std::pair<int, int>> excluded_pairs;
  /// pairs (i, j), i < j, held by a joint with collide_connected false (one entry per such joint):
  /// they never collide either; sorted. Written by the World from its joints.
  std::vector<std::pair<int, int>> joined_pairs;

  std::size_t size() const { return shape.size(); }

  /// Calls f on each per-body array in the order above (excluded_pairs is not one): the one list
  /// of the fields, used to remove bodies, so that a new field is added here only.
  template <class F>
  void for_each_array(F&& f) {
    f(shape), f(is_static), f(mass), f(inv_mass), f(I_body), f(I_body_inv), f(rho), f(inner), f(material), f(is_kinematic),
        f(enabled), f(can_sleep), f(is_sensor), f(bullet), f(filter), f(name);
  }

  /// true when bodies i and j may get contacts: both enabled, at least one of them moved by
  /// contacts (finite mass: two static or kinematic bodies cannot push each other), their filters
  /// match and the pair is not excluded. O(log of the excluded pairs); allocates nothing.
  bool can_collide(int i, int j) const {
    if (!enabled[i] || !enabled[j]) return false;
    if (inv_mass[i] == 0.0 && inv_mass[j] == 0.0) return false;
    if (!(filter[i].group & filter[j].mask) || !(filter[j].group & filter[i].mask)) return false;
    const auto key = std::make_pair(std::min(i, j), std::max(i, j));
    if (!joined_pairs.empty() && std::binary_search(joined_pairs.begin(), joined_pairs.end(), key)) return false;
    return excluded_pairs.empty() || !std::binary_search(excluded_pairs.begin(), excluded_pairs.end(), key);
  }

  /// Appends the defaults of the fields after `material` for one body (for models built by hand:
  /// dynamic or static as is_static says, enabled, able to sleep, colliding with everything, unnamed).
  void push_defaults() {
    is_kinematic.push_back(false);
    enabled.push_back(true);
    can_sleep.push_back(true);
    is_sensor.push_back(false);
    bullet.push_back(false);
    filter.push_back(CollisionFilter());
    name.emplace_back();
  }
};

}  // namespace signorini
