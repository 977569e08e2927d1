"""Joint rows (docs/conventions.md, "Joints") for the PGS, in plain NumPy, re-derived from the
conventions: each joint gives blocks of rows, Jacobian pairs J_A = (ang_a, lin_a), J_B = (ang_b,
lin_b) in the lecture's (omega, p_dot) layout, solved block by block after each sweep of the
contact rows, then a position pass on the pseudo-velocities, then the forces on B.

A joint (``snapshot["joints"]``, a list of dicts, as ``World.snapshot()`` writes them):
    kind        "Revolute" | "Prismatic" | "Spherical" | "Fixed" | "Distance"
    body_a, body_b      indices
    anchor_a, anchor_b  (3,) m, lever arms from each body's centre of mass in its own frame
    axis_a, axis_b, ref_a, ref_b  (3,) unit, each body's frame (R_A axis_a = R_B axis_b at creation)
    R_rel       (3, 3) R_A^T R_B at creation
    has_limits, lower, upper    (rad or m);  motor, motor_speed, motor_max_force (and, for a
    spring-damper motor, motor_position, motor_stiffness, motor_damping); friction (N m or N, 0: none); effort (N m or N)
    min_length, max_length      (m; Distance)
    alpha       (9,) the rows' forces of the last substep by slot (N or N m): the warm start
Slots: motor 0, lower 1, upper 2, linear 3..5, angular 6..8, friction 9, effort 10.
"""
import numpy as np

from .rigid import rodrigues

SLOT_MOTOR, SLOT_LOWER, SLOT_UPPER, SLOT_LINEAR, SLOT_ANGULAR, SLOT_FRICTION, SLOT_EFFORT = 0, 1, 2, 3, 6, 9, 10
SLOTS = 9
EQUALITY, LIMIT, MOTOR = "equality", "limit", "motor"


def tangent_basis(n):
    """The contacts' basis: k the first axis whose |n_k| is within 1e-9 of the smallest,
    t1 = unit(n x e_k), t2 = n x t1."""
    a = np.abs(n)
    k = int(np.argmax(a <= a.min() + 1e-9))
    t1 = np.cross(n, np.eye(3)[k])
    t1 = t1 / np.linalg.norm(t1)
    return t1, np.cross(n, t1)


def axial(E):
    """The axial vector of the skew part of E (sin of the angle along the axis for a rotation)."""
    return 0.5 * np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])


def hinge_angle(joint, RA, RB):
    """B's turn about the axis relative to A (rad, in (-pi, pi])."""
    axis = RA @ joint["axis_a"]
    u_a, u_b = RA @ joint["ref_a"], RB @ joint["ref_b"]
    return float(np.arctan2(axis @ np.cross(u_a, u_b), u_a @ u_b))


def _block(kind, n, joint, slot):
    return {"kind": kind, "n": n, "a": joint["body_a"], "b": joint["body_b"], "joint": joint, "slot": slot,
            "ang_a": np.zeros((n, 3)), "lin_a": np.zeros((n, 3)), "ang_b": np.zeros((n, 3)),
            "lin_b": np.zeros((n, 3)), "C": np.zeros(n), "target": 0.0, "gamma": 0.0, "lo": 0.0,
            "hi": 0.0}


def _linear(b, k, e, ra_lin, r_b):
    """Row k along e: J_A = (-(ra_lin x e), -e), J_B = (r_b x e, e)."""
    b["ang_a"][k], b["lin_a"][k] = -np.cross(ra_lin, e), -e
    b["ang_b"][k], b["lin_b"][k] = np.cross(r_b, e), e


def _angular(b, k, e):
    """Row k about e: J_A = (-e, 0), J_B = (e, 0)."""
    b["ang_a"][k], b["ang_b"][k] = -e, e


