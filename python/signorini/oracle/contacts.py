"""Exact contact detection for the pairs the oracle knows (docs/conventions.md, "Contacts").

A contact is (body_a, body_b, point y, normal n, gap), world frame:
    n    unit, points from A towards B
    gap  signed distance along n, m (negative = overlap)
    y    midpoint of the witness points, y = (w_A + w_B) / 2 with w_B - w_A = gap n

Dispatch table (plane is always A; other pairs have A = lower body index):
    plane  - sphere : one contact, the sphere's lowest point
    plane  - box    : the 8 corners, corner order k = 0..7
    plane  - mesh   : every vertex, vertex order
    sphere - sphere : one contact along the line of centres
    box    - sphere : one contact, the sphere centre clamped into the box (nearest face if inside)
    anything else   : NotImplementedError when the bounding spheres are within reach
                      (the core uses FCL there; the oracle does not), skipped when not.
"""

import numpy as np

from .rigid import body_arrays


def bounding_radius(shape):
    """rho: largest distance of the shape's surface from its COM, m.

    sphere r, box |(a, b, c)|, mesh max |vertex| (body frame, COM at origin); plane inf.
    """
    kind = shape["type"]
    if kind == "sphere":
        return float(shape["radius"])
    if kind == "box":
        return float(np.linalg.norm(np.asarray(shape["half_extents"], dtype=float)))
    if kind == "mesh":
        return float(np.max(np.linalg.norm(np.asarray(shape["vertices"], dtype=float), axis=1)))
    if kind == "plane":
        return np.inf
    raise ValueError(f"unknown shape type {kind!r}")


def speculative_reach(snapshot, dt):
    """s_b = dt (|v_b| + dt |g| + |omega_b| rho_b) per dynamic body, 0 for static ones.

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
            s[b] = dt * (np.linalg.norm(v[b]) + dt * g + np.linalg.norm(omega[b]) * rho)
    return s


def plane_reach(snapshot, b, n, dt):
    """Reach of body b towards a plane of world normal n (3,): only the approach counts,
    dt (max(0, -n . v_b) + dt max(0, -n . g) + |omega_b| rho_b); 0 for a static body. m."""
    body = snapshot["bodies"][b]
    if body["static"]:
        return 0.0
    v = np.asarray(snapshot["velocity"], dtype=float).reshape(-1, 3)[b]
    omega = np.asarray(snapshot["angular_velocity"], dtype=float).reshape(-1, 3)[b]
    g = np.asarray(snapshot["gravity"], dtype=float)
    return dt * (max(0.0, -float(n @ v)) + dt * max(0.0, -float(n @ g))
                 + np.linalg.norm(omega) * bounding_radius(body["shape"]))


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


def _plane_against(plane, shape, p, R):
    """Candidate features of a plane (A) against a body (B) with COM p (3,), rotation R (3, 3).

    Returns (y, n, gap) for every candidate feature in the conventions' order, or None when
    the pair is not handled (plane against plane).
    """
    normal, offset = plane["normal"], float(plane["offset"])
    kind = shape["type"]
    if kind == "sphere":
        return contact_plane_sphere(normal, offset, p, float(shape["radius"]))
    if kind == "box":
        X = box_corners(shape["half_extents"])
        return contact_plane_points(normal, offset, X @ R.T + p)
    if kind == "mesh":
        X = np.asarray(shape["vertices"], dtype=float)
        return contact_plane_points(normal, offset, X @ R.T + p)
    return None


def detect_contacts(snapshot, dt):
    """All contacts of the current state, in the order the PGS sweeps them.

    Pairs (i, j), i < j, lexicographic; static-static pairs skipped; within a pair the
    features in the conventions' order.  A candidate becomes a contact when
    gap < contact_margin + s_A + s_B (speculative reach ``speculative_reach``).

    Inputs: snapshot, dt s.
    Output: dict body_a (K,) int64, body_b (K,) int64, point (K, 3) m, normal (K, 3),
            gap (K,) m, world frame, n from A towards B.
    Raises NotImplementedError for a pair with no exact rule here (box-box, box-sphere,
    anything-mesh other than plane-mesh) whose bounding spheres are within reach.
    """
    bodies = snapshot["bodies"]
    static, _, _, _ = body_arrays(snapshot)
    p = np.asarray(snapshot["position"], dtype=float).reshape(-1, 3)
    R = np.asarray(snapshot["rotation"], dtype=float).reshape(-1, 3, 3)
    margin = float(snapshot["settings"]["contact_margin"])
    s = speculative_reach(snapshot, dt)

    body_a, body_b, point, normal, gap = [], [], [], [], []
    N = len(bodies)
    for i in range(N):
        for j in range(i + 1, N):
            if static[i] and static[j]:
                continue
            shape_i, shape_j = bodies[i]["shape"], bodies[j]["shape"]
            kinds = (shape_i["type"], shape_j["type"])
            threshold = margin + s[i] + s[j]

            # choose A and B: a plane is always A, otherwise the lower index
            candidates = None
            a, b = i, j
            if kinds[1] == "plane" and kinds[0] != "plane":
                a, b = j, i
            if kinds[0] == "plane" or kinds[1] == "plane":
                if kinds[0] != kinds[1]:
                    # the plane in world coordinates; the body's reach only towards it
                    plane = bodies[a]["shape"]
                    n_w = R[a] @ np.asarray(plane["normal"], dtype=float)
                    world_plane = {"normal": n_w, "offset": float(plane["offset"]) + n_w @ p[a]}
                    candidates = _plane_against(world_plane, bodies[b]["shape"], p[b], R[b])
                    threshold = margin + plane_reach(snapshot, b, n_w, dt)
            elif kinds == ("sphere", "sphere"):
                candidates = contact_sphere_sphere(p[i], float(shape_i["radius"]),
                                                   p[j], float(shape_j["radius"]))
            elif kinds == ("box", "sphere"):
                candidates = contact_box_sphere(p[i], R[i], shape_i["half_extents"], p[j],
                                                float(shape_j["radius"]))
            elif kinds == ("sphere", "box"):
                y, n, d = contact_box_sphere(p[j], R[j], shape_j["half_extents"], p[i],
                                             float(shape_i["radius"]))
                candidates = (y, -n, d)

            if candidates is None:
                # no exact rule: fail loudly unless the bounding spheres cannot touch
                reach = (np.linalg.norm(p[j] - p[i]) - bounding_radius(shape_i)
                         - bounding_radius(shape_j))
                if reach < threshold:
                    raise NotImplementedError(
                        f"oracle has no exact contact for bodies {i} ({kinds[0]}) and "
                        f"{j} ({kinds[1]})")
                continue

            # keep the features within the margin plus the speculative reach
            y, n, d = candidates
            keep = d < threshold
            k = int(keep.sum())
            body_a += [a] * k
            body_b += [b] * k
            point.append(y[keep])
            normal.append(n[keep])
            gap.append(d[keep])

    return {
        "body_a": np.array(body_a, dtype=np.int64),
        "body_b": np.array(body_b, dtype=np.int64),
        "point": np.concatenate(point).reshape(-1, 3) if point else np.zeros((0, 3)),
        "normal": np.concatenate(normal).reshape(-1, 3) if normal else np.zeros((0, 3)),
        "gap": np.concatenate(gap) if gap else np.zeros(0),
    }
