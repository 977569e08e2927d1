"""Triangle meshes generated in NumPy, and meshes for drawing shapes.

Every generator returns ``(vertices, faces)``:

- ``vertices``: (n, 3) float64, metres, in the generator's own frame (centred on the origin);
- ``faces``: (k, 3) int64, rows of vertex indices.

The meshes are closed (every directed edge appears exactly once and its reverse exactly once) and
consistently outward oriented (counter-clockwise seen from outside, so the signed volume is
positive). They can be handed to ``signorini.Mesh(vertices, faces)`` as they are.

Nothing here is physics: the volumes below are for tests and documentation, and the drawing
helpers (``render_mesh``, ``posed``) are only used for plots.
"""

from __future__ import annotations

import math

import numpy as np


__all__ = [
    "torus",
    "box_mesh",
    "icosphere",
    "cylinder_mesh",
    "signed_volume",
    "torus_mesh_volume",
    "cylinder_mesh_volume",
    "posed",
    "render_mesh",
]


def _check_positive(**values: float) -> None:
    """Raise ValueError naming the first argument that is not a finite number > 0."""
    for name, value in values.items():
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")


def _check_count(name: str, value: int, least: int) -> None:
    """Raise ValueError unless value is an integer >= least."""
    if int(value) != value or value < least:
        raise ValueError(f"{name} must be an integer >= {least}, got {value!r}")


def _grid_quads(n_u: int, n_v: int) -> np.ndarray:
    """Triangles of a periodic (n_u x n_v) grid of vertices indexed i * n_v + j.

    Returns (2 n_u n_v, 3) int64. Each grid cell (i, j)-(i+1, j)-(i+1, j+1)-(i, j+1), indices
    taken modulo the grid size, is split along its (i, j)-(i+1, j+1) diagonal; the winding is
    counter-clockwise when d/du x d/dv points outwards.
    """
    i, j = np.meshgrid(np.arange(n_u), np.arange(n_v), indexing="ij")
    i, j = i.ravel(), j.ravel()
    i1, j1 = (i + 1) % n_u, (j + 1) % n_v
    a, b, c, d = i * n_v + j, i1 * n_v + j, i1 * n_v + j1, i * n_v + j1
    tris = np.concatenate([np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)])
    return tris.astype(np.int64)


def torus(
    major_radius: float, minor_radius: float, n_major: int = 32, n_minor: int = 16
) -> tuple[np.ndarray, np.ndarray]:
    """Torus around the z axis, centred on the origin.

    Inputs: major_radius R (m, centre of the tube to the z axis), minor_radius r (m, tube radius,
    0 < r < R), n_major (>= 3) rings around z, n_minor (>= 3) vertices around each ring.
    Outputs: vertices (n_major * n_minor, 3) float64 on the smooth torus,
    vertex i * n_minor + j = ((R + r cos v_j) cos u_i, (R + r cos v_j) sin u_i, r sin v_j)
    with u_i = 2 pi i / n_major, v_j = 2 pi j / n_minor; faces (2 n_major n_minor, 3) int64.

    The four vertices of each grid cell are coplanar (mirror images across the plane at the
    cell's middle angle), so the mesh is a polyhedron whose volume is known exactly: see
    ``torus_mesh_volume``.
    """
    _check_positive(major_radius=major_radius, minor_radius=minor_radius)
    if minor_radius >= major_radius:
        raise ValueError(
            f"minor_radius must be smaller than major_radius, got {minor_radius!r} >= {major_radius!r}"
        )
    _check_count("n_major", n_major, 3)
    _check_count("n_minor", n_minor, 3)

    # angles around the z axis (u) and around the tube (v)
    u = 2.0 * np.pi * np.arange(n_major) / n_major
    v = 2.0 * np.pi * np.arange(n_minor) / n_minor
    uu, vv = np.meshgrid(u, v, indexing="ij")

    # points on the smooth surface, u-major order
    rho = major_radius + minor_radius * np.cos(vv)
    vertices = np.stack(
        [rho * np.cos(uu), rho * np.sin(uu), minor_radius * np.sin(vv)], axis=-1
    ).reshape(-1, 3)

    # d/du x d/dv points out of the tube, so the grid winding is outward
    faces = _grid_quads(n_major, n_minor)
    return vertices.astype(np.float64), faces


