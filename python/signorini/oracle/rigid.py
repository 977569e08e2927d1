"""Rigid-body kinematics and the unconstrained update (docs/conventions.md, "Body",
"Jacobian", "One step" items 2 and 4), with the three gyroscopic options of item 2
(``free_rotation``: "midpoint", the default, and "implicit"; "explicit" in ``unconstrained_velocity``).

State layout (the snapshot dict, N bodies):
    position p          (N, 3)     COM, world, m
    rotation R          (N, 3, 3)  world-from-body, x = R X + p
    velocity v          (N, 3)     COM velocity, world, m/s
    angular_velocity w  (N, 3)     world, rad/s
    q_dot               (6,)       (omega, p_dot): angular part first, as in the lecture
"""

import numpy as np

# below this rotation angle theta = |omega| dt, Rodrigues uses its Taylor series
RODRIGUES_SMALL_ANGLE = 1e-4


def skew(x):
    """Cross-product matrix [x]x, so that skew(x) @ y = x cross y.

    Input: x (..., 3).  Output: (..., 3, 3).
    """
    x = np.asarray(x, dtype=float)
    K = np.zeros(x.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2] = -x[..., 2], x[..., 1]
    K[..., 1, 0], K[..., 1, 2] = x[..., 2], -x[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -x[..., 1], x[..., 0]
    return K


def rodrigues(omega, dt):
    """exp([omega dt]x): the rotation by angle theta = |omega| dt about omega.

    Inputs: omega (3,) rad/s, world; dt s.  Output: (3, 3) rotation.
    exp(K) = I + A K + B K^2, K = [omega dt]x, A = sin(theta)/theta, B = (1 - cos(theta))/theta^2;
    for theta < 1e-4: A = 1 - theta^2/6, B = 1/2 - theta^2/24 (conventions).
    """
    omega = np.asarray(omega, dtype=float)
    K = skew(omega * dt)
    theta = np.linalg.norm(omega) * dt
    if theta < RODRIGUES_SMALL_ANGLE:
        A = 1.0 - theta**2 / 6.0
        B = 0.5 - theta**2 / 24.0
    else:
        A = np.sin(theta) / theta
        B = (1.0 - np.cos(theta)) / theta**2
    return np.eye(3) + A * K + B * (K @ K)


def quat_to_matrix(q):
    """Rotation matrix of a quaternion q = (w, x, y, z), (4,).

    A non-unit quaternion is normalised; a zero one is rejected (ValueError).
    Output: (3, 3) world-from-body.
    """
    q = np.asarray(q, dtype=float)
    norm = np.linalg.norm(q)
    if norm == 0.0:
        raise ValueError("zero quaternion has no rotation")
    w, x, y, z = q / norm
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def matrix_to_quat(R):
    """Unit quaternion (w, x, y, z), (4,), of a rotation matrix R (3, 3), with w >= 0.

    Shepperd's method: take the square root of the largest of 1 + tr R, 1 + 2 R_ii - tr R,
    so the division is always by a number >= 1/2.
    """
    R = np.asarray(R, dtype=float)
    tr = np.trace(R)
    candidates = [tr, R[0, 0], R[1, 1], R[2, 2]]
    k = int(np.argmax(candidates))
    if k == 0:
        s = 2.0 * np.sqrt(1.0 + tr)                       # s = 4 w
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif k == 1:
        s = 2.0 * np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])  # s = 4 x
        q = [(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif k == 2:
        s = 2.0 * np.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])  # s = 4 y
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])  # s = 4 z
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s]
    q = np.array(q)
    q /= np.linalg.norm(q)
    return -q if q[0] < 0 else q


def jacobian(p, y):
    """J(y) = [ -[y - p]x , I3 ], (3, 6): maps q_dot = (omega, p_dot) of a body with COM p
    to the world velocity of its point y:  J(y) q_dot = omega x (y - p) + p_dot.

    Inputs: p (3,) COM, world, m; y (3,) point, world, m.  Output (3, 6).
    J(y)^T f = ((y - p) x f, f) is the (torque, force) of a force f applied at y.
    """
    r = np.asarray(y, dtype=float) - np.asarray(p, dtype=float)
    return np.hstack([-skew(r), np.eye(3)])


