"""The comparison harness: the C++ core against the NumPy oracle, step by step.

    python -m signorini.compare SCENE [--steps N] [--mode lockstep|free|both]

Two comparisons:
- lockstep: every step starts both from the core's state; the oracle is handed the core's contact
  list and re-derives the unconstrained velocity, the solve (the PGS, or the soft step of
  World(solver="soft")) and the integration, and the step's state, contact forces and certificate
  are compared. This isolates the dynamics and the solver (one-step agreement).
- free: the oracle detects its own contacts and runs on its own from the initial state, and the two
  trajectories are compared step by step (needs a scene whose pairs the oracle detects exactly:
  plane against sphere, box or mesh vertices; sphere against sphere).

Prints the largest per-step differences of positions, rotations, velocities and angular velocities
(and, lockstep, of the contacts and the certificate).
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field

import numpy as np

from . import oracle
from .meshes import torus
from ._core import Box, Capsule, Cylinder, Mesh, Plane, Sphere
from .world import World

STATE_KEYS = ("position", "rotation", "velocity", "angular_velocity")
# what lockstep also compares after each step: the step's contacts (Contacts) and its certificate
# (SolverStats). Forces are measured against the step's largest normal force F (at least 1 N): a
# force's rounding is a few ulps of the forces it is summed with, so a pile of heavy boxes and a
# ball are held to the same relative 1e-10; impulses against F dt, spin torques and the
# complementarity against F times 1 m and 1 m/s. Velocities (m/s) and the overlap (m) are absolute,
# as the state's.
CONTACT_KEYS = ("alpha", "impulse", "friction", "spin_torque", "normal_velocity", "slip")
CERTIFICATE_KEYS = ("residual", "max_alpha_negative", "max_penetration_velocity", "max_complementarity",
                    "max_cone_violation", "max_dissipation_violation", "max_overlap")
STAT_KEYS = ("contacts", "iterations", "restitution_iterations", "position_iterations", "converged")
# the scale of each compared quantity, in units of F (force), F dt (impulse) or 1 (absolute)
_SCALE = {"alpha": "F", "friction": "F", "spin_torque": "F", "impulse": "F dt", "normal_velocity": "1",
          "slip": "1", "residual": "1", "max_alpha_negative": "F", "max_penetration_velocity": "1",
          "max_complementarity": "F", "max_cone_violation": "F", "max_dissipation_violation": "F",
          "max_overlap": "1"}


@dataclass
class Report:
    """Largest differences, core minus oracle, over the steps compared (m, -, m/s, rad/s)."""

    mode: str
    steps: int
    max_diff: dict = field(default_factory=dict)
    worst_step: dict = field(default_factory=dict)
    contact_count_mismatches: int = 0
    # lockstep: the steps whose solver counts (STAT_KEYS) differ, and the first of them
    stat_mismatches: int = 0
    first_stat_mismatch: str = ""
    # lockstep, soft step: the steps in which a contact's gap was zero to rounding in a biased
    # sweep (``oracle.soft.soft_sweep``), those in which the core took another side than the
    # oracle's sign, and those with too many such contacts to try every side (compared as the
    # oracle chose)
    tied_steps: int = 0
    retied_steps: int = 0
    untried_steps: int = 0

    @property
    def largest(self) -> float:
        return max(self.max_diff.values()) if self.max_diff else 0.0

    def lines(self) -> list[str]:
        out = [f"{self.mode}: {self.steps} steps"]
        for k in (*STATE_KEYS, *CONTACT_KEYS, *CERTIFICATE_KEYS):
            if k in self.max_diff:
                scale = "" if _SCALE.get(k, "1") == "1" else f" / {_SCALE[k]}"
                out.append(f"  {k:25s} max |core - oracle|{scale:6s} = {self.max_diff[k]:.3e}  "
                           f"(step {self.worst_step[k]})")
        if self.mode == "free":
            out.append(f"  steps whose contact count differs: {self.contact_count_mismatches}")
        if self.mode == "lockstep":
            out.append(f"  steps whose solver counts differ: {self.stat_mismatches} {self.first_stat_mismatch}")
        if self.tied_steps:
            out.append(f"  steps with a gap zero to rounding: {self.tied_steps}, taken on the other side by "
                       f"the core: {self.retied_steps}, too many to try: {self.untried_steps}")
        return out


def _state(snapshot: dict) -> dict:
    return {k: np.asarray(snapshot[k], dtype=float) for k in STATE_KEYS}


def _track(report: Report, core: dict, orc: dict, k: int, keys=STATE_KEYS, scale=None) -> None:
    for key in keys:
        c, o = np.asarray(core[key], dtype=float), np.asarray(orc[key], dtype=float)
        d = float(np.max(np.abs(c - o))) if c.size else 0.0
        if scale is not None:
            d /= scale[_SCALE[key]]
        if d >= report.max_diff.get(key, -1.0):
            report.max_diff[key] = d
            report.worst_step[key] = k


def _track_solve(report: Report, world: World, info: dict, dt: float, k: int) -> None:
    """The step's contacts, certificate and solver counts, core (world) against oracle (info)."""
    contacts, stats = world.contacts, world.solver_stats
    F = max(1.0, float(np.max(contacts.alpha, initial=0.0)))
    scale = {"F": F, "F dt": F * dt, "1": 1.0}
    _track(report, {key: getattr(contacts, key) for key in CONTACT_KEYS}, info, k, CONTACT_KEYS, scale)
    _track(report, {key: getattr(stats, key) for key in CERTIFICATE_KEYS}, info, k, CERTIFICATE_KEYS, scale)
    core_counts = {key: getattr(stats, key) for key in STAT_KEYS}
    oracle_counts = {key: info["contacts"]["gap"].shape[0] if key == "contacts" else info[key] for key in STAT_KEYS}
    if {key: int(v) for key, v in core_counts.items()} != {key: int(v) for key, v in oracle_counts.items()}:
        report.stat_mismatches += 1
        if not report.first_stat_mismatch:
            report.first_stat_mismatch = f"(first: step {k}, core {core_counts}, oracle {oracle_counts})"


