"""Exact contact detection for the pairs the oracle knows (docs/conventions.md, "Contacts",
"Feature ids", "Manifolds").

A contact is (body_a, body_b, point y, normal n, gap, feature_a, feature_b), world frame:
    n          unit, points from A towards B
    gap        signed distance along n, m (negative = overlap)
    y          midpoint of the witness points, y = (w_A + w_B) / 2 with w_B - w_A = gap n
    feature_*  the feature of A / B the point comes from, np.uint64
               (part * 2^32 + kind * 2^28 + index, see ``manifold.feature_id``)

Dispatch table (plane is always A; other pairs have A = lower body index), features (A, B):
    plane    - sphere   : the sphere's lowest point                       (face 0, shape 0)
    plane    - box      : the 8 corners, corner order k = 0..7            (face 0, vertex k)
    plane    - mesh     : every vertex, vertex order                      (face 0, vertex i)
    plane    - capsule  : both segment ends as spheres                    (face 0, vertex 0 / 1)
    plane    - cylinder : 16 rim points and the deepest rim point per cap (face 0, vertex 8 s + k
                          / edge s)
    sphere   - sphere   : along the line of centres                       (shape 0, shape 0)
    box      - sphere   : the centre clamped into the box                 (shape 0, shape 0)
    sphere   - capsule  : the closest point of the capsule's segment      (shape 0, vertex 0 / 1 /
                                                                           edge 0)
    box      - box      : separating axes and face clipping (``manifold.contact_box_box``)
    anything else       : NotImplementedError when the bounding spheres are within reach
                          (the core uses FCL there; the oracle does not), skipped when not.
Each pair's candidates the pair can close in the step (``reachable``) become its manifold by
``manifold.select_manifold`` (gap < threshold, id order, duplicates dropped, at most 4 points;
against a plane ranked by the gaps they close to in the step, ``end_gap``), a mesh on a plane too.
"""

import numpy as np

from .manifold import (
    EDGE,
    FACE,
    SHAPE,
    VERTEX,
    contact_box_box,
    feature_id,
    select_manifold,
)
from .rigid import body_arrays, motion_flags


# m, the documented default of the setting contact_margin (old snapshots may lack it)
DEFAULT_CONTACT_MARGIN = 0.005


def bounding_radius(shape):
    """rho: largest distance of the shape's surface from its COM, m.

    sphere r, box |(a, b, c)|, capsule r + h, cylinder sqrt(r^2 + h^2), mesh, hull or triangle
    mesh max |vertex| (body frame, COM at origin); plane inf.
    """
    kind = shape["type"]
    if kind == "sphere":
        return float(shape["radius"])
    if kind == "box":
        return float(np.linalg.norm(np.asarray(shape["half_extents"], dtype=float)))
    if kind == "capsule":
        return float(shape["radius"]) + float(shape["half_length"])
    if kind == "cylinder":
        return float(np.hypot(float(shape["radius"]), float(shape["half_height"])))
    if kind in ("mesh", "hull", "trimesh"):
        return float(np.max(np.linalg.norm(np.asarray(shape["vertices"], dtype=float), axis=1)))
    if kind == "plane":
        return np.inf
    raise ValueError(f"unknown shape type {kind!r}")


def turn_speed(omega, rho, dt):
    """How fast (m/s) a body turning at omega rad/s can move its surface over a step of dt, with
    bounding radius rho m: omega rho, but a turn moves no point further than 2 rho, so at most
    2 rho / dt."""
    return min(omega * rho, 2.0 * rho / dt)


