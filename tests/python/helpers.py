"""Test helpers shared by the tests and the benchmarks: random convex bodies and placements of
known separation, triangle floors, and the tolerances they are checked to.

The reference separation of a random pair is made, not searched for: a random unit d (A -> B),
x_A a point of A's support set along d, x_B one of B's along -d, and B moved so that
x_B = x_A + delta d. Then
  - delta >= 0: the planes d . x = d . x_A and d . x = d . x_A + delta separate A and B, and
    |x_B - x_A| = delta, so the distance is delta exactly, and the closest-point direction
    (unique for convex sets apart) is d;
  - delta < 0: if a ball of radius rho_A inside A touches A's surface at x_A (its centre
    x_A - rho_A d) and one of radius rho_B inside B touches at x_B, the Minkowski difference B - A
    holds a ball of radius rho = rho_A + rho_B tangent to the support plane at the origin's foot,
    so for -delta < rho the penetration depth is -delta exactly and its direction d is unique.
    rho is 0 at a vertex, an edge or a rim, r for spheres and capsules, and at a point of a face
    (polytope face, cylinder cap or side) the largest inscribed ball there, in closed form.

Tolerances (m):
  EXACT = 1e-9: closed forms (spheres, capsules, polytopes, planes, triangles) evaluate a few dozen
    double operations on coordinates below 3 m, i.e. rounding of ~1e-15; 1e-9 is the issue's figure.
  support pairs (a cylinder against anything but a sphere): GJK stops at a duality gap of 1e-12 of
    the pair's scale and EPA at 1e-10 L (docs/conventions.md), L = the pair's summed bounding radii
    (< 2 m here); a clipped manifold takes the support pair only when it is deeper than every
    clipped point by 1e-9 L. Hence 1e-9 + 1e-9 L/m on gaps and witnesses (support_tol).
  witnesses: on or inside their shape within the gap tolerance; the deepest contact's on the
    surface (a clipped capsule's body witness may lie inside: test_random_pairs._assert_on_body).
  normals: where the direction is unique, closed forms to EXACT; a support pair's normal n to the
    angle its gap tolerance allows, sqrt(4 tol / (rho + delta)) (normal_bound).
"""
import importlib.util
import math
import os
import pickle
import sys
from pathlib import Path

import numpy as np

import signorini as sg
from signorini import scenes
from signorini.oracle import support as osup
from signorini.oracle.rigid import matrix_to_quat as quat_of, quat_to_matrix

EXACT = 1e-9
MARGIN = 0.01        # m: the random pairs are apart by at most this (minus a hair)
FACE_COS = 0.995     # a face within acos(0.995) = 5.7 degrees of the normal is clipped as a face
                     # (support_feature in cpp/src/collision/round_contacts.cpp; CURVED_TOL in test_random_pairs)
IDENTITY = (1.0, 0.0, 0.0, 0.0)
Z = np.array([0.0, 0.0, 1.0])
KINDS = {"sphere": ("sphere",), "capsule": ("capsule",), "cylinder": ("cylinder",), "polytope": ("box", "hull", "mesh")}
FULL = os.environ.get("SIGNORINI_FULL", "") not in ("", "0")


def sample(default, full):
    """The size of a seeded random sample: `default` in the default suite, `full` with
    SIGNORINI_FULL=1 (the default sample is the first `default` of the full one: same seed)."""
    return full if FULL else default


# --------------------------------------------------------------------------- shapes and floors

def random_hull_points(rng):
    k = rng.integers(6, 20)
    return rng.normal(size=(k, 3)) * rng.uniform(0.1, 0.6, 3)


def tessellated_floor(n=8, half=1.0):
    """A flat 2 half x 2 half m floor in z = 0 of n x n squares, two triangles each: every interior
    edge is inactive (flat)."""
    xs = np.linspace(-half, half, n + 1)
    V = np.array([(x, y, 0.0) for y in xs for x in xs])
    F = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            F += [(a, a + 1, a + n + 2), (a, a + n + 2, a + n + 1)]
    return sg.TriangleMesh(V, np.array(F))


