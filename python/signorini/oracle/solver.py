"""The staged contact solve of one step (docs/conventions.md, "Materials", "One step (dt)"
item 3, "The Signorini certificate"), written from the spec in the core's order of operations:

    a. prepare_rows      rows (normal, t1, t2 per contact; a spin row for a contact alone in its
                         body pair with spinning friction), delta, bias b, mu, e, mu_spin, u
    b. warm_start        the previous step's forces for contacts with the same key, applied
    c. iterate           projected Gauss-Seidel sweeps over all rows (normal, then friction, then spin)
    d. restitution       Newton's law on the normal rows of the contacts that hit fast
    e. position_pass     split impulse: pseudo-velocities q_p that remove overlaps beyond the
                         slop (never kept as velocity)
    f. store, certificate  forces per contact and per body, the next cache, the certificate
    solve_contacts       all of them in order

Rows.  Contact i (bodies A, B, point y_i, normal n_i from A to B) gives rows 3i (direction
d = n_i), 3i + 1 (t1_i) and 3i + 2 (t2_i).  With r_X = y_i - p_X at the start of the step:
    J_A = -(r_A x d, d),  J_B = (r_B x d, d)           (6,) each, (omega, p_dot) layout
    delta = dt (J_A . M_A^-1 J_A + J_B . M_B^-1 J_B)    s/kg
    J q_dot = J_B . q_dot_B + J_A . q_dot_A            m/s
alpha of a row is a force (N); a change d_alpha moves q_dot_X += dt d_alpha M_X^-1 J_X.
Velocities are kept per body as q_dot (N, 6) = (omega, p_dot), world; static bodies have
M^-1 = 0 and are never moved (they are skipped, not given 0 * change).

Spin rows (torsional friction).  A contact that is the only one of its body pair (its neighbours
in the contact list, which holds a pair's contacts together, belong to other pairs) with
mu_spin = max(mu_spin_A, mu_spin_B) > 0 (m) also gets an angular-only row about its normal:
    J_A = (-n, 0),  J_B = (n, 0),  J q_dot = n . (omega_B - omega_A)   rad/s
    delta = dt (n . I_A^-1 n + n . I_B^-1 n)                           s/(kg m^2)
whose unknown alpha_spin is a torque on B about n (N m; A gets the opposite), in
[-mu_spin alpha_n, mu_spin alpha_n].  Its arrays are per contact (K), unused where ``spin`` is
False, and its torques a separate (K,) array ``alpha_spin`` (0 where there is no row).  A pair with
several points resists spin through the friction at its separate points and gets none.

A row whose delta is not > 0 (both bodies static: the narrow phase never makes one) is
skipped by every stage and keeps alpha = 0.

One departure from the conventions' text: the "cone" friction update scales both tangent rows
of a contact by one delta_t = max(delta_1, delta_2) instead of each by its own delta_k, in
``iterate`` and in the certificate's residual (the reason is in ``iterate``).
"""

import numpy as np

from .joints import (joint_position_pass, predict_drift, prepare_joints, store_joints, sweep_joints,
                     touching_bodies, warm_start_joints)

from .rigid import GYROSCOPIC_DEFAULT, GYROSCOPIC_OPTIONS, body_arrays, inverse_mass_blocks, motion_flags

# the documented defaults (conventions, last paragraph); a snapshot without a key uses these
DEFAULT_SETTINGS = {
    "contact_margin": 0.005,        # m
    "erp": 0.2,                     # fraction of an overlap removed per step
    "tolerance": 1e-6,              # m/s
    "max_iterations": 30,           # sweeps per stage
    "slop": 0.001,                  # m, overlap the position pass leaves alone
    "max_push_velocity": 1.0,       # m/s
    "restitution_threshold": 0.5,   # m/s
    "friction_cone": "pyramid",
    "gyroscopic": GYROSCOPIC_DEFAULT,
    "warm_start": True,
    "substeps": 0,                  # 0: automatic, the fewest substeps of at most AUTO_SUBSTEP
    "warn_velocity": 1.0,           # m/s
    # which solver a step runs: "pgs" (this module) or "soft" (the soft step, ``soft``), and the
    # soft step's settings
    "solver": "pgs",
    "contact_hertz": 30.0,          # Hz, a contact spring's natural frequency
    "damping_ratio": 10.0,          # the spring's damping ratio zeta
    "soft_iterations": 1,           # sweeps with the soft bias per substep
    "relax_iterations": 1,          # rigid sweeps per substep, after the poses move
    "joint_hertz": 240.0,           # Hz, a joint spring's natural frequency (the soft step)
    "joint_damping_ratio": 2.0,     # its damping ratio
}
# a contact's slop is at most this fraction of the smaller inner radius of its bodies (a ball each
# body's shape contains, "inner_radius" of the snapshot's body dicts; infinity when absent)
SLOP_INNER_FRACTION = 0.2
AUTO_SUBSTEP = 1.0 / 960.0         # s, the longest automatic substep of the PGS
SOFT_AUTO_SUBSTEP = 1.0 / 240.0    # s, the longest automatic substep of the soft step
# a spring (a contact's or a joint's) is at most this fraction of the substep rate 1 / h (Hz per
# Hz): stiffer springs than the substep can resolve only add energy (Catto, "Solver2D"; Box2D v3
# uses 0.25)
MAX_HERTZ_PER_RATE = 0.25
SOLVERS = ("pgs", "soft")
FRICTION_CONES = ("pyramid", "cone")
DEFAULT_FRICTION = 0.5
DEFAULT_RESTITUTION = 0.0
DEFAULT_SPINNING_FRICTION = 0.0    # m
# a contact slides (for max_dissipation_violation) when its slip speed exceeds this, m/s
SLIDING_SPEED = 1e-3
CACHE_KEYS = ("body_a", "body_b", "feature_a", "feature_b", "alpha", "friction", "spin")


# --------------------------------------------------------------------------- inputs

