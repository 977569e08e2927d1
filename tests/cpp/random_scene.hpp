// Seeded random scenes written once and shared by the C++ tests (tests/cpp/test_broad_phase.cpp,
// test_contacts.cpp) and the collision benchmark (benchmarks/bench_collision.cpp): a tessellated
// floor, random
// rotations, random convex shapes, and a Model + State of bodies scattered in a cube, built
// without a World so that the broad phase and the narrow phase can be driven stage by stage; and, for
// the World tests, a ground plane and a World's motion as bytes to compare runs bit for bit.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "collision/collision.hpp"
#include "signorini/shapes.hpp"
#include "signorini/world.hpp"

namespace signorini::scenes {

/// A flat floor [-s, s]^2 at z = 0 of n x n cells, 2 n^2 triangles, facing +z.
inline TriangleMesh floor_mesh(double s, int n) {
  Points v((n + 1) * (n + 1), 3);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) v.row(i * (n + 1) + j) << -s + 2 * s * i / n, -s + 2 * s * j / n, 0.0;
  Triangles f(2 * n * n, 3);
  int k = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int a = i * (n + 1) + j, b = a + (n + 1), c = b + 1, d = a + 1;
      f.row(k++) << a, b, c;
      f.row(k++) << a, c, d;
    }
  return TriangleMesh(v, f);
}

/// Uniform random rotation (a normalised 4-d Gaussian as a quaternion).
inline Mat3 random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  return q.normalized().toRotationMatrix();
}

/// Rotation by a random axis through an angle uniform in [0, max_angle] (rad).
inline Mat3 small_rotation(std::mt19937_64& rng, double max_angle) {
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, max_angle);
  const Vec3 axis = Vec3(g(rng), g(rng), g(rng)).normalized();
  return Eigen::AngleAxisd(u(rng), axis).toRotationMatrix();
}

/// Vector with components uniform in [-s, s].
inline Vec3 random_vector(std::mt19937_64& rng, double s) {
  std::uniform_real_distribution<double> u(-s, s);
  return Vec3(u(rng), u(rng), u(rng));
}

/// Convex hull of n points uniform in the box [-h, h] (body frame, m).
inline ConvexHull random_hull(std::mt19937_64& rng, int n, const Vec3& h) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Points pts(n, 3);
  for (int k = 0; k < n; ++k) pts.row(k) << h.x() * u(rng), h.y() * u(rng), h.z() * u(rng);
  return ConvexHull(pts);
}

/// Which shapes random_shape may draw.
enum class Mix { BoxesAndSpheres, AllConvex };

/// A random convex shape with sizes (radii, half extents) in [lo, hi] m. BoxesAndSpheres draws
/// boxes for even k and spheres for odd k (half each); AllConvex draws sphere, box, capsule,
/// cylinder or a 12-point hull at random.
inline Shape random_shape(std::mt19937_64& rng, Mix mix, int k, double lo, double hi) {
  std::uniform_real_distribution<double> size(lo, hi);
  int kind = (k % 2 == 0) ? 1 : 0;
  if (mix == Mix::AllConvex) kind = std::uniform_int_distribution<int>(0, 4)(rng);
  switch (kind) {
    case 0: return Sphere(size(rng));
    case 1: return Box(Vec3(size(rng), size(rng), size(rng)));
    case 2: return Capsule(size(rng), size(rng));
    case 3: return Cylinder(size(rng), size(rng));
    default: return random_hull(rng, 12, Vec3(size(rng), size(rng), size(rng)));
  }
}

