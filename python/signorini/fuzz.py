"""Seeded random scenes, each run in its own process and checked for what must never happen.

    python -m signorini.fuzz N SEED [-j JOBS] [--timeout S]   # N scenes of SEED, a summary line
    python -m signorini.fuzz --scene SEED:INDEX                # one scene, in this process, in detail

Scene INDEX of SEED is drawn from ``numpy.random.default_rng([SEED, INDEX])`` alone, so it is the
same whatever N, JOBS or the order of the runs (``generate``). A scene has 1 to 14 dynamic bodies
of every kind (sphere, box, capsule, cylinder, convex hull, convex mesh, compound), largest
dimension 1 cm to 10 m, masses within 1:1000 of each other, speeds to 50 m/s and 50 rad/s, over a
plane, a triangle-mesh height field, or a height field with a plane below it; dt is 1/60, 1/240 or
1/1000 and the scene runs ``DURATION`` seconds. Friction is 0 to 1, restitution 0 or up to 0.5,
and half the bodies have spinning (torsional) friction, up to 0.15 mu times their size (a contact
patch of a quarter of it), drawn from a second stream ``default_rng([SEED, INDEX, 1])`` so that
the shapes, poses and velocities are those the first stream drew before spinning friction. Half
the scenes also shoot 1 to 3 fast small bodies (1 to 2 cm, 20 to 200 m/s) down at the floor
(``_projectiles``, a fourth stream ``default_rng([SEED, INDEX, 3])``, after the other bodies): what
continuous collision is for.

Every step is checked (``run``). Failure classes, each with a one-line reproducer:

- ``crash``: the scene's process died (a signal); ``timeout``: it ran longer than ``--timeout``.
- ``exception``: the world raised; ``nonfinite``: the core undid a step that became non-finite;
  ``explosion``: the core undid a step whose energy grew by orders of magnitude.
- ``tunnel``: a body's centre of mass is below the floor surface under it by more than
  ``TUNNEL_DEPTH`` (1 mm + 5% of its bounding radius) at the end of the run. A convex body resting
  on the floor has its centre above the surface; one that has gone through keeps falling. A body
  whose centre left a height field's square at some step is not judged: it may have fallen past
  the field's edge and been pulled back under it by its joints (1:229, a ragdoll's thigh).
- ``off_shape``: a contact point y of ``detect_contacts`` is the midpoint of witness points w_A =
  y - gap/2 n on A and w_B = y + gap/2 n on B, so it lies within |gap| / 2 of each body. It fails
  when it is farther from body A or body B than |gap| (1/2 + ``POINT_SLACK``) + ``POINT_TOLERANCE``
  (1 + bounding radius); distances by closed forms and point-triangle distances in NumPy
  (``point_distance``), not by the core. A contact whose pair kept its manifold (``kept``, contact
  recycling) has its witness points carried with their bodies since they were found: they part by
  at most the pair's drift D, which recycling keeps under min(``recycle_distance``,
  ``RECYCLE_INNER_FRACTION`` r_inner) (r_inner the smaller of the bodies' ``inner_radii``), and
  its gap changed by at most D, so its point lies within (|gap| + 2 D) / 2 of each body: D is added
  to its bound (docs/conventions.md, "Contact recycling").
- ``energy``: the total energy (kinetic + gravitational, potential measured from the lowest floor
  point) rose above its starting value by more than ``ENERGY_GAIN`` (1%) at some step. A passive
  system under gravity, friction and restitution e <= 1 can only lose energy.
- ``slow``: a step took more than ``SLOW_STEP`` (100 ms) of wall time.

Jointed structures (``structures``, from a third stream ``default_rng([SEED, INDEX, 2])``, so the
free bodies are those drawn before; ``generate(..., joints=False)`` and ``--no-joints`` leave them
out): 1 or 2 per scene, each a chain of 2 to 8 links (hinges with and without limits and joint
friction, ball joints, distance rods and ropes) hanging from a small static box or free, or the
ragdoll of ``PARTS`` and ``RAGDOLL_JOINTS`` scaled to the scene; no motors (they do work), so the
energy target holds unchanged: joints do no work. Each starts in one rigid motion, which every
joint allows.

Measured and summarised, not failed: how far the joints open (``joint_errors``) relative to
``joint_gap``, the opening a converged solve allows: the PGS's position pass takes back erp of a
joint's error each substep h, so what a substep adds, h (tolerance + h spin^2 lever) (the solver's
residual and the second-order turn of the anchor over the substep), stays below that over erp; the
soft step's springs (``joint_hertz``, at most 0.25 / h) sag by the acceleration they carry, g + spin^2
lever, over their omega^2. It is not yet a failure class: on a first sample the PGS ends its 30
sweeps unconverged on jointed chains in contact and leaves errors of 1e-6 m at rest, 100 to 10,000
times this bound. The deepest overlap of a detected contact relative to the
smaller body's inner size (the radius of a ball it surely contains; a resting contact keeps the
solver's slop, at most 1 mm and 0.2 of that size; a body's contacts with the floor are not
measured once its centre has left a height field's square, as for ``tunnel``: fallen past the
field's edge, it can be pulled back in under the field from below), the largest energy gain, the
worst contact-point error and the slowest step, each with the scene it came from. The scenes whose
deepest overlap passes ``DEEP_OVERLAP`` are counted, and among them those whose moving bodies' masses
are within 1:``MASS_RATIO_TARGET`` (each scene's heaviest over its lightest, ``mass_ratio``: issue
21's overlap target covers those), named.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import codec
from ._core import Compound, Mesh, Plane, TriangleMesh, matrix_to_quat, quat_to_matrix
from .collision import feature
from .joints import Distance, Revolute, Spherical
from .meshes import box_mesh, cylinder_mesh, icosphere
from .scenes import axis_angle_quaternion
from .world import SolverWarning, World

DTS = (1.0 / 60.0, 1.0 / 240.0, 1.0 / 1000.0)
KINDS = ("sphere", "box", "capsule", "cylinder", "hull", "convex_mesh", "compound")
FLOORS = ("plane", "heightfield", "both")
MAX_BODIES = 14
DURATION = 1.5          # s simulated per scene
MAX_SPEED = 50.0        # m/s
MAX_SPIN = 50.0         # rad/s
ENERGY_GAIN = 0.01      # relative rise of the total energy above its start
ENERGY_FLOOR = 1e-9     # J: rises below this are rounding
SLOW_STEP = 0.1         # s of wall time per step
POINT_TOLERANCE = 1e-6  # m (plus 1e-6 of the body's size): contact points are exact, not fitted
POINT_SLACK = 0.05      # of |gap|: clipped speculative points sit on a face's plane, not always its face
# a kept manifold's drift is at most this fraction of its bodies' smaller inner radius (the core's
# collision::kRecycleInnerFraction) and at most recycle_distance
RECYCLE_INNER_FRACTION = 0.1
# overlaps past this fraction of the smaller body's inner size are counted in the summary (issue 21's
# target: none on 1,000 scenes)
DEEP_OVERLAP = 0.5
# the mass ratios issue 21's overlap target covers: a scene whose heaviest moving body (a
# structure's links counted) is at most this many times its lightest
MASS_RATIO_TARGET = 1000.0
JOINT_ROUNDING = 1e-12  # m (plus 1e-12 of the lever): anchors computed from poses of rounded floats
STRUCTURES = ("hanging_chain", "free_chain", "ragdoll")
MAX_STRUCTURES = 2
MAX_LINKS = 8
JOINT_KINDS = ("hinge", "ball", "distance")
FAILURES = ("crash", "timeout", "exception", "nonfinite", "explosion", "tunnel", "off_shape", "energy", "slow")


def TUNNEL_DEPTH(bounding_radius: float) -> float:
    """How far (m) a centre of mass may sit below the floor surface before it counts as tunnelled."""
    return 1e-3 + 0.05 * bounding_radius


# ------------------------------------------------------------------------------------ scenes

def _quaternion(rng) -> list:
    q = rng.normal(size=4)
    return (q / np.linalg.norm(q)).tolist()


def _log_uniform(rng, lo: float, hi: float) -> float:
    return float(10.0 ** rng.uniform(math.log10(lo), math.log10(hi)))


def _speed(rng, top: float) -> float:
    """0 for a third of the bodies (dropped from rest), else log-uniform from 1e-2 to top."""
    return 0.0 if rng.random() < 1.0 / 3.0 else _log_uniform(rng, 1e-2, top)


def _direction(rng) -> list:
    d = rng.normal(size=3)
    return (d / np.linalg.norm(d)).tolist()


def _primitive(rng, kind: str, h: float) -> dict:
    """A shape description of half size h (m): its largest half dimension is about h."""
    a = np.sort(rng.uniform(0.3, 1.0, size=3))[::-1]
    a[0] = 1.0
    rng.shuffle(a)
    if kind == "sphere":
        return {"type": "sphere", "radius": h}
    if kind == "box":
        return {"type": "box", "half_extents": (h * a).tolist()}
    if kind == "capsule":
        r = h * rng.uniform(0.2, 0.6)
        return {"type": "capsule", "radius": r, "half_length": max(h - r, 0.0)}
    if kind == "cylinder":
        return {"type": "cylinder", "radius": h * rng.uniform(0.2, 1.0), "half_height": h * rng.uniform(0.2, 1.0)}
    if kind == "hull":
        n = int(rng.integers(6, 25))
        d = rng.normal(size=(n, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return {"type": "hull", "points": (d * rng.uniform(0.5, 1.0, size=(n, 1)) * h * a).tolist()}
    if kind == "convex_mesh":
        form = ("icosphere", "prism", "box")[int(rng.integers(3))]
        if form == "icosphere":
            return {"type": "convex_mesh", "form": form, "scale": (h * a).tolist()}
        if form == "prism":
            return {"type": "convex_mesh", "form": form, "radius": h * rng.uniform(0.3, 1.0),
                    "half_height": h * rng.uniform(0.2, 1.0), "sides": int(rng.integers(3, 13))}
        return {"type": "convex_mesh", "form": form, "scale": (h * a).tolist()}
    if kind == "compound":
        parts = []
        for k in range(int(rng.integers(2, 4))):
            sub = ("sphere", "box", "capsule", "cylinder", "hull")[int(rng.integers(5))]
            hp = h * rng.uniform(0.35, 0.6)
            # parts overlap around the middle, so the centre of mass lies inside the body
            offset = (rng.uniform(-1.0, 1.0, size=3) * (h - hp) * 0.8).tolist()
            parts.append({"shape": _primitive(rng, sub, hp), "position": offset, "orientation": _quaternion(rng)})
        return {"type": "compound", "parts": parts}
    raise ValueError(f"unknown kind {kind!r}")


def _heightfield(rng, half_width: float) -> dict:
    """A square grid of heights (a few random waves) over [-W, W]^2, as vertices and triangles."""
    cells = int(rng.integers(6, 25))
    amplitude = half_width * rng.uniform(0.0, 0.08)
    waves = [(rng.normal(size=2) * rng.uniform(0.5, 3.0) / half_width, rng.uniform(0, 2 * np.pi), rng.random())
             for _ in range(3)]
    return {"half_width": half_width, "cells": cells, "amplitude": amplitude,
            "waves": [(k.tolist(), phase, weight) for k, phase, weight in waves],
            "noise_seed": int(rng.integers(2**31))}


def heightfield_mesh(hf: dict) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (n, 3), faces (k, 3)) of a height field description; faces counter-clockwise from +z,
    each grid cell (i, j) split along its (i, j)-(i+1, j+1) diagonal."""
    n, W = hf["cells"], hf["half_width"]
    x = np.linspace(-W, W, n + 1)
    X, Y = np.meshgrid(x, x, indexing="ij")
    Z = np.zeros_like(X)
    for k, phase, weight in hf["waves"]:
        Z += weight * np.sin(k[0] * X + k[1] * Y + phase)
    Z += 0.3 * np.random.default_rng(hf["noise_seed"]).uniform(-1.0, 1.0, size=Z.shape)
    Z *= hf["amplitude"]
    vertices = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    i, j = i.ravel(), j.ravel()
    v00, v10, v11, v01 = i * (n + 1) + j, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1, i * (n + 1) + j + 1
    faces = np.concatenate([np.stack([v00, v10, v11], 1), np.stack([v00, v11, v01], 1)]).astype(np.int64)
    return vertices, faces


