"""Convex decomposition of closed non-convex meshes with CoACD, cached on disk.

A dynamic non-convex ``Mesh`` collides with other bodies through convex pieces (the narrow phase
is exact only for convex shapes). ``World.add_body`` calls :func:`decompose` for such a mesh, so a
scene with a torus needs nothing more than ``w.add_body(sg.Mesh(v, f), density=...)``. CoACD
(Wei et al., SIGGRAPH 2022) is a well-kept decomposition library; the first call on a mesh takes
about a second, later ones read the cache (``$SIGNORINI_CACHE`` or ``~/.cache/signorini``).
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np

from ._core import Mesh

#: CoACD's concavity threshold: smaller gives more, tighter pieces.
DEFAULT_THRESHOLD = 0.05


def cache_dir() -> Path:
    """Where decompositions are kept: ``$SIGNORINI_CACHE/coacd`` or ``~/.cache/signorini/coacd``."""
    root = os.environ.get("SIGNORINI_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "signorini")
    return Path(root) / "coacd"


def _key(vertices: np.ndarray, faces: np.ndarray, threshold: float, seed: int, version: str) -> str:
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(vertices, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(faces, dtype=np.int64).tobytes())
    h.update(f"{threshold!r}/{seed}/{version}".encode())
    return h.hexdigest()[:32]


def convex_pieces(mesh: Mesh, threshold: float = DEFAULT_THRESHOLD, seed: int = 0) -> list[np.ndarray]:
    """The vertex arrays (n_i, 3) of the convex pieces of a closed mesh (its own frame, m).

    Read from the cache when this mesh was decomposed before with the same settings; otherwise
    computed by CoACD (deterministic for a given seed) and stored. Raises ValueError for an open
    or inconsistently oriented mesh, or a threshold outside (0, 1].
    """
    if not isinstance(mesh, Mesh):
        raise TypeError(f"decompose: mesh must be a signorini Mesh, got {type(mesh).__name__}")
    if not (isinstance(threshold, (int, float)) and 0.0 < threshold <= 1.0):
        raise ValueError(f"decompose: threshold must be in (0, 1], got {threshold!r}")
    problem = mesh.closedness_problem()
    if problem:
        raise ValueError(f"decompose: the mesh must be closed to be decomposed: {problem}")
    import coacd

    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    path = cache_dir() / f"{_key(vertices, faces, threshold, seed, coacd.__version__ if hasattr(coacd, '__version__') else '')}.npz"
    if path.exists():
        with np.load(path) as data:
            return [data[f"piece_{k}"] for k in range(int(data["count"]))]
    coacd.set_log_level("error")
    parts = coacd.run_coacd(coacd.Mesh(vertices, faces), threshold=threshold, seed=seed)
    pieces = [np.asarray(v, dtype=np.float64) for v, _ in parts]
    path.parent.mkdir(parents=True, exist_ok=True)
    # written to a temporary file and renamed, so a reader never sees half a file
    with tempfile.NamedTemporaryFile(dir=path.parent, suffix=".npz", delete=False) as tmp:
        np.savez(tmp, count=len(pieces), **{f"piece_{k}": p for k, p in enumerate(pieces)})
    os.replace(tmp.name, path)
    return pieces


def decompose(mesh: Mesh, threshold: float = DEFAULT_THRESHOLD, seed: int = 0) -> Mesh:
    """A copy of ``mesh`` that collides through convex pieces (its convex hull for a convex mesh,
    CoACD's decomposition otherwise); its mass properties stay those of the mesh itself."""
    if mesh.is_convex():
        return mesh
    return mesh.with_pieces(convex_pieces(mesh, threshold, seed))
