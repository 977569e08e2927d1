"""Joints as a user writes them: ``w.add_joint(sg.Revolute(a, b, anchor=..., axis=...))``.

These are plain descriptions in world coordinates at the moment of creation (docs/conventions.md,
"Joints"); ``World.add_joint`` checks them, the core converts anchors and axes to each body's frame
and keeps the joint. Nothing here computes physics.

Bodies are indices (``add_body``'s return value); ``body_b`` may be a static body (the world).
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from .arguments import as_flag, as_index, as_name, as_number, as_vector

# the core's JointKind values
REVOLUTE, PRISMATIC, SPHERICAL, FIXED, DISTANCE = range(5)


class Motor:
    """The drive of a hinge or a slider (docs/conventions.md, "Motors, servos and damping").

    With ``stiffness`` and ``damping`` 0 (the default), a velocity motor: it drives the joint
    velocity (rad/s, m/s) to ``speed`` with at most ``max_force`` (N m for a hinge, N for a
    slider; ``max_torque`` is the same argument by another name). Otherwise a spring-damper,
    integrated implicitly over each substep: F = stiffness (position - x) + damping (speed - x_dot),
    |F| <= max_force (which may be ``math.inf``). A servo holds ``position`` (rad or m, as
    ``World.joint_positions``; a hinge's error is taken the short way round); joint damping is
    ``Motor(0, math.inf, damping=c)``; MuJoCo's velocity actuator is ``Motor(ctrl, max, damping=kv)``
    and its position actuator ``Motor(0, max, position=ctrl, stiffness=kp, damping=kv)``.
    """

    def __init__(self, speed: float, max_force: Optional[float] = None, *, max_torque: Optional[float] = None,
                 position: float = 0.0, stiffness: float = 0.0, damping: float = 0.0):
        if (max_force is None) == (max_torque is None):
            raise TypeError("Motor: give max_force (or max_torque), once")
        self.speed = speed
        self.max_force = max_force if max_force is not None else max_torque
        self.position = position
        self.stiffness = stiffness
        self.damping = damping

    def _core_args(self, who: str) -> dict:
        """The motor's numbers, type-checked (values are the core's to check)."""
        return dict(speed=as_number(self.speed, who, "motor speed"),
                    max_force=as_number(self.max_force, who, "motor max_force"),
                    position=as_number(self.position, who, "motor position"),
                    stiffness=as_number(self.stiffness, who, "motor stiffness"),
                    damping=as_number(self.damping, who, "motor damping"))

    def __repr__(self) -> str:
        extra = "".join(f", {k}={getattr(self, k)!r}" for k in ("position", "stiffness", "damping") if getattr(self, k))
        return f"Motor(speed={self.speed!r}, max_force={self.max_force!r}{extra})"


class Joint:
    """What every joint description has: two bodies, a name, whether they collide, and when it
    breaks: after a step whose last substep's force on B passed ``break_force`` (N) or its torque
    about B's anchor ``break_torque`` (N m), both > 0, None: never (``World.joint_breaks``)."""
    kind = -1

    def __init__(self, body_a: int, body_b: int, *, name: Optional[str] = None,
                 break_force: Optional[float] = None, break_torque: Optional[float] = None,
                 collide_connected: bool = False):
        self.body_a = body_a
        self.body_b = body_b
        self.name = name
        self.collide_connected = collide_connected
        self.break_force = break_force
        self.break_torque = break_torque

    def __repr__(self) -> str:
        fields = ", ".join(f"{k}={v!r}" for k, v in vars(self).items() if v is not None)
        return f"{type(self).__name__}({fields})"

    def _core_args(self, who: str, positions: np.ndarray) -> dict:
        """The keyword arguments of the core's add_joint, type-checked (values are the core's to check)."""
        a = as_index(self.body_a, who, "body_a")
        b = as_index(self.body_b, who, "body_b")
        return dict(body_a=a, body_b=b, anchor=np.zeros(3), anchor_b=np.zeros(3), axis=np.array([0.0, 0.0, 1.0]),
                    has_limits=False, lower=0.0, upper=0.0, motor=False, motor_speed=0.0, motor_max_force=0.0,
                    min_length=0.0, max_length=math.inf,
                    collide_connected=as_flag(self.collide_connected, who, "collide_connected"),
                    name=as_name(self.name, who),
                    break_force=_limit(self.break_force, who, "break_force"),
                    break_torque=_limit(self.break_torque, who, "break_torque"))


