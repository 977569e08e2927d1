"""Support mappings of convex shapes and a brute-force signed separation of two of them.

A support mapping s_K of a convex set K takes unit directions U (k, 3) and returns points of K
farthest along each, (k, 3): s_K(u) . u = h_K(u) = max over x in K of x . u, the support
function.  All points and directions are world frame, lengths in m.

The signed separation of convex A and B (``support_separation``) is

    sep(A, B) = max over unit d of  g(d),   g(d) = -(h_A(d) + h_B(-d)),

the largest gap between a support plane of A with outward normal d and one of B with normal -d.
For disjoint sets it is their distance (the separating-hyperplane theorem: the closest points
give the best d); for overlapping sets it is minus the penetration depth, the shortest
translation that separates them.  It needs nothing but the two support mappings, so it shares
no code with the separating-axis test of ``manifold`` and checks it.

Accuracy (tests/python/test_oracle_manifolds.py and sweeps against closed forms): polytopes to
rounding (~1e-15 m on unit-size shapes: the maximiser is a facet normal of the Minkowski
difference, which the refinement computes exactly from three support points); spheres, capsules,
cylinders ~1e-12 m, worst seen 2e-10 m where a sphere sits just beside a cylinder's rim (a
curved ridge of g).  Cost: ~10 ms for a box pair, up to ~50 ms with a cylinder.
"""

import itertools

import numpy as np


# --------------------------------------------------------------------------- support mappings

def _as_directions(U):
    return np.asarray(U, dtype=float).reshape(-1, 3)


def support_sphere(radius, c):
    """Ball of radius r (m) about c (3,): s(u) = c + r u."""
    c = np.asarray(c, dtype=float)

    def s(U):
        return c + radius * _as_directions(U)
    return s


def support_box(half_extents, p, R):
    """Box of half extents h (3,) m at COM p (3,), rotation R (3, 3): s(u) = p + R (sign(R^T u) h),
    sign + for 0."""
    h = np.asarray(half_extents, dtype=float)
    p, R = np.asarray(p, dtype=float), np.asarray(R, dtype=float)

    def s(U):
        local = _as_directions(U) @ R          # rows R^T u
        return (np.where(local >= 0, 1.0, -1.0) * h) @ R.T + p
    return s


def support_hull(vertices, p, R):
    """Convex hull of body-frame points (n, 3) m placed at (p, R): the vertex of largest u . x
    (first on ties)."""
    W = np.asarray(vertices, dtype=float).reshape(-1, 3) @ np.asarray(R, dtype=float).T + p

    def s(U):
        return W[np.argmax(_as_directions(U) @ W.T, axis=1)]
    return s


def support_capsule(radius, half_length, p, R):
    """Capsule: points within r of the segment p -+ h a, a = R e_z:
    s(u) = p + sign(u . a) h a + r u, sign + for 0."""
    p = np.asarray(p, dtype=float)
    a = np.asarray(R, dtype=float)[:, 2]

    def s(U):
        U = _as_directions(U)
        side = np.where(U @ a >= 0, 1.0, -1.0)
        return p + (side * half_length)[:, None] * a + radius * U
    return s


def support_cylinder(radius, half_height, p, R):
    """Solid cylinder of radius r and half height h about the axis a = R e_z through p:
    s(u) = p + sign(u . a) h a + r v / |v|, v = u - (u . a) a.

    v is projected twice, so that v / |v| is normal to a to rounding even when u is almost +-a;
    for |v| < 1e-12 the radial term is left out: the cap centre, a point of the cylinder whose
    support value is short by at most r |v| < 1e-12 r.  (A radial direction computed from a v
    that is all rounding would leave the cylinder and overestimate h.)"""
    p = np.asarray(p, dtype=float)
    a = np.asarray(R, dtype=float)[:, 2]

    def s(U):
        U = _as_directions(U)
        ua = U @ a
        v = U - ua[:, None] * a
        v -= (v @ a)[:, None] * a
        norm = np.linalg.norm(v, axis=1)
        radial = np.zeros_like(v)
        nz = norm >= 1e-12
        radial[nz] = v[nz] / norm[nz, None]
        return p + (np.where(ua >= 0, 1.0, -1.0) * half_height)[:, None] * a + radius * radial
    return s


def support_of(shape, p, R):
    """The support mapping of an oracle shape dict placed at COM p (3,), rotation R (3, 3):
    sphere, box, capsule, cylinder, or any dict with "vertices" (hull, convex mesh)."""
    kind = shape["type"]
    if kind == "sphere":
        return support_sphere(float(shape["radius"]), p)
    if kind == "box":
        return support_box(shape["half_extents"], p, R)
    if kind == "capsule":
        return support_capsule(float(shape["radius"]), float(shape["half_length"]), p, R)
    if kind == "cylinder":
        return support_cylinder(float(shape["radius"]), float(shape["half_height"]), p, R)
    if "vertices" in shape:
        return support_hull(shape["vertices"], p, R)
    raise ValueError(f"no support mapping for shape type {kind!r}")


