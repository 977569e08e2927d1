// Rotations: quaternion <-> matrix with the World's own maths (signorini/rotation.hpp), for the
// Python codec. Shape checks here; finiteness and zero checks in the core (ValueError).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>

#include <stdexcept>
#include <string>

#include "signorini/rotation.hpp"

namespace py = pybind11;
using namespace signorini;

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// x as a float64 array of exactly `shape`, or ValueError "<who>: <what> must have shape ..., got ...".
Array exactly(const py::handle& x, const std::vector<py::ssize_t>& shape, const std::string& who,
              const std::string& what) {
  auto text = [](const std::vector<py::ssize_t>& s) {
    std::string out = "(";
    for (std::size_t k = 0; k < s.size(); ++k) out += (k ? ", " : "") + std::to_string(s[k]);
    return out + (s.size() == 1 ? ",)" : ")");
  };
  Array a = Array::ensure(x);
  if (!a) throw py::type_error(who + ": " + what + " must be an array of numbers, got " + std::string(py::repr(x)));
  const std::vector<py::ssize_t> got(a.shape(), a.shape() + a.ndim());
  if (got != shape)
    throw py::value_error(who + ": " + what + " must have shape " + text(shape) + ", got shape " + text(got));
  return a;
}

}  // namespace

void register_rotation(py::module_& m) {
  m.def(
      "quat_to_matrix",
      [](const py::object& q) {
        Array a = exactly(q, {4}, "quat_to_matrix", "q");
        try {
          return rotation_matrix(Quat4(a.at(0), a.at(1), a.at(2), a.at(3)));
        } catch (const std::invalid_argument& e) {
          throw py::value_error(std::string("quat_to_matrix: ") + e.what());
        }
      },
      py::arg("q"),
      "Rotation matrix (3, 3), world-from-body, of a quaternion (4,) (w, x, y, z), made unit first "
      "as the World does (equal to World.rotations to the bit). ValueError for a wrong shape or a "
      "non-finite or zero quaternion.");
  m.def(
      "matrix_to_quat",
      [](const py::object& R) {
        Array a = exactly(R, {3, 3}, "matrix_to_quat", "R");
        Mat3 M;
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) M(r, c) = a.at(r, c);
        try {
          return rotation_quaternion(M);
        } catch (const std::invalid_argument& e) {
          throw py::value_error(std::string("matrix_to_quat: ") + e.what());
        }
      },
      py::arg("R"),
      "Unit quaternion (4,) (w, x, y, z), w >= 0, of a rotation matrix (3, 3). ValueError for a wrong "
      "shape or a non-finite or zero matrix.");
}
