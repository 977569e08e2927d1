// NumPy <-> Eigen marshalling shared by the register_*.cpp files: shape checks with clear errors.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "signorini/contact.hpp"
#include "signorini/shapes.hpp"
#include "signorini/types.hpp"
#include "signorini/world.hpp"

namespace py = pybind11;

namespace signorini::bindings {

/// (n, cols) float64 C-contiguous copy of an array-like, or ValueError "<who>: <what> must have shape (n, cols), got ...".
inline py::array_t<double, py::array::c_style | py::array::forcecast> as_rows(const py::handle& x, py::ssize_t cols,
                                                                             const std::string& who,
                                                                             const std::string& what) {
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(x);
  if (!a) throw py::type_error(who + ": " + what + " must be an array of numbers");
  if (a.ndim() != 2 || a.shape(1) != cols) {
    std::string shape = "(";
    for (py::ssize_t k = 0; k < a.ndim(); ++k) shape += (k ? ", " : "") + std::to_string(a.shape(k));
    shape += a.ndim() == 1 ? ",)" : ")";
    throw py::value_error(who + ": " + what + " must have shape (n, " + std::to_string(cols) + "), got " + shape);
  }
  return a;
}

/// A real number from a Python object, or TypeError "<who>: <what> must be a number, got ..." for
/// bool, str, None and other non-numbers (True is not a radius), ValueError for an int too large
/// for a double. Ranges are the core's to check.
inline double number(const py::handle& x, const std::string& who, const std::string& what) {
  const py::module_ numpy = py::module_::import("numpy");
  const bool is_bool = py::isinstance<py::bool_>(x) || py::isinstance(x, numpy.attr("bool_"));
  const bool is_number = py::isinstance<py::int_>(x) || py::isinstance<py::float_>(x) ||
                         py::isinstance(x, numpy.attr("integer")) || py::isinstance(x, numpy.attr("floating"));
  if (is_bool || !is_number)
    throw py::type_error(who + ": " + what + " must be a number, got " + std::string(py::repr(x)));
  const double value = PyFloat_AsDouble(x.ptr());
  if (value == -1.0 && PyErr_Occurred()) {
    PyErr_Clear();
    throw py::value_error(who + ": " + what + " is too large for a double (at most about 1.8e308)");
  }
  return value;
}

/// (n, 3) array from a vector of Vec3 (a copy: the state vectors may reallocate when bodies are added).
inline py::array_t<double> rows_of(const std::vector<Vec3>& xs) {
  py::array_t<double> out({static_cast<py::ssize_t>(xs.size()), py::ssize_t(3)});
  auto o = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < xs.size(); ++i)
    for (int c = 0; c < 3; ++c) o(i, c) = xs[i][c];
  return out;
}

/// (n, 3, 3) array from a vector of Mat3.
inline py::array_t<double> stack_of(const std::vector<Mat3>& xs) {
  py::array_t<double> out({static_cast<py::ssize_t>(xs.size()), py::ssize_t(3), py::ssize_t(3)});
  auto o = out.mutable_unchecked<3>();
  for (std::size_t i = 0; i < xs.size(); ++i)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) o(i, r, c) = xs[i](r, c);
  return out;
}

