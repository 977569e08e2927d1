"""The soft step (docs/conventions.md, "The soft step"): Catto's soft-constraint substepping (Catto,
"Soft Constraints", GDC 2011; "Solver2D", 2024; Box2D v3's soft step) on the lecture's rows,
re-derived here from its equations and never from the core.

A step of dt detects its contacts once and runs n substeps of h = dt / n (``substep_count``: at
most 1/240 s each when automatic):

    begin      rows once, at the step's start poses, with dt folded as h (``prepare_rows``);
               u_i = J_n q_dot from the velocities at the step's start (before gravity's kick);
               each contact's softness (``softness``); the previous step's forces recalled
               (``recall_forces``), not applied
    per substep k:
      velocity   q_dot* = the unconstrained velocity of the current state over h
      solve      the current forces applied again as this substep's first guess (``apply_forces``;
                 the cache's in the first substep), the gaps carried to the current poses
                 (``carried_gaps``), soft_iterations sweeps with the soft bias (``soft_sweep``)
      advance    the poses move over h with the solved velocities (``integrate``)
      relax      the gaps carried to the new poses, relax_iterations sweeps with rigid contacts,
                 whose velocities are kept; then restitution (3d) on the contacts that push for
                 the first time in this substep (alpha 0 after every substep before) with e > 0 and
                 an approach u = J_n q_dot before the biased sweep below -restitution_threshold:
                 n^T (v_B - v_A) >= -e u, so that the rebound starts within h of the impact
    end        store (the last substep's forces, the next cache of its forces before restitution),
               the step's whole normal impulse sum_k h alpha_k, the certificate against the rigid
               targets; each joint's force and torque on B from its last substep's rows

The joints (``joints``) are mirrored too: in each substep's solve, after the contacts' forces are
applied, the joints' blocks are made at the substep's poses (W of the step's start inertia, as the
contact rows'), each row's drift predicted from the velocities then (``joints.predict_drift``: not
for a joint whose moving bodies have a contact row, nor one whose bodies turn more than DRIFT_TURN
in h / 2), their forces applied (the warm start); one joint sweep follows each contact sweep, the
biased sweeps' with the joint spring (``joint_spring``: the settings' joint_hertz, at most a quarter
of 1 / h, and joint_damping_ratio; a limit with C > 0 speculative), the relax sweeps' rigid, on
the same blocks (made at the substep's start poses, drift included).

The normal row of contact i (its force alpha >= 0, N) is updated in a sweep by
    alpha <- max(alpha - (mass_scale J q_dot + b) / delta - impulse_scale alpha, 0)
with its gap s_i (m) carried with the bodies and
    s_i > 0 (either sweep)        b = s_i / h, mass_scale = 1, impulse_scale = 0
                                  (speculative: the rigid contact closes its gap, no more)
    s_i <= 0, biased (solve)      b = max(mass_scale bias_rate s_i, -max_push_velocity)
                                  (the spring-damper on the whole overlap: no slop)
    s_i <= 0, not biased (relax)  b = 0, mass_scale = 1, impulse_scale = 0 (rigid)
Friction and spin rows follow the normal row as in the PGS (``solver.friction_rows``). With
mass_scale 1 and impulse_scale 0 the rule is the lecture's projection
alpha <- max(-gamma / delta, 0), gamma = J q_dot + b - delta alpha.

Why it is a spring: a sphere of mass m resting on the ground (one normal row, delta = h / m)
with alpha = m g: gravity's kick gives J q_dot* = -g h, the applied force brings it back to
J q_dot = -g h + delta alpha = 0, and the biased sweep keeps alpha when
b / delta + impulse_scale alpha = 0, i.e. mass_scale bias_rate s = -impulse_scale g h:
    s = -g h / (a2 bias_rate) = -g h a1 / (h omega a1 omega) = -g / omega^2,
the static deflection of a spring of natural frequency omega (m omega^2 |s| = m g). The poses
then do not move, and the relax sweep (b = 0, J q_dot = 0) keeps alpha too: the sphere rests at
that overlap for good (tests/python/test_oracle_soft.py checks it, and the core).
"""

import numpy as np