def lockstep(world: World, dt: float, steps: int) -> Report:
    """Steps the world; after every step compares it with one oracle step from the same state and
    the same contacts (those the step detects at its start; its substeps carry them along): the
    state (STATE_KEYS), the step's contacts (CONTACT_KEYS) and certificate (CERTIFICATE_KEYS), in
    the scales of ``_SCALE``, and the solver's counts (STAT_KEYS, which must be equal). The oracle
    runs the world's solver (``solver`` "pgs" or "soft"); a contact the world recycled (``kept``) reaches
    it with the lever arms its rows keep (anchor_a, anchor_b). The world is advanced by `steps` steps."""
    report = Report("lockstep", steps)
    for k in range(steps):
        before = world.snapshot()
        detected = world.detect_contacts(dt).as_dict()
        contacts = {key: detected[key] for key in ("body_a", "body_b", "point", "normal", "gap", "feature_a",
                                                   "feature_b")}
        if detected["kept"].any():  # recycled contacts: their rows keep the lever arms they were found with
            kept = detected["kept"][:, None]
            p = before["position"]
            contacts["anchor_a"] = np.where(kept, p[detected["body_a"]] + detected["arm_a"], detected["point"])
            contacts["anchor_b"] = np.where(kept, p[detected["body_b"]] + detected["arm_b"], detected["point"])
        world.step(dt)
        core = _state(world.snapshot())
        expected, info = oracle.step(before, dt, contacts=contacts)
        if info.get("tied"):
            expected, info = _closest_sides(report, core, before, dt, contacts, expected, info)
        _track(report, core, _state(expected), k + 1)
        _track_solve(report, world, info, dt, k + 1)
    return report


# at most this many contacts of one step whose gap is zero to rounding get every side tried (2^m
# oracle steps)
MAX_TIED = 4


def _closest_sides(report: Report, core: dict, before: dict, dt: float, contacts: dict, expected: dict,
                   info: dict) -> tuple[dict, dict]:
    """A soft step in which some contacts' gaps were zero to rounding in a biased sweep: the soft
    rule is discontinuous there (rigid above 0, a spring at and below), and which side the core's
    rounding put each on is not the oracle's to know. Returns, of the oracle's steps with every
    choice of sides for these contacts, the one closest to the core's state (largest absolute
    difference); the core must then agree with it as with any other step."""
    tied = info["tied"]
    report.tied_steps += 1
    if len(tied) > MAX_TIED:
        report.untried_steps += 1
        return expected, info

    def distance(state: dict) -> float:
        return max(float(np.max(np.abs(core[key] - np.asarray(state[key], dtype=float)), initial=0.0))
                   for key in STATE_KEYS)

    best, best_distance, moved = (expected, info), distance(expected), False
    for m in range(2 ** len(tied)):
        sides = {i: bool(m >> j & 1) for j, i in enumerate(tied)}
        state, other = oracle.step(before, dt, contacts=contacts, ties=sides)
        d = distance(state)
        if d < best_distance:
            best, best_distance, moved = (state, other), d, True
    report.retied_steps += moved
    return best



