"""Convex decomposition of closed non-convex meshes with CoACD, in a worker process, cached on disk.

A dynamic non-convex ``Mesh`` collides with other bodies through convex pieces (the narrow phase
is exact only for convex shapes). ``World.add_body`` calls :func:`decompose` with the default
settings for a mesh that has none, so a scene with a torus needs nothing more than
``w.add_body(sg.Mesh(v, f), density=...)``. CoACD (Wei et al., SIGGRAPH 2022) is a well-kept
decomposition library, and a slow one: with the defaults, CoACD 1.0.14 took 14 s on the tests'
576-triangle torus, 44 s on pybullet_data's bunny (902 triangles, 42 pieces), 2.7 min on its duck
(4,212 triangles, remeshed first) and 4.3 min on teddy's 15 hulls taken as one mesh, on a 2-core
machine shared with other jobs (``TIMINGS``; on a quieter one the bunny took 20 s and the duck
54 s). So:

- a mesh convex within ``meshfile.CONVEX_TOLERANCE`` (a UV sphere whose faces bend by rounding)
  is its own single piece, without CoACD; a file of convex objects (V-HACD's) is read as its
  pieces (``meshfile``);
- before CoACD starts, one line on stderr gives the settings, an estimate (``estimate``), that
  Ctrl-C stops it and where the result is cached; while it runs, a progress bar counts the pieces
  CoACD has finished and those it is still cutting (it cuts every piece whose concavity exceeds
  the threshold in two, round after round, then merges);
- CoACD runs in a worker process (``_coacd_worker.py``): Ctrl-C (KeyboardInterrupt) in the caller
  terminates it, and nothing is cached or changed (``add_body`` adds nothing);
- the pieces are cached under ``$SIGNORINI_CACHE/coacd`` (or ``~/.cache/signorini/coacd``), keyed
  by the mesh's arrays, every CoACD setting and CoACD's version, so a second run is a file read;
- to pay once and ship the result: ``m = sg.decompose(mesh, ...)``, ``sg.save_mesh(m, "part.npz")``,
  and from then on ``sg.load_mesh("part.npz")`` (the pieces come with the mesh).

Settings, speed against quality (measured as ``TIMINGS``, one run each):

- ``threshold`` in (0, 1], default 0.05: the concavity a piece may keep, as a fraction of the
  mesh's size. Larger is coarser and faster: the bunny took 44 s for 42 pieces at 0.05, 14 s for
  17 at 0.1, 5 s for 6 at 0.2. A mesh CoACD remeshes first gains less (duck: 164 s at 0.05, 139 s
  at 0.1, most of it the remeshing).
- ``max_pieces``, None or >= 1: merge the pieces down to at most this many at the end (CoACD's
  ``max_convex_hull``). Fewer pieces make contacts cheaper, CoACD no faster: it cuts as before,
  then merges for longer (the bunny with 8: the same cutting rounds, 8 pieces).
- ``preprocess_resolution``, default 50: the voxel resolution of the remeshing CoACD does first on
  a mesh it finds not manifold (self-intersecting or overlapping parts, such as a union of hulls).
  Lower is faster and coarser: duck_vhacd's hulls as one mesh took 100 s at 50 and 30 s at 30,
  teddy's 257 s and 132 s. A clean closed mesh is not remeshed and does not use it.
- ``seed``: CoACD's random seed; a given seed gives the same pieces.
"""
from __future__ import annotations

import contextlib
import contextvars
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from . import meshfile, progress as progress_bars
from ._core import Mesh

__all__ = ["decompose", "convex_pieces", "quiet", "estimate", "cache_dir", "DEFAULT_THRESHOLD",
           "DEFAULT_PREPROCESS_RESOLUTION", "TIMINGS"]

#: CoACD's concavity threshold: smaller gives more, tighter pieces.
DEFAULT_THRESHOLD = 0.05
#: CoACD's voxel resolution for remeshing a mesh that is not a clean manifold
DEFAULT_PREPROCESS_RESOLUTION = 50

