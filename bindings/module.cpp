// signorini._core: the pybind11 extension. Thin: argument marshalling only, no physics.
#include <pybind11/pybind11.h>

namespace py = pybind11;

void register_shapes(py::module_& m);
void register_world(py::module_& m);
void register_collision(py::module_& m);
void register_rotation(py::module_& m);
void register_queries(py::module_& m);

PYBIND11_MODULE(_core, m) {
  m.doc() = "signorini C++ core (private; use the signorini package)";
  register_shapes(m);
  register_world(m);
  register_collision(m);
  register_rotation(m);
  register_queries(m);
}