def _limit(x, who: str, what: str) -> float:
    """A breaking limit: None is never (infinite)."""
    return math.inf if x is None else as_number(x, who, what)


def _limits(limits, who: str, what: str = "limits") -> dict:
    if limits is None:
        return dict(has_limits=False)
    if isinstance(limits, (str, bytes)) or not hasattr(limits, "__len__") or len(limits) != 2:
        raise TypeError(f"{who}: {what} must be (lower, upper), got {limits!r}")
    return dict(has_limits=True, lower=as_number(limits[0], who, f"{what}[0]"),
                upper=as_number(limits[1], who, f"{what}[1]"))


def _motor(motor, who: str) -> dict:
    if motor is None:
        return dict(motor=False)
    if not isinstance(motor, Motor):
        raise TypeError(f"{who}: motor must be a signorini.Motor, got {motor!r}")
    return {"motor": True, **{f"motor_{k}": v for k, v in motor._core_args(who).items()}}


class _Axial(Joint):
    """A one-degree-of-freedom joint about or along an axis (world, at creation)."""

    def __init__(self, body_a: int, body_b: int, anchor=None, axis=(0.0, 0.0, 1.0), *, limits=None,
                 motor: Optional[Motor] = None, friction: float = 0.0, effort: float = 0.0,
                 name: Optional[str] = None,
                 break_force: Optional[float] = None, break_torque: Optional[float] = None,
                 collide_connected: bool = False):
        super().__init__(body_a, body_b, name=name, collide_connected=collide_connected,
                         break_force=break_force, break_torque=break_torque)
        self.anchor = anchor
        self.axis = axis
        self.limits = limits
        self.motor = motor
        self.friction = friction
        self.effort = effort

    def _core_args(self, who: str, positions: np.ndarray) -> dict:
        d = super()._core_args(who, positions)
        anchor = self.anchor
        if anchor is None:
            if self.kind == REVOLUTE:
                raise TypeError(f"{who}: a hinge needs its anchor (a world point)")
            anchor = positions[d["body_b"]] if 0 <= d["body_b"] < len(positions) else np.zeros(3)
        d.update(anchor=as_vector(anchor, 3, who, "anchor"), axis=as_vector(self.axis, 3, who, "axis"),
                 **_limits(self.limits, who), **_motor(self.motor, who),
                 friction=as_number(self.friction, who, "friction"), effort=as_number(self.effort, who, "effort"))
        return d


class Revolute(_Axial):
    """A hinge: the bodies share the ``anchor`` point and B turns about ``axis`` only (world, at
    creation). ``limits=(lo, hi)`` (rad, in (-pi, pi); the angle is 0 at creation, positive when B
    turns counter-clockwise about the axis relative to A); ``motor=Motor(speed, max_torque)``;
    ``friction`` (N m): Coulomb friction, the most torque the hinge resists turning with; ``effort``
    (N m): a torque it applies about the axis, on B (-effort on A), every substep
    (``World.set_joint_effort`` sets it per step: MuJoCo's motor actuator)."""
    kind = REVOLUTE


class Prismatic(_Axial):
    """A slider: no relative turn, and B moves along ``axis`` (world, at creation) only. ``anchor``
    defaults to B's centre of mass; ``limits=(lo, hi)`` (m, the offset is 0 at creation);
    ``motor=Motor(speed, max_force)``; ``friction`` (N): the most force it resists sliding with;
    ``effort`` (N): a force it applies along the axis, on B (-effort on A)."""
    kind = PRISMATIC


