// World: construction, bodies, stepping, state and contact arrays (state and contacts as read-only
// zero-copy views, model arrays as copies; shapes in comments), saved states. What is read from the
// World's model or state directly is read holding World::lock() (locked_copy, state_view), so
// another thread's call (a step without the GIL, an add_body moving the arrays) is never seen half
// done; Python objects are built after the lock is released.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "arrays.hpp"
#include "signorini/batch.hpp"
#include "signorini/world.hpp"

using namespace signorini;
using bindings::contact_arrays;

namespace {

/// f(w) (a copy of what it reads) run holding the World's lock. Nothing Python runs under it:
/// Python code may switch threads, and a thread calling into this World waits for the lock
/// holding the GIL.
template <class F>
auto locked_copy(const World& w, F&& f) {
  const auto held = w.lock();
  return f(w);
}

/// A read-only zero-copy view (base: the Python World) of one of the World's state arrays, its
/// address and length taken together under the lock (add_body may move the array; the old
/// storage is kept, see World::push_keeping); its values then show later steps as they run.
template <class T, class View>
py::array state_view(const py::object& self, std::vector<T> State::*array, View view) {
  const World& w = self.cast<const World&>();
  const auto [data, n] = locked_copy(w, [array](const World& w) {
    const std::vector<T>& xs = w.state().*array;
    return std::pair(xs.data(), xs.size());
  });
  return view(self, data, n);
}

/// field(model, i) of every body i, read under the lock, as an (N,) array.
template <class T>
py::array_t<T> per_body(const World& w, T (*field)(const Model&, std::size_t)) {
  const std::vector<T> values = locked_copy(w, [field](const World& w) {
    std::vector<T> out(w.model().size());
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = field(w.model(), i);
    return out;
  });
  py::array_t<T> out(static_cast<py::ssize_t>(values.size()));
  std::copy(values.begin(), values.end(), out.mutable_data());
  return out;
}

}  // namespace

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

  m.def("set_simd", &set_simd, py::arg("isa"));
  m.def("simd", &simd);

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
      .def_readwrite("recycle_distance", &SolverSettings::recycle_distance)
      .def_readwrite("continuous", &SolverSettings::continuous)
      .def_readwrite("joint_hertz", &SolverSettings::joint_hertz)
      .def_readwrite("joint_damping_ratio", &SolverSettings::joint_damping_ratio)
      .def(py::pickle(
          [](const SolverSettings& s) {
            return py::make_tuple(s.erp, s.tolerance, s.max_iterations, s.slop, s.max_push_velocity,
                                  s.restitution_threshold, s.friction_cone, s.gyroscopic, s.warm_start, s.substeps,
                                  s.warn_velocity, s.method, s.contact_hertz, s.damping_ratio, s.soft_iterations,
                                  s.relax_iterations, s.recycle_distance, s.continuous, s.joint_hertz,
                                  s.joint_damping_ratio);
          },
          [](const py::tuple& t) {
            // 11 items: a pickle from before the soft step (its settings keep their defaults); 16:
            // before contact recycling (it stays off, as it was); 17: before continuous collision
            // (on, the default); 18: before the joints' softness settings (60 Hz and 2, as it was)
            const std::size_t n = t.size();
            if (n != 20 && n != 18 && n != 17 && n != 16 && n != 11)
              throw py::value_error("SolverSettings: a pickled state has 20 items (18 before the joints' softness "
                                    "settings, 17 before continuous collision, 16 before contact recycling, 11 "
                                    "before the soft step)");
            SolverSettings s;
            s.recycle_distance = n >= 17 ? t[16].cast<double>() : 0.0;
            if (n >= 18) s.continuous = t[17].cast<bool>();
            s.joint_hertz = n >= 20 ? t[18].cast<double>() : 60.0;
            s.joint_damping_ratio = n >= 20 ? t[19].cast<double>() : 2.0;
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
            if (t.size() >= 16) {
              s.method = t[11].cast<SolverMethod>();
              s.contact_hertz = t[12].cast<double>();
              s.damping_ratio = t[13].cast<double>();
              s.soft_iterations = t[14].cast<int>();
              s.relax_iterations = t[15].cast<int>();
            }
            return s;
          }));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<SolverSettings>>(m.attr("SolverSettings")));

  // sleep settings: plain fields, validated by World (docs/conventions.md, "Sleeping")
  py::class_<SleepSettings>(m, "SleepSettings")
      .def(py::init<>())
      .def_readwrite("enabled", &SleepSettings::enabled)
      .def_readwrite("linear_velocity", &SleepSettings::linear_velocity)
      .def_readwrite("angular_velocity", &SleepSettings::angular_velocity)
      .def_readwrite("time_to_sleep", &SleepSettings::time_to_sleep)
      .def(py::pickle(
          [](const SleepSettings& s) {
            return py::make_tuple(s.enabled, s.linear_velocity, s.angular_velocity, s.time_to_sleep);
          },
          [](const py::tuple& t) {
            if (t.size() != 4) throw py::value_error("SleepSettings: a pickled state has 4 items");
            SleepSettings s;
            s.enabled = t[0].cast<bool>();
            s.linear_velocity = t[1].cast<double>();
            s.angular_velocity = t[2].cast<double>();
            s.time_to_sleep = t[3].cast<double>();
            return s;
          }));
  bindings::pickle_at_every_protocol(py::reinterpret_borrow<py::class_<SleepSettings>>(m.attr("SleepSettings")));

  // an index that is not in the world: both an IndexError and a ValueError
  py::register_exception<BodyIndexError>(m, "BodyIndexError",
                                         py::make_tuple(py::handle(PyExc_IndexError), py::handle(PyExc_ValueError)));

  py::class_<World>(m, "World")
      .def(py::init([](const Vec3& gravity, double margin, const SolverSettings& solver,
                       const std::optional<SleepSettings>& sleep, int threads) {
             WorldSettings s;
             s.gravity = gravity;
             s.contact_margin = margin;
             s.solver = solver;
             if (sleep) s.sleep = *sleep;
             s.threads = threads;
             return std::make_unique<World>(s);
           }),
           py::arg("gravity"), py::arg("contact_margin"), py::arg("solver"), py::arg("sleep") = py::none(),
           py::arg("threads") = 0)
      .def(
          "add_body",
          [](World& w, const py::object& shape, bool is_static, bool is_kinematic, std::optional<double> density,
             std::optional<double> mass, std::optional<Mat3> inertia, const Vec3& position, const Quat4& orientation,
             const Vec3& velocity, const Vec3& angular_velocity, double friction, double restitution,
             double spinning_friction, const std::string& name, std::uint32_t group, std::uint32_t mask, bool enabled,
             bool can_sleep, bool sensor, bool bullet) {
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
            d.can_sleep = can_sleep;
            d.sensor = sensor;
            d.bullet = bullet;
            return w.add_body(d);
          },
          py::arg("shape"), py::arg("is_static"), py::arg("is_kinematic"), py::arg("density"), py::arg("mass"),
          py::arg("inertia"), py::arg("position"), py::arg("orientation"), py::arg("velocity"),
          py::arg("angular_velocity"), py::arg("friction"), py::arg("restitution"), py::arg("spinning_friction"),
          py::arg("name"),
          py::arg("group"), py::arg("mask"), py::arg("enabled"), py::arg("can_sleep") = true, py::arg("sensor") = false,
          py::arg("bullet") = false)
      .def("remove_body", &World::remove_body, py::arg("i"))
      .def("remove_bodies", &World::remove_bodies, py::arg("indices"))
      .def("step", &World::step, py::arg("dt"), py::arg("steps") = 1, py::call_guard<py::gil_scoped_release>())
      .def("substep_count", &World::substep_count, py::arg("dt"))
      .def("set_position", &World::set_position)
      .def("set_orientation", &World::set_orientation)
      .def("set_velocity", &World::set_velocity)
      .def("set_angular_velocity", &World::set_angular_velocity)
      .def("set_external_wrench", &World::set_external_wrench)
      .def("set_positions", &World::set_positions)
      .def("set_orientations", &World::set_orientations)
      .def("set_velocities", &World::set_velocities)
      .def("set_angular_velocities", &World::set_angular_velocities)
      // no point: the centre of mass, read by the World under its lock once the index is checked
      .def("apply_impulse", [](World& w, BodyIndex i, const Vec3& J, std::optional<Vec3> point) {
        w.apply_impulse(i, J, point);
      })
      .def("apply_force", [](World& w, BodyIndex i, const Vec3& f, std::optional<Vec3> point) {
        w.apply_force(i, f, point);
      })
      .def("set_kinematic", &World::set_kinematic)
      .def("set_enabled", &World::set_enabled)
      .def("set_collision_filter", [](World& w, BodyIndex i, std::uint32_t group, std::uint32_t mask) {
        w.set_collision_filter(i, CollisionFilter{group, mask});
      })
      .def("set_pair_collision", &World::set_pair_collision)
      .def("set_awake", &World::set_awake)
      .def("set_can_sleep", &World::set_can_sleep)
      .def("set_sensor", &World::set_sensor, py::arg("i"), py::arg("sensor"))
      .def("set_bullet", &World::set_bullet, py::arg("i"), py::arg("bullet"))
      .def("set_sleep", [](World& w, const SleepSettings& sleep) {
        const auto held = w.lock();  // read, change, write as one call
        WorldSettings s = w.settings();
        s.sleep = sleep;
        w.set_settings(s);
      })
      .def("find", &World::find)
      .def("label", &World::label)
      .def("save_state", [](const World& w) { return py::bytes(w.save_state()); })
      .def("restore_state", [](World& w, const py::bytes& b) { w.restore_state(std::string(b)); })
      .def("set_material", [](World& w, BodyIndex i, double friction, double restitution, double spinning_friction) {
        w.set_material(i, Material{friction, restitution, spinning_friction});
      })
      .def("set_mass", &World::set_mass)
      .def("set_gravity", &World::set_gravity)
      .def("set_solver", [](World& w, const SolverSettings& solver) {
        const auto held = w.lock();  // read, change, write as one call
        WorldSettings s = w.settings();
        s.solver = solver;
        w.set_settings(s);
      })
      .def("shape", [](const World& w, BodyIndex i) {
        return bindings::from_shape(locked_copy(w, [i](const World& w) {
          w.label(i);  // BodyIndexError naming the index and the body count
          return w.model().shape[i];
        }));
      })
      .def_property_readonly("num_bodies", &World::num_bodies)
      .def_property_readonly("time", [](const World& w) {
        return locked_copy(w, [](const World& w) { return w.state().time; });
      })
      // state (N x 3, N x 3 x 3, N x 4): read-only views of the core's arrays, base = this World
      .def_property_readonly("positions", [](const py::object& self) { return state_view(self, &State::p, bindings::vec3_view); })
      .def_property_readonly("rotations", [](const py::object& self) { return state_view(self, &State::R, bindings::mat3_view); })
      .def_property_readonly("orientations", [](const py::object& self) { return state_view(self, &State::q, bindings::quat_view); })
      .def_property_readonly("velocities", [](const py::object& self) { return state_view(self, &State::v, bindings::vec3_view); })
      .def_property_readonly("angular_velocities", [](const py::object& self) { return state_view(self, &State::omega, bindings::vec3_view); })
      .def_property_readonly("forces", [](const py::object& self) { return state_view(self, &State::f_ext, bindings::vec3_view); })
      .def_property_readonly("torques", [](const py::object& self) { return state_view(self, &State::tau_ext, bindings::vec3_view); })
      // the next step's one-step force and torque, and pending impulse and angular impulse (N x 3)
      .def_property_readonly("step_forces", [](const py::object& self) { return state_view(self, &State::f_step, bindings::vec3_view); })
      .def_property_readonly("step_torques", [](const py::object& self) { return state_view(self, &State::tau_step, bindings::vec3_view); })
      .def_property_readonly("impulses", [](const py::object& self) { return state_view(self, &State::impulse, bindings::vec3_view); })
      .def_property_readonly("angular_impulses", [](const py::object& self) { return state_view(self, &State::angular_impulse, bindings::vec3_view); })
      // (N,) bool: awake (False asleep, or static); the sleep timers (N,) s, a copy
      .def_property_readonly("awake", [](const py::object& self) {
        return state_view(self, &State::awake, [](const py::handle& owner, const std::uint8_t* data, std::size_t n) {
          return bindings::readonly_view(owner, reinterpret_cast<const bool*>(data), {static_cast<py::ssize_t>(n)},
                                         {static_cast<py::ssize_t>(sizeof(bool))});
        });
      })
      .def_property_readonly("sleep_times", [](const World& w) {
        return py::array_t<double>(py::cast(locked_copy(w, [](const World& w) { return w.state().sleep_time; })));
      })
      // model
      .def_property_readonly("masses", [](const World& w) {
        return py::array_t<double>(py::cast(locked_copy(w, [](const World& w) { return w.model().mass; })));
      })
      .def_property_readonly("inv_masses", [](const World& w) {
        return py::array_t<double>(py::cast(locked_copy(w, [](const World& w) { return w.model().inv_mass; })));
      })
      // (N,) m: the radius of a ball each body's shape contains (inner_radius; inf for planes and
      // triangle meshes), which scales its contacts' slop
      .def_property_readonly("inner_radii", [](const World& w) {
        return py::array_t<double>(py::cast(locked_copy(w, [](const World& w) { return w.model().inner; })));
      })
      .def_property_readonly("inertias", [](const World& w) {
        return bindings::stack_of(locked_copy(w, [](const World& w) { return w.model().I_body; }));
      })
      .def_property_readonly("inv_inertias", [](const World& w) {
        return bindings::stack_of(locked_copy(w, [](const World& w) { return w.model().I_body_inv; }));
      })
      .def_property_readonly("frictions", [](const World& w) {
        return per_body<double>(w, [](const Model& m, std::size_t i) { return m.material[i].friction; });
      })
      .def_property_readonly("restitutions", [](const World& w) {
        return per_body<double>(w, [](const Model& m, std::size_t i) { return m.material[i].restitution; });
      })
      .def_property_readonly("spinning_frictions", [](const World& w) {
        return per_body<double>(w, [](const Model& m, std::size_t i) { return m.material[i].spinning_friction; });
      })
      .def_property_readonly("is_static", [](const World& w) {
        return per_body<bool>(w, [](const Model& m, std::size_t i) -> bool { return m.is_static[i]; });
      })
      .def_property_readonly("is_kinematic", [](const World& w) {
        return per_body<bool>(w, [](const Model& m, std::size_t i) -> bool { return m.is_kinematic[i]; });
      })
      .def_property_readonly("enabled", [](const World& w) {
        return per_body<bool>(w, [](const Model& m, std::size_t i) -> bool { return m.enabled[i]; });
      })
      .def_property_readonly("is_bullet", [](const World& w) {
        return per_body<bool>(w, [](const Model& m, std::size_t i) -> bool { return m.bullet[i]; });
      })
      .def_property_readonly("is_sensor", [](const World& w) {
        return per_body<bool>(w, [](const Model& m, std::size_t i) -> bool { return m.is_sensor[i]; });
      })
      .def_property_readonly("can_sleep", [](const World& w) {
        return per_body<bool>(w, [](const Model& m, std::size_t i) -> bool { return m.can_sleep[i]; });
      })
      .def_property_readonly("groups", [](const World& w) {
        return per_body<std::uint32_t>(w, [](const Model& m, std::size_t i) { return m.filter[i].group; });
      })
      .def_property_readonly("masks", [](const World& w) {
        return per_body<std::uint32_t>(w, [](const Model& m, std::size_t i) { return m.filter[i].mask; });
      })
      .def_property_readonly("names", [](const World& w) {
        return locked_copy(w, [](const World& w) { return w.model().name; });
      })
      .def_property_readonly("excluded_pairs", [](const World& w) {
        return locked_copy(w, [](const World& w) { return w.model().excluded_pairs; });
      })
      // settings
      .def_property_readonly("gravity", [](const World& w) { return w.settings().gravity; })
      .def_property_readonly("contact_margin", [](const World& w) { return w.settings().contact_margin; })
      .def_property_readonly("solver", [](const World& w) { return w.settings().solver; })
      .def_property_readonly("sleep", [](const World& w) { return w.settings().sleep; })
      .def_property_readonly("threads", [](const World& w) { return w.settings().threads; })
      .def("set_threads", [](World& w, int threads) {
        const auto held = w.lock();  // read, change, write as one call
        WorldSettings s = w.settings();
        s.threads = threads;
        w.set_settings(s);
      }, py::arg("threads"))
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
        d["pairs"] = s.pairs;
        d["recycled_pairs"] = s.recycled_pairs;
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
        d["continuous"] = r.continuous;
        d["worst_penetration_velocity"] = r.worst_penetration_velocity;
        d["worst_time"] = r.worst_time;
        return d;
      })
      .def_property_readonly("events", [](const World& w) {
        const ContactEvents e = w.events();
        py::dict d;
        d["begin"] = bindings::event_arrays(e.begin);
        d["end"] = bindings::event_arrays(e.end);
        d["hits"] = bindings::event_arrays(e.hits);
        d["sensor_begin"] = bindings::event_arrays(e.sensor_begin);
        d["sensor_end"] = bindings::event_arrays(e.sensor_end);
        return d;
      })
      .def_property("hit_speed", &World::hit_speed, &World::set_hit_speed)
      .def_property_readonly("step_profile", [](const World& w) {
        const StepProfile t = w.step_report().time;
        py::dict d;  // in the step's order (StepProfile), then the whole step
        d["guard"] = t.guard;
        d["detect"] = t.detect;
        d["wake"] = t.wake;
        d["prepare"] = t.prepare;
        d["solve"] = t.solve;
        d["integrate"] = t.integrate;
        d["relax"] = t.relax;
        d["store"] = t.store;
        d["continuous"] = t.continuous;
        d["commit"] = t.commit;
        d["total"] = t.total;
        return d;
      })
      // per body (N x 3): summed contact force (N) and torque about the com (N m) of the last step
      .def_property_readonly("contact_forces", [](const World& w) { return bindings::rows_of(w.contact_forces()); })
      .def_property_readonly("contact_torques", [](const World& w) { return bindings::rows_of(w.contact_torques()); })
      .def_property_readonly("warm_start_cache", [](const World& w) { return bindings::cache_arrays(w.warm_start_cache()); })
      // joints (docs/conventions.md, "Joints"): the Python layer builds the desc from sg.Revolute & co.
      .def("add_joint", [](World& w, int kind, BodyIndex body_a, BodyIndex body_b, const Vec3& anchor,
                           const Vec3& anchor_b, const Vec3& axis, bool has_limits, double lower, double upper,
                           bool motor, double motor_speed, double motor_max_force, double min_length,
                           double max_length, bool collide_connected, const std::string& name, double motor_position,
                           double motor_stiffness, double motor_damping, double friction, double break_force,
                           double break_torque, double effort, bool has_twist, double twist_lower,
                           double twist_upper) {
             if (kind < 0 || kind > static_cast<int>(JointKind::Distance))
               throw std::invalid_argument("add_joint: unknown joint kind " + std::to_string(kind));
             JointDesc d;
             d.kind = static_cast<JointKind>(kind);
             d.body_a = body_a, d.body_b = body_b;
             d.anchor = anchor, d.anchor_b = anchor_b, d.axis = axis;
             d.has_limits = has_limits, d.lower = lower, d.upper = upper;
             d.has_twist = has_twist, d.twist_lower = twist_lower, d.twist_upper = twist_upper;
             d.motor.enabled = motor, d.motor.speed = motor_speed, d.motor.max_force = motor_max_force;
             d.motor.position = motor_position, d.motor.stiffness = motor_stiffness, d.motor.damping = motor_damping;
             d.friction = friction;
             d.effort = effort;
             d.break_force = break_force, d.break_torque = break_torque;
             d.min_length = min_length, d.max_length = max_length;
             d.collide_connected = collide_connected;
             d.name = name;
             return w.add_joint(d);
           },
           py::arg("kind"), py::arg("body_a"), py::arg("body_b"), py::arg("anchor"), py::arg("anchor_b"), py::arg("axis"),
           py::arg("has_limits"), py::arg("lower"), py::arg("upper"), py::arg("motor"), py::arg("motor_speed"),
           py::arg("motor_max_force"), py::arg("min_length"), py::arg("max_length"), py::arg("collide_connected"),
           py::arg("name"), py::arg("motor_position") = 0.0, py::arg("motor_stiffness") = 0.0,
           py::arg("motor_damping") = 0.0, py::arg("friction") = 0.0,
           py::arg("break_force") = std::numeric_limits<double>::infinity(),
           py::arg("break_torque") = std::numeric_limits<double>::infinity(), py::arg("effort") = 0.0,
           py::arg("has_twist") = false, py::arg("twist_lower") = 0.0, py::arg("twist_upper") = 0.0)
      .def("set_joint_effort", &World::set_joint_effort, py::arg("j"), py::arg("effort"))
      .def("set_joint_broken", &World::set_joint_broken, py::arg("j"), py::arg("broken"))
      .def_property_readonly("joint_breaks", [](const World& w) {
        const std::vector<World::JointBreak> breaks = w.joint_breaks();
        const auto n = static_cast<py::ssize_t>(breaks.size());
        py::array_t<std::int64_t> step(n), joint(n);
        std::vector<Vec3> force, torque;
        for (py::ssize_t i = 0; i < n; ++i) {
          const World::JointBreak& b = breaks[static_cast<std::size_t>(i)];
          step.mutable_at(i) = b.step;
          joint.mutable_at(i) = b.joint;
          force.push_back(b.force);
          torque.push_back(b.torque);
        }
        py::dict d;
        d["step"] = step;
        d["joint"] = joint;
        d["force"] = bindings::rows_of(force);
        d["torque"] = bindings::rows_of(torque);
        return d;
      })
      .def("remove_joint", &World::remove_joint, py::arg("j"))
      .def("set_joint_motor", [](World& w, JointIndex j, bool enabled, double speed, double max_force, double position,
                                 double stiffness, double damping) {
             w.set_joint_motor(j, Motor{enabled, speed, max_force, position, stiffness, damping});
           },
           py::arg("j"), py::arg("enabled"), py::arg("speed"), py::arg("max_force"), py::arg("position") = 0.0,
           py::arg("stiffness") = 0.0, py::arg("damping") = 0.0)
      .def("find_joint", &World::find_joint)
      .def("joint_label", &World::joint_label)
      .def_property_readonly("num_joints", &World::num_joints)
      .def("joint", [](const World& w, JointIndex j) {
        const std::vector<Joint> all = w.joints();
        if (j < 0 || static_cast<std::size_t>(j) >= all.size())
          throw std::out_of_range("joint index " + std::to_string(j) + " is out of range: the world has " +
                                  std::to_string(all.size()) + " joints");
        const Joint& x = all[static_cast<std::size_t>(j)];
        py::dict d;
        d["kind"] = static_cast<int>(x.kind);
        d["body_a"] = x.a, d["body_b"] = x.b;
        d["anchor_a"] = x.anchor_a, d["anchor_b"] = x.anchor_b;
        d["axis_a"] = x.axis_a, d["axis_b"] = x.axis_b;
        d["ref_a"] = x.ref_a, d["ref_b"] = x.ref_b;
        d["R_rel"] = Mat3(x.R_rel);
        d["has_limits"] = x.has_limits, d["lower"] = x.lower, d["upper"] = x.upper;
        d["has_twist"] = x.has_twist, d["twist_lower"] = x.twist_lower, d["twist_upper"] = x.twist_upper;
        d["motor"] = x.motor.enabled, d["motor_speed"] = x.motor.speed, d["motor_max_force"] = x.motor.max_force;
        d["motor_position"] = x.motor.position, d["motor_stiffness"] = x.motor.stiffness;
        d["motor_damping"] = x.motor.damping;
        d["friction"] = x.friction;
        d["effort"] = x.effort;
        d["break_force"] = x.break_force, d["break_torque"] = x.break_torque, d["broken"] = x.broken;
        d["min_length"] = x.min_length, d["max_length"] = x.max_length;
        d["collide_connected"] = x.collide_connected;
        d["name"] = x.name;
        d["alpha"] = std::vector<double>(x.alpha.begin(), x.alpha.end());
        d["force"] = x.force, d["torque"] = x.torque;
        return d;
      })
      .def_property_readonly("joint_positions", [](const World& w) {
        const std::vector<double> x = w.joint_positions();
        py::array_t<double> out(static_cast<py::ssize_t>(x.size()));
        std::copy(x.begin(), x.end(), out.mutable_data());
        return out;
      })
      .def_property_readonly("joint_velocities", [](const World& w) {
        const std::vector<double> x = w.joint_velocities();
        py::array_t<double> out(static_cast<py::ssize_t>(x.size()));
        std::copy(x.begin(), x.end(), out.mutable_data());
        return out;
      })
      .def_property_readonly("joint_forces", [](const World& w) { return bindings::rows_of(w.joint_forces()); })
      // per joint, its rows' forces of the last substep by slot (J x kJointSlots; Joint::alpha)
      .def_property_readonly("joint_row_forces", [](const World& w) {
        const std::vector<Joint> all = w.joints();
        py::array_t<double> out({static_cast<py::ssize_t>(all.size()), static_cast<py::ssize_t>(kJointSlots)});
        auto o = out.mutable_unchecked<2>();
        for (std::size_t j = 0; j < all.size(); ++j)
          for (int k = 0; k < kJointSlots; ++k) o(static_cast<py::ssize_t>(j), k) = all[j].alpha[static_cast<std::size_t>(k)];
        return out;
      })
      .def_property_readonly("joint_torques", [](const World& w) { return bindings::rows_of(w.joint_torques()); })
      .def("kinetic_energy", &World::kinetic_energy)
      .def("potential_energy", &World::potential_energy);
  bindings::refuse_pickling(py::reinterpret_borrow<py::class_<World>>(m.attr("World")),
                            "pickle the signorini.World that holds it");

  // many worlds on one pool of threads (signorini.Batch holds the worlds and the output arrays)
  using Rows = py::array_t<double, py::array::c_style>;
  const auto out = [](Rows& a, const char* what) {
    if (!a.writeable()) throw std::invalid_argument(std::string("batch: ") + what + " must be writeable");
    return a.mutable_data();
  };
  py::class_<BatchStepper>(m, "BatchStepper")
      .def(py::init<int>(), py::arg("threads"))
      .def_property_readonly("threads", &BatchStepper::threads)
      .def(
          "step",
          [out](const BatchStepper& b, const std::vector<World*>& worlds, double dt, int steps,
                py::array_t<std::uint8_t, py::array::c_style> frozen, Rows p, Rows q, Rows v, Rows omega) {
            const std::size_t n = worlds.size(), N = n ? worlds[0]->num_bodies() : 0;
            const auto sized = [&](const py::array& a, std::size_t width, const char* what) {
              if (a.size() != static_cast<py::ssize_t>(n * N * width))
                throw std::invalid_argument(std::string("batch: ") + what + " has the wrong size");
            };
            sized(p, 3, "positions"), sized(q, 4, "orientations"), sized(v, 3, "velocities"), sized(omega, 3, "angular velocities");
            if (frozen.size() != static_cast<py::ssize_t>(n)) throw std::invalid_argument("batch: one flag per world");
            std::vector<std::uint8_t> flags(frozen.data(), frozen.data() + n);
            std::vector<std::string> errors(n);
            double *pp = out(p, "positions"), *qq = out(q, "orientations"), *vv = out(v, "velocities"),
                   *ww = out(omega, "angular velocities");
            {
              py::gil_scoped_release released;
              b.step(worlds, dt, steps, flags, errors, pp, qq, vv, ww);
            }
            std::copy(flags.begin(), flags.end(), frozen.mutable_data());
            return errors;
          },
          py::arg("worlds"), py::arg("dt"), py::arg("steps"), py::arg("frozen"), py::arg("positions"),
          py::arg("orientations"), py::arg("velocities"), py::arg("angular_velocities"))
      .def_static(
          "copy_state",
          [out](const World& w, std::size_t i, Rows p, Rows q, Rows v, Rows omega) {
            const std::size_t N = static_cast<std::size_t>(p.shape(1));
            if (static_cast<std::size_t>(p.shape(0)) <= i) throw std::invalid_argument("batch: world index out of range");
            BatchStepper::copy_state(w, N, i, out(p, "positions"), out(q, "orientations"), out(v, "velocities"),
                                     out(omega, "angular velocities"));
          },
          py::arg("world"), py::arg("i"), py::arg("positions"), py::arg("orientations"), py::arg("velocities"),
          py::arg("angular_velocities"));
  bindings::refuse_pickling(py::reinterpret_borrow<py::class_<BatchStepper>>(m.attr("BatchStepper")),
                            "pickle the worlds of the signorini.Batch that holds it (Batch.world(i))");
}