def torus_mesh_volume(
    major_radius: float, minor_radius: float, n_major: int = 32, n_minor: int = 16
) -> float:
    """Exact enclosed volume (m^3) of ``torus(major_radius, minor_radius, n_major, n_minor)``.

    Each of the n_major wedges is the tube's cross-section polygon Q (a regular n_minor-gon of
    circumradius r centred at distance R from the axis) swept linearly from angle u_i to u_{i+1};
    the map (rho, z, t) -> (rho ((1-t) e_i + t e_{i+1}), z) has Jacobian rho sin(2 pi / n_major),
    so the wedge volume is sin(2 pi / n_major) * area(Q) * R (Q's centroid is at rho = R):

        V = [n_major sin(2 pi / n_major)] R * [n_minor / 2 sin(2 pi / n_minor)] r^2.

    Both bracketed factors increase towards 2 pi and pi, so V approaches the smooth torus'
    2 pi^2 R r^2 from below, with relative error about (2 pi^2 / 3)(1/n_major^2 + 1/n_minor^2).
    """
    ring = n_major * math.sin(2.0 * math.pi / n_major)
    section = 0.5 * n_minor * math.sin(2.0 * math.pi / n_minor)
    return ring * major_radius * section * minor_radius**2


def box_mesh(half_extents) -> tuple[np.ndarray, np.ndarray]:
    """Box centred on the origin with its edges along the axes.

    Inputs: half_extents (3,) (a, b, c), metres, each > 0.
    Outputs: vertices (8, 3) float64 in the conventions' corner order, corner k =
    (sx a, sy b, sz c) with sx = +1 if k & 1 else -1, sy = +1 if k & 2, sz = +1 if k & 4;
    faces (12, 3) int64, two outward triangles per side.
    """
    a, b, c = np.asarray(half_extents, dtype=np.float64).reshape(3)
    _check_positive(a=a, b=b, c=c)

    # corners in the conventions' order
    k = np.arange(8)
    signs = np.stack([np.where(k & 1, 1.0, -1.0), np.where(k & 2, 1.0, -1.0), np.where(k & 4, 1.0, -1.0)], 1)
    vertices = signs * np.array([a, b, c])

    # each side as a quad, counter-clockwise seen from outside
    quads = np.array(
        [
            [0, 2, 3, 1],  # -z
            [4, 5, 7, 6],  # +z
            [0, 1, 5, 4],  # -y
            [2, 6, 7, 3],  # +y
            [0, 4, 6, 2],  # -x
            [1, 3, 7, 5],  # +x
        ]
    )
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return vertices, faces.astype(np.int64)


def icosphere(radius: float, subdivisions: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Sphere approximated by a subdivided icosahedron, centred on the origin.

    Inputs: radius (m, > 0), subdivisions (>= 0; each one splits every triangle into four).
    Outputs: vertices (10 * 4^s + 2, 3) float64, all at distance ``radius`` from the origin;
    faces (20 * 4^s, 3) int64. The mesh is a convex polyhedron inscribed in the sphere, so its
    volume is below 4/3 pi r^3 and above 4/3 pi d^3, d the smallest distance of a face plane
    from the centre.
    """
    _check_positive(radius=radius)
    _check_count("subdivisions", subdivisions, 0)

    # the icosahedron: three golden rectangles, 20 outward faces
    t = (1.0 + math.sqrt(5.0)) / 2.0
    vertices = np.array(
        [
            [-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0],
            [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
            [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1],
        ],
        dtype=np.float64,
    )
    faces = np.array(
        [
            [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
            [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
            [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
            [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
        ],
        dtype=np.int64,
    )
    vertices /= np.linalg.norm(vertices, axis=1, keepdims=True)

    for _ in range(int(subdivisions)):
        # one new vertex per edge, shared by the two faces on either side
        edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        keys = np.sort(edges, axis=1)
        unique, inverse = np.unique(keys, axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        mid = vertices[unique[:, 0]] + vertices[unique[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = len(vertices) + inverse.reshape(3, -1)  # rows: midpoints of edges 01, 12, 20
        m01, m12, m20 = m

        # each triangle becomes four with the same winding
        a, b, c = faces.T
        faces = np.concatenate(
            [
                np.stack([a, m01, m20], 1),
                np.stack([b, m12, m01], 1),
                np.stack([c, m20, m12], 1),
                np.stack([m01, m12, m20], 1),
            ]
        )
        vertices = np.concatenate([vertices, mid])

    return radius * vertices, faces.astype(np.int64)


def cylinder_mesh(radius: float, half_height: float, n: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """Cylinder along the z axis, centred on the origin (z from -half_height to +half_height).

    Inputs: radius (m), half_height (m), n (>= 3) vertices around each rim.
    Outputs: vertices (2 n + 2, 3) float64: the bottom rim (0..n-1), the top rim (n..2n-1), then
    the bottom and top cap centres; faces (4 n, 3) int64 (side quads split in two, cap fans).
    The mesh is an n-gonal prism with volume ``cylinder_mesh_volume(radius, half_height, n)``.
    """
    _check_positive(radius=radius, half_height=half_height)
    _check_count("n", n, 3)

    # the two rims and the two cap centres
    u = 2.0 * np.pi * np.arange(n) / n
    rim = np.stack([radius * np.cos(u), radius * np.sin(u)], axis=1)
    bottom = np.column_stack([rim, np.full(n, -half_height)])
    top = np.column_stack([rim, np.full(n, half_height)])
    vertices = np.concatenate([bottom, top, [[0.0, 0.0, -half_height], [0.0, 0.0, half_height]]])

    # side quads (counter-clockwise seen from outside) and the cap fans
    i = np.arange(n)
    i1 = (i + 1) % n
    cb, ct = 2 * n, 2 * n + 1
    faces = np.concatenate(
        [
            np.stack([i, i1, n + i1], 1),
            np.stack([i, n + i1, n + i], 1),
            np.stack([np.full(n, cb), i1, i], 1),
            np.stack([np.full(n, ct), n + i, n + i1], 1),
        ]
    )
    return vertices.astype(np.float64), faces.astype(np.int64)


def cylinder_mesh_volume(radius: float, half_height: float, n: int = 32) -> float:
    """Exact volume (m^3) of ``cylinder_mesh``: the n-gon's area (n/2) r^2 sin(2 pi/n) times 2h."""
    return 0.5 * n * radius**2 * math.sin(2.0 * math.pi / n) * 2.0 * half_height


def signed_volume(vertices, faces) -> float:
    """Signed enclosed volume (m^3) of a closed triangle mesh by the divergence theorem: the sum
    over faces of det(v0, v1, v2) / 6, positive when the faces are outward oriented. For tests
    and documentation (the simulator's mass properties come from the core; this module does not
    import the oracle, which checks the core independently).

    Inputs: vertices (n, 3), faces (k, 3).
    """
    X = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    v0, v1, v2 = X[F[:, 0]], X[F[:, 1]], X[F[:, 2]]
    return float(np.einsum("ki,ki->k", v0, np.cross(v1, v2)).sum() / 6.0)


# drawing helpers: used by the plots only, never by the simulation


def posed(vertices, position, orientation) -> np.ndarray:
    """World coordinates (n, 3) of body-frame vertices (n, 3) for a body at position (3,) (m)
    with orientation (4,) (w, x, y, z): x = R X + p."""
    w, x, y, z = np.asarray(orientation, dtype=np.float64) / np.linalg.norm(orientation)
    R = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])
    return np.asarray(vertices, dtype=np.float64) @ R.T + np.asarray(position, dtype=np.float64)


