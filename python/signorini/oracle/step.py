"""One full step and a rollout (docs/conventions.md, "One step (dt)"):
    0. pending impulses                                   (apply_impulses)
    1. contacts from the current state                   (detect_contacts)
    2. unconstrained velocities, gyroscopic option        (unconstrained_velocity)
    3. the staged contact solve a-f                       (solver.solve_contacts)
    4. integrate the poses with q_dot_pos + q_p; keep the velocities after restitution (integrate)
with 1 once per step and 2-4 in n substeps of dt / n (``substeps``, or automatic: the fewest of
at most 1/960 s), each on the step's contacts carried along by the motion (carry_contacts).
With ``settings["solver"] == "soft"`` the step is the soft step (``soft.soft_step``): 0 and 1 as
above, then substeps of at most 1/240 s when automatic, each solve -> integrate -> relax (the
joints' rows in both schedules), in runs of rows made anew where a pair has turned far
(``soft_runs``). Automatic substeps, with either solver, are also short enough for the turning and
closing pairs in contact (``turn_substeps``, within ``turn_budget``, half of it before the first
substep). After the step, joints pulled past their break_force or
break_torque break (``joints.break_joints``).
"""

import copy

import numpy as np

from .contacts import DEFAULT_CONTACT_MARGIN, bounding_radius, detect_contacts, speculative_reach
from .joints import break_joints
from .rigid import apply_impulses, integrate, motion_flags, unconstrained_velocity
from .soft import contact_rounding, soft_step
from .solver import solve_contacts, solver_settings, substep_count

# the per-contact and per-step figures of the solve that ``step`` reports in its info
INFO_KEYS = (
    "alpha", "impulse", "friction", "force", "spin_torque", "normal_velocity", "slip", "mu", "restitution",
    "mu_spin",
    "body_force", "body_torque", "iterations", "restitution_iterations", "position_iterations",
    "converged", "residual", "max_alpha_negative", "max_penetration_velocity",
    "max_complementarity", "max_cone_violation", "max_dissipation_violation", "max_overlap",
)


def copy_snapshot(snapshot):
    """Deep copy of a snapshot dict, state arrays as float NumPy arrays."""
    new = copy.deepcopy(snapshot)
    for key in ("position", "velocity", "angular_velocity", "force", "torque"):
        new[key] = np.array(snapshot[key], dtype=float).reshape(-1, 3)
    for key in ("step_force", "step_torque", "impulse", "angular_impulse"):  # optional
        if key in snapshot:
            new[key] = np.array(snapshot[key], dtype=float).reshape(-1, 3)
    new["rotation"] = np.array(snapshot["rotation"], dtype=float).reshape(-1, 3, 3)
    return new


def step_once(snapshot, dt, contacts=None):
    """One step of dt seconds, items 1-4, whatever ``substeps`` says.

    Inputs: snapshot dict, dt s, contacts dict (detected from the current state when None).
    Outputs: (new_snapshot, info) as ``step``.
    """
    # 1. contacts from the current state
    if contacts is None:
        contacts = detect_contacts(snapshot, dt)

    # 2. unconstrained velocities
    v_star, omega_star = unconstrained_velocity(snapshot, dt)

    # 3. contact solve: the kept velocities, and the ones that move the poses
    result = solve_contacts(snapshot, contacts, v_star, omega_star, dt)

    # 4. integrate the poses with q_dot_pos + q_p; keep the velocities after restitution
    position, rotation = integrate(snapshot, result["velocity_move"], result["angular_velocity_move"], dt)

    new = copy_snapshot(snapshot)
    new["position"] = position
    new["rotation"] = rotation
    new["velocity"] = result["velocity"]
    new["angular_velocity"] = result["angular_velocity"]
    new["cache"] = result["cache"]
    if result["joints"]:
        new["joints"] = result["joints"]
    info = {"contacts": contacts, "joint_force": result["joint_force"], "joint_torque": result["joint_torque"]}
    info.update({key: result[key] for key in INFO_KEYS})
    return new, info


