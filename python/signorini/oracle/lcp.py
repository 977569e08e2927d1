"""The contact problem as a linear complementarity problem (LCP), solved exactly.

Stacking the notes' conditions for all contacts (alpha_i >= 0, delta_i alpha_i + gamma_i >= 0,
complementary) gives the LCP
    w = A alpha + b,  alpha >= 0,  w >= 0,  alpha . w = 0
with the Delassus matrix A = dt G M^-1 G^T (K, K), s/kg, and b = G q_dot* + b_bias (K,), m/s,
where row i of G (K, 6N) holds g_i^A in body A's columns and g_i^B in body B's.
A_ii = delta_i, and w_i is the relative normal velocity plus bias after the step.
PGS is Gauss-Seidel on this LCP, so it converges to its solution.  With b_bias = max(gap, 0) / dt
(``contact_lcp(..., b_bias="speculative")``) it is also the problem of the staged solver
(``solver``) when friction and restitution are 0: its friction rows then stay at zero.
"""

from itertools import combinations

import numpy as np

from .pgs import bias, contact_rows
from .rigid import inverse_mass_blocks
from .solver import speculative_bias

# enumeration visits 2^K active sets
LCP_MAX_SIZE = 12


def contact_jacobian(snapshot, contacts):
    """G (K, 6N): row i is g_i^A in body A's six columns and g_i^B in body B's;
    the columns of body n are 6n..6n+5 in the (omega, p_dot) layout."""
    A = np.asarray(contacts["body_a"], dtype=np.int64)
    B = np.asarray(contacts["body_b"], dtype=np.int64)
    N = len(snapshot["bodies"])
    g_A, g_B = contact_rows(snapshot, contacts)
    G = np.zeros((len(A), 6 * N))
    for i in range(len(A)):
        G[i, 6 * A[i]:6 * A[i] + 6] += g_A[i]
        G[i, 6 * B[i]:6 * B[i] + 6] += g_B[i]
    return G


def inverse_mass_matrix(snapshot):
    """M^-1 (6N, 6N), block diagonal of the per-body diag(R I_body^-1 R^T, m^-1 I3)."""
    blocks = inverse_mass_blocks(snapshot)
    N = len(blocks)
    M_inv = np.zeros((6 * N, 6 * N))
    for n in range(N):
        M_inv[6 * n:6 * n + 6, 6 * n:6 * n + 6] = blocks[n]
    return M_inv


def contact_lcp(snapshot, contacts, v_star, omega_star, dt, b_bias=None):
    """The LCP of one step: returns (A (K, K) s/kg, b (K,) m/s) with
    A = dt G M^-1 G^T and b = G q_dot* + b_bias.

    b_bias (K,) m/s: None = the lecture's PGS rule (``pgs.bias``: gap / dt, erp for overlap), the
    problem ``pgs`` solves; ``"speculative"`` = max(gap, 0) / dt (``solver.speculative_bias``), the
    normal rows of the staged solver with friction 0 and no restitution; or an array.
    """
    G = contact_jacobian(snapshot, contacts)
    M_inv = inverse_mass_matrix(snapshot)
    q_dot_star = np.hstack([np.asarray(omega_star, dtype=float).reshape(-1, 3),
                            np.asarray(v_star, dtype=float).reshape(-1, 3)]).reshape(-1)
    A = dt * G @ M_inv @ G.T
    if b_bias is None:
        b_bias = bias(contacts, float(snapshot["settings"]["erp"]), dt)
    elif isinstance(b_bias, str):
        if b_bias != "speculative":
            raise ValueError(f"contact_lcp: b_bias must be None, 'speculative' or an array, got {b_bias!r}")
        b_bias = speculative_bias(contacts, dt)
    b = G @ q_dot_star + np.asarray(b_bias, dtype=float).reshape(-1)
    return A, b


def velocities_from_alpha(snapshot, contacts, v_star, omega_star, alpha, dt):
    """q_dot = q_dot* + dt M^-1 G^T alpha, returned as (velocity (N, 3), angular_velocity (N, 3))."""
    G = contact_jacobian(snapshot, contacts)
    M_inv = inverse_mass_matrix(snapshot)
    q_dot = np.hstack([np.asarray(omega_star, dtype=float).reshape(-1, 3),
                       np.asarray(v_star, dtype=float).reshape(-1, 3)]).reshape(-1)
    q_dot = (q_dot + dt * M_inv @ G.T @ np.asarray(alpha, dtype=float)).reshape(-1, 6)
    return q_dot[:, 3:], q_dot[:, :3]


def lcp_solve(A, b, tol=None):
    """Exact solution of  w = A x + b, x >= 0, w >= 0, x . w = 0  by enumerating active sets.

    Inputs: A (K, K) symmetric positive semi-definite, b (K,), K <= 12.
    For each active set S (smallest first) solve A_SS x_S = -b_S (least squares, so a singular
    A_SS, e.g. four coplanar corners, still gives a candidate), set x = 0 off S, and accept it
    when x >= -tol, w >= -tol and A_SS x_S + b_S = 0 within tol.
    tol defaults to 1e-10 (max|A| + max|b|) (a relative rounding allowance).
    Outputs: x (K,), w (K,).  Raises ValueError when K > 12 or no active set works.
    For PSD A, w (and A x) is the same for every solution, x is unique when A is definite.
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float)
    K = len(b)
    if K > LCP_MAX_SIZE:
        raise ValueError(f"lcp_solve enumerates 2^K active sets; K = {K} > {LCP_MAX_SIZE}")
    if K == 0:
        return np.zeros(0), np.zeros(0)
    if tol is None:
        tol = 1e-10 * (np.max(np.abs(A)) + np.max(np.abs(b)))
    for size in range(K + 1):
        for S in combinations(range(K), size):
            S = list(S)
            x = np.zeros(K)
            if S:
                x[S] = np.linalg.lstsq(A[np.ix_(S, S)], -b[S], rcond=None)[0]
            w = A @ x + b
            if np.all(x >= -tol) and np.all(w >= -tol) and np.all(np.abs(w[S]) <= tol):
                x = np.maximum(x, 0.0)
                return x, A @ x + b
    raise ValueError("no active set solves the LCP (A not PSD, or the LCP is infeasible)")