def _place(rng, placed: list, rho: float, spread: float) -> np.ndarray:
    """A centre (3,) for something of bounding radius rho (m) clear of ``placed`` ((centre, radius)
    pairs, which it joins): 50 tries at a random spot, else on top of everything."""
    for _attempt in range(50):
        xy = rng.uniform(-spread, spread, size=2)
        z = rng.uniform(0.0, 2.0) + 1.5 * rho + 0.02
        c = np.array([xy[0], xy[1], z])
        if all(np.linalg.norm(c - p) > rho + r + 1e-3 for p, r in placed):
            break
    else:
        c[2] = max(p[2] + r for p, r in placed) + rho + 0.01
    placed.append((c, rho))
    return c


# Parts of a standing ragdoll (z up, facing +x, feet at z = 0): name, radius r (m), half length
# of the segment (m), centre (m), the segment's direction ("z" upright, "y" sideways). The pelvis
# comes first (pybullet's base), and every part after its parent. benchmarks/bench_joints.py's
# ragdoll is this one (its add_ragdoll), and the fuzzer's ragdolls are it scaled.
PARTS = (
    ("pelvis", 0.10, 0.06, (0.0, 0.0, 1.00), "y"),
    ("torso", 0.11, 0.08, (0.0, 0.0, 1.29), "z"),
    ("head", 0.10, 0.02, (0.0, 0.0, 1.62), "z"),
    ("upper_arm_l", 0.05, 0.10, (0.0, 0.35, 1.42), "y"),
    ("forearm_l", 0.045, 0.095, (0.0, 0.64, 1.42), "y"),
    ("upper_arm_r", 0.05, 0.10, (0.0, -0.35, 1.42), "y"),
    ("forearm_r", 0.045, 0.095, (0.0, -0.64, 1.42), "y"),
    ("thigh_l", 0.07, 0.145, (0.0, 0.10, 0.735), "z"),
    ("shin_l", 0.055, 0.175, (0.0, 0.10, 0.29), "z"),
    ("thigh_r", 0.07, 0.145, (0.0, -0.10, 0.735), "z"),
    ("shin_r", 0.055, 0.175, (0.0, -0.10, 0.29), "z"),
)
# Joints: name, parent, child, kind ("ball" or "hinge"), anchor (m), axis, limits. A hinge's axis
# and limits (rad; 0 is the standing pose, positive the way the joint bends: waist forward, elbows
# forward, knees backward); a ball joint's axis (along the child limb, out of the joint) and limits
# (cone, (twist lower, twist upper)) in rad: the child's axis within the cone of where it stands,
# its turn about that axis within the twist range.
RAGDOLL_JOINTS = (
    ("waist", "pelvis", "torso", "hinge", (0.0, 0.0, 1.10), (0.0, 1.0, 0.0), (-0.4, 1.2)),
    ("neck", "torso", "head", "ball", (0.0, 0.0, 1.50), (0.0, 0.0, 1.0), (0.6, (-0.8, 0.8))),
    ("shoulder_l", "torso", "upper_arm_l", "ball", (0.0, 0.20, 1.42), (0.0, 1.0, 0.0), (1.5, (-1.0, 1.0))),
    ("elbow_l", "upper_arm_l", "forearm_l", "hinge", (0.0, 0.50, 1.42), (0.0, 0.0, -1.0), (0.0, 2.5)),
    ("shoulder_r", "torso", "upper_arm_r", "ball", (0.0, -0.20, 1.42), (0.0, -1.0, 0.0), (1.5, (-1.0, 1.0))),
    ("elbow_r", "upper_arm_r", "forearm_r", "hinge", (0.0, -0.50, 1.42), (0.0, 0.0, 1.0), (0.0, 2.5)),
    ("hip_l", "pelvis", "thigh_l", "ball", (0.0, 0.10, 0.95), (0.0, 0.0, -1.0), (1.2, (-0.6, 0.6))),
    ("knee_l", "thigh_l", "shin_l", "hinge", (0.0, 0.10, 0.52), (0.0, 1.0, 0.0), (0.0, 2.5)),
    ("hip_r", "pelvis", "thigh_r", "ball", (0.0, -0.10, 0.95), (0.0, 0.0, -1.0), (1.2, (-0.6, 0.6))),
    ("knee_r", "thigh_r", "shin_r", "hinge", (0.0, -0.10, 0.52), (0.0, 1.0, 0.0), (0.0, 2.5)),
)
RAGDOLL_CENTRE = 0.87   # m: the standing ragdoll's mid-height
RAGDOLL_RADIUS = 1.0    # m: every part lies within this of (0, 0, RAGDOLL_CENTRE)


