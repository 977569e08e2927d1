"""Projected Gauss-Seidel on the Signorini conditions (lecture notes, "Projected
Gauss-Seidel"; docs/conventions.md, step 3).

For contact i between bodies A and B at point y_i with normal n_i (A towards B):
    g_i^A = -J_A(y_i)^T n_i,   g_i^B = J_B(y_i)^T n_i                       (6,) each
    delta_i = dt (g_B^T M_B^-1 g_B + g_A^T M_A^-1 g_A)                        s/kg
    q_dot = q_dot* + dt sum_j alpha_j M^-1 g_j                                (kept up to date)
    gamma_i = g_B^T q_dot_B + g_A^T q_dot_A - delta_i alpha_i + b_i           m/s
    b_i = gap_i / dt if gap_i >= 0 else erp gap_i / dt                        m/s
    alpha_i <- max(-gamma_i / delta_i, 0)                                     N
alpha_i is a force (N): the contact impulse is dt alpha_i (N s).
"""

import numpy as np

from .rigid import inverse_mass_blocks


def contact_rows(snapshot, contacts):
    """g_i^A and g_i^B of every contact, (K, 6) each, in the (omega, p_dot) layout.

    With J(y)^T n = ((y - p) x n, n) (``jacobian``):
        g_i^A = -J_A(y_i)^T n_i = -((y_i - p_A) x n_i, n_i)
        g_i^B =  J_B(y_i)^T n_i =  ((y_i - p_B) x n_i, n_i)
    """
    p = np.asarray(snapshot["position"], dtype=float).reshape(-1, 3)
    A = np.asarray(contacts["body_a"], dtype=np.int64)
    B = np.asarray(contacts["body_b"], dtype=np.int64)
    y = np.asarray(contacts["point"], dtype=float).reshape(-1, 3)
    n = np.asarray(contacts["normal"], dtype=float).reshape(-1, 3)
    g_A = -np.hstack([np.cross(y - p[A], n), n])
    g_B = np.hstack([np.cross(y - p[B], n), n])
    return g_A, g_B


def bias(contacts, erp, dt):
    """b_i = gap_i / dt for gap_i >= 0 (speculative), erp gap_i / dt for overlap; (K,) m/s."""
    gap = np.asarray(contacts["gap"], dtype=float)
    return np.where(gap >= 0.0, gap / dt, erp * gap / dt)


def pgs(snapshot, contacts, v_star, omega_star, dt):
    """Solve for the contact forces alpha by projected Gauss-Seidel.

    Inputs: snapshot (settings erp, tolerance, max_iterations are used), contacts dict (K),
            v_star, omega_star (N, 3) unconstrained velocities, dt s.
    Sweeps run in contact order from alpha = 0 until max_i delta_i |alpha_new - alpha_old|
    <= tolerance (m/s) or max_iterations sweeps.
    Output dict:
        alpha (K,) N, velocity (N, 3) m/s, angular_velocity (N, 3) rad/s (after contacts),
        iterations (sweeps used), converged (bool),
        residual max_i |min(delta_i alpha_i, w_i)|, w_i = g_B^T q_dot_B + g_A^T q_dot_A + b_i (m/s),
        delta (K,) s/kg, gamma (K,) m/s as computed in the last sweep.
    Static bodies have M^-1 = 0 and never move.
    """
    settings = snapshot["settings"]
    erp = float(settings["erp"])
    tolerance = float(settings["tolerance"])
    max_iterations = int(settings["max_iterations"])

    A = np.asarray(contacts["body_a"], dtype=np.int64)
    B = np.asarray(contacts["body_b"], dtype=np.int64)
    K = len(A)

    # q_dot = (omega, p_dot) per body, starting from the unconstrained velocities
    q_dot = np.hstack([np.asarray(omega_star, dtype=float).reshape(-1, 3),
                       np.asarray(v_star, dtype=float).reshape(-1, 3)])

    # per-contact constants: g, dt M^-1 g (the velocity change per unit alpha), delta, b
    M_inv = inverse_mass_blocks(snapshot)
    g_A, g_B = contact_rows(snapshot, contacts)
    M_inv_g_A = np.einsum("kij,kj->ki", M_inv[A], g_A)
    M_inv_g_B = np.einsum("kij,kj->ki", M_inv[B], g_B)
    delta = dt * (np.einsum("ki,ki->k", g_B, M_inv_g_B) + np.einsum("ki,ki->k", g_A, M_inv_g_A))
    dq_A, dq_B = dt * M_inv_g_A, dt * M_inv_g_B
    b = bias(contacts, erp, dt)

    # the sweep reads and writes q_dot_A, q_dot_B of contact i through these row views
    q_dot_A = [q_dot[a] for a in A.tolist()]
    q_dot_B = [q_dot[b_] for b_ in B.tolist()]
    # (plain Python floats in the sweep: scalar NumPy indexing is slow)
    delta, b = delta.tolist(), b.tolist()
    alpha = [0.0] * K
    gamma = [0.0] * K
    iterations, converged = 0, K == 0
    while not converged and iterations < max_iterations:
        iterations += 1
        change = 0.0
        for i in range(K):
            # gamma_i: relative normal velocity with every contact but i, plus the bias
            gamma[i] = (g_B[i].dot(q_dot_B[i]) + g_A[i].dot(q_dot_A[i])
                        - delta[i] * alpha[i] + b[i])
            alpha_new = max(-gamma[i] / delta[i], 0.0)
            # apply the change of force to both bodies
            d_alpha = alpha_new - alpha[i]
            q_dot_A[i] += d_alpha * dq_A[i]
            q_dot_B[i] += d_alpha * dq_B[i]
            alpha[i] = alpha_new
            change = max(change, delta[i] * abs(d_alpha))
        converged = change <= tolerance
    alpha, gamma, delta, b = np.array(alpha), np.array(gamma), np.array(delta), np.array(b)

    # residual of the complementarity conditions at the final velocities
    w = np.einsum("ki,ki->k", g_B, q_dot[B]) + np.einsum("ki,ki->k", g_A, q_dot[A]) + b
    residual = float(np.max(np.abs(np.minimum(delta * alpha, w)))) if K else 0.0

    return {
        "alpha": alpha,
        "velocity": q_dot[:, 3:].copy(),
        "angular_velocity": q_dot[:, :3].copy(),
        "iterations": iterations,
        "converged": bool(converged),
        "residual": residual,
        "delta": delta,
        "gamma": gamma,
    }
