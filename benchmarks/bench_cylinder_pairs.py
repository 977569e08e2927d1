"""Exactness of every cylinder pair type (issue 8's target): prints, never asserts.

    python benchmarks/bench_cylinder_pairs.py [--pairs 10000] [--types cylinder,polytope,...]
                                              [--oracle-every 100]

Target: the deepest contact's gap within 1e-9 m of the reference signed distance, on 10,000
seeded pairs of every cylinder pair type (a cylinder against a sphere, a capsule, a cylinder, a
box, a convex hull, a convex mesh piece, a plane, a one-triangle mesh), apart, exactly touching,
and shallowly or deeply overlapping.

The pairs are made as in tests/python/test_table_slots.py, by tests/python/helpers.py (whose module
docstring has the argument): a random unit d, A's support point x_A along d, B's x_B along -d,
and B moved so that x_B = x_A + delta d. Then delta is the
signed distance exactly when delta >= 0, and when -delta is less than the summed radii rho of
balls inside the shapes that touch their surfaces at x_A and x_B (a face, a cylinder's cap or
side, a sphere or capsule: rho > 0; a vertex, an edge or a rim: 0). Regimes cycle with the pair
index: apart (0.1 to 10 mm), touching (delta = 0, any features: a rim exactly on a vertex too),
shallow (in by up to min(rho / 2, 2 cm)) and deep (in by 20 % to 50 % of rho, up to 20 cm here).
Every `--oracle-every`-th pair is also checked against signorini.oracle's brute-force support
search, which shares no code with the core or the construction: g(d) from its support mappings
equals delta, and its search over the sphere of directions finds nothing better ("reference").

Columns per pair type:
- pairs; none: pairs without a contact (every pair is within the 1 cm margin, so each is a
  failure); near: pairs where a face lies within 5.7 degrees of d but not along it, which the core
  clips as a face (test_table_slots.test_random_item_pairs): their deepest gap is only bounded
  (min(delta, delta / 0.995) - 2 tol <= gap <= delta + tol) and they are counted in "bound" and
  left out of "gap err";
- gap err: the largest |deepest gap - delta| (m) over the other pairs; > 1e-9: how many exceed the
  target;
- witness: the largest |signed distance| of the deepest contact's two witnesses (point -+ gap/2
  normal) from their shapes (m), over all pairs;
- normal: the largest angle (rad) between the deepest contact's normal and d where d is unique
  (delta != 0, rho + delta > 0) and no face is near;
- bound: near pairs outside their bound; reference: oracle checks failed / done;
- us/pair: wall time of sg.collide per pair, Python call included (not the C++ benchmark).
"""
from __future__ import annotations

import argparse
import sys
import time
import zlib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "python"))
import signorini as sg  # noqa: E402
from signorini.oracle import support as osup  # noqa: E402
from helpers import (  # noqa: E402
    EXACT, FACE_COS, IDENTITY, MARGIN, Body, Placed, angle, lone_triangle_pair, orient, place_pair, support_tol,
    witnesses)

TYPES = ["sphere", "capsule", "cylinder", "box", "hull", "mesh", "plane", "triangle"]
REGIMES = ("apart", "touch", "shallow", "deep")
DEEP_CAP = 0.2  # m


def delta_of(regime, rho, rng):
    if regime == "apart":
        return rng.uniform(1e-4, MARGIN - 1e-4)
    if regime == "touch":
        return 0.0
    if regime == "shallow":
        return -rng.uniform(1e-4, 1.0) * min(0.5 * rho, 0.02)
    return -rng.uniform(0.2, 0.5) * min(rho, 2.0 * DEEP_CAP)


def item_pair(kind, seed, k):
    """(a, b, d, delta, rho, regime): a cylinder A and a `kind` B, or None to skip."""
    rng = np.random.default_rng([seed, k])
    A, B = Body("cylinder", rng), Body(kind, rng)
    regime = REGIMES[k % 4]
    fa, fb = bool(rng.integers(2)), bool(rng.integers(2)) and kind != "sphere"
    if regime in ("shallow", "deep") and not (fa or fb) and kind != "sphere":
        fa = True  # an overlap needs an inscribed ball on one side at least
    return (*place_pair(A, B, rng, regime, fa, fb, delta_of), regime)


