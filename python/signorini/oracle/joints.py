"""Joint rows (docs/conventions.md, "Joints") for the PGS, in plain NumPy, re-derived from the
conventions: each joint gives blocks of rows, Jacobian pairs J_A = (ang_a, lin_a), J_B = (ang_b,
lin_b) in the lecture's (omega, p_dot) layout, solved joint by joint after each sweep of the
contact rows, then a position pass on the pseudo-velocities, then the forces on B.

A joint is solved as one group: its equality rows E together, d alpha_E = -K_EE^-1 (J_E q_dot +
bias_E), then each bounded row l (limits, motor, friction, effort: all along the joint's free
direction) with its effective K_l - K_lE K_EE^-1 K_El, the equality rows following it by
d alpha_E = -K_EE^-1 K_El d alpha_l so that they stay satisfied. (A limit solved alone would see a
far-out load's spin about its own centre only, m L^2 / I times too light.) When K_EE is not
positive definite (Cholesky fails) the joint's blocks are solved one by one.

A joint (``snapshot["joints"]``, a list of dicts, as ``World.snapshot()`` writes them):
    kind        "Revolute" | "Prismatic" | "Spherical" | "Fixed" | "Distance"
    body_a, body_b      indices
    anchor_a, anchor_b  (3,) m, lever arms from each body's centre of mass in its own frame
    axis_a, axis_b, ref_a, ref_b  (3,) unit, each body's frame (R_A axis_a = R_B axis_b at creation)
    R_rel       (3, 3) R_A^T R_B at creation
    has_limits, lower, upper    (rad or m; a Spherical joint's cone is upper);  has_twist,
    twist_lower, twist_upper    (rad; Spherical);  motor, motor_speed, motor_max_force (and, for a
    spring-damper motor, motor_position, motor_stiffness, motor_damping); friction (N m or N, 0: none); effort (N m or N)
    min_length, max_length      (m; Distance)
    alpha       (11,) the rows' forces of the last substep by slot (N or N m): the warm start
Slots: motor 0, lower 1, upper 2 (a ball joint's cone), linear 3..5, angular 6..8 (a ball joint's
twist lower and upper limits at 6 and 7), friction 9, effort 10.

The soft step (``soft.soft_step``) solves the same blocks with two more sweep modes
(``sweep_joints``): SOFT_BIASED after each biased contact sweep, a spring-damper of the settings'
joint_hertz (capped at a quarter of the substep rate) and joint_damping_ratio on the position error C,
    equality rows  d_alpha = -mass_scale K^-1 (J q_dot + drift + bias_rate C) - impulse_scale alpha
    limit, C <= 0  alpha <- max(alpha - mass_scale (J q_dot + drift + bias_rate C) / K
                                - impulse_scale alpha, 0)
(a limit with C > 0 speculative as in the PGS, motors as in the PGS; a coupled joint as one:
its equality rows and its limits with C <= 0 take mass_scale times the rigid group's answer to the
velocity without their forces, ``_solve_group_soft``), and SOFT_RELAX after each relax contact sweep: the PGS's rigid rule on
the same blocks, drift included. Its drift is predicted from the velocities before the joints'
solve (the PGS's: after its first sweep), and not for a joint whose bodies turn more than
DRIFT_TURN in h / 2.
"""
import numpy as np

from .rigid import rodrigues

SLOT_MOTOR, SLOT_LOWER, SLOT_UPPER, SLOT_LINEAR, SLOT_ANGULAR, SLOT_FRICTION, SLOT_EFFORT = 0, 1, 2, 3, 6, 9, 10
SLOT_TWIST_LOWER, SLOT_TWIST_UPPER = 6, 7  # a ball joint's twist limits, in angular slots it has no rows for
SLOTS = 9
EQUALITY, LIMIT, MOTOR = "equality", "limit", "motor"
# sweep modes: the PGS's iterate, the soft step's biased sweep (the joint spring on C) and its relax
# sweep (rigid)
HARD, SOFT_BIASED, SOFT_RELAX = "hard", "soft biased", "soft relax"
# the soft step predicts a joint's drift only while its bodies turn at most this much (rad) in h / 2
DRIFT_TURN = 0.1


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