def render_mesh(shape, sphere_subdivisions: int = 2) -> tuple[np.ndarray, np.ndarray] | None:
    """Triangle mesh of a body's shape, in its body frame, for drawing.

    Inputs: a shape object (``signorini.Sphere`` (.radius), ``Box`` (.half_extents), ``Capsule``
    (.radius, .half_length), ``Cylinder`` (.radius, .half_height), ``Mesh``, ``ConvexHull`` and
    ``TriangleMesh`` (.vertices, .faces), ``Compound`` (.parts) or ``Plane`` (.normal, .offset);
    any object with these attributes works). Outputs: (vertices (n, 3) float64 m, faces (k, 3) int64), or None for a
    plane, which has no finite mesh (draw it as a patch). Unknown shapes raise TypeError.
    """
    # test the attributes rather than the classes, so that plots work on recorded shapes too
    if hasattr(shape, "parts"):
        # a compound: its parts' meshes placed by their poses, in one vertex array
        vertices, faces, count = [], [], 0
        for part, (position, orientation) in shape.parts:
            v, f = render_mesh(part, sphere_subdivisions)
            vertices.append(posed(v, position, orientation))
            faces.append(f + count)
            count += len(v)
        return np.concatenate(vertices), np.concatenate(faces)
    if hasattr(shape, "half_length"):
        # a capsule: a sphere mesh whose halves are pushed apart along z
        v, f = icosphere(float(shape.radius), sphere_subdivisions)
        v = v.copy()
        v[:, 2] += np.where(v[:, 2] >= 0.0, 1.0, -1.0) * float(shape.half_length)
        return v, f
    if hasattr(shape, "half_height"):
        return cylinder_mesh(float(shape.radius), float(shape.half_height))
    if hasattr(shape, "vertices") and hasattr(shape, "faces"):
        return np.asarray(shape.vertices, dtype=np.float64), np.asarray(shape.faces, dtype=np.int64)
    if hasattr(shape, "half_extents"):
        return box_mesh(shape.half_extents)
    if hasattr(shape, "radius"):
        return icosphere(float(shape.radius), sphere_subdivisions)
    if hasattr(shape, "normal") and hasattr(shape, "offset"):
        return None
    raise TypeError(f"render_mesh: cannot draw a shape of type {type(shape).__name__}")
