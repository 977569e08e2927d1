"""Collide two shapes without a world, and read feature ids.

    import signorini as sg
    c = sg.collide(sg.Box((0.5, 0.5, 0.5)), ((0, 0, 0), (1, 0, 0, 0)),
                   sg.Sphere(0.2), ((0, 0, 0.69), (1, 0, 0, 0)), margin=0.0)
    c.gap, c.normal, c.feature_a

The contacts are those ``World.step`` would make for the pair (docs/conventions.md): up to 4
points, normals from A to B, gap < margin.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import _core
from .arguments import as_scalar, as_vector
from .world import Contacts

KINDS = ("shape", "vertex", "edge", "face")


class Feature(NamedTuple):
    """A decoded feature id: the compound part, mesh piece or triangle; the kind ("shape",
    "vertex", "edge", "face"); and the vertex, edge or face number within that part."""

    part: int
    kind: str
    index: int


def feature(feature_id) -> Feature:
    """Decodes one feature id (an element of ``Contacts.feature_a`` or ``feature_b``)."""
    f = int(feature_id)
    if f < 0 or f >= 2**64:
        raise ValueError(f"feature: {feature_id!r} is not a 64-bit feature id")
    return Feature(part=f >> 32, kind=KINDS[(f >> 28) & 0xF] if ((f >> 28) & 0xF) < 4 else "unknown",
                   index=f & 0x0FFFFFFF)


def _pose(pose, who: str):
    """(position (3,), quaternion (4,)) arrays from a user's pose, or a clear TypeError / ValueError."""
    if not isinstance(pose, (tuple, list)) or len(pose) != 2:
        raise TypeError(f"collide: {who} must be a pair (position, orientation), orientation a quaternion "
                        f"(w, x, y, z), got {pose!r}")
    # the core checks the values (finite, non-zero quaternion)
    return as_vector(pose[0], 3, "collide", f"{who} position"), as_vector(pose[1], 4, "collide", f"{who} orientation")


def collide(shape_a, pose_a, shape_b, pose_b, margin: float = 0.0) -> Contacts:
    """Contacts between shape_a at pose_a and shape_b at pose_b.

    A pose is ``(position, orientation)``: position (3,) m in the world frame, orientation a
    quaternion (w, x, y, z), normalised if not unit. ``margin`` (m, >= 0): pairs closer than this
    get speculative contacts with a positive gap. Returns the arrays of ``World.contacts`` with
    body_a = 0 (shape_a), body_b = 1 (shape_b) and zero alpha and impulse; the normal points from
    A to B. Raises ValueError for an unsupported pair or bad numbers, TypeError for a non-shape.
    """
    p_a, q_a = _pose(pose_a, "pose_a")
    p_b, q_b = _pose(pose_b, "pose_b")
    m = as_scalar(margin, "collide", "margin")
    return Contacts(**_core.collide(shape_a, p_a, q_a, shape_b, p_b, q_b, m))