def _frame(rng, u) -> np.ndarray:
    """A rotation (3, 3) whose z column is the unit vector u, turned about it at random."""
    e = np.cross(u, rng.normal(size=3))
    e /= np.linalg.norm(e)
    return np.column_stack([e, np.cross(u, e), u])


def _rigid_velocities(bodies: list, pivot, v, w) -> None:
    """Gives every body dict the velocity of one rigid motion: v (3,) at ``pivot`` (3,), spin w (3,)."""
    for b in bodies:
        b["velocity"] = (np.asarray(v) + np.cross(w, np.asarray(b["position"]) - pivot)).tolist()
        b["angular_velocity"] = np.asarray(w, dtype=float).tolist()


def _material(rng) -> dict:
    return {"friction": float(rng.uniform(0.0, 1.0)),
            "restitution": float(rng.uniform(0.0, 0.5)) if rng.random() < 0.5 else 0.0, "spinning_friction": 0.0}


def _chain(rng, kind: str, placed: list, size0: float, mass0: float, spread: float) -> dict:
    """A chain of 2 to MAX_LINKS links (capsules, boxes or spheres along a random direction u, each
    of length l, touching end to end, masses within 1:10), each joined to the next at their common
    end by a hinge (a random axis; half of them with limits around 0, a quarter with joint
    friction), a ball joint or a distance joint (between points l / 4 inside either link: a rod of
    that length or a rope up to 30 % slack); a hanging chain's first link is so joined to a small
    static box (the hook) at the chain's start. Velocities are one rigid motion (a spin about the
    hook for a hanging chain, about the hook's axis if it is a hinge): consistent with every joint."""
    links = int(rng.integers(2, MAX_LINKS + 1))
    length = float(np.clip(size0 * 10.0 ** rng.uniform(-0.5, 0.5), 0.01, 10.0))
    u = np.array(_direction(rng))
    hanging = kind == "hanging_chain"
    shape = ("capsule", "box", "sphere")[int(rng.integers(3))]
    centre = _place(rng, placed, 0.5 * links * length + 0.5 * length, spread)
    start = centre - 0.5 * links * length * u
    mass = mass0 * 10.0 ** rng.uniform(0.0, 2.5)
    material = _material(rng)
    h = 0.5 * length
    bodies = []
    for k in range(links):
        R = _frame(rng, u)
        if shape == "capsule":
            r = h * rng.uniform(0.2, 0.5)
            d = {"type": "capsule", "radius": r, "half_length": h - r}
        elif shape == "box":
            d = {"type": "box", "half_extents": [h * rng.uniform(0.2, 0.6), h * rng.uniform(0.2, 0.6), h]}
        else:
            d = {"type": "sphere", "radius": h}
        bodies.append({"shape": d, "mass": mass * 10.0 ** rng.uniform(-0.5, 0.5),
                       "position": (start + (k + 0.5) * length * u).tolist(),
                       "orientation": list(matrix_to_quat(R)), **material})
    joints = []
    for k in range(0 if hanging else 1, links):
        point = start + k * length * u
        a, b = k - 1, k  # -1: the hook
        what = JOINT_KINDS[int(rng.integers(len(JOINT_KINDS)))]
        if what == "hinge":
            j = {"type": "hinge", "a": a, "b": b, "anchor": point.tolist(), "axis": _direction(rng), "limits": None,
                 "friction": 0.0}
            if rng.random() < 0.5:
                j["limits"] = [float(rng.uniform(-2.5, 0.0)), float(rng.uniform(0.0, 2.5))]
            if rng.random() < 0.25:
                j["friction"] = float(rng.uniform(0.0, 1.0) * bodies[b]["mass"] * 9.81 * length)
        elif what == "ball":
            j = {"type": "ball", "a": a, "b": b, "anchor": point.tolist()}
        else:
            rod = 0.5 * length
            j = {"type": "distance", "a": a, "b": b, "anchor_a": (point - 0.25 * length * u).tolist(),
                 "anchor_b": (point + 0.25 * length * u).tolist(), "min_length": rod, "max_length": rod}
            if rng.random() < 0.5:
                j["min_length"], j["max_length"] = 0.0, rod * float(rng.uniform(1.0, 1.3))
        joints.append(j)
    speed, spin = _speed(rng, MAX_SPEED), _speed(rng, MAX_SPIN)
    reach = links * length
    spin = min(spin, MAX_SPEED / reach)  # no point faster than MAX_SPEED
    if hanging:
        w = np.array(joints[0]["axis"]) if joints[0]["type"] == "hinge" else np.array(_direction(rng))
        _rigid_velocities(bodies, start, np.zeros(3), spin * w)
    else:
        _rigid_velocities(bodies, centre, speed * np.array(_direction(rng)), spin * np.array(_direction(rng)))
    hook = None
    if hanging:
        hook = {"shape": {"type": "box", "half_extents": [0.25 * length] * 3}, "position": start.tolist(),
                "orientation": [1.0, 0.0, 0.0, 0.0]}
    return {"kind": kind, "hook": hook, "bodies": bodies, "joints": joints, "self_collision": True}


