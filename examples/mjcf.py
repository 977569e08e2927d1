"""MJCF: a MuJoCo model of three free bodies (a crate, a dumbbell of three geoms, a can lying on
its side) on a floor, imported with sg.load_mjcf. Each comes to rest on the floor: the crate's
centre 0.2 m up, the dumbbell on its balls (0.08 m), the can on its side (0.1 m).

Run: python examples/mjcf.py [FILE.xml]
"""
import sys
from pathlib import Path

import numpy as np

import signorini as sg

path = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent / "data" / "boxes.xml"
scene = sg.read_mjcf(path)                  # the World, dt from <option timestep>, body names
w = scene.world
w.step(scene.dt, int(3.0 / scene.dt))
for i, name in enumerate(scene.names):
    if not w.is_static[i]:
        print(f"{name:10s} mass {w.masses[i]:8.4f} kg, rests at z = {w.positions[i, 2]:.4f} m")
if len(sys.argv) == 1:
    rest = {"crate": 0.2, "dumbbell": 0.08, "can": 0.1}
    for name, z in rest.items():
        i = scene.names.index(name)
        assert abs(w.positions[i, 2] - z) < 2e-3, (name, w.positions[i, 2])
        assert np.abs(w.velocities[i]).max() < 2e-2, name