# --------------------------------------------------------------------------- separation

def fibonacci_sphere(count):
    """count unit directions (count, 3) spread evenly on the sphere (golden-angle spiral)."""
    i = np.arange(count) + 0.5
    z = 1.0 - 2.0 * i / count
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = i * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _cross(a, b):
    """a x b for (..., 3) arrays (np.cross is slow on the small arrays used here)."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def _tangent_basis(u):
    """Two unit vectors (3,) that make (e1, e2, u) orthonormal."""
    helper = np.eye(3)[int(np.argmin(np.abs(u)))]
    e1 = _cross(u, helper)
    e1 /= np.linalg.norm(e1)
    return e1, _cross(u, e1)


# the cap pattern: 2 rings of 8 directions, angular radius 1 and 1/2, the inner turned by half a step
_CAP_THETA = np.repeat([1.0, 0.5], 8)
_CAP_PHI = (np.arange(16) % 8 + 0.5 * (np.arange(16) // 8)) * 2.0 * np.pi / 8


def _cap(u, rho):
    """16 directions about u (16, 3): two rings of 8 at angular radius rho and rho / 2."""
    e1, e2 = _tangent_basis(u)
    theta = rho * _CAP_THETA
    t = np.cos(_CAP_PHI)[:, None] * e1 + np.sin(_CAP_PHI)[:, None] * e2
    return np.cos(theta)[:, None] * u + np.sin(theta)[:, None] * t


_COMBINATIONS = {}


def _model_directions(S):
    """Critical directions of m(d) = min over x in S of x . d on the unit sphere, S (M, 3):
    where one point is active, d = x / |x|; two points x1, x2, d = the part of x1 normal to
    x1 - x2, unit; three points, d = -+ unit((x2 - x1) x (x3 - x1)).  m's maximum is one of them
    (m is the minimum of finitely many linear functions).  Output (k, 3) unit directions."""
    M = len(S)
    if M not in _COMBINATIONS:
        _COMBINATIONS[M] = tuple(
            np.array(list(itertools.combinations(range(M), k)), dtype=np.int64).reshape(-1, k)
            for k in (2, 3))
    pairs, triples = _COMBINATIONS[M]
    out = [S]
    if len(pairs):
        x1, w = S[pairs[:, 0]], S[pairs[:, 0]] - S[pairs[:, 1]]
        w = w / np.linalg.norm(w, axis=1)[:, None]
        out.append(x1 - np.sum(x1 * w, axis=1)[:, None] * w)
    if len(triples):
        c = _cross(S[triples[:, 1]] - S[triples[:, 0]], S[triples[:, 2]] - S[triples[:, 0]])
        out += [c, -c]
    D = np.vstack(out)
    norm = np.linalg.norm(D, axis=1)
    ok = norm > 1e-300
    return D[ok] / norm[ok, None]


def _ridge_steps(S, u, rho):
    """Directions at angle rho and rho / 2 from u along the great circles through u normal to
    x_i - x_j, for the pairs of the points S (M, 3): the ridges where x_i . d = x_j . d."""
    if len(S) < 2:
        return np.zeros((0, 3))
    i, j = np.triu_indices(len(S), 1)
    t = _cross(S[i] - S[j], u)
    norm = np.linalg.norm(t, axis=1)
    t = t[norm > 1e-300] / norm[norm > 1e-300, None]
    steps = [np.cos(theta) * u + np.sin(theta) * sign * t
             for theta in (rho, 0.5 * rho) for sign in (1.0, -1.0)]
    return np.vstack(steps)


def _refine(gap_of, u0, g0, rho0, max_points=10, max_iterations=400):
    """Local maximum of g on the unit sphere near u0 (3,), g0 = g(u0), starting radius rho0 rad.

    A pattern search on caps about the best direction: 16 directions at angle rho and rho / 2;
    after a long step rho doubles (up to rho0), after a short one it halves, after no
    improvement it shrinks tenfold, down to 1e-13.  Each step also tries the critical
    directions of the polyhedral model min over x in S of x . d, S = the 10 support points
    seen so far that are most active at the best direction (exact at the kinks of polytopes,
    where a pattern search stalls), and steps along the ridges of that model.

    gap_of(U) -> (g (k,), x (k, 3)) with g = x . u; returns (g, u) at the best direction seen."""
    u, g = u0, g0
    rho = rho0
    S = np.zeros((0, 3))
    for _ in range(max_iterations):
        # sample a cap about u, collect the support points, keep the ones most active at u
        U = _cap(u, rho)
        G, X = gap_of(U)
        S = np.unique(np.vstack([S, X]), axis=0)
        S = S[np.argsort(S @ u, kind="stable")[:max_points]]

        # try the model's critical directions near u, and steps along its ridges through u
        # (where two support points are equally active g has a kink across and is smooth
        # along: a pattern search alone stalls there)
        C = np.vstack([_model_directions(S), _ridge_steps(S, u, rho)])
        C = C[C @ u >= np.cos(min(4.0 * rho, np.pi))]
        if len(C):
            G_C, _ = gap_of(C)
            U, G = np.vstack([U, C]), np.concatenate([G, G_C])

        # move to the best direction seen; grow the cap after a long step, shrink it otherwise
        k = int(np.argmax(G))
        if G[k] > g:
            moved = np.arccos(np.clip(U[k] @ u, -1.0, 1.0))
            u, g = U[k], float(G[k])
            if moved > 0.75 * rho:
                rho = min(2.0 * rho, rho0)
            elif moved < 0.25 * rho:
                rho *= 0.5
        else:
            rho *= 0.1
        if rho < 1e-13:
            break
    return g, u


_NEIGHBOURS = {}


def _grid_neighbours(U, k=8):
    """Indices (n, k) of the k nearest other directions of each direction of the grid U (n, 3),
    computed once per grid size (in blocks, to bound the memory to 512 n doubles)."""
    n = len(U)
    if n not in _NEIGHBOURS:
        out = np.zeros((n, k), dtype=np.int64)
        for start in range(0, n, 512):
            dots = U[start:start + 512] @ U.T
            dots[np.arange(len(dots)), np.arange(start, start + len(dots))] = -np.inf
            out[start:start + 512] = np.argpartition(-dots, k, axis=1)[:, :k]
        _NEIGHBOURS[n] = out
    return _NEIGHBOURS[n]


def support_separation(support_a, support_b, n_directions=4096, max_seeds=32):
    """Signed separation of convex A and B from their support mappings alone, m.

    sep = max over unit d of g(d), g(d) = -(h_A(d) + h_B(-d)) = (s_B(-d) - s_A(d)) . d:
    the distance between A and B when they are disjoint, minus the penetration depth when they
    overlap (see the module docstring).

    Inputs: support_a, support_b: support mappings (k, 3) -> (k, 3), world frame.
            n_directions: size of the dense Fibonacci grid of directions; max_seeds: how many
            local maxima of the grid are refined at most.
    Output: (sep m, d (3,) the maximising direction, unit, pointing from A towards B).
    Method: g on the dense grid (spacing sqrt(4 pi / n) rad); the seeds are
      - every local maximum of the grid (no larger value among its 8 nearest grid neighbours)
        within 2 |x|_max spacing of the best grid value (|x|_max, the largest support point of
        B - A, bounds the slope of g on the sphere, so a lower grid maximum cannot hide a
        higher basin), and
      - the 4 best critical directions of the polyhedral model on the support points of those
        near-best directions: a polytope's maximum is a facet normal of B - A, whose basin may
        be narrower than the grid, but whose facet's vertices the grid has seen;
    each seed is refined (``_refine``) and the best refined value wins.
    """
    def gap_of(U):
        x = support_b(-U) - support_a(U)
        return np.sum(x * U, axis=1), x

    U = fibonacci_sphere(n_directions)
    G, X = gap_of(U)
    spacing = np.sqrt(4.0 * np.pi / n_directions)
    scale = np.max(np.linalg.norm(X, axis=1))

    near_top = G >= G.max() - 2.0 * scale * spacing

    # seeds: the grid's local maxima within slope * 2 spacings of the best, best first
    local_max = G >= np.max(G[_grid_neighbours(U)], axis=1)
    candidates = np.flatnonzero(local_max & near_top)
    seeds = [(float(G[k]), U[k]) for k in candidates[np.argsort(-G[candidates], kind="stable")]]

    # and the critical directions of the polyhedral model on the support points of the near-top
    # directions: a polytope's maximum sits on a facet normal, whose basin can be narrower than
    # the grid (then no grid local maximum lies in it); its facet's vertices are among these
    # points (for smooth shapes, where they are many, those of the 40 best directions are used)
    top = np.flatnonzero(near_top)
    X_top = np.unique(X[top], axis=0)
    if len(X_top) > 40:
        X_top = np.unique(X[top[np.argsort(-G[top], kind="stable")[:40]]], axis=0)
    C = _model_directions(X_top)
    G_C, _ = gap_of(C)
    seeds += [(float(G_C[k]), C[k]) for k in np.argsort(-G_C, kind="stable")[:4]]
    seeds.sort(key=lambda seed: -seed[0])

    best, refined = (-np.inf, None), []
    for g0, u0 in seeds[:max_seeds]:
        if any(u0 @ u > np.cos(1e-6) for u in refined):
            continue  # the same direction again (a facet normal from another triple of vertices)
        refined.append(u0)
        g, d = _refine(gap_of, u0, g0, 2.0 * spacing)
        if g > best[0]:
            best = (g, d)
    return best
