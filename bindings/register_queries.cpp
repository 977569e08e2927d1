// World queries (issue 24): ray casts, overlaps, distances, added to the World class that
// register_world made. Marshalling only; the batch runs with the GIL released.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <optional>
#include <vector>

#include "arrays.hpp"
#include "signorini/query.hpp"
#include "signorini/world.hpp"

using namespace signorini;

namespace {

QueryFilter filter_of(std::uint32_t group, std::uint32_t mask, std::vector<BodyIndex> exclude) {
  QueryFilter f;
  f.group = group, f.mask = mask, f.exclude = std::move(exclude);
  return f;
}

/// (body, point (3,), normal (3,), distance, feature)
py::tuple hit_tuple(const RayHit& h) { return py::make_tuple(h.body, h.point, h.normal, h.distance, h.feature); }

py::object maybe_hit(const std::optional<RayHit>& h) { return h ? py::object(hit_tuple(*h)) : py::object(py::none()); }

template <class T>
py::array_t<T> array_of(const std::vector<T>& v) {
  py::array_t<T> out(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

}  // namespace

void register_queries(py::module_& m) {
  auto world = py::reinterpret_borrow<py::class_<World>>(m.attr("World"));
  world
      .def("cast_ray",
           [](const World& w, const Vec3& o, const Vec3& d, double max_distance, std::uint32_t group, std::uint32_t mask,
              std::vector<BodyIndex> exclude) {
             return maybe_hit(w.cast_ray(o, d, max_distance, filter_of(group, mask, std::move(exclude))));
           },
           py::arg("origin"), py::arg("direction"), py::arg("max_distance"), py::arg("group"), py::arg("mask"),
           py::arg("exclude"))
      .def("cast_ray_any",
           [](const World& w, const Vec3& o, const Vec3& d, double max_distance, std::uint32_t group, std::uint32_t mask,
              std::vector<BodyIndex> exclude) {
             return maybe_hit(w.cast_ray_any(o, d, max_distance, filter_of(group, mask, std::move(exclude))));
           },
           py::arg("origin"), py::arg("direction"), py::arg("max_distance"), py::arg("group"), py::arg("mask"),
           py::arg("exclude"))
      .def("cast_ray_all",
           [](const World& w, const Vec3& o, const Vec3& d, double max_distance, std::uint32_t group, std::uint32_t mask,
              std::vector<BodyIndex> exclude) {
             py::list out;
             for (const RayHit& h : w.cast_ray_all(o, d, max_distance, filter_of(group, mask, std::move(exclude))))
               out.append(hit_tuple(h));
             return out;
           },
           py::arg("origin"), py::arg("direction"), py::arg("max_distance"), py::arg("group"), py::arg("mask"),
           py::arg("exclude"))
      // (n, 3) origins and directions, (n,) max_distance -> dict of body (n,) int32, point (n, 3),
      // normal (n, 3), distance (n,), feature (n,) uint64
      .def("cast_rays",
           [](const World& w, const Points& origins, const Points& directions, const Eigen::VectorXd& max_distance,
              std::uint32_t group, std::uint32_t mask, std::vector<BodyIndex> exclude) {
             const QueryFilter f = filter_of(group, mask, std::move(exclude));
             RayHits hits;
             {
               const py::gil_scoped_release released;
               hits = w.cast_rays(origins, directions, max_distance, f);
             }
             py::dict out;
             out["body"] = array_of(std::vector<std::int32_t>(hits.body.begin(), hits.body.end()));
             out["point"] = py::array_t<double>(py::cast(hits.point));
             out["normal"] = py::array_t<double>(py::cast(hits.normal));
             out["distance"] = array_of(hits.distance);
             out["feature"] = array_of(std::vector<std::uint64_t>(hits.feature.begin(), hits.feature.end()));
             return out;
           },
           py::arg("origins"), py::arg("directions"), py::arg("max_distance"), py::arg("group"), py::arg("mask"),
           py::arg("exclude"))
      .def("overlap",
           [](const World& w, const py::object& shape, const Vec3& position, const Quat4& orientation,
              std::uint32_t group, std::uint32_t mask, std::vector<BodyIndex> exclude) {
             const Shape s = bindings::to_shape(shape, "overlap: shape");
             return w.overlap(s, position, orientation, filter_of(group, mask, std::move(exclude)));
           },
           py::arg("shape"), py::arg("position"), py::arg("orientation"), py::arg("group"), py::arg("mask"),
           py::arg("exclude"))
      .def("overlap_aabb",
           [](const World& w, const Vec3& lo, const Vec3& hi, std::uint32_t group, std::uint32_t mask,
              std::vector<BodyIndex> exclude) {
             return w.overlap_aabb(lo, hi, filter_of(group, mask, std::move(exclude)));
           },
           py::arg("lo"), py::arg("hi"), py::arg("group"), py::arg("mask"), py::arg("exclude"))
      .def("overlap_point",
           [](const World& w, const Vec3& x, std::uint32_t group, std::uint32_t mask, std::vector<BodyIndex> exclude) {
             return w.overlap_point(x, filter_of(group, mask, std::move(exclude)));
           },
           py::arg("point"), py::arg("group"), py::arg("mask"), py::arg("exclude"))
      // (body, fraction, point (3,), normal (3,)) or None
      .def("cast_shape",
           [](const World& w, const py::object& shape, const Vec3& position, const Quat4& orientation,
              const Vec3& translation, std::uint32_t group, std::uint32_t mask, std::vector<BodyIndex> exclude) {
             const Shape s = bindings::to_shape(shape, "cast_shape: shape");
             const std::optional<ShapeHit> h =
                 w.cast_shape(s, position, orientation, translation, filter_of(group, mask, std::move(exclude)));
             return h ? py::object(py::make_tuple(h->body, h->fraction, h->point, h->normal)) : py::object(py::none());
           },
           py::arg("shape"), py::arg("position"), py::arg("orientation"), py::arg("translation"), py::arg("group"),
           py::arg("mask"), py::arg("exclude"))
      // (distance, point_a (3,), point_b (3,), normal (3,))
      .def("distance",
           [](const World& w, BodyIndex i, BodyIndex j) {
             const BodyDistance d = w.distance(i, j);
             return py::make_tuple(d.distance, d.point_a, d.point_b, d.normal);
           },
           py::arg("i"), py::arg("j"))
      .def_property_readonly("query_stats", [](const World& w) {
        const QueryStats s = w.query_stats();
        py::dict out;
        out["queries"] = s.queries, out["nodes"] = s.nodes, out["body_tests"] = s.body_tests;
        return out;
      });
}
