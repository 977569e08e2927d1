"""Queries a World answers between steps (issue 24): what the results look like and how the
arguments are converted. No geometry here: the C++ core casts the rays and tests the shapes
(docs/conventions.md, "Queries"); ``World.cast_ray`` and its siblings call these helpers.

A ray is ``origin + t u`` with ``u = direction / |direction|`` and ``t`` in ``[0, max_distance]``
(metres, world frame). A ray that starts strictly inside a solid hits it at distance 0 with normal
``-u``; triangle meshes are surfaces, hit from either side. Bodies are seen when enabled and their
filter meets the query's (``group`` and ``mask``, as two bodies' filters meet), and not in
``exclude``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .arguments import as_bits, as_indices, as_number, as_rows, as_vector, readonly


@dataclass(frozen=True)
class Hit:
    """Where a ray meets a body: ``body`` index, ``point`` (3,) m world, unit ``normal`` (3,) out of
    the body (a triangle: towards the ray's side), ``distance`` m along the unit direction, and the
    surface's ``feature`` id (``signorini.feature(hit.feature)`` unpacks it)."""
    body: int
    point: np.ndarray
    normal: np.ndarray
    distance: float
    feature: int


@dataclass(frozen=True)
class ShapeHit:
    """Where a swept shape first touches a body (``World.cast_shape``): ``body`` index, ``fraction``
    of the translation in [0, 1] (0: it overlaps the body where it starts), ``point`` (3,) m world
    where they touch, unit ``normal`` (3,) out of the body, against the sweep."""
    body: int
    fraction: float
    point: np.ndarray
    normal: np.ndarray


def shape_hit(t) -> ShapeHit | None:
    """A ShapeHit from the core's (body, fraction, point, normal), or None."""
    if t is None:
        return None
    body, fraction, point, normal = t
    return ShapeHit(int(body), float(fraction), readonly(np.array(point, dtype=float)),
                    readonly(np.array(normal, dtype=float)))


@dataclass(frozen=True)
class RayHits:
    """Closest hits of n rays, row k for ray k: ``body`` (n,) int32, -1 where nothing is hit;
    ``point``, ``normal`` (n, 3) (zeros on a miss); ``distance`` (n,) m (inf on a miss);
    ``feature`` (n,) uint64 (0 on a miss). Arrays are read-only."""
    body: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    distance: np.ndarray
    feature: np.ndarray

    def __len__(self) -> int:
        return len(self.body)


@dataclass(frozen=True)
class BodyDistance:
    """Signed distance of two bodies (``World.distance(i, j)``): ``distance`` m (negative: depth of
    overlap), witness points ``point_a`` on body i and ``point_b`` on body j (3,), unit ``normal``
    (3,) from i towards j, with ``point_b - point_a = distance * normal``."""
    distance: float
    point_a: np.ndarray
    point_b: np.ndarray
    normal: np.ndarray


def filter_args(who: str, group, mask, exclude) -> dict:
    """The query filter as the core takes it (TypeError / ValueError naming the argument; the core
    checks that every excluded index exists)."""
    ii = as_indices(exclude, f"{who}: exclude")
    beyond = ii[(ii < -2**31) | (ii >= 2**31)]  # not even a C int: the core could not name it
    if beyond.size:
        raise _core.BodyIndexError(f"{who}: exclude: body index {beyond[0]} is out of range")
    return {"group": as_bits(group, who, "group"), "mask": as_bits(mask, who, "mask"),
            "exclude": [int(k) for k in ii]}


def ray_args(who: str, origin, direction, max_distance) -> tuple:
    return (as_vector(origin, 3, who, "origin"), as_vector(direction, 3, who, "direction"),
            as_number(max_distance, who, "max_distance"))


def hit(t) -> Hit | None:
    """A Hit from the core's (body, point, normal, distance, feature), or None."""
    if t is None:
        return None
    body, point, normal, distance, feature = t
    return Hit(int(body), readonly(np.asarray(point)), readonly(np.asarray(normal)), float(distance), int(feature))


def rays_args(origins, directions, max_distance) -> tuple:
    """origins, directions as (n, 3) float64, max_distance as (n,) (a number is broadcast); the
    core checks the values and that the lengths agree."""
    who = "cast_rays"
    o = as_rows(origins, 3, who, "origins")
    d = as_rows(directions, 3, who, "directions")
    if max_distance is None or isinstance(max_distance, (str, bytes)):
        raise TypeError(f"{who}: max_distance must be a number or (n,) numbers, got {max_distance!r}")
    if np.ndim(max_distance) == 0:
        return o, d, np.full(len(o), as_number(max_distance, who, "max_distance"))
    try:
        m = np.asarray(max_distance, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{who}: max_distance must be a number or (n,) numbers, got {max_distance!r}") from None
    if m.ndim != 1:
        raise ValueError(f"{who}: max_distance must be a number or have shape (n,), got shape {m.shape}")
    return o, d, m


def ray_hits(d: dict) -> RayHits:
    return RayHits(**{k: readonly(np.asarray(v)) for k, v in d.items()})


def distance(t) -> BodyDistance:
    gap, a, b, n = t
    return BodyDistance(float(gap), readonly(np.asarray(a)), readonly(np.asarray(b)), readonly(np.asarray(n)))


def indices(xs) -> np.ndarray:
    """Body indices (ascending) as a read-only int32 array."""
    return readonly(np.asarray(xs, dtype=np.int32).reshape(-1))