def reference_check(f, sa, sb, d, delta):
    """Counts in f whether the constructed pair (support functions sa of A, sb of B) really is
    delta apart along d: the supports' gap along d, and the oracle's brute-force separation."""
    g = float((sb(-d)[0] - sa(d)[0]) @ d)
    sep, _ = osup.support_separation(sa, sb)
    f["ref"] += 1
    f["ref_bad"] += abs(g - delta) > EXACT or sep > delta + EXACT


def timed_collide(f, shape_a, pose_a, shape_b, pose_b):
    """sg.collide of the pair, its time added to f["t"] and the pair counted in f (f["none"] when
    it has no contact: then None is returned, else the contacts)."""
    t0 = time.perf_counter()
    c = sg.collide(shape_a, pose_a, shape_b, pose_b, margin=MARGIN)
    f["t"] += time.perf_counter() - t0
    f["pairs"] += 1
    if len(c) == 0:
        f["none"] += 1
        return None
    return c


def run_items(kind, n, oracle_every):
    seed = zlib.crc32(("bench cylinder-" + kind).encode())
    f = dict(pairs=0, none=0, near=0, gap=0.0, over=0, witness=0.0, normal=0.0, bound=0, ref_bad=0, ref=0, t=0.0)
    for k in range(n):
        a, b, d, delta, rho, regime = item_pair(kind, seed, k)
        if k % oracle_every == 0:
            reference_check(f, a.support_fn(), b.support_fn(), d, delta)
        first, second, n_ref = (a, b, d) if k % 2 == 0 else (b, a, -d)
        c = timed_collide(f, first.body.shape, first.pose, second.body.shape, second.pose)
        if c is None:
            continue
        i = int(np.argmin(c.gap))
        g, nrm = float(c.gap[i]), c.normal[i]
        w1, w2 = witnesses(c)
        f["witness"] = max(f["witness"], abs(float(first.sd(w1[i])[0])), abs(float(second.sd(w2[i])[0])))
        cos_f = max(a.best_face_cos(d), b.best_face_cos(-d))
        if FACE_COS - 1e-6 <= cos_f < 1.0 - 1e-12:
            f["near"] += 1
            tol = support_tol(a, b)
            f["bound"] += not (min(delta, delta / FACE_COS) - 2 * tol <= g <= delta + tol)
            continue
        err = abs(g - delta)
        f["gap"] = max(f["gap"], err)
        f["over"] += err > EXACT
        if delta != 0.0 and rho + delta > 0.0:
            f["normal"] = max(f["normal"], angle(nrm, n_ref))
    return f


def run_plane(n, oracle_every):
    """A plane of random normal and offset, the cylinder on it lifted or pressed in by delta: the
    cylinder's support point along -n is exact, so is the gap (test_random_plane_pairs)."""
    seed = zlib.crc32(b"bench cylinder-plane")
    f = dict(pairs=0, none=0, near=0, gap=0.0, over=0, witness=0.0, normal=0.0, bound=0, ref_bad=0, ref=0, t=0.0)
    for k in range(n):
        rng = np.random.default_rng([seed, k])
        body = Body("cylinder", rng)
        nn = rng.normal(size=3)
        nn /= np.linalg.norm(nn)
        offset = rng.uniform(-1.0, 1.0)
        regime = REGIMES[k % 4]
        R, x, rho = orient(body, -nn, rng, bool(rng.integers(2)))
        delta = {"apart": rng.uniform(1e-4, MARGIN - 1e-4), "touch": 0.0, "shallow": -rng.uniform(1e-4, 0.02),
                 "deep": -rng.uniform(0.02, DEEP_CAP)}[regime]
        t = rng.normal(size=3)
        b = Placed(body, offset * nn + (t - (t @ nn) * nn) + delta * nn - R @ x, R)
        plane = sg.Plane(nn, offset)
        c = timed_collide(f, plane, ((0, 0, 0), IDENTITY), body.shape, b.pose)
        if c is None:
            continue
        i = int(np.argmin(c.gap))
        err = abs(float(c.gap[i]) - delta)
        f["gap"] = max(f["gap"], err)
        f["over"] += err > EXACT
        on_plane, on_body = witnesses(c)
        f["witness"] = max(f["witness"], abs(float(on_plane[i] @ nn - offset)), abs(float(b.sd(on_body[i])[0])))
        f["normal"] = max(f["normal"], angle(c.normal[i], nn))
    return f


