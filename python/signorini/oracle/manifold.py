"""Feature ids, the box polytope, box-box contact and the reduction of a manifold to 4 points
(docs/conventions.md, "Feature ids" and "Manifolds").

A contact point carries one feature id per side, so that it is recognised from step to step:
    id = part * 2^32 + kind * 2^28 + index          (np.uint64)
    kind SHAPE = 0 (sphere, plane), VERTEX = 1, EDGE = 2, FACE = 3;
    part = compound part, mesh piece or triangle-mesh triangle (0 otherwise).

A manifold is every contact point of one body pair.  Its points are (docs, "Manifolds"):
    1. the candidates with gap < threshold (threshold = margin + speculative reach),
    2. sorted by (feature_a, feature_b),
    3. without exact duplicates (within 1e-9 L of an earlier point; L = sum of the bounding radii),
    4. reduced to 4 when there are more (``reduce_manifold``),
and written in id order.  ``select_manifold`` does all four.

Box-box contact (``contact_box_box``) is the separating-axis test on A's faces, B's faces and the
9 edge-edge axes, then either Sutherland-Hodgman clipping of the incident face against the side
planes of the reference face, or a single edge-edge point (for boxes apart whose edge lines meet
off the edges: their closest pair, ``closest_features``).  Everything is in world coordinates.
"""

import numpy as np

SHAPE, VERTEX, EDGE, FACE = 0, 1, 2, 3

# box-box prefers faces to edges and A's face to B's unless the other axis separates more by
# FACE_PREFERENCE L (docs, "Manifolds": two stacked boxes tilted by theta have an edge axis
# better than the face axis by about 0.2 L theta; without the preference they would rock on one
# point)
FACE_PREFERENCE = 5e-4
# axes within 0.05 rad count as nearly parallel: only among those are faces preferred
NEARLY_PARALLEL = float(np.cos(0.05))

# corner bit k & 1 -> x, k & 2 -> y, k & 4 -> z (docs, "plane against a box")
_BIT = (1, 2, 4)


# --------------------------------------------------------------------------- feature ids

def feature_id(kind, index, part=0):
    """id = part * 2^32 + kind * 2^28 + index, as np.uint64 (scalars or arrays, broadcast).

    kind in {SHAPE, VERTEX, EDGE, FACE}; 0 <= index < 2^28; 0 <= part < 2^32.
    """
    kind = np.asarray(kind, dtype=np.int64)
    index = np.asarray(index, dtype=np.int64)
    part = np.asarray(part, dtype=np.int64)
    if np.any((kind < 0) | (kind > 3)) or np.any((index < 0) | (index >= 2**28)) \
            or np.any((part < 0) | (part >= 2**32)):
        raise ValueError("feature id out of range: kind 0..3, index < 2^28, part < 2^32")
    return ((part.astype(np.uint64) << np.uint64(32)) | (kind.astype(np.uint64) << np.uint64(28))
            | index.astype(np.uint64))


def feature_parts(ids):
    """Inverse of ``feature_id``: (part, kind, index) as int64 arrays of the shape of ids."""
    ids = np.asarray(ids, dtype=np.uint64)
    part = (ids >> np.uint64(32)).astype(np.int64)
    kind = ((ids >> np.uint64(28)) & np.uint64(0xF)).astype(np.int64)
    index = (ids & np.uint64(0x0FFFFFFF)).astype(np.int64)
    return part, kind, index


# --------------------------------------------------------------------------- box polytope

