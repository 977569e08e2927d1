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
joints' rows in both schedules). After the step, joints pulled past their break_force or
break_torque break (``joints.break_joints``).
"""

import copy

import numpy as np

from .contacts import detect_contacts
from .joints import break_joints
from .rigid import apply_impulses, integrate, unconstrained_velocity
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


def carry_contacts(contacts, detected, now):
    """The contacts detected at snapshot ``detected`` carried to snapshot ``now`` by the motion of
    their bodies (a substep), to first order, as the velocity constraint linearises it: with each
    body's displacement dp = p - p_0 and turn dtheta = vee of the skew part of R R_0^T, and the
    witness points w_A = y - gap/2 n, w_B = y + gap/2 n,
    gap <- gap + n . ((dp_B + dtheta_B x (w_B - p_B0)) - (dp_A + dtheta_A x (w_A - p_A0))),
    but on a round side (``soft.contact_rounding``: rho_X > 0) the core c_B = w_B + rho_B n (c_A =
    w_A - rho_A n) moved with the body's whole turn, dp_X + (R_X R_X0^T - I) (c_X - p_X0), in place
    of its term (a spinning body's witness stays under its core). The normal stays; the lever arms
    stay as detected: anchor_X = y + dp_X (or, when the contacts carry anchor_X, anchor_X + dp_X),
    where the solver applies the force on X; y <- (anchor_a + anchor_b) / 2.

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
    moved_b = np.where((rho_b > 0.0)[:, None], turned(b, point + half + rho_b[:, None] * n), moved(b, point + half))
    moved_a = np.where((rho_a > 0.0)[:, None], turned(a, point - half - rho_a[:, None] * n), moved(a, point - half))
    out = dict(contacts)
    out["gap"] = gap + np.einsum("ki,ki->k", n, moved_b - moved_a)
    out["anchor_a"], out["anchor_b"] = point + dp[a], point + dp[b]
    out["point"] = 0.5 * (out["anchor_a"] + out["anchor_b"])
    for key, i in (("anchor_a", a), ("anchor_b", b)):  # given lever arms (a recycled contact's) stay
        if key in contacts:
            out[key] = np.asarray(contacts[key], dtype=float).reshape(-1, 3) + dp[i]
    return out


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
    if settings["solver"] == "soft":
        # the soft step: its substeps share one set of rows; flagged once, at its end
        state, info = soft_step(snapshot, contacts, dt, n, ties)
        flagged = (not info["converged"]) and info["max_penetration_velocity"] > settings["warn_velocity"]
    else:
        state, info, flagged, impulse = snapshot, None, 0, 0.0
        for k in range(n):
            state, info = step_once(state, dt / n, contacts if k == 0 else carry_contacts(contacts, snapshot, state))
            impulse = impulse + np.asarray(info["impulse"], dtype=float)  # the step's: summed over its substeps
            # the substeps the Python layer warns about: unconverged and approaching too fast
            flagged += (not info["converged"]) and info["max_penetration_velocity"] > settings["warn_velocity"]
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