def signed_distance(kind, r, h, x):
    """Signed distance of body-frame points x (K, 3) from a capsule or cylinder (radius r, half
    height h, axis z)."""
    if kind == "capsule":
        return np.linalg.norm(x - np.outer(np.clip(x[:, 2], -h, h), [0, 0, 1]), axis=1) - r
    d_r, d_z = np.hypot(x[:, 0], x[:, 1]) - r, np.abs(x[:, 2]) - h
    return np.minimum(np.maximum(d_r, d_z), 0.0) + np.hypot(np.maximum(d_r, 0.0), np.maximum(d_z, 0.0))


# --------------------------------------------------------------------------- rotations

def random_rotation(rng):
    q = rng.normal(size=4)
    return quat_to_matrix(q / np.linalg.norm(q))


def frame(v):
    """A rotation whose first column is the unit vector v."""
    v = v / np.linalg.norm(v)
    t = np.cross(v, [1.0, 0.0, 0.0] if abs(v[0]) < 0.9 else [0.0, 1.0, 0.0])
    t /= np.linalg.norm(t)
    return np.column_stack([v, t, np.cross(v, t)])


def aligning(n_local, d, rng):
    """A rotation R with R n_local = d, turned about d at random."""
    phi = rng.uniform(0.0, 2.0 * np.pi)
    c, s = np.cos(phi), np.sin(phi)
    spin = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    return frame(d) @ spin @ frame(n_local).T


# --------------------------------------------------------------------------- convex bodies and pairs