def box_polytope(half_extents):
    """The box with half extents h = (a, b, c) as a polytope, body frame
    (docs/polytope_numbering.md).

    Output dict:
        vertices   (8, 3) m: vertex k = (sx a, sy b, sz c), sx = +1 if k & 1 else -1, sy by k & 2,
                   sz by k & 4
        loops      (6, 4) int: face f's vertices, counter-clockwise seen from outside
        normals    (6, 3): outward unit normal; face 2 i has -e_i, face 2 i + 1 has +e_i
        offsets    (6,) m: normals[f] . x = offsets[f] on face f (= h_i), <= inside
        edges      (12, 4) int: (v0, v1, f0, f1), numbered in order of first appearance walking
                   faces 0..5 and loop sides k = loop[k] -> loop[k + 1]; the edge runs v0 -> v1 in
                   f0's loop and v1 -> v0 in f1's
        face_edges (6, 4) int: the edge of loop side k of face f
    Loop rule, face with normal s e_i, j = (i + 1) % 3, k = (i + 2) % 3: the (j, k) signs run
    (-,-), (+,-), (+,+), (-,+) for s = +1 and (-,-), (-,+), (+,+), (+,-) for s = -1.
    """
    h = np.asarray(half_extents, dtype=float).reshape(3)
    corner = np.arange(8)
    signs = np.stack([np.where(corner & bit, 1.0, -1.0) for bit in _BIT], axis=1)
    vertices = signs * h

    loops = np.zeros((6, 4), dtype=np.int64)
    normals = np.zeros((6, 3))
    offsets = np.zeros(6)
    for f in range(6):
        i, s = f // 2, (1 if f % 2 else -1)
        j, k = (i + 1) % 3, (i + 2) % 3
        jk = [(-1, -1), (1, -1), (1, 1), (-1, 1)] if s > 0 else [(-1, -1), (-1, 1), (1, 1), (1, -1)]
        for corner_k, (sj, sk) in enumerate(jk):
            loops[f, corner_k] = ((s > 0) * _BIT[i]) + ((sj > 0) * _BIT[j]) + ((sk > 0) * _BIT[k])
        normals[f, i] = s
        offsets[f] = h[i]

    # edges by first appearance: faces 0..5, sides k = loop[k] -> loop[k + 1]
    edges, face_edges, seen = [], np.zeros((6, 4), dtype=np.int64), {}
    for f in range(6):
        for k in range(4):
            v0, v1 = int(loops[f, k]), int(loops[f, (k + 1) % 4])
            key = (min(v0, v1), max(v0, v1))
            if key not in seen:
                seen[key] = len(edges)
                edges.append([v0, v1, f, -1])
            else:
                edges[seen[key]][3] = f
            face_edges[f, k] = seen[key]
    return {"vertices": vertices, "loops": loops, "normals": normals, "offsets": offsets,
            "edges": np.array(edges, dtype=np.int64), "face_edges": face_edges}


def box_edge(polytope, axis, signs):
    """Index of the box edge along body axis ``axis`` whose other two coordinates have the signs
    ``signs`` (3,) (the entry at ``axis`` is ignored; a sign >= 0 counts as +)."""
    base = sum(_BIT[k] for k in range(3) if k != axis and signs[k] >= 0)
    key = {base, base + _BIT[axis]}
    for e, (v0, v1, _, _) in enumerate(polytope["edges"]):
        if {int(v0), int(v1)} == key:
            return e
    raise ValueError("no such box edge")


def polytope_to_world(polytope, p, R):
    """The polytope placed at (p, R): x = R X + p.  Same dict, vertices (n, 3) and normals
    (f, 3) world, offsets (f,) m with n_f . x = offset_f on face f (world)."""
    p, R = np.asarray(p, dtype=float), np.asarray(R, dtype=float)
    world = dict(polytope)
    world["vertices"] = polytope["vertices"] @ R.T + p
    world["normals"] = polytope["normals"] @ R.T
    world["offsets"] = polytope["offsets"] + world["normals"] @ p
    return world


# --------------------------------------------------------------------------- manifold selection

# the manifold's touching tolerance counts gravity's kick up to this fraction of the pair's smaller
# inner radius (the core's kTouchInnerFraction)
TOUCH_INNER_FRACTION = 0.2


def _first_within(values, best, tol, largest):
    """Index of the first entry within tol of the extreme value ``best`` (ties go to the first)."""
    ok = values >= best - tol if largest else values <= best + tol
    return int(np.flatnonzero(ok)[0])


def signed_area(a, b, q, n):
    """area(a, b, q) = ((b - a) x (q - a)) . n / 2, m^2; a, b (3,), q (K, 3) or (3,), n (3,) unit.
    Positive when a, b, q turn counter-clockwise seen from the side n points to."""
    return np.cross(b - a, q - a) @ n / 2.0