def solver_settings(snapshot):
    """The snapshot's settings with the documented defaults for missing keys, checked.

    Output: dict with every key of ``DEFAULT_SETTINGS``, numbers as float / int / bool.
    Raises ValueError for an unknown friction_cone, gyroscopic or solver, substeps < 0, and for
    the soft step's settings out of range (contact_hertz > 0, damping_ratio >= 0, joint_hertz > 0,
    joint_damping_ratio >= 0, soft_iterations >= 1, relax_iterations >= 0).
    """
    given = snapshot.get("settings") or {}
    s = {key: given.get(key, default) for key, default in DEFAULT_SETTINGS.items()}
    for key in ("contact_margin", "erp", "tolerance", "slop", "max_push_velocity",
                "restitution_threshold", "warn_velocity", "contact_hertz", "damping_ratio", "joint_hertz",
                "joint_damping_ratio"):
        s[key] = float(s[key])
    for key in ("max_iterations", "substeps", "soft_iterations", "relax_iterations"):
        s[key] = int(s[key])
    s["warm_start"] = bool(s["warm_start"])
    if s["solver"] not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {s['solver']!r}")
    if not (np.isfinite(s["contact_hertz"]) and s["contact_hertz"] > 0.0):
        raise ValueError(f"contact_hertz must be finite and > 0, got {s['contact_hertz']}")
    if not (np.isfinite(s["damping_ratio"]) and s["damping_ratio"] >= 0.0):
        raise ValueError(f"damping_ratio must be finite and >= 0, got {s['damping_ratio']}")
    if not (np.isfinite(s["joint_hertz"]) and s["joint_hertz"] > 0.0):
        raise ValueError(f"joint_hertz must be finite and > 0, got {s['joint_hertz']}")
    if not (np.isfinite(s["joint_damping_ratio"]) and s["joint_damping_ratio"] >= 0.0):
        raise ValueError(f"joint_damping_ratio must be finite and >= 0, got {s['joint_damping_ratio']}")
    if s["soft_iterations"] < 1:
        raise ValueError(f"soft_iterations must be >= 1, got {s['soft_iterations']}")
    if s["relax_iterations"] < 0:
        raise ValueError(f"relax_iterations must be >= 0, got {s['relax_iterations']}")
    if s["friction_cone"] not in FRICTION_CONES:
        raise ValueError(f"friction_cone must be one of {FRICTION_CONES}, got {s['friction_cone']!r}")
    if s["gyroscopic"] not in GYROSCOPIC_OPTIONS:
        raise ValueError(f"gyroscopic must be one of {GYROSCOPIC_OPTIONS}, got {s['gyroscopic']!r}")
    if s["substeps"] < 0:
        raise ValueError(f"substeps must be >= 1, or 0 for automatic, got {s['substeps']}")
    return s


def substep_count(settings, dt, joints=False):
    """Substeps of a step of dt s: settings["substeps"] when >= 1, else the fewest that keep each
    at most AUTO_SUBSTEP (PGS) or SOFT_AUTO_SUBSTEP (the soft step; with joints, True when the
    world has a joint that is not broken, also at most MAX_HERTZ_PER_RATE / joint_hertz, so that
    the joints' springs are as stiff as asked); 1e-9 absorbs the rounding of dt = k / 960 or k / 240."""
    if settings["substeps"] >= 1:
        return settings["substeps"]
    longest = SOFT_AUTO_SUBSTEP if settings["solver"] == "soft" else AUTO_SUBSTEP
    if settings["solver"] == "soft" and joints:
        longest = min(longest, MAX_HERTZ_PER_RATE / settings["joint_hertz"])
    return int(min(max(np.ceil(dt / longest - 1e-9), 1), 10**6))


def empty_cache():
    """A warm-start cache with no entries (the format of ``read_cache``)."""
    return {"body_a": np.zeros(0, dtype=np.int64), "body_b": np.zeros(0, dtype=np.int64),
            "feature_a": np.zeros(0, dtype=np.uint64), "feature_b": np.zeros(0, dtype=np.uint64),
            "alpha": np.zeros(0), "friction": np.zeros((0, 3)), "spin": np.zeros(0)}


def read_cache(snapshot):
    """The previous step's warm-start cache of the snapshot (missing or None = empty).

    Output: dict body_a, body_b (C,) int64, feature_a, feature_b (C,) uint64, alpha (C,) N
    (normal force after stage c), friction (C, 3) N (world friction force on B), spin (C,) N m
    (torsional friction torque on B about the normal; zeros when the cache has no "spin").
    """
    cache = snapshot.get("cache")
    if cache is None or len(cache.get("alpha", ())) == 0:
        return empty_cache()
    return {"body_a": np.asarray(cache["body_a"], dtype=np.int64).reshape(-1),
            "body_b": np.asarray(cache["body_b"], dtype=np.int64).reshape(-1),
            "feature_a": np.asarray(cache["feature_a"], dtype=np.uint64).reshape(-1),
            "feature_b": np.asarray(cache["feature_b"], dtype=np.uint64).reshape(-1),
            "alpha": np.asarray(cache["alpha"], dtype=float).reshape(-1),
            "friction": np.asarray(cache["friction"], dtype=float).reshape(-1, 3),
            "spin": (np.asarray(cache["spin"], dtype=float).reshape(-1) if "spin" in cache
                     else np.zeros(len(np.asarray(cache["alpha"]).reshape(-1))))}


def contact_materials(snapshot, contacts):
    """Per contact mu_i = sqrt(mu_A mu_B) and e_i = max(e_A, e_B) (conventions, "Materials").

    Body keys "friction" (default 0.5) and "restitution" (default 0), static bodies too.
    Outputs: mu (K,), e (K,), dimensionless.
    """
    bodies = snapshot["bodies"]
    mu_body = np.array([float(b.get("friction", DEFAULT_FRICTION)) for b in bodies])
    e_body = np.array([float(b.get("restitution", DEFAULT_RESTITUTION)) for b in bodies])
    A = np.asarray(contacts["body_a"], dtype=np.int64)
    B = np.asarray(contacts["body_b"], dtype=np.int64)
    return np.sqrt(mu_body[A] * mu_body[B]), np.maximum(e_body[A], e_body[B])


def spinning_friction(snapshot, contacts):
    """Per contact mu_spin_i = max(mu_spin_A, mu_spin_B) (m; conventions, "Materials").

    Body key "spinning_friction" (default 0), static bodies too.  Output: (K,) m.
    """
    spin = np.array([float(b.get("spinning_friction", DEFAULT_SPINNING_FRICTION)) for b in snapshot["bodies"]])
    A = np.asarray(contacts["body_a"], dtype=np.int64).reshape(-1)
    B = np.asarray(contacts["body_b"], dtype=np.int64).reshape(-1)
    return np.maximum(spin[A], spin[B])


def alone_in_pair(contacts):
    """(K,) bool: contact i is the only one of its body pair (body_a, body_b).  The contact list
    holds each pair's contacts next to each other (conventions, "Order"), so its neighbours tell."""
    A = np.asarray(contacts["body_a"], dtype=np.int64).reshape(-1)
    B = np.asarray(contacts["body_b"], dtype=np.int64).reshape(-1)
    same_as_next = (A[1:] == A[:-1]) & (B[1:] == B[:-1])
    alone = np.ones(len(A), dtype=bool)
    alone[1:] &= ~same_as_next
    alone[:-1] &= ~same_as_next
    return alone


def speculative_bias(contacts, dt):
    """b_i = max(gap_i, 0) / dt, (K,) m/s: a speculative contact may close its gap, no more;
    an overlap is not pushed out by the velocity (the position pass does that)."""
    return np.maximum(np.asarray(contacts["gap"], dtype=float), 0.0) / dt


def tangent_basis(normal):
    """t1, t2 of unit normals n (K, 3): with k the first axis whose |n_k| is within 1e-9 of the
    smallest (components equal up to rounding noise count as tied, so the noise never turns the
    friction pyramid), t1 = unit(n x e_k), t2 = n x t1.  Outputs (K, 3) each; (n, t1, t2) is
    right-handed."""
    n = np.asarray(normal, dtype=float).reshape(-1, 3)
    m = np.abs(n)
    tied = m <= m.min(axis=1, keepdims=True) + 1e-9
    e_k = np.eye(3)[np.argmax(tied, axis=1)]
    t1 = np.cross(n, e_k)
    t1 = t1 / np.linalg.norm(t1, axis=1)[:, None]
    return t1, np.cross(n, t1)


# --------------------------------------------------------------------------- a. prepare