from .joints import (
    DRIFT_TURN,
    SOFT_BIASED,
    SOFT_RELAX,
    predict_drift,
    prepare_joints,
    store_joints,
    sweep_joints,
    touching_bodies,
    warm_start_joints,
)
from .rigid import body_arrays, integrate, motion_flags, unconstrained_velocity
from .solver import (
    MAX_HERTZ_PER_RATE,
    RowSweep,
    apply_forces,
    certificate,
    contact_anchors,
    friction_rows,
    prepare_rows,
    read_cache,
    read_joints,
    recall_forces,
    restitution,
    solve_order,
    solver_settings,
    store,
)

# the carried gap s is a sum of terms as large as the detected gap, the lever arms and the
# displacements, each a few roundings deep (R0^T r, (R - R0) l, the sums): two evaluations
# of it in another order differ by a few ulps of the largest; within this many ulps of
# (|gap| + |r_A| + |r_B| + |dp_A| + |dp_B|) the sign of s is rounding's to decide
GAP_ROUNDING_ULPS = 16


def softness(hertz, zeta, h):
    """The soft constraint of a spring of natural frequency ``hertz`` (Hz) and damping ratio zeta
    over a substep h (s) (Catto, "Soft Constraints", GDC 2011):
        omega = 2 pi hertz,  a1 = 2 zeta + h omega,  a2 = h omega a1,
        bias_rate = omega / a1  (1/s),  mass_scale = a2 / (1 + a2),  impulse_scale = 1 / (1 + a2).
    Inputs may be arrays of one shape; outputs (bias_rate, mass_scale, impulse_scale) have it."""
    omega = 2.0 * np.pi * np.asarray(hertz, dtype=float)
    a1 = 2.0 * np.asarray(zeta, dtype=float) + h * omega
    a2 = h * omega * a1
    return omega / a1, a2 / (1.0 + a2), 1.0 / (1.0 + a2)


def joint_spring(settings, h):
    """The joints' spring in the soft step's biased sweeps over a substep h (s): ``softness`` of
    min(settings["joint_hertz"], MAX_HERTZ_PER_RATE / h) Hz and damping ratio
    settings["joint_damping_ratio"], the same for every joint (moving or static partner).
    Output (bias_rate 1/s, mass_scale, impulse_scale)."""
    hertz = min(settings["joint_hertz"], MAX_HERTZ_PER_RATE / h)
    bias_rate, mass_scale, impulse_scale = softness(hertz, settings["joint_damping_ratio"], h)
    return float(bias_rate), float(mass_scale), float(impulse_scale)


def contact_softness(snapshot, contacts, settings, h):
    """Each contact's softness (``softness``) for a substep h: the spring of
    hertz = min(contact_hertz, MAX_HERTZ_PER_RATE / h) and damping_ratio between two bodies that
    move; twice as stiff (2 hertz) and half as damped (damping_ratio / 2) against a static or
    kinematic body (Box2D v3: such a contact carries the whole load alone).

    Inputs: snapshot (bodies), contacts dict (body_a, body_b; K), settings (``solver_settings``),
            h s.  Output dict of (K,) arrays: bias_rate 1/s, mass_scale, impulse_scale, hertz Hz,
            zeta.
    """
    static, _, _, _ = body_arrays(snapshot)
    kinematic, _ = motion_flags(snapshot)
    moves = ~static & ~kinematic
    A = np.asarray(contacts["body_a"], dtype=np.int64).reshape(-1)
    B = np.asarray(contacts["body_b"], dtype=np.int64).reshape(-1)
    both = moves[A] & moves[B]
    hertz = min(settings["contact_hertz"], MAX_HERTZ_PER_RATE / h)
    f = np.where(both, hertz, 2.0 * hertz)
    zeta = np.where(both, settings["damping_ratio"], 0.5 * settings["damping_ratio"])
    bias_rate, mass_scale, impulse_scale = softness(f, zeta, h)
    return {"bias_rate": bias_rate, "mass_scale": mass_scale, "impulse_scale": impulse_scale,
            "hertz": f, "zeta": zeta}


def rounding_radius(shape, part=0):
    """The radius (m) by which a shape dict, or a compound's part ``part``, rounds a core: a
    contact's witness point on it is its core point (a sphere's centre, the nearest point of a
    capsule's segment) moved by this radius against the normal, however the body has turned.
    Sphere and capsule: their radius; a compound: its part's (0 for a part it does not have);
    every other shape 0 (its witness points are points of the body)."""
    kind = shape["type"]
    if kind in ("sphere", "capsule"):
        return float(shape["radius"])
    if kind == "compound":
        parts = shape["parts"]
        return rounding_radius(parts[part][0]) if part < len(parts) else 0.0
    return 0.0