def _ragdoll(rng, placed: list, size0: float, spread: float) -> dict:
    """The ragdoll of PARTS and RAGDOLL_JOINTS scaled by s (the torso about the scene's typical
    size; its smallest part 1 cm or more), of one density (100 to 10,000 kg/m^3), turned at random,
    its own parts not colliding (as the benchmark's), with one rigid motion's velocities."""
    # the smallest part's radius (0.045 s) at least 1 cm, as the docstring says: smaller ragdolls, a
    # few cm tall with parts of 2 to 9 mm spun to thousands of rad/s, are out of what the joints are
    # for (seed 7 scene 13 gained energy without bound at dt 1/240 until 16 substeps)
    s = float(np.clip(size0 / 0.4 * 10.0 ** rng.uniform(-0.3, 0.3), 0.01 / 0.045, 6.0))
    density = 1000.0 * 10.0 ** rng.uniform(-1.0, 1.0)
    R = np.asarray(quat_to_matrix(_quaternion(rng)))
    centre = _place(rng, placed, RAGDOLL_RADIUS * s, spread)
    t = centre - R @ np.array([0.0, 0.0, RAGDOLL_CENTRE * s])
    sideways = np.asarray(quat_to_matrix(axis_angle_quaternion((1.0, 0.0, 0.0), -0.5 * math.pi)))  # z -> y
    material = _material(rng)
    index, bodies = {}, []
    for part, radius, half_length, c, direction in PARTS:
        r, hl = radius * s, half_length * s
        index[part] = len(bodies)
        turn = R @ sideways if direction == "y" else R
        bodies.append({"shape": {"type": "capsule", "radius": r, "half_length": hl},
                       "mass": density * math.pi * r * r * (2.0 * hl + 4.0 / 3.0 * r),
                       "position": (R @ (s * np.asarray(c)) + t).tolist(),
                       "orientation": list(matrix_to_quat(turn)), **material})
    joints = []
    for _, parent, child, kind, anchor, axis, limits in RAGDOLL_JOINTS:
        y = (R @ (s * np.asarray(anchor)) + t).tolist()
        if kind == "ball":
            cone, twist = limits
            joints.append({"type": "ball", "a": index[parent], "b": index[child], "anchor": y,
                           "axis": (R @ np.asarray(axis)).tolist(), "cone": cone, "twist": list(twist)})
        else:
            joints.append({"type": "hinge", "a": index[parent], "b": index[child], "anchor": y,
                           "axis": (R @ np.asarray(axis)).tolist(), "limits": list(limits), "friction": 0.0})
    speed, spin = _speed(rng, MAX_SPEED), _speed(rng, MAX_SPIN)
    spin = min(spin, MAX_SPEED / (RAGDOLL_RADIUS * s))
    _rigid_velocities(bodies, centre, speed * np.array(_direction(rng)), spin * np.array(_direction(rng)))
    return {"kind": "ragdoll", "hook": None, "bodies": bodies, "joints": joints, "self_collision": False}


def structures(seed: int, index: int, placed: list, size0: float, mass0: float, spread: float) -> list:
    """The jointed structures of scene SEED:INDEX (1 to MAX_STRUCTURES of STRUCTURES), drawn from
    a third stream ``default_rng([SEED, INDEX, 2])`` after the free bodies were placed (``placed``)."""
    rng = np.random.default_rng([int(seed), int(index), 2])
    out = []
    for _ in range(int(rng.integers(1, MAX_STRUCTURES + 1))):
        kind = STRUCTURES[int(rng.integers(len(STRUCTURES)))]
        if kind == "ragdoll":
            out.append(_ragdoll(rng, placed, size0, spread))
        else:
            out.append(_chain(rng, kind, placed, size0, mass0, spread))
    return out


def _projectiles(seed: int, index: int, spread: float, placed: list, mass0: float) -> list:
    """Fast small bodies (issue 24, continuous collision), from a fourth stream
    ``default_rng([SEED, INDEX, 3])`` (the other bodies stay as drawn): in half the scenes 1 to 3
    spheres, capsules or boxes of 1 to 2 cm at 20 to 200 m/s (log-uniform), shot down at the floor
    from 0.1 to 1 m above everything placed, at most 60 degrees off the vertical; their mass the
    scene's least, mass0, so that its masses stay within 1000 of each other. Each joins ``placed``
    (centre, its size as the bound of its bounding radius, as the free bodies' do), so that the
    structures placed after them start clear of them (they did not: fuzz 1:770's chain began with a
    link 4 cm inside a 1 cm box, 926 % of its inner size, before any step)."""
    above = max((float(c[2]) + r for c, r in placed), default=0.0)
    rng = np.random.default_rng([int(seed), int(index), 3])
    if rng.random() < 0.5:
        return []
    out = []
    for _ in range(int(rng.integers(1, 4))):
        kind = ("sphere", "capsule", "box")[int(rng.integers(3))]
        size = _log_uniform(rng, 0.01, 0.02)
        tilt, heading = math.radians(rng.uniform(0.0, 60.0)), rng.uniform(0.0, 2.0 * math.pi)
        d = np.array([math.sin(tilt) * math.cos(heading), math.sin(tilt) * math.sin(heading), -math.cos(tilt)])
        out.append({
            "shape": _primitive(rng, kind, size / 2.0), "mass": mass0,
            "position": [float(rng.uniform(-spread, spread) / 2), float(rng.uniform(-spread, spread) / 2),
                         above + float(rng.uniform(0.1, 1.0))],
            "orientation": _quaternion(rng),
            "velocity": (_log_uniform(rng, 20.0, 200.0) * d).tolist(), "angular_velocity": [0.0, 0.0, 0.0],
            "friction": float(rng.uniform(0.0, 1.0)), "restitution": 0.0,
        })
        placed.append((np.asarray(out[-1]["position"], dtype=float), size))
    return out


def generate(seed: int, index: int, joints: bool = True, projectiles: bool | None = None) -> dict:
    """Scene `index` of `seed` as plain data (JSON-ready): floor, dt, bodies (with ``projectiles``,
    by default as ``joints``, the fast small bodies of ``_projectiles`` after the others) and
    (``joints``) structures; without both the scene is the one this fuzzer drew before it had
    joints."""
    rng = np.random.default_rng([int(seed), int(index)])
    spin_rng = np.random.default_rng([int(seed), int(index), 1])  # spinning friction (see above)
    floor = FLOORS[int(rng.integers(3))]
    dt = DTS[int(rng.integers(3))]
    count = int(rng.integers(1, MAX_BODIES + 1))
    size0 = _log_uniform(rng, 0.01, 10.0)      # largest dimension (m) of the scene's typical body
    mass0 = 1000.0 * (size0 / 2.0) ** 3        # kg
    spread = max(3.0 * size0, 0.5) * math.sqrt(count)
    scene = {"seed": int(seed), "index": int(index), "floor": floor, "dt": dt, "duration": DURATION}
    if floor in ("heightfield", "both"):
        scene["heightfield"] = _heightfield(rng, half_width=1.5 * spread + 2.0 * size0)
    bodies = []
    placed = []  # (centre, bounding radius) of the bodies so far, to start without overlaps
    for _ in range(count):
        kind = KINDS[int(rng.integers(len(KINDS)))]
        size = float(np.clip(size0 * 10.0 ** rng.uniform(-0.5, 0.5), 0.01, 10.0))
        shape = _primitive(rng, kind, size / 2.0)
        rho = size  # bounding radius bound: every part lies within h of its place, places within h
        c = _place(rng, placed, rho, spread)
        speed, spin = _speed(rng, MAX_SPEED), _speed(rng, MAX_SPIN)
        bodies.append({
            "shape": shape, "mass": mass0 * 10.0 ** rng.uniform(0.0, 3.0),
            "position": c.tolist(), "orientation": _quaternion(rng),
            "velocity": (speed * np.array(_direction(rng))).tolist(),
            "angular_velocity": (spin * np.array(_direction(rng))).tolist(),
            "friction": float(rng.uniform(0.0, 1.0)),
            "restitution": float(rng.uniform(0.0, 0.5)) if rng.random() < 0.5 else 0.0,
        })
        spinning = spin_rng.random() < 0.5
        mu_spin = spin_rng.uniform(0.0, 0.15)
        bodies[-1]["spinning_friction"] = float(mu_spin * bodies[-1]["friction"] * size) if spinning else 0.0
    if joints if projectiles is None else projectiles:
        bodies += _projectiles(seed, index, spread, placed, mass0)
    scene["bodies"] = bodies
    if joints:
        scene["structures"] = structures(seed, index, placed, size0, mass0, spread)
    return scene


