"""Mesh files: OBJ, STL, PLY, OFF and GLB read through trimesh, and the exact ``.npz`` mesh file of
scene files.

``load_mesh(path)`` gives a ``Mesh`` (a dynamic body's shape; closed, outward triangles) or, with
``static=True``, a ``TriangleMesh`` (terrain, bowls; need not be closed). Corners that a file
stores more than once are merged: the corners of formats that store each triangle on its own (STL),
and the corners split at texture or normal seams (an OBJ's ``f 1/1/1 2/5/2 ...`` gives one vertex
per position, texture and normal triple), so a textured cube has 8 vertices, not 24 or 36.
Materials, textures and other files an OBJ or GLB names are never read.

Files of several objects (OBJ ``o`` objects or ``g`` groups, GLB nodes, each placed by its node):
when every object is closed and convex within ``CONVEX_TOLERANCE`` (V-HACD's ``*_vhacd.obj``, one
object per convex piece), a dynamic ``Mesh`` collides through those objects as its convex pieces and
is not decomposed again; with ``compound=True`` the objects become the parts of a ``Compound`` of
convex hulls. Otherwise the objects are one mesh (their union, corners merged across objects),
which a dynamic body decomposes (``sg.decompose``, ``signorini.decomposition``). With
``repair=True`` each object is judged as repair leaves it (CAD solids wound inconsistently are
convex pieces once wound outwards).

Problems and repair: a dynamic mesh must be closed, consistently and outward wound and free of
degenerate faces, and enclose a volume (more than 1e-12 of the cubed mesh size, the core's rule);
a static one free of degenerate and duplicate faces. ``load_mesh`` checks this when it reads the
file and its error says what is wrong (an edge of more than two faces is named non-manifold:
solids touching along an edge, which repair does not separate) and that ``repair=True`` exists.
With ``repair=True`` it drops degenerate faces (area below 1e-12 of the squared mesh size, the
core's rule, or a repeated corner) and duplicate faces (the same three corners), makes the
winding consistent (and outward, for a closed part), fills holes of 3 or 4 edges (dynamic meshes
only: a static mesh may be open on purpose; a hole whose filling would enclose nothing, such as a
loose triangle's own three edges, stays open), drops the vertices no face uses, and reports what
it changed in a ``MeshRepairWarning`` (its ``report`` is a ``RepairReport`` of counts).
``repair_arrays`` does the same on arrays and returns the report.

The ``.npz`` mesh file holds the arrays exactly (float64 vertices, int64 faces, and the convex
pieces of a decomposed mesh: ``piece_count`` and ``piece_<k>``), so a scene saved with its meshes
loads bit for bit, without decomposing again. It is what ``save_scene`` writes, and what
``save_mesh`` writes for one mesh (``sg.decompose`` once, save, and load it from then on).

Limits: a mesh file is at most ``MAX_MESH_BYTES`` (64 MiB; for ``.npz`` files, also once its arrays
are decompressed, checked from their headers before they are read); vertices are finite and faces
index existing vertices. Running out of memory or stack reading a file is reported as the
ValueError below.

Every error names the file and the problem.
"""
from __future__ import annotations

import io
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Union

import numpy as np

from . import filecheck
from ._core import Compound, ConvexHull, Mesh, TriangleMesh

__all__ = ["load_mesh", "save_mesh", "read_mesh_arrays", "write_npz_mesh", "repair_arrays", "RepairReport",
           "MeshRepairWarning", "convex_problem", "MESH_SUFFIXES", "CONVEX_TOLERANCE"]

#: suffixes load_mesh reads (trimesh's readers, and signorini's exact .npz)
MESH_SUFFIXES = (".obj", ".stl", ".ply", ".off", ".glb", ".npz")

PathLike = Union[str, "os.PathLike[str]"]

#: the largest mesh file read (and the most its .npz arrays may hold decompressed): a binary STL of
#: 64 MiB holds 1.3 million triangles, far more than a contact mesh needs, and bounds what trimesh
#: builds from it (a few times the file)
MAX_MESH_BYTES = 64 * 2**20

#: an object of a multi-object file is a convex piece when it is closed, outward wound, and its
#: convex hull's volume exceeds its own by at most this fraction of the hull's (V-HACD's pieces,
#: hulls written with 6 decimals, are within 1e-5)
CONVEX_TOLERANCE = 1e-3

