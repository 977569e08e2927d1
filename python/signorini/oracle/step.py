"""One full step and a rollout (docs/conventions.md, "One step (dt)"):
    1. contacts from the current state                   (detect_contacts)
    2. unconstrained velocities, gyroscopic option        (unconstrained_velocity)
    3. the staged contact solve a-f                       (solver.solve_contacts)
    4. integrate the poses with q_dot_pos + q_p; keep the velocities after restitution (integrate)
with n substeps (``substeps``, or automatic: the fewest of at most 1/240 s) running all of it n
times with dt / n.
"""

import copy

import numpy as np

from .contacts import detect_contacts
from .rigid import integrate, unconstrained_velocity
from .solver import solve_contacts, solver_settings, substep_count

# the per-contact and per-step figures of the solve that ``step`` reports in its info
INFO_KEYS = (
    "alpha", "impulse", "friction", "force", "normal_velocity", "slip", "mu", "restitution",
    "body_force", "body_torque", "iterations", "restitution_iterations", "position_iterations",
    "converged", "residual", "max_alpha_negative", "max_penetration_velocity",
    "max_complementarity", "max_cone_violation", "max_dissipation_violation", "max_overlap",
)


def copy_snapshot(snapshot):
    """Deep copy of a snapshot dict, state arrays as float NumPy arrays."""
    new = copy.deepcopy(snapshot)
    for key in ("position", "velocity", "angular_velocity", "force", "torque"):
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
    info = {"contacts": contacts}
    info.update({key: result[key] for key in INFO_KEYS})
    return new, info


def step(snapshot, dt, contacts=None):
    """Advance the snapshot by one step of dt seconds (``substeps`` = n steps of dt / n, contacts
    re-detected each time; the info is the last substep's).

    Inputs: snapshot dict (settings, bodies with friction and restitution, optional cache; missing
            keys take the documented defaults), dt s, contacts dict (detected from the current state
            when None; only with substeps = 1, else ValueError).
    Outputs: (new_snapshot, info)
        new_snapshot: a copy with position (N, 3), rotation (N, 3, 3), velocity (N, 3),
                      angular_velocity (N, 3) and cache (the warm start of the next step) updated;
                      the input is not modified.
        info: contacts (the dict used); per contact (K): alpha N (after restitution),
              impulse = dt alpha N s, friction (K, 3) N on B, force (K, 3) = alpha n + friction N,
              normal_velocity m/s, slip (K, 3) m/s, mu, restitution; per body: body_force,
              body_torque (N, 3) (N, N m about the com, world); iterations, restitution_iterations,
              position_iterations, converged, and the certificate: residual (m/s),
              max_alpha_negative, max_penetration_velocity, max_complementarity,
              max_cone_violation, max_dissipation_violation, max_overlap; flagged: how many of
              the substeps ended unconverged with max_penetration_velocity > warn_velocity (the
              Python layer's SolverWarning).
    """
    settings = solver_settings(snapshot)
    n = substep_count(settings, dt)
    if contacts is not None and n != 1:
        raise ValueError(f"step: contacts can be given only with substeps = 1, got substeps = {n}")
    state, info, flagged = snapshot, None, 0
    for _ in range(n):
        state, info = step_once(state, dt / n, contacts)
        # the substeps the Python layer warns about: unconverged and approaching too fast
        flagged += (not info["converged"]) and info["max_penetration_velocity"] > settings["warn_velocity"]
    info["flagged"] = int(flagged)
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