def speculative_reach(snapshot, dt):
    """s_b = dt (|v_b| + dt |g| + turn_speed(|omega_b|, rho_b, dt)) per dynamic body, 0 for static ones.

    Inputs: snapshot, dt s.  Output (N,) m: how far a body's surface can travel in one step.
    """
    static, _, _, _ = body_arrays(snapshot)
    v = np.asarray(snapshot["velocity"], dtype=float).reshape(-1, 3)
    omega = np.asarray(snapshot["angular_velocity"], dtype=float).reshape(-1, 3)
    g = np.linalg.norm(np.asarray(snapshot["gravity"], dtype=float))
    s = np.zeros(len(static))
    for b, body in enumerate(snapshot["bodies"]):
        if not static[b]:
            rho = bounding_radius(body["shape"])
            s[b] = dt * (np.linalg.norm(v[b]) + dt * g + turn_speed(np.linalg.norm(omega[b]), rho, dt))
    return s


def plane_reach(snapshot, b, n, dt):
    """Reach of body b towards a plane of world normal n (3,): only the approach counts,
    dt (max(0, -n . v_b) + dt max(0, -n . g) + turn_speed(|omega_b|, rho_b, dt)); 0 for a static body. m."""
    body = snapshot["bodies"][b]
    if body["static"]:
        return 0.0
    v = np.asarray(snapshot["velocity"], dtype=float).reshape(-1, 3)[b]
    omega = np.asarray(snapshot["angular_velocity"], dtype=float).reshape(-1, 3)[b]
    g = np.asarray(snapshot["gravity"], dtype=float)
    return dt * (max(0.0, -float(n @ v)) + dt * max(0.0, -float(n @ g))
                 + turn_speed(np.linalg.norm(omega), bounding_radius(body["shape"]), dt))


def _point_motion(snapshot, i, y):
    """Body i's motion at the points y (K, 3) m: v_i(y) = v_i + omega_i x (y - p_i) (K, 3) m/s, g_i
    (3,) m/s^2 (gravity for a body gravity moves, else 0), and whether it is dynamic (a contact
    with a third body can stop it within the step)."""
    static, _, _, _ = body_arrays(snapshot)
    kinematic, _ = motion_flags(snapshot)
    p = np.asarray(snapshot["position"], dtype=float).reshape(-1, 3)
    v = np.asarray(snapshot["velocity"], dtype=float).reshape(-1, 3)
    omega = np.asarray(snapshot["angular_velocity"], dtype=float).reshape(-1, 3)
    g = np.asarray(snapshot["gravity"], dtype=float)
    dynamic = not (static[i] or kinematic[i])
    return v[i] + np.cross(omega[i], y - p[i]), (g if dynamic else np.zeros(3)), dynamic


def _relative_motion(snapshot, a, b, y):
    """The motion of the pair (a, b) at the points y (K, 3) m: v_b(y) - v_a(y) (K, 3) m/s, with
    v_i(y) = v_i + omega_i x (y - p_i), and g_b - g_a (3,) m/s^2, g_i = gravity for a body gravity
    moves, else 0."""
    v_a, g_a, _ = _point_motion(snapshot, a, y)
    v_b, g_b, _ = _point_motion(snapshot, b, y)
    return v_b - v_a, g_b - g_a