class Body:
    """A random convex shape of one kind with its geometry in its own frame: signed distance,
    support points, its flat features (faces, cylinder caps and sides) and their inscribed balls."""

    def __init__(self, kind, rng):
        self.kind = kind
        if kind == "sphere":
            self.r = rng.uniform(0.1, 0.5)
            self.shape = sg.Sphere(self.r)
        elif kind == "capsule":
            self.r, self.h = rng.uniform(0.05, 0.3), rng.uniform(0.05, 0.5)
            self.shape = sg.Capsule(self.r, self.h)
        elif kind == "cylinder":
            self.r, self.h = rng.uniform(0.1, 0.4), rng.uniform(0.05, 0.4)
            self.shape = sg.Cylinder(self.r, self.h)
        else:
            if kind == "box":
                h = rng.uniform(0.1, 0.5, 3)
                self.shape = sg.Box(h)
                V = np.array([[sx * h[0], sy * h[1], sz * h[2]] for sz in (-1, 1) for sy in (-1, 1) for sx in (-1, 1)])
                F = np.array(sg.ConvexHull(V).faces)   # the box's 12 triangles, for sampling its faces
            elif kind == "hull":
                self.shape = sg.ConvexHull(random_hull_points(rng))
                V, F = np.asarray(self.shape.vertices), np.asarray(self.shape.faces)
            else:
                # a convex mesh (a mesh piece): the hull's triangles of random points or of a prism
                # (its caps merge into one polygon face each). Never a vertex inside a face: see
                # test_a_convex_mesh_with_a_vertex_inside_a_face_does_not_crash
                if rng.integers(2):
                    pts = random_hull_points(rng)
                else:
                    k, r, hh = int(rng.integers(5, 10)), rng.uniform(0.1, 0.4), rng.uniform(0.05, 0.4)
                    phi = 2.0 * np.pi * np.arange(k) / k
                    pts = np.array([(r * np.cos(p), r * np.sin(p), z) for z in (-hh, hh) for p in phi])
                hull = sg.ConvexHull(pts)
                V, F = np.asarray(hull.vertices), np.asarray(hull.faces)
                self.shape = sg.Mesh(V, F)
            self.V = V
            T = V[F]
            n = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
            n /= np.linalg.norm(n, axis=1)[:, None]
            n *= np.where(np.einsum("ij,ij->i", n, T[:, 0] - V.mean(axis=0)) >= 0, 1.0, -1.0)[:, None]
            self.T, self.N, self.D = T, n, np.einsum("ij,ij->i", n, T[:, 0])

    @property
    def polytope(self):
        return self.kind in ("box", "hull", "mesh")

    def radius(self):
        """Bounding radius about the body origin (the core's L uses the same)."""
        if self.kind == "sphere":
            return self.r
        if self.kind == "capsule":
            return self.r + self.h
        if self.kind == "cylinder":
            return np.hypot(self.r, self.h)
        return np.linalg.norm(self.V, axis=1).max()

    def sd(self, x):
        """Signed distance (K,) of body-frame points x (K, 3). Polytopes: the largest face-plane
        distance, exact inside and a lower bound outside (within the dihedral factor)."""
        x = np.atleast_2d(x)
        if self.kind == "sphere":
            return np.linalg.norm(x, axis=1) - self.r
        if self.kind in ("capsule", "cylinder"):
            return signed_distance(self.kind, self.r, self.h, x)
        return np.max(x @ self.N.T - self.D, axis=1)

    def support(self, d):
        """(x, rho): a point of the support set along unit d (body frame) and the radius of a ball
        inside the body touching its surface there (0 where no such ball is known)."""
        if self.kind == "sphere":
            return self.r * d, self.r
        if self.kind == "capsule":
            return np.copysign(self.h, d[2]) * Z + self.r * d, self.r
        if self.kind == "cylinder":
            u = np.array([d[0], d[1], 0.0])
            if np.linalg.norm(u) < 1e-12:  # along the axis: the cap's centre
                return np.copysign(self.h, d[2]) * Z, min(self.r, self.h)
            return np.copysign(self.h, d[2]) * Z + self.r * u / np.linalg.norm(u), 0.0
        return self.V[np.argmax(self.V @ d)], 0.0

    def flat(self, rng):
        """A random point of a flat support feature (polytope face, cylinder cap or side, capsule
        side): (x, outward normal, inscribed-ball radius) in the body frame."""
        if self.kind == "capsule":
            phi = rng.uniform(0.0, 2.0 * np.pi)
            n = np.array([np.cos(phi), np.sin(phi), 0.0])
            return self.r * n + rng.uniform(-self.h, self.h) * Z, n, self.r
        if self.kind == "cylinder":
            phi = rng.uniform(0.0, 2.0 * np.pi)
            if rng.integers(2):  # a cap, at radius t from the axis: ball of radius min(r - t, h)
                n = np.array([0.0, 0.0, rng.choice([-1.0, 1.0])])
                t = self.r * np.sqrt(rng.uniform(0.0, 0.9))
                return np.array([t * np.cos(phi), t * np.sin(phi), n[2] * self.h]), n, min(self.r - t, self.h)
            n = np.array([np.cos(phi), np.sin(phi), 0.0])  # the side, at height z: min(r, h - |z|)
            z = rng.uniform(-0.9, 0.9) * self.h
            return self.r * n + z * Z, n, min(self.r, self.h - abs(z))
        k = rng.integers(len(self.T))
        x = rng.dirichlet([2.0, 2.0, 2.0]) @ self.T[k]
        n = self.N[k]
        # the ball of radius rho centred at x - rho n is inside every face plane j:
        # n_j . (x - rho n) + rho <= d_j, i.e. rho (1 - n_j . n) <= d_j - n_j . x
        cos = self.N @ n
        other = cos < 1.0 - 1e-9
        return x, n, max(0.0, float(np.min((self.D[other] - self.N[other] @ x) / (1.0 - cos[other]))))

    def face_normals(self):
        """Normals (body frame) of the faces the core may clip (polytope faces, cylinder caps)."""
        if self.polytope:
            return self.N
        if self.kind == "cylinder":
            return np.array([Z, -Z])
        return np.zeros((0, 3))


class Placed:
    """A body at (p, R), R exactly the matrix the core builds from the quaternion q."""

    def __init__(self, body, p, R):
        self.body, self.q = body, quat_of(R)
        self.R = quat_to_matrix(self.q)
        self.p = np.asarray(p, dtype=float)

    @property
    def pose(self):
        return (self.p, self.q)

    def sd(self, X):
        return self.body.sd((np.atleast_2d(X) - self.p) @ self.R)

    def support_fn(self):
        return osup.support_of(sg.shape_dict(self.body.shape), self.p, self.R)

    def best_face_cos(self, d):
        """The largest cosine between d (world) and a clippable face normal of the body."""
        N = self.body.face_normals()
        return float(np.max(N @ (self.R.T @ d))) if len(N) else -1.0