def _drive(m, joint, x, h, angle):
    """The motor row m of a joint at coordinate x (rad or m) over a substep of h: a rigid velocity
    motor (gamma 0, target the speed), or the spring-damper F = k (position - x_new) + c (speed -
    x_dot_new) with x_new = x + h x_dot_new, so that x_dot_new = target - gamma F:
    gamma = 1 / (k h + c), target = gamma (k (position - x) + c speed), a hinge's error taken the
    short way round (in [-pi, pi])."""
    k, c = joint.get("motor_stiffness", 0.0), joint.get("motor_damping", 0.0)
    m["lo"], m["hi"] = -joint["motor_max_force"], joint["motor_max_force"]
    if k == 0.0 and c == 0.0:
        m["target"], m["gamma"] = joint["motor_speed"], 0.0
        return
    error = joint.get("motor_position", 0.0) - x
    if angle:  # the core's std::remainder: error - n 2 pi, n the nearest integer (ties to even)
        error = error - 2.0 * np.pi * float(np.rint(error / (2.0 * np.pi)))
    m["gamma"] = 1.0 / (k * h + c)
    m["target"] = m["gamma"] * (k * error + c * joint["motor_speed"])


def _effort(joint, row):
    """The effort row of a joint: bounds lo = hi = effort, so every sweep leaves alpha = effort, and
    the joint's alpha holds it now (applied once per substep by the warm start, or by the first
    sweep without one). row(block) fills its Jacobian."""
    e = _block(MOTOR, 1, joint, SLOT_EFFORT)
    row(e)
    e["lo"] = e["hi"] = joint["effort"]
    joint["alpha"][SLOT_EFFORT] = joint["effort"]
    return e