def reachable(snapshot, dt, margin, a, b, y, n, gap):
    """Which points of the pair (a, b)'s manifold it can close in this step (K,) bool: gap < margin,
    or gap < margin + dt (c + dt (|omega_a|^2 rho_a + |omega_b|^2 rho_b) / 2) with c the closing
    speed: the largest of u + dt g_n (u = max(0, -n . (v_b(y) - v_a(y))) the approach speed at the
    point, v_i(y) = v_i + omega_i x (y - p_i), g_n = max(0, -n . (g_b - g_a)), g_i = gravity for a
    body gravity moves, else 0) and, for a dynamic partner that a third body can stop within the
    step, each body's own: max(0, -n . v_b(y)) + dt max(0, -n . g_b) with a stopped,
    max(0, n . v_a(y)) + dt max(0, n . g_a) with b stopped (a stack falling as one closes its gaps
    when its lowest body lands). The last term is the turn of a spinning surface beyond first order
    (centripetal acceleration <= |omega|^2 rho).

    Inputs: snapshot, dt s, margin m, bodies a, b, y (K, 3) m, n (K, 3) from a to b, gap (K,) m.
    """
    static, _, _, _ = body_arrays(snapshot)
    omega = np.asarray(snapshot["angular_velocity"], dtype=float).reshape(-1, 3)
    bodies = snapshot["bodies"]

    def turning(i):
        return 0.0 if static[i] else float(omega[i] @ omega[i]) * bounding_radius(bodies[i]["shape"])

    def toward(velocity, g, sign):  # closing speed along sign * n, with gravity's kick
        return np.maximum(0.0, sign * np.einsum("kj,kj->k", n, velocity)) + dt * np.maximum(0.0, sign * (n @ g))

    v_a, g_a, dynamic_a = _point_motion(snapshot, a, y)
    v_b, g_b, dynamic_b = _point_motion(snapshot, b, y)
    closing = toward(v_b - v_a, g_b - g_a, -1.0)
    if dynamic_a:
        closing = np.maximum(closing, toward(v_b, g_b, -1.0))
    if dynamic_b:
        closing = np.maximum(closing, toward(v_a, g_a, 1.0))
    reach = dt * (closing + dt * (0.5 * (turning(a) + turning(b))))
    return gap < margin + reach  # reach >= 0: every point within the margin stays


def end_gap(snapshot, dt, a, b, y, n, gap):
    """The gaps the points of the pair (a, b) close to in this step if each moves on at its
    velocity after gravity's kick, (K,) m: gap + dt n . (v_b(y) - v_a(y) + dt (g_b - g_a)), with
    v_i(y) = v_i + omega_i x (y - p_i) and g_i = gravity for a body gravity moves, else 0 (the
    ranking of the manifold's reduction to 4, ``manifold.reduce_manifold``).

    Inputs: snapshot, dt s, bodies a, b, y (K, 3) m, n (K, 3) from a to b, gap (K,) m.
    """
    y, n = np.asarray(y, dtype=float).reshape(-1, 3), np.asarray(n, dtype=float).reshape(-1, 3)
    relative, g_rel = _relative_motion(snapshot, a, b, y)
    return np.asarray(gap, dtype=float) + dt * np.einsum("kj,kj->k", n, relative + dt * g_rel)


def gravity_kick(snapshot, dt, a, b):
    """Gravity's kick in the end gaps of the pair (a, b), dt^2 (g_b - g_a), (3,) m, with g_i =
    gravity for a body gravity moves, else 0: the same for every point of the pair, so the
    manifold's touching rule leaves it out (``manifold.reduce_manifold``)."""
    _, g_rel = _relative_motion(snapshot, a, b, np.zeros((0, 3)))
    return dt * dt * g_rel


def box_corners(half_extents):
    """The 8 corners of a box in body axes, (8, 3), corner order of the conventions:
    corner_k = (sx a, sy b, sz c), sx = +1 if k & 1 else -1, sy by k & 2, sz by k & 4."""
    a, b, c = np.asarray(half_extents, dtype=float)
    k = np.arange(8)
    sx = np.where(k & 1, 1.0, -1.0)
    sy = np.where(k & 2, 1.0, -1.0)
    sz = np.where(k & 4, 1.0, -1.0)
    return np.stack([sx * a, sy * b, sz * c], axis=1)


def contact_plane_points(normal, offset, x):
    """Plane {n . x = offset} (A) against world points x (K, 3) of B.

    gap = n . x - offset, w_B = x, w_A = x - gap n, y = x - gap n / 2.
    Outputs: y (K, 3), n (K, 3), gap (K,).
    """
    n = np.asarray(normal, dtype=float)
    x = np.asarray(x, dtype=float).reshape(-1, 3)
    gap = x @ n - offset
    y = x - 0.5 * gap[:, None] * n
    return y, np.tile(n, (len(x), 1)), gap


