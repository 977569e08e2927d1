// collide(): the narrow phase without a world. Poses arrive checked by the Python layer.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "arrays.hpp"
#include "signorini/collide.hpp"

using namespace signorini;

void register_collision(py::module_& m) {
  m.def(
      "collide",
      [](const py::object& shape_a, const Vec3& p_a, const Quat4& q_a, const py::object& shape_b, const Vec3& p_b,
         const Quat4& q_b, double margin) {
        const Shape a = bindings::to_shape(shape_a, "collide: shape_a");
        const Shape b = bindings::to_shape(shape_b, "collide: shape_b");
        return bindings::contact_arrays(collide(a, p_a, q_a, b, p_b, q_b, margin));
      },
      py::arg("shape_a"), py::arg("position_a"), py::arg("orientation_a"), py::arg("shape_b"),
      py::arg("position_b"), py::arg("orientation_b"), py::arg("margin") = 0.0,
      "Contact arrays (as World.contacts) of shape_a and shape_b at the given poses; normals from A to B.");
}