def carry_contacts(contacts, detected, now, anchored=False):
    """The contacts detected at snapshot ``detected`` carried to snapshot ``now`` by the motion of
    their bodies (a substep), to first order, as the velocity constraint linearises it: with each
    body's displacement dp = p - p_0 and turn dtheta = vee of the skew part of R R_0^T, and the
    witness points w_A = y - gap/2 n, w_B = y + gap/2 n,
    gap <- gap + n . ((dp_B + dtheta_B x (w_B - p_B0)) - (dp_A + dtheta_A x (w_A - p_A0))),
    but on a round side (``soft.contact_rounding``: rho_X > 0) the core c_B = w_B + rho_B n (c_A =
    w_A - rho_A n) moved with the body's whole turn, dp_X + (R_X R_X0^T - I) (c_X - p_X0), in place
    of its term (a spinning body's witness stays under its core). The normal stays; the lever arms
    stay as detected: anchor_X = y + dp_X (or, when the contacts carry anchor_X, anchor_X + dp_X),
    where the solver applies the force on X; on a round side moved along n by half the change of
    the gap, (gap' - gap) / 2 n for A and the opposite for B (its anchor is half the gap beyond its
    witness, as a contact point is, since its core is taken from it); y <- (anchor_a + anchor_b) / 2.
    With anchored (contacts carried before, whose point, the anchors' midpoint, lags a fast body by
    half its travel), each side's witness is taken from its anchor: w_A = anchor_a - gap/2 n, w_B =
    anchor_b + gap/2 n.

    Inputs: contacts dict (K contacts), two snapshots (position (N, 3), rotation (N, 3, 3); the
            first with its bodies).
    Output: a new contacts dict, the same but for point (K, 3), gap (K,), and with anchor_a,
            anchor_b (K, 3).
    """
    a = np.asarray(contacts["body_a"], dtype=np.int64)
    b = np.asarray(contacts["body_b"], dtype=np.int64)
    n = np.asarray(contacts["normal"], dtype=float).reshape(-1, 3)
    gap = np.asarray(contacts["gap"], dtype=float)
    point = np.asarray(contacts["point"], dtype=float).reshape(-1, 3)
    half = 0.5 * gap[:, None] * n
    p0, p = np.asarray(detected["position"], float), np.asarray(now["position"], float)
    turn = np.einsum("kij,klj->kil", np.asarray(now["rotation"], float), np.asarray(detected["rotation"], float))
    dtheta = 0.5 * np.stack([turn[:, 2, 1] - turn[:, 1, 2], turn[:, 0, 2] - turn[:, 2, 0],
                             turn[:, 1, 0] - turn[:, 0, 1]], axis=1)
    dp = p - p0

    def moved(i, x):  # the first-order motion of the point x of body i since detection
        return dp[i] + np.cross(dtheta[i], x - p0[i])

    def turned(i, x):  # the motion of the point x of body i with its whole turn
        r = x - p0[i]
        return dp[i] + np.einsum("kij,kj->ki", turn[i], r) - r

    # a round side carries its core, rho beyond its witness, with the body's whole turn, so its
    # witness stays under the core however the body turns
    rho_a, rho_b = contact_rounding(detected, contacts)
    y_a, y_b = point, point
    if anchored:
        y_a = np.asarray(contacts["anchor_a"], dtype=float).reshape(-1, 3)
        y_b = np.asarray(contacts["anchor_b"], dtype=float).reshape(-1, 3)
    moved_b = np.where((rho_b > 0.0)[:, None], turned(b, y_b + half + rho_b[:, None] * n), moved(b, y_b + half))
    moved_a = np.where((rho_a > 0.0)[:, None], turned(a, y_a - half - rho_a[:, None] * n), moved(a, y_a - half))
    out = dict(contacts)
    out["gap"] = gap + np.einsum("ki,ki->k", n, moved_b - moved_a)
    # a round side's anchor half the new gap beyond its witness, as a contact point is (its core is
    # taken from it); a flat side's stays its lever arm
    shift = 0.5 * (out["gap"] - gap)[:, None] * n
    shift_a, shift_b = np.where((rho_a > 0.0)[:, None], shift, 0.0), np.where((rho_b > 0.0)[:, None], shift, 0.0)
    out["anchor_a"], out["anchor_b"] = point + dp[a] + shift_a, point + dp[b] - shift_b
    out["point"] = 0.5 * (out["anchor_a"] + out["anchor_b"])
    # given lever arms (a recycled contact's) stay
    for key, i, moved_by in (("anchor_a", a, shift_a), ("anchor_b", b, -shift_b)):
        if key in contacts:
            out[key] = np.asarray(contacts[key], dtype=float).reshape(-1, 3) + dp[i] + moved_by
    return out