def contact_rounding(snapshot, contacts):
    """Each contact's rounding radii (``rounding_radius``, m, (K,) each) on A and on B. The part of
    a feature id is its high 32 bits (docs/conventions.md, "Feature ids"); contacts made by hand,
    without feature ids, count as part 0."""
    bodies = snapshot["bodies"]

    def side(body_key, feature_key):
        X = np.asarray(contacts[body_key], dtype=np.int64).reshape(-1)
        F = np.asarray(contacts.get(feature_key, np.zeros(len(X))), dtype=np.uint64).reshape(-1)
        return np.array([rounding_radius(bodies[x]["shape"], int(f) >> 32) for x, f in zip(X, F)], dtype=float)

    return side("body_a", "feature_a"), side("body_b", "feature_b")


def core_offsets(snapshot, contacts):
    """Where each contact's carried points lie from its point (m, (K,) each, along -n for A and
    +n for B): a round side's core (``rounding_radius`` rho > 0) at gap / 2 + rho, the witness
    gap / 2 from the contact point and the core rho beyond it; 0 on any other side.

    Inputs: snapshot (bodies with their shape dicts), contacts dict (K; body_a, body_b, gap,
            feature_a, feature_b). Output: (sigma_a, sigma_b)."""
    gap = np.asarray(contacts["gap"], dtype=float).reshape(-1)
    return tuple(np.where(rho > 0.0, 0.5 * gap + rho, 0.0) for rho in contact_rounding(snapshot, contacts))


def carried_gaps(contacts, start, now, sigma=None):
    """Each contact's gap with its point carried rigidly by each of its two bodies from the step's
    start to now: the point y moves with body X to y_X = p_X + R_X l_X, l_X = R_X0^T (y - p_X0) its
    lever arm in X's frame, so with dp_X = p_X - p_X0,
        s = gap + n . ((dp_B + (R_B - R_B0) l_B) - (dp_A + (R_A - R_A0) l_A)),
    exactly gap until a body moves. The normal stays as detected. With anchor_a, anchor_b (a
    recycled contact's: its rows' lever arms as its manifold was found) the point carried with X is
    anchor_X, as the rows' lever arms say (``contact_anchors``). With sigma = (sigma_a, sigma_b)
    (``core_offsets``) the point carried with A is y - sigma_a n and with B y + sigma_b n: a round
    side's core, whose witness stays where the normal says whichever way the body turns (a ball
    rolling on the ground keeps its gap).

    Inputs: contacts dict (K; body_a, body_b, point, normal, gap as detected at ``start``; optional
            anchor_a, anchor_b (K, 3)), two snapshots (position (N, 3), rotation (N, 3, 3)): the
            step's start and now; sigma: None or two (K,) arrays, m.
    Output: s (K,) m.
    """
    A = np.asarray(contacts["body_a"], dtype=np.int64).reshape(-1)
    B = np.asarray(contacts["body_b"], dtype=np.int64).reshape(-1)
    n = np.asarray(contacts["normal"], dtype=float).reshape(-1, 3)
    y_A, y_B = contact_anchors(contacts)
    if sigma is not None:
        y_A = y_A - sigma[0][:, None] * n
        y_B = y_B + sigma[1][:, None] * n
    gap = np.asarray(contacts["gap"], dtype=float).reshape(-1)
    p0, p = np.asarray(start["position"], dtype=float), np.asarray(now["position"], dtype=float)
    R0, R = np.asarray(start["rotation"], dtype=float), np.asarray(now["rotation"], dtype=float)
    D = R - R0

    def moved(X, y):  # y_X - y: how far the point y moved with body X
        lever = np.einsum("kji,kj->ki", R0[X], y - p0[X])  # R0^T (y - p0)
        return (p[X] - p0[X]) + np.einsum("kij,kj->ki", D[X], lever)

    return gap + np.einsum("ki,ki->k", n, moved(B, y_B) - moved(A, y_A)) if len(gap) else gap.copy()


