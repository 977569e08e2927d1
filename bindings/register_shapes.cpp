// Shapes and mass_properties. Constructors validate in C++ (std::invalid_argument -> ValueError).
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <sstream>
#include <utility>
#include <vector>

#include "arrays.hpp"
#include "signorini/mass_properties.hpp"
#include "signorini/shapes.hpp"

using namespace signorini;

namespace {

Vec3 vec3(const py::handle& x, const std::string& who, const std::string& what) {
  // bools are not lengths, and neither are strings (which NumPy would parse)
  auto raw = py::array::ensure(x);
  if (!raw || raw.dtype().kind() == 'b' || raw.dtype().kind() == 'U' || raw.dtype().kind() == 'S' ||
      raw.dtype().kind() == 'O')
    throw py::type_error(who + ": " + what + " must be 3 numbers, got " + std::string(py::repr(x)));
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

/// (k, 3) int64 triangle indices from an integer array-like, or TypeError / ValueError naming who.
Triangles triangles(const py::object& faces, const std::string& who) {
  auto fa = py::array::ensure(faces);
  if (!fa || !(fa.dtype().kind() == 'i' || fa.dtype().kind() == 'u'))
    throw py::type_error(who + ": faces must be an integer array of shape (k, 3)");
  auto f = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(fa);
  if (f.ndim() != 2 || f.shape(1) != 3)
    throw py::value_error(who + ": faces must have shape (k, 3), got " + std::string(py::str(py::tuple(f.attr("shape")))));
  return Eigen::Map<const Triangles>(f.data(), f.shape(0), 3);
}

Points points(const py::object& x, const std::string& who, const std::string& what) {
  auto v = bindings::as_rows(x, 3, who, what);
  return Eigen::Map<const Points>(v.data(), v.shape(0), 3);
}

/// A read-only (n, 3) copy of a polytope's or hull's vertices.
py::array_t<double> readonly_rows(const Points& p) {
  py::array_t<double> out({static_cast<py::ssize_t>(p.rows()), py::ssize_t(3)});
  std::copy(p.data(), p.data() + p.size(), out.mutable_data());
  out.attr("flags").attr("writeable") = false;
  return out;
}

/// One compound part from (shape, (position, orientation)); errors name the part index.
Compound::Part compound_part(const py::handle& item, std::size_t i) {
  const std::string who = "Compound: part " + std::to_string(i);
  if (!py::isinstance<py::sequence>(item) || py::isinstance<py::str>(item) || py::len(item) != 2)
    throw py::type_error(who + " must be (shape, (position, orientation)), got " + std::string(py::repr(item)));
  const py::sequence pair = py::reinterpret_borrow<py::sequence>(item);
  const py::object pose = pair[1];
  if (!py::isinstance<py::sequence>(pose) || py::isinstance<py::str>(pose) || py::len(pose) != 2)
    throw py::type_error(who + ": pose must be (position, orientation), got " + std::string(py::repr(pose)));
  const py::sequence pq = py::reinterpret_borrow<py::sequence>(pose);
  const Vec3 position = vec3(pq[0], who, "position");
  auto q = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(pq[1]);
  if (!q) throw py::type_error(who + ": orientation must be 4 numbers (w, x, y, z)");
  // a (3, 3) orientation is the rotation matrix itself, kept exactly (scene files write one when
  // the part's quaternion would not give back its matrix to the bit)
  const bool is_matrix = q.ndim() == 2 && q.shape(0) == 3 && q.shape(1) == 3;
  if (!is_matrix && (q.ndim() != 1 || q.shape(0) != 4))
    throw py::value_error(who + ": orientation must have shape (4,), got " + std::string(py::str(py::tuple(q.attr("shape")))));
  Quat4 orientation = Quat4(1.0, 0.0, 0.0, 0.0);
  Mat3 rotation = Mat3::Identity();
  if (is_matrix)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) rotation(r, c) = q.at(r, c);
  else
    orientation = Quat4(q.at(0), q.at(1), q.at(2), q.at(3));
  const py::object s = pair[0];
  Primitive shape = Sphere(1.0);
  if (py::isinstance<Sphere>(s)) shape = s.cast<Sphere>();
  else if (py::isinstance<Box>(s)) shape = s.cast<Box>();
  else if (py::isinstance<Capsule>(s)) shape = s.cast<Capsule>();
  else if (py::isinstance<Cylinder>(s)) shape = s.cast<Cylinder>();
  else if (py::isinstance<ConvexHull>(s)) shape = s.cast<ConvexHull>();
  else if (py::isinstance<Mesh>(s)) {
    const Mesh& mesh = s.cast<const Mesh&>();
    if (!mesh.is_convex())
      throw py::value_error(who + ": a Mesh part must be convex (it becomes the ConvexHull of its vertices); "
                                  "split a non-convex mesh into convex parts");
    try {
      shape = ConvexHull(mesh.vertices);
    } catch (const std::invalid_argument& e) {
      throw py::value_error(who + ": " + e.what());
    }
  } else {
    throw py::type_error(who + ": shape must be a Sphere, Box, Capsule, Cylinder, ConvexHull or convex Mesh, got " +
                         std::string(py::str(py::type::of(s).attr("__name__"))));
  }
  if (is_matrix) return Compound::Part{std::move(shape), position, rotation};  // checked by Compound
  try {
    return Compound::make_part(std::move(shape), position, orientation);
  } catch (const std::invalid_argument& e) {
    throw py::value_error(who + ": " + e.what());
  }
}

// ---- pickling: each shape as its constructor's arguments; the derived polytopes of hulls and
// mesh pieces are kept exactly as they are (a re-run of Qhull could order faces differently, and a
// pickled world must step bit-identically)

py::tuple polytope_state(const Polytope& p) {
  py::list faces, face_edges;
  for (const auto& f : p.faces) faces.append(py::cast(f));
  for (const auto& f : p.face_edges) face_edges.append(py::cast(f));
  py::array_t<int> edges({static_cast<py::ssize_t>(p.edges.size()), py::ssize_t(4)});
  for (std::size_t k = 0; k < p.edges.size(); ++k) {
    const Polytope::Edge& e = p.edges[k];
    edges.mutable_at(k, 0) = e.v0;
    edges.mutable_at(k, 1) = e.v1;
    edges.mutable_at(k, 2) = e.f0;
    edges.mutable_at(k, 3) = e.f1;
  }
  return py::make_tuple(p.vertices, faces, bindings::rows_of(p.normals), py::cast(p.offsets),
                        edges, face_edges, p.centroid);
}

std::shared_ptr<const Polytope> polytope_from_state(const py::handle& state) {
  const auto t = py::reinterpret_borrow<py::tuple>(state);
  if (t.size() != 7) throw py::value_error("polytope state must have 7 items");
  auto p = std::make_shared<Polytope>();
  p->vertices = points(t[0], "Polytope", "vertices");
  p->faces = t[1].cast<std::vector<std::vector<int>>>();
  const Points normals = points(t[2], "Polytope", "normals");
  for (Eigen::Index k = 0; k < normals.rows(); ++k) p->normals.push_back(normals.row(k).transpose());
  p->offsets = t[3].cast<std::vector<double>>();
  const auto edges = py::array_t<int, py::array::c_style | py::array::forcecast>::ensure(t[4]);
  if (!edges || edges.ndim() != 2 || edges.shape(1) != 4) throw py::value_error("polytope edges must have shape (E, 4)");
  for (py::ssize_t k = 0; k < edges.shape(0); ++k)
    p->edges.push_back({edges.at(k, 0), edges.at(k, 1), edges.at(k, 2), edges.at(k, 3)});
  p->face_edges = t[5].cast<std::vector<std::vector<int>>>();
  p->centroid = t[6].cast<Vec3>();
  return p;
}

/// A compound part's primitive from its Python object.
Primitive primitive(const py::handle& s) {
  if (py::isinstance<Sphere>(s)) return s.cast<Sphere>();
  if (py::isinstance<Box>(s)) return s.cast<Box>();
  if (py::isinstance<Capsule>(s)) return s.cast<Capsule>();
  if (py::isinstance<Cylinder>(s)) return s.cast<Cylinder>();
  if (py::isinstance<ConvexHull>(s)) return s.cast<ConvexHull>();
  throw py::type_error("Compound: a part must be a Sphere, Box, Capsule, Cylinder or ConvexHull");
}

}  // namespace

