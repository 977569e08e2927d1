"""Ray casts by brute force, to check the core's (docs/conventions.md, "Queries").

Nothing here is the core's method. A solid is a containment test written from the shape's
definition (a ball, slabs, the distance to a segment, a disk times an interval, the half-spaces of
a hull's face planes, a union of parts or pieces); a ray's first entry is found by sampling the
ray and bisecting the first sample step that goes from outside to inside. A triangle mesh is a
surface: each triangle's plane is cut by the ray and the cut point kept when it is on the inner
side of all three edges (edge functions, not Moller-Trumbore's barycentric solve).

Shapes are in the arrays form (``signorini.shape_dict`` / ``World.snapshot``): dicts with
``type`` in sphere, box, capsule, cylinder, plane, hull, mesh (convex ``pieces`` as vertex
arrays, or the mesh itself when it has none), compound (``parts``: (shape, position, rotation)),
trimesh. A pose is (R (3, 3) world-from-body, p (3,)); points and directions are world, metres.
Containment is closed: the surface counts.
"""
import itertools

import numpy as np


def _face_planes(vertices: np.ndarray):
    """(normals (k, 3), offsets (k,)) of the convex hull of the points, by brute force: the plane
    through three points is a face plane when every point lies on or behind it (1e-12 of the
    size). O(n^4): for the small pieces and hulls of tests."""
    V = np.asarray(vertices, dtype=float)
    scale = np.abs(V).max() + 1.0
    normals, offsets = [], []
    for i, j, k in itertools.combinations(range(len(V)), 3):
        n = np.cross(V[j] - V[i], V[k] - V[i])
        if np.linalg.norm(n) < 1e-12 * scale * scale:
            continue
        n = n / np.linalg.norm(n)
        s = V @ n - n @ V[i]
        for sign in (1.0, -1.0):
            if (sign * s <= 1e-12 * scale).all():
                normals.append(sign * n)
                offsets.append(sign * (n @ V[i]))
    return np.array(normals), np.array(offsets)


def solid(shape: dict, R: np.ndarray, p: np.ndarray):
    """The closed solid of `shape` at pose (R, p) as a test inside(X) -> (m,) bool for world points
    X (m, 3) (a plane: its half-space n . x <= offset; a triangle mesh: nothing)."""
    kind = shape["type"]
    R, p = np.asarray(R, dtype=float), np.asarray(p, dtype=float)
    if kind == "plane":
        n = R @ np.asarray(shape["normal"], dtype=float)
        n = n / np.linalg.norm(n)
        return lambda X: X @ n <= shape["offset"] + n @ p
    if kind == "trimesh":
        return lambda X: np.zeros(len(X), dtype=bool)
    if kind == "compound":
        parts = [solid(part, R @ Rk, R @ pk + p) for part, pk, Rk in shape["parts"]]
        return lambda X: np.any([inside(X) for inside in parts], axis=0)

    def local(X):
        return (np.asarray(X, dtype=float) - p) @ R  # rows R^T (x - p)

    if kind == "sphere":
        return lambda X: (local(X) ** 2).sum(axis=1) <= shape["radius"] ** 2
    if kind == "box":
        h = np.asarray(shape["half_extents"], dtype=float)
        return lambda X: (np.abs(local(X)) <= h).all(axis=1)
    if kind == "capsule":
        def in_capsule(X):
            L = local(X)
            q = np.clip(L[:, 2], -shape["half_length"], shape["half_length"])
            return L[:, 0] ** 2 + L[:, 1] ** 2 + (L[:, 2] - q) ** 2 <= shape["radius"] ** 2
        return in_capsule
    if kind == "cylinder":
        def in_cylinder(X):
            L = local(X)
            return (L[:, 0] ** 2 + L[:, 1] ** 2 <= shape["radius"] ** 2) & (np.abs(L[:, 2]) <= shape["half_height"])
        return in_cylinder
    if kind in ("hull", "mesh"):
        planes = [_face_planes(piece) for piece in (shape.get("pieces") or [shape["vertices"]])]
        return lambda X: np.any([((local(X) @ N.T) <= d).all(axis=1) for N, d in planes], axis=0)
    raise ValueError(f"rays.solid: unknown shape type {kind!r}")


def contains(shape: dict, R: np.ndarray, p: np.ndarray, x) -> bool:
    """Whether the world point x lies in the closed solid of `shape` at pose (R, p)."""
    return bool(solid(shape, R, p)(np.asarray(x, dtype=float)[None, :])[0])


def first_entry(shape: dict, R: np.ndarray, p: np.ndarray, o, u, t_max: float, samples: int = 4000):
    """The least t in [0, t_max] with o + t u in the solid (u unit), or None: `samples` evenly
    spaced points, then the first outside-to-inside step bisected to the last bit. An entry whose
    chord is shorter than the spacing t_max / samples can be missed (a grazing ray)."""
    inside = solid(shape, R, p)
    o, u = np.asarray(o, dtype=float), np.asarray(u, dtype=float)
    ts = np.linspace(0.0, t_max, samples + 1)
    flags = inside(o + ts[:, None] * u)
    if flags[0]:
        return 0.0
    if not flags.any():
        return None
    k = int(np.argmax(flags))
    lo, hi = ts[k - 1], ts[k]  # lo outside, hi inside
    while True:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            return hi
        if inside((o + mid * u)[None, :])[0]:
            hi = mid
        else:
            lo = mid


def triangle_entry(vertices, faces, R: np.ndarray, p: np.ndarray, o, u, t_max: float):
    """(t, triangle) of the first triangle of a triangle mesh at pose (R, p) that the ray o + t u
    (u unit, t in [0, t_max]) meets, from either side, the lower index on ties; or None."""
    V = np.asarray(vertices, dtype=float) @ np.asarray(R, dtype=float).T + p
    T = V[np.asarray(faces)]  # (k, 3 corners, 3)
    a, b, c = T[:, 0], T[:, 1], T[:, 2]
    o, u = np.asarray(o, dtype=float), np.asarray(u, dtype=float)
    n = np.cross(b - a, c - a)
    den = n @ u
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.einsum("ij,ij->i", n, a - o) / den
    X = o + t[:, None] * u
    # inside: X on the inner side of each edge (each edge function has the sign of n . n)
    nn = np.einsum("ij,ij->i", n, n)
    ok = (den != 0.0) & (t >= 0.0) & (t <= t_max)
    for e0, e1 in ((a, b), (b, c), (c, a)):
        ok &= np.einsum("ij,ij->i", np.cross(e1 - e0, X - e0), n) >= -1e-12 * nn
    if not ok.any():
        return None
    k = np.flatnonzero(ok)
    best = k[np.argmin(t[k])]  # argmin takes the first (lowest index) of equal values
    return float(t[best]), int(best)