#: CoACD 1.0.14 with the default settings on pybullet_data's meshes (and the torus of the tests), on
#: a 2-core machine shared with other jobs: {mesh: (triangles, seconds, pieces)}. The estimate
#: printed before a run is drawn from these; README "Meshes" has the other settings' figures.
TIMINGS = {
    "torus(0.3, 0.1, 24, 12)": (576, 14.4, 11),
    "bunny.obj": (902, 44.4, 42),
    "duck.obj": (4212, 163.9, 11),
    "teddy2_VHACD_CHs.obj as one mesh": (2432, 256.5, 36),
}

# the worker script, run by path (it imports numpy and coacd, not signorini)
_WORKER = Path(__file__).with_name("_coacd_worker.py")
# a version of the cache's key and layout: bump it when either changes
_CACHE_FORMAT = "2"


def cache_dir() -> Path:
    """Where decompositions are kept: ``$SIGNORINI_CACHE/coacd`` or ``~/.cache/signorini/coacd``."""
    root = os.environ.get("SIGNORINI_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "signorini")
    return Path(root) / "coacd"


def _settings(threshold, max_pieces, preprocess_resolution, seed) -> dict:
    """CoACD's run_coacd keywords for the given settings, checked (ValueError or TypeError naming
    the setting)."""
    if isinstance(threshold, bool) or not isinstance(threshold, (int, float, np.integer, np.floating)) \
            or not 0.0 < float(threshold) <= 1.0:
        raise ValueError(f"decompose: threshold must be a number in (0, 1], got {threshold!r}")
    for name, value, least in (("max_pieces", max_pieces, 1), ("preprocess_resolution", preprocess_resolution, 10),
                               ("seed", seed, 0)):
        if value is None and name == "max_pieces":
            continue
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise TypeError(f"decompose: {name} must be an integer, got {value!r}")
        if value < least:
            raise ValueError(f"decompose: {name} must be >= {least}, got {value!r}")
    return {"threshold": float(threshold), "max_convex_hull": -1 if max_pieces is None else int(max_pieces),
            "preprocess_resolution": int(preprocess_resolution), "seed": int(seed)}


def _coacd_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("coacd")
    except PackageNotFoundError:
        return "unknown"


def _key(vertices: np.ndarray, faces: np.ndarray, settings: dict) -> str:
    """The cache key: the mesh's arrays, every CoACD setting, CoACD's version and the format."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(vertices, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(faces, dtype=np.int64).tobytes())
    h.update(json.dumps({"settings": settings, "coacd": _coacd_version(), "format": _CACHE_FORMAT},
                        sort_keys=True).encode())
    return h.hexdigest()[:32]


def estimate(mesh: Mesh, threshold: float = DEFAULT_THRESHOLD) -> tuple[float, float]:
    """(low, high) seconds CoACD may take on this mesh with this threshold, from ``TIMINGS``.

    CoACD's time is set by how many pieces it cuts and whether it first remeshes (a mesh it finds
    not manifold), neither known before it runs, so this is the range measured on meshes of a few
    hundred to a few thousand triangles, scaled by the threshold as measured on the bunny (time
    about proportional to threshold^-1.6: a third at 0.1, a ninth at 0.2); for a mesh of under 200
    triangles, from a second to the smallest of them. A range to plan by, not a promise."""
    factor = (DEFAULT_THRESHOLD / float(threshold)) ** 1.6
    seconds = [t for _, t, _ in TIMINGS.values()]
    if len(mesh.faces) < 200:
        return 1.0, max(1.0, factor * min(seconds))
    return factor * min(seconds), factor * max(seconds)


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.0f} min"


#: whether a decomposition asked for without ``progress=`` (``World.add_body``'s) prints its estimate and bar
_PROGRESS: contextvars.ContextVar[bool] = contextvars.ContextVar("signorini_decomposition_progress", default=True)


@contextlib.contextmanager
def quiet():
    """Within ``with decomposition.quiet():`` decompositions asked for without ``progress=`` (those
    ``World.add_body`` and the scene loaders start) print neither the estimate nor the progress
    bar (``python -m signorini run --quiet``). CoACD still runs, and Ctrl-C still stops it."""
    token = _PROGRESS.set(False)
    try:
        yield
    finally:
        _PROGRESS.reset(token)


def convex_pieces(mesh: Mesh, threshold: float = DEFAULT_THRESHOLD, seed: int = 0, *, max_pieces: int | None = None,
                  preprocess_resolution: int = DEFAULT_PREPROCESS_RESOLUTION,
                  progress: bool | None = None) -> list[np.ndarray]:
    """The vertex arrays (n_i, 3) of the convex pieces of a closed mesh (its own frame, m).

    Read from the cache when this mesh was decomposed before with the same settings (module doc);
    otherwise computed by CoACD in a worker process (deterministic for a given seed) and cached.
    progress: print the estimate and show the progress bar on stderr (nothing is printed for a
    cached mesh); None (the default): yes, except inside ``quiet()``. Raises ValueError for an open or inconsistently oriented mesh or a setting out of
    range, TypeError for a non-integer count, RuntimeError when CoACD fails; KeyboardInterrupt
    (Ctrl-C) stops the worker and propagates, with nothing cached.
    """
    if not isinstance(mesh, Mesh):
        raise TypeError(f"decompose: mesh must be a signorini Mesh, got {type(mesh).__name__}")
    settings = _settings(threshold, max_pieces, preprocess_resolution, seed)
    problem = mesh.closedness_problem()
    if problem:
        raise ValueError(f"decompose: the mesh must be closed to be decomposed: {problem}")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    path = cache_dir() / f"{_key(vertices, faces, settings)}.npz"
    cached = _read_pieces(path)
    if cached is not None:
        return cached
    if progress is None:
        progress = _PROGRESS.get()
    if progress:
        low, high = estimate(mesh, settings["threshold"])
        print(f"signorini: decomposing a mesh of {len(faces):,} triangles into convex pieces with CoACD (threshold "
              f"{settings['threshold']}, max_pieces {max_pieces}, preprocess_resolution {preprocess_resolution}): "
              f"expect {_duration(low)} to {_duration(high)} (pybullet_data's bunny took 44 s, its duck 2.7 min). "
              f"Ctrl-C stops it; the pieces are cached in {path.parent}; sg.decompose then sg.save_mesh keep them "
              "with the mesh.", file=sys.stderr, flush=True)
    pieces = _run_worker(vertices, faces, settings, progress)
    path.parent.mkdir(parents=True, exist_ok=True)
    # written to a temporary file and renamed, so a reader never sees half a file
    with tempfile.NamedTemporaryFile(dir=path.parent, suffix=".npz", delete=False) as tmp:
        np.savez(tmp, count=len(pieces), **{f"piece_{k}": p for k, p in enumerate(pieces)})
    os.replace(tmp.name, path)
    return pieces


def _read_pieces(path: Path) -> list[np.ndarray] | None:
    """The pieces in a cache or worker file, or None when there is none or it is unreadable."""
    try:
        with np.load(path) as data:
            return [np.asarray(data[f"piece_{k}"], dtype=np.float64).reshape(-1, 3) for k in range(int(data["count"]))]
    except (OSError, KeyError, ValueError, EOFError):
        return None


def _run_worker(vertices: np.ndarray, faces: np.ndarray, settings: dict, progress: bool) -> list[np.ndarray]:
    """CoACD's pieces of the mesh, computed in the worker process, whose log drives the bar."""
    with tempfile.TemporaryDirectory(prefix="signorini-coacd-") as folder:
        source, target = Path(folder) / "mesh.npz", Path(folder) / "pieces.npz"
        np.savez(source, vertices=vertices, faces=faces)
        options = json.dumps({"coacd": settings, "path": sys.path})
        bar, other, worker = _Progress(progress), [], None
        try:
            # its own session: Ctrl-C reaches this process only, which then stops the worker (below)
            worker = subprocess.Popen([sys.executable, str(_WORKER), str(source), str(target), options],
                                      stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                      text=True, errors="replace", start_new_session=True)
            for line in worker.stdout:
                if not bar.feed(line):
                    other = (other + [line.rstrip()])[-12:]
            worker.wait()
        except BaseException:
            # Ctrl-C (KeyboardInterrupt) or any other error here: the worker stops with us
            bar.close()
            if worker is not None:
                _stop(worker)
            raise
        finally:
            if worker is not None:
                worker.stdin.close()
                worker.stdout.close()
        pieces = _read_pieces(target) if worker.returncode == 0 else None
        bar.done(None if pieces is None else len(pieces))
        if pieces is None:
            raise RuntimeError(f"decompose: CoACD failed (worker exit status {worker.returncode})"
                               + (": " + " | ".join(other) if other else ""))
        return pieces