def world_inertia(R, I_body):
    """I_w = R I_body R^T.  Inputs (..., 3, 3) each; output (..., 3, 3), kg m^2, world."""
    return R @ I_body @ np.swapaxes(R, -1, -2)


def body_arrays(snapshot):
    """Per-body constants as arrays: (static (N,) bool, inv_mass (N,), I_body (N, 3, 3),
    inv_I_body (N, 3, 3)); static bodies have inv_mass 0 and inv_I_body 0."""
    bodies = snapshot["bodies"]
    static = np.array([bool(b["static"]) for b in bodies], dtype=bool)
    inv_mass = np.array([0.0 if b["static"] else float(b["inv_mass"]) for b in bodies])
    I_body = np.array([np.asarray(b["inertia"], dtype=float) for b in bodies]).reshape(-1, 3, 3)
    inv_I_body = np.array([np.zeros((3, 3)) if b["static"] else np.asarray(b["inv_inertia"], dtype=float)
                           for b in bodies]).reshape(-1, 3, 3)
    return static, inv_mass, I_body, inv_I_body


def motion_flags(snapshot):
    """(kinematic (N,) bool, enabled (N,) bool) from the body dicts ("kinematic" default False,
    "enabled" default True). A kinematic body moves with its own velocity only and has inv_mass 0
    and inv_inertia 0 in the snapshot; a disabled body neither moves nor collides."""
    bodies = snapshot["bodies"]
    kinematic = np.array([bool(b.get("kinematic", False)) for b in bodies], dtype=bool)
    enabled = np.array([bool(b.get("enabled", True)) for b in bodies], dtype=bool)
    return kinematic, enabled


def inverse_mass_blocks(snapshot):
    """M^-1 per body, (N, 6, 6): diag(R I_body^-1 R^T, m^-1 I3) in the (omega, p_dot) layout.

    Static bodies get the zero matrix (the notes' infinite mass).
    """
    static, inv_mass, _, inv_I_body = body_arrays(snapshot)
    R = np.asarray(snapshot["rotation"], dtype=float)
    N = len(static)
    M_inv = np.zeros((N, 6, 6))
    M_inv[:, :3, :3] = world_inertia(R, inv_I_body)
    M_inv[:, 3:, 3:] = inv_mass[:, None, None] * np.eye(3)
    return M_inv


# step 2's options for the gyroscopic term w x (I w), and the midpoint rule's Newton limits
GYROSCOPIC_OPTIONS = ("midpoint", "implicit", "explicit")
GYROSCOPIC_DEFAULT = "midpoint"
MIDPOINT_MAX_NEWTON = 10
MIDPOINT_NEWTON_TOLERANCE = 1e-14


