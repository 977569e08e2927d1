// World: construction, bodies, stepping, state and contact arrays (state and contacts as read-only
// zero-copy views, model arrays as copies; shapes in comments), saved states.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <optional>
#include <string>

#include "arrays.hpp"
#include "signorini/world.hpp"

using namespace signorini;
using bindings::contact_arrays;

void register_world(py::module_& m) {
  py::enum_<FrictionCone>(m, "FrictionCone").value("pyramid", FrictionCone::Pyramid).value("cone", FrictionCone::Cone);
  py::enum_<Gyroscopic>(m, "Gyroscopic")
      .value("midpoint", Gyroscopic::Midpoint)
      .value("implicit", Gyroscopic::Implicit)
      .value("explicit", Gyroscopic::Explicit);
  py::enum_<SolverMethod>(m, "SolverMethod").value("pgs", SolverMethod::PGS).value("soft", SolverMethod::Soft);
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<SolverMethod>>(m.attr("SolverMethod")));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<FrictionCone>>(m.attr("FrictionCone")));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<Gyroscopic>>(m.attr("Gyroscopic")));

  // solver settings: plain fields, validated by World (docs/conventions.md, "Defaults")
  py::class_<SolverSettings>(m, "SolverSettings")
      .def(py::init<>())
      .def_readwrite("erp", &SolverSettings::erp)
      .def_readwrite("tolerance", &SolverSettings::tolerance)
      .def_readwrite("max_iterations", &SolverSettings::max_iterations)
      .def_readwrite("slop", &SolverSettings::slop)
      .def_readwrite("max_push_velocity", &SolverSettings::max_push_velocity)
      .def_readwrite("restitution_threshold", &SolverSettings::restitution_threshold)
      .def_readwrite("friction_cone", &SolverSettings::friction_cone)
      .def_readwrite("gyroscopic", &SolverSettings::gyroscopic)
      .def_readwrite("warm_start", &SolverSettings::warm_start)
      .def_readwrite("substeps", &SolverSettings::substeps)
      .def_readwrite("warn_velocity", &SolverSettings::warn_velocity)
      .def_readwrite("method", &SolverSettings::method)
      .def_readwrite("contact_hertz", &SolverSettings::contact_hertz)
      .def_readwrite("damping_ratio", &SolverSettings::damping_ratio)
      .def_readwrite("soft_iterations", &SolverSettings::soft_iterations)
      .def_readwrite("relax_iterations", &SolverSettings::relax_iterations)
      .def(py::pickle(
          [](const SolverSettings& s) {
            return py::make_tuple(s.erp, s.tolerance, s.max_iterations, s.slop, s.max_push_velocity,
                                  s.restitution_threshold, s.friction_cone, s.gyroscopic, s.warm_start, s.substeps,
                                  s.warn_velocity, s.method, s.contact_hertz, s.damping_ratio, s.soft_iterations,
                                  s.relax_iterations);
          },
          [](const py::tuple& t) {
            // 11 items: a pickle from before the soft step (its settings keep their defaults)
            if (t.size() != 16 && t.size() != 11)
              throw py::value_error("SolverSettings: a pickled state has 16 items (11 before the soft step)");
            SolverSettings s;
            s.erp = t[0].cast<double>();
            s.tolerance = t[1].cast<double>();
            s.max_iterations = t[2].cast<int>();
            s.slop = t[3].cast<double>();
            s.max_push_velocity = t[4].cast<double>();
            s.restitution_threshold = t[5].cast<double>();
            s.friction_cone = t[6].cast<FrictionCone>();
            s.gyroscopic = t[7].cast<Gyroscopic>();
            s.warm_start = t[8].cast<bool>();
            s.substeps = t[9].cast<int>();
            s.warn_velocity = t[10].cast<double>();
            if (t.size() == 16) {
              s.method = t[11].cast<SolverMethod>();
              s.contact_hertz = t[12].cast<double>();
              s.damping_ratio = t[13].cast<double>();
              s.soft_iterations = t[14].cast<int>();
              s.relax_iterations = t[15].cast<int>();
            }
            return s;
          }));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<SolverSettings>>(m.attr("SolverSettings")));

  // an index that is not in the world: both an IndexError and a ValueError
  py::register_exception<BodyIndexError>(m, "BodyIndexError",
                                         py::make_tuple(py::handle(PyExc_IndexError), py::handle(PyExc_ValueError)));

  py::class_<World>(m, "World")
      .def(py::init([](const Vec3& gravity, double margin, const SolverSettings& solver) {
             WorldSettings s;
             s.gravity = gravity;
             s.contact_margin = margin;
             s.solver = solver;
             return std::make_unique<World>(s);
           }),
           py::arg("gravity"), py::arg("contact_margin"), py::arg("solver"))
      .def(
          "add_body",
          [](World& w, const py::object& shape, bool is_static, bool is_kinematic, std::optional<double> density,
             std::optional<double> mass, std::optional<Mat3> inertia, const Vec3& position, const Quat4& orientation,
             const Vec3& velocity, const Vec3& angular_velocity, double friction, double restitution,
             double spinning_friction, const std::string& name, std::uint32_t group, std::uint32_t mask, bool enabled) {
            BodyDesc d;
            d.shape = bindings::to_shape(shape, "body " + std::to_string(w.num_bodies()));
            d.is_static = is_static;
            d.is_kinematic = is_kinematic;
            d.density = density;
            d.mass = mass;
            d.inertia = inertia;
            d.position = position;
            d.orientation = orientation;
            d.velocity = velocity;
            d.angular_velocity = angular_velocity;
            d.material.friction = friction;
            d.material.restitution = restitution;
            d.material.spinning_friction = spinning_friction;
            d.name = name;
            d.filter = CollisionFilter{group, mask};
            d.enabled = enabled;
            return w.add_body(d);
          },
          py::arg("shape"), py::arg("is_static"), py::arg("is_kinematic"), py::arg("density"), py::arg("mass"),
          py::arg("inertia"), py::arg("position"), py::arg("orientation"), py::arg("velocity"),
          py::arg("angular_velocity"), py::arg("friction"), py::arg("restitution"), py::arg("spinning_friction"),
          py::arg("name"),
          py::arg("group"), py::arg("mask"), py::arg("enabled"))
      .def("remove_body", &World::remove_body, py::arg("i"))
      .def("remove_bodies", &World::remove_bodies, py::arg("indices"))
      .def("step", &World::step, py::arg("dt"), py::arg("steps") = 1, py::call_guard<py::gil_scoped_release>())
      .def("set_position", &World::set_position)
      .def("set_orientation", &World::set_orientation)
      .def("set_velocity", &World::set_velocity)
      .def("set_angular_velocity", &World::set_angular_velocity)
      .def("set_external_wrench", &World::set_external_wrench)
      .def("set_positions", &World::set_positions)
      .def("set_orientations", &World::set_orientations)
      .def("set_velocities", &World::set_velocities)
      .def("set_angular_velocities", &World::set_angular_velocities)
      .def("apply_impulse", [](World& w, BodyIndex i, const Vec3& J, std::optional<Vec3> point) {
        w.apply_impulse(i, J, point ? *point : w.state().p.at(i));
      })
      .def("apply_force", [](World& w, BodyIndex i, const Vec3& f, std::optional<Vec3> point) {
        w.apply_force(i, f, point ? *point : w.state().p.at(i));
      })
      .def("set_kinematic", &World::set_kinematic)
      .def("set_enabled", &World::set_enabled)
      .def("set_collision_filter", [](World& w, BodyIndex i, std::uint32_t group, std::uint32_t mask) {
        w.set_collision_filter(i, CollisionFilter{group, mask});
      })
      .def("set_pair_collision", &World::set_pair_collision)
      .def("find", &World::find)
      .def("label", &World::label)
      .def("save_state", [](const World& w) { return py::bytes(w.save_state()); })
      .def("restore_state", [](World& w, const py::bytes& b) { w.restore_state(std::string(b)); })
      .def("set_material", [](World& w, BodyIndex i, double friction, double restitution, double spinning_friction) {
        w.set_material(i, Material{friction, restitution, spinning_friction});
      })
      .def("set_solver", [](World& w, const SolverSettings& solver) {
        WorldSettings s = w.settings();
        s.solver = solver;
        w.set_settings(s);
      })
      .def("shape", [](const World& w, BodyIndex i) {
        w.label(i);  // BodyIndexError naming the index and the body count
        return bindings::from_shape(w.model().shape[i]);
      })
      .def_property_readonly("num_bodies", &World::num_bodies)
      .def_property_readonly("time", [](const World& w) { return w.state().time; })
      // state (N x 3, N x 3 x 3, N x 4): read-only views of the core's arrays, base = this World
      .def_property_readonly("positions", [](const py::object& self) { return bindings::vec3_view(self, self.cast<const World&>().state().p); })
      .def_property_readonly("rotations", [](const py::object& self) { return bindings::mat3_view(self, self.cast<const World&>().state().R); })
      .def_property_readonly("orientations", [](const py::object& self) { return bindings::quat_view(self, self.cast<const World&>().state().q); })
      .def_property_readonly("velocities", [](const py::object& self) { return bindings::vec3_view(self, self.cast<const World&>().state().v); })
      .def_property_readonly("angular_velocities", [](const py::object& self) { return bindings::vec3_view(self, self.cast<const World&>().state().omega); })
      .def_property_readonly("forces", [](const py::object& self) { return bindings::vec3_view(self, self.cast<const World&>().state().f_ext); })
      .def_property_readonly("torques", [](const py::object& self) { return bindings::vec3_view(self, self.cast<const World&>().state().tau_ext); })
      // the next step's one-step force and torque, and pending impulse and angular impulse (N x 3)
      .def_property_readonly("step_forces", [](const py::object& self) { return bindings::vec3_view(self, self.cast<const World&>().state().f_step); })
      .def_property_readonly("step_torques", [](const py::object& self) { return bindings::vec3_view(self, self.cast<const World&>().state().tau_step); })
      .def_property_readonly("impulses", [](const py::object& self) { return bindings::vec3_view(self, self.cast<const World&>().state().impulse); })
      .def_property_readonly("angular_impulses", [](const py::object& self) { return bindings::vec3_view(self, self.cast<const World&>().state().angular_impulse); })
      // model
      .def_property_readonly("masses", [](const World& w) { return py::array_t<double>(py::cast(w.model().mass)); })
      .def_property_readonly("inv_masses", [](const World& w) { return py::array_t<double>(py::cast(w.model().inv_mass)); })
      .def_property_readonly("inertias", [](const World& w) { return bindings::stack_of(w.model().I_body); })
      .def_property_readonly("inv_inertias", [](const World& w) { return bindings::stack_of(w.model().I_body_inv); })
      .def_property_readonly("frictions", [](const World& w) {
        py::array_t<double> out(static_cast<py::ssize_t>(w.num_bodies()));
        for (std::size_t i = 0; i < w.num_bodies(); ++i) out.mutable_at(i) = w.model().material[i].friction;
        return out;
      })
      .def_property_readonly("restitutions", [](const World& w) {
        py::array_t<double> out(static_cast<py::ssize_t>(w.num_bodies()));
        for (std::size_t i = 0; i < w.num_bodies(); ++i) out.mutable_at(i) = w.model().material[i].restitution;
        return out;
      })
      .def_property_readonly("spinning_frictions", [](const World& w) {
        py::array_t<double> out(static_cast<py::ssize_t>(w.num_bodies()));
        for (std::size_t i = 0; i < w.num_bodies(); ++i) out.mutable_at(i) = w.model().material[i].spinning_friction;
        return out;
      })
      .def_property_readonly("is_static", [](const World& w) {
        std::vector<bool> s(w.model().is_static.begin(), w.model().is_static.end());
        return py::array_t<bool>(py::cast(s));
      })
      .def_property_readonly("is_kinematic", [](const World& w) {
        std::vector<bool> s(w.model().is_kinematic.begin(), w.model().is_kinematic.end());
        return py::array_t<bool>(py::cast(s));
      })
      .def_property_readonly("enabled", [](const World& w) {
        std::vector<bool> s(w.model().enabled.begin(), w.model().enabled.end());
        return py::array_t<bool>(py::cast(s));
      })
      .def_property_readonly("groups", [](const World& w) {
        py::array_t<std::uint32_t> out(static_cast<py::ssize_t>(w.num_bodies()));
        for (std::size_t i = 0; i < w.num_bodies(); ++i) out.mutable_at(i) = w.model().filter[i].group;
        return out;
      })
      .def_property_readonly("masks", [](const World& w) {
        py::array_t<std::uint32_t> out(static_cast<py::ssize_t>(w.num_bodies()));
        for (std::size_t i = 0; i < w.num_bodies(); ++i) out.mutable_at(i) = w.model().filter[i].mask;
        return out;
      })
      .def_property_readonly("names", [](const World& w) { return w.model().name; })
      .def_property_readonly("excluded_pairs", [](const World& w) { return w.model().excluded_pairs; })
      // settings
      .def_property_readonly("gravity", [](const World& w) { return w.settings().gravity; })
      .def_property_readonly("contact_margin", [](const World& w) { return w.settings().contact_margin; })
      .def_property_readonly("solver", [](const World& w) { return w.settings().solver; })
      // last step
      .def_property_readonly("contacts", [](const World& w) { return bindings::contact_views(w.shared_contacts()); })
      .def(
          "detect_contacts",
          [](const World& w, double dt) {
            std::vector<Contact> found;
            {
              // the narrow phase runs without the GIL, as step does (it may wait for the world's lock)
              const py::gil_scoped_release release;
              found = w.detect_contacts(dt);
            }
            return contact_arrays(found);
          },
          py::arg("dt"))
      .def_property_readonly("solver_stats", [](const World& w) {
        const SolverStats& s = w.solver_stats();
        py::dict d;
        d["iterations"] = s.iterations;
        d["restitution_iterations"] = s.restitution_iterations;
        d["position_iterations"] = s.position_iterations;
        d["converged"] = s.converged;
        d["contacts"] = s.contacts;
        d["residual"] = s.residual;
        d["max_alpha_negative"] = s.max_alpha_negative;
        d["max_penetration_velocity"] = s.max_penetration_velocity;
        d["max_complementarity"] = s.max_complementarity;
        d["max_cone_violation"] = s.max_cone_violation;
        d["max_dissipation_violation"] = s.max_dissipation_violation;
        d["max_overlap"] = s.max_overlap;
        return d;
      })
      .def_property_readonly("step_report", [](const World& w) {
        const StepReport& r = w.step_report();
        py::dict d;
        d["steps"] = r.steps;
        d["flagged"] = r.flagged;
        d["worst_penetration_velocity"] = r.worst_penetration_velocity;
        d["worst_time"] = r.worst_time;
        return d;
      })
      // per body (N x 3): summed contact force (N) and torque about the com (N m) of the last step
      .def_property_readonly("contact_forces", [](const World& w) { return bindings::rows_of(w.contact_forces()); })
      .def_property_readonly("contact_torques", [](const World& w) { return bindings::rows_of(w.contact_torques()); })
      .def_property_readonly("warm_start_cache", [](const World& w) { return bindings::cache_arrays(w.warm_start_cache()); })
      .def("kinetic_energy", &World::kinetic_energy)
      .def("potential_energy", &World::potential_energy);
  bindings::refuse_pickling(py::reinterpret_borrow<py::class_<World>>(m.attr("World")),
                            "pickle the signorini.World that holds it");
}
