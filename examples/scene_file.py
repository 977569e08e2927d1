"""Scene file: a world written by hand in TOML, run, saved and loaded again. The saved file
steps bit for bit like the original, and the ball dropped onto the box comes to rest on top of it
(its centre at 2 half heights plus its radius).

Run: python examples/scene_file.py [FILE.toml]
"""
import sys
import tempfile
from pathlib import Path

import numpy as np

import signorini as sg

SCENE = """
[scene]
description = "a ball dropped on a box"
dt = 0.004166666666666667
steps = 720

[world]
gravity = [0.0, 0.0, -9.81]

[materials.wood]
friction = 0.6

[[bodies]]
name = "ground"
static = true
shape = { type = "plane", normal = [0.0, 0.0, 1.0] }

[[bodies]]
name = "box"
shape = { type = "box", half_extents = [0.3, 0.3, 0.2] }
density = 600.0
material = "wood"
position = [0.0, 0.0, 0.2]

[[bodies]]
name = "ball"
shape = { type = "sphere", radius = 0.1 }
mass = 0.5
material = "wood"
position = [0.05, 0.0, 1.0]
"""

folder = Path(tempfile.mkdtemp())
path = Path(sys.argv[1]) if len(sys.argv) > 1 else folder / "ball_on_box.toml"
if len(sys.argv) == 1:
    path.write_text(SCENE)

scene = sg.read_scene(path)                  # the World, with the file's dt, steps and names
copy = sg.read_scene(sg.save_scene(scene, folder / "saved.toml"))   # with its dt, steps and names
for s in (scene, copy):
    s.world.step(s.dt, s.steps)
same = np.array_equal(scene.world.positions, copy.world.positions)
print(f"{path.name}: {scene.world.num_bodies} bodies ({', '.join(scene.names or ())}), {scene.steps} steps; "
      f"saved copy bit-identical: {same}")
assert same
if len(sys.argv) == 1:
    ball = scene.names.index("ball")
    print(f"the ball rests at z = {scene.world.positions[ball, 2]:.4f} m (box top 0.4 m + radius 0.1 m)")
    assert abs(scene.world.positions[ball, 2] - 0.5) < 1e-3