def reduce_manifold(y, gap, n, L, end_gap=None, kick=None, inner=np.inf):
    """Choose at most 4 of K > 4 candidate points of one manifold (docs, "Manifolds").

    Inputs: y (K, 3) world points in id order, gap (K,) m, n (K, 3) their normals (A to B),
            L m the pair's length scale, end_gap (K,) m the gaps the points close to in the step
            (``end_gap`` in contacts.py; None: gap, as without a motion), kick (3,) m gravity's
            kick in them, dt^2 (g_B - g_A) (``gravity_kick`` in contacts.py; None: none, as
            without a motion), inner m the smaller inner radius of the pair's bodies.
    Output: the indices (ascending, i.e. id order) of the kept points, 2 to 4 of them.
    The points are ranked by e = end_gap. A tie (within 1e-9 L for lengths, 1e-9 L^2 for areas,
    of the extreme value) goes to the first candidate in id order. p2 to p4 are chosen among the
    touching points (e <= max(e of p1, min(0, n . kick + TOUCH_INNER_FRACTION inner)) + 1e-9 L,
    n the normal at p1, or e <= max(e of p1, 0) + 1e-9 L without a kick: those that end the step
    on the plane, gravity's kick counted up to a fraction of the inner radius) while the best of them scores above the
    tolerance, else among all:
        p1 the deepest (least e); p2 the farthest from p1;
        p3 the largest |area(p1, p2, q)| with n = the normal at p1; if that is <= 1e-9 L^2 (all
           on a line) the manifold is p1 and p2; p2 and p3 are swapped if area(p1, p2, p3) < 0;
        p4 the largest max(-area(p1, p2, q), -area(p2, p3, q), -area(p3, p1, q)),
           kept only if that exceeds 1e-9 L^2.
    """
    y, gap = np.asarray(y, dtype=float), np.asarray(gap, dtype=float)
    e = gap if end_gap is None else np.asarray(end_gap, dtype=float)
    tol_length, tol_area = 1e-9 * L, 1e-9 * L * L
    taken = np.zeros(len(gap), dtype=bool)

    # 1. the deepest point; its normal orients the areas
    p1 = _first_within(e, e.min(), tol_length, largest=False)
    taken[p1] = True
    n = np.asarray(n, dtype=float).reshape(-1, 3)[p1]
    # the touching points, from which 2. to 4. choose while they offer one above the tolerance
    # (gravity's kick moves every point alike and a supported body does not fall it: counted whole,
    # at dt 1/60 every vertex of a small resting body within dt^2 g = 2.7 mm touched)
    touch = 0.0
    if kick is not None:
        touch = min(0.0, float(n @ np.asarray(kick, dtype=float)) + TOUCH_INNER_FRACTION * inner)
    touching = e <= max(e[p1], touch) + tol_length

    def choose(score, tol):
        among = np.where(touching, score, -np.inf)
        best = _first_within(among, among.max(), tol, largest=True)
        return best if among[best] > tol else _first_within(score, score.max(), tol, largest=True)

    # 2. the farthest from p1
    dist = np.where(taken, -np.inf, np.linalg.norm(y - y[p1], axis=1))
    p2 = choose(dist, tol_length)
    taken[p2] = True

    # 3. the largest triangle on p1 p2, oriented counter-clockwise about n
    area = np.where(taken, -np.inf, np.abs(signed_area(y[p1], y[p2], y, n)))
    p3 = choose(area, tol_area)
    taken[p3] = True
    if area[p3] <= tol_area:
        return np.array(sorted([p1, p2]), dtype=np.int64)  # all on a line
    if signed_area(y[p1], y[p2], y[p3], n) < 0:
        p2, p3 = p3, p2

    # 4. the point farthest outside the triangle p1 p2 p3
    outside = np.maximum.reduce([-signed_area(y[p1], y[p2], y, n),
                                 -signed_area(y[p2], y[p3], y, n),
                                 -signed_area(y[p3], y[p1], y, n)])
    outside = np.where(taken, -np.inf, outside)
    p4 = choose(outside, tol_area)
    kept = [p1, p2, p3] + ([p4] if outside[p4] > tol_area else [])
    return np.array(sorted(kept), dtype=np.int64)


def select_manifold(y, n, gap, feature_a, feature_b, threshold, L, end_gap=None, kick=None, inner=np.inf):
    """The contact points of one body pair from its candidates (docs, "Manifolds").

    Inputs: y (K, 3) m, n (K, 3), gap (K,) m, feature_a, feature_b (K,) ids, all world frame;
            threshold m (margin + speculative reach); L m (sum of the bounding radii of the
            pair's bounded shapes); end_gap (K,) m or None, the ranking of ``reduce_manifold``,
            and kick (3,) m and inner m as ``reduce_manifold`` takes them.
    Output: (y, n, gap, feature_a, feature_b) of the kept points, at most 4, in increasing
            (feature_a, feature_b) order: candidates with gap < threshold, exact duplicates (y
            within 1e-9 L of an earlier candidate in id order) dropped, more than 4 reduced by
            ``reduce_manifold``.
    """
    y = np.asarray(y, dtype=float).reshape(-1, 3)
    n = np.asarray(n, dtype=float).reshape(-1, 3)
    gap = np.asarray(gap, dtype=float).reshape(-1)
    feature_a = np.asarray(feature_a, dtype=np.uint64).reshape(-1)
    feature_b = np.asarray(feature_b, dtype=np.uint64).reshape(-1)
    e = gap if end_gap is None else np.asarray(end_gap, dtype=float).reshape(-1)

    # within the threshold, in id order
    keep = gap < threshold
    order = np.flatnonzero(keep)[np.lexsort((feature_b[keep], feature_a[keep]))]
    y, n, gap, feature_a, feature_b, e = (x[order] for x in (y, n, gap, feature_a, feature_b, e))

    # exact duplicates of an earlier candidate are dropped
    unique = np.ones(len(gap), dtype=bool)
    for i in range(1, len(gap)):
        if np.any(np.linalg.norm(y[:i] - y[i], axis=1) <= 1e-9 * L):
            unique[i] = False
    y, n, gap, feature_a, feature_b, e = (x[unique] for x in (y, n, gap, feature_a, feature_b, e))

    # more than 4: reduce
    if len(gap) > 4:
        kept = reduce_manifold(y, gap, n, L, e, kick, inner)
        y, n, gap, feature_a, feature_b = (x[kept] for x in (y, n, gap, feature_a, feature_b))
    return y, n, gap, feature_a, feature_b