def free(world: World, dt: float, steps: int) -> Report:
    """Runs the core and an independent oracle rollout (its own contacts) from the same initial
    state, comparing every step. The world is advanced by `steps` steps."""
    report = Report("free", steps)
    snap = world.snapshot()
    for k in range(steps):
        world.step(dt)
        snap, info = oracle.step(snap, dt)
        _track(report, _state(world.snapshot()), _state(snap), k + 1)
        if len(info["contacts"]["gap"]) != len(world.contacts):
            report.contact_count_mismatches += 1
    return report


# scenes the oracle can follow on its own ---------------------------------------------------------
# They run every solver stage to its sweep limit (tolerance 0): a stopping test that sits on the
# tolerance could stop one side a sweep earlier than the other by rounding, and the free comparison
# would then measure that choice instead of the arithmetic. Friction is the default 0.5, spinning
# friction the default 0 except in ``spinners``.
SOLVER = {"tolerance": 0.0}

def tumbling_box() -> tuple[World, float, int]:
    """A box thrown spinning onto the ground: tumbles, bounces on corners and edges, settles."""
    w = World(gravity=(0, 0, -9.81), sleeping=False, **SOLVER)  # the oracle does not sleep
    w.add_static(Plane(normal=(0, 0, 1), offset=0.0))
    w.add_body(Box(half_extents=(0.3, 0.2, 0.1)), density=500.0, position=(0, 0, 0.6),
               orientation=(0.9, 0.3, 0.2, 0.1), velocity=(0.5, 0, 0), angular_velocity=(2.0, -3.0, 1.0))
    return w, 1 / 240, 500


def mesh_drop() -> tuple[World, float, int]:
    """A coarse torus mesh dropped tilted and spinning onto the ground (non-convex: its vertices
    against the plane, several at once)."""
    w = World(gravity=(0, 0, -9.81), sleeping=False, **SOLVER)  # the oracle does not sleep
    w.add_static(Plane(normal=(0, 0, 1), offset=0.0))
    v, f = torus(0.3, 0.1, 16, 8)
    w.add_body(Mesh(v, f), density=800.0, position=(0, 0, 0.6), orientation=(0.95, 0.25, 0.1, 0.0),
               angular_velocity=(0.5, 1.0, 0.0))
    return w, 1 / 240, 500


def spheres() -> tuple[World, float, int]:
    """Spheres on the ground: two meet head on, a third drops onto one of them."""
    w = World(gravity=(0, 0, -9.81), sleeping=False, **SOLVER)  # the oracle does not sleep
    w.add_static(Plane(normal=(0, 0, 1), offset=0.0))
    w.add_body(Sphere(0.2), mass=1.0, position=(-1.0, 0, 0.2), velocity=(2.0, 0, 0))
    w.add_body(Sphere(0.3), mass=2.0, position=(1.0, 0.05, 0.3), velocity=(-1.0, 0, 0))
    w.add_body(Sphere(0.15), mass=0.5, position=(1.0, 0.1, 1.2))
    return w, 1 / 240, 500


def stack() -> tuple[World, float, int]:
    """Box-box manifolds and capsules: three boxes dropped into a stack on a static box, each turned
    about the vertical, a capsule lying on the ground with a sphere landing on it, a cylinder
    standing on the ground."""
    w = World(gravity=(0, 0, -9.81), sleeping=False, **SOLVER)  # the oracle does not sleep
    w.add_static(Plane(normal=(0, 0, 1), offset=0.0))
    w.add_static(Box(half_extents=(0.6, 0.6, 0.1)), position=(0, 0, 0.1))
    for k, angle in enumerate((0.0, 0.4, 0.8)):
        w.add_body(Box(half_extents=(0.2, 0.2, 0.1)), density=500.0, position=(0.02 * k, 0, 0.31 + 0.21 * k),
                   orientation=(np.cos(angle / 2), 0, 0, np.sin(angle / 2)))
    w.add_body(Capsule(0.1, 0.3), density=500.0, position=(2.2, 0, 0.11), orientation=(np.sqrt(0.5), 0, np.sqrt(0.5), 0))
    w.add_body(Sphere(0.1), mass=0.5, position=(2.3, 0.02, 0.5))
    w.add_body(Cylinder(0.15, 0.2), density=500.0, position=(-2.2, 0, 0.25))
    return w, 1 / 240, 500


