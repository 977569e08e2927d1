"""signorini: rigid-body contact simulation with a C++ core (Eigen, FCL) and the lecture's PGS.

    import signorini as sg
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane(normal=(0, 0, 1), offset=0.0))
    w.add_body(sg.Box(half_extents=(0.5, 0.5, 0.5)), density=1000.0, position=(0, 0, 1))
    w.step(dt=1/240, steps=240)

``signorini.oracle`` re-derives each step in plain NumPy; ``python -m signorini.compare`` checks
the core against it; ``python -m signorini run`` runs a built-in scene. ``sg.Recorder(world)``
records a run with its scene into one file (``sg.load_trajectory``), which the HTML player,
the viewer (``python -m signorini view``) and the video, glTF and USD exports read.
"""
from typing import TYPE_CHECKING

from ._core import Box, Capsule, Compound, ConvexHull, Cylinder, Mesh, Plane, Sphere, TriangleMesh
from .joints import Distance, Fixed, Motor, Prismatic, Revolute, Spherical
from .world import (BodyIndexError, ContactEventList, ContactEvents, ContactPairs, Contacts, SavedState, SolverStats,
                    SolverWarning, World, mass_properties)
from .codec import shape_to_dict as shape_dict
from .collision import Feature, collide, feature
from .queries import BodyDistance, Hit, RayHits
from .trajectory import Record, Recorder, load_trajectory, save_trajectory
from . import meshes, meshfile
from .meshfile import MeshRepairWarning, load_mesh, save_mesh
from .decomposition import decompose
from .batch import Batch

if TYPE_CHECKING:
    from .mjcf import MJCFError, import_mjcf, load_mjcf, read_mjcf
    from .urdf import URDFError, add_urdf, load_urdf
    from .scenefile import SceneFileError, load_scene, read_scene, save_scene
    from .sweeps import SweepError, state_hash, sweep

# imported when first used: pydantic takes a tenth of a second to import
_LAZY = {"load_scene": "scenefile", "read_scene": "scenefile", "save_scene": "scenefile",
         "SceneFileError": "scenefile", "load_mjcf": "mjcf", "read_mjcf": "mjcf", "MJCFError": "mjcf",
         "import_mjcf": "mjcf",
         "load_urdf": "urdf", "add_urdf": "urdf", "URDFError": "urdf",
         "sweep": "sweeps", "SweepError": "sweeps", "state_hash": "sweeps"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'signorini' has no attribute {name!r}")


def __dir__() -> list[str]:
    """The module's names, the lazily imported ones included (so ``dir(sg)`` lists ``load_mjcf``)."""
    return sorted(set(globals()) | set(_LAZY))


# the public API: every name the README and docs use as ``sg.<name>`` (tests/python/test_api.py
# checks it), the submodules meshes and meshfile included
__all__ = ["World", "Hit", "RayHits", "BodyDistance", "Sphere", "Box", "Plane", "Mesh", "Capsule", "Cylinder",
           "ConvexHull", "TriangleMesh", "Compound", "mass_properties", "Revolute", "Prismatic", "Spherical", "Fixed",
           "Distance", "Motor", "Batch", "Contacts", "ContactEvents", "ContactEventList", "ContactPairs", "SolverStats", "SavedState",
           "BodyIndexError", "SolverWarning", "shape_dict", "collide", "feature", "Feature",
           "Record", "Recorder", "load_trajectory", "save_trajectory", "load_mesh", "save_mesh", "decompose",
           "MeshRepairWarning", "load_scene", "read_scene",
           "save_scene", "SceneFileError", "load_mjcf", "read_mjcf", "import_mjcf", "MJCFError", "load_urdf", "add_urdf",
           "URDFError", "sweep", "SweepError", "state_hash", "meshes", "meshfile"]
__version__ = "0.1.0"