def contact_anchors(contacts):
    """Where each contact's force acts on A and on B (K, 3) each: anchor_a and anchor_b when the
    contacts carry them (a substep), else the contact point for both."""
    y = np.asarray(contacts["point"], dtype=float).reshape(-1, 3)
    y_A = np.asarray(contacts["anchor_a"], dtype=float).reshape(-1, 3) if "anchor_a" in contacts else y
    y_B = np.asarray(contacts["anchor_b"], dtype=float).reshape(-1, 3) if "anchor_b" in contacts else y
    return y_A, y_B


# the first colour of a contact against a body that does not move (static or kinematic)
STATIC_COLOUR = 32


# a unit of more contacts than this (a body pair's run, ``by_pair``) is listed after the shorter
# ones of its colour
MANIFOLD_POINTS = 4


def solve_order(snapshot, contacts, by_pair=False):
    """The order the sweeps visit the contacts in (docs/conventions.md, step 3, "Solve order").

    Greedy colouring of units in contact order, a unit being a contact (the PGS) or, with
    ``by_pair`` (the soft step), a body pair's run of consecutive contacts: unit u takes the
    lowest of the colours 0..63 that neither of its moving (not static, not kinematic) bodies has
    taken yet, from colour 32 up against a body that does not move (so that the ground's contacts
    are solved after those of the bodies they carry, as Box2D v3 does; below 32 when 32..63 are
    all taken), or colour 64 when all are taken; the order lists colour 0's units, then colour
    1's, ..., within a colour first (by pair) the units of exactly two contacts, then the other
    units of at most MANIFOLD_POINTS contacts, then the longer ones, each part in contact order, a
    unit's contacts in contact order. By contact,
    consecutive contacts rarely share a body, which lets the core's sweep start one contact
    before the previous one's velocity update is done; by pair, the core's lanes solve four pairs
    at once. The order is part of the method, so the oracle repeats it.

    Inputs: snapshot (bodies), contacts dict (body_a, body_b, K). Output: order (K,) int64.
    """
    A = np.asarray(contacts["body_a"], dtype=np.int64).reshape(-1).tolist()
    B = np.asarray(contacts["body_b"], dtype=np.int64).reshape(-1).tolist()
    static, _, _, _ = body_arrays(snapshot)
    kinematic, _ = motion_flags(snapshot)
    free = (~static & ~kinematic).tolist()
    used = [0] * len(free)
    everything = (1 << 64) - 1
    bucket = []  # 3 colour, + 0 in a two-point unit (by pair), + 2 in one of more than MANIFOLD_POINTS contacts, + 1 else
    i, K = 0, len(A)
    while i < K:
        j = i + 1
        while by_pair and j < K and (A[j], B[j]) == (A[i], B[i]):
            j += 1
        a, b = A[i], B[i]
        taken = (used[a] if free[a] else 0) | (used[b] if free[b] else 0)
        if taken == everything:
            c = 64
        else:
            c = 0 if free[a] and free[b] else STATIC_COLOUR  # against a body that does not move: from 32
            if c and (~taken & everything) >> c == 0:
                c = 0
            while taken >> c & 1:
                c += 1
            for x in (a, b):
                if free[x]:
                    used[x] |= 1 << c
        part = 2 if j - i > MANIFOLD_POINTS else 0 if by_pair and j - i == 2 else 1
        bucket += [3 * c + part] * (j - i)
        i = j
    return np.argsort(np.asarray(bucket, dtype=np.int64), kind="stable")


def prepare_rows(snapshot, contacts, q_dot_star, dt):
    """Stage a: the rows of every contact and the contact constants.

    Inputs: snapshot (positions and rotations at the start of the step, bodies), contacts dict
            (K; optional anchor_a, anchor_b (K, 3): where the force acts on A and on B, else the
            point for both), q_dot_star (N, 6) unconstrained (omega, p_dot), dt s.
    Output dict (row k = 3 i + j, j = 0 normal, 1 t1, 2 t2):
        a, b         (3K,) int64 body indices of each row
        direction    (3K, 3) d of each row: n_i, t1_i, t2_i
        J_A, J_B     (3K, 6) as in the module doc
        MJ_A, MJ_B   (3K, 6) M_A^-1 J_A, M_B^-1 J_B (1/kg, 1/(kg m))
        delta        (3K,) s/kg
        moves        (N,) bool, False for static bodies
        bias         (K,) m/s, b_i = max(gap_i, 0) / dt
        gap          (K,) m;  mu, e (K,) materials;  u (K,) m/s, J_n q_dot* (< 0 approaching)
        order        (K,) int64, the solve order (``solve_order``)
        mu_spin      (K,) m, max(mu_spin_A, mu_spin_B)
        spin         (K,) bool: the contact has a spin row (alone in its pair, mu_spin > 0, delta > 0)
        spin_J_A, spin_J_B, spin_MJ_A, spin_MJ_B  (K, 6) the spin rows' J = (-n, 0), (n, 0) and M^-1 J
        spin_delta   (K,) s/(kg m^2)
    """
    p = np.asarray(snapshot["position"], dtype=float).reshape(-1, 3)
    A = np.asarray(contacts["body_a"], dtype=np.int64).reshape(-1)
    B = np.asarray(contacts["body_b"], dtype=np.int64).reshape(-1)
    y_A, y_B = contact_anchors(contacts)
    n = np.asarray(contacts["normal"], dtype=float).reshape(-1, 3)
    K = len(A)

    # directions: normal, then the two tangents, contact by contact
    t1, t2 = tangent_basis(n)
    d = np.stack([n, t1, t2], axis=1).reshape(-1, 3)
    a, b = np.repeat(A, 3), np.repeat(B, 3)
    r_A, r_B = np.repeat(y_A - p[A], 3, axis=0), np.repeat(y_B - p[B], 3, axis=0)

    # Jacobian rows, M^-1 J and delta
    J_A = -np.hstack([np.cross(r_A, d), d])
    J_B = np.hstack([np.cross(r_B, d), d])
    M_inv = inverse_mass_blocks(snapshot)
    MJ_A = np.einsum("kij,kj->ki", M_inv[a], J_A)
    MJ_B = np.einsum("kij,kj->ki", M_inv[b], J_B)
    delta = dt * (np.einsum("ki,ki->k", J_A, MJ_A) + np.einsum("ki,ki->k", J_B, MJ_B))

    # contact constants: bias, materials, normal velocity before the solve
    gap = np.asarray(contacts["gap"], dtype=float).reshape(-1)
    mu, e = contact_materials(snapshot, contacts)
    q = np.asarray(q_dot_star, dtype=float).reshape(-1, 6)
    u = (np.einsum("ki,ki->k", J_B[0::3], q[B]) + np.einsum("ki,ki->k", J_A[0::3], q[A])
         if K else np.zeros(0))
    static, _, _, _ = body_arrays(snapshot)

    # spin rows: angular only, about the normal, for a contact alone in its body pair
    zeros = np.zeros((K, 3))
    spin_J_A, spin_J_B = np.hstack([-n, zeros]), np.hstack([n, zeros])
    spin_MJ_A = np.einsum("kij,kj->ki", M_inv[A], spin_J_A)
    spin_MJ_B = np.einsum("kij,kj->ki", M_inv[B], spin_J_B)
    spin_delta = dt * (np.einsum("ki,ki->k", spin_J_A, spin_MJ_A) + np.einsum("ki,ki->k", spin_J_B, spin_MJ_B))
    mu_spin = spinning_friction(snapshot, contacts)
    spin = (mu_spin > 0.0) & alone_in_pair(contacts) & (spin_delta > 0.0)
    return {"a": a, "b": b, "direction": d, "J_A": J_A, "J_B": J_B, "MJ_A": MJ_A, "MJ_B": MJ_B,
            "delta": delta, "moves": ~static, "bias": speculative_bias(contacts, dt), "gap": gap,
            "mu": mu, "e": e, "u": u, "order": solve_order(snapshot, contacts),
            "mu_spin": mu_spin, "spin": spin, "spin_J_A": spin_J_A, "spin_J_B": spin_J_B,
            "spin_MJ_A": spin_MJ_A, "spin_MJ_B": spin_MJ_B, "spin_delta": spin_delta}