# A pair is collided again in a substep once its bodies' turns since the step's detection have
# moved their points more than TURN_REACH of its smaller inner radius; automatic substeps are short
# enough that each turns a pair by at most as much, at most TURN_SUBSTEPS of them per 1 / TURN_RATE s
# or TURN_SUBSTEP_FACTOR times the step's own count (``turn_budget``; the core's
# collision::kTurnReach, kTurnSubsteps, kTurnRate, kTurnSubstepFactor; docs/conventions.md, "Deep
# overlaps"); the soft step too, in runs of rows (``soft_runs``)
TURN_REACH = 0.25
TURN_SUBSTEPS = 16
TURN_RATE = 240.0
TURN_SUBSTEP_FACTOR = 4


def _turn_radii(snapshot):
    """Per body (N,): its bounding radius rho (m), 0 for a static body or a sphere (a sphere's
    contacts do not follow its turn); and its inner radius (m, infinity when unknown)."""
    rho = np.array([0.0 if b.get("static") or b["shape"]["type"] == "sphere" else bounding_radius(b["shape"])
                    for b in snapshot["bodies"]])
    inner = np.array([float(b.get("inner_radius", np.inf)) for b in snapshot["bodies"]])
    return rho, inner


def _turn_reach(detected, now):
    """Per body (N,): how far its turn between the two snapshots has moved its points, at most,
    sqrt(3 - tr(R R_0^T)) rho (= 2 sin(angle / 2) rho; 0 for a static body or a sphere), m; and
    its inner radius (``_turn_radii``)."""
    rho, inner = _turn_radii(detected)
    R0 = np.asarray(detected["rotation"], dtype=float).reshape(-1, 3, 3)
    R = np.asarray(now["rotation"], dtype=float).reshape(-1, 3, 3)
    return np.sqrt(np.maximum(0.0, 3.0 - np.einsum("kij,kij->k", R, R0))) * rho, inner


def _impact_levers(snapshot, contacts, closes, rho):
    """Per contact (K,): f = min(1, |(y - p) x n| / rho), the larger of its pair's bodies' (0 for a
    static or kinematic body or a sphere: rho 0 here), y the centroid of the closing points
    (``closes``, (K,) bool) of its pair's run in the list: how much of an impact's closing speed
    can turn a body (``turn_substeps``, soft step)."""
    a = np.asarray(contacts["body_a"], dtype=np.int64)
    b = np.asarray(contacts["body_b"], dtype=np.int64)
    n = np.asarray(contacts["normal"], dtype=float).reshape(-1, 3)
    y = np.asarray(contacts["point"], dtype=float).reshape(-1, 3)
    p = np.asarray(snapshot["position"], dtype=float).reshape(-1, 3)
    kinematic, _ = motion_flags(snapshot)
    turns = (rho > 0.0) & ~kinematic
    centroid = np.zeros((len(a), 3))
    start = 0
    for k in range(1, len(a) + 1):
        if k == len(a) or a[k] != a[start] or b[k] != b[start]:
            run = np.arange(start, k)[closes[start:k]]
            if len(run):
                total = np.zeros(3)
                for m in run:  # (summed in order, as the core)
                    total = total + y[m]
                centroid[start:k] = total / len(run)
            start = k

    def lever(i):
        arm = np.linalg.norm(np.cross(centroid - p[i], n), axis=1)
        return np.where(turns[i], np.minimum(1.0, arm / np.where(turns[i], rho[i], 1.0)), 0.0)

    return np.maximum(lever(a), lever(b))