def orient(body, d, rng, flat):
    """A rotation of `body` and its local support point along d: (R, x_local, rho)."""
    if flat:
        x, n, rho = body.flat(rng)
        return quat_to_matrix(quat_of(aligning(n, d, rng))), x, rho
    R = random_rotation(rng)
    x, rho = body.support(R.T @ d)
    return R, x, rho


def place_pair(A, B, rng, regime, flat_a, flat_b, delta_of=None):
    """A at random, B against it along a random d as in the module docstring: (a, b, d, delta, rho).
    delta_of(regime, rho, rng), when given, draws delta for regimes of its own (the benchmarks')."""
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    R_a, x_a, rho_a = orient(A, d, rng, flat_a)
    R_b, x_b, rho_b = orient(B, -d, rng, flat_b)
    a = Placed(A, rng.uniform(-1.0, 1.0, 3), R_a)
    rho = rho_a + rho_b
    if delta_of is not None:
        delta = delta_of(regime, rho, rng)
    elif regime == "apart":
        delta = rng.uniform(1e-4, MARGIN - 1e-4)
    elif regime == "touch":
        delta = 0.0
    else:  # shallow: at most half the inscribed balls' radius (so that rho + delta >= rho / 2) and 2 cm
        delta = -rng.uniform(1e-4, 1.0) * min(0.5 * rho, 0.02)
    x_world = a.p + a.R @ x_a
    R_b = quat_to_matrix(quat_of(R_b))
    b = Placed(B, x_world + delta * d - R_b @ x_b, R_b)
    return a, b, d, delta, rho


def witnesses(c):
    half = 0.5 * c.gap[:, None] * c.normal
    return c.point - half, c.point + half


def normal_bound(tol, rho, delta):
    """Largest angle (rad) between a support pair's normal n and the unique direction d: its gap
    g(n) >= delta - 2 tol (its gap within tol of delta, its certificate gap - g(n) within tol),
    while the inscribed ball (module docstring; for delta > 0 the ball of radius delta about the
    origin outside B - A) gives g(n) <= delta - (rho + delta)(1 - cos angle); so
    angle <= sqrt(4 tol / (rho + delta)) to first order. None when the direction is not unique."""
    return np.sqrt(4.0 * tol / (rho + delta)) if delta != 0.0 and rho + delta > 0.0 else None


def angle(u, v):
    """Angle (rad) between vectors, accurate near 0 (arccos of a dot product is not: 1.5e-8 at 1 ulp)."""
    return float(np.arctan2(np.linalg.norm(np.cross(u, v)), u @ v))


def support_tol(a, b):
    """Gap and witness tolerance of a support (GJK/EPA) pair, m (module docstring)."""
    return EXACT + 1e-9 * (a.body.radius() + b.body.radius())


# --------------------------------------------------------------------------- lone triangles

