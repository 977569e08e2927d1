// Shapes and mass_properties. Constructors validate in C++ (std::invalid_argument -> ValueError).
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <sstream>

#include "arrays.hpp"
#include "signorini/mass_properties.hpp"
#include "signorini/shapes.hpp"

using namespace signorini;

namespace {

Vec3 vec3(const py::handle& x, const std::string& who, const std::string& what) {
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(x);
  if (!a) throw py::type_error(who + ": " + what + " must be 3 numbers");
  if (a.ndim() != 1 || a.shape(0) != 3)
    throw py::value_error(who + ": " + what + " must have shape (3,), got " + std::string(py::str(py::tuple(a.attr("shape")))));
  return Vec3(a.at(0), a.at(1), a.at(2));
}

std::string str(const Vec3& x) {
  std::ostringstream s;
  s << "(" << x.x() << ", " << x.y() << ", " << x.z() << ")";
  return s.str();
}

}  // namespace

void register_shapes(py::module_& m) {
  py::class_<Sphere>(m, "Sphere", "Ball of the given radius (m), centred at the body origin.")
      .def(py::init<double>(), py::arg("radius"))
      .def_readonly("radius", &Sphere::radius)
      .def("__repr__", [](const Sphere& s) { return "Sphere(radius=" + std::to_string(s.radius) + ")"; });

  py::class_<Box>(m, "Box", "Box with half extents (a, b, c) (m) along the body axes.")
      .def(py::init([](const py::object& h) { return Box(vec3(h, "Box", "half_extents")); }), py::arg("half_extents"))
      .def_readonly("half_extents", &Box::half_extents)
      .def("__repr__", [](const Box& b) { return "Box(half_extents=" + str(b.half_extents) + ")"; });

  py::class_<Plane>(m, "Plane",
                    "Static plane n . x = offset (n normalised); bodies live on the side n . x > offset.")
      .def(py::init([](const py::object& n, double d) { return Plane(vec3(n, "Plane", "normal"), d); }),
           py::arg("normal"), py::arg("offset") = 0.0)
      .def_readonly("normal", &Plane::normal)
      .def_readonly("offset", &Plane::offset)
      .def("__repr__", [](const Plane& p) { return "Plane(normal=" + str(p.normal) + ", offset=" + std::to_string(p.offset) + ")"; });

  py::class_<Mesh>(m, "Mesh",
                   "Triangle mesh: vertices (n, 3) in m, faces (k, 3) vertex indices, counter-clockwise seen "
                   "from outside. A dynamic mesh must be closed; its body frame is its centre of mass.")
      .def(py::init([](const py::object& vertices, const py::object& faces) {
             auto v = bindings::as_rows(vertices, 3, "Mesh", "vertices");
             auto fa = py::array::ensure(faces);
             if (!fa || !(fa.dtype().kind() == 'i' || fa.dtype().kind() == 'u'))
               throw py::type_error("Mesh: faces must be an integer array of shape (k, 3)");
             auto f = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(fa);
             if (f.ndim() != 2 || f.shape(1) != 3)
               throw py::value_error("Mesh: faces must have shape (k, 3), got " + std::string(py::str(py::tuple(f.attr("shape")))));
             Points P = Eigen::Map<const Points>(v.data(), v.shape(0), 3);
             Triangles T = Eigen::Map<const Triangles>(f.data(), f.shape(0), 3);
             return Mesh(std::move(P), std::move(T));
           }),
           py::arg("vertices"), py::arg("faces"))
      .def_readonly("vertices", &Mesh::vertices)
      .def_readonly("faces", &Mesh::faces)
      .def("is_convex", &Mesh::is_convex)
      .def("closedness_problem", &Mesh::closedness_problem,
           "Empty when closed and consistently oriented; otherwise what is wrong.")
      .def("__repr__", [](const Mesh& mesh) {
        return "Mesh(" + std::to_string(mesh.vertices.rows()) + " vertices, " + std::to_string(mesh.faces.rows()) + " faces)";
      });

  m.def(
      "mass_properties",
      [](const py::object& shape, double density) {
        const MassProperties mp = mass_properties(bindings::to_shape(shape, "mass_properties"), density);
        return py::make_tuple(mp.mass, mp.com, mp.inertia);
      },
      py::arg("shape"), py::arg("density"),
      "(mass kg, com (3,) m in the shape frame, inertia (3, 3) kg m^2 about the com) for a uniform density.");
}