def turn_substeps(snapshot, contacts, span):
    """The substeps ``span`` seconds take for the contacts' fast-turning bodies at the snapshot's
    angular velocities: the fewest that turn each contact's pair by at most TURN_REACH of its
    smaller inner radius, span (|omega_A| rho_A + |omega_B| rho_B + f u) / (TURN_REACH min(inner_A,
    inner_B)). u is the closing speed of its bodies' centres -n . (v_B - v_A) when it closes within
    the span (gap < span u), else 0 (a turn's share of the closing is in the sweep terms): an
    impact can set a body turning at about f u / rho. With the soft step, f = min(1, |(y - p) x n|
    / rho) at the centroid y of the pair's points that close within the span, the larger of its
    bodies' (0 for a static or kinematic body or a sphere; a pair's points are its run in the
    list); the PGS counts the whole u (f = 1: its hard landings sink less for it). A contact
    counts only when its pair can touch within the span, gap < span (|omega_A| rho_A + |omega_B|
    rho_B + u); 1 when none turns, at most 10**6."""
    a = np.asarray(contacts["body_a"], dtype=np.int64)
    b = np.asarray(contacts["body_b"], dtype=np.int64)
    if len(a) == 0:
        return 1
    rho, inner = _turn_radii(snapshot)
    v = np.asarray(snapshot["velocity"], dtype=float).reshape(-1, 3)
    n = np.asarray(contacts["normal"], dtype=float).reshape(-1, 3)
    gap = np.asarray(contacts["gap"], dtype=float)
    u = np.maximum(0.0, -np.einsum("ki,ki->k", n, v[b] - v[a]))  # the centres' (the turn's is the sweep's)
    closes = gap < span * u
    soft = solver_settings(snapshot)["solver"] == "soft"
    f = _impact_levers(snapshot, contacts, closes, rho) if soft else np.ones(len(a))
    omega = np.asarray(snapshot["angular_velocity"], dtype=float).reshape(-1, 3)
    sweep = np.linalg.norm(omega, axis=1) * rho
    s = sweep[a] + sweep[b]
    term = np.where(gap < span * (s + u), s + np.where(closes, f * u, 0.0), 0.0)  # pairs that can touch
    fastest = float(np.max(term / np.minimum(inner[a], inner[b])))
    return int(min(max(np.ceil(span * fastest / TURN_REACH - 1e-9), 1), 10**6))


def redetect_turned(contacts, carried, detected, now, dt, escaped=None):
    """The step's contacts in a substep: ``carried`` (carry_contacts's), but for the pairs whose
    bodies' turns since ``detected`` moved their points more than TURN_REACH of the pair's
    smaller inner radius (a turn from R_0 to R moves a point at rho by sqrt(3 - tr(R R_0^T)) rho
    at most), whose contacts are found again at ``now`` as a detection for a step of dt (what is
    left of the step) finds them, their anchors at their points; and, with ``escaped`` (N,) bool
    (``escaped_bodies``), the pairs of an escaped body that carry no contact, found at ``now``
    likewise (a pair the step's detection left out, or kept no point of, on the reach the
    escaped body has outrun). None when no pair has turned and no body escaped so far.

    Inputs: contacts dict (the step's, as detected), carried dict, two snapshots, dt s, escaped.
    Output: a contacts dict (pair order) with anchor_a, anchor_b, or None.
    """
    moved, inner = _turn_reach(detected, now)

    far = moved[:, None] + moved[None, :] > TURN_REACH * np.minimum(inner[:, None], inner[None, :])
    escaped = np.zeros(len(moved), dtype=bool) if escaped is None else np.asarray(escaped, dtype=bool)
    if not far.any() and not escaped.any():
        return None
    fresh = detect_contacts(now, dt)
    pair_of = {}  # (lower, higher) -> (contact indices of the carried list, of the fresh list)
    for name, c in (("carried", carried), ("fresh", fresh)):
        for k, (i, j) in enumerate(zip(c["body_a"], c["body_b"])):
            pair_of.setdefault((min(i, j), max(i, j)), {"carried": [], "fresh": []})[name].append(k)
    pick = []  # (list, index) in pair order
    for key in sorted(pair_of):
        lost = (escaped[key[0]] or escaped[key[1]]) and not pair_of[key]["carried"]
        name = "fresh" if far[key] or lost else "carried"
        pick += [(name, k) for k in pair_of[key][name]]
    anchors = {"carried": (np.asarray(carried["anchor_a"]), np.asarray(carried["anchor_b"])),
               "fresh": (fresh["point"], fresh["point"])}
    out = {}
    for field in ("body_a", "body_b", "point", "normal", "gap", "feature_a", "feature_b"):
        src = {"carried": np.asarray(carried[field]), "fresh": np.asarray(fresh[field])}
        out[field] = np.array([src[name][k] for name, k in pick], dtype=src["carried"].dtype).reshape(
            (len(pick),) + src["carried"].shape[1:])
    out["anchor_a"] = np.array([anchors[name][0][k] for name, k in pick], dtype=float).reshape(-1, 3)
    out["anchor_b"] = np.array([anchors[name][1][k] for name, k in pick], dtype=float).reshape(-1, 3)
    return out