def make_shape(d: dict):
    """The signorini shape of a description from ``generate``: the codec's data form, plus
    "convex_mesh" (an icosphere, prism or box mesh of the given form and size)."""
    t = d["type"]
    if t == "convex_mesh":
        if d["form"] == "icosphere":
            v, f = icosphere(1.0, 1)
            return Mesh(v * np.array(d["scale"]), f)
        if d["form"] == "prism":
            return Mesh(*cylinder_mesh(d["radius"], d["half_height"], d["sides"]))
        return Mesh(*box_mesh(d["scale"]))
    if t == "compound":
        return Compound([(make_shape(p["shape"]), (p["position"], p["orientation"])) for p in d["parts"]])
    return codec.shape_from_data(d)


def build(scene: dict):
    """(world, floor) for a scene; floor = {"plane": z or None, "heightfield": (vertices, faces) or None}."""
    world = World(**scene.get("world", {}))
    floor = {"plane": None, "heightfield": None}
    if "heightfield" in scene:
        v, f = heightfield_mesh(scene["heightfield"])
        world.add_static(TriangleMesh(v, f))
        floor["heightfield"] = (v, f)
    if scene["floor"] == "plane":
        floor["plane"] = 0.0
    elif scene["floor"] == "both":
        floor["plane"] = float(floor["heightfield"][0][:, 2].min()) - 0.05
    if floor["plane"] is not None:
        world.add_static(Plane((0.0, 0.0, 1.0), floor["plane"]))
    # bodies start above the highest floor point under them
    top = 0.0 if floor["heightfield"] is None else float(floor["heightfield"][0][:, 2].max())
    lift = np.array([0.0, 0.0, top])

    def add(b) -> int:
        return world.add_body(make_shape(b["shape"]), mass=b["mass"], position=np.array(b["position"]) + lift,
                              orientation=b["orientation"], velocity=b["velocity"],
                              angular_velocity=b["angular_velocity"], friction=b["friction"],
                              restitution=b["restitution"], spinning_friction=b.get("spinning_friction", 0.0))

    for b in scene["bodies"]:
        add(b)
    for structure in scene.get("structures", []):
        hook = structure["hook"]
        index = {}
        if hook is not None:
            index[-1] = world.add_static(make_shape(hook["shape"]), position=np.array(hook["position"]) + lift,
                                         orientation=hook["orientation"])
        for k, b in enumerate(structure["bodies"]):
            index[k] = add(b)
        for j in structure["joints"]:
            world.add_joint(_joint(j, index[j["a"]], index[j["b"]], lift))
        if not structure["self_collision"]:
            ids = [index[k] for k in range(len(structure["bodies"]))]
            for k, i in enumerate(ids):
                for other in ids[k + 1:]:
                    world.disable_collision(i, other)
    return world, floor


def _joint(j: dict, a: int, b: int, lift):
    """The joint description of a structure's joint dict between world bodies a and b."""
    if j["type"] == "hinge":
        return Revolute(a, b, anchor=np.array(j["anchor"]) + lift, axis=j["axis"],
                        limits=None if j["limits"] is None else tuple(j["limits"]), friction=j["friction"])
    if j["type"] == "ball":  # a chain's ball joints are free; a ragdoll's have a cone and a twist range
        limited = j.get("cone") is not None
        return Spherical(a, b, anchor=np.array(j["anchor"]) + lift, axis=j["axis"] if limited else None,
                         cone=j.get("cone"), twist=tuple(j["twist"]) if limited else None)
    return Distance(a, b, np.array(j["anchor_a"]) + lift, np.array(j["anchor_b"]) + lift, j["min_length"],
                    j["max_length"])


def joint_frames(world) -> dict:
    """What ``joint_errors`` needs of every joint of ``world``, read once: bodies (J, 2), anchors
    (J, 2, 3) in each body's frame (the core's), distance (J,) bool, min_length, max_length (J,)."""
    joints = [world.joint(k) for k in range(world.num_joints)]
    return {"bodies": np.array([[d["body_a"], d["body_b"]] for d in joints], dtype=np.int64).reshape(-1, 2),
            "anchors": np.array([[d["anchor_a"], d["anchor_b"]] for d in joints], dtype=float).reshape(-1, 2, 3),
            "distance": np.array([d["kind"] == "Distance" for d in joints], dtype=bool),
            "min_length": np.array([d["min_length"] for d in joints], dtype=float),
            "max_length": np.array([d["max_length"] for d in joints], dtype=float)}


def joint_errors(world, frames: dict) -> np.ndarray:
    """(J,) how far (m) each joint is from holding: a hinge's or ball joint's |x_B - x_A| between
    its anchor points x_X = p_X + R_X anchor_X, a distance joint's length |x_B - x_A| outside
    [min_length, max_length]. ``frames``: ``joint_frames(world)``."""
    P, R = world.positions, world.rotations
    a, b = frames["bodies"][:, 0], frames["bodies"][:, 1]
    x_a = P[a] + np.einsum("jik,jk->ji", R[a], frames["anchors"][:, 0])
    x_b = P[b] + np.einsum("jik,jk->ji", R[b], frames["anchors"][:, 1])
    gap = np.linalg.norm(x_b - x_a, axis=1)
    stretch = np.maximum(np.maximum(gap - frames["max_length"], frames["min_length"] - gap), 0.0)
    return np.where(frames["distance"], stretch, gap)


def joint_gap(h: float, settings: dict, spin, lever, g: float):
    """How far (m) a joint may be open after a step (the ``joint`` target), per joint: spin (J,)
    the faster of its bodies' angular speeds (rad/s), lever (J,) its longer lever arm |anchor_X|
    (m), h the substep (s), g (m/s^2), settings ``World.solver``. See the module's doc."""
    if settings["solver"] == "soft":
        omega = 2.0 * math.pi * min(settings["joint_hertz"], 0.25 / h)
        return (g + spin ** 2 * lever) / omega ** 2 + JOINT_ROUNDING * (1.0 + lever)
    return h / settings["erp"] * (settings["tolerance"] + h * spin ** 2 * lever) + JOINT_ROUNDING * (1.0 + lever)