def twist_angle(joint, RA, RB):
    """A ball joint's twist psi (rad, in (-pi, pi]) and its rate's direction t, or None where the
    axes point apart (1 + a_A . a_B <= 1e-9). With a_X = R_X axis_X, the swing S is the least turn
    taking a_B onto a_A, S x = (a_B . a_A) x + c x x + c (c . x) / (1 + a_B . a_A), c = a_B x a_A;
    psi is the angle from R_A ref_a to S R_B ref_b about a_A, and dpsi/dt = t . (w_B - w_A)
    exactly, t = (a_A + a_B) / (1 + a_A . a_B)."""
    a_A, a_B = RA @ joint["axis_a"], RB @ joint["axis_b"]
    cos_swing = a_B @ a_A
    if not 1.0 + cos_swing > 1e-9:
        return None
    c = np.cross(a_B, a_A)
    u_a, u_b = RA @ joint["ref_a"], RB @ joint["ref_b"]
    swung = cos_swing * u_b + np.cross(c, u_b) + ((c @ u_b) / (1.0 + cos_swing)) * c
    psi = float(np.arctan2(a_A @ np.cross(u_a, swung), u_a @ swung))
    return psi, (a_A + a_B) / (1.0 + cos_swing)


def turning_with_a(joint, RA):
    """The directions across a hinge's or slider's axis: the contacts' basis of A's axis in A's frame,
    turned with A (R_A t_k), so that they never jump as a basis chosen in the world would where the
    axis's smallest component changes."""
    u1, u2 = tangent_basis(np.asarray(joint["axis_a"], dtype=float))
    return RA @ u1, RA @ u2


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
        t1, t2 = turning_with_a(joint, RA)
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
        t1, t2 = turning_with_a(joint, RA)
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
        if kind == "Spherical" and joint.get("has_limits", False):
            # the cone: phi = angle(a_A, a_B) <= upper; C = upper - phi, dphi/dt = n . (w_B - w_A)
            a_A, a_B = RA @ joint["axis_a"], RB @ joint["axis_b"]
            c = np.cross(a_A, a_B)
            s = np.linalg.norm(c)
            if s > 1e-12:
                n = c / s
            else:  # the axes meet: any normal of a_A (C is the whole cone, far from binding)
                k = int(np.argmin(np.abs(a_A)))
                n = np.cross(a_A, np.eye(3)[k])
                n /= np.linalg.norm(n)
            cone = _block(LIMIT, 1, joint, SLOT_UPPER)
            _angular(cone, 0, -n)
            cone["C"][0] = joint["upper"] - np.arctan2(s, a_A @ a_B)
            out.append(cone)
        if kind == "Spherical" and joint.get("has_twist", False):  # as a hinge's limits, about t
            # where the twist is not defined (a swing of pi) the rows stay, far open (C = 2 pi: a
            # speculative row that cannot push): a joint has the same rows at every pose
            twist = twist_angle(joint, RA, RB)
            psi, t = twist if twist is not None else (None, RA @ joint["axis_a"])
            lo, hi = _block(LIMIT, 1, joint, SLOT_TWIST_LOWER), _block(LIMIT, 1, joint, SLOT_TWIST_UPPER)
            _angular(lo, 0, t)
            lo["C"][0] = psi - joint["twist_lower"] if twist is not None else 2.0 * np.pi
            _angular(hi, 0, -t)
            hi["C"][0] = joint["twist_upper"] - psi if twist is not None else 2.0 * np.pi
            out += [lo, hi]
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


