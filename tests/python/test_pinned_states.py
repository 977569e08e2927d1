"""Three busy scenes end in pinned states: a restructuring that must not change behaviour (issue 20)
changes none of these bits. The digest covers the final poses and velocities and the last step's
contacts (points, normals, gaps, forces and feature ids).

If a change is meant to alter the physics, re-pin: print ``digest`` of each scene and say why in
the commit."""
import hashlib
import warnings

import numpy as np
import pytest

from signorini import fuzz, scenes

# re-pinned once more when Contacts.impulse became the step's whole impulse (summed over the
# substeps, issue 25): with the last substep's h alpha in its place the digests are the earlier
# pins, bit for bit, so nothing else moved.
# Re-pinned when a contact's three rows became one record (ContactRows, issue 21): the sweeps read
# the relative velocity at the point once and move the bodies by one impulse, the same sums in
# another rounding; the oracle still matches every step (test_oracle_solver, test_oracle_soft).
# The fuzzer scene re-pinned once more when sleeping became the default: two of its bodies sleep
# by its end (the pile and the pyramid keep theirs: nothing in them sleeps within their steps)
# The pile and the pyramid re-pinned when contacts against a static body moved to the solve
# order's colours from 32 up (solved after the contacts between moving bodies, issue 21): the
# same rows in another order; the fuzzer scene, whose bodies meet the floor more than each other,
# kept its bits. The oracle repeats the order and still matches every step.
# The pile and the fuzzer scene re-pinned when the PGS's substeps came to carry a round side's core
# with its whole turn, not its witness point to first order (issue 21, docs/conventions.md "One
# step"): both have capsules and balls; the pyramid, boxes only, kept its bits. The oracle does the
# same and matches every step.
# All three re-pinned when a body with the same inertia about every axis (the pile's spheres and
# cubes, the pyramid's cubes, the fuzzer scene's balls) came to keep omega exactly in the
# unconstrained velocity, omega + dt tau / I_0, instead of through the body frame and back and the
# midpoint rule's Newton iterations (issue 21: 1e-16 of rounding per substep, and a sixth of the
# pyramid's solve stage); with the commit before it the pyramid's pin came back, bit for bit. The
# oracle, which computes the rule as written, still matches every step.
# The pile and the fuzzer scene re-pinned when the PGS step came to find a fast-turning pair's
# contacts again in its substeps, in more substeps for the turning bodies in contact (issue 21,
# docs/conventions.md "Deep overlaps"), and a turn's speculative reach came to stop at 2 rho: with
# the pairs' turn rule switched off (and the reach as before) both pins came back, bit for bit;
# the pyramid, where nothing turns fast, kept its bits. The oracle does the same and matches.
# The pile re-pinned again when the turning rule's closing speed became that of the bodies' centres
# (a point carried through the substeps lags a fast body; docs/conventions.md "One step"): with the
# closing speed at the contact's point, as before, the pin came back, bit for bit.
PINNED = {
    # built-in mixed pile (spheres, boxes, capsules, cylinders, hulls, meshes, compounds, decomposed
    # tori in a walled pit), 400 steps of 1/240 s: bodies landing on each other (re-pinned once, when
    # the shipped pile.toml was written again with the last bits of 9 orientations changed; the
    # restructuring had kept the earlier pin)
    # (re-pinned at stop 50: pairs falling as one keep the contacts a landing closes, and a
    # cylinder's side lying along a side gets both ends; each alone moved it)
    # (re-pinned at stop 51: a round side's carried anchor follows the closing gap, so that the
    # core taken from it stays its centre; the commit before it kept the stop 50 pin)
    "pile": "2c4dfac2f78c3b339589ddd0564a276bde2b3f4fea32d02351688f6b76d8f318",
    # the 210-box pyramid, 150 steps of 1/240 s
    "pyramid": "543c7e75d1659e5490a4f81d11806f27bd3f6f69d5a94815fa3f767e2d21e9d6",
    # fuzzer scene 1:103: 14 bodies of all 7 kinds on a triangle-mesh height field, its full 1.5 s
    # (re-pinned when a capsule got both segment ends and a cylinder its rim points in the floor
    # against mesh triangles, issue 21: its capsule and cylinders land differently)
    # (re-pinned when continuous collision came, issue 24: at step 149 a cylinder falling at 3.4 m/s
    # would have ended with its centre 9 mm under the height field's surface; it is put back before
    # it, once in the run; with set_solver(continuous=False) the old digest came back, bit for bit)
    # (re-pinned when continuous collision swept turns too, issue 21: 7 more put-backs of a capsule,
    # a cylinder and a mesh spun to 100 to 740 rad/s, each 0.4 to 1.6 mm deeper in the field without)
    # (re-pinned at stop 50 when a cylinder's side lying along a side got both ends of the overlap;
    # the rule for pairs falling as one left it as it was; and again when a step came to take at most
    # half of its turning budget before its first substep, which the pile's 400 steps never reach)
    # (re-pinned at stop 51 with the pile: a round side's carried anchor follows the closing gap)
    "fuzz 1:103": "cc73948a56e6315b41661526d9f24bba0fa5004dd5a475abfa1d38e41476780f",
}


def digest(world) -> str:
    h = hashlib.sha256()
    for a in (world.positions, world.orientations, world.velocities, world.angular_velocities):
        h.update(np.ascontiguousarray(a).tobytes())
    c = world.contacts
    for a in (c.body_a, c.body_b, c.point, c.normal, c.gap, c.alpha, c.impulse, c.feature_a, c.feature_b):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def run(name: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the pile's solver warning is not what is pinned here
        if name.startswith("fuzz"):
            scene = fuzz.generate(1, 103, joints=False)  # as pinned: without structures or projectiles
            world, _ = fuzz.build(scene)
            world.step(scene["dt"], int(round(scene["duration"] / scene["dt"])))
        else:
            scene = scenes.build(name)
            scene.world.step(scene.dt, {"pile": 400, "pyramid": 150}[name])
            world = scene.world
    return world


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(PINNED))
def test_busy_scene_ends_in_its_pinned_state(name):
    world = run(name)
    assert len(world.contacts.gap) > 0  # the scene is busy: something is touching at the end
    assert digest(world) == PINNED[name]