def contact_plane_sphere(normal, offset, c, r):
    """Plane (A) against a sphere (B) of centre c (3,) and radius r.

    gap = n . c - offset - r, w_B = c - r n, w_A = w_B - gap n.  Outputs as
    ``contact_plane_points`` with K = 1.
    """
    n = np.asarray(normal, dtype=float)
    c = np.asarray(c, dtype=float)
    gap = n @ c - offset - r
    w_B = c - r * n
    y = w_B - 0.5 * gap * n
    return y[None, :], n[None, :], np.array([gap])


def contact_sphere_sphere(c_A, r_A, c_B, r_B):
    """Sphere A against sphere B (A the lower body index).

    d = c_B - c_A, n = d / |d|, gap = |d| - r_A - r_B, w_A = c_A + r_A n, w_B = c_B - r_B n.
    Concentric spheres have no normal: ValueError.  Outputs as above with K = 1.
    """
    c_A = np.asarray(c_A, dtype=float)
    c_B = np.asarray(c_B, dtype=float)
    d = c_B - c_A
    dist = np.linalg.norm(d)
    if dist == 0.0:
        raise ValueError("concentric spheres: the contact normal is undefined")
    n = d / dist
    gap = dist - r_A - r_B
    w_A = c_A + r_A * n
    w_B = c_B - r_B * n
    y = 0.5 * (w_A + w_B)
    return y[None, :], n[None, :], np.array([gap])


def contact_box_sphere(p_box, R_box, half_extents, c, r):
    """Box (COM p_box, rotation R_box, half extents h) against a sphere (centre c, radius r).

    In box coordinates c_l = R^T (c - p): the closest box point q is c_l clamped to [-h, h]; if
    c_l is outside, n = (c_l - q) / |c_l - q| and gap = |c_l - q| - r; if inside, the nearest
    face k (lowest index on ties) gives n = sign(c_l[k]) e_k and gap = -(h_k - |c_l[k]|) - r,
    with q = c_l moved onto that face. Witnesses q on the box and c_l - r n on the sphere.
    Outputs (y (1, 3), n (1, 3) from the box towards the sphere, gap (1,)), world frame.
    """
    h = np.asarray(half_extents, dtype=float)
    R_box = np.asarray(R_box, dtype=float)
    c_l = R_box.T @ (np.asarray(c, dtype=float) - np.asarray(p_box, dtype=float))
    q = np.clip(c_l, -h, h)
    if np.any(q != c_l):
        d = c_l - q
        n_l = d / np.linalg.norm(d)
        gap = np.linalg.norm(d) - r
    else:
        slack = h - np.abs(c_l)
        k = int(np.argmin(slack))
        n_l = np.zeros(3)
        n_l[k] = -1.0 if c_l[k] < 0 else 1.0
        gap = -slack[k] - r
        q = c_l.copy()
        q[k] = n_l[k] * h[k]
    y_l = 0.5 * (q + (c_l - r * n_l))
    return (R_box @ y_l + p_box)[None, :], (R_box @ n_l)[None, :], np.array([gap])