def gap_rounding(contacts, start, now):
    """How far the sign of each carried gap (``carried_gaps``) is rounding's to decide (m, (K,)):
    GAP_ROUNDING_ULPS ulps of |gap| + |r_A| + |r_B| + |dp_A| + |dp_B|, the magnitudes s is summed
    from. Inputs as ``carried_gaps``."""
    A = np.asarray(contacts["body_a"], dtype=np.int64).reshape(-1)
    B = np.asarray(contacts["body_b"], dtype=np.int64).reshape(-1)
    y_A, y_B = contact_anchors(contacts)
    gap = np.asarray(contacts["gap"], dtype=float).reshape(-1)
    p0, p = np.asarray(start["position"], dtype=float), np.asarray(now["position"], dtype=float)
    size = (np.abs(gap) + np.linalg.norm(y_A - p0[A], axis=1) + np.linalg.norm(y_B - p0[B], axis=1)
            + np.linalg.norm(p[A] - p0[A], axis=1) + np.linalg.norm(p[B] - p0[B], axis=1))
    return GAP_ROUNDING_ULPS * np.finfo(float).eps * size


def soft_sweep(sweep, rows, soft, s, x, tau, q_dot, h, biased, max_push_velocity, friction_cone,
               band=None, ties=None, tied=None):
    """One sweep over every contact in solve order: its normal row by the soft rule of the module
    doc (biased: the spring on an overlap; not biased: rigid; a positive gap s_i: rigid with the
    speculative bias s_i / h either way), then its friction rows and its spin row
    (``friction_rows``). A body pair of exactly two contacts (a unit of the solve order by pair)
    has its two normal rows solved as one block first (``solve_pair``), then each contact's
    friction rows.

    The biased rule is discontinuous at s_i = 0 (rigid above, a damped spring at and below), and
    a contact that closed its gap speculatively ends at a gap of rounding size: which side it is on
    is then rounding's choice, and two correct evaluations may choose differently. A contact with
    |s_i| <= band_i in a biased sweep is added to ``tied``, and takes the side ties[i] (True: as
    s_i > 0) when ``ties`` names it. The relax rule is continuous at 0 (b = max(s_i, 0) / h).

    Inputs: sweep (``RowSweep`` of the rows for h), rows, soft (``contact_softness``), s (K,) m the
            gaps now, x (3K list, N) and tau (K list, N m) the forces, modified in place, q_dot
            (N, 6) modified in place, h s, biased, max_push_velocity m/s, friction_cone;
            band (K,) m (``gap_rounding``), ties {contact: bool}, tied (a set, added to) or None.
    """
    mu = rows["mu"].tolist()
    bias_rate, mass_scale = soft["bias_rate"].tolist(), soft["mass_scale"].tolist()
    impulse_scale = soft["impulse_scale"].tolist()
    gap = np.asarray(s, dtype=float).tolist()
    band = [0.0] * len(gap) if band is None else np.asarray(band, dtype=float).tolist()

    def rule(i):  # (b, mass_scale, impulse_scale) of contact i's normal row
        speculative = gap[i] > 0.0
        if biased and abs(gap[i]) <= band[i]:
            if tied is not None:
                tied.add(i)
            if ties is not None and i in ties:
                speculative = bool(ties[i])
        if speculative:
            return gap[i] / h, 1.0, 0.0
        if biased:
            return max(mass_scale[i] * bias_rate[i] * gap[i], -max_push_velocity), mass_scale[i], impulse_scale[i]
        return 0.0, 1.0, 0.0

    two = two_point_pairs(sweep)
    order = rows["order"].tolist()
    k = 0
    while k < len(order):
        i = order[k]
        n = 3 * i
        if two[i] and sweep.delta[n] > 0.0 and sweep.delta[n + 3] > 0.0:
            # the pair's normal rows as one block: each row's own rule, its velocity J_i q_dot
            # seeing the other row's change too (K_ij the rows' coupling),
            #   K_ii (y_i - alpha_i) + mass_scale_i K_ij (y_j - alpha_j)
            #     = -(mass_scale_i J_i q_dot + b_i) - impulse_scale_i K_ii alpha_i,
            # y >= 0 complementary
            m = n + 3
            (b1, m1, i1), (b2, m2, i2) = rule(i), rule(i + 1)
            K11, K22 = sweep.delta[n], sweep.delta[m]
            K12 = sweep.dt * float(sweep.J_A[n] @ sweep.MJ_A[m] + sweep.J_B[n] @ sweep.MJ_B[m])
            c1 = K11 * x[n] + m1 * K12 * x[m] - i1 * K11 * x[n] - (m1 * sweep.velocity(n, q_dot) + b1)
            c2 = m2 * K12 * x[n] + K22 * x[m] - i2 * K22 * x[m] - (m2 * sweep.velocity(m, q_dot) + b2)
            y1, y2 = solve_pair(K11, K22, m1 * K12, m2 * K12, c1, c2)
            for row, y in ((n, y1), (m, y2)):
                if y != x[row]:
                    sweep.apply(row, y - x[row], q_dot)
                    x[row] = y
            friction_rows(sweep, i, mu[i], x, tau, q_dot, friction_cone)
            friction_rows(sweep, i + 1, mu[i + 1], x, tau, q_dot, friction_cone)
            k += 2
            continue
        k += 1
        delta = sweep.delta[n]
        if not delta > 0.0:
            continue  # both bodies static: never produced by the narrow phase
        b, m_scale, i_scale = rule(i)
        # normal: alpha <- max(alpha - (mass_scale J q_dot + b) / delta - impulse_scale alpha, 0)
        alpha = max(x[n] - (m_scale * sweep.velocity(n, q_dot) + b) / delta - i_scale * x[n], 0.0)
        if alpha != x[n]:
            sweep.apply(n, alpha - x[n], q_dot)
            x[n] = alpha
        # friction and spin, bounded by the new normal force, as in the PGS
        friction_rows(sweep, i, mu[i], x, tau, q_dot, friction_cone)