class RowSweep:
    """The rows as Python lists (scalar NumPy indexing is slow) and the two row operations
    every stage uses: the row velocity J q_dot and the update q_dot += dt d_alpha M^-1 J."""

    def __init__(self, rows, dt):
        self.a, self.b = rows["a"].tolist(), rows["b"].tolist()
        self.J_A, self.J_B = list(rows["J_A"]), list(rows["J_B"])
        self.MJ_A, self.MJ_B = list(rows["MJ_A"]), list(rows["MJ_B"])
        self.delta = rows["delta"].tolist()
        self.moves = rows["moves"].tolist()
        self.dt = dt
        # spin rows, by contact (rows made without them have none)
        K = len(rows["mu"])
        self.spin = rows["spin"].tolist() if "spin" in rows else [False] * K
        if any(self.spin):
            self.spin_J_A, self.spin_J_B = list(rows["spin_J_A"]), list(rows["spin_J_B"])
            self.spin_MJ_A, self.spin_MJ_B = list(rows["spin_MJ_A"]), list(rows["spin_MJ_B"])
            self.spin_delta, self.mu_spin = rows["spin_delta"].tolist(), rows["mu_spin"].tolist()

    def spin_velocity(self, i, q_dot):
        """J q_dot of contact i's spin row, n . (omega_B - omega_A), rad/s."""
        n = 3 * i
        return float(self.spin_J_B[i] @ q_dot[self.b[n]] + self.spin_J_A[i] @ q_dot[self.a[n]])

    def spin_apply(self, i, d_tau, q_dot):
        """q_dot_X += dt d_tau M_X^-1 J_X of contact i's spin row, for its moving bodies."""
        s, n = self.dt * d_tau, 3 * i
        if self.moves[self.a[n]]:
            q_dot[self.a[n]] += s * self.spin_MJ_A[i]
        if self.moves[self.b[n]]:
            q_dot[self.b[n]] += s * self.spin_MJ_B[i]

    def velocity(self, k, q_dot):
        """J q_dot of row k, m/s."""
        return float(self.J_B[k] @ q_dot[self.b[k]] + self.J_A[k] @ q_dot[self.a[k]])

    def apply(self, k, d_alpha, q_dot):
        """q_dot_X += dt d_alpha M_X^-1 J_X for the moving bodies of row k."""
        s = self.dt * d_alpha
        if self.moves[self.a[k]]:
            q_dot[self.a[k]] += s * self.MJ_A[k]
        if self.moves[self.b[k]]:
            q_dot[self.b[k]] += s * self.MJ_B[k]

    def update_normal(self, k, b, alpha, q_dot):
        """gamma = J q_dot - delta alpha_k + b, alpha_k <- max(-gamma / delta, 0), applied.
        alpha is the list of the stage's unknowns (modified); returns delta |d_alpha| (m/s)."""
        delta = self.delta[k]
        if not delta > 0.0:
            return 0.0
        gamma = self.velocity(k, q_dot) - delta * alpha[k] + b
        alpha_new = max(-gamma / delta, 0.0)
        d_alpha = alpha_new - alpha[k]
        if d_alpha == 0.0:
            return 0.0
        alpha[k] = alpha_new
        self.apply(k, d_alpha, q_dot)
        return delta * abs(d_alpha)


def project_friction(a1, a2, bound, friction_cone):
    """The friction set of a contact: the pyramid clamps each of a1, a2 to [-bound, bound];
    the cone scales (a1, a2) onto the disk |a| <= bound when outside it.  Floats in and out, N."""
    if friction_cone == "cone":
        s = np.hypot(a1, a2)
        if s > bound:
            k = bound / s if s > 0.0 else 0.0
            a1, a2 = a1 * k, a2 * k
        return float(a1), float(a2)
    return min(max(a1, -bound), bound), min(max(a2, -bound), bound)


# --------------------------------------------------------------------------- b. warm start

def warm_start(rows, contacts, cache, q_dot, dt, friction_cone, alpha_spin=None):
    """Stage b: start each contact from the cached forces of the same key, and apply them:
    ``recall_forces``, then ``apply_forces``.

    Inputs: rows (``prepare_rows``), contacts (needs feature_a, feature_b when the cache is not
            empty), cache (``read_cache``), q_dot (N, 6) modified in place, dt s, friction_cone,
            alpha_spin (K,) N m written in place (None: the spin rows are not warm-started).
    Output: alpha (3K,) N, the rows' starting forces.
    """
    alpha = recall_forces(rows, contacts, cache, friction_cone, alpha_spin)
    apply_forces(rows, alpha, q_dot, dt, alpha_spin)
    return alpha


def recall_forces(rows, contacts, cache, friction_cone, alpha_spin=None):
    """The previous step's forces for contacts with the same key, not applied.

    A contact whose key (body_a, body_b, feature_a, feature_b) is in the cache (the first such
    contact in contact order; the first cache entry of that key) gets alpha_n = the cached
    normal force and alpha_t1 = f . t1, alpha_t2 = f . t2 from the cached friction force f,
    projected onto its friction set of alpha_n (``project_friction``); a contact with a spin row
    gets alpha_spin = the cached spin torque clamped to [-mu_spin alpha_n, mu_spin alpha_n].
    Other contacts start from zero.

    Inputs: rows, contacts, cache, friction_cone as ``warm_start``; alpha_spin (K,) N m written in
            place (None: not recalled).
    Output: alpha (3K,) N.
    """
    K = len(rows["mu"])
    alpha = np.zeros(3 * K)
    if len(cache["alpha"]) == 0 or K == 0:
        return alpha
    if "feature_a" not in contacts or "feature_b" not in contacts:
        raise ValueError("warm start: the contacts need feature_a and feature_b to match the cache")

    # the first cache entry of each key
    index = {}
    for j, key in enumerate(zip(cache["body_a"].tolist(), cache["body_b"].tolist(),
                                cache["feature_a"].tolist(), cache["feature_b"].tolist())):
        index.setdefault(key, j)

    # the first contact of each key takes the entry, projected onto its own friction set
    used = set()
    keys = zip(np.asarray(contacts["body_a"]).tolist(), np.asarray(contacts["body_b"]).tolist(),
               np.asarray(contacts["feature_a"], dtype=np.uint64).tolist(),
               np.asarray(contacts["feature_b"], dtype=np.uint64).tolist())
    d = rows["direction"]
    for i, key in enumerate(keys):
        j = index.get(key)
        if j is None or j in used:
            continue
        used.add(j)
        alpha_n = float(cache["alpha"][j])
        f = cache["friction"][j]
        a1, a2 = project_friction(float(f @ d[3 * i + 1]), float(f @ d[3 * i + 2]),
                                  float(rows["mu"][i]) * alpha_n, friction_cone)
        alpha[3 * i:3 * i + 3] = alpha_n, a1, a2
        if alpha_spin is not None and rows["spin"][i]:
            bound = float(rows["mu_spin"][i]) * alpha_n
            alpha_spin[i] = min(max(float(cache["spin"][j]), -bound), bound)
    return alpha