def run_triangle(n, oracle_every):
    """A one-triangle mesh and the cylinder against its face, or against its edges and vertices
    from above (helpers.lone_triangle_pair with cylinder_touch: apart, touching, or in by
    less than the inscribed ball onto the face); the pairs whose cylinder reaches behind the plane
    are skipped. Touching a vertex or an edge, where the normal is not unique, takes the normal of
    the cylinder raised by a hair (lone_triangle_pair says why); a pair with no contact shows in
    the "none" column."""
    seed = zlib.crc32(b"bench cylinder-triangle")
    f = dict(pairs=0, none=0, near=0, gap=0.0, over=0, witness=0.0, normal=0.0, bound=0, ref_bad=0, ref=0, t=0.0)
    for k in range(n):
        made = lone_triangle_pair("cylinder", seed, k, cylinder_touch=True)
        if made is None:
            continue
        V, n_t, b, d, delta, rho, regime, face = made
        if k % oracle_every == 0:
            reference_check(f, osup.support_hull(V, np.zeros(3), np.eye(3)), b.support_fn(), d, delta)
        c = timed_collide(f, sg.TriangleMesh(V, np.array([[0, 1, 2]])), ((0, 0, 0), IDENTITY), b.body.shape, b.pose)
        if c is None:
            continue
        i = int(np.argmin(c.gap))
        err = abs(float(c.gap[i]) - delta)
        f["gap"] = max(f["gap"], err)
        f["over"] += err > EXACT
        f["witness"] = max(f["witness"], abs(float(b.sd(witnesses(c)[1][i])[0])))
        if delta != 0.0 and rho + delta > 0.0:
            f["normal"] = max(f["normal"], angle(c.normal[i], d))
    return f


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--pairs", type=int, default=10000)
    p.add_argument("--types", default=",".join(TYPES))
    p.add_argument("--oracle-every", type=int, default=100)
    args = p.parse_args(argv)
    print(f"cylinder pairs: {args.pairs} seeded pairs per type (triangle: those in front of its plane), "
          f"target: deepest gap within {EXACT:.0e} m of the reference")
    print(f"{'pair':<20} {'pairs':>6} {'none':>5} {'near':>5} {'gap err':>10} {'>1e-9':>6} {'witness':>10} {'normal':>10} "
          f"{'bound':>6} {'reference':>10} {'us/pair':>8}")
    rows = []
    for kind in args.types.split(","):
        start = time.perf_counter()
        if kind == "plane":
            f = run_plane(args.pairs, args.oracle_every)
        elif kind == "triangle":
            f = run_triangle(args.pairs, args.oracle_every)
        else:
            f = run_items(kind, args.pairs, args.oracle_every)
        f["kind"] = "cylinder-" + kind
        rows.append(f)
        print(f"{f['kind']:<20} {f['pairs']:>6} {f['none']:>5} {f['near']:>5} {f['gap']:>10.2e} {f['over']:>6} {f['witness']:>10.2e} "
              f"{f['normal']:>10.2e} {f['bound']:>6} {f['ref_bad']:>4}/{f['ref']:<5} {1e6 * f['t'] / max(f['pairs'], 1):>8.1f}"
              f"   ({time.perf_counter() - start:.0f} s)", flush=True)
    return rows


if __name__ == "__main__":
    main()