# a pair's two normal rows are one block only while det K >= PAIR_CONDITIONING K11 K22 (Box2D v2's
# block solver asks as much of its condition number, at 1,000): two points nearly on top of each
# other are solved one at a time (the first alone, ``solve_pair``)
PAIR_CONDITIONING = 1e-3


def two_point_pairs(sweep):
    """(K,) bools: contact i is the first of a body pair's exactly two contacts (consecutive in
    contact order, as the narrow phase lists a pair's points), whose normal rows a soft sweep
    solves as one block."""
    A, B = sweep.a[0::3], sweep.b[0::3]
    K = len(A)
    first = [False] * K
    i = 0
    while i < K:
        j = i + 1
        while j < K and (A[j], B[j]) == (A[i], B[i]):
            j += 1
        if j - i == 2:
            first[i] = True
        i = j
    return first


def solve_pair(K11, K22, K12, K21, c1, c2):
    """The block of two normal rows (Box2D v2's two-point block solver, with the soft rule):
    y >= 0 with w = K y - c >= 0 and y_i w_i = 0, K = [[K11, K12], [K21, K22]] (s/kg; each row's
    coupling scaled by its mass scale: a P-matrix), c (m/s), by its cases in turn: both push
    (y = K^-1 c, when det K >= PAIR_CONDITIONING K11 K22), the first alone (y1 = c1 / K11 with
    K21 y1 - c2 >= 0), the second alone, neither (c <= 0); at a case's edge, where rounding may
    reject every one, the first alone, clamped at 0. Output: (y1, y2) N."""
    det = K11 * K22 - K12 * K21
    if det >= PAIR_CONDITIONING * K11 * K22:
        y1, y2 = (K22 * c1 - K12 * c2) / det, (K11 * c2 - K21 * c1) / det
        if y1 >= 0.0 and y2 >= 0.0:
            return y1, y2
    z1, z2 = c1 / K11, c2 / K22
    if z1 >= 0.0 and K21 * z1 - c2 >= 0.0:
        return z1, 0.0
    if z2 >= 0.0 and K12 * z2 - c1 >= 0.0:
        return 0.0, z2
    if c1 <= 0.0 and c2 <= 0.0:
        return 0.0, 0.0
    return max(z1, 0.0), 0.0


def _moved(snapshot, q_dot, h):
    """The snapshot after its poses moved over h with q_dot (N, 6) = (omega, v), which it then
    keeps as its velocities."""
    position, rotation = integrate(snapshot, q_dot[:, 3:], q_dot[:, :3], h)
    new = dict(snapshot)
    new["position"], new["rotation"] = position, rotation
    new["velocity"], new["angular_velocity"] = q_dot[:, 3:].copy(), q_dot[:, :3].copy()
    return new


def normal_velocities(rows, q_dot):
    """J_n q_dot of every contact's normal row (K,) m/s, for velocities q_dot (N, 6)."""
    a, b = rows["a"][0::3], rows["b"][0::3]
    return (np.einsum("ki,ki->k", rows["J_B"][0::3], q_dot[b]) + np.einsum("ki,ki->k", rows["J_A"][0::3], q_dot[a])
            if len(a) else np.zeros(0))