/// Bodies as the broad phase and the narrow phase see them: the Model's shape, is_static and rho
/// (bounding radius about the body origin; masses are not needed and left unit/zero), and a State.
struct Scene {
  Model model;
  State state;
  /// Appends a body; static bodies get zero velocities.
  void add(Shape shape, bool is_static, const Vec3& p, const Mat3& R, const Vec3& v, const Vec3& omega) {
    model.rho.push_back(bounding_radius(shape));
    model.inner.push_back(inner_radius(shape));
    model.shape.push_back(std::move(shape));
    model.is_static.push_back(is_static);
    model.mass.push_back(1.0);
    model.inv_mass.push_back(is_static ? 0.0 : 1.0);
    model.I_body.push_back(Mat3::Identity());
    model.I_body_inv.push_back(is_static ? Mat3(Mat3::Zero()) : Mat3(Mat3::Identity()));
    state.p.push_back(p);
    state.R.push_back(R);
    state.v.push_back(is_static ? Vec3(Vec3::Zero()) : v);
    state.omega.push_back(is_static ? Vec3(Vec3::Zero()) : omega);
    state.q.push_back(Quat4(1, 0, 0, 0));  // not read by collision
    for (std::vector<Vec3>* x : {&state.f_ext, &state.tau_ext, &state.f_step, &state.tau_step, &state.impulse,
                                 &state.angular_impulse})
      x->push_back(Vec3::Zero());
    model.push_defaults();
  }
  std::size_t size() const { return model.size(); }
};

/// n bodies at positions uniform in the cube [0, side]^3 with random orientations, speeds
/// |v_k| <= max_speed (m/s) and |omega_k| <= max_spin (rad/s) per component; a fraction
/// static_fraction of them static.
inline Scene random_scene(std::uint64_t seed, int n, Mix mix, double side, double lo, double hi,
                          double max_speed, double max_spin, double static_fraction) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Scene scene;
  for (int k = 0; k < n; ++k) {
    Shape shape = random_shape(rng, mix, k, lo, hi);
    const Vec3 p(side * u(rng), side * u(rng), side * u(rng));
    const Mat3 R = random_rotation(rng);
    const Vec3 v = random_vector(rng, max_speed), omega = random_vector(rng, max_spin);
    const bool is_static = u(rng) < static_fraction;
    scene.add(std::move(shape), is_static, p, R, v, omega);
  }
  return scene;
}

/// Registers every body of the scene with a broad phase, in index order.
inline void register_bodies(const Scene& scene, collision::BroadPhase& broad_phase) {
  for (std::size_t i = 0; i < scene.size(); ++i)
    broad_phase.add_body(static_cast<BodyIndex>(i), scene.model.shape[i], scene.model.is_static[i],
                         scene.state.p[i], scene.state.R[i]);
}

/// Moves every dynamic body by one step of dt with its velocities (p += v dt, R <- exp([omega] dt) R,
/// re-orthonormalised), reflecting velocities off the walls of the cube [0, side]^3 so that the
/// density stays constant.
inline void drift(Scene& scene, double dt, double side) {
  State& s = scene.state;
  for (std::size_t i = 0; i < scene.size(); ++i) {
    if (scene.model.is_static[i]) continue;
    s.p[i] += dt * s.v[i];
    for (int a = 0; a < 3; ++a) {
      if ((s.p[i][a] < 0.0 && s.v[i][a] < 0.0) || (s.p[i][a] > side && s.v[i][a] > 0.0)) s.v[i][a] = -s.v[i][a];
    }
    const double angle = s.omega[i].norm() * dt;
    if (angle > 0.0) {
      const Mat3 turn = Eigen::AngleAxisd(angle, s.omega[i].normalized()).toRotationMatrix();
      const Mat3 R = turn * s.R[i];
      s.R[i] = 1.5 * R - 0.5 * R * R.transpose() * R;
    }
  }
}

/// A static ground plane z = 0 (normal +z).
inline BodyDesc ground() {
  BodyDesc d;
  d.shape = Plane(Vec3::UnitZ(), 0.0);
  d.is_static = true;
  return d;
}

/// A world's motion as numbers to compare bit for bit: every body's p, v and omega, then every
/// contact's normal force.
inline std::vector<double> motion_bytes(const World& world) {
  std::vector<double> bytes;
  for (std::size_t i = 0; i < world.state().p.size(); ++i)
    for (const Vec3& x : {world.state().p[i], world.state().v[i], world.state().omega[i]})
      bytes.insert(bytes.end(), x.data(), x.data() + 3);
  for (const Contact& c : world.contacts()) bytes.push_back(c.alpha);
  return bytes;
}

}  // namespace signorini::scenes