def build_blocks(joint, pA, RA, pB, RB, h):
    """The blocks of one joint with its bodies at (pA, RA), (pB, RB), in the core's order: motor,
    friction, effort, lower limit, upper limit, then the equality blocks (h: the substep, for a
    spring-damper motor); friction is a motor row of speed 0 bounded by the joint's friction."""
    r_a, r_b = RA @ joint["anchor_a"], RB @ joint["anchor_b"]
    d = (pB + r_b) - (pA + r_a)
    kind, out = joint["kind"], []
    if kind == "Revolute":
        axis = RA @ joint["axis_a"]
        theta = hinge_angle(joint, RA, RB)
        if joint["motor"]:
            m = _block(MOTOR, 1, joint, SLOT_MOTOR)
            _angular(m, 0, axis)
            _drive(m, joint, theta, h, True)
            out.append(m)
        if joint.get("friction", 0.0) > 0.0:
            f = _block(MOTOR, 1, joint, SLOT_FRICTION)
            _angular(f, 0, axis)
            f["lo"], f["hi"] = -joint["friction"], joint["friction"]
            out.append(f)
        if joint.get("effort", 0.0) != 0.0:
            out.append(_effort(joint, lambda e: _angular(e, 0, axis)))
        if joint["has_limits"]:
            lo, hi = _block(LIMIT, 1, joint, SLOT_LOWER), _block(LIMIT, 1, joint, SLOT_UPPER)
            _angular(lo, 0, axis)
            lo["C"][0] = theta - joint["lower"]
            _angular(hi, 0, -axis)
            hi["C"][0] = joint["upper"] - theta
            out += [lo, hi]
        p = _block(EQUALITY, 3, joint, SLOT_LINEAR)
        for k in range(3):
            _linear(p, k, np.eye(3)[k], r_a, r_b)
        p["C"] = d.copy()
        w = _block(EQUALITY, 2, joint, SLOT_ANGULAR)
        t1, t2 = tangent_basis(axis)
        tilt = np.cross(axis, RB @ joint["axis_b"])
        _angular(w, 0, t1)
        _angular(w, 1, t2)
        w["C"] = np.array([t1 @ tilt, t2 @ tilt])
        out += [p, w]
    elif kind == "Prismatic":
        axis = RA @ joint["axis_a"]
        ra_lin = r_a + d
        s = axis @ d
        if joint["motor"]:
            m = _block(MOTOR, 1, joint, SLOT_MOTOR)
            _linear(m, 0, axis, ra_lin, r_b)
            _drive(m, joint, s, h, False)
            out.append(m)
        if joint.get("friction", 0.0) > 0.0:
            f = _block(MOTOR, 1, joint, SLOT_FRICTION)
            _linear(f, 0, axis, ra_lin, r_b)
            f["lo"], f["hi"] = -joint["friction"], joint["friction"]
            out.append(f)
        if joint.get("effort", 0.0) != 0.0:
            out.append(_effort(joint, lambda e: _linear(e, 0, axis, ra_lin, r_b)))
        if joint["has_limits"]:
            lo, hi = _block(LIMIT, 1, joint, SLOT_LOWER), _block(LIMIT, 1, joint, SLOT_UPPER)
            _linear(lo, 0, axis, ra_lin, r_b)
            lo["C"][0] = s - joint["lower"]
            _linear(hi, 0, -axis, ra_lin, r_b)
            hi["C"][0] = joint["upper"] - s
            out += [lo, hi]
        t1, t2 = tangent_basis(axis)
        p = _block(EQUALITY, 2, joint, SLOT_LINEAR)
        _linear(p, 0, t1, ra_lin, r_b)
        _linear(p, 1, t2, ra_lin, r_b)
        p["C"] = np.array([t1 @ d, t2 @ d])
        w = _block(EQUALITY, 3, joint, SLOT_ANGULAR)
        for k in range(3):
            _angular(w, k, np.eye(3)[k])
        w["C"] = axial(RB @ joint["R_rel"].T @ RA.T)
        out += [p, w]
    elif kind in ("Spherical", "Fixed"):
        p = _block(EQUALITY, 3, joint, SLOT_LINEAR)
        for k in range(3):
            _linear(p, k, np.eye(3)[k], r_a, r_b)
        p["C"] = d.copy()
        out.append(p)
        if kind == "Fixed":
            w = _block(EQUALITY, 3, joint, SLOT_ANGULAR)
            for k in range(3):
                _angular(w, k, np.eye(3)[k])
            w["C"] = axial(RB @ joint["R_rel"].T @ RA.T)
            out.append(w)
    elif kind == "Distance":
        length = float(np.linalg.norm(d))
        u = d / length if length > 1e-12 else np.array([1.0, 0.0, 0.0])
        if joint["min_length"] == joint["max_length"]:
            e = _block(EQUALITY, 1, joint, SLOT_LOWER)
            _linear(e, 0, u, r_a, r_b)
            e["C"][0] = length - joint["min_length"]
            out.append(e)
        else:
            if joint["min_length"] > 0.0:
                lo = _block(LIMIT, 1, joint, SLOT_LOWER)
                _linear(lo, 0, u, r_a, r_b)
                lo["C"][0] = length - joint["min_length"]
                out.append(lo)
            if np.isfinite(joint["max_length"]):
                hi = _block(LIMIT, 1, joint, SLOT_UPPER)
                _linear(hi, 0, -u, r_a, r_b)
                hi["C"][0] = joint["max_length"] - length
                out.append(hi)
    else:
        raise ValueError(f"unknown joint kind {kind!r}")
    return out


def moving(snapshot):
    """(N,) bool: dynamic, enabled and awake bodies (the others have infinite mass for a joint)."""
    bodies = snapshot["bodies"]
    awake = snapshot.get("awake")
    return np.array([not b["static"] and not b.get("kinematic", False) and b.get("enabled", True)
                     and (awake is None or bool(awake[i])) for i, b in enumerate(bodies)], dtype=bool)