def escaped_bodies(detected, now, dt):
    """Per body (N,) bool: a dynamic body (not kinematic) whose surface has moved further since
    ``detected`` than the step's detection reached for it: |p - p_0| plus its turn's reach
    (sqrt(3 - tr(R R_0^T)) rho, 0 for a sphere) above its speculative reach s_b for the step of dt
    (``speculative_reach``) and half the contact margin (what a pair's threshold, margin + s_A +
    s_B, grants each side). Such a body was set moving within the step (struck by a faster one,
    pulled by a joint): pairs the detection left out, as beyond its reach, may touch now.

    Inputs: two snapshots (the step's start after its impulses, and now), dt s (the whole step's).
    """
    kinematic, _ = motion_flags(detected)
    static = np.array([bool(b["static"]) for b in detected["bodies"]], dtype=bool)
    p0 = np.asarray(detected["position"], dtype=float).reshape(-1, 3)
    p = np.asarray(now["position"], dtype=float).reshape(-1, 3)
    moved = np.linalg.norm(p - p0, axis=1) + _turn_reach(detected, now)[0]
    margin = float((detected.get("settings") or {}).get("contact_margin", DEFAULT_CONTACT_MARGIN))
    return ~static & ~kinematic & (moved > speculative_reach(detected, dt) + 0.5 * margin)


def turn_budget(dt, n):
    """The most substeps the turning rule gives a step of dt whose own rule gives n (the core's
    World::turn_budget): TURN_SUBSTEPS per 1 / TURN_RATE s of the step (begun) or
    TURN_SUBSTEP_FACTOR n, whichever is more; a step takes at most half of them before its first
    substep, so that a body set turning by an impact leaves room to split the rest."""
    spans = int(min(max(np.ceil(dt * TURN_RATE - 1e-9), 1), 10**6))
    return max(TURN_SUBSTEPS * spans, TURN_SUBSTEP_FACTOR * n)


def _turned_contacts(contacts, detected, now):
    """Whether a pair of ``contacts`` has turned far between the two snapshots: its bodies' turns
    moved their points more than TURN_REACH of its smaller inner radius (as ``redetect_turned``)."""
    moved, inner = _turn_reach(detected, now)
    a = np.asarray(contacts["body_a"], dtype=np.int64)
    b = np.asarray(contacts["body_b"], dtype=np.int64)
    return bool(np.any(moved[a] + moved[b] > TURN_REACH * np.minimum(inner[a], inner[b])))