def static_body(kind, rng, k):
    """The k-th body of a kind: polytopes cycle box, hull, mesh with k // 3 (regimes with k % 3)."""
    return Body(KINDS[kind][(k // 3) % len(KINDS[kind])], rng)


def lone_triangle(rng):
    V = rng.normal(size=(3, 3)) * 0.5
    n_t = np.cross(V[1] - V[0], V[2] - V[0])
    return V, n_t / np.linalg.norm(n_t)


def lone_triangle_pair(kind, seed, k, off_face=False, min_cos=0.2, cylinder_touch=False):
    """A one-triangle mesh (all three edges active) and a body against it along d: d = n_t onto a
    random point of the face (apart, touching, or in by less than the body's inscribed ball), or
    a random d with d . n_t >= min_cos onto the triangle's vertex furthest along d (apart; touching
    too except for cylinders, unless cylinder_touch: see below). Returns
    (V, n_t, b, d, delta, rho, regime, face), or None when the body's centre is behind the triangle's
    plane (a body is then left alone or pushed back through: the one-sided rules)."""
    rng = np.random.default_rng([seed, k])
    V, n_t = lone_triangle(rng)
    body = static_body(kind, rng, k)
    # touching a vertex or an edge, a polytope or cylinder gets the normal of the body raised by a
    # hair (docs/conventions.md, "Contacts", static triangle mesh); off_face=True: off the face only
    face = k % 2 == 0 and not off_face
    regime = ("apart", "touch", "over")[k % 3] if face else ("apart", "touch")[k % 2]
    if not off_face:
        regime = "apart" if kind == "cylinder" and not face and not cylinder_touch else regime
    if face:
        d, x_a = n_t, rng.dirichlet([2.0, 2.0, 2.0]) @ V
    else:
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        if d @ n_t < min_cos:
            d = d - (d @ n_t - min_cos - rng.uniform(0.0, 1.0 - min_cos)) * n_t
            d /= np.linalg.norm(d)
        x_a = V[np.argmax(V @ d)]
    round_body = body.kind in ("sphere", "capsule")
    flat = (regime == "over" and not round_body) or (bool(rng.integers(2)) and body.kind != "sphere")
    R, x, rho = orient(body, -d, rng, flat)
    delta = {"apart": rng.uniform(1e-4, MARGIN - 1e-4), "touch": 0.0,
             "over": -rng.uniform(1e-4, 1.0) * min(0.5 * rho, 0.02)}[regime]
    b = Placed(body, x_a + delta * d - R @ x, R)
    if n_t @ (b.p - V[0]) <= 0.0:
        return None
    return V, n_t, b, d, delta, rho, regime, face


# ---- scenes shared by the solver tests (tests/python/test_solver.py, test_soft_step.py) ----------

def block_on_slope(mu, dt, angle_deg=30.0, **world_kwargs):
    """A 1 kg unit box resting on a plane tilted by angle about y, in World(**world_kwargs);
    returns (world, body, downhill)."""
    th = math.radians(angle_deg)
    n = np.array([-math.sin(th), 0.0, math.cos(th)])
    w = sg.World(**world_kwargs)
    w.add_static(sg.Plane(normal=n, offset=0.0), friction=mu)
    q = scenes.axis_angle_quaternion((0, 1, 0), -th)
    b = w.add_body(sg.Box((0.5, 0.5, 0.5)), mass=1.0, position=0.5 * n, orientation=q, friction=mu)
    downhill = np.array([math.cos(th), 0.0, math.sin(th)]) * -1.0
    return w, b, downhill


def first_rebound_apex(dt, e=0.5, h=1.0, r=0.1, **settings):
    """Apex of a sphere's first rebound over its drop height h (bottom of the sphere)."""
    w = sg.World(**settings)
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0), restitution=e)
    b = w.add_body(sg.Sphere(r), mass=1.0, position=(0, 0, h + r), restitution=e)
    z, vz = [], []
    for _ in range(round(1.5 / dt)):
        w.step(dt)
        z.append(w.positions[b][2] - r)
        vz.append(w.velocities[b][2])
    z, vz = np.array(z), np.array(vz)
    up = int(np.argmax(vz > 0))
    down = up + int(np.argmax(vz[up:] <= 0))
    return z[up:down + 1].max() / h


def newtons_cradle(**world_kwargs):
    """Five equal frictionless 1 kg spheres (r = 0.1 m) 2 cm apart on the x axis, e = 1, no gravity,
    the first at 1 m/s towards the others, after 2 s of dt 1/240 in World(**world_kwargs)."""
    w = sg.World(gravity=(0, 0, 0), **world_kwargs)
    for k in range(5):
        w.add_body(sg.Sphere(0.1), mass=1.0, position=(0.22 * k, 0, 0), friction=0.0, restitution=1.0)
    w.set_velocity(0, (1.0, 0, 0))
    w.step(1 / 240, 480)
    return w


def head_on_velocities(e, **world_kwargs):
    """Two frictionless 1 kg spheres meeting head on at 1 m/s each with restitution e, no gravity:
    their x velocities after 1 s of dt 1/240 in World(**world_kwargs)."""
    w = sg.World(gravity=(0, 0, 0), **world_kwargs)
    a = w.add_body(sg.Sphere(0.1), mass=1.0, position=(-0.3, 0, 0), velocity=(1, 0, 0), friction=0.0,
                   restitution=e)
    b = w.add_body(sg.Sphere(0.1), mass=1.0, position=(0.3, 0, 0), velocity=(-1, 0, 0), friction=0.0,
                   restitution=e)
    w.step(1 / 240, 240)
    return w.velocities[a][0], w.velocities[b][0]


# ---- many runs (test_sweep.py, test_batch.py) -----------------------------------------------------
SLOPE_ANGLE = math.radians(25.0)
SLOPE_DOWN = np.array([-math.cos(SLOPE_ANGLE), 0.0, -math.sin(SLOPE_ANGLE)])   # down the slope


def slope_box(seed: int = 0, friction: float = 0.3) -> sg.World:
    """A 0.2 m box (density 1000: 8 kg) at rest on a 25 degree slope of friction 1, the box's
    `friction` (a contact uses sqrt(mu_A mu_B)); seed s starts it s mm further down the slope."""
    w = sg.World(gravity=(0, 0, -9.81))
    n = np.array([-math.sin(SLOPE_ANGLE), 0.0, math.cos(SLOPE_ANGLE)])
    w.add_static(sg.Plane(normal=n, offset=0.0), friction=1.0)
    w.add_body(sg.Box(half_extents=(0.1, 0.1, 0.1)), density=1000.0, position=tuple(0.1 * n + 1e-3 * seed * SLOPE_DOWN),
               orientation=(math.cos(-SLOPE_ANGLE / 2), 0.0, math.sin(-SLOPE_ANGLE / 2), 0.0), friction=friction)
    return w


def down_slope_speed(w: sg.World) -> dict:
    """The box's velocity along the slope, downwards (m/s), as a sweep metric."""
    return {"speed": float(w.velocities[1] @ SLOPE_DOWN)}


def ell_arrays():
    """(vertices (12, 3), faces (20, 3)) of a closed, outward L-shaped prism (0.2 x 0.2 x 0.1 m):
    not convex; CoACD cuts it in about a second (the decomposition tests' mesh)."""
    outline = np.array([(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)], dtype=float) * 0.1
    n = len(outline)
    v = np.vstack([np.c_[outline, np.zeros(n)], np.c_[outline, np.full(n, 0.1)]])
    caps = [(0, 2, 1), (0, 3, 2), (0, 4, 3), (0, 5, 4)]
    f = caps + [(a + n, c + n, b + n) for a, b, c in caps]
    f += [t for i in range(n) for t in ((i, (i + 1) % n, (i + 1) % n + n), (i, (i + 1) % n + n, i + n))]
    return v, np.array(f)


def load_benchmark(name: str):
    """benchmarks/<name>.py as a module (the smoke tests call its main), registered in sys.modules
    before it runs: its dataclasses look their module up by name."""
    spec = importlib.util.spec_from_file_location(name, Path(__file__).resolve().parents[2] / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


# ---- joints (tests/python/test_joints.py, test_joint_twist.py, test_oracle_soft_joints.py) ----

def assert_pickle_and_saved_state_continue(w: sg.World, dt: float, steps: int = 60) -> None:
    """A pickled copy of ``w`` and ``w`` restored from its saved state each go on bit for bit as
    ``w`` does over ``steps`` steps of ``dt`` (``w`` ends stepped by them, from where it was)."""
    copy = pickle.loads(pickle.dumps(w))
    saved = w.save_state()
    w.step(dt, steps)
    copy.step(dt, steps)
    np.testing.assert_array_equal(w.positions, copy.positions)
    after = w.positions.copy()
    w.restore_state(saved)
    w.step(dt, steps)
    np.testing.assert_array_equal(w.positions, after)

LO, HI = -0.3, 0.4  # rad: hanging_rod's twist limits
AXIS = np.array([0.0, 0.0, -1.0])  # hanging_rod's joint axis: straight down along the rod


def hanging_rod(solver, spin, swing=0.0, cone=None, twist=(LO, HI)):
    """A 1 kg rod of 1 m (a thin box along z) hanging from a ball joint at the origin, spun about
    its own axis at `spin` rad/s (positive: psi grows) and kicked sideways at `swing` rad/s.
    Returns (world, rod, joint)."""
    w = sg.World(solver=solver, sleeping=False)
    ground = w.add_static(sg.Plane(normal=(0, 0, 1), offset=-100.0))
    rod = w.add_body(sg.Box((0.05, 0.02, 0.5)), mass=1.0, position=(0, 0, -0.5))
    limited = cone is not None or twist is not None
    j = w.add_joint(sg.Spherical(ground, rod, anchor=(0, 0, 0), axis=AXIS if limited else None, cone=cone, twist=twist))
    omega = spin * AXIS + np.array([swing, 0.0, 0.0])
    w.set_angular_velocity(rod, omega)
    w.set_velocity(rod, np.cross(omega, (0, 0, -0.5)))
    return w, rod, j


def every_kind(solver="pgs"):
    """Short chains of each joint kind (a hinge with limits, one with a motor, a slider with limits
    and a motor, a ball, a weld, a rope, a rod, a servo hinge, a damped slider, a hinge (with an
    effort) and a slider with friction, and a ball with a cone and twist limits) hanging from the
    world and swinging onto a floor with loose boxes: joints beside contacts (tests/python/test_joints.py
    and test_oracle_soft_joints.py)."""
    w = sg.World(solver=solver, sleeping=False, gravity=(0.0, 0.0, -9.81))
    floor = w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    specs = [
        lambda a, b, x: sg.Revolute(a, b, anchor=x, axis=(0, 1, 0), limits=(-0.4, 0.6)),
        lambda a, b, x: sg.Revolute(a, b, anchor=x, axis=(0, 0.6, 0.8), motor=sg.Motor(2.0, max_torque=0.05)),
        lambda a, b, x: sg.Prismatic(a, b, anchor=x, axis=(0.6, 0, -0.8), limits=(-0.05, 0.1),
                                     motor=sg.Motor(-0.3, 2.0)),
        lambda a, b, x: sg.Spherical(a, b, anchor=x),
        lambda a, b, x: sg.Fixed(a, b, anchor=x),
        lambda a, b, x: sg.Distance(a, b, x, x + np.array([0.05, 0.0, 0.0]), 0.0, 0.08),
        lambda a, b, x: sg.Distance(a, b, x, x + np.array([0.05, 0.0, 0.0])),
        # spring-damper motors: a servo hinge, and a damped slider
        lambda a, b, x: sg.Revolute(a, b, anchor=x, axis=(1, 0, 0),
                                    motor=sg.Motor(0.2, max_torque=0.02, position=0.3, stiffness=0.5, damping=0.01)),
        lambda a, b, x: sg.Prismatic(a, b, anchor=x, axis=(0, 0, 1), limits=(-0.05, 0.05),
                                     motor=sg.Motor(0.0, np.inf, damping=2.0)),
        # Coulomb friction: a hinge with a motor too, and a slider
        lambda a, b, x: sg.Revolute(a, b, anchor=x, axis=(0, 1, 0), friction=0.004, motor=sg.Motor(1.0, 0.01),
                                    effort=0.003),
        lambda a, b, x: sg.Prismatic(a, b, anchor=x, axis=(0.6, 0, -0.8), limits=(-0.05, 0.1), friction=0.3),
        # a ball joint with a cone and a twist range
        lambda a, b, x: sg.Spherical(a, b, anchor=x, axis=(1, 0, 0), cone=0.4, twist=(-0.2, 0.2)),
    ]
    for c, spec in enumerate(specs):
        prev = floor
        for k in range(3):
            b = w.add_body(sg.Box((0.1, 0.03, 0.03)), density=500.0, position=(0.1 + 0.2 * k, 0.3 * c, 0.35),
                           angular_velocity=(0.3 * c, 0.5, 0.2 * k))
            w.add_joint(spec(prev, b, np.array([0.2 * k, 0.3 * c, 0.35])))
            prev = b
    for k in range(6):
        w.add_body(sg.Box((0.05, 0.05, 0.05)), density=500.0, position=(0.2 * k, 0.15 + 0.3 * (k % 3), 0.06))
    return w