def soft_step(snapshot, contacts, dt, n, ties=None, h=None, cut=None):
    """One soft step of dt in n substeps of h = dt / n (the module doc), from a snapshot whose
    pending impulses are applied, on the contacts detected at its start. With h given, n substeps
    of h (a run of rows within a step: ``step.step``); with cut, a function of (state after
    substep k, k) that returns True to end the run after substep k (the info then reports the k + 1
    substeps run).

    Inputs: snapshot (bodies, settings, cache, state at the step's start), contacts dict (K; with
            feature_a, feature_b for the warm start), dt s, n substeps, ties {contact: bool} (the
            side a contact whose gap is zero to rounding takes in a biased sweep: ``soft_sweep``;
            None: the sign of its gap as computed here).
    Outputs: (new_snapshot, info) as ``step.step``: new_snapshot with position, rotation, velocity,
            angular_velocity (the last substep's, after its restitution) and cache (the last
            substep's forces before restitution: normal forces, friction forces, spin torques);
            info: the ``store`` keys of the last substep's forces (alpha N, friction, force,
            spin_torque, normal_velocity, slip, body_force, body_torque), but impulse (K,) N s =
            the step's whole normal impulse, sum_k h alpha_k (restitution's included); the
            ``certificate`` keys against the rigid targets (b_i = max(s_i, 0) / h with s_i the gap
            at the step's end, or e_i u_i for a contact that bounced in the last substep);
            iterations = soft_iterations + relax_iterations (per substep), restitution_iterations
            (summed over the substeps), position_iterations = 0, converged = True (a fixed number
            of sweeps: never unconverged); mu, restitution, mu_spin (K,); u (K,) m/s: J_n q_dot at
            the step's start, or for a contact that bounced the approach its restitution answered;
            and the soft step's own: gap_end (K,) m, alpha_max (K,) N (the largest normal force
            after a substep), restitutive (K,) bool (bounced in the last substep), bounced (K,)
            bool (in some substep), hertz, zeta (K,), substeps n; tied: the contacts (sorted list)
            whose gap was zero to rounding (``gap_rounding``) in a biased sweep of some substep;
            joints (the snapshot's joints with their new alpha, force and torque; also in
            new_snapshot when there are any), joint_force, joint_torque (J, 3) N, N m on B
            (``joints.store_joints``, at the step's end poses).
    """
    s = solver_settings(snapshot)
    h = dt / n if h is None else h
    start = snapshot

    # begin: rows at the start poses, u_i from the start velocities, softness, the recalled forces
    q_start = np.hstack([np.asarray(start["angular_velocity"], dtype=float).reshape(-1, 3),
                         np.asarray(start["velocity"], dtype=float).reshape(-1, 3)])
    rows = prepare_rows(start, contacts, q_start, h)
    rows["order"] = solve_order(start, contacts, by_pair=True)  # a body pair's contacts together
    K = len(rows["mu"])
    soft = contact_softness(start, contacts, s, h)
    sigma = core_offsets(start, contacts)  # a round side carries its core
    sweep = RowSweep(rows, h)
    alpha_spin = np.zeros(K)
    alpha = (recall_forces(rows, contacts, read_cache(start), s["friction_cone"], alpha_spin)
             if s["warm_start"] else np.zeros(3 * K))
    impulse, alpha_max = np.zeros(K), np.zeros(K)
    u, u_before = rows["u"].copy(), np.zeros(K)
    restitutive, bounced = np.zeros(K, dtype=bool), np.zeros(K, dtype=bool)
    restitution_iterations = 0

    # the joints: their spring, and the bodies whose joints keep drift 0 (they have contact rows)
    joints = read_joints(start)
    spring = joint_spring(s, h)
    touching = touching_bodies(start, rows) if joints else set()
    blocks = []

    state = start
    x, tau = alpha.tolist(), alpha_spin.tolist()
    tied = set()
    ran = 0
    for k in range(n):
        # the unconstrained velocity of the current state
        v_star, omega_star = unconstrained_velocity(state, h)
        q_dot = np.hstack([omega_star, v_star])
        # solve: the current forces as the first guess, the soft sweeps at the current gaps; the
        # approach of a contact that has not pushed yet is kept for its restitution
        apply_forces(rows, np.asarray(x), q_dot, h, np.asarray(tau), sweep)
        if joints:  # the joints' blocks at these poses, their drift from these velocities, warm started
            blocks = prepare_joints(state, joints, q_dot, h, inertia_rotation=start["rotation"])
            predict_drift(blocks, q_dot, h, touching, DRIFT_TURN, limits=False)
            if s["warm_start"]:
                warm_start_joints(blocks, q_dot)
            else:
                for joint in joints:
                    joint["alpha"][:] = 0.0
        gap, band = carried_gaps(contacts, start, state, sigma), gap_rounding(contacts, start, state)
        u_before = np.where(alpha_max == 0.0, normal_velocities(rows, q_dot), u_before)
        for _ in range(s["soft_iterations"]):
            soft_sweep(sweep, rows, soft, gap, x, tau, q_dot, h, True, s["max_push_velocity"], s["friction_cone"],
                       band, ties, tied)
            sweep_joints(blocks, q_dot, h, SOFT_BIASED, spring)
        # the poses move with the solved velocities
        state = _moved(state, q_dot, h)
        # relax: rigid sweeps at the new gaps (the joints' on the same blocks); their velocities are kept
        gap = carried_gaps(contacts, start, state, sigma)
        for _ in range(s["relax_iterations"]):
            soft_sweep(sweep, rows, soft, gap, x, tau, q_dot, h, False, s["max_push_velocity"], s["friction_cone"])
            sweep_joints(blocks, q_dot, h, SOFT_RELAX)
        # restitution on the contacts that push for the first time, e > 0, that approached faster
        # than the threshold: n^T (v_B - v_A) >= -e u_before (the cache keeps the forces before it)
        alpha = np.asarray(x, dtype=float)
        alpha_iter = alpha[0::3].copy()
        restitutive = ((alpha_max == 0.0) & (alpha_iter > 0.0) & (rows["e"] > 0.0)
                       & (u_before < -s["restitution_threshold"]))
        u = np.where(restitutive, u_before, u)
        if np.any(restitutive):
            restitution_iterations += restitution(dict(rows, u=u), alpha, q_dot, restitutive, h, s["tolerance"],
                                                  s["max_iterations"])
            x = alpha.tolist()
        bounced |= restitutive
        state["velocity"], state["angular_velocity"] = q_dot[:, 3:].copy(), q_dot[:, :3].copy()
        alpha_n = alpha[0::3]
        impulse += h * alpha_n
        alpha_max = np.maximum(alpha_max, alpha_n)
        ran = k + 1
        if cut is not None and k + 1 < n and cut(state, k):
            break
    alpha, alpha_spin = np.asarray(x, dtype=float), np.asarray(tau, dtype=float)

    # end: store the last substep's forces, the whole impulse, the certificate against the rigid
    # contact at its end gap (or e u for a contact that bounced in the last substep)
    rows = dict(rows, u=u)
    out = store(rows, contacts, start, alpha, alpha_iter, q_dot, h, alpha_spin)
    out["impulse"] = impulse
    rigid = dict(rows, bias=np.maximum(gap, 0.0) / h)
    out.update(certificate(rigid, alpha, q_dot, restitutive, out["friction"], out["slip"],
                           s["friction_cone"], out["spin_torque"]))
    out.update({
        "mu": rows["mu"], "restitution": rows["e"], "mu_spin": rows["mu_spin"], "u": u,
        "iterations": s["soft_iterations"] + s["relax_iterations"],
        "restitution_iterations": restitution_iterations, "position_iterations": 0, "converged": True,
        "gap_end": gap, "alpha_max": alpha_max, "restitutive": restitutive, "bounced": bounced,
        "hertz": soft["hertz"], "zeta": soft["zeta"], "substeps": ran, "tied": sorted(tied),
    })

    # the joints' forces and torques on B, from the last substep's blocks, about B's anchor at the end
    out["joints"] = joints
    out["joint_force"], out["joint_torque"] = store_joints(state, joints, blocks)

    new = dict(state)
    new["velocity"], new["angular_velocity"] = q_dot[:, 3:].copy(), q_dot[:, :3].copy()
    new["cache"] = out.pop("cache")
    if joints:
        new["joints"] = joints
    info = {"contacts": contacts, **out}
    return new, info