def soft_runs(snapshot, contacts, dt, n, most, ties=None):
    """The soft step of dt in n substeps (``soft.soft_step``), in runs of rows: after a substep k
    (but the last) of a run, with most > 0 (automatic substeps; at most ``most`` substeps in all),
    when a pair of the run's contacts has turned far since its rows were made (``_turned_contacts``)
    or the rest of the step, rest = (n - k - 1) h, wants more substeps for the contacts' turning
    and closing (``turn_substeps`` at now, capped at most - k - 1), the run ends; its contacts
    are carried to now (``carry_contacts``), the turned pairs found again (``redetect_turned``, for
    the rest of the step), and the rest runs on rows made anew, in the more substeps, warm started
    from the run's forces (its cache). The step's impulse per contact is summed over the runs by
    key (a contact found anew starts from 0); the rest of the info is the last run's.

    Returns (new_snapshot, info, flagged)."""
    settings = solver_settings(snapshot)
    h, done, start = dt / n, 0, snapshot  # done: the substeps of the runs before
    sums, flagged = {}, 0
    while True:
        decided = {}

        def cut(state, k):
            i = done + k  # the substep of the step
            rest = (n - i - 1) * h
            more = min(most - i - 1, turn_substeps(state, contacts, rest)) if n < most else 0
            turned = _turned_contacts(contacts, start, state)
            if not turned and more <= n - i - 1:
                return False
            decided.update(i=i, rest=rest, more=more, turned=turned)
            return True

        state, info = soft_step(start, contacts, dt, n - done, ties if done == 0 else None, h=h,
                                cut=cut if most > 0 else None)
        flagged += (not info["converged"]) and info["max_penetration_velocity"] > settings["warn_velocity"]
        impulse = np.asarray(info["impulse"], dtype=float) + np.array(
            [sums.get(key, 0.0) for key in _keys(contacts)], dtype=float)
        if not decided:
            info["impulse"], info["substeps"] = impulse, n
            return state, info, flagged
        sums = dict(zip(_keys(contacts), impulse))
        carried = carry_contacts(contacts, start, state, anchored=done > 0)
        fresh = redetect_turned(contacts, carried, start, state, decided["rest"]) if decided["turned"] else None
        contacts = fresh if fresh is not None else carried
        if decided["more"] > n - decided["i"] - 1:
            h, n = decided["rest"] / decided["more"], decided["i"] + 1 + decided["more"]
        done, start = decided["i"] + 1, state


def _keys(contacts):
    return list(zip(np.asarray(contacts["body_a"]).tolist(), np.asarray(contacts["body_b"]).tolist(),
                    np.asarray(contacts["feature_a"]).tolist(), np.asarray(contacts["feature_b"]).tolist()))


