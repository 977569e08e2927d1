"""Mesh files: OBJ, STL, PLY, OFF and GLB read through trimesh, and the exact ``.npz`` mesh file of
scene files.

``load_mesh(path)`` gives a ``Mesh`` (a dynamic body's shape; closed, outward triangles) or, with
``static=True``, a ``TriangleMesh`` (terrain, bowls; need not be closed). trimesh merges the
duplicated corners of formats that store each triangle on its own (STL), so a cube read from STL
has 8 vertices, not 36. A GLB holding several meshes gives their union, each placed by its node.

The ``.npz`` mesh file holds the arrays exactly (float64 vertices, int64 faces, and the convex
pieces of a decomposed mesh: ``piece_count`` and ``piece_<k>``), so a scene saved with its meshes
loads bit for bit, without decomposing again. It is what ``save_scene`` writes.

Limits: a mesh file is at most ``MAX_MESH_BYTES`` (64 MiB; for ``.npz`` files, also once its arrays
are decompressed, checked from their headers before they are read); vertices are finite and faces
index existing vertices. Running out of memory or stack reading a file is reported as the
ValueError below.

Every error names the file and the problem.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Union

import numpy as np

from . import filecheck
from ._core import Mesh, TriangleMesh

__all__ = ["load_mesh", "read_mesh_arrays", "write_npz_mesh", "MESH_SUFFIXES"]

#: suffixes load_mesh reads (trimesh's readers, and signorini's exact .npz)
MESH_SUFFIXES = (".obj", ".stl", ".ply", ".off", ".glb", ".npz")

PathLike = Union[str, "os.PathLike[str]"]

#: the largest mesh file read (and the most its .npz arrays may hold decompressed): a binary STL of
#: 64 MiB holds 1.3 million triangles, far more than a contact mesh needs, and bounds what trimesh
#: builds from it (a few times the file)
MAX_MESH_BYTES = 64 * 2**20


def _mesh_error(path: Path, problem: str) -> ValueError:
    return ValueError(f"mesh file {str(path)!r}: {problem}")


def read_mesh_arrays(path: PathLike, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """(vertices (n, 3) float64 m, faces (k, 3) int64, convex pieces [(n_i, 3) float64]) of a mesh file.

    Inputs: path of an .obj, .stl, .ply, .off, .glb (through trimesh) or .npz (``write_npz_mesh``)
    file; scale (> 0) multiplies every coordinate (and the pieces' vertices). Pieces come only from
    .npz files. Raises FileNotFoundError for a missing file and ValueError naming the file for an
    unknown suffix, an unreadable or empty file, or a bad scale.
    """
    path = Path(path)
    if isinstance(scale, bool) or not isinstance(scale, (int, float, np.integer, np.floating)) \
            or not (np.isfinite(scale) and scale > 0):
        raise _mesh_error(path, f"scale must be a finite number > 0, got {scale!r}")
    if not path.is_file():
        raise FileNotFoundError(f"mesh file {str(path)!r} does not exist" if not path.exists()
                                else f"mesh file {str(path)!r} is not a file")
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise _mesh_error(path, f"unknown mesh format {suffix or '(no suffix)'!r}; "
                                f"known: {', '.join(MESH_SUFFIXES)}")
    try:
        vertices, faces, pieces = _read(path, suffix)
    except (MemoryError, RecursionError) as e:
        raise _mesh_error(path, f"out of memory or stack reading it ({type(e).__name__})") from None
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise _mesh_error(path, f"vertices must be (n, 3) and faces (k, 3), got {vertices.shape} and {faces.shape}")
    if len(vertices) == 0 or len(faces) == 0:
        raise _mesh_error(path, f"holds no triangles ({len(vertices)} vertices, {len(faces)} faces)")
    if not np.all(np.isfinite(vertices)) or not all(np.all(np.isfinite(p)) for p in pieces):
        raise _mesh_error(path, "a vertex coordinate is not finite (NaN or infinity)")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise _mesh_error(path, f"faces index vertices outside 0..{len(vertices) - 1}")
    if scale != 1.0:
        vertices = vertices * float(scale)
        pieces = [p * float(scale) for p in pieces]
    return vertices, faces, pieces


def _read(path: Path, suffix: str) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """The arrays of a mesh file as it holds them (checked by the caller)."""
    pieces: list[np.ndarray] = []
    try:
        filecheck.check_size(path, MAX_MESH_BYTES)
    except filecheck.FileLimitError as e:
        raise _mesh_error(path, str(e)) from None
    if suffix == ".npz":
        try:
            data = filecheck.read_npz(path, MAX_MESH_BYTES)
            count = data["piece_count"] if "piece_count" in data else np.int64(0)
            if count.shape != () or count.dtype.kind not in "iu" or not 0 <= int(count) <= len(data):
                raise _mesh_error(path, f"piece_count must be one integer in 0..{len(data)}, got {count}")
            vertices = np.asarray(data["vertices"], dtype=np.float64)
            faces = np.asarray(data["faces"], dtype=np.int64)
            pieces = [np.asarray(data[f"piece_{k}"], dtype=np.float64).reshape(-1, 3) for k in range(int(count))]
        except KeyError as e:
            raise _mesh_error(path, f"not a signorini mesh file: no array {e.args[0]!r}") from None
        except filecheck.FileLimitError as e:
            raise _mesh_error(path, f"unreadable as .npz: {e}") from None
        except (OSError, TypeError, ValueError) as e:
            if str(e).startswith("mesh file"):
                raise
            raise _mesh_error(path, f"unreadable as .npz: {e}") from None
    else:
        import trimesh

        if path.stat().st_size == 0:
            raise _mesh_error(path, "the file is empty")
        try:
            # force="mesh": a GLB scene becomes one mesh, each geometry placed by its node
            loaded = trimesh.load(str(path), force="mesh", process=True)
        except Exception as e:  # trimesh raises many types for broken files
            raise _mesh_error(path, f"unreadable as {suffix[1:].upper()}: {type(e).__name__}: {e}") from None
        if not isinstance(loaded, trimesh.Trimesh):
            raise _mesh_error(path, f"holds no triangle mesh (read as {type(loaded).__name__})")
        vertices = np.array(loaded.vertices, dtype=np.float64)
        faces = np.array(loaded.faces, dtype=np.int64)
    return vertices, faces, pieces


def load_mesh(path: PathLike, scale: float = 1.0, static: bool = False) -> Mesh | TriangleMesh:
    """The mesh in a file, as a ``Mesh`` (``static=False``) or a ``TriangleMesh`` (``static=True``).

    Inputs: path of an OBJ, STL, PLY, OFF or GLB file (read by trimesh; corners shared by several
    triangles are merged) or a signorini .npz mesh file (exact arrays, with convex pieces when it
    has them); scale (> 0) multiplies every coordinate (e.g. 0.001 for a file in millimetres).
    Coordinates are metres after scaling, in the file's own frame. Limits (file size, finite
    vertices, faces in range) in the module doc. Raises FileNotFoundError for a missing file and
    ValueError naming the file for an unreadable, empty, invalid or over-limit one.
    """
    path = Path(path)
    vertices, faces, pieces = read_mesh_arrays(path, scale)
    try:
        if static:
            return TriangleMesh(vertices, faces)
        mesh = Mesh(vertices, faces)
        return mesh.with_pieces(pieces) if pieces else mesh
    except ValueError as e:
        raise _mesh_error(path, str(e)) from None


def write_npz_mesh(path: PathLike, vertices, faces, pieces=()) -> Path:
    """Writes vertices (n, 3) float64, faces (k, 3) int64 and convex pieces [(n_i, 3)] to an .npz
    mesh file that ``load_mesh`` reads back exactly; returns the path."""
    path = Path(path)
    arrays: dict[str, Any] = {"vertices": np.asarray(vertices, dtype=np.float64), "faces": np.asarray(faces, dtype=np.int64),
              "piece_count": np.int64(len(pieces))}
    arrays.update({f"piece_{k}": np.asarray(p, dtype=np.float64) for k, p in enumerate(pieces)})
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    return path
