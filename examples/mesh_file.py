"""Mesh from a file: a cube written as an STL in millimetres, read with sg.load_mesh(scale=0.001),
has the mass density x (0.2 m)^3 and comes to rest on the ground with its centre 0.1 m up.

Run: python examples/mesh_file.py [FILE]   (any OBJ, STL, PLY, OFF or GLB in millimetres)
"""
import sys
import tempfile
from pathlib import Path

import numpy as np
import trimesh

import signorini as sg
from signorini import meshes

if len(sys.argv) > 1:
    path = Path(sys.argv[1])
else:
    # a 200 mm cube, as a CAD program would export it
    v, f = meshes.box_mesh((100.0, 100.0, 100.0))
    path = Path(tempfile.mkdtemp()) / "cube_mm.stl"
    trimesh.Trimesh(v, f).export(str(path))

mesh = sg.load_mesh(path, scale=0.001)             # millimetres to metres
print(f"{path.name}: {len(mesh.vertices)} vertices, {len(mesh.faces)} triangles")
w = sg.World(gravity=(0.0, 0.0, -9.81))
w.add_static(sg.Plane(normal=(0.0, 0.0, 1.0), offset=0.0))
cube = w.add_body(mesh, density=800.0, position=(0.0, 0.0, 0.5),
                  orientation=(0.96, 0.2, 0.1, 0.0), angular_velocity=(1.0, 0.0, 0.0))
w.step(dt=1.0 / 240.0, steps=720)
print(f"mass {w.masses[cube]:.4f} kg, resting with its centre at z = {w.positions[cube, 2]:.4f} m")
if len(sys.argv) == 1:
    assert abs(w.masses[cube] - 800.0 * 0.2**3) < 1e-9
    assert abs(w.positions[cube, 2] - 0.1) < 1e-3 and np.abs(w.velocities[cube]).max() < 1e-2