def _stop(worker: subprocess.Popen) -> None:
    """Terminates the worker and waits for it (killed if it does not stop within 5 s)."""
    worker.terminate()
    try:
        worker.wait(timeout=5.0)
    except subprocess.TimeoutExpired:
        worker.kill()
        worker.wait()


class _Progress:
    """A progress bar of CoACD's pieces from its log lines (``signorini.progress.bar``: tqdm's on a terminal,
    a plain line per round in a log): CoACD starts each round with 'iter k ----
    waiting pool: N' (N pieces to cut or accept this round) and ends with ' - Merge Convex Hulls'.
    The pieces of round k that did not come back to round k + 1 as two halves are final, so after
    round k the bar shows final / (final + still being cut)."""

    _ROUND = re.compile(r"iter (\d+) -+ waiting pool: (\d+)")

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.bar = None
        self.final = 0
        self.pool = 0

    def feed(self, line: str) -> bool:
        """Takes one line of the worker's output; False when it is not a CoACD log line."""
        if "[CoACD]" not in line:
            return False
        found = self._ROUND.search(line)
        if found:
            round_, pool = int(found.group(1)), int(found.group(2))
            if round_ > 0:
                self.final += max(self.pool - (pool + 1) // 2, 0)
            self.pool = pool
            self._show(f"round {round_ + 1}, cutting {pool}")
        elif "Merge Convex Hulls" in line:
            self.final += self.pool
            self.pool = 0
            self._show("merging")
        return True

    def _show(self, what: str) -> None:
        if not self.enabled:
            return
        if self.bar is None:
            self.bar = progress_bars.bar(1, "CoACD", "pieces final", file=sys.stderr,
                                    bar_format="{desc}: {percentage:3.0f}%|{bar}| {n}/{total} pieces final "
                                               "[{elapsed}{postfix}]")
        self.bar.total = self.final + self.pool
        self.bar.n = self.final
        self.bar.set_postfix_str(what, refresh=False)
        self.bar.refresh()

    def done(self, pieces: int | None) -> None:
        """Shows the count of pieces CoACD returned (after merging) and closes the bar."""
        if self.bar is not None and pieces is not None:
            self.bar.total = self.bar.n = max(self.final, 1)
            self.bar.set_postfix_str(f"{pieces} after merging", refresh=False)
            self.bar.refresh()
        self.close()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def decompose(mesh: Mesh, threshold: float = DEFAULT_THRESHOLD, seed: int = 0, *, max_pieces: int | None = None,
              preprocess_resolution: int = DEFAULT_PREPROCESS_RESOLUTION, progress: bool | None = None) -> Mesh:
    """A copy of ``mesh`` that collides through convex pieces: the mesh itself when it is convex,
    its own hull when it is convex within ``meshfile.CONVEX_TOLERANCE``, else CoACD's pieces
    (``convex_pieces``; settings, cost, cache and Ctrl-C in the module doc). Its mass properties
    stay those of the mesh itself. Save it with ``sg.save_mesh(m, "part.npz")`` to keep the pieces
    with the mesh. Errors as for ``convex_pieces``; the mesh given is never changed."""
    if not isinstance(mesh, Mesh):
        raise TypeError(f"decompose: mesh must be a signorini Mesh, got {type(mesh).__name__}")
    _settings(threshold, max_pieces, preprocess_resolution, seed)
    if mesh.is_convex():
        return mesh
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    if not meshfile.convex_problem(vertices, np.asarray(mesh.faces, dtype=np.int64)):
        return mesh.with_pieces([vertices])
    return mesh.with_pieces(convex_pieces(mesh, threshold, seed, max_pieces=max_pieces,
                                          preprocess_resolution=preprocess_resolution, progress=progress))