# the core's rule for a degenerate triangle: doubled area below this times the squared mesh size
_DEGENERATE_AREA = 1e-12
# the core's rule for a solid that encloses nothing: volume below this times the cubed mesh size
_FLAT_VOLUME = 1e-12

_REPAIR_HINT = ("load_mesh(..., repair=True) drops degenerate and duplicate faces, makes the winding consistent, "
                "fills holes of 3 or 4 edges and reports what it changed")


class MeshRepairWarning(UserWarning):
    """``load_mesh(..., repair=True)`` changed the mesh; ``report`` (a ``RepairReport``) says how."""

    def __init__(self, message: str, report: "RepairReport"):
        super().__init__(message)
        self.report = report


@dataclass(frozen=True)
class RepairReport:
    """What ``repair_arrays`` changed, as counts (all 0: nothing); ``str()`` lists the changes.

    degenerate_faces, duplicate_faces: faces dropped; flipped_faces: faces whose winding was
    reversed (to agree with their neighbours, outward for a closed part); filled_holes and
    added_faces: holes of 3 or 4 edges closed and the faces that closed them; unused_vertices:
    vertices no face used any more, dropped. ``first_degenerate`` and ``first_duplicate`` give
    the indices (in the faces as read) of the first few dropped faces."""

    degenerate_faces: int = 0
    duplicate_faces: int = 0
    flipped_faces: int = 0
    filled_holes: int = 0
    added_faces: int = 0
    unused_vertices: int = 0
    first_degenerate: tuple = field(default=(), compare=False)
    first_duplicate: tuple = field(default=(), compare=False)

    def __bool__(self) -> bool:
        return any((self.degenerate_faces, self.duplicate_faces, self.flipped_faces, self.added_faces,
                    self.unused_vertices))

    def __str__(self) -> str:
        def some(first: tuple, count: int) -> str:
            shown = ", ".join(str(i) for i in first) + (", ..." if count > len(first) else "")
            return f" ({'face' if count == 1 else 'faces'} {shown})" if first else ""
        parts = []
        if self.degenerate_faces:
            parts.append(f"dropped {_count(self.degenerate_faces, 'degenerate face')}"
                         f"{some(self.first_degenerate, self.degenerate_faces)}")
        if self.duplicate_faces:
            parts.append(f"dropped {_count(self.duplicate_faces, 'duplicate face')}"
                         f"{some(self.first_duplicate, self.duplicate_faces)}")
        if self.flipped_faces:
            parts.append(f"reversed the winding of {_count(self.flipped_faces, 'face')}")
        if self.filled_holes:
            parts.append(f"filled {_count(self.filled_holes, 'hole')} with {_count(self.added_faces, 'face')}")
        if self.unused_vertices:
            parts.append(f"dropped {_count(self.unused_vertices, 'unused vertex', 'unused vertices')}")
        return "; ".join(parts) if parts else "nothing to repair"


def _count(n: int, one: str, many: str | None = None) -> str:
    return f"{n:,} {one if n == 1 else (many or one + 's')}"


def _mesh_error(path: Path, problem: str) -> ValueError:
    return ValueError(f"mesh file {str(path)!r}: {problem}")


@dataclass
class _Read:
    """A mesh file's arrays: the mesh (vertices (n, 3) m, faces (k, 3)), its convex pieces
    [(n_i, 3) m], and for a file of several objects that are not all convex pieces, the first one
    that is not (name, why) (compound=True reports it)."""

    vertices: np.ndarray
    faces: np.ndarray
    pieces: list
    not_convex: tuple | None = None


