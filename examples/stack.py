"""Stack: five boxes stacked on the ground stand still. The solver holds each box on the one
below; after 3 s no box has moved more than a millimetre.

Run: python examples/stack.py
"""
import numpy as np

import signorini as sg

w = sg.World(gravity=(0.0, 0.0, -9.81))
w.add_static(sg.Plane(normal=(0.0, 0.0, 1.0), offset=0.0))
half = 0.1
boxes = [w.add_body(sg.Box((half, half, half)), mass=1.0, position=(0.0, 0.0, half + 2 * half * k))
         for k in range(5)]
start = w.positions[boxes].copy()

w.step(dt=1.0 / 240.0, steps=720)
drift = np.linalg.norm(w.positions[boxes] - start, axis=1)
print("drift of each box after 3 s (mm):", np.round(drift * 1000.0, 4))
assert drift.max() < 1e-3, "the stack did not stand"
assert np.abs(w.velocities[boxes]).max() < 1e-3, "the stack is still moving"