class Spherical(Joint):
    """A ball joint: the bodies share the ``anchor`` point (world, at creation). With ``axis`` (world,
    at creation; fixed in each body from then on), a ragdoll's shoulder or hip:

    - ``cone`` (rad, in (0, pi)): a swing limit, B's axis within ``cone`` of A's;
    - ``twist=(lo, hi)`` (rad, in (-pi, pi)): B's turn about the axis relative to A, once the
      swing is taken out (0 at creation), within [lo, hi].

    Each is solved as a hinge's limit is (a speculative row, restitution 0)."""
    kind = SPHERICAL

    def __init__(self, body_a: int, body_b: int, anchor, *, axis=None, cone: Optional[float] = None,
                 twist=None, name: Optional[str] = None, break_force: Optional[float] = None,
                 break_torque: Optional[float] = None, collide_connected: bool = False):
        super().__init__(body_a, body_b, name=name, collide_connected=collide_connected,
                         break_force=break_force, break_torque=break_torque)
        self.anchor = anchor
        self.axis = axis
        self.cone = cone
        self.twist = twist

    def _core_args(self, who: str, positions: np.ndarray) -> dict:
        d = super()._core_args(who, positions)
        d["anchor"] = as_vector(self.anchor, 3, who, "anchor")
        cone, twist = getattr(self, "cone", None), getattr(self, "twist", None)
        if cone is not None or twist is not None:
            if self.axis is None:
                raise TypeError(f"{who}: a cone or twist range needs its axis (world, at creation), got axis=None")
            d["axis"] = as_vector(self.axis, 3, who, "axis")
        elif getattr(self, "axis", None) is not None:
            raise TypeError(f"{who}: axis is the cone's and twist's axis: give cone= or twist= with it, or no axis")
        if cone is not None:
            d.update(has_limits=True, lower=0.0, upper=as_number(cone, who, "cone"))
        if twist is not None:
            limits = _limits(twist, who, "twist")
            d.update(has_twist=True, twist_lower=limits["lower"], twist_upper=limits["upper"])
        return d


class Fixed(Spherical):
    """A weld: no relative motion from the poses at creation. ``anchor`` (the point whose force and
    torque are reported) defaults to B's centre of mass."""
    kind = FIXED

    def __init__(self, body_a: int, body_b: int, anchor=None, *, name: Optional[str] = None,
                 break_force: Optional[float] = None, break_torque: Optional[float] = None,
                 collide_connected: bool = False):
        super().__init__(body_a, body_b, anchor, name=name, collide_connected=collide_connected,
                         break_force=break_force, break_torque=break_torque)

    def _core_args(self, who: str, positions: np.ndarray) -> dict:
        if self.anchor is None:
            d = Joint._core_args(self, who, positions)
            d["anchor"] = positions[d["body_b"]].copy() if 0 <= d["body_b"] < len(positions) else np.zeros(3)
            return d
        return super()._core_args(who, positions)


class Distance(Joint):
    """min_length <= |x_B - x_A| <= max_length for the points ``anchor_a`` on A and ``anchor_b`` on
    B (world, at creation; m). Both None: a rod of the current length; ``min_length=0`` with a
    ``max_length``: a rope; ``min_length == max_length``: a rod."""
    kind = DISTANCE

    def __init__(self, body_a: int, body_b: int, anchor_a, anchor_b, min_length: Optional[float] = None,
                 max_length: Optional[float] = None, *, name: Optional[str] = None,
                 break_force: Optional[float] = None, break_torque: Optional[float] = None,
                 collide_connected: bool = False):
        super().__init__(body_a, body_b, name=name, collide_connected=collide_connected,
                         break_force=break_force, break_torque=break_torque)
        self.anchor_a = anchor_a
        self.anchor_b = anchor_b
        self.min_length = min_length
        self.max_length = max_length

    def _core_args(self, who: str, positions: np.ndarray) -> dict:
        d = super()._core_args(who, positions)
        a = as_vector(self.anchor_a, 3, who, "anchor_a")
        b = as_vector(self.anchor_b, 3, who, "anchor_b")
        length = float(np.linalg.norm(b - a))
        lo = None if self.min_length is None else as_number(self.min_length, who, "min_length")
        hi = None if self.max_length is None else as_number(self.max_length, who, "max_length")
        if lo is None and hi is None:
            lo = hi = length
        d.update(anchor=a, anchor_b=b, min_length=0.0 if lo is None else lo, max_length=math.inf if hi is None else hi)
        return d


KINDS = {REVOLUTE: "Revolute", PRISMATIC: "Prismatic", SPHERICAL: "Spherical", FIXED: "Fixed", DISTANCE: "Distance"}