def apply_forces(rows, alpha, q_dot, dt, alpha_spin=None, sweep=None):
    """q_dot += dt M^-1 J^T alpha: every row's force applied, in solve order (each contact's
    normal, t1, t2, then its spin row's torque).

    Inputs: rows, alpha (3K,) N, q_dot (N, 6) modified in place, dt s, alpha_spin (K,) N m (None:
            no spin torques), sweep (the rows' ``RowSweep`` for dt, when the caller has one).
    """
    sweep = RowSweep(rows, dt) if sweep is None else sweep
    for i in rows["order"].tolist():
        for k in (3 * i, 3 * i + 1, 3 * i + 2):
            if alpha[k] != 0.0:
                sweep.apply(k, float(alpha[k]), q_dot)
        if alpha_spin is not None and sweep.spin[i] and alpha_spin[i] != 0.0:
            sweep.spin_apply(i, float(alpha_spin[i]), q_dot)


# --------------------------------------------------------------------------- c. iterate

def iterate(rows, alpha, q_dot, dt, tolerance, max_iterations, friction_cone, alpha_spin=None, joint_sweep=None):
    """Stage c: projected Gauss-Seidel sweeps over all rows, contact by contact in solve order.

    Per contact i, with its current alpha_n:
        normal:  gamma = J q_dot - delta alpha + b_i, alpha <- max(-gamma / delta, 0)
        pyramid: each tangent row in turn, gamma = J q_dot - delta alpha,
                 alpha <- clamp(-gamma / delta, -mu alpha_n, mu alpha_n)
        cone:    both tangent rows from the same q_dot with one scale delta_t = max(delta_1, delta_2):
                 a_k = alpha_k - J_k q_dot / delta_t, (a_1, a_2) scaled onto the disk
                 |a| <= mu alpha_n when outside it, then applied (t1, then t2)
        spin:    (a contact with a spin row, with either cone) gamma = J q_dot - delta alpha,
                 alpha <- clamp(-gamma / delta, -mu_spin alpha_n, mu_spin alpha_n), from the
                 velocities the friction rows left
    At most max_iterations sweeps, stopping after a sweep whose largest delta |d_alpha| (each
    row's own delta) is <= tolerance (m/s; rad/s for spin rows).

    Why one delta_t for the cone (the conventions' text divides each row by its own delta_k):
    a fixed point of a = P_disk(a - D^-1 v), D = diag(delta_1, delta_2), that slides has
    a parallel to -D^-1 v, so friction opposes the slip only when delta_1 = delta_2; with a
    scalar delta_t it is parallel to -v (Coulomb's maximal dissipation) whatever delta_t > 0.
    delta_t = max(delta_1, delta_2) is at least half the largest eigenvalue of the contact's
    2 x 2 tangent block (PSD: |c| <= sqrt(delta_1 delta_2)), so the projected step still
    converges.  A box sliding down a slope along a direction between t1 and t2 with per-row
    deltas yaws and accelerates 1% too fast; with delta_t it follows g (sin - mu cos) to rounding.
    The pyramid is a box, separable per row, so its fixed points do not depend on the scales.

    Inputs: rows, alpha (3K,) N modified in place, q_dot (N, 6) modified in place, dt s,
            tolerance m/s, max_iterations, friction_cone, alpha_spin (K,) N m modified in place
            (None: start the spin rows from 0 and keep their torques to this call),
            joint_sweep: called with q_dot after each sweep of the contact rows (the joints' blocks,
            ``joints.sweep_joints``), returning its largest change, which the stopping rule counts.
    Outputs: (iterations, converged); converged is True with 0 sweeps when there are no rows.
    """
    sweep = RowSweep(rows, dt)
    K = len(rows["mu"])
    tau = [0.0] * K if alpha_spin is None else np.asarray(alpha_spin, dtype=float).tolist()
    bias, mu = rows["bias"].tolist(), rows["mu"].tolist()
    order = rows["order"].tolist()
    x = alpha.tolist()
    iterations, converged = 0, K == 0 and joint_sweep is None
    while not converged and iterations < max_iterations:
        iterations += 1
        change = 0.0
        for i in order:
            # normal: the lecture's projection onto alpha >= 0
            change = max(change, sweep.update_normal(3 * i, bias[i], x, q_dot))
            # friction and spin, bounded by the current normal force
            change = max(change, friction_rows(sweep, i, mu[i], x, tau, q_dot, friction_cone))
        if joint_sweep is not None:  # the joints' blocks after the contacts
            change = max(change, joint_sweep(q_dot))
        converged = tolerance > 0.0 and change <= tolerance
    alpha[:] = x
    if alpha_spin is not None:
        alpha_spin[:] = tau
    return iterations, converged


def friction_rows(sweep, i, mu_i, x, tau, q_dot, friction_cone):
    """Contact i's friction rows and its spin row in a sweep, after its normal row (``iterate``):
        pyramid: each tangent row in turn, gamma = J q_dot - delta alpha,
                 alpha <- clamp(-gamma / delta, -mu alpha_n, mu alpha_n)
        cone:    both tangent rows from the same q_dot with one scale delta_t = max(delta_1, delta_2):
                 a_k = alpha_k - J_k q_dot / delta_t, (a_1, a_2) scaled onto the disk
                 |a| <= mu alpha_n when outside it, then applied (t1, then t2)
        spin:    (a contact with a spin row) gamma = J q_dot - delta alpha,
                 alpha <- clamp(-gamma / delta, -mu_spin alpha_n, mu_spin alpha_n)
    with alpha_n = x[3 i], the contact's current normal force.

    Inputs: sweep (``RowSweep``), contact i, mu_i, x (3K list, N) and tau (K list, N m) the forces,
            modified in place; q_dot (N, 6) modified in place; friction_cone.
    Output: the largest delta |d_alpha| of these rows (m/s; rad/s for the spin row).
    """
    n, k1, k2 = 3 * i, 3 * i + 1, 3 * i + 2
    delta = sweep.delta
    change = 0.0
    # friction: Coulomb, bounded by mu times the current normal force
    if delta[k1] > 0.0:
        bound = mu_i * x[n]
        if friction_cone == "cone":
            delta_t = max(delta[k1], delta[k2])
            a1 = x[k1] - sweep.velocity(k1, q_dot) / delta_t
            a2 = x[k2] - sweep.velocity(k2, q_dot) / delta_t
            a1, a2 = project_friction(a1, a2, bound, "cone")
            d1, d2 = a1 - x[k1], a2 - x[k2]
            x[k1], x[k2] = a1, a2
            if d1 != 0.0:
                sweep.apply(k1, d1, q_dot)
            if d2 != 0.0:
                sweep.apply(k2, d2, q_dot)
            change = max(change, delta[k1] * abs(d1), delta[k2] * abs(d2))
        else:
            for k in (k1, k2):
                gamma = sweep.velocity(k, q_dot) - delta[k] * x[k]
                a = min(max(-gamma / delta[k], -bound), bound)
                d_alpha = a - x[k]
                if d_alpha == 0.0:
                    continue
                x[k] = a
                sweep.apply(k, d_alpha, q_dot)
                change = max(change, delta[k] * abs(d_alpha))
    # spin: torsional friction, bounded by mu_spin times the current normal force
    if sweep.spin[i]:
        bound = sweep.mu_spin[i] * x[n]
        gamma = sweep.spin_velocity(i, q_dot) - sweep.spin_delta[i] * tau[i]
        t = min(max(-gamma / sweep.spin_delta[i], -bound), bound)
        d_tau = t - tau[i]
        if d_tau != 0.0:
            tau[i] = t
            sweep.spin_apply(i, d_tau, q_dot)
            change = max(change, sweep.spin_delta[i] * abs(d_tau))
    return change