# --------------------------------------------------------------------------- box-box

def box_box_separation(p_A, R_A, h_A, p_B, R_B, h_B):
    """Separating axes of two boxes (COM p (3,) m, rotation R (3, 3), half extents h (3,) m).

    Output dict, world frame, lengths in m:
        sep_A, face_a: max over A's faces f of min over B's vertices v of n_f . v - d_f, and the
                       first face attaining it;
        sep_B, face_b: the same with A and B swapped;
        sep_E, axes:   max over the 9 pairs (i, j) (i major, first on ties) of A's axis u_i and
                       B's axis w_j with |u_i x w_j| >= 1e-9 of L . (p_B - p_A) - r_A(L) - r_B(L),
                       L = u_i x w_j / |u_i x w_j| turned so that L . (p_B - p_A) >= 0 and
                       r(L) = sum_k h_k |L . axis_k|; axes = (i, j) (None and -inf if all the
                       axes are parallel);
        L_edge (3,):   that L;
        A, B:          the boxes' world polytopes (``polytope_to_world``).
    The signed separation of the boxes is max(sep_A, sep_B, sep_E) when they overlap (the
    penetration depth, negated) and a lower bound of their distance when they do not.
    """
    A = polytope_to_world(box_polytope(h_A), p_A, R_A)
    B = polytope_to_world(box_polytope(h_B), p_B, R_B)
    h_A, h_B = np.asarray(h_A, dtype=float), np.asarray(h_B, dtype=float)
    R_A, R_B = np.asarray(R_A, dtype=float), np.asarray(R_B, dtype=float)
    d = np.asarray(p_B, dtype=float) - np.asarray(p_A, dtype=float)

    # face axes: the least height of the other box's vertices over each face plane
    s_A = np.min(A["normals"] @ B["vertices"].T - A["offsets"][:, None], axis=1)
    s_B = np.min(B["normals"] @ A["vertices"].T - B["offsets"][:, None], axis=1)
    face_a, face_b = int(np.argmax(s_A)), int(np.argmax(s_B))

    # edge axes u_i x w_j
    sep_E, axes, L_edge = -np.inf, None, None
    for i in range(3):
        for j in range(3):
            c = np.cross(R_A[:, i], R_B[:, j])
            norm = np.linalg.norm(c)
            if norm < 1e-9:
                continue
            L = c / norm
            if L @ d < 0:
                L = -L
            sep = L @ d - h_A @ np.abs(R_A.T @ L) - h_B @ np.abs(R_B.T @ L)
            if sep > sep_E:
                sep_E, axes, L_edge = sep, (i, j), L
    return {"sep_A": float(s_A[face_a]), "face_a": face_a, "sep_B": float(s_B[face_b]),
            "face_b": face_b, "sep_E": float(sep_E), "axes": axes, "L_edge": L_edge,
            "A": A, "B": B}


def clip_incident_face(ref, ref_face, inc, inc_face):
    """Sutherland-Hodgman clipping of the incident face's loop against the side planes of the
    reference face, with feature-id tracking (docs, "Manifolds", face contact).

    Inputs: ref, inc world polytopes (``polytope_to_world``), the face indices.
    Output: q (K, 3) m, points on the incident face inside every side plane; ref_id, inc_id (K,)
            feature ids on the reference and incident polytope.
    Side k runs loop[k] -> loop[k + 1]; its outward normal m_k = unit(e_k x n_ref) and a point x
    is kept where m_k . x <= m_k . loop[k].  The loop's points start with ids (reference face,
    incident vertex); a point where an incident edge e crosses side k gets (edge of side k, e); a
    point where the cut of an earlier side k' crosses side k gets (vertex shared by k' and k,
    incident face).
    """
    n_ref = ref["normals"][ref_face]
    ref_loop = ref["loops"][ref_face]
    n_sides = len(ref_loop)

    # polygon entries: [point, ref id, inc id, the edge leaving it: ("inc", edge) or ("side", k)]
    polygon = []
    for t, v in enumerate(inc["loops"][inc_face]):
        polygon.append([inc["vertices"][v], feature_id(FACE, ref_face), feature_id(VERTEX, v),
                        ("inc", int(inc["face_edges"][inc_face][t]))])

    for k in range(n_sides):
        a = ref["vertices"][ref_loop[k]]
        b = ref["vertices"][ref_loop[(k + 1) % n_sides]]
        m = np.cross(b - a, n_ref)
        m /= np.linalg.norm(m)
        clipped = []
        for i, cur in enumerate(polygon):
            nxt = polygon[(i + 1) % len(polygon)]
            d_cur, d_nxt = m @ cur[0] - m @ a, m @ nxt[0] - m @ a
            if d_cur <= 0:
                clipped.append(cur)
            if (d_cur <= 0) != (d_nxt <= 0):
                x = cur[0] + d_cur / (d_cur - d_nxt) * (nxt[0] - cur[0])
                kind, e = cur[3]
                if kind == "inc":
                    ids = (feature_id(EDGE, ref["face_edges"][ref_face][k]), feature_id(EDGE, e))
                elif e == (k - 1) % n_sides:
                    ids = (feature_id(VERTEX, ref_loop[k]), feature_id(FACE, inc_face))
                elif e == (k + 1) % n_sides:
                    ids = (feature_id(VERTEX, ref_loop[(k + 1) % n_sides]), feature_id(FACE, inc_face))
                else:
                    ids = (None, None)  # lines of non-adjacent sides: outside the face, cut later
                # leaving: the boundary runs along side k; entering: along the edge it came from
                clipped.append([x, ids[0], ids[1], ("side", k) if d_cur <= 0 else cur[3]])
        polygon = clipped
        if not polygon:
            break

    if any(entry[1] is None for entry in polygon):
        raise RuntimeError("a crossing of non-adjacent side lines survived the clipping")
    q = np.array([entry[0] for entry in polygon]).reshape(-1, 3)
    ref_id = np.array([entry[1] for entry in polygon], dtype=np.uint64)
    inc_id = np.array([entry[2] for entry in polygon], dtype=np.uint64)
    return q, ref_id, inc_id


