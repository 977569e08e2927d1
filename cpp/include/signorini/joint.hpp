// Joints (docs/conventions.md, "Joints"): what a user asks for (JointDesc, world frame at creation)
// and what the World keeps (Joint, each body's frame). The rows a joint makes and how both solvers
// treat them are internal (cpp/src/solver/joint_rows.hpp).
#pragma once

#include <array>
#include <limits>
#include <string>

#include "signorini/types.hpp"

namespace signorini {

/// Index of a joint in a World: 0, 1, 2, ... in the order added; removing a joint (or a body it
/// holds) moves the later ones down one, like erasing from a list.
using JointIndex = int;

enum class JointKind {
  Revolute,   ///< hinge: the anchor points coincide, B turns about the axis only (1 dof: angle)
  Prismatic,  ///< slider: no relative turn, B moves along the axis only (1 dof: offset)
  Spherical,  ///< ball: the anchor points coincide (3 rotational dof)
  Fixed,      ///< weld: no relative motion (0 dof)
  Distance,   ///< min_length <= |x_B - x_A| <= max_length (a rope for min 0, a rod for min = max)
};

/// The drive of a one-degree-of-freedom joint (docs/conventions.md, "Joints", "Motors, servos and
/// damping"). With stiffness and damping both 0, a velocity motor: it drives the joint's velocity
/// (rad/s for a hinge, m/s for a slider) to `speed` with a force (N) or torque (N m) of at most
/// max_force. Otherwise a spring-damper drive, integrated implicitly over each substep:
/// F = stiffness (position - theta) + damping (speed - theta_dot), |F| <= max_force; a servo
/// (stiffness > 0) holds `position`, a damper (stiffness 0, speed 0) is joint damping, and
/// MuJoCo's velocity actuator is damping kv with speed the control.
struct Motor {
  bool enabled = false;
  double speed = 0.0;      ///< target joint velocity (rad/s or m/s)
  double max_force = 0.0;  ///< >= 0 (may be infinite): bound on |motor torque| (N m) or |motor force| (N)
  double position = 0.0;   ///< target coordinate of a servo (rad or m, as joint_position)
  double stiffness = 0.0;  ///< >= 0: N m/rad or N/m
  double damping = 0.0;    ///< >= 0: N m s/rad or N s/m
  /// a spring-damper drive (else a rigid velocity motor)
  bool soft() const { return stiffness > 0.0 || damping > 0.0; }
};

/// What a user asks for when adding a joint. Points and axes are world coordinates at the moment
/// of creation (the World converts them to each body's frame).
struct JointDesc {
  JointKind kind = JointKind::Revolute;
  BodyIndex body_a = 0, body_b = 0;  ///< two different bodies, not both static
  Vec3 anchor = Vec3::Zero();        ///< world point (m): the joint's point on both bodies (Distance: on A)
  Vec3 anchor_b = Vec3::Zero();      ///< Distance only: the world point on B (m)
  Vec3 axis = Vec3::UnitZ();         ///< Revolute, Prismatic: world direction, normalised (non-zero, finite)
  bool has_limits = false;           ///< Revolute (rad), Prismatic (m): lower <= coordinate <= upper
  double lower = 0.0, upper = 0.0;   ///< lower <= upper; the coordinate is 0 at creation
  /// Spherical with an axis: twist_lower <= psi <= twist_upper, psi B's twist about the axis
  /// relative to A once the swing is taken out (rad, 0 at creation; docs/conventions.md, "Joints")
  bool has_twist = false;
  double twist_lower = 0.0, twist_upper = 0.0;  ///< in (-pi, pi), twist_lower <= twist_upper
  Motor motor;                       ///< Revolute, Prismatic
  /// Revolute, Prismatic: Coulomb friction, the most torque (N m) or force (N) the joint resists
  /// sliding with (>= 0, finite; 0: none): a row J q_dot = 0 with |alpha| <= friction
  double friction = 0.0;
  /// Revolute, Prismatic: a torque (N m) or force (N) the joint applies along its coordinate every
  /// substep, +effort on B and -effort on A (MuJoCo's motor actuator, a ROS effort command); finite
  double effort = 0.0;
  double min_length = 0.0;           ///< Distance (m, >= 0)
  double max_length = std::numeric_limits<double>::infinity();  ///< Distance (m, >= min_length, > 0)
  bool collide_connected = false;    ///< false: bodies A and B get no contacts with each other
  std::string name;                  ///< "" or unique among the world's joints
  /// the joint breaks after a step whose last substep's force on B exceeded break_force (N), or its
  /// torque about B's anchor break_torque (N m): both > 0 (infinite: never)
  double break_force = std::numeric_limits<double>::infinity();
  double break_torque = std::numeric_limits<double>::infinity();
};

/// Slots of a joint's warm-start forces (Joint::alpha): each row block keeps its own.
enum JointSlot : int {
  kSlotMotor = 0,      ///< motor row (1)
  kSlotLower = 1,      ///< lower limit row (1); a Distance joint's lower (or equality) row
  kSlotUpper = 2,      ///< upper limit row (1)
  kSlotLinear = 3,     ///< point rows (3, world x y z) or a slider's two perpendicular rows (2)
  kSlotAngular = 6,    ///< angular rows: a hinge's two perpendicular rows, a weld's or slider's 3
  kSlotFriction = 9,   ///< friction row (1)
  kSlotEffort = 10,    ///< effort row (1): alpha = effort
  kSlotTwistLower = 6, ///< a ball joint's twist limits (1 each), in angular slots it has no rows for
  kSlotTwistUpper = 7,
  kJointSlots = 11,
};

/// A joint as the World keeps it. Anchors are lever arms from each body's centre of mass in the
/// body's frame (m); axes and references unit vectors in the body's frame. At creation
/// R_A axis_a = R_B axis_b and R_A ref_a = R_B ref_b (so the joint's coordinate is 0).
struct Joint {
  JointKind kind = JointKind::Revolute;
  BodyIndex a = 0, b = 0;
  Vec3 anchor_a = Vec3::Zero(), anchor_b = Vec3::Zero();  ///< body frames (m, from the com)
  Vec3 axis_a = Vec3::UnitZ(), axis_b = Vec3::UnitZ();    ///< body frames (unit)
  Vec3 ref_a = Vec3::UnitX(), ref_b = Vec3::UnitX();      ///< body frames, perpendicular to the axis (unit)
  Mat3 R_rel = Mat3::Identity();  ///< R_A^T R_B at creation: the relative rotation a weld or slider keeps
  bool has_limits = false;
  double lower = 0.0, upper = 0.0;
  bool has_twist = false;                       ///< JointDesc::has_twist
  double twist_lower = 0.0, twist_upper = 0.0;  ///< rad
  Motor motor;
  double friction = 0.0;  ///< N m or N (JointDesc::friction)
  double effort = 0.0;    ///< N m or N (JointDesc::effort)
  double min_length = 0.0, max_length = std::numeric_limits<double>::infinity();
  bool collide_connected = false;
  std::string name;
  double break_force = std::numeric_limits<double>::infinity();   ///< N (JointDesc::break_force)
  double break_torque = std::numeric_limits<double>::infinity();  ///< N m
  /// broken (by a force past its limits, or World::set_joint_broken): it makes no rows, links no
  /// island, transmits nothing, and its bodies collide unless something else keeps them apart
  bool broken = false;
  /// the rows' forces of the last substep (N for linear rows, N m for angular ones), by JointSlot:
  /// the next substep's and step's warm start
  std::array<double, kJointSlots> alpha{};
  /// what the joint transmits to B in the last substep (world): force (N), and torque about B's
  /// anchor point x_B = p_B + R_B anchor_b (N m); A gets the opposite force
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();

  /// One degree of freedom (Revolute, Prismatic): joint_position and joint_velocity are defined.
  bool one_dof() const { return kind == JointKind::Revolute || kind == JointKind::Prismatic; }
};

}  // namespace signorini
