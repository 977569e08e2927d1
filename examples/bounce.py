"""Bounce: a ball dropped on the ground with restitution e rises to e^2 of its drop height.

Newton's law of restitution reverses the approach speed v scaled by e, and a ball thrown up at
e v rises (e v)^2 / 2g, so the apex ratio is e^2 (no air drag). Run: python examples/bounce.py
"""
import numpy as np

import signorini as sg

e, radius, drop = 0.8, 0.1, 1.0                  # restitution, m, m (gap below the ball)
dt = 1.0 / 1000.0

w = sg.World(gravity=(0.0, 0.0, -9.81))
w.add_static(sg.Plane(normal=(0.0, 0.0, 1.0), offset=0.0))
ball = w.add_body(sg.Sphere(radius), mass=1.0, position=(0.0, 0.0, radius + drop), restitution=e)

# fall, bounce, rise: record the height of the ball's lowest point every step for 1.5 s
gaps = []
for _ in range(1500):
    w.step(dt)
    gaps.append(w.positions[ball, 2] - radius)
gaps = np.array(gaps)
bounce = int(np.argmin(gaps[:700]))               # the first touch is at t = sqrt(2 drop / g) = 0.45 s
apex = gaps[bounce:].max()

ratio = apex / drop
print(f"e = {e}: dropped from {drop:.3f} m, rose to {apex:.4f} m; ratio {ratio:.4f}, e^2 = {e * e:.4f}")
assert abs(ratio - e * e) < 0.01 * e * e, "the apex ratio is not e^2 within 1%"