# ------------------------------------------------------------------ distances from a point to a shape

def _point_triangle_distance(X, A, B, C):
    """Distances (k, m) from points X (k, 3) to triangles (A, B, C) (m, 3) each (closest-point regions)."""
    X = X[:, None, :]
    ab, ac = B - A, C - A
    ap = X - A
    n = np.cross(ab, ac)
    nn = np.einsum("ij,ij->i", n, n)
    # projection onto the plane, then barycentric coordinates
    d_plane = np.einsum("kmj,mj->km", ap, n) / np.where(nn > 0, nn, 1.0)
    q = X - d_plane[..., None] * n
    aq = q - A
    d00, d01, d11 = (np.einsum("ij,ij->i", ab, ab), np.einsum("ij,ij->i", ab, ac), np.einsum("ij,ij->i", ac, ac))
    d20, d21 = np.einsum("kmj,mj->km", aq, ab), np.einsum("kmj,mj->km", aq, ac)
    den = np.where(nn > 0, d00 * d11 - d01 * d01, 1.0)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    inside = (v >= 0) & (w >= 0) & (v + w <= 1) & (nn > 0)
    best = np.where(inside, np.linalg.norm(X - q, axis=-1), np.inf)
    for P, Q in ((A, B), (B, C), (C, A)):
        e = Q - P
        ee = np.einsum("ij,ij->i", e, e)
        s = np.clip(np.einsum("kmj,mj->km", X - P, e) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(X - (P + s[..., None] * e), axis=-1))
    return best


def _convex_faces_distance(X, vertices, faces):
    """Distances (k,) from points (k, 3) to a closed convex triangle mesh (0 inside)."""
    A, B, C = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    n = np.cross(B - A, C - A)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    inside = np.all(np.einsum("kmj,mj->km", X[:, None, :] - A, n) <= 0.0, axis=1)
    return np.where(inside, 0.0, _point_triangle_distance(X, A, B, C).min(axis=1))


def point_distance(shape: dict, p, R, X) -> np.ndarray:
    """Distances (k,) (m) from world points X (k, 3) to a bounded convex-part shape (an oracle
    shape dict, as ``signorini.shape_dict`` gives) placed at centre p (3,), rotation R (3, 3);
    0 for a point inside. Compounds take the nearest part."""
    X = np.atleast_2d(np.asarray(X, dtype=float))
    L = (X - p) @ np.asarray(R)  # body frame
    t = shape["type"]
    if t == "sphere":
        return np.maximum(np.linalg.norm(L, axis=1) - shape["radius"], 0.0)
    if t == "box":
        return np.linalg.norm(np.maximum(np.abs(L) - shape["half_extents"], 0.0), axis=1)
    if t == "capsule":
        z = np.clip(L[:, 2], -shape["half_length"], shape["half_length"])
        return np.maximum(np.linalg.norm(L - np.column_stack([0 * z, 0 * z, z]), axis=1) - shape["radius"], 0.0)
    if t == "cylinder":
        radial = np.maximum(np.hypot(L[:, 0], L[:, 1]) - shape["radius"], 0.0)
        axial = np.maximum(np.abs(L[:, 2]) - shape["half_height"], 0.0)
        return np.hypot(radial, axial)
    if t in ("hull", "mesh"):
        return _convex_faces_distance(L, np.asarray(shape["vertices"]), np.asarray(shape["faces"]))
    if t == "compound":
        return np.min([point_distance(part, pos, Rp, L) for part, pos, Rp in shape["parts"]], axis=0)
    raise ValueError(f"point_distance: unsupported shape type {t!r}")


def floor_height(floor: dict, x: float, y: float):
    """The floor's surface height (m) under (x, y), or None where there is no floor."""
    if floor["heightfield"] is not None:
        v, f = floor["heightfield"]
        A, B, C = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
        # barycentric coordinates in the xy projection
        d = (B[:, 1] - C[:, 1]) * (A[:, 0] - C[:, 0]) + (C[:, 0] - B[:, 0]) * (A[:, 1] - C[:, 1])
        l1 = ((B[:, 1] - C[:, 1]) * (x - C[:, 0]) + (C[:, 0] - B[:, 0]) * (y - C[:, 1])) / d
        l2 = ((C[:, 1] - A[:, 1]) * (x - C[:, 0]) + (A[:, 0] - C[:, 0]) * (y - C[:, 1])) / d
        l3 = 1.0 - l1 - l2
        hit = np.nonzero((l1 >= -1e-12) & (l2 >= -1e-12) & (l3 >= -1e-12))[0]
        if len(hit):
            k = hit[0]
            return float(l1[k] * A[k, 2] + l2[k] * B[k, 2] + l3[k] * C[k, 2])
    return floor["plane"]


def _floor_distance(floor: dict, X: np.ndarray) -> np.ndarray:
    """Distances (k,) from points to the floor solid (0 below its surface)."""
    best = np.full(len(X), np.inf)
    if floor["plane"] is not None:
        best = np.maximum(X[:, 2] - floor["plane"], 0.0)
    if floor["heightfield"] is not None:
        v, f = floor["heightfield"]
        for k, x in enumerate(X):
            h = floor_height(floor, x[0], x[1])
            if h is not None and x[2] <= h:
                best[k] = 0.0
            elif best[k] > 0.0:
                best[k] = min(best[k], _point_triangle_distance(x[None], v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]).min())
    return best


def _inner_size(shape: dict) -> float:
    """Radius (m) of a ball the shape surely contains (for relative overlaps)."""
    t = shape["type"]
    if t == "sphere":
        return shape["radius"]
    if t == "box":
        return float(np.min(shape["half_extents"]))
    if t == "capsule":
        return shape["radius"]
    if t == "cylinder":
        return min(shape["radius"], shape["half_height"])
    if t in ("hull", "mesh"):
        V, F = np.asarray(shape["vertices"]), np.asarray(shape["faces"])
        A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        n = np.cross(B - A, C - A)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        centre = V.mean(axis=0)
        return float(np.min(np.einsum("ij,ij->i", A - centre, n)))
    if t == "compound":
        return max(_inner_size(part) for part, _, _ in shape["parts"])
    return math.inf


def _bounding_radius(shape: dict) -> float:
    t = shape["type"]
    if t == "sphere":
        return shape["radius"]
    if t == "box":
        return float(np.linalg.norm(shape["half_extents"]))
    if t == "capsule":
        return shape["radius"] + shape["half_length"]
    if t == "cylinder":
        return math.hypot(shape["radius"], shape["half_height"])
    if t in ("hull", "mesh"):
        return float(np.linalg.norm(shape["vertices"], axis=1).max())
    if t == "compound":
        return max(np.linalg.norm(pos) + _bounding_radius(part) for part, pos, _ in shape["parts"])
    return math.inf


# ------------------------------------------------------------------------------------ running

