"""Slope: a box sliding down a plane tilted by theta with friction mu accelerates at
a = g (sin theta - mu cos theta) (Coulomb friction, mu < tan theta so it slides).

Run: python examples/slope.py
"""
import math

import numpy as np

import signorini as sg

theta, mu, g = math.radians(30.0), 0.3, 9.81
dt = 1.0 / 240.0

# the ground plane through the origin with its normal tilted by theta about y; downhill is +x'
n = np.array([-math.sin(theta), 0.0, math.cos(theta)])
downhill = np.array([math.cos(theta), 0.0, math.sin(theta)])
w = sg.World(gravity=(0.0, 0.0, -g), friction_cone="cone")   # the round cone: |f| <= mu alpha exactly
w.add_static(sg.Plane(normal=n, offset=0.0), friction=mu)
half = 0.1
tilt = (math.cos(-theta / 2), 0.0, math.sin(-theta / 2), 0.0)   # the box turned to lie flat on the slope
box = w.add_body(sg.Box((half, half, half)), density=500.0, friction=mu,
                 position=tuple(half * n), orientation=tilt)

# slide for 1 s and fit s(t) = s0 + v0 t + a t^2 / 2 along the slope (downhill is -x' here)
times, s = [], []
for k in range(240):
    w.step(dt)
    times.append(w.time)
    s.append(-(w.positions[box] @ downhill))
a = 2.0 * np.polyfit(times, s, 2)[0]
expected = g * (math.sin(theta) - mu * math.cos(theta))
print(f"theta = 30 deg, mu = {mu}: a = {a:.4f} m/s^2, g (sin theta - mu cos theta) = {expected:.4f} m/s^2")
assert abs(a - expected) < 0.01 * expected, "the sliding acceleration is off by more than 1%"