def spinners() -> tuple[World, float, int]:
    """Torsional friction at single-point contacts: balls spinning about the vertical on the ground
    (one sliding too, one spinning about a tilted axis), a ball dropped spinning onto a resting one
    (a sphere-sphere point), a capsule spinning upright on its end; the ground's spinning friction
    and the bodies' differ (a pair takes the larger), one ball has none against a ground with some."""
    w = World(gravity=(0, 0, -9.81), sleeping=False, **SOLVER)  # the oracle does not sleep
    w.add_static(Plane(normal=(0, 0, 1), offset=0.0), spinning_friction=0.0005)
    w.add_body(Sphere(0.1), mass=1.0, position=(0, 0, 0.1), angular_velocity=(0, 0, 8.0), spinning_friction=0.002)
    w.add_body(Sphere(0.15), mass=2.0, position=(1.0, 0, 0.15), velocity=(0.5, 0.2, 0),
               angular_velocity=(1.0, -0.5, -6.0), spinning_friction=0.003)
    w.add_body(Sphere(0.2), mass=1.5, position=(-1.0, 0.5, 0.2), angular_velocity=(0, 0, 5.0))
    w.add_body(Sphere(0.1), mass=0.5, position=(-1.0, 0.52, 0.65), angular_velocity=(0, 0, -4.0),
               spinning_friction=0.004)
    w.add_body(Capsule(0.05, 0.1), density=800.0, position=(0, 1.0, 0.15), angular_velocity=(0, 0, 10.0),
               spinning_friction=0.001)
    return w, 1 / 240, 500


COMPARE_SCENES = {"tumbling_box": tumbling_box, "mesh_drop": mesh_drop, "spheres": spheres, "stack": stack,
                  "spinners": spinners}


def build(name: str) -> tuple[World, float, int]:
    """(world, dt, steps) for a comparison scene or a built-in scene of ``signorini.scenes``, with
    contact recycling off: the oracle finds every pair anew every step, so the core must too for
    their contacts to agree to rounding (docs/conventions.md, "Contact recycling")."""
    if name in COMPARE_SCENES:
        world, dt, steps = COMPARE_SCENES[name]()
    else:
        from .scenes import SCENES, build as build_scene
        if name not in SCENES:
            known = ", ".join(sorted(set(COMPARE_SCENES) | set(SCENES)))
            raise ValueError(f"unknown scene {name!r}; known: {known}")
        scene = build_scene(name)
        world, dt, steps = scene.world, scene.dt, scene.steps
    world.set_solver(recycle_distance=0.0)
    return world, dt, steps


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m signorini.compare", description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", nargs="?", default="tumbling_box",
                        help="tumbling_box, mesh_drop, spheres, stack, spinners, or a built-in scene (torus, "
                             "boxes, shapes)")
    parser.add_argument("--steps", type=int, default=None, help="steps to compare (default: the scene's)")
    parser.add_argument("--mode", choices=("lockstep", "free", "both"), default="both")
    args = parser.parse_args(argv)
    try:
        world, dt, steps = build(args.scene)
    except ValueError as e:
        parser.error(str(e))
    if args.steps is not None:
        if args.steps < 1:
            parser.error("--steps must be >= 1")
        steps = args.steps
    print(f"scene {args.scene}: {world.num_bodies} bodies, dt = {dt:g} s")
    modes = ("lockstep", "free") if args.mode == "both" else (args.mode,)
    for mode in modes:
        w = build(args.scene)[0] if mode == "free" and args.mode == "both" else world
        try:
            report = (lockstep if mode == "lockstep" else free)(w, dt, steps)
        except NotImplementedError as e:
            print(f"{mode}: the oracle cannot follow this scene on its own: {e}")
            continue
        print("\n".join(report.lines()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