def free_rotation(I_body, w, dt, gyroscopic=GYROSCOPIC_DEFAULT):
    """One step dt of the torque-free Euler equation I w_dot + w x (I w) = 0, body frame.

    Inputs: I_body (3, 3) kg m^2, body axes; w (3,) rad/s, body frame (w = R^T omega);
            dt s; gyroscopic "midpoint" or "implicit" (the body-frame options of step 2).
    Output: w' (3,) rad/s, body frame, before the external torque's impulse.

    midpoint: the implicit midpoint rule  F(w') = I (w' - w) + dt m x (I m) = 0,  m = (w + w') / 2,
              by Newton from w' = w with dF/dw' = I + dt/2 ([m]x I - [I m]x), at most 10 iterations,
              stopping once |step|_inf <= 1e-14 |w'|_inf.  It keeps 1/2 w.I w and |I w|; if
              rounding (or an early stop) left E' = 1/2 w'.I w' > E = 1/2 w.I w, w' is scaled by
              sqrt(E / E') (the gyroscopic term does no work).
    implicit: Catto's one Newton step of backward Euler,
              w' = w - (I + dt ([w]x I - [I w]x))^-1 (dt w x (I w)).  Stable, but dissipates.
    """
    I = np.asarray(I_body, dtype=float)
    w = np.asarray(w, dtype=float)
    if gyroscopic == "implicit":
        # one Newton step on I (w' - w) + dt w' x (I w') = 0, from w' = w
        J = I + dt * (skew(w) @ I - skew(I @ w))
        return w - np.linalg.solve(J, dt * np.cross(w, I @ w))
    if gyroscopic != "midpoint":
        raise ValueError(f"free_rotation: gyroscopic must be 'midpoint' or 'implicit', got {gyroscopic!r}")

    # Newton on F(w') = I (w' - w) + dt m x (I m), m the midpoint velocity
    w1 = w.copy()
    for _ in range(MIDPOINT_MAX_NEWTON):
        m = 0.5 * (w + w1)
        F = I @ (w1 - w) + dt * np.cross(m, I @ m)
        dF = I + 0.5 * dt * (skew(m) @ I - skew(I @ m))
        step = np.linalg.solve(dF, F)
        w1 = w1 - step
        if np.max(np.abs(step)) <= MIDPOINT_NEWTON_TOLERANCE * np.max(np.abs(w1)):
            break

    # the gyroscopic term does no work: never leave with more energy than we came with
    E0, E1 = w @ (I @ w), w1 @ (I @ w1)
    if E1 > E0:
        w1 = w1 * np.sqrt(E0 / E1)
    return w1


def unconstrained_velocity(snapshot, dt):
    """Velocities after gravity, external forces and the gyroscopic term, before contacts
    (conventions, "One step" item 2).

    Per dynamic body, world frame, with f = force + step_force and tau = torque + step_torque
    (the one-step keys are optional):
        v* = v + dt (g + f / m)
    and the angular part by ``snapshot["settings"]["gyroscopic"]`` (default "midpoint"):
        midpoint, implicit: in the body frame, w = R^T omega, tau_b = R^T tau,
                            w' = ``free_rotation(I_body, w, dt, gyroscopic)``,
                            w* = w' + dt I_body^-1 tau_b,  omega* = R w*
        explicit:           the lecture's term, world frame,
                            omega* = omega + dt I_w^-1 (tau - omega x (I_w omega)),  I_w = R I_body R^T
                            (I_w omega* = L + dt (tau - omega x L), L = I_w omega; it gains energy)
    Static bodies never move: their v* and omega* are zero. Kinematic and disabled bodies keep
    v and omega (``motion_flags``).

    Inputs: snapshot (see module doc), dt s.
    Outputs: v_star (N, 3) m/s, omega_star (N, 3) rad/s.
    """
    static, inv_mass, I_body, inv_I_body = body_arrays(snapshot)
    gyroscopic = snapshot.get("settings", {}).get("gyroscopic", GYROSCOPIC_DEFAULT)
    if gyroscopic not in GYROSCOPIC_OPTIONS:
        raise ValueError(f"gyroscopic must be one of {GYROSCOPIC_OPTIONS}, got {gyroscopic!r}")
    g = np.asarray(snapshot["gravity"], dtype=float)
    R = np.asarray(snapshot["rotation"], dtype=float).reshape(-1, 3, 3)
    v = np.asarray(snapshot["velocity"], dtype=float).reshape(-1, 3)
    omega = np.asarray(snapshot["angular_velocity"], dtype=float).reshape(-1, 3)
    # the persistent wrench plus the one-step one (apply_force), when the snapshot has it
    f = np.asarray(snapshot["force"], dtype=float).reshape(-1, 3) + np.asarray(
        snapshot.get("step_force", 0.0), dtype=float)
    tau = np.asarray(snapshot["torque"], dtype=float).reshape(-1, 3) + np.asarray(
        snapshot.get("step_torque", 0.0), dtype=float)

    # linear: gravity plus external force
    v_star = v + dt * (g + inv_mass[:, None] * f)

    if gyroscopic == "explicit":
        # angular, world frame: torque minus the gyroscopic term omega x L, with L = I_w omega
        I_w = world_inertia(R, I_body)
        I_w_inv = world_inertia(R, inv_I_body)
        L = np.einsum("nij,nj->ni", I_w, omega)
        omega_star = omega + dt * np.einsum("nij,nj->ni", I_w_inv, tau - np.cross(omega, L))
    else:
        # angular, body frame: the free rotation, then the external torque's impulse
        omega_star = np.zeros_like(omega)
        kinematic, enabled = motion_flags(snapshot)
        for n in np.flatnonzero(~static & ~kinematic & enabled):
            w1 = free_rotation(I_body[n], R[n].T @ omega[n], dt, gyroscopic)
            omega_star[n] = R[n] @ (w1 + dt * (inv_I_body[n] @ (R[n].T @ tau[n])))

    # static bodies never move; kinematic ones keep their velocity (no gravity, no forces), and so
    # do disabled ones (they are frozen)
    v_star[static] = 0.0
    omega_star[static] = 0.0
    kinematic, enabled = motion_flags(snapshot)
    keep = (kinematic | ~enabled) & ~static
    v_star[keep] = v[keep]
    omega_star[keep] = omega[keep]
    return v_star, omega_star