def run(scene: dict, log=None) -> dict:
    """Runs a scene in this process and checks every step; returns the result as plain data:
    {"scene": "SEED:INDEX", "failures": {class: first message}, "steps", "max_step_ms",
    "max_overlap" (relative), "max_energy_gain" (relative), "max_point_error" (m), "wall" (s)}."""
    start = time.perf_counter()
    name = f"{scene['seed']}:{scene['index']}"
    failures: dict[str, str] = {}

    def fail(kind: str, message: str):
        if kind not in failures:
            failures[kind] = message
            if log:
                log(f"  {kind}: {message}")

    world, floor = build(scene)
    dt = scene["dt"]
    steps = int(round(scene["duration"] / dt))
    n = world.num_bodies
    shapes = [codec.shape_to_dict(world.shape(i)) for i in range(n)]
    static = world.is_static
    inner = np.array([math.inf if static[i] else _inner_size(shapes[i]) for i in range(n)])
    inner_radii = np.array(world.inner_radii)  # the core's, which its recycling reads
    recycle = world.solver["recycle_distance"]
    radius = np.array([0.0 if static[i] else _bounding_radius(shapes[i]) for i in range(n)])
    dynamic = np.nonzero(~static)[0]
    lowest = floor["plane"] if floor["heightfield"] is None else float(floor["heightfield"][0][:, 2].min())
    if floor["plane"] is not None:
        lowest = min(lowest, floor["plane"])
    masses = world.masses

    def energy() -> float:
        return world.kinetic_energy() + world.potential_energy() + float(
            np.sum(masses[dynamic]) * world.gravity[2] * lowest)

    E0 = energy()
    max_gain = 0.0
    # joints: how far each may open (joint_gap), from the solver's substep and the bodies' spin
    frames = joint_frames(world)
    lever = np.linalg.norm(frames["anchors"], axis=2).max(axis=1) if world.num_joints else np.zeros(0)
    settings = world.solver
    h = dt / world.substep_count(dt)
    g = float(np.linalg.norm(world.gravity))
    max_joint, joint_at = 0.0, ""
    max_overlap = 0.0
    overlap_at = ""
    max_point_error = 0.0
    max_step = 0.0
    done = 0
    # the bodies whose centre left the height field's square (never judged as tunnelled)
    field = float(np.abs(floor["heightfield"][0][:, :2]).max()) if floor["heightfield"] is not None else math.inf
    left = np.zeros(n, dtype=bool)
    floor_body = np.array([bool(static[i]) and shapes[i]["type"] in ("plane", "trimesh") for i in range(n)])
    for k in range(steps):
        # contacts of the state the step starts from: exact points, checked against both shapes
        c = world.detect_contacts(dt)
        if len(c):
            P, R = world.positions, world.rotations
            gap = c.gap
            rel = -gap / np.minimum(inner[c.body_a], inner[c.body_b])
            # (a body that left the height field's square may come back in under it: as for tunnel)
            under = floor_body[c.body_a] & left[c.body_b] | floor_body[c.body_b] & left[c.body_a]
            rel = np.where(under, 0.0, rel)
            worst = int(np.argmax(rel))
            if rel[worst] > max_overlap:
                max_overlap = float(rel[worst])
                overlap_at = (f"step {k}: bodies {c.body_a[worst]} - {c.body_b[worst]}, {-gap[worst]:.3g} m "
                              f"(inner size {min(inner[c.body_a[worst]], inner[c.body_b[worst]]):.3g} m)")
            allowed = np.abs(gap) * (0.5 + POINT_SLACK)
            if np.any(c.kept):  # recycled: the drift the pair may have made since it was found
                drift = np.minimum(recycle, RECYCLE_INNER_FRACTION * np.minimum(inner_radii[c.body_a], inner_radii[c.body_b]))
                allowed = allowed + np.where(c.kept, drift, 0.0)
            for side, bodies in (("A", c.body_a), ("B", c.body_b)):
                for i in np.unique(bodies):
                    rows = np.nonzero(bodies == i)[0]
                    X = c.point[rows]
                    if static[i]:
                        d = _floor_distance(floor, X) if shapes[i]["type"] in ("plane", "trimesh") else np.zeros(len(X))
                        size = 0.0
                    else:
                        d = point_distance(shapes[i], P[i], R[i], X)
                        size = radius[i]
                    excess = d - allowed[rows]
                    j = int(np.argmax(excess))
                    max_point_error = max(max_point_error, float(excess[j]))
                    if excess[j] > POINT_TOLERANCE * (1.0 + size):
                        other = (c.body_b if side == "A" else c.body_a)[rows[j]]
                        kinds = "-".join(feature(f[rows[j]]).kind for f in (c.feature_a, c.feature_b))
                        fail("off_shape", f"step {k} (t = {world.time:.4f} s): contact {c.body_a[rows[j]]} - "
                                          f"{c.body_b[rows[j]]} ({kinds}, gap {gap[rows[j]]:.4g} m) lies {d[j]:.4g} m from body {i}, "
                                          f"{excess[j]:.3g} m more than |gap| (1/2 + {POINT_SLACK:g}) "
                                          f"({shapes[i]['type']}; other body {other})")
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", SolverWarning)
                world.step(dt)
        except Exception as e:  # noqa: BLE001 - every failure is reported, none is fatal
            text = str(e)
            kind = "nonfinite" if "non-finite" in text else "explosion" if "energy" in text else "exception"
            fail(kind, f"step {k} (t = {world.time:.4f} s): {type(e).__name__}: {text}")
            break
        elapsed = time.perf_counter() - t0
        max_step = max(max_step, elapsed)
        if elapsed > SLOW_STEP:
            fail("slow", f"step {k} took {elapsed * 1e3:.0f} ms ({n} bodies, {len(c)} contacts)")
        if world.num_joints:
            a, b = frames["bodies"][:, 0], frames["bodies"][:, 1]
            W = world.angular_velocities
            spin = np.maximum(np.linalg.norm(W[a], axis=1), np.linalg.norm(W[b], axis=1))
            error = joint_errors(world, frames)
            ratio = error / joint_gap(h, settings, spin, lever, g)
            j = int(np.argmax(ratio))
            if ratio[j] > max_joint:
                max_joint = float(ratio[j])
                joint_at = (f"step {k} (t = {world.time:.4f} s): joint {j} ({world.joint(j)['kind']}, bodies {a[j]} - {b[j]}, "
                            f"lever {lever[j]:.3g} m, spin {spin[j]:.3g} rad/s) {error[j]:.3g} m apart, "
                            f"{ratio[j]:.3g} of its bound")
        if floor["heightfield"] is not None:
            left |= (np.abs(world.positions[:, :2]) > field).any(axis=1)
        E = energy()
        gain = (E - E0) / abs(E0) if E0 != 0 else 0.0
        if E - E0 > ENERGY_FLOOR:
            max_gain = max(max_gain, gain)
            if gain > ENERGY_GAIN:
                fail("energy", f"step {k} (t = {world.time:.4f} s): energy {E:.6g} J, start {E0:.6g} J (+{gain:.1%})")
        done = k + 1
    # tunnelling: a centre below the floor surface under it at the end
    P = world.positions
    for i in dynamic:
        h = floor_height(floor, P[i, 0], P[i, 1])
        if h is not None and not left[i] and P[i, 2] < h - TUNNEL_DEPTH(radius[i]):
            fail("tunnel", f"body {i} ({shapes[i]['type']}, radius {radius[i]:.3g} m) ends with its centre "
                           f"{h - P[i, 2]:.3g} m below the floor surface (speed {np.linalg.norm(world.velocities[i]):.3g} m/s)")
    return {"scene": name, "failures": failures, "steps": done, "max_step_ms": max_step * 1e3,
            "max_overlap": max_overlap, "overlap_at": overlap_at, "max_energy_gain": max_gain, "max_point_error": max_point_error,
            "max_joint": max_joint, "joint_at": joint_at, "joints": world.num_joints,
            "wall": time.perf_counter() - start, "bodies": len(dynamic), "dt": dt, "floor": scene["floor"],
            "mass_ratio": mass_ratio(masses[dynamic])}