def _closest_points_of_lines(a0, u, b0, w):
    """Closest points a0 + s u and b0 + t w of two non-parallel lines (u, w unit), (3,) each."""
    r = a0 - b0
    c = u @ w
    s = (c * (w @ r) - u @ r) / (1.0 - c * c)
    t = w @ r + s * c
    return a0 + s * u, b0 + t * w


def _edge_crossing(ref, ref_edge, inc, inc_edge, n_ref):
    """(gap, y, L) of the edge-edge contact at a clipped crossing of reference edge ref_edge and
    incident edge inc_edge (docs, "Manifolds"), or None when their cross product is not within
    0.05 rad of n_ref or their closest points are not on both edges."""
    r0, r1 = (ref["vertices"][v] for v in ref["edges"][ref_edge][:2])
    i0, i1 = (inc["vertices"][v] for v in inc["edges"][inc_edge][:2])
    u, w = r1 - r0, i1 - i0
    L = np.cross(u, w)
    if not np.linalg.norm(L) > 1e-9 * np.linalg.norm(u) * np.linalg.norm(w):
        return None
    L = L / np.linalg.norm(L)
    if L @ n_ref < 0:
        L = -L
    if L @ n_ref < NEARLY_PARALLEL:
        return None
    # closest points r0 + s u, i0 + t w of the two lines
    A = np.array([[u @ u, -(u @ w)], [u @ w, -(w @ w)]])
    s, t = np.linalg.solve(A, [-(u @ (r0 - i0)), -(w @ (r0 - i0))])
    if not (0.0 <= s <= 1.0 and 0.0 <= t <= 1.0):
        return None
    x_ref, x_inc = r0 + s * u, i0 + t * w
    return L @ (x_inc - x_ref), 0.5 * (x_ref + x_inc), L


def _line_parameters(p0, u, q0, w):
    """Parameters (s, t) of the closest points p0 + s u and q0 + t w of two non-parallel lines
    (p0, q0 (3,) m; u, w (3,) their edge vectors, any length)."""
    r = p0 - q0
    uu, ww, uw, ur, wr = u @ u, w @ w, u @ w, u @ r, w @ r
    det = uw * uw - uu * ww
    return (ur * ww - uw * wr) / det, (uw * ur - uu * wr) / det


def _closest_on_edges(X, V, edges, part):
    """Every point of X (K, 3) against every edge of a polytope (vertices V (n, 3), edges (E, 4)
    rows (v0, v1, f0, f1)): its closest point on the segment v0 -> v1, (K, E, 3), the feature id
    of that point (the end vertex itself when the parameter t = (x - v0) . w / w . w, w = v1 - v0,
    is <= 0 or >= 1, else the edge), (K, E), and its dimension (0 vertex, 1 edge), (K, E)."""
    Q0, Q1 = V[edges[:, 0]], V[edges[:, 1]]
    W = Q1 - Q0
    t = np.einsum("kej,ej->ke", X[:, None, :] - Q0[None], W) / np.einsum("ej,ej->e", W, W)
    low, high = ~(t > 0.0), ~(t < 1.0)
    inner = Q0[None] + t[..., None] * W[None]
    point = np.where(low[..., None], Q0[None], np.where(high[..., None], Q1[None], inner))
    E = np.broadcast_to(np.arange(len(edges)), t.shape)
    ids = np.where(low, feature_id(VERTEX, np.broadcast_to(edges[:, 0], t.shape), part),
                   np.where(high, feature_id(VERTEX, np.broadcast_to(edges[:, 1], t.shape), part),
                            feature_id(EDGE, E, part)))
    return point, ids, np.where(low | high, 0, 1)