def prepare_joints(snapshot, joints, q_dot, h, inertia_rotation=None):
    """Every joint's blocks at the snapshot's poses, with W, K = J W J^T, K^-1, grouped by joint
    (``_group``), and drift 0: the PGS asks for it from the velocities its first sweep leaves
    (``predict_drift``, called by its second sweep), the soft step from those before the joints'
    solve.

    Inputs: snapshot (position, rotation, bodies), joints (list of dicts, alpha read and written
            by the later stages), q_dot (N, 6) the velocities before the joints' solve (unused: kept
            for the signature), h s, inertia_rotation (N, 3, 3) the rotations at which W takes each
            body's inverse inertia h R I^-1 R^T (the soft step's: the step's start, where its rows
            are made once; None: the snapshot's).
    Output: list of blocks (dicts), in joint order.
    """
    P = np.asarray(snapshot["position"], dtype=float)
    R = np.asarray(snapshot["rotation"], dtype=float)
    R_W = R if inertia_rotation is None else np.asarray(inertia_rotation, dtype=float)
    moves = moving(snapshot)
    blocks = []
    for joint in joints:
        a, b = joint["body_a"], joint["body_b"]
        if (not moves[a] and not moves[b]) or joint.get("broken", False):
            continue
        here = build_blocks(joint, P[a], R[a], P[b], R[b], h)
        for blk in here:
            W_ang = {x: (h * R_W[i] @ np.asarray(snapshot["bodies"][i]["inv_inertia"], float) @ R_W[i].T if moves[i]
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
            blk["drift"] = np.zeros(blk["n"])
        _group(here)
        here[0]["group"]["poses"] = (P[a], R[a], P[b], R[b])
        blocks += here
    return blocks


def touching_bodies(snapshot, rows):
    """The moving bodies (``moving``) with a contact row (rows: ``solver.prepare_rows``), a set:
    their joints keep drift 0 (``predict_drift``)."""
    moves = moving(snapshot)
    return {int(i) for i in np.concatenate([rows["a"], rows["b"]]) if moves[int(i)]}


def predict_drift(blocks, q_dot, h, touching=None, turn=np.inf, limits=True):
    """Each row's drift h/2 (dJ/dt) q_dot = J(poses after h/2 at q_dot) q_dot - J q_dot (0 for a
    motor), from the velocities q_dot (N, 6): solving J q_dot + drift = 0 asks the rows of the
    substep's midpoint, where a swing's energy loss to the rows' turning cancels to second order.
    The PGS takes q_dot after its first sweep: the velocities before the solve may run into a contact
    or a limit, and their midpoint rows would ask for velocities that are not there to keep.
    ``touching``: the moving bodies with a contact row this substep, whose joints keep drift 0 (a
    contact changes their velocities within the substep; None: every joint gets its drift).
    ``turn`` (rad): a joint whose bodies turn more than this in h / 2 (h/2 max(|omega_A|, |omega_B|))
    keeps its drift too (the soft step's DRIFT_TURN: the rule is the first term of an expansion in
    that turn; the PGS's none). ``limits``: whether limit rows get theirs (the PGS's do, the soft
    step's not: the cancellation holds for a row that holds through the substep, and a limit that
    lets go keeps the separating velocity its drift asked for)."""
    half = 0.5 * h
    for group in _groups(blocks):
        here = group["blocks"]
        joint = here[0]["joint"]
        a, b = joint["body_a"], joint["body_b"]
        if touching is not None and (a in touching or b in touching):
            continue
        if half * max(np.sqrt(q_dot[a, :3] @ q_dot[a, :3]), np.sqrt(q_dot[b, :3] @ q_dot[b, :3])) > turn:
            continue
        pA, RA, pB, RB = group["poses"]
        there = build_blocks(joint, pA + half * q_dot[a, 3:], rodrigues(q_dot[a, :3], half) @ RA,
                             pB + half * q_dot[b, 3:], rodrigues(q_dot[b, :3], half) @ RB, h)
        for blk, later in zip(here, there):
            if blk["kind"] == MOTOR or (not limits and blk["kind"] == LIMIT):
                blk["drift"] = np.zeros(blk["n"])
            else:
                blk["drift"] = ((later["ang_a"] - blk["ang_a"]) @ q_dot[a, :3] + (later["lin_a"] - blk["lin_a"]) @ q_dot[a, 3:]
                                + (later["ang_b"] - blk["ang_b"]) @ q_dot[b, :3] + (later["lin_b"] - blk["lin_b"]) @ q_dot[b, 3:])


def _row_K(x, i, y, k):
    """(J W J^T) between row i of block x and row k of block y of one joint."""
    return (x["ang_a"][i] @ y["w_ang_a"][k] + y["w_lin_a"] * (x["lin_a"][i] @ y["lin_a"][k])
            + x["ang_b"][i] @ y["w_ang_b"][k] + y["w_lin_b"] * (x["lin_b"][i] @ y["lin_b"][k]))


def _group(blocks):
    """One joint's blocks as a group (each block's ``group``): its equality rows E (the Equality
    blocks' rows in order), K_EE^-1 when K_EE is positive definite (``coupled``), and for each
    bounded row g = K_EE^-1 K_El and K_eff = K_ll - K_lE g."""
    E = [(blk, k) for blk in blocks if blk["kind"] == EQUALITY for k in range(blk["n"])]
    group = {"blocks": blocks, "n_e": len(E), "coupled": False}
    if E:
        K_EE = np.array([[_row_K(x, i, y, k) for (y, k) in E] for (x, i) in E])
        try:
            np.linalg.cholesky(K_EE)
            group["coupled"] = True
            group["K_EE_inv"] = np.linalg.inv(K_EE)
        except np.linalg.LinAlgError:
            pass
    for blk in blocks:
        blk["group"] = group
        if group["coupled"] and blk["kind"] != EQUALITY:
            K_El = np.array([_row_K(x, i, blk, 0) for (x, i) in E])
            blk["g"] = group["K_EE_inv"] @ K_El
            blk["K_eff"] = blk["K"][0, 0] - K_El @ blk["g"]


def _groups(blocks):
    """The joints' groups, in order."""
    out = []
    for blk in blocks:
        if not out or out[-1] is not blk["group"]:
            out.append(blk["group"])
    return out


def _add_to_equalities(group, d_E, q, alpha):
    """The group's equality rows take the force changes d_E (n_e,): added to alpha(blk) and applied to q."""
    r = 0
    for blk in group["blocks"]:
        if blk["kind"] != EQUALITY:
            continue
        part = d_E[r:r + blk["n"]]
        alpha(blk)[:] += part
        _apply(blk, part, q)
        r += blk["n"]


def _solve_group(group, q, bias, alpha, active, new_force, equalities=True):
    """One pass over a coupled group on q (N, 6): the equality rows at once, d_alpha_E =
    -K_EE^-1 u_E with u_E = J_E q + bias_E (unless ``equalities`` is False: then they only
    follow); then each active bounded row l, alpha_l <- new_force(l, alpha_l, J_l q + bias_l,
    K_eff), the equality rows following it. bias(blk), alpha(blk): the block's velocity bias and its
    force storage (a view). Returns the rows' largest velocity change (the equality rows: their
    residual)."""
    change = 0.0
    if equalities:
        equal = [blk for blk in group["blocks"] if blk["kind"] == EQUALITY]
        u_E = np.concatenate([_velocity(blk, q) + bias(blk) for blk in equal])
        change = float(np.max(np.abs(u_E)))
        _add_to_equalities(group, -(group["K_EE_inv"] @ u_E), q, alpha)
    for blk in group["blocks"]:
        if blk["kind"] == EQUALITY or not active(blk):
            continue
        a = alpha(blk)
        old = a[0]
        a[0] = new_force(blk, old, (_velocity(blk, q) + bias(blk))[0], blk["K_eff"])
        d = a[0] - old
        if d == 0.0:
            continue
        _apply(blk, np.array([d]), q)
        _add_to_equalities(group, -d * blk["g"], q, alpha)
        change = max(change, abs(blk["K_eff"] * d))
    return change


def _solve_group_soft(group, q, bias, h, spring):
    """The soft step's biased pass over a coupled group on q (N, 6), spring = (bias_rate,
    mass_scale, impulse_scale). A soft row's new force is mass_scale times the rigid force the
    velocity without it asks (the soft rule, as 1 - impulse_scale = mass_scale), K the matrix of
    the group's equality rows and its limits with C <= 0 together: their forces (and the
    speculative limits', C > 0) are given back, the group solved rigidly from zero (the equality
    rows at once, then those limits max(-(u + bias_rate C) / K_eff, 0), the equality rows
    following), (1 - mass_scale) of that taken back; then the other bounded rows as ``_bounded``
    in SOFT_BIASED (motors from their force, speculative limits from zero), the equality rows
    following each in full."""
    bias_rate, mass_scale, _ = spring

    def soft_row(blk):
        return blk["kind"] == EQUALITY or (blk["kind"] == LIMIT and blk["C"][0] <= 0.0)

    def scale(s, speculative_too):
        for blk in group["blocks"]:
            if not (soft_row(blk) or (speculative_too and blk["kind"] == LIMIT)):
                continue
            a = _alpha(blk)
            d = (s - 1.0) * np.array(a)
            a[:] += d
            _apply(blk, d, q)

    def pushing(blk, old, u, k):
        return max(old - (1.0 / k if k > 0.0 else 0.0) * (u + bias_rate * blk["C"][0]), 0.0)

    scale(0.0, True)
    _solve_group(group, q, bias, _alpha, lambda blk: blk["kind"] == LIMIT and soft_row(blk), pushing)
    scale(mass_scale, False)
    _solve_group(group, q, bias, _alpha, lambda blk: not soft_row(blk),
                 lambda blk, old, u, k: _bounded(blk, old, u, k, h, SOFT_BIASED, spring), equalities=False)


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


def _bounded(blk, old, u, k, h, mode=HARD, spring=None):
    """The new force of a bounded row of velocity u (J q_dot with its drift) whose K is k, in a sweep
    of ``mode`` (spring: (bias_rate, mass_scale, impulse_scale), for SOFT_BIASED):
        limit     C > 0: max(alpha - (u + C / h) / k, 0) (speculative: close the distance, no more);
                  else max(alpha - u / k, 0), or in SOFT_BIASED
                  max(alpha - mass_scale (u + bias_rate C) / k - impulse_scale alpha, 0)
        motor     clamp(alpha - (u - target) / k, -max_force, max_force) (rigid), or
                  clamp(alpha - (u + gamma alpha - target) / (k + gamma), ...) (a spring-damper)"""
    k_inv = 1.0 / k if k > 0.0 else 0.0
    if blk["kind"] == LIMIT:
        C = blk["C"][0]
        if C > 0.0:
            return max(old - k_inv * (u + C / h), 0.0)
        if mode == SOFT_BIASED:
            bias_rate, mass_scale, impulse_scale = spring
            return max(old - mass_scale * k_inv * (u + bias_rate * C) - impulse_scale * old, 0.0)
        return max(old - k_inv * u, 0.0)
    g = blk["gamma"]
    new = old - k_inv * (u - blk["target"]) if g == 0.0 else old - (u + g * old - blk["target"]) / (k + g)
    return min(max(new, blk["lo"]), blk["hi"])


def sweep_joints(blocks, q_dot, h, mode=HARD, spring=None):
    """One Gauss-Seidel sweep over the joints, q_dot (N, 6) in place, in ``mode``: HARD (the PGS's
    iterate) and SOFT_RELAX (the soft step's relax sweep) rigid, SOFT_BIASED (its biased sweep) with
    the joint spring ``spring`` = (bias_rate 1/s, mass_scale, impulse_scale) (``soft.joint_spring``).
    Each coupled joint as its group (module docstring), with bias the rows' drift (SOFT_BIASED: the
    equality rows' drift + bias_rate C); the blocks of the others one by one, equality d_alpha =
    -K^-1 (J q_dot + drift) (SOFT_BIASED: -mass_scale K^-1 (J q_dot + drift + bias_rate C) -
    impulse_scale alpha), bounded rows as ``_bounded`` with their own K. Returns the largest row
    velocity change (m/s or rad/s; the soft step does not read it)."""
    change = 0.0
    biased = mode == SOFT_BIASED

    def bias(blk):  # the velocity bias: the drift, and in the biased sweep the equality rows' spring on C
        return blk["drift"] + spring[0] * blk["C"] if biased and blk["kind"] == EQUALITY else blk["drift"]

    for group in _groups(blocks):
        if group["coupled"] and biased:
            _solve_group_soft(group, q_dot, bias, h, spring)
            continue
        if group["coupled"]:
            change = max(change, _solve_group(group, q_dot, bias, _alpha, lambda blk: True,
                                              lambda blk, old, u, k: _bounded(blk, old, u, k, h, mode, spring)))
            continue
        for blk in group["blocks"]:
            u = _velocity(blk, q_dot) + blk["drift"]
            alpha = blk["joint"]["alpha"]
            s = blk["slot"]
            if blk["kind"] == EQUALITY:
                if biased:
                    bias_rate, mass_scale, impulse_scale = spring
                    d = (-mass_scale * (blk["K_inv"] @ (u + bias_rate * blk["C"]))
                         - impulse_scale * alpha[s:s + blk["n"]])
                else:
                    d = -(blk["K_inv"] @ u)
                alpha[s:s + blk["n"]] += d
            else:
                old = alpha[s]
                alpha[s] = _bounded(blk, old, u[0], blk["K"][0, 0], h, mode, spring)
                d = np.array([alpha[s] - old])
            _apply(blk, d, q_dot)
            change = max(change, float(np.max(np.abs(blk["K"] @ d))))
    return change


def joint_position_pass(blocks, q_p, h, erp, tolerance, max_iterations):
    """The joints' part of the position pass, after the contacts' (q_p (N, 6) in place): the target
    J q_p = -erp C / h for every equality row (those without an error holding) and for limit rows
    only while C < 0, pseudo-forces beta (>= 0 for a limit), joint by joint as the iterate (coupled
    groups together), swept to the tolerance; nothing when no block has an error. Returns the
    sweeps used."""
    def violated(blk):
        return blk["kind"] == LIMIT and blk["C"][0] < 0.0

    def error(blk):
        return np.any(blk["C"] != 0.0) if blk["kind"] == EQUALITY else violated(blk)

    if not any(error(blk) for blk in blocks):
        return 0
    beta = {id(blk): np.zeros(blk["n"]) for blk in blocks}

    def bias(blk):
        return (erp / h) * blk["C"][:blk["n"]]

    def push(blk, old, u, k):
        return max(old - (1.0 / k if k > 0.0 else 0.0) * u, 0.0)

    sweeps, converged = 0, False
    while not converged and sweeps < max_iterations:
        sweeps += 1
        change = 0.0
        for group in _groups(blocks):
            if group["coupled"]:
                change = max(change, _solve_group(group, q_p, bias, lambda blk: beta[id(blk)], violated, push))
                continue
            for blk in group["blocks"]:
                if not (blk["kind"] == EQUALITY or violated(blk)):
                    continue
                u = _velocity(blk, q_p) + bias(blk)
                b = beta[id(blk)]
                if blk["kind"] == EQUALITY:
                    d = -(blk["K_inv"] @ u)
                    b += d
                else:
                    new = push(blk, b[0], u[0], blk["K"][0, 0])
                    d = np.array([new - b[0]])
                    b[0] = new
                _apply(blk, d, q_p)
                change = max(change, float(np.max(np.abs(blk["K"] @ d))))
        converged = tolerance > 0.0 and change <= tolerance
    return sweeps


def store_joints(snapshot, joints, blocks):
    """Each joint's force on B (N) and torque about B's anchor (N m), world, (J, 3) each:
    F = sum alpha_r lin_b,r, tau = sum alpha_r ang_b,r - (R_B anchor_b) x F, also written to each
    joint's ``force`` and ``torque``; a joint without blocks (broken, or its bodies asleep or
    immovable) keeps the ``force`` and ``torque`` it has (zero when it has none)."""
    R = np.asarray(snapshot["rotation"], dtype=float)
    force, torque = np.zeros((len(joints), 3)), np.zeros((len(joints), 3))
    index = {id(j): k for k, j in enumerate(joints)}
    solved = set()
    for blk in blocks:
        k = index[id(blk["joint"])]
        solved.add(k)
        a = np.array(_alpha(blk))
        force[k] += a @ blk["lin_b"]
        torque[k] += a @ blk["ang_b"]
    for k, joint in enumerate(joints):
        if k not in solved:
            force[k] = np.asarray(joint.get("force", np.zeros(3)), dtype=float)
            torque[k] = np.asarray(joint.get("torque", np.zeros(3)), dtype=float)
            continue
        torque[k] -= np.cross(R[joint["body_b"]] @ joint["anchor_b"], force[k])
        joint["force"], joint["torque"] = force[k].copy(), torque[k].copy()
    return force, torque


def break_joints(joints):
    """After a step: each unbroken joint whose force or torque (``store_joints``) is larger than its
    break_force (N) or break_torque (N m) breaks: broken, its alpha, force and torque zero (its
    bodies collide from the next step unless excluded). In place; returns the indices broken."""
    broken = []
    for k, joint in enumerate(joints):
        if joint.get("broken", False):
            continue
        f = np.linalg.norm(np.asarray(joint.get("force", np.zeros(3)), dtype=float))
        t = np.linalg.norm(np.asarray(joint.get("torque", np.zeros(3)), dtype=float))
        if f > joint.get("break_force", np.inf) or t > joint.get("break_torque", np.inf):
            joint["broken"] = True
            joint["alpha"] = np.zeros_like(np.asarray(joint["alpha"], dtype=float))
            joint["force"], joint["torque"] = np.zeros(3), np.zeros(3)
            broken.append(k)
    return broken