def step(snapshot, dt, contacts=None, ties=None):
    """Advance the snapshot by one step of dt seconds: contacts detected once (reaching as far as
    the whole step moves), then n substeps of dt / n (``substeps``, or automatic), each solving the
    step's contacts carried along by the motion since detection (``carry_contacts``); the info is
    the last substep's but for impulse, the whole step's (summed over the substeps). With
    settings["solver"] == "soft", the soft step (``soft.soft_step``).

    Inputs: snapshot dict (settings, bodies with friction, restitution and spinning_friction,
            optional cache; missing
            keys take the documented defaults), dt s, contacts dict (the step's; detected from the
            current state when None), ties (the soft step only: ``soft.soft_step``).
    Outputs: (new_snapshot, info)
        new_snapshot: a copy with position (N, 3), rotation (N, 3, 3), velocity (N, 3),
                      angular_velocity (N, 3) and cache (the warm start of the next step) updated;
                      the input is not modified.
        info: contacts (the dict used); per contact (K): alpha N (after restitution),
              impulse = sum over the substeps of h alpha N s (h = dt / n; the step's whole normal
              impulse, so impulse / dt is the mean normal force over the step), friction (K, 3) N on B, force (K, 3) = alpha n + friction N,
              spin_torque N m (torsional friction on B about n), normal_velocity m/s, slip (K, 3)
              m/s, mu, restitution, mu_spin m; per body: body_force,
              body_torque (N, 3) (N, N m about the com, world); iterations, restitution_iterations,
              position_iterations, converged, and the certificate: residual (m/s),
              max_alpha_negative, max_penetration_velocity, max_complementarity,
              max_cone_violation, max_dissipation_violation, max_overlap; flagged: how many of
              the substeps ended unconverged with max_penetration_velocity > warn_velocity (the
              Python layer's SolverWarning); with joints: joint_force, joint_torque (J, 3) N, N m
              on B (the last substep's; zero for a joint that broke after the step) and
              joint_breaks (the indices of the joints that broke after it), and new_snapshot's
              joints with their alpha, force, torque and broken.
    """
    settings = solver_settings(snapshot)
    n = substep_count(settings, dt, any(not j.get("broken", False) for j in snapshot.get("joints", ())))
    # 0. pending impulses change the velocities first (before the contacts look ahead)
    snapshot = apply_impulses(snapshot)
    if contacts is None:
        contacts = detect_contacts(snapshot, dt)
    # automatic substeps are short enough for the turning bodies, at most turn_budget(dt, n) in
    # all, half of them before the first
    automatic, most = settings["substeps"] < 1, turn_budget(dt, n)
    if automatic:
        n = max(n, min(most // 2, turn_substeps(snapshot, contacts, dt)))
    if settings["solver"] == "soft":
        # the soft step: its substeps share one set of rows until a pair turns far or the rest of
        # the step wants shorter substeps (soft_runs); flagged once per run of rows
        state, info, flagged = soft_runs(snapshot, contacts, dt, n, most if automatic else 0, ties)
    else:
        h, elapsed = dt / n, 0.0
        state, info, flagged, impulse, last, redetected, k = snapshot, None, 0, 0.0, None, False, -1
        while k + 1 < n:
            k += 1
            now = contacts
            if k > 0:
                now = carry_contacts(contacts, snapshot, state)
                # (pairs of a body set moving past its reach within the step: found now too)
                fresh = redetect_turned(contacts, now, snapshot, state, dt - elapsed,
                                        escaped_bodies(snapshot, state, dt))  # for the rest of the step
                # the step's impulse per contact, summed over its substeps: by key once a substep's
                # contacts are not the carried ones (a point found anew starts from 0)
                if fresh is not None or redetected:
                    sums = dict(zip(_keys(last), impulse))
                    now = fresh if fresh is not None else now
                    impulse = np.array([sums.get(key, 0.0) for key in _keys(now)], dtype=float)
                redetected = fresh is not None
            state, info = step_once(state, h, now)
            impulse = impulse + np.asarray(info["impulse"], dtype=float)  # the step's: summed over its substeps
            last, elapsed = now, elapsed + h
            # the substeps the Python layer warns about: unconverged and approaching too fast
            flagged += (not info["converged"]) and info["max_penetration_velocity"] > settings["warn_velocity"]
            # a body set turning fast by this substep's contacts: the rest of the step in shorter substeps
            if automatic and k + 1 < n and n < most:
                rest = (n - k - 1) * h
                more = min(most - k - 1, turn_substeps(state, now, rest))
                if more > n - k - 1:
                    h, n = rest / more, k + 1 + more
        info["impulse"] = impulse
    info["flagged"] = int(flagged)
    # joints pulled harder than they bear break, after the whole step (World::break_joints)
    if state.get("joints"):
        info["joint_breaks"] = break_joints(state["joints"])
        for k in info["joint_breaks"]:
            info["joint_force"][k], info["joint_torque"][k] = 0.0, 0.0
    # the one-step force and torque are spent
    for key in ("step_force", "step_torque"):
        if key in state:
            state[key] = np.zeros_like(np.asarray(state[key], dtype=float))
    return state, info


def rollout(snapshot, dt, steps):
    """Run ``steps`` steps from the snapshot.

    Output dict (index k = the state after k steps, k = 0 is the initial state):
        position (steps + 1, N, 3), rotation (steps + 1, N, 3, 3), velocity (steps + 1, N, 3),
        angular_velocity (steps + 1, N, 3);
        per step (index k = step k + 1): num_contacts (steps,), iterations (steps,),
        converged (steps,) bool, residual (steps,); infos (list of each step's info);
        snapshot: the final snapshot.
    """
    state = copy_snapshot(snapshot)
    keys = ("position", "rotation", "velocity", "angular_velocity")
    history = {key: [state[key]] for key in keys}
    infos = []
    for _ in range(steps):
        state, info = step(state, dt)
        for key in keys:
            history[key].append(state[key])
        infos.append(info)
    out = {key: np.array(history[key]) for key in keys}
    out["num_contacts"] = np.array([len(info["alpha"]) for info in infos], dtype=np.int64)
    out["iterations"] = np.array([info["iterations"] for info in infos], dtype=np.int64)
    out["converged"] = np.array([info["converged"] for info in infos], dtype=bool)
    out["residual"] = np.array([info["residual"] for info in infos])
    out["infos"] = infos
    out["snapshot"] = state
    return out