def mass_ratio(masses: np.ndarray) -> float:
    """The heaviest of the moving bodies' masses over the lightest (1 with fewer than two)."""
    return float(masses.max() / masses.min()) if len(masses) > 1 else 1.0


def describe(scene: dict) -> str:
    """One line per body: kind, size, mass, speed."""
    lines = [f"scene {scene['seed']}:{scene['index']}: floor {scene['floor']}, dt 1/{round(1 / scene['dt'])}, "
             f"{len(scene['bodies'])} bodies, {scene['duration']} s"]
    first = ("heightfield" in scene) + (scene["floor"] in ("plane", "both"))  # static bodies come first
    for k, b in enumerate(scene["bodies"]):
        s = b["shape"]
        detail = {key: v for key, v in s.items() if key not in ("type", "points", "parts")}
        if s["type"] == "compound":
            detail = [p["shape"]["type"] for p in s["parts"]]
        lines.append(f"  body {first + k}: {s['type']} {detail} mass {b['mass']:.3g} kg, "
                     f"speed {np.linalg.norm(b['velocity']):.3g} m/s, spin {np.linalg.norm(b['angular_velocity']):.3g} rad/s")
    return "\n".join(lines)


def reproducer(name: str, solver: str | None = None) -> str:
    return f"python -m signorini.fuzz --scene {name}" + (f" --solver {solver}" if solver else "")


def with_solver(scene: dict, solver: str | None) -> dict:
    """The scene with its World's ``solver`` setting replaced (None: as generated, the default)."""
    if solver is not None:
        scene = {**scene, "world": {**scene.get("world", {}), "solver": solver}}
    return scene


def run_isolated(seed: int, index: int, timeout: float, solver: str | None = None, joints: bool = True) -> dict:
    """Runs scene SEED:INDEX in a child process (crash isolation, timeout); its result dict."""
    name = f"{seed}:{index}"
    start = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, "-m", "signorini.fuzz", "--scene", name, "--json"] +
                              (["--solver", solver] if solver else []) + ([] if joints else ["--no-joints"]),
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"scene": name, "failures": {"timeout": f"no result after {timeout:g} s"},
                "wall": time.perf_counter() - start}
    for line in reversed(proc.stdout.splitlines()):
        if line.startswith("{"):
            return json.loads(line)
    why = f"exit status {proc.returncode}"
    if proc.returncode < 0:
        why = f"killed by signal {-proc.returncode}"
    tail = proc.stderr.strip().splitlines()[-1:] or [""]
    return {"scene": name, "failures": {"crash": f"{why}: {tail[0]}"}, "wall": time.perf_counter() - start}


def run_many(count: int, seed: int, jobs: int = 1, timeout: float = 300.0, out=print,
             solver: str | None = None, joints: bool = True) -> dict:
    """Runs scenes 0..count-1 of seed, each in its own process, `jobs` at a time; prints one line per
    failure (with its reproducer) and the summary line; returns {"results": [...], "counts": {...},
    "summary": str}."""
    results = [None] * count

    def one(index):
        results[index] = run_isolated(seed, index, timeout, solver, joints)
        for kind, message in results[index]["failures"].items():
            out(f"FAIL {kind} {results[index]['scene']}: {message}  | {reproducer(results[index]['scene'], solver)}")
        return results[index]

    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        list(pool.map(one, range(count)))
    counts = {kind: sum(kind in r["failures"] for r in results) for kind in FAILURES}
    clean = sum(not r["failures"] for r in results)
    got = [r for r in results if "max_overlap" in r]

    def worst(key: str, fmt: str) -> str:
        if not got:
            return "-"
        r = max(got, key=lambda r: r[key])
        return f"{format(r[key], fmt)} ({r['scene']})"

    deep = [r for r in got if r["max_overlap"] > DEEP_OVERLAP]
    deep_in_range = [r for r in deep if r["mass_ratio"] <= MASS_RATIO_TARGET]
    summary = (f"fuzz {count} scenes, seed {seed}{f', solver {solver}' if solver else ''}: {clean} clean; " +
               ", ".join(f"{kind} {counts[kind]}" for kind in FAILURES) +
               f"; deepest overlap {worst('max_overlap', '.0%')} of inner size "
               f"({len(deep)} scenes past {DEEP_OVERLAP:.0%}, {len(deep_in_range)} of them with masses within "
               f"1:{MASS_RATIO_TARGET:.0f}{': ' + ', '.join(r['scene'] for r in deep_in_range) if deep_in_range else ''}), "
               f"worst point off its shapes "
               f"{worst('max_point_error', '.2g')} m, largest energy gain {worst('max_energy_gain', '.2%')}, "
               f"slowest step {worst('max_step_ms', '.1f')} ms, largest joint opening {worst('max_joint', '.3g')} of its "
               f"bound ({sum(r.get('joints', 0) > 0 for r in got)} scenes with joints), "
               f"{np.mean([r['wall'] for r in results]):.2f} s per scene")
    out(summary)
    return {"results": results, "counts": counts, "summary": summary}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m signorini.fuzz", description=__doc__.split("\n\n")[0])
    parser.add_argument("count", nargs="?", type=int, help="number of scenes")
    parser.add_argument("seed", nargs="?", type=int, default=0, help="seed (default 0)")
    parser.add_argument("-j", "--jobs", type=int, default=1, help="scenes run at a time (default 1)")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds per scene (default 300)")
    parser.add_argument("--scene", help="run scene SEED:INDEX in this process and report in detail")
    parser.add_argument("--json", action="store_true", help="with --scene: print the result as one JSON line")
    parser.add_argument("--no-joints", action="store_true", help="the scenes without their jointed structures")
    parser.add_argument("--solver", choices=("pgs", "soft"), help="run every scene with this solver "
                        "(default: as generated, the World's default)")
    args = parser.parse_args(argv)
    if args.scene:
        try:
            seed, index = (int(x) for x in args.scene.split(":"))
        except ValueError:
            parser.error(f"--scene takes SEED:INDEX, got {args.scene!r}")
        scene = with_solver(generate(seed, index, joints=not args.no_joints), args.solver)
        if args.json:
            print(json.dumps(run(scene)))
            return 0
        print(describe(scene))
        result = run(scene, log=print)
        print(f"{'clean' if not result['failures'] else 'FAILED: ' + ', '.join(result['failures'])}; "
              f"{result['steps']} steps, slowest {result['max_step_ms']:.1f} ms, "
              f"overlap {result['max_overlap']:.0%} ({result['overlap_at'] or 'none'}; masses 1:{result['mass_ratio']:.3g}), "
              f"energy gain {result['max_energy_gain']:.2%}, point error {result['max_point_error']:.2g} m, "
              f"{result['wall']:.1f} s")
        return 1 if result["failures"] else 0
    if args.count is None:
        parser.error("give N SEED, or --scene SEED:INDEX")
    if args.count < 0 or args.jobs < 1:
        parser.error("N must be >= 0 and -j >= 1")
    report = run_many(args.count, args.seed, args.jobs, args.timeout, solver=args.solver, joints=not args.no_joints)
    return 1 if any(report["counts"].values()) else 0


if __name__ == "__main__":
    sys.exit(main())