# --------------------------------------------------------------------------- d. restitution

def restitutive_contacts(rows, alpha, restitution_threshold):
    """The contacts of stage d: e_i > 0, u_i < -restitution_threshold and alpha_n > 0 after
    stage c.  Inputs: rows, alpha (3K,) N after c, threshold m/s.  Output (K,) bool."""
    return (rows["e"] > 0.0) & (rows["u"] < -restitution_threshold) & (alpha[0::3] > 0.0)


def restitution(rows, alpha, q_dot, restitutive, dt, tolerance, max_iterations):
    """Stage d: Newton's law n^T (v_B - v_A) >= -e_i u_i on the restitutive contacts.

    Their normal rows only (friction is not swept again), in solve order, same stopping rule:
        gamma = J q_dot - delta alpha + e_i u_i, alpha <- max(-gamma / delta, 0)
    so alpha_n ends as the total normal force (the stage c force plus the bounce).

    Inputs: rows, alpha (3K,) N and q_dot (N, 6) modified in place, restitutive (K,) bool, dt s,
            tolerance m/s, max_iterations.
    Output: sweeps used (0 when no contact is restitutive).
    """
    contacts = [i for i in rows["order"].tolist() if restitutive[i]]
    if not contacts:
        return 0
    sweep = RowSweep(rows, dt)
    target = (rows["e"] * rows["u"]).tolist()
    x = alpha.tolist()
    sweeps, converged = 0, False
    while not converged and sweeps < max_iterations:
        sweeps += 1
        change = 0.0
        for i in contacts:
            change = max(change, sweep.update_normal(3 * i, target[i], x, q_dot))
        converged = tolerance > 0.0 and change <= tolerance
    alpha[:] = x
    return sweeps


# --------------------------------------------------------------------------- e. position pass

def contact_slops(snapshot, contacts, slop):
    """slop_i = min(slop, SLOP_INNER_FRACTION min(r_A, r_B)), (K,) m: the overlap the position pass
    leaves alone at contact i, smaller for a thin body (r_X: body X's "inner_radius", the radius
    of a ball its shape contains; infinity when the body dict has none)."""
    inner = np.array([float(b.get("inner_radius", np.inf)) for b in snapshot["bodies"]])
    A = np.asarray(contacts["body_a"], dtype=np.int64).reshape(-1)
    B = np.asarray(contacts["body_b"], dtype=np.int64).reshape(-1)
    return np.minimum(slop, SLOP_INNER_FRACTION * np.minimum(inner[A], inner[B]))


def position_targets(rows, restitutive, dt, erp, slop, max_push_velocity):
    """b_pos,i = max(push_i, bounce_i), (K,) m/s, the separation speed the position pass asks for:
        push_i   = min(erp max(-gap_i - slop_i, 0) / dt, max_push_velocity)
                   (an overlap up to slop_i is left alone, so resting contacts are not stirred;
                   slop: one number or (K,) per contact, ``contact_slops``)
        bounce_i = e_i max(-u_i - max(gap_i, 0) / dt, 0) for a restitutive contact, else 0
    (after the impact at t_c = gap / |u| the bodies separate at e |u| for the rest of the step)."""
    gap = rows["gap"]
    push = np.minimum(erp * np.maximum(-gap - slop, 0.0) / dt, max_push_velocity)
    bounce = np.where(restitutive, rows["e"] * np.maximum(-rows["u"] - np.maximum(gap, 0.0) / dt, 0.0), 0.0)
    return np.maximum(push, bounce)


def position_pass(rows, b_pos, n_bodies, dt, tolerance, max_iterations):
    """Stage e: pseudo-velocities q_p that separate the contacts at b_pos (split impulse).

    q_p starts at zero and the normal rows of all contacts are swept in solve order, same
    stopping rule, with pseudo-forces beta_i >= 0:
        gamma = J q_p - delta beta_i - b_pos,i, beta_i <- max(-gamma / delta, 0),
        q_p += dt d_beta M^-1 J.
    q_p moves the poses (step 4) and is then dropped.  When every b_pos,i is 0 nothing is done.

    Inputs: rows, b_pos (K,) m/s, n_bodies N, dt s, tolerance m/s, max_iterations.
    Outputs: q_p (N, 6) (omega_p, v_p), beta (K,) N, sweeps used.
    """
    K = len(b_pos)
    q_p = np.zeros((n_bodies, 6))
    beta = np.zeros(K)
    if not np.any(b_pos > 0.0):
        return q_p, beta, 0
    sweep = RowSweep(rows, dt)
    x = np.zeros(3 * K).tolist()      # the normal rows' beta at 3 i (the tangent slots stay 0)
    order = rows["order"].tolist()
    target = (-b_pos).tolist()
    sweeps, converged = 0, False
    while not converged and sweeps < max_iterations:
        sweeps += 1
        change = 0.0
        for i in order:
            change = max(change, sweep.update_normal(3 * i, target[i], x, q_p))
        converged = tolerance > 0.0 and change <= tolerance
    beta[:] = x[0::3]
    return q_p, beta, sweeps


# --------------------------------------------------------------------------- f. store

def sort_cache(cache):
    """The cache sorted by key (body_a, body_b, feature_a, feature_b), one entry per key (the
    first in the given order), as the core keeps it."""
    order = np.lexsort((cache["feature_b"], cache["feature_a"], cache["body_b"], cache["body_a"]))
    keys = list(zip(*(cache[k][order].tolist() for k in ("body_a", "body_b", "feature_a", "feature_b"))))
    keep = [m for m in range(len(order)) if m == 0 or keys[m] != keys[m - 1]]
    return {k: cache[k][order[keep]] for k in CACHE_KEYS}