def contact_sphere_capsule(c, r_s, p, R, r_c, h):
    """Sphere (centre c (3,), radius r_s) against a capsule (COM p (3,), rotation R (3, 3),
    radius r_c, half length h; segment p0 = p - h a, p1 = p + h a, a = R e_z), all m.

    t = the parameter of the segment point closest to c, clamped to [0, 1] (0 when h = 0),
    q = p0 + t (p1 - p0), n_cap = (c - q) / |c - q| (R e_x when c = q), gap = |c - q| - r_c - r_s,
    witnesses q + r_c n_cap (capsule) and c - r_s n_cap (sphere).
    Outputs: y (1, 3), n_cap (1, 3) from the capsule towards the sphere, gap (1,), and the
    capsule's feature (1,) np.uint64: vertex 0 if t = 0, vertex 1 if t = 1, else edge 0.
    """
    c, p, R = (np.asarray(x, dtype=float) for x in (c, p, R))
    a = R[:, 2]
    p0, p1 = p - h * a, p + h * a
    e = p1 - p0
    t = 0.0 if e @ e == 0.0 else float(np.clip((c - p0) @ e / (e @ e), 0.0, 1.0))
    q = p0 + t * e
    d = c - q
    dist = np.linalg.norm(d)
    n_cap = d / dist if dist > 0.0 else R[:, 0]
    gap = dist - r_c - r_s
    y = 0.5 * ((q + r_c * n_cap) + (c - r_s * n_cap))
    feature = (feature_id(VERTEX, 0) if t == 0.0 else feature_id(VERTEX, 1) if t == 1.0
               else feature_id(EDGE, 0))
    return y[None, :], n_cap[None, :], np.array([gap]), np.array([feature], dtype=np.uint64)


def contact_plane_capsule(normal, offset, p, R, r_c, h):
    """Plane {n . x = offset} (A) against a capsule (B: COM p (3,), rotation R (3, 3), radius r_c,
    half length h, m): both segment ends p_0 = p - h a, p_1 = p + h a (a = R e_z) as spheres of
    radius r_c: gap = n . p_k - offset - r_c, w_B = p_k - r_c n, y = w_B - gap n / 2.
    Outputs: y (2, 3), n (2, 3), gap (2,), the capsule's features (2,) (vertex 0, vertex 1).
    """
    n = np.asarray(normal, dtype=float)
    p, R = np.asarray(p, dtype=float), np.asarray(R, dtype=float)
    ends = np.stack([p - h * R[:, 2], p + h * R[:, 2]])
    gap = ends @ n - offset - r_c
    y = ends - r_c * n - 0.5 * gap[:, None] * n
    return y, np.tile(n, (2, 1)), gap, feature_id(VERTEX, np.arange(2))


def contact_plane_cylinder(normal, offset, p, R, r, h):
    """Plane {n . x = offset} (A) against a cylinder (B: centre p (3,), rotation R (3, 3), axis
    a = R e_z, radius r, half height h, m).

    For each cap s = 0 (c_0 = p - h a) and s = 1 (c_1 = p + h a): the 8 rim points
    c_s + r (cos phi_k R e_x + sin phi_k R e_y), phi_k = k pi / 4, as vertex 8 s + k, then, where
    u = -n + (n . a) a has |u| > 1e-12, the deepest rim point c_s + r u / |u| as edge s.  Each is a
    point x of B against the plane (``contact_plane_points``).
    Outputs: y (K, 3), n (K, 3), gap (K,), the cylinder's features (K,), K = 16 or 18.
    """
    n = np.asarray(normal, dtype=float)
    p, R = np.asarray(p, dtype=float), np.asarray(R, dtype=float)
    a = R[:, 2]
    phi = np.arange(8) * np.pi / 4
    rim = r * (np.cos(phi)[:, None] * R[:, 0] + np.sin(phi)[:, None] * R[:, 1])
    caps = [p - h * a, p + h * a]
    x = [c_s + rim for c_s in caps]
    features = [feature_id(VERTEX, np.arange(16))]
    u = -n + (n @ a) * a
    if np.linalg.norm(u) > 1e-12:
        x += [np.stack([c_s + r * u / np.linalg.norm(u) for c_s in caps])]
        features += [feature_id(EDGE, np.arange(2))]
    y, n_k, gap = contact_plane_points(n, offset, np.vstack(x))
    return y, n_k, gap, np.concatenate(features)


# --------------------------------------------------------------------------- dispatch
#
# Every pair function takes (shape_A, p_A, R_A, shape_B, p_B, R_B, threshold) with p (3,) the COM
# and R (3, 3) the rotation of each body, and returns its candidates (y (K, 3), n (K, 3) from A
# towards B, gap (K,), feature_a (K,), feature_b (K,)), world frame, m.  A plane is A.