def read_mesh_arrays(path: PathLike, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """(vertices (n, 3) float64 m, faces (k, 3) int64, convex pieces [(n_i, 3) float64]) of a mesh file.

    Inputs: path of an .obj, .stl, .ply, .off, .glb (through trimesh) or .npz (``write_npz_mesh``)
    file; scale (> 0) multiplies every coordinate (and the pieces' vertices). Pieces come from .npz
    files and from files whose objects are all convex pieces (module doc). Raises
    FileNotFoundError for a missing file and ValueError naming the file for an unknown suffix, an
    unreadable or empty file, or a bad scale.
    """
    read = _read_checked(Path(path), scale, static=False)
    return read.vertices, read.faces, read.pieces


def _read_checked(path: Path, scale: float, static: bool, repair: bool = False) -> _Read:
    """The arrays of a mesh file, checked (shapes, finite, indices in range) and scaled."""
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
        read = _read(path, suffix, static, repair)
    except (MemoryError, RecursionError) as e:
        raise _mesh_error(path, f"out of memory or stack reading it ({type(e).__name__})") from None
    vertices, faces, pieces = read.vertices, read.faces, read.pieces
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise _mesh_error(path, f"vertices must be (n, 3) and faces (k, 3), got {vertices.shape} and {faces.shape}")
    if len(vertices) == 0 or len(faces) == 0:
        raise _mesh_error(path, f"holds no triangles ({len(vertices)} vertices, {len(faces)} faces)")
    if not np.all(np.isfinite(vertices)) or not all(np.all(np.isfinite(p)) for p in pieces):
        raise _mesh_error(path, "a vertex coordinate is not finite (NaN or infinity)")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise _mesh_error(path, f"faces index vertices outside 0..{len(vertices) - 1}")
    if scale != 1.0:
        read.vertices = vertices * float(scale)
        read.pieces = [p * float(scale) for p in pieces]
    return read


def _read(path: Path, suffix: str, static: bool, repair: bool = False) -> _Read:
    """The arrays of a mesh file as it holds them (checked by the caller); repair: the objects of a
    multi-object file are judged convex pieces or not as repair_arrays leaves them."""
    try:
        filecheck.check_size(path, MAX_MESH_BYTES)
    except filecheck.FileLimitError as e:
        raise _mesh_error(path, str(e)) from None
    if suffix == ".npz":
        return _read_npz(path)
    import trimesh

    data = path.read_bytes()
    if not data:
        raise _mesh_error(path, "the file is empty")
    # from the bytes, with no resolver: materials, textures and buffers the file names are not read
    options = dict(split_objects=True, split_groups=True, group_material=False, skip_materials=True) \
        if suffix == ".obj" else {}
    try:
        scene = trimesh.load_scene(io.BytesIO(data), file_type=suffix[1:], process=True, **options)
        # each geometry placed by its node (GLB); points and lines are not triangles
        objects = [g for g in scene.dump() if isinstance(g, trimesh.Trimesh) and len(g.faces)]
        for g in objects:
            # one vertex per position: seams of textures and normals merged
            g.merge_vertices(merge_tex=True, merge_norm=True)
    except Exception as e:  # trimesh raises many types for broken files
        raise _mesh_error(path, f"unreadable as {suffix[1:].upper()}: {type(e).__name__}: {e}") from None
    if not objects:
        raise _mesh_error(path, "holds no triangle mesh")
    if len(objects) > 1 and not static:
        arrays = [(np.array(g.vertices, dtype=np.float64), np.array(g.faces, dtype=np.int64)) for g in objects]
        pieces = []
        for g, (v, f) in zip(objects, arrays):
            if repair:
                # judged as repair will leave it (load_mesh repairs, and reports, the union of the objects)
                v, f, _ = repair_arrays(v, f, closed=True)
            problem = convex_problem(v, f)
            if problem:
                break
            pieces.append(v)
        else:
            # every object a convex piece: the mesh is their union, each object closed on its own
            offsets = np.cumsum([0] + [len(v) for v, _ in arrays[:-1]])
            return _Read(np.concatenate([v for v, _ in arrays]),
                         np.concatenate([f + o for (_, f), o in zip(arrays, offsets)]), pieces)
        name = g.metadata.get("name") or f"object {objects.index(g)}"
        union = _union(trimesh, objects)
        return _Read(np.array(union.vertices, dtype=np.float64), np.array(union.faces, dtype=np.int64), [],
                     not_convex=(name, problem))
    union = objects[0] if len(objects) == 1 else _union(trimesh, objects)
    return _Read(np.array(union.vertices, dtype=np.float64), np.array(union.faces, dtype=np.int64), [])


def _union(trimesh, objects):
    """One trimesh of several, corners merged across them (a closed mesh split into groups)."""
    union = trimesh.util.concatenate(objects)
    union.merge_vertices(merge_tex=True, merge_norm=True)
    return union


def _read_npz(path: Path) -> _Read:
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
    return _Read(vertices, faces, pieces)


def _signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Enclosed volume (m^3) of a closed mesh, positive when its faces point outwards:
    sum over faces of det(v0, v1, v2) / 6 (divergence theorem)."""
    v0, v1, v2 = (vertices[faces[:, c]] for c in range(3))
    return float(np.einsum("ki,ki->k", v0, np.cross(v1, v2)).sum() / 6.0)


def _closedness_problem(faces: np.ndarray) -> str:
    """'' when every directed edge appears once and its reverse once (closed, consistently wound)."""
    start, end = faces.ravel(), faces[:, [1, 2, 0]].ravel()
    n = int(faces.max()) + 1 if len(faces) else 0
    edges, uses = np.unique(start * n + end, return_counts=True)
    if len(uses) and uses.max() > 1:
        return "an edge is used twice in the same direction"
    if not np.all(np.isin(end * n + start, edges)):
        return "it is open"
    return ""


def convex_problem(vertices: np.ndarray, faces: np.ndarray) -> str:
    """'' when a file's object is a convex piece (closed, outward, within CONVEX_TOLERANCE of its
    hull by volume); else why not."""
    if len(faces) < 4 or not np.all(np.isfinite(vertices)):
        return "it is not a closed solid"
    problem = _closedness_problem(faces)
    if problem:
        return problem
    volume = _signed_volume(vertices, faces)
    if volume <= 0.0:
        return "its faces point inwards" if volume < 0.0 else "it is flat"
    try:
        hull = ConvexHull(vertices)
    except ValueError:
        return "it is flat"
    hull_volume = _signed_volume(np.asarray(hull.vertices), np.asarray(hull.faces))
    excess = (hull_volume - volume) / hull_volume
    if excess > CONVEX_TOLERANCE:
        return f"it is not convex (its convex hull is {100 * excess:.2g} % larger)"
    return ""


def _degenerate(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(k,) bool: faces with a repeated corner or a doubled area below the core's bound."""
    size = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0))) if len(vertices) else 0.0
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 2] == faces[:, 0])
    return repeated | (area2 <= _DEGENERATE_AREA * size * size)