def store(rows, contacts, snapshot, alpha, alpha_iter, q_dot, dt, alpha_spin=None):
    """Stage f: forces per contact and per body, velocities at the contacts, the next cache.

    Inputs: rows, contacts, snapshot (positions at the start of the step), alpha (3K,) N after
            stage d, alpha_iter (K,) N the normal forces after stage c, q_dot (N, 6) the kept
            velocities, dt s, alpha_spin (K,) N m the spin rows' torques (None: all 0).
    Output dict:
        alpha (K,) N;  impulse (K,) N s = dt alpha;  friction (K, 3) N, f_i = alpha_t1 t1 + alpha_t2 t2
        on B (-f_i on A);  force (K, 3) N = alpha n + f on B;  spin_torque (K,) N m, the torsional
        friction torque on B about n (spin_torque n on B, the opposite on A; 0 without a spin row);
        normal_velocity (K,) m/s, J_n q_dot;
        slip (K, 3) m/s, (v_B(y) - v_A(y)) - vn n;  body_force, body_torque (N, 3) N, N m: the summed
        contact force on each body and its torque about the body's com (world; static bodies too;
        the spin torques included);
        cache: body_a, body_b, feature_a, feature_b, alpha (after c), friction, spin (``sort_cache``);
        empty when the contacts carry no feature ids.
    """
    p = np.asarray(snapshot["position"], dtype=float).reshape(-1, 3)
    A = np.asarray(contacts["body_a"], dtype=np.int64).reshape(-1)
    B = np.asarray(contacts["body_b"], dtype=np.int64).reshape(-1)
    y_A, y_B = contact_anchors(contacts)
    K, N = len(A), len(p)
    d = rows["direction"].reshape(K, 3, 3)
    n, t1, t2 = d[:, 0], d[:, 1], d[:, 2]
    alpha_n = alpha[0::3].copy()

    # forces: normal alpha n, friction alpha_t1 t1 + alpha_t2 t2, on B (A gets the opposite)
    friction = alpha[1::3, None] * t1 + alpha[2::3, None] * t2
    force = alpha_n[:, None] * n + friction
    # torsional friction: spin_torque n on B, the opposite on A
    spin_torque = np.zeros(K) if alpha_spin is None else np.where(rows["spin"], alpha_spin, 0.0)

    # per body: summed force and its torque about the com, in contact order
    body_force, body_torque = np.zeros((N, 3)), np.zeros((N, 3))
    for i in range(K):
        body_force[B[i]] += force[i]
        body_torque[B[i]] += np.cross(y_B[i] - p[B[i]], force[i]) + spin_torque[i] * n[i]
        body_force[A[i]] -= force[i]
        body_torque[A[i]] -= np.cross(y_A[i] - p[A[i]], force[i]) + spin_torque[i] * n[i]

    # velocities at the contacts after the solve: normal and slip
    q = np.asarray(q_dot, dtype=float).reshape(-1, 6)
    v_rel = ((np.cross(q[B, :3], y_B - p[B]) + q[B, 3:]) - (np.cross(q[A, :3], y_A - p[A]) + q[A, 3:])
             if K else np.zeros((0, 3)))
    normal_velocity = (np.einsum("ki,ki->k", rows["J_B"][0::3], q[B])
                       + np.einsum("ki,ki->k", rows["J_A"][0::3], q[A])) if K else np.zeros(0)
    slip = v_rel - normal_velocity[:, None] * n

    # the cache for the next step: the normal force before restitution, the friction force
    # (contacts without feature ids cannot be recognised next step: they leave no cache)
    cache = empty_cache()
    if K and "feature_a" in contacts and "feature_b" in contacts:
        cache = sort_cache({
            "body_a": A.copy(), "body_b": B.copy(),
            "feature_a": np.asarray(contacts["feature_a"], dtype=np.uint64).reshape(-1),
            "feature_b": np.asarray(contacts["feature_b"], dtype=np.uint64).reshape(-1),
            "alpha": np.asarray(alpha_iter, dtype=float).copy(), "friction": friction.copy(),
            "spin": spin_torque.copy()})
    return {"alpha": alpha_n, "impulse": dt * alpha_n, "friction": friction, "force": force,
            "spin_torque": spin_torque, "normal_velocity": normal_velocity, "slip": slip,
            "body_force": body_force, "body_torque": body_torque, "cache": cache}


def certificate(rows, alpha, q_dot, restitutive, friction, slip, friction_cone, spin_torque=None):
    """The Signorini certificate of the step (conventions, "The Signorini certificate").

    With the kept velocities q_dot: vn_i = J_n q_dot, w_i = vn_i + b_i, b_i = e_i u_i for a
    restitutive contact, else max(gap_i, 0) / dt (``rows["bias"]``).
        max_alpha_negative        max(0, -min alpha_i)                                     N
        max_penetration_velocity  max(0, -min w_i)                                         m/s
        max_complementarity       max |alpha_i w_i|                                        W
        max_cone_violation        max(0, max |f_i| - mu_i alpha_i)                         N
        max_dissipation_violation max over |s_i| > 1e-3 m/s of |f_i + mu_i alpha_i s_i / |s_i||  N
        max_overlap               max(0, -min gap_i)                                       m
        residual                  max over rows of delta |alpha - P(alpha - w / delta)|      m/s,
                                  P onto [0, inf) (normal rows, w = w_i) or the friction set of the
                                  final alpha_n (tangent rows, w = J q_dot; the cone projects the pair
                                  and uses delta_t = max(delta_1, delta_2) for both, as ``iterate``)
                                  or [-mu_spin alpha_n, mu_spin alpha_n] (spin rows, w = J q_dot,
                                  rad/s)
    Inputs: rows, alpha (3K,) N final, q_dot (N, 6) kept, restitutive (K,) bool, friction (K, 3) N,
            slip (K, 3) m/s, friction_cone, spin_torque (K,) N m (None: all 0).  Output dict of
            floats; all 0 when there are no contacts.
    """
    K = len(rows["mu"])
    out = {key: 0.0 for key in ("residual", "max_alpha_negative", "max_penetration_velocity",
                                "max_complementarity", "max_cone_violation",
                                "max_dissipation_violation", "max_overlap")}
    if K == 0:
        return out
    q = np.asarray(q_dot, dtype=float).reshape(-1, 6)
    a, b = rows["a"], rows["b"]
    # every row's velocity J q_dot
    v_row = np.einsum("ki,ki->k", rows["J_B"], q[b]) + np.einsum("ki,ki->k", rows["J_A"], q[a])
    alpha_n, mu, delta = alpha[0::3], rows["mu"], rows["delta"]
    w = v_row[0::3] + np.where(restitutive, rows["e"] * rows["u"], rows["bias"])

    # the conditions, contact by contact
    out["max_alpha_negative"] = max(0.0, float(-alpha_n.min()))
    out["max_penetration_velocity"] = max(0.0, float(-w.min()))
    out["max_complementarity"] = float(np.abs(alpha_n * w).max())
    out["max_cone_violation"] = max(0.0, float((np.linalg.norm(friction, axis=1) - mu * alpha_n).max()))
    s = np.linalg.norm(slip, axis=1)
    sliding = s > SLIDING_SPEED
    if np.any(sliding):
        opposed = friction[sliding] + (mu * alpha_n)[sliding, None] * slip[sliding] / s[sliding, None]
        out["max_dissipation_violation"] = float(np.linalg.norm(opposed, axis=1).max())
    out["max_overlap"] = max(0.0, float(-rows["gap"].min()))

    # natural residual, row by row
    residual = 0.0
    for i in range(K):
        n, k1, k2 = 3 * i, 3 * i + 1, 3 * i + 2
        if not delta[n] > 0.0:
            continue
        residual = max(residual, delta[n] * abs(alpha[n] - max(alpha[n] - w[i] / delta[n], 0.0)))
        # friction rows: the pyramid scales each row by its own delta, the cone both by delta_t
        d1, d2 = delta[k1], delta[k2]
        if friction_cone == "cone":
            d1 = d2 = max(d1, d2)
        p1, p2 = project_friction(alpha[k1] - v_row[k1] / d1, alpha[k2] - v_row[k2] / d2,
                                  mu[i] * alpha[n], friction_cone)
        residual = max(residual, d1 * abs(alpha[k1] - p1), d2 * abs(alpha[k2] - p2))
        # the spin row: the box [-mu_spin alpha_n, mu_spin alpha_n]
        if spin_torque is not None and rows["spin"][i]:
            d_s, t = rows["spin_delta"][i], spin_torque[i]
            v_s = rows["spin_J_B"][i] @ q[b[n]] + rows["spin_J_A"][i] @ q[a[n]]
            bound = rows["mu_spin"][i] * alpha[n]
            residual = max(residual, d_s * abs(t - min(max(t - v_s / d_s, -bound), bound)))
    out["residual"] = float(residual)
    return out