def _world_plane(plane, p, R):
    """World normal R n (3,) and offset offset + (R n) . p of a plane body at (p, R)."""
    n_w = R @ np.asarray(plane["normal"], dtype=float)
    return n_w, float(plane["offset"]) + n_w @ p


def _with_plane_feature(candidates):
    y, n, gap, feature_b = candidates
    return y, n, gap, np.full(len(gap), feature_id(FACE, 0), dtype=np.uint64), feature_b


def _pair_plane_sphere(plane, p_A, R_A, sphere, p_B, R_B, threshold):
    y, n, gap = contact_plane_sphere(*_world_plane(plane, p_A, R_A), p_B, float(sphere["radius"]))
    return _with_plane_feature((y, n, gap, np.array([feature_id(SHAPE, 0)])))


def _pair_plane_box(plane, p_A, R_A, box, p_B, R_B, threshold):
    x = box_corners(box["half_extents"]) @ R_B.T + p_B
    y, n, gap = contact_plane_points(*_world_plane(plane, p_A, R_A), x)
    return _with_plane_feature((y, n, gap, feature_id(VERTEX, np.arange(8))))


def _pair_plane_mesh(plane, p_A, R_A, mesh, p_B, R_B, threshold):
    x = np.asarray(mesh["vertices"], dtype=float) @ R_B.T + p_B
    y, n, gap = contact_plane_points(*_world_plane(plane, p_A, R_A), x)
    return _with_plane_feature((y, n, gap, feature_id(VERTEX, np.arange(len(x)))))


def _pair_plane_capsule(plane, p_A, R_A, capsule, p_B, R_B, threshold):
    return _with_plane_feature(contact_plane_capsule(
        *_world_plane(plane, p_A, R_A), p_B, R_B, float(capsule["radius"]),
        float(capsule["half_length"])))


def _pair_plane_cylinder(plane, p_A, R_A, cylinder, p_B, R_B, threshold):
    return _with_plane_feature(contact_plane_cylinder(
        *_world_plane(plane, p_A, R_A), p_B, R_B, float(cylinder["radius"]),
        float(cylinder["half_height"])))


def _pair_sphere_sphere(sphere_A, p_A, R_A, sphere_B, p_B, R_B, threshold):
    y, n, gap = contact_sphere_sphere(p_A, float(sphere_A["radius"]), p_B, float(sphere_B["radius"]))
    shape = np.array([feature_id(SHAPE, 0)])
    return y, n, gap, shape, shape


def _pair_box_sphere(box, p_A, R_A, sphere, p_B, R_B, threshold):
    y, n, gap = contact_box_sphere(p_A, R_A, box["half_extents"], p_B, float(sphere["radius"]))
    shape = np.array([feature_id(SHAPE, 0)])
    return y, n, gap, shape, shape


def _pair_sphere_box(sphere, p_A, R_A, box, p_B, R_B, threshold):
    y, n, gap = contact_box_sphere(p_B, R_B, box["half_extents"], p_A, float(sphere["radius"]))
    shape = np.array([feature_id(SHAPE, 0)])
    return y, -n, gap, shape, shape


def _pair_capsule_sphere(capsule, p_A, R_A, sphere, p_B, R_B, threshold):
    y, n_cap, gap, feature = contact_sphere_capsule(
        p_B, float(sphere["radius"]), p_A, R_A, float(capsule["radius"]), float(capsule["half_length"]))
    return y, n_cap, gap, feature, np.array([feature_id(SHAPE, 0)])


def _pair_sphere_capsule(sphere, p_A, R_A, capsule, p_B, R_B, threshold):
    y, n_cap, gap, feature = contact_sphere_capsule(
        p_A, float(sphere["radius"]), p_B, R_B, float(capsule["radius"]), float(capsule["half_length"]))
    return y, -n_cap, gap, np.array([feature_id(SHAPE, 0)]), feature