def prepare_joints(snapshot, joints, q_dot, h):
    """Every joint's blocks at the snapshot's poses, with W, K = J W J^T, K^-1 and the drift
    h/2 (dJ/dt) q_dot = J(poses after h/2 at q_dot) q_dot - J q_dot (0 for a motor).

    Inputs: snapshot (position, rotation, bodies), joints (list of dicts, alpha read and written
            by the later stages), q_dot (N, 6) the velocities before the joints' solve, h s.
    Output: list of blocks (dicts), in joint order.
    """
    P = np.asarray(snapshot["position"], dtype=float)
    R = np.asarray(snapshot["rotation"], dtype=float)
    moves = moving(snapshot)
    blocks = []
    for joint in joints:
        a, b = joint["body_a"], joint["body_b"]
        if (not moves[a] and not moves[b]) or joint.get("broken", False):
            continue
        here = build_blocks(joint, P[a], R[a], P[b], R[b], h)
        half = 0.5 * h
        there = build_blocks(joint, P[a] + half * q_dot[a, 3:], rodrigues(q_dot[a, :3], half) @ R[a],
                             P[b] + half * q_dot[b, 3:], rodrigues(q_dot[b, :3], half) @ R[b], h)
        for blk, later in zip(here, there):
            W_ang = {x: (h * R[i] @ np.asarray(snapshot["bodies"][i]["inv_inertia"], float) @ R[i].T if moves[i]
                         else np.zeros((3, 3))) for x, i in (("a", a), ("b", b))}
            blk["w_ang_a"] = blk["ang_a"] @ W_ang["a"].T
            blk["w_ang_b"] = blk["ang_b"] @ W_ang["b"].T
            blk["w_lin_a"] = h * float(snapshot["bodies"][a]["inv_mass"]) if moves[a] else 0.0
            blk["w_lin_b"] = h * float(snapshot["bodies"][b]["inv_mass"]) if moves[b] else 0.0
            blk["a_moves"], blk["b_moves"] = bool(moves[a]), bool(moves[b])
            K = (blk["ang_a"] @ blk["w_ang_a"].T + blk["w_lin_a"] * blk["lin_a"] @ blk["lin_a"].T
                 + blk["ang_b"] @ blk["w_ang_b"].T + blk["w_lin_b"] * blk["lin_b"] @ blk["lin_b"].T)
            blk["K"] = K
            blk["K_inv"] = np.linalg.inv(K) if np.linalg.det(K) > 0.0 else np.zeros_like(K)
            if blk["kind"] == MOTOR:
                blk["drift"] = np.zeros(blk["n"])
            else:
                blk["drift"] = ((later["ang_a"] - blk["ang_a"]) @ q_dot[a, :3] + (later["lin_a"] - blk["lin_a"]) @ q_dot[a, 3:]
                                + (later["ang_b"] - blk["ang_b"]) @ q_dot[b, :3] + (later["lin_b"] - blk["lin_b"]) @ q_dot[b, 3:])
        blocks += here
    return blocks


def _alpha(blk):
    return blk["joint"]["alpha"][blk["slot"]:blk["slot"] + blk["n"]]


def _velocity(blk, q):
    a, b = blk["a"], blk["b"]
    return blk["ang_a"] @ q[a, :3] + blk["lin_a"] @ q[a, 3:] + blk["ang_b"] @ q[b, :3] + blk["lin_b"] @ q[b, 3:]


def _apply(blk, d, q):
    """q += W J^T d for the block's force changes d (n,)."""
    a, b = blk["a"], blk["b"]
    if blk["a_moves"]:
        q[a, :3] += d @ blk["w_ang_a"]
        q[a, 3:] += blk["w_lin_a"] * (d @ blk["lin_a"])
    if blk["b_moves"]:
        q[b, :3] += d @ blk["w_ang_b"]
        q[b, 3:] += blk["w_lin_b"] * (d @ blk["lin_b"])


def warm_start_joints(blocks, q_dot):
    """Applies every block's alpha (the joints' forces of the last substep) to q_dot (N, 6)."""
    for blk in blocks:
        _apply(blk, np.array(_alpha(blk)), q_dot)