# --------------------------------------------------------------------------- all stages

def read_joints(snapshot):
    """The snapshot's joints (``snapshot["joints"]``, see ``joints``) as new dicts of NumPy arrays
    (the snapshot is not modified): [] when it has none."""
    out = []
    for j in snapshot.get("joints", ()):
        joint = dict(j)
        for key in ("anchor_a", "anchor_b", "axis_a", "axis_b", "ref_a", "ref_b", "R_rel", "alpha"):
            joint[key] = np.array(j[key], dtype=float)
        for key in ("body_a", "body_b"):
            joint[key] = int(j[key])
        out.append(joint)
    return out


def solve_contacts(snapshot, contacts, v_star, omega_star, dt):
    """Stages a-f of step 3 for one step of dt.

    Inputs: snapshot (state at the start of the step, bodies, settings, cache), contacts dict (K;
            feature_a, feature_b needed for the warm start), v_star, omega_star (N, 3)
            unconstrained velocities (m/s, rad/s, world), dt s.
    Output dict:
        velocity, angular_velocity (N, 3): the kept velocities (after d)
        velocity_move, angular_velocity_move (N, 3): q_dot_pos + q_p, what moves the poses (step 4)
        velocity_pos, angular_velocity_pos, velocity_p, angular_velocity_p (N, 3): the two parts
        the ``store`` keys (alpha, impulse, friction, force, spin_torque, normal_velocity, slip,
        body_force, body_torque, cache), the ``certificate`` keys,
        mu, restitution, mu_spin, u (K,); restitutive (K,) bool; alpha_iter (K,) N; b_pos (K,) m/s;
        beta (K,) N; alpha_rows (3K,) N; alpha_spin (K,) N m; rows (``prepare_rows``);
        iterations, restitution_iterations, position_iterations, converged, contacts (K);
        joints (the snapshot's joints with their new alpha), joint_force, joint_torque (J, 3) N,
        N m on B (``joints.store_joints``).
    """
    s = solver_settings(snapshot)
    N = len(snapshot["bodies"])
    q_dot = np.hstack([np.asarray(omega_star, dtype=float).reshape(-1, 3),
                       np.asarray(v_star, dtype=float).reshape(-1, 3)])

    # a. prepare rows; b. warm start; c. iterate
    rows = prepare_rows(snapshot, contacts, q_dot, dt)
    alpha_spin = np.zeros(len(rows["mu"]))
    if s["warm_start"]:
        alpha = warm_start(rows, contacts, read_cache(snapshot), q_dot, dt, s["friction_cone"], alpha_spin)
    else:
        alpha = np.zeros(3 * len(rows["mu"]))
    # the joints' blocks at these poses, warm started from their last forces (docs, "Joints")
    joints = read_joints(snapshot)
    blocks = prepare_joints(snapshot, joints, q_dot, dt) if joints else []
    if not s["warm_start"]:
        for joint in joints:
            joint["alpha"][:] = 0.0
    warm_start_joints(blocks, q_dot)
    sweeps = [0]

    def joint_sweep(q):  # the drift from the velocities the first sweep leaves (joints.predict_drift)
        sweeps[0] += 1
        if sweeps[0] == 2:
            predict_drift(blocks, q, dt, touching_bodies(snapshot, rows))
        return sweep_joints(blocks, q, dt)

    iterations, converged = iterate(rows, alpha, q_dot, dt, s["tolerance"], s["max_iterations"],
                                    s["friction_cone"], alpha_spin, joint_sweep if blocks else None)
    alpha_iter = alpha[0::3].copy()
    # the poses move with the velocities of c; d changes only the kept ones
    q_dot_pos = q_dot.copy()

    # d. restitution
    restitutive = restitutive_contacts(rows, alpha, s["restitution_threshold"])
    restitution_iterations = restitution(rows, alpha, q_dot, restitutive, dt, s["tolerance"],
                                         s["max_iterations"])

    # e. position pass
    b_pos = position_targets(rows, restitutive, dt, s["erp"], contact_slops(snapshot, contacts, s["slop"]),
                             s["max_push_velocity"])
    q_p, beta, position_iterations = position_pass(rows, b_pos, N, dt, s["tolerance"],
                                                   s["max_iterations"])
    position_iterations += joint_position_pass(blocks, q_p, dt, s["erp"], s["tolerance"], s["max_iterations"])

    # f. store and certify
    out = store(rows, contacts, snapshot, alpha, alpha_iter, q_dot, dt, alpha_spin)
    out["joints"] = joints
    out["joint_force"], out["joint_torque"] = store_joints(snapshot, joints, blocks)
    out.update(certificate(rows, alpha, q_dot, restitutive, out["friction"], out["slip"],
                           s["friction_cone"], out["spin_torque"]))
    q_move = q_dot_pos + q_p
    out.update({
        "velocity": q_dot[:, 3:].copy(), "angular_velocity": q_dot[:, :3].copy(),
        "velocity_move": q_move[:, 3:].copy(), "angular_velocity_move": q_move[:, :3].copy(),
        "velocity_pos": q_dot_pos[:, 3:].copy(), "angular_velocity_pos": q_dot_pos[:, :3].copy(),
        "velocity_p": q_p[:, 3:].copy(), "angular_velocity_p": q_p[:, :3].copy(),
        "mu": rows["mu"], "restitution": rows["e"], "mu_spin": rows["mu_spin"], "u": rows["u"],
        "restitutive": restitutive, "alpha_iter": alpha_iter, "b_pos": b_pos, "beta": beta,
        "alpha_rows": alpha, "alpha_spin": alpha_spin, "rows": rows,
        "iterations": iterations, "restitution_iterations": restitution_iterations,
        "position_iterations": position_iterations, "converged": bool(converged),
        "contacts": len(rows["mu"]),
    })
    return out
