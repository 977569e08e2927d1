"""One full step and a rollout (docs/conventions.md, "One step"):
    1. contacts from the current state       (detect_contacts)
    2. unconstrained velocities              (unconstrained_velocity)
    3. contact forces by PGS                 (pgs)
    4. integrate with the new velocities     (integrate)
"""

import copy

import numpy as np

from .contacts import detect_contacts
from .pgs import pgs
from .rigid import integrate, unconstrained_velocity


def copy_snapshot(snapshot):
    """Deep copy of a snapshot dict, state arrays as float NumPy arrays."""
    new = copy.deepcopy(snapshot)
    for key in ("position", "velocity", "angular_velocity", "force", "torque"):
        new[key] = np.array(snapshot[key], dtype=float).reshape(-1, 3)
    new["rotation"] = np.array(snapshot["rotation"], dtype=float).reshape(-1, 3, 3)
    return new


def step(snapshot, dt, contacts=None):
    """Advance the snapshot by one step of dt seconds.

    Inputs: snapshot dict, dt s, contacts dict (detected from the current state when None).
    Outputs: (new_snapshot, info)
        new_snapshot: a copy with position (N, 3), rotation (N, 3, 3), velocity (N, 3),
                      angular_velocity (N, 3) updated; the input is not modified.
        info: contacts (the dict used), alpha (K,) N, impulse = dt alpha (K,) N s,
              iterations, converged, residual (m/s), as reported by ``pgs``.
    """
    # 1. contacts from the current state
    if contacts is None:
        contacts = detect_contacts(snapshot, dt)

    # 2. unconstrained velocities
    v_star, omega_star = unconstrained_velocity(snapshot, dt)

    # 3. contact forces and the velocities after contacts
    result = pgs(snapshot, contacts, v_star, omega_star, dt)

    # 4. integrate positions and rotations with the new velocities
    position, rotation = integrate(snapshot, result["velocity"], result["angular_velocity"], dt)

    new = copy_snapshot(snapshot)
    new["position"] = position
    new["rotation"] = rotation
    new["velocity"] = result["velocity"]
    new["angular_velocity"] = result["angular_velocity"]
    info = {
        "contacts": contacts,
        "alpha": result["alpha"],
        "impulse": dt * result["alpha"],
        "iterations": result["iterations"],
        "converged": result["converged"],
        "residual": result["residual"],
    }
    return new, info


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