def _feet_inside(X, P):
    """Every point of X (K, 3) against every face f of polytope P (a world polytope dict): the
    height h = n_f . x - d_f (K, F), the foot x - h n_f (K, F, 3), and whether h > 0 and the foot
    lies strictly inside the face (K, F): (loop[k+1] - loop[k]) x n_f . (foot - loop[k]) < 0 for
    every side k."""
    V, N = P["vertices"], P["normals"]
    h = X @ N.T - P["offsets"][None, :]
    foot = X[:, None, :] - h[..., None] * N[None]
    inside = h > 0.0
    for f, loop in enumerate(P["loops"]):
        for k in range(len(loop)):
            r0, r1 = V[loop[k]], V[loop[(k + 1) % len(loop)]]
            inside[:, f] &= (foot[:, f] - r0) @ np.cross(r1 - r0, N[f]) < 0.0
    return h, foot, inside


def closest_features(A, B, tie, part_a=0, part_b=0):
    """The closest points of two disjoint convex polytopes and the features holding them.

    Inputs: A, B world polytope dicts (``polytope_to_world``), tie m (the core uses 1e-12 L),
            part_a, part_b the parts written into the feature ids.
    Output: (p (3,) on A, q (3,) on B, |q - p| m, feature_a, feature_b).
    The candidates, in this order, each in (feature of A, feature of B) index order:
        1. each vertex of A against each edge of B (its closest point on the segment; the end
           vertex itself when clamped);  2. each edge of A against each vertex of B;
        3. each pair of non-parallel edges (|u x w| > 1e-9 |u| |w|) whose lines' closest points lie
           strictly inside both;
        4. each vertex of A with height h > 0 over a face of B and its foot strictly inside;
        5. each face of A against each vertex of B likewise.
    The closest pair of disjoint convex polytopes is one of them, so their least distance D is the
    distance. Chosen: among the candidates within D + tie, the one whose features' dimensions
    (vertex 0, edge 1, face 2) sum least, first in the order above (docs, "Manifolds").
    """
    VA, VB = A["vertices"], B["vertices"]
    EA, EB = np.asarray(A["edges"]), np.asarray(B["edges"])
    P, Q, D, FA, FB, DIM = [], [], [], [], [], []

    def add(p, q, fa, fb, dim):
        p, q = np.asarray(p).reshape(-1, 3), np.asarray(q).reshape(-1, 3)
        P.append(p), Q.append(q), D.append(np.linalg.norm(q - p, axis=1))
        FA.append(np.asarray(fa, dtype=np.uint64).reshape(-1)), FB.append(np.asarray(fb, dtype=np.uint64).reshape(-1))
        DIM.append(np.asarray(dim).reshape(-1))

    # 1. vertices of A against edges of B; 2. edges of A against vertices of B
    point, ids, dim = _closest_on_edges(VA, VB, EB, part_b)
    add(np.broadcast_to(VA[:, None, :], point.shape), point,
        np.broadcast_to(feature_id(VERTEX, np.arange(len(VA)), part_a)[:, None], ids.shape), ids, dim)
    point, ids, dim = _closest_on_edges(VB, VA, EA, part_a)       # (vertex of B, edge of A)
    point, ids, dim = point.transpose(1, 0, 2), ids.T, dim.T       # (edge of A, vertex of B)
    add(point, np.broadcast_to(VB[None, :, :], point.shape), ids,
        np.broadcast_to(feature_id(VERTEX, np.arange(len(VB)), part_b)[None, :], ids.shape), dim)
    # 3. edges against edges, closest points strictly inside both
    for i, (a0, a1, _, _) in enumerate(EA):
        p0, u = VA[a0], VA[a1] - VA[a0]
        for j, (b0, b1, _, _) in enumerate(EB):
            q0, w = VB[b0], VB[b1] - VB[b0]
            if not np.linalg.norm(np.cross(u, w)) > 1e-9 * np.linalg.norm(u) * np.linalg.norm(w):
                continue
            s, t = _line_parameters(p0, u, q0, w)
            if 0.0 < s < 1.0 and 0.0 < t < 1.0:
                add(p0 + s * u, q0 + t * w, feature_id(EDGE, i, part_a), feature_id(EDGE, j, part_b), 2)
    # 4. vertices of A over faces of B; 5. faces of A under vertices of B
    _, foot, inside = _feet_inside(VA, B)
    i, f = np.nonzero(inside)
    add(VA[i], foot[i, f], feature_id(VERTEX, i, part_a), feature_id(FACE, f, part_b), np.full(len(i), 2))
    _, foot, inside = _feet_inside(VB, A)                          # (vertex of B, face of A)
    f, j = np.nonzero(inside.T)                                    # in (face of A, vertex of B) order
    add(foot[j, f], VB[j], feature_id(FACE, f, part_a), feature_id(VERTEX, j, part_b), np.full(len(j), 2))

    P, Q, D, FA, FB, DIM = (np.concatenate(x) for x in (P, Q, D, FA, FB, DIM))
    near = D <= D.min() + tie
    k = int(np.flatnonzero(near & (DIM == DIM[near].min()))[0])
    return P[k], Q[k], float(D[k]), FA[k], FB[k]