def _non_manifold_edge(faces: np.ndarray) -> tuple[tuple[int, int], int] | None:
    """((i, j), n) of the first edge (in vertex order) that more than two faces share, duplicate
    faces left out (repair drops those); None when every edge has at most two."""
    f = faces[~_duplicates(faces)]
    edges, uses = np.unique(np.sort(np.stack([f.ravel(), f[:, [1, 2, 0]].ravel()], axis=1), axis=1), axis=0,
                            return_counts=True)
    over = np.flatnonzero(uses > 2)
    return ((int(edges[over[0], 0]), int(edges[over[0], 1])), int(uses[over[0]])) if len(over) else None


def _duplicates(faces: np.ndarray) -> np.ndarray:
    """(k,) bool: faces with the same three corners as an earlier face (either winding)."""
    _, first = np.unique(np.sort(faces, axis=1), axis=0, return_index=True)
    keep = np.zeros(len(faces), dtype=bool)
    keep[first] = True
    return ~keep


def repair_arrays(vertices, faces, closed: bool = True) -> tuple[np.ndarray, np.ndarray, RepairReport]:
    """(vertices (n', 3) float64, faces (k', 3) int64, report) of a repaired mesh (module doc).

    Inputs: vertices (n, 3) m, faces (k, 3) indices in 0..n-1; closed: True for a dynamic body's
    mesh (holes of 3 or 4 edges are filled and each closed part is wound outwards), False for a
    static one (open on purpose: no holes filled, each connected part keeps the winding of most
    of its area). The faces kept stay in their input order, added faces last.
    """
    v = np.array(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.array(faces, dtype=np.int64).reshape(-1, 3)
    ids = np.arange(len(f))
    degenerate = _degenerate(v, f)
    f, ids = f[~degenerate], ids[~degenerate]
    duplicate = _duplicates(f)
    dropped_duplicates = ids[duplicate]
    f = f[~duplicate]

    g, _ = _wind(v, f, closed)
    holes = added = 0
    if closed and len(g) and _closedness_problem(g):
        # trimesh fills the holes of 3 or 4 edges, each face wound against its hole's edges
        import trimesh

        mesh = trimesh.Trimesh(v, g, process=False, validate=False)
        before, loops = len(g), _boundary_loops(mesh)
        trimesh.repair.fill_holes(mesh)
        if len(mesh.faces) > before:
            filled, part = _wind(v, np.array(mesh.faces, dtype=np.int64), closed)
            # a fill that closes a loose sheet (each triangle of trimesh's soup.stl, its hole its
            # own three edges) makes a part that encloses nothing: it is undone, the sheet stays open
            flat = _flat_parts(v, filled, part)
            undo = (np.arange(len(filled)) >= before) & flat[part]
            if undo.any():
                filled, _ = _wind(v, filled[~undo], closed)
            added = len(filled) - before
            if added:
                holes = loops - _boundary_loops(trimesh.Trimesh(v, filled, process=False, validate=False))
                g = filled
    flipped = int(np.count_nonzero(np.any(g[:len(f)] != f, axis=1)))

    # vertices no face uses any more, dropped (kept in order)
    used = np.zeros(len(v), dtype=bool)
    used[g.ravel()] = True
    remap = np.cumsum(used) - 1
    report = RepairReport(degenerate_faces=int(degenerate.sum()), duplicate_faces=int(duplicate.sum()),
                          flipped_faces=flipped, filled_holes=holes, added_faces=added,
                          unused_vertices=int(np.count_nonzero(~used)),
                          first_degenerate=tuple(int(i) for i in np.flatnonzero(degenerate)[:5]),
                          first_duplicate=tuple(int(i) for i in dropped_duplicates[:5]))
    return v[used], remap[g], report


def _flat_parts(vertices: np.ndarray, faces: np.ndarray, part: np.ndarray) -> np.ndarray:
    """(parts,) bool: connected parts (``part`` of ``_wind``) whose enclosed volume is within the
    core's bound of zero (|V| <= 1e-12 times the cube of the mesh size, as ``solid_properties``)."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    volume = np.bincount(part, weights=np.einsum("ki,ki->k", a, np.cross(b, c)), minlength=int(part.max()) + 1) / 6.0
    size = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
    return np.abs(volume) <= _FLAT_VOLUME * size ** 3


def _boundary_loops(mesh) -> int:
    """The number of boundary loops (holes) of a trimesh."""
    import networkx as nx
    from trimesh.grouping import group_rows

    boundary = mesh.edges_sorted[group_rows(mesh.edges_sorted, require_count=1)]
    return nx.number_connected_components(nx.from_edgelist(boundary)) if len(boundary) else 0


def _wind(vertices: np.ndarray, faces: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """(faces (k, 3), part (k,)): the faces with the winding made consistent across each connected
    part (faces joined by an edge two faces share), then each part turned as a whole: outwards
    when ``closed`` and the part is closed, else to the winding of most of its area as given;
    part numbers each face's connected part (0, 1, ... in the order of their first faces).

    A breadth-first walk over the faces (in Python, linear: trimesh's fix_winding takes minutes on
    the 125,000 faces of pybullet's samurai_monastry.obj) gives each face its flip relative to its
    part's first face: a face reached over an edge both faces run the same way is flipped
    relative to the face it was reached from. Edges of more than two faces do not join faces."""
    k = len(faces)
    if k == 0:
        return faces, np.zeros(0, dtype=np.int64)
    start, end = faces.ravel(), faces[:, [1, 2, 0]].ravel()   # half-edge 3 i + c of face i
    owner = np.repeat(np.arange(k), 3)
    _, edge, uses = np.unique(np.sort(np.stack([start, end], axis=1), axis=1), axis=0,
                              return_inverse=True, return_counts=True)
    edge = edge.reshape(-1)
    order = np.argsort(edge, kind="stable")
    first = (np.cumsum(uses) - uses)[uses == 2]
    h1, h2 = order[first], order[first + 1]
    f1, f2, same = owner[h1], owner[h2], start[h1] == start[h2]

    # neighbours of each face with the flip parity across the shared edge
    neighbours: list[list[tuple[int, bool]]] = [[] for _ in range(k)]
    for a, b, s in zip(f1.tolist(), f2.tolist(), same.tolist()):
        neighbours[a].append((b, s))
        neighbours[b].append((a, s))
    flip = np.zeros(k, dtype=bool)
    part = np.full(k, -1, dtype=np.int64)
    flips, parts = flip.tolist(), part.tolist()
    count = 0
    for root in range(k):
        if parts[root] >= 0:
            continue
        parts[root] = count
        queue = [root]
        for face in queue:
            for other, s in neighbours[face]:
                if parts[other] < 0:
                    parts[other] = count
                    flips[other] = flips[face] ^ s
                    queue.append(other)
        count += 1
    flip, part = np.array(flips, dtype=bool), np.array(parts, dtype=np.int64)

    # each part turned as a whole: by its volume when closed, else by the majority of its area
    wound = np.where(flip[:, None], faces[:, ::-1], faces)
    a, b, c = (vertices[wound[:, i]] for i in range(3))
    area = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    turn = np.bincount(part, weights=area * flip, minlength=count) > np.bincount(part, weights=area * ~flip,
                                                                                   minlength=count)
    if closed:
        # half-edge h of the faces as given runs end -> start once its face is flipped (a flipped
        # face's half-edges are not at the same places 3 i + c, so they are not read from `wound`)
        flipped = flip[owner]
        wstart, wend = np.where(flipped, end, start), np.where(flipped, start, end)
        paired = np.zeros(3 * k, dtype=bool)
        paired[h1] = paired[h2] = wstart[h1] == wend[h2]
        is_closed = np.bincount(part[owner], weights=~paired, minlength=count) == 0
        volume = np.bincount(part, weights=np.einsum("ki,ki->k", a, np.cross(b, c)), minlength=count)
        turn = np.where(is_closed, volume < 0.0, turn)
    return np.where(turn[part][:, None], wound[:, ::-1], wound), part


def load_mesh(path: PathLike, scale: float = 1.0, static: bool = False, *, repair: bool = False,
              compound: bool = False) -> Mesh | TriangleMesh | Compound:
    """The mesh in a file, as a ``Mesh`` (``static=False``), a ``TriangleMesh`` (``static=True``)
    or a ``Compound`` of convex hulls (``compound=True``).

    Inputs: path of an OBJ, STL, PLY, OFF or GLB file (read by trimesh; corners shared by several
    triangles are merged, seams of textures and normals included) or a signorini .npz mesh file
    (exact arrays, with convex pieces when it has them); scale (> 0) multiplies every coordinate
    (e.g. 0.001 for a file in millimetres). Coordinates are metres after scaling, in the file's own
    frame. A file of several objects that are all convex gives a Mesh with those objects as its
    convex pieces (no decomposition), or with ``compound=True`` a Compound of their hulls (module
    doc). repair: fix what can be fixed and report it in a ``MeshRepairWarning`` (module doc).
    Limits (file size, finite vertices, faces in range) in the module doc.

    Raises FileNotFoundError for a missing file and ValueError naming the file and the problem for
    an unreadable, empty, over-limit one, a dynamic mesh that is open, inconsistently wound,
    non-manifold, flat or inside out, degenerate or duplicate faces (the error says that
    ``repair=True`` exists where it helps), and
    ``compound=True`` on a file whose objects are not all convex.
    """
    path = Path(path)
    if compound and static:
        raise _mesh_error(path, "compound=True gives a dynamic body's shape; static=True a TriangleMesh: "
                                "choose one")
    read = _read_checked(path, scale, static, repair)
    vertices, faces, report = read.vertices, read.faces, None
    if repair:
        vertices, faces, report = repair_arrays(vertices, faces, closed=not static)
        if report:
            warnings.warn(MeshRepairWarning(f"mesh file {str(path)!r}: repaired: {report}", report), stacklevel=2)
    after = f" (after repair: {report})" if report else (" after repair" if repair else "")
    if static:
        try:
            return TriangleMesh(vertices, faces)
        except ValueError as e:
            raise _mesh_error(path, f"{e}{after}{_hint(repair, vertices, faces)}") from None
    try:
        mesh = Mesh(vertices, faces)
    except ValueError as e:
        raise _mesh_error(path, f"{e}{after}{_hint(repair, vertices, faces)}") from None
    problem = mesh.closedness_problem()
    shared = _non_manifold_edge(faces) if problem else None
    if shared is not None:
        # no winding can close an edge of more than two faces, and repair does not cut them apart
        (i, j), n = shared
        hint = _hint(repair, vertices, faces) if _degenerate(vertices, faces).any() or _duplicates(faces).any() else ""
        raise _mesh_error(path, f"edge ({i}, {j}) is shared by {n} faces: the mesh is non-manifold (solids that "
                                f"touch along an edge or share a face){after}; give each solid its own object "
                                "(OBJ o or g, ASCII STL solid) so that each is closed on its own, or load it with "
                                f"static=True as a TriangleMesh for a static body{hint}")
    if not problem:
        size = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
        volume = _signed_volume(vertices, faces)
        if abs(volume) <= _FLAT_VOLUME * size ** 3:
            problem = f"it encloses no volume ({volume:.3g} m^3 after scaling): it is flat, not a solid"
        elif volume < 0.0:
            problem = "its faces point inwards (negative volume): it is inside out"
    if problem:
        more = ("; holes of more than 4 edges, and holes whose filling would enclose nothing (a loose sheet), "
                "are not filled: close it in a mesh editor, or load it with static=True as a TriangleMesh for a "
                "static body") if repair and "open" in problem else ""
        raise _mesh_error(path, f"{problem}{after}{more}{_hint(repair, vertices, faces)}"
                                f"{'' if repair or 'open' not in problem else '; static=True accepts open meshes'}")
    if compound:
        return _compound(path, read, vertices)
    return mesh.with_pieces(read.pieces) if read.pieces else mesh


def _hint(repair: bool, vertices: np.ndarray, faces: np.ndarray) -> str:
    """What repair=True would drop, and that it exists (nothing once it was asked for)."""
    if repair:
        return ""
    counts = []
    degenerate, duplicate = int(_degenerate(vertices, faces).sum()), int(_duplicates(faces).sum())
    if degenerate:
        counts.append(_count(degenerate, "degenerate face"))
    if duplicate:
        counts.append(_count(duplicate, "duplicate face"))
    return f" ({' and '.join(counts)} in all); {_REPAIR_HINT}" if counts else f"; {_REPAIR_HINT}"


def _compound(path: Path, read: _Read, vertices: np.ndarray) -> Compound:
    """The Compound of a file's convex objects (one for a convex single-object file)."""
    if read.not_convex is not None:
        name, problem = read.not_convex
        raise _mesh_error(path, f"compound=True needs every object to be a convex piece; {name!r} is not: "
                                f"{problem} (sg.decompose splits a non-convex mesh into convex pieces)")
    pieces = read.pieces
    if not pieces:
        problem = convex_problem(vertices, read.faces)
        if problem:
            raise _mesh_error(path, f"compound=True needs convex objects; the mesh is one object and {problem} "
                                    "(sg.decompose splits a non-convex mesh into convex pieces)")
        pieces = [vertices]
    origin = ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))
    try:
        return Compound([(ConvexHull(p), origin) for p in pieces])
    except ValueError as e:
        raise _mesh_error(path, str(e)) from None


def save_mesh(mesh: Mesh, path: PathLike) -> Path:
    """Writes a ``Mesh`` (its vertices, faces and convex pieces, exactly) to an .npz mesh file that
    ``load_mesh`` reads back as the same Mesh, pieces included: decompose once
    (``sg.decompose``), save, and load the file from then on. Returns the path. Raises TypeError
    for anything but a Mesh and ValueError for a path not ending in .npz."""
    if not isinstance(mesh, Mesh):
        raise TypeError(f"save_mesh: mesh must be a signorini Mesh, got {type(mesh).__name__}")
    path = Path(path)
    if path.suffix.lower() != ".npz":
        raise ValueError(f"save_mesh: {str(path)!r}: the file name must end in .npz (signorini's exact mesh file)")
    return write_npz_mesh(path, mesh.vertices, mesh.faces, list(mesh.pieces))


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