def sweep_joints(blocks, q_dot, h):
    """One Gauss-Seidel sweep over the blocks (the PGS's iterate), q_dot (N, 6) in place:
        equality  d_alpha = -K^-1 (J q_dot + drift)
        limit     alpha <- max(alpha - (J q_dot + drift + max(C, 0) / h) / K, 0)
        motor     alpha <- clamp(alpha - (J q_dot - target) / K, -max_force, max_force) (rigid), or
                  clamp(alpha - (J q_dot + gamma alpha - target) / (K + gamma), ...) (a spring-damper)
    Returns the largest |K d_alpha| (m/s or rad/s)."""
    change = 0.0
    for blk in blocks:
        u = _velocity(blk, q_dot) + blk["drift"]
        alpha = blk["joint"]["alpha"]
        s = blk["slot"]
        if blk["kind"] == EQUALITY:
            d = -(blk["K_inv"] @ u)
            alpha[s:s + blk["n"]] += d
        else:
            old, k_inv = alpha[s], blk["K_inv"][0, 0]
            if blk["kind"] == LIMIT:
                C = blk["C"][0]
                new = old - k_inv * (u[0] + C / h) if C > 0.0 else old - k_inv * u[0]
                new = max(new, 0.0)
            else:
                g = blk["gamma"]
                new = (old - k_inv * (u[0] - blk["target"]) if g == 0.0
                       else old - (u[0] + g * old - blk["target"]) / (blk["K"][0, 0] + g))
                new = min(max(new, blk["lo"]), blk["hi"])
            d = np.array([new - old])
            alpha[s] = new
        _apply(blk, d, q_dot)
        change = max(change, float(np.max(np.abs(blk["K"] @ d))))
    return change


def joint_position_pass(blocks, q_p, h, erp, tolerance, max_iterations):
    """The joints' part of the position pass, after the contacts' (q_p (N, 6) in place): per block
    the target J q_p = -erp C / h (every equality block, those without an error holding; limit rows
    only while C < 0), pseudo-forces beta (>= 0 for a limit), swept to the tolerance; nothing when
    no block has an error. Returns the sweeps used."""
    def active(blk):  # every equality block takes part (holding where it has no error); a limit while violated
        return blk["kind"] == EQUALITY or (blk["kind"] == LIMIT and blk["C"][0] < 0.0)

    def error(blk):
        return np.any(blk["C"] != 0.0) if blk["kind"] == EQUALITY else blk["kind"] == LIMIT and blk["C"][0] < 0.0

    if not any(error(blk) for blk in blocks):
        return 0
    beta = [np.zeros(blk["n"]) for blk in blocks]
    sweeps, converged = 0, False
    while not converged and sweeps < max_iterations:
        sweeps += 1
        change = 0.0
        for i, blk in enumerate(blocks):
            if not active(blk):
                continue
            u = _velocity(blk, q_p) + (erp / h) * blk["C"]
            if blk["kind"] == EQUALITY:
                d = -(blk["K_inv"] @ u)
                beta[i] += d
            else:
                new = max(beta[i][0] - blk["K_inv"][0, 0] * u[0], 0.0)
                d = np.array([new - beta[i][0]])
                beta[i][0] = new
            _apply(blk, d, q_p)
            change = max(change, float(np.max(np.abs(blk["K"] @ d))))
        converged = tolerance > 0.0 and change <= tolerance
    return sweeps


def store_joints(snapshot, joints, blocks):
    """Each joint's force on B (N) and torque about B's anchor (N m), world, (J, 3) each:
    F = sum alpha_r lin_b,r, tau = sum alpha_r ang_b,r - (R_B anchor_b) x F."""
    R = np.asarray(snapshot["rotation"], dtype=float)
    force, torque = np.zeros((len(joints), 3)), np.zeros((len(joints), 3))
    index = {id(j): k for k, j in enumerate(joints)}
    for blk in blocks:
        k = index[id(blk["joint"])]
        a = np.array(_alpha(blk))
        force[k] += a @ blk["lin_b"]
        torque[k] += a @ blk["ang_b"]
    for k, joint in enumerate(joints):
        torque[k] -= np.cross(R[joint["body_b"]] @ joint["anchor_b"], force[k])
    return force, torque