void register_shapes(py::module_& m) {
  py::class_<Sphere>(m, "Sphere", "Ball of the given radius (m), centred at the body origin.")
      .def(py::init([](const py::object& r) { return Sphere(bindings::number(r, "Sphere", "radius")); }), py::arg("radius"))
      .def_readonly("radius", &Sphere::radius)
      .def("__repr__", [](const Sphere& s) { return "Sphere(radius=" + std::to_string(s.radius) + ")"; })
      .def(py::pickle([](const Sphere& s) { return py::make_tuple(s.radius); },
                      [](const py::tuple& t) { return Sphere(t[0].cast<double>()); }));

  py::class_<Box>(m, "Box", "Box with half extents (a, b, c) (m) along the body axes.")
      .def(py::init([](const py::object& h) { return Box(vec3(h, "Box", "half_extents")); }), py::arg("half_extents"))
      .def_readonly("half_extents", &Box::half_extents)
      .def("__repr__", [](const Box& b) { return "Box(half_extents=" + str(b.half_extents) + ")"; })
      .def(py::pickle([](const Box& b) { return py::make_tuple(b.half_extents); },
                      [](const py::tuple& t) { return Box(t[0].cast<Vec3>()); }));

  py::class_<Plane>(m, "Plane",
                    "Static plane n . x = offset (n normalised); bodies live on the side n . x > offset.")
      .def(py::init([](const py::object& n, const py::object& d) {
             return Plane(vec3(n, "Plane", "normal"), bindings::number(d, "Plane", "offset"));
           }),
           py::arg("normal"), py::arg("offset") = 0.0)
      .def_readonly("normal", &Plane::normal)
      .def_readonly("offset", &Plane::offset)
      .def("__repr__", [](const Plane& p) { return "Plane(normal=" + str(p.normal) + ", offset=" + std::to_string(p.offset) + ")"; })
      .def(py::pickle([](const Plane& p) { return py::make_tuple(p.normal, p.offset); },
                      [](const py::tuple& t) {
                        Plane p(t[0].cast<Vec3>(), t[1].cast<double>());
                        p.normal = t[0].cast<Vec3>();  // as stored: normalising again may move the last bit
                        return p;
                      }));

  py::class_<Mesh>(m, "Mesh",
                   "Triangle mesh: vertices (n, 3) in m, faces (k, 3) vertex indices, counter-clockwise seen "
                   "from outside. A dynamic mesh must be closed; its body frame is its centre of mass. A "
                   "non-convex one collides through convex pieces (see with_pieces).")
      .def(py::init([](const py::object& vertices, const py::object& faces) {
             return Mesh(points(vertices, "Mesh", "vertices"), triangles(faces, "Mesh"));
           }),
           py::arg("vertices"), py::arg("faces"),
           "A mesh from vertices (n, 3) float, m, and faces (k, 3) int, vertex indices of triangles "
           "counter-clockwise seen from outside. Needs at least 3 finite vertices and one face; a face "
           "indexing a missing vertex or of zero area raises ValueError. Closedness and winding are "
           "checked when it is added as a dynamic body (closedness_problem() says what is wrong); a "
           "non-convex one is decomposed then (signorini.decompose). To read a file: signorini.load_mesh.")
      .def_readonly("vertices", &Mesh::vertices)
      .def_readonly("faces", &Mesh::faces)
      .def("is_convex", &Mesh::is_convex)
      .def("closedness_problem", &Mesh::closedness_problem,
           "Empty when closed and consistently oriented; otherwise what is wrong.")
      .def(
          "with_pieces",
          [](const Mesh& mesh, const py::iterable& pieces) {
            Mesh out = mesh;
            out.pieces.clear();
            std::size_t i = 0;
            for (const py::handle& piece : pieces) {
              const std::string who = "Mesh.with_pieces: piece " + std::to_string(i++);
              try {
                out.pieces.push_back(ConvexHull(points(py::reinterpret_borrow<py::object>(piece), who, "vertices")).polytope);
              } catch (const std::invalid_argument& e) {
                throw py::value_error(who + ": " + e.what());
              }
            }
            return out;
          },
          py::arg("pieces"),
          "A copy of this mesh whose convex pieces (for collisions) are the convex hulls of the given (n_i, 3) "
          "vertex arrays (m, mesh frame). Mass properties stay those of the mesh itself.")
      .def_property_readonly(
          "pieces",
          [](const Mesh& mesh) {
            py::list out;
            for (const auto& piece : mesh.pieces) out.append(readonly_rows(piece->vertices));
            return out;
          },
          "The convex pieces' hull vertices, a list of read-only (n_i, 3) arrays (empty when none).")
      .def("__repr__", [](const Mesh& mesh) {
        std::string s = "Mesh(" + std::to_string(mesh.vertices.rows()) + " vertices, " + std::to_string(mesh.faces.rows()) + " faces";
        if (!mesh.pieces.empty()) s += ", " + std::to_string(mesh.pieces.size()) + (mesh.pieces.size() == 1 ? " convex piece" : " convex pieces");
        return s + ")";
      })
      .def(py::pickle(
          [](const Mesh& mesh) {
            py::list pieces;
            for (const auto& piece : mesh.pieces) pieces.append(polytope_state(*piece));
            return py::make_tuple(mesh.vertices, mesh.faces, pieces);
          },
          [](const py::tuple& t) {
            Mesh mesh(points(t[0], "Mesh", "vertices"), triangles(t[1], "Mesh"));
            for (const py::handle& piece : t[2].cast<py::list>()) mesh.pieces.push_back(polytope_from_state(piece));
            return mesh;
          }));

  py::class_<Capsule>(m, "Capsule",
                      "Points within `radius` (m) of the segment from (0, 0, -half_length) to (0, 0, +half_length) "
                      "(m) on the body z axis; half_length 0 is a sphere.")
      .def(py::init([](const py::object& r, const py::object& h) {
             return Capsule(bindings::number(r, "Capsule", "radius"), bindings::number(h, "Capsule", "half_length"));
           }),
           py::arg("radius"), py::arg("half_length"))
      .def_readonly("radius", &Capsule::radius)
      .def_readonly("half_length", &Capsule::half_length)
      .def("__repr__", [](const Capsule& c) {
        return "Capsule(radius=" + std::to_string(c.radius) + ", half_length=" + std::to_string(c.half_length) + ")";
      })
      .def(py::pickle([](const Capsule& c) { return py::make_tuple(c.radius, c.half_length); },
                      [](const py::tuple& t) { return Capsule(t[0].cast<double>(), t[1].cast<double>()); }));

  py::class_<Cylinder>(m, "Cylinder",
                       "Solid cylinder of `radius` (m) around the body z axis, from z = -half_height to +half_height (m).")
      .def(py::init([](const py::object& r, const py::object& h) {
             return Cylinder(bindings::number(r, "Cylinder", "radius"), bindings::number(h, "Cylinder", "half_height"));
           }),
           py::arg("radius"), py::arg("half_height"))
      .def_readonly("radius", &Cylinder::radius)
      .def_readonly("half_height", &Cylinder::half_height)
      .def("__repr__", [](const Cylinder& c) {
        return "Cylinder(radius=" + std::to_string(c.radius) + ", half_height=" + std::to_string(c.half_height) + ")";
      })
      .def(py::pickle([](const Cylinder& c) { return py::make_tuple(c.radius, c.half_height); },
                      [](const py::tuple& t) { return Cylinder(t[0].cast<double>(), t[1].cast<double>()); }));

  py::class_<ConvexHull>(m, "ConvexHull",
                         "Convex hull (Qhull) of (n, 3) points (m, body frame), n >= 4, not all coplanar. "
                         "vertices: the hull's points in input order; faces: (k, 3) outward triangles.")
      .def(py::init([](const py::object& pts) { return ConvexHull(points(pts, "ConvexHull", "points")); }), py::arg("points"))
      .def_readonly("vertices", &ConvexHull::vertices)
      .def_readonly("faces", &ConvexHull::faces)
      .def("__repr__", [](const ConvexHull& h) {
        return "ConvexHull(" + std::to_string(h.vertices.rows()) + " vertices, " + std::to_string(h.faces.rows()) +
               " triangles, " + std::to_string(h.polytope->faces.size()) + " faces)";
      })
      .def(py::pickle(
          [](const ConvexHull& h) { return py::make_tuple(h.vertices, h.faces, polytope_state(*h.polytope)); },
          [](const py::tuple& t) {
            ConvexHull h(points(t[0], "ConvexHull", "vertices"));
            h.vertices = points(t[0], "ConvexHull", "vertices");  // exactly as stored, in their order
            h.faces = triangles(t[1], "ConvexHull");
            h.polytope = polytope_from_state(t[2]);
            return h;
          }));

  py::class_<TriangleMesh>(m, "TriangleMesh",
                           "Static triangle mesh of any shape (terrain, bowls, ramps): vertices (n, 3) in m, faces "
                           "(k, 3) counter-clockwise seen from the side bodies touch. Static bodies only.")
      .def(py::init([](const py::object& vertices, const py::object& faces) {
             return TriangleMesh(points(vertices, "TriangleMesh", "vertices"), triangles(faces, "TriangleMesh"));
           }),
           py::arg("vertices"), py::arg("faces"),
           "A static triangle mesh from vertices (n, 3) float, m, and faces (k, 3) int, vertex indices "
           "of triangles counter-clockwise seen from the side bodies touch; it need not be closed. To "
           "read a file: signorini.load_mesh(path, static=True).")
      .def_readonly("vertices", &TriangleMesh::vertices)
      .def_readonly("faces", &TriangleMesh::faces)
      .def_property_readonly(
          "active_edge",
          [](const TriangleMesh& t) {
            py::array_t<bool> out({static_cast<py::ssize_t>(t.active_edge.size()), py::ssize_t(3)});
            auto o = out.mutable_unchecked<2>();
            for (std::size_t k = 0; k < t.active_edge.size(); ++k)
              for (int c = 0; c < 3; ++c) o(k, c) = t.active_edge[k][c];
            out.attr("flags").attr("writeable") = false;
            return out;
          },
          "(k, 3) bool: side c of face k (v_c -> v_c+1) can make edge contacts (boundary, non-manifold, or convex "
          "by more than 1e-6 rad).")
      .def_property_readonly(
          "normals", [](const TriangleMesh& t) { return bindings::rows_of(t.normals); }, "(k, 3) unit face normals.")
      .def("__repr__", [](const TriangleMesh& t) {
        return "TriangleMesh(" + std::to_string(t.vertices.rows()) + " vertices, " + std::to_string(t.faces.rows()) + " faces)";
      })
      .def(py::pickle([](const TriangleMesh& t) { return py::make_tuple(t.vertices, t.faces); },
                      [](const py::tuple& t) {
                        return TriangleMesh(points(t[0], "TriangleMesh", "vertices"), triangles(t[1], "TriangleMesh"));
                      }));

  py::class_<Compound>(m, "Compound",
                       "Convex parts on one body: a list of (shape, (position, orientation)), shape a Sphere, Box, "
                       "Capsule, Cylinder, ConvexHull or convex Mesh (which becomes the ConvexHull of its vertices), "
                       "position (3,) m and orientation (w, x, y, z) (normalised) in the compound frame, or instead "
                       "of the quaternion a (3, 3) compound-from-part rotation matrix (kept exactly). A dynamic "
                       "compound is re-centred on its centre of mass.")
      .def(py::init([](const py::object& items) {
             if (!py::isinstance<py::iterable>(items) || py::isinstance<py::str>(items))
               throw py::type_error("Compound: parts must be a list of (shape, (position, orientation)), got " +
                                    std::string(py::repr(items)));
             std::vector<Compound::Part> parts;
             for (const py::handle& item : items) parts.push_back(compound_part(item, parts.size()));
             return Compound(std::move(parts));
           }),
           py::arg("parts"))
      .def_property_readonly(
          "parts",
          [](const Compound& c) {
            py::list out;
            for (const Compound::Part& p : c.parts) {
              py::object shape = std::visit([](const auto& s) { return py::cast(s); }, p.shape);
              const Quat4 q = p.orientation();
              py::array_t<double> position(3), orientation(4);
              for (int k = 0; k < 3; ++k) position.mutable_at(k) = p.position[k];
              for (int k = 0; k < 4; ++k) orientation.mutable_at(k) = q[k];
              out.append(py::make_tuple(shape, py::make_tuple(position, orientation)));
            }
            return out;
          },
          "[(shape, (position (3,), orientation (w, x, y, z) with w >= 0))], in the compound frame.")
      .def_property_readonly(
          "rotations",
          [](const Compound& c) {
            std::vector<Mat3> R;
            for (const Compound::Part& p : c.parts) R.push_back(p.rotation);
            return bindings::stack_of(R);
          },
          "(parts, 3, 3) compound-from-part rotation matrices, as the core stores them.")
      .def("__repr__", [](const Compound& c) {
        std::string s = "Compound(" + std::to_string(c.parts.size()) + " parts:";
        for (std::size_t i = 0; i < c.parts.size(); ++i)
          s += (i ? ", " : " ") + std::visit([](const auto& x) { return shape_name(Shape(x)); }, c.parts[i].shape);
        return s + ")";
      })
      .def(py::pickle(
          [](const Compound& c) {
            py::list parts;  // (primitive, position, rotation matrix): the rotation as stored, no quaternion round trip
            for (const Compound::Part& p : c.parts)
              parts.append(py::make_tuple(std::visit([](const auto& x) { return py::cast(x); }, p.shape), p.position, p.rotation));
            return py::make_tuple(parts);
          },
          [](const py::tuple& t) {
            std::vector<Compound::Part> parts;
            for (const py::handle& item : t[0].cast<py::list>()) {
              const auto part = item.cast<py::tuple>();
              parts.push_back(Compound::Part{primitive(part[0]), part[1].cast<Vec3>(), part[2].cast<Mat3>()});
            }
            try {
              return Compound(std::move(parts));
            } catch (const std::invalid_argument& e) {
              throw py::value_error(e.what());
            }
          }));

  m.def(
      "mass_properties",
      [](const py::object& shape, double density) {
        const MassProperties mp = mass_properties(bindings::to_shape(shape, "mass_properties"), density);
        return py::make_tuple(mp.mass, mp.com, mp.inertia);
      },
      py::arg("shape"), py::arg("density"),
      "(mass kg, com (3,) m in the shape frame, inertia (3, 3) kg m^2 about the com) for a uniform density.");
  // every shape pickles at every protocol (arrays.hpp)
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<Sphere>>(m.attr("Sphere")));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<Box>>(m.attr("Box")));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<Plane>>(m.attr("Plane")));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<Mesh>>(m.attr("Mesh")));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<Capsule>>(m.attr("Capsule")));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<Cylinder>>(m.attr("Cylinder")));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<ConvexHull>>(m.attr("ConvexHull")));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<TriangleMesh>>(m.attr("TriangleMesh")));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<Compound>>(m.attr("Compound")));
}