def _pair_box_box(box_A, p_A, R_A, box_B, p_B, R_B, threshold):
    return contact_box_box(p_A, R_A, box_A["half_extents"], p_B, R_B, box_B["half_extents"], threshold)


# (type of A, type of B) -> pair function; a pair missing here has no exact rule in the oracle
PAIRS = {
    ("plane", "sphere"): _pair_plane_sphere,
    ("plane", "box"): _pair_plane_box,
    ("plane", "mesh"): _pair_plane_mesh,
    ("plane", "capsule"): _pair_plane_capsule,
    ("plane", "cylinder"): _pair_plane_cylinder,
    ("sphere", "sphere"): _pair_sphere_sphere,
    ("box", "sphere"): _pair_box_sphere,
    ("sphere", "box"): _pair_sphere_box,
    ("capsule", "sphere"): _pair_capsule_sphere,
    ("sphere", "capsule"): _pair_sphere_capsule,
    ("box", "box"): _pair_box_box,
}

def pair_filter(snapshot):
    """A function (i, j) -> bool: may bodies i and j touch? Both enabled, not both of infinite
    mass (static or kinematic: inv_mass 0), their filter bits matching as in Box2D,
    (group_i & mask_j) and (group_j & mask_i) non-zero (defaults group 1, mask all bits), and the
    pair not in ``snapshot["excluded_pairs"]`` nor held by an unbroken joint of ``snapshot["joints"]``
    without ``collide_connected``, and neither body a sensor (the core finds a sensor's contacts,
    then takes them out of the step's: they are never solved)."""
    bodies = snapshot["bodies"]
    _, inv_mass, _, _ = body_arrays(snapshot)
    _, enabled = motion_flags(snapshot)
    group = [int(b.get("group", 1)) for b in bodies]
    mask = [int(b.get("mask", 0xFFFFFFFF)) for b in bodies]
    excluded = {(min(i, j), max(i, j)) for i, j in snapshot.get("excluded_pairs", ())}
    excluded |= {(min(j["body_a"], j["body_b"]), max(j["body_a"], j["body_b"])) for j in snapshot.get("joints", ())
                 if not j.get("collide_connected", False) and not j.get("broken", False)}
    sensor = [bool(b.get("sensor", False)) for b in bodies]

    def allowed(i, j):
        return bool(enabled[i] and enabled[j] and (inv_mass[i] > 0 or inv_mass[j] > 0) and not sensor[i]
                    and not sensor[j] and group[i] & mask[j] and group[j] & mask[i]
                    and (min(i, j), max(i, j)) not in excluded)
    return allowed