/// A read-only NumPy view of memory owned by `owner` (the array's base keeps it alive): shape and
/// strides in elements of T... given in bytes for strides. Empty arrays get their own (empty) data.
template <class T>
py::array readonly_view(const py::handle& owner, const T* data, std::vector<py::ssize_t> shape,
                        std::vector<py::ssize_t> strides) {
  py::array a(py::dtype::of<T>(), std::move(shape), std::move(strides), data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

/// (n, 3) read-only view of the n Vec3 (24-byte rows) at xs, base `owner`.
inline py::array vec3_view(const py::handle& owner, const Vec3* xs, std::size_t n) {
  return readonly_view(owner, n ? xs->data() : nullptr, {static_cast<py::ssize_t>(n), 3},
                       {static_cast<py::ssize_t>(sizeof(Vec3)), sizeof(double)});
}

/// (n, 4) read-only view of the n Quat4 at xs, base `owner`.
inline py::array quat_view(const py::handle& owner, const Quat4* xs, std::size_t n) {
  return readonly_view(owner, n ? xs->data() : nullptr, {static_cast<py::ssize_t>(n), 4},
                       {static_cast<py::ssize_t>(sizeof(Quat4)), sizeof(double)});
}

/// (n, 3, 3) read-only view of the n column-major Mat3 at xs (row stride 1 double, column stride 3).
inline py::array mat3_view(const py::handle& owner, const Mat3* xs, std::size_t n) {
  return readonly_view(owner, n ? xs->data() : nullptr, {static_cast<py::ssize_t>(n), 3, 3},
                       {static_cast<py::ssize_t>(sizeof(Mat3)), sizeof(double), 3 * sizeof(double)});
}

/// Contacts as a dict of read-only views into the shared list (which the base, a capsule holding
/// it, keeps alive and unchanged): body_a, body_b (K,) int32; point, normal, friction, force,
/// slip, arm_a, arm_b (K, 3); gap, alpha, impulse, spin_torque, normal_velocity (K,); feature_a,
/// feature_b (K,) uint64; kept (K,) bool.
inline py::dict contact_views(std::shared_ptr<const std::vector<Contact>> list) {
  const std::vector<Contact>& cs = *list;
  py::capsule owner(new std::shared_ptr<const std::vector<Contact>>(std::move(list)),
                    [](void* p) { delete static_cast<std::shared_ptr<const std::vector<Contact>>*>(p); });
  const auto K = static_cast<py::ssize_t>(cs.size());
  const py::ssize_t row = sizeof(Contact);
  const Contact* c0 = cs.empty() ? nullptr : cs.data();
  // field addresses of the first contact (null for an empty list: the views get their own data)
  auto scalar = [&](const auto* field) {
    using T = std::remove_cv_t<std::remove_pointer_t<decltype(field)>>;
    return readonly_view<T>(owner, c0 ? field : nullptr, {K}, {row});
  };
  auto vector3 = [&](const Vec3* field) { return readonly_view<double>(owner, c0 ? field->data() : nullptr, {K, 3}, {row, sizeof(double)}); };
  static const Contact blank;
  const Contact& c = c0 ? *c0 : blank;
  py::dict d;
  d["body_a"] = scalar(&c.body_a);
  d["body_b"] = scalar(&c.body_b);
  d["point"] = vector3(&c.point);
  d["normal"] = vector3(&c.normal);
  d["gap"] = scalar(&c.gap);
  d["alpha"] = scalar(&c.alpha);
  d["impulse"] = scalar(&c.impulse);
  d["friction"] = vector3(&c.friction);
  d["force"] = vector3(&c.force);
  d["spin_torque"] = scalar(&c.spin_torque);
  d["normal_velocity"] = scalar(&c.normal_velocity);
  d["slip"] = vector3(&c.slip);
  d["feature_a"] = scalar(&c.feature_a);
  d["feature_b"] = scalar(&c.feature_b);
  d["arm_a"] = vector3(&c.arm_a);
  d["arm_b"] = vector3(&c.arm_b);
  d["kept"] = scalar(&c.kept);
  return d;
}

/// A Python shape object (Sphere, Box, Plane, Mesh, Capsule, Cylinder, ConvexHull, TriangleMesh,
/// Compound) as the core's Shape variant (a copy; meshes and hulls share their polytopes).
inline Shape to_shape(const py::handle& x, const std::string& who) {
  if (py::isinstance<Sphere>(x)) return x.cast<Sphere>();
  if (py::isinstance<Box>(x)) return x.cast<Box>();
  if (py::isinstance<Plane>(x)) return x.cast<Plane>();
  if (py::isinstance<Mesh>(x)) return x.cast<Mesh>();
  if (py::isinstance<Capsule>(x)) return x.cast<Capsule>();
  if (py::isinstance<Cylinder>(x)) return x.cast<Cylinder>();
  if (py::isinstance<ConvexHull>(x)) return x.cast<ConvexHull>();
  if (py::isinstance<TriangleMesh>(x)) return x.cast<TriangleMesh>();
  if (py::isinstance<Compound>(x)) return x.cast<Compound>();
  throw py::type_error(who + ": shape must be a Sphere, Box, Plane, Mesh, Capsule, Cylinder, ConvexHull, "
                       "TriangleMesh or Compound, got " + std::string(py::str(py::type::of(x).attr("__name__"))));
}

/// The core's Shape as its Python object.
inline py::object from_shape(const Shape& shape) {
  return std::visit([](const auto& s) { return py::cast(s); }, shape);
}

/// Contacts as a dict of arrays: body_a, body_b (K,) int64; point, normal (K, 3); gap, alpha,
/// impulse, spin_torque, normal_velocity (K,); friction, force, slip, arm_a, arm_b (K, 3);
/// feature_a, feature_b (K,) uint64; kept (K,) bool
/// (docs/conventions.md, "Feature ids" and "The Signorini certificate").
inline py::dict contact_arrays(const std::vector<Contact>& contacts) {
  const auto K = static_cast<py::ssize_t>(contacts.size());
  py::array_t<std::int64_t> a(K), b(K);
  py::array_t<std::uint64_t> fa(K), fb(K);
  py::array_t<double> gap(K), alpha(K), impulse(K), spin_torque(K), vn(K);
  py::array_t<bool> kept(K);
  std::vector<Vec3> point, normal, friction, force, slip, arm_a, arm_b;
  for (py::ssize_t i = 0; i < K; ++i) {
    const Contact& c = contacts[i];
    kept.mutable_at(i) = c.kept;
    arm_a.push_back(c.arm_a);
    arm_b.push_back(c.arm_b);
    a.mutable_at(i) = c.body_a;
    b.mutable_at(i) = c.body_b;
    fa.mutable_at(i) = c.feature_a;
    fb.mutable_at(i) = c.feature_b;
    gap.mutable_at(i) = c.gap;
    alpha.mutable_at(i) = c.alpha;
    impulse.mutable_at(i) = c.impulse;
    spin_torque.mutable_at(i) = c.spin_torque;
    vn.mutable_at(i) = c.normal_velocity;
    point.push_back(c.point);
    normal.push_back(c.normal);
    friction.push_back(c.friction);
    force.push_back(c.force);
    slip.push_back(c.slip);
  }
  py::dict d;
  d["body_a"] = a;
  d["body_b"] = b;
  d["point"] = rows_of(point);
  d["normal"] = rows_of(normal);
  d["gap"] = gap;
  d["alpha"] = alpha;
  d["impulse"] = impulse;
  d["friction"] = rows_of(friction);
  d["force"] = rows_of(force);
  d["spin_torque"] = spin_torque;
  d["normal_velocity"] = vn;
  d["slip"] = rows_of(slip);
  d["feature_a"] = fa;
  d["feature_b"] = fb;
  d["arm_a"] = rows_of(arm_a);
  d["arm_b"] = rows_of(arm_b);
  d["kept"] = kept;
  return d;
}

/// Contact events as a dict of arrays (n events): step, body_a, body_b (n,) int64; point, normal
/// (n, 3) world; speed (n,) m/s; impulse (n,) N s.
inline py::dict event_arrays(const std::vector<ContactEvent>& events) {
  const auto n = static_cast<py::ssize_t>(events.size());
  py::array_t<std::int64_t> step(n), a(n), b(n);
  py::array_t<double> speed(n), impulse(n);
  std::vector<Vec3> point, normal;
  for (py::ssize_t i = 0; i < n; ++i) {
    const ContactEvent& e = events[static_cast<std::size_t>(i)];
    step.mutable_at(i) = e.step;
    a.mutable_at(i) = e.body_a;
    b.mutable_at(i) = e.body_b;
    speed.mutable_at(i) = e.speed;
    impulse.mutable_at(i) = e.impulse;
    point.push_back(e.point);
    normal.push_back(e.normal);
  }
  py::dict d;
  d["step"] = step;
  d["body_a"] = a;
  d["body_b"] = b;
  d["point"] = rows_of(point);
  d["normal"] = rows_of(normal);
  d["speed"] = speed;
  d["impulse"] = impulse;
  return d;
}

/// The warm-start cache as a dict of arrays: body_a, body_b (K,) int64; feature_a, feature_b (K,)
/// uint64; alpha (K,) N; friction (K, 3) N, world; spin (K,) N m.
inline py::dict cache_arrays(const std::vector<CachedContact>& cache) {
  const auto K = static_cast<py::ssize_t>(cache.size());
  py::array_t<std::int64_t> a(K), b(K);
  py::array_t<std::uint64_t> fa(K), fb(K);
  py::array_t<double> alpha(K), spin(K);
  std::vector<Vec3> friction;
  for (py::ssize_t i = 0; i < K; ++i) {
    const CachedContact& c = cache[i];
    a.mutable_at(i) = c.body_a;
    b.mutable_at(i) = c.body_b;
    fa.mutable_at(i) = c.feature_a;
    fb.mutable_at(i) = c.feature_b;
    alpha.mutable_at(i) = c.alpha;
    spin.mutable_at(i) = c.spin;
    friction.push_back(c.friction);
  }
  py::dict d;
  d["body_a"] = a;
  d["body_b"] = b;
  d["feature_a"] = fa;
  d["feature_b"] = fb;
  d["alpha"] = alpha;
  d["friction"] = rows_of(friction);
  d["spin"] = spin;
  return d;
}

// ---- pickling at every protocol: pybind11's py::pickle serves protocols 2 to 5 through
// __getstate__ / __setstate__; at 0 and 1, and for a direct __reduce__(), Python's default
// reduction builds the object with object.__new__, which pybind11 answers by aborting the process.

/// Gives a class with py::pickle __reduce_ex__ and __reduce__ that work at every protocol:
/// (copyreg.__newobj__, (cls,), state), as protocol 2's NEWOBJ does.
template <class Class>
void pickle_at_every_protocol(Class cls) {
  auto reduce = [](const py::object& self) -> py::tuple {
    const py::object newobj = py::module_::import("copyreg").attr("__newobj__");
    const py::object state = self.attr("__getstate__")();
    return py::make_tuple(newobj, py::make_tuple(py::type::of(self)), state);
  };
  cls.def("__reduce_ex__", [reduce](const py::object& self, int) -> py::tuple { return reduce(self); },
          py::arg("protocol"));
  cls.def("__reduce__", reduce);
}

/// Refuses pickling at every protocol with a TypeError that says what to pickle instead.
template <class Class>
void refuse_pickling(Class cls, const std::string& instead) {
  const std::string message = "cannot pickle a signorini._core." +
                              std::string(py::str(cls.attr("__name__"))) + ": " + instead;
  auto refuse = [message](const py::object&) -> py::tuple { throw py::type_error(message); };
  cls.def("__reduce_ex__", [refuse](const py::object& self, int) -> py::tuple { return refuse(self); },
          py::arg("protocol"));
  cls.def("__reduce__", refuse);
}

}  // namespace signorini::bindings