def contact_box_box(p_A, R_A, h_A, p_B, R_B, h_B, threshold):
    """Candidate contact points of box A against box B (A the lower index; docs, "Manifolds").

    Inputs: COM p (3,) m, rotation R (3, 3), half extents h (3,) m of each box; threshold m.
    Output: (y (K, 3) m, n (K, 3) from A towards B, gap (K,) m, feature_a (K,), feature_b (K,)
            np.uint64), world frame, in clipping order (``select_manifold`` filters, sorts and
            reduces them).  K = 0 when any of sep_A, sep_B, sep_E is >= threshold.
    Faces are preferred among nearly parallel axes (|a . b| >= cos 0.05), L = |h_A| + |h_B|:
    the reference face is face_a of A unless sep_B > sep_A + tol_F (then face_b of B),
    tol_F = FACE_PREFERENCE L if the two faces are nearly parallel, else 1e-9 L; the contact is
    edge-edge if sep_E > max(sep_A, sep_B) + tol_E, tol_E = FACE_PREFERENCE L if the edge axis is
    nearly parallel to the better face's normal, else 1e-9 L:
      face: the incident face is the other box's face with the least n_inc . n_ref; its loop is
            clipped (``clip_incident_face``); each point q has gap = n_ref . q - d_ref,
            y = q - gap n_ref / 2, n = n_ref if the reference face is A's, else -n_ref; except a
            crossing of two edges whose cross product is within 0.05 rad of n_ref and whose
            closest points lie on both edges, which is their edge-edge contact
            (``_edge_crossing``). When the boxes are apart or touching (max(sep_A, sep_B) >=
            -1e-12 L) and the least gap of the clipped points below threshold (inf if none:
            corners facing each other beside the faces) exceeds max(sep_A, sep_B) by more than
            1e-9 L, the boxes' closest pair (``closest_features``, tie 1e-12 L) is added when it is
            nearer than threshold and than every such clipped point by more than 1e-9 L (touching
            within 1e-12 L: normal along the better face axis, A -> B; else (q - p) / gap), and
            the clipped points with its ids or within 1e-9 L of its point (p + q) / 2 are dropped:
            a speculative contact's deepest gap is the distance.
      edge: A's edge along u_i supporting A in +L, B's edge along w_j supporting B in -L;
            y = midpoint of the closest points of their lines, gap = sep_E, n = L; except when
            the boxes are apart (sep_E > 0) and those closest points are not both on the edges
            (segment parameters in [0, 1]): sep_E is then only a lower bound of the distance, and
            the contact is the boxes' closest pair p, q (``closest_features``, tie 1e-12 L):
            y = (p + q) / 2, gap = |q - p|, n = (q - p) / gap, the ids of their features; none
            when gap >= threshold.
    """
    h_A, h_B = np.asarray(h_A, dtype=float), np.asarray(h_B, dtype=float)
    R_A, R_B = np.asarray(R_A, dtype=float), np.asarray(R_B, dtype=float)
    p_A, p_B = np.asarray(p_A, dtype=float), np.asarray(p_B, dtype=float)
    sat = box_box_separation(p_A, R_A, h_A, p_B, R_B, h_B)
    tol = FACE_PREFERENCE * (np.linalg.norm(h_A) + np.linalg.norm(h_B))

    # any axis that separates by the threshold or more: no contact
    if max(sat["sep_A"], sat["sep_B"], sat["sep_E"]) >= threshold:
        return (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.uint64),
                np.zeros(0, dtype=np.uint64))

    # the reference: A's face, B's face, or the edge pair; the preference for faces applies only
    # among nearly parallel axes (docs, "Manifolds")
    L_scale = np.linalg.norm(h_A) + np.linalg.norm(h_B)
    n_fa = sat["A"]["normals"][sat["face_a"]]
    n_fb = sat["B"]["normals"][sat["face_b"]]
    tol_F = tol if abs(n_fa @ n_fb) >= NEARLY_PARALLEL else 1e-9 * L_scale
    n_better = n_fb if sat["sep_B"] > sat["sep_A"] else n_fa
    edge_parallel = sat["L_edge"] is not None and abs(sat["L_edge"] @ n_better) >= NEARLY_PARALLEL
    tol_E = tol if edge_parallel else 1e-9 * L_scale
    a_is_ref = not sat["sep_B"] > sat["sep_A"] + tol_F
    if sat["sep_E"] > max(sat["sep_A"], sat["sep_B"]) + tol_E:
        # edge-edge: the supporting edge of A along +L and of B along -L
        i, j = sat["axes"]
        L = sat["L_edge"]
        signs_A = np.where(R_A.T @ L >= 0, 1.0, -1.0)
        signs_B = np.where(-(R_B.T @ L) >= 0, 1.0, -1.0)
        signs_A[i], signs_B[j] = 0.0, 0.0
        a0 = p_A + R_A @ (signs_A * h_A)          # midpoint of A's edge
        b0 = p_B + R_B @ (signs_B * h_B)          # midpoint of B's edge
        x_A, x_B = _closest_points_of_lines(a0, R_A[:, i], b0, R_B[:, j])
        edge_a = box_edge(sat["A"], i, signs_A)
        edge_b = box_edge(sat["B"], j, signs_B)
        # apart, with the lines' closest points off an edge: the closest pair of the boxes
        ra0, ra1 = sat["A"]["vertices"][sat["A"]["edges"][edge_a][:2]]
        rb0, rb1 = sat["B"]["vertices"][sat["B"]["edges"][edge_b][:2]]
        s_a, t_b = _line_parameters(ra0, ra1 - ra0, rb0, rb1 - rb0)
        if sat["sep_E"] > 0.0 and not (0.0 <= s_a <= 1.0 and 0.0 <= t_b <= 1.0):
            p, q, gap, fa, fb = closest_features(sat["A"], sat["B"], 1e-12 * L_scale)
            if not gap < threshold:
                return (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.uint64),
                        np.zeros(0, dtype=np.uint64))
            return ((0.5 * (p + q))[None, :], ((q - p) / gap)[None, :], np.array([gap]),
                    np.array([fa]), np.array([fb]))
        return ((0.5 * (x_A + x_B))[None, :], L[None, :], np.array([sat["sep_E"]]),
                np.array([feature_id(EDGE, edge_a)]), np.array([feature_id(EDGE, edge_b)]))

    # face: clip the incident face against the reference face's side planes
    ref, inc = (sat["A"], sat["B"]) if a_is_ref else (sat["B"], sat["A"])
    ref_face = sat["face_a"] if a_is_ref else sat["face_b"]
    n_ref, d_ref = ref["normals"][ref_face], ref["offsets"][ref_face]
    inc_face = int(np.argmin(inc["normals"] @ n_ref))
    q, ref_id, inc_id = clip_incident_face(ref, ref_face, inc, inc_face)
    gap = q @ n_ref - d_ref
    y = q - 0.5 * gap[:, None] * n_ref
    n = np.tile(n_ref, (len(gap), 1))
    # a crossing of two nearly parallel edges keeps their exact edge-edge distance
    for k in range(len(gap)):
        if feature_parts(ref_id[k])[1] == EDGE and feature_parts(inc_id[k])[1] == EDGE:
            crossing = _edge_crossing(ref, int(feature_parts(ref_id[k])[2]), inc,
                                      int(feature_parts(inc_id[k])[2]), n_ref)
            if crossing is not None:
                gap[k], y[k], n[k] = crossing
    if not a_is_ref:
        n = -n
    fa_ids, fb_ids = (ref_id, inc_id) if a_is_ref else (inc_id, ref_id)
    # apart or touching, the clip can miss the closest pair, added when the least clipped gap exceeds
    # the larger face separation by 1e-9 L (docs/conventions.md, "Manifolds", face contact)
    lower = max(sat["sep_A"], sat["sep_B"])
    least = float(gap[gap < threshold].min()) if np.any(gap < threshold) else np.inf
    if lower >= -1e-12 * L_scale and least > lower + 1e-9 * L_scale:
        p, q, dist, fa, fb = closest_features(sat["A"], sat["B"], 1e-12 * L_scale)
        if dist < threshold and dist < least - 1e-9 * L_scale:
            if dist <= 1e-12 * L_scale:
                normal = (-sat["B"]["normals"][sat["face_b"]] if sat["sep_B"] > sat["sep_A"]
                          else sat["A"]["normals"][sat["face_a"]])
            else:
                normal = (q - p) / dist
            point = 0.5 * (p + q)
            stay = ~(((fa_ids == fa) & (fb_ids == fb)) | (np.linalg.norm(y - point, axis=1) <= 1e-9 * L_scale))
            y, n, gap, fa_ids, fb_ids = (x[stay] for x in (y, n, gap, fa_ids, fb_ids))
            y, n, gap = np.vstack([y, point]), np.vstack([n, normal]), np.append(gap, dist)
            fa_ids = np.append(fa_ids, np.uint64(fa)).astype(np.uint64)
            fb_ids = np.append(fb_ids, np.uint64(fb)).astype(np.uint64)
    return y, n, gap, fa_ids, fb_ids