def apply_impulses(snapshot):
    """Pending impulses J (``impulse``, N s) and angular impulses L (``angular_impulse``, N m s about
    the com), world frame, applied at the start of a step to enabled dynamic bodies:
        v += J / m,   omega += I_w^-1 L,   I_w^-1 = R I_body^-1 R^T
    Returns a copy with them applied and zeroed (the snapshot itself when it has none)."""
    if "impulse" not in snapshot and "angular_impulse" not in snapshot:
        return snapshot
    J = np.asarray(snapshot.get("impulse", 0.0), dtype=float) * np.ones((len(snapshot["bodies"]), 3))
    L = np.asarray(snapshot.get("angular_impulse", 0.0), dtype=float) * np.ones_like(J)
    static, inv_mass, _, inv_I_body = body_arrays(snapshot)
    kinematic, enabled = motion_flags(snapshot)
    R = np.asarray(snapshot["rotation"], dtype=float).reshape(-1, 3, 3)
    new = dict(snapshot)
    v = np.array(snapshot["velocity"], dtype=float).reshape(-1, 3)
    omega = np.array(snapshot["angular_velocity"], dtype=float).reshape(-1, 3)
    for n in np.flatnonzero(~static & ~kinematic & enabled):
        if np.any(J[n]) or np.any(L[n]):
            v[n] = v[n] + inv_mass[n] * J[n]
            omega[n] = omega[n] + (R[n] @ inv_I_body[n] @ R[n].T) @ L[n]
    new["velocity"], new["angular_velocity"] = v, omega
    new["impulse"], new["angular_impulse"] = np.zeros_like(J), np.zeros_like(L)
    return new


def integrate(snapshot, velocity, angular_velocity, dt):
    """Positions and rotations after one step with the new velocities (conventions, step 4).

        R <- exp([omega]x dt) R            (Rodrigues)
        R <- 1.5 R - 0.5 R R^T R           (one polar Newton step, keeps R orthonormal)
        p <- p + dt v
    Static and disabled bodies keep their position and rotation.

    Inputs: snapshot, velocity (N, 3) m/s, angular_velocity (N, 3) rad/s (world), dt s.
    Outputs: position (N, 3) m, rotation (N, 3, 3) world-from-body.
    """
    static = np.array([bool(b["static"]) for b in snapshot["bodies"]], dtype=bool)
    static = static | ~motion_flags(snapshot)[1]
    p = np.array(snapshot["position"], dtype=float).reshape(-1, 3)
    R = np.array(snapshot["rotation"], dtype=float).reshape(-1, 3, 3)
    v = np.asarray(velocity, dtype=float).reshape(-1, 3)
    omega = np.asarray(angular_velocity, dtype=float).reshape(-1, 3)
    for n in np.flatnonzero(~static):
        R_n = rodrigues(omega[n], dt) @ R[n]
        R[n] = 1.5 * R_n - 0.5 * R_n @ R_n.T @ R_n
        p[n] = p[n] + dt * v[n]
    return p, R