def detect_contacts(snapshot, dt):
    """All contacts of the current state, in the order the PGS sweeps them.

    Pairs (i, j), i < j, lexicographic; static-static pairs and those ``pair_filter`` refuses
    skipped; within a pair the
    manifold's points in (feature_a, feature_b) order.  A candidate
    becomes a contact when gap < contact_margin + s_A + s_B (speculative reach
    ``speculative_reach``; against a plane only the approach counts, ``plane_reach``) that its
    pair can close in this step (``reachable``); the manifold is chosen among those.

    Inputs: snapshot, dt s.
    Output: dict body_a (K,) int64, body_b (K,) int64, point (K, 3) m, normal (K, 3),
            gap (K,) m, feature_a (K,) np.uint64, feature_b (K,) np.uint64, world frame,
            n from A towards B.
    Raises NotImplementedError for a pair with no exact rule here (not in ``PAIRS``) whose
    bounding spheres are within reach.
    """
    bodies = snapshot["bodies"]
    static, _, _, _ = body_arrays(snapshot)
    p = np.asarray(snapshot["position"], dtype=float).reshape(-1, 3)
    R = np.asarray(snapshot["rotation"], dtype=float).reshape(-1, 3, 3)
    margin = float((snapshot.get("settings") or {}).get("contact_margin", DEFAULT_CONTACT_MARGIN))
    s = speculative_reach(snapshot, dt)
    allowed = pair_filter(snapshot)

    out = {key: [] for key in ("body_a", "body_b", "point", "normal", "gap", "feature_a", "feature_b")}
    N = len(bodies)
    for i in range(N):
        for j in range(i + 1, N):
            if (static[i] and static[j]) or not allowed(i, j):
                continue

            # choose A and B: a plane is always A, otherwise the lower index
            a, b = i, j
            if bodies[j]["shape"]["type"] == "plane" and bodies[i]["shape"]["type"] != "plane":
                a, b = j, i
            shape_a, shape_b = bodies[a]["shape"], bodies[b]["shape"]
            kinds = (shape_a["type"], shape_b["type"])

            # the threshold: margin + reach (towards a plane only the approach counts)
            if kinds[0] == "plane" and kinds[1] != "plane":
                n_w, _ = _world_plane(shape_a, p[a], R[a])
                threshold = margin + plane_reach(snapshot, b, n_w, dt)
            else:
                threshold = margin + s[i] + s[j]

            pair = PAIRS.get(kinds)
            if pair is None:
                # no exact rule: fail loudly unless the bounding spheres cannot touch
                reach = (np.linalg.norm(p[j] - p[i]) - bounding_radius(bodies[i]["shape"])
                         - bounding_radius(bodies[j]["shape"]))
                if reach < threshold:
                    raise NotImplementedError(
                        f"oracle has no exact contact for bodies {i} ({bodies[i]['shape']['type']}) "
                        f"and {j} ({bodies[j]['shape']['type']})")
                continue
            y, n, gap, feature_a, feature_b = pair(shape_a, p[a], R[a], shape_b, p[b], R[b], threshold)

            # the points the pair can close in this step, then its manifold among them: within the
            # threshold, id order, at most 4 points (a far speculative point that the step cannot
            # close never takes the place of one that holds)
            keep = reachable(snapshot, dt, margin, a, b, y, n, gap)
            y, n, gap, feature_a, feature_b = (x[keep] for x in (y, n, gap, feature_a, feature_b))
            # L: the pair's length scale, the sum of its bounded shapes' bounding radii; against a
            # plane the points are ranked by the gaps they close to in the step, else by their gaps
            L = sum(r for r in map(bounding_radius, (shape_a, shape_b)) if np.isfinite(r))
            plane = kinds[0] == "plane"
            ranking = end_gap(snapshot, dt, a, b, y, n, gap) if plane else None
            kick = gravity_kick(snapshot, dt, a, b) if plane else None
            inner = min(float(snapshot["bodies"][x].get("inner_radius", np.inf)) for x in (a, b))
            y, n, gap, feature_a, feature_b = select_manifold(y, n, gap, feature_a, feature_b, threshold, L,
                                                              ranking, kick, inner)
            out["body_a"] += [a] * len(gap)
            out["body_b"] += [b] * len(gap)
            out["point"].append(y)
            out["normal"].append(n)
            out["gap"].append(gap)
            out["feature_a"].append(feature_a)
            out["feature_b"].append(feature_b)

    def joined(parts, empty):
        return np.concatenate(parts) if parts else empty

    return {
        "body_a": np.array(out["body_a"], dtype=np.int64),
        "body_b": np.array(out["body_b"], dtype=np.int64),
        "point": joined(out["point"], np.zeros((0, 3))),
        "normal": joined(out["normal"], np.zeros((0, 3))),
        "gap": joined(out["gap"], np.zeros(0)),
        "feature_a": joined(out["feature_a"], np.zeros(0, dtype=np.uint64)).astype(np.uint64),
        "feature_b": joined(out["feature_b"], np.zeros(0, dtype=np.uint64)).astype(np.uint64),
    }
