"""Fuzzing the file loaders: seeded mutations of valid scene files, trajectories, MJCF files and
meshes, each loaded in a child process under a memory cap.

    python -m signorini.fuzz_files 3000 7        # 3,000 mutated files of seed 7
    python -m signorini.fuzz_files 1 7 --keep out --start 1234   # file 1234 of seed 7, kept in out/

Mutation k of seed s depends only on (s, k): a kind (scene, trajectory, MJCF, OBJ, STL, .npz mesh,
in turn) and one to three mutations of that kind's valid sample: byte flips, a truncation, a
duplicated or deleted span, a huge or non-finite number put in place of one, or a deep nesting
inserted (arrays, dotted keys, elements, JSON) or a run of escaped quotes never closed; trajectories and .npz meshes are also mutated one
array at a time (its .npy header or data) and zipped again.

Each load runs in a forked child whose address space is capped at what it holds plus ``CAP_MB``
(RLIMIT_AS) and whose time is capped at ``TIMEOUT_S``. A load may end in only two ways: loaded, or
the loader's documented error (``SceneFileError``, ``ValueError`` for trajectories and meshes,
``MJCFError``). Failures, each printed with its reproducer: another exception type, a signal
(crash), a timeout, or a documented error that says memory ran out (the cap was reached: a limit
should have refused the file before). The last line sums up: files tried, loaded, errors by type,
failures, and the children's peak memory (growth of the peak RSS over what the child started with).
"""
from __future__ import annotations

import argparse
import faulthandler
import io
import json
import os
import random
import re
import resource
import signal
import sys
import tempfile
import time
import zipfile
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import meshes, meshfile, mjcf, scenefile, trajectory

__all__ = ["run", "mutate_file", "Summary", "KINDS", "CAP_MB", "TIMEOUT_S"]

#: memory a child may take on top of what it holds when forked (MiB); the samples load in ~20 MiB
CAP_MB = 512
#: seconds a load may take (the samples load in well under a second)
TIMEOUT_S = 30
#: the kinds of file, tried in turn
KINDS = ("scene", "trajectory", "mjcf", "obj", "stl", "npz_mesh")
#: the documented error of each kind's loader
DOCUMENTED = {"scene": ("SceneFileError",), "trajectory": ("ValueError",), "mjcf": ("MJCFError",),
              "obj": ("ValueError",), "stl": ("ValueError",), "npz_mesh": ("ValueError",)}
_SUFFIX = {"scene": ".toml", "trajectory": ".npz", "mjcf": ".xml", "obj": ".obj", "stl": ".stl", "npz_mesh": ".npz"}

_SCENE = """format = 1
[scene]
name = "fuzz"
dt = 0.004
steps = 10
snapshot_times = [0.0, 0.02]

[world]
gravity = [0.0, 0.0, -9.81]
erp = 0.2

[materials.rubber]
friction = 0.9
restitution = 0.5

[[bodies]]
name = "ground"
static = true
shape = { type = "plane", normal = [0.0, 0.0, 1.0], offset = 0.0 }

[[bodies]]
name = "ball"
shape = { type = "mesh", file = "scene.meshes/ball.npz" }
density = 500.0
material = "rubber"
position = [0.0, 0.0, 1.0]

[[bodies]]
shape = { type = "compound", parts = [{ shape = { type = "box", half_extents = [0.1, 0.2, 0.3] }, position = [0.1, 0.0, 0.0] }, { shape = { type = "sphere", radius = 0.1 }, position = [-0.2, 0.0, 0.0], orientation = [1.0, 0.0, 0.0, 0.0] }] }
mass = 2.0
position = [1.0, 0.0, 1.0]
velocity = [0.5, 0.0, 0.0]

[[bodies]]
static = true
shape = { type = "trimesh", vertices = [[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]], faces = [[0, 1, 2]] }

disabled_pairs = [[0, 3]]
"""

_MJCF = """<mujoco model="fuzz">
  <compiler angle="degree" meshdir="assets"/>
  <option gravity="0 0 -9.81" timestep="0.004"/>
  <default>
    <geom density="500" friction="0.7"/>
    <default class="heavy"><geom density="2000"/></default>
  </default>
  <asset><mesh name="ball" file="ball.obj" scale="1 1 1"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="crate" pos="0 0 1" euler="10 20 30">
      <freejoint/>
      <geom type="box" size="0.1 0.2 0.3"/>
      <geom type="sphere" size="0.1" pos="0.2 0 0"/>
      <body pos="0 0 0.3"><geom type="capsule" fromto="0 0 0 0.1 0 0.1" size="0.05"/></body>
    </body>
    <body name="ball" pos="1 0 1" childclass="heavy">
      <joint type="free"/>
      <geom type="mesh" mesh="ball"/>
    </body>
    <body name="shelf" pos="-1 0 0"><geom type="cylinder" size="0.05 0.5"/></body>
  </worldbody>
</mujoco>
"""

_NUMBER = re.compile(rb"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")
_HUGE = [b"1e308", b"-1e308", b"1e999", b"nan", b"inf", b"-inf", b"9" * 400, b"18446744073709551616",
         b"9223372036854775807", b"-9223372036854775808", b"1e-320", b"2147483648", b"-0"]


# the valid samples ------------------------------------------------------------------------------
def samples(folder: Path) -> dict[str, bytes]:
    """Each kind's valid sample as bytes; writes the files the samples refer to (the scene's mesh,
    the MJCF's mesh) into folder, where the mutated files are loaded."""
    import trimesh

    from .world import World

    v, f = meshes.icosphere(0.2, 1)
    (folder / "scene.meshes").mkdir(parents=True, exist_ok=True)
    meshfile.write_npz_mesh(folder / "scene.meshes" / "ball.npz", v, f, [v])
    (folder / "assets").mkdir(exist_ok=True)
    trimesh.Trimesh(v, f).export(str(folder / "assets" / "ball.obj"))
    out = {"scene": _SCENE.encode(), "mjcf": _MJCF.encode()}
    out["obj"] = trimesh.Trimesh(v, f).export(file_type="obj").encode()
    out["stl"] = trimesh.Trimesh(*meshes.box_mesh((0.1, 0.2, 0.3))).export(file_type="stl")
    buf = io.BytesIO()
    np.savez(buf, vertices=v, faces=f, piece_count=np.int64(1), piece_0=v)
    out["npz_mesh"] = buf.getvalue()
    from ._core import Box, Plane, Sphere

    w = World(gravity=(0, 0, -9.81))
    w.add_static(Plane((0, 0, 1), 0.0))
    w.add_body(Box((0.1, 0.1, 0.1)), density=100.0, position=(0, 0, 0.1))
    w.add_body(Sphere(0.1), density=100.0, position=(0.5, 0, 0.12))
    rec = trajectory.Recorder(w, stride=2)
    rec.step(1 / 240, 6)
    path = trajectory.save_trajectory(folder / "sample_trajectory.npz", rec.record())
    out["trajectory"] = path.read_bytes()
    return out


# mutations --------------------------------------------------------------------------------------
def _span(rng: random.Random, n: int) -> tuple[int, int]:
    a = rng.randrange(max(n, 1))
    return a, min(n, a + rng.randint(1, max(1, min(4096, n // 10 + 1))))


def _deep(rng: random.Random, kind: str) -> bytes:
    k = rng.choice((64, 1000, 100_000))
    if kind == "scene":
        return rng.choice((b"x = " + b"[" * k + b"]" * k + b"\n", b"a." * k + b"a = 1\n", b"[" + b"t." * k + b"t]\n",
                           b"y = " + b"{ a = " * k + b"1" + b" }" * k + b"\n", b"[" * k, b'z = "' + b'\\"' * k))
    if kind == "mjcf":
        return rng.choice((b"<body>" * k + b"</body>" * k, b"<body>" * k, b"<default class='c'>" * k))
    if kind == "trajectory":  # the shapes JSON
        return rng.choice((b"[" * k + b"]" * k, b'{"a":' * k + b"1" + b"}" * k, b"[" * k, b'"' + b'\\"' * k))
    return b"v 1 2 3\n" * k if kind == "obj" else b"\x00" * k


def mutate_bytes(rng: random.Random, data: bytes, kind: str) -> bytes:
    """One to three byte-level mutations of data (module doc)."""
    b = bytearray(data)
    for _ in range(rng.randint(1, 3)):
        op = rng.choice(("flip", "truncate", "duplicate", "delete", "number", "deep"))
        n = len(b)
        if op == "flip" and n:
            for _ in range(rng.randint(1, 8)):
                b[rng.randrange(n)] ^= 1 << rng.randrange(8)
        elif op == "truncate":
            del b[rng.randrange(n + 1):]
        elif op == "duplicate" and n:
            x, y = _span(rng, n)
            at = rng.randrange(n + 1)
            b[at:at] = b[x:y]
        elif op == "delete" and n:
            x, y = _span(rng, n)
            del b[x:y]
        elif op == "number":
            numbers = list(_NUMBER.finditer(bytes(b)))
            if numbers and kind not in ("stl", "trajectory", "npz_mesh"):
                m = rng.choice(numbers)
                b[m.start():m.end()] = rng.choice(_HUGE)
            elif n >= 8:  # binary: a huge or non-finite 8-byte number at an aligned offset
                at = rng.randrange(n // 8) * 8
                b[at:at + 8] = rng.choice((np.float64(1e308), np.float64(np.nan), np.int64(2**62),
                                           np.int64(-1), np.float64(np.inf))).tobytes()
        elif op == "deep":
            text = bytes(b)
            cuts = [m.end() for m in re.finditer(rb"\n|>", text)] or [0]
            at = rng.choice(cuts)
            b[at:at] = _deep(rng, kind)
    return bytes(b)


def _npz_members(data: bytes) -> dict[str, bytes]:
    with zipfile.ZipFile(io.BytesIO(data)) as z:
        return {i.filename: z.read(i) for i in z.infolist()}


def mutate_npz(rng: random.Random, data: bytes, kind: str) -> bytes:
    """The .npz zipped again with one or two arrays mutated (header, data, shape or JSON)."""
    members = _npz_members(data)
    for _ in range(rng.randint(1, 2)):
        name = rng.choice(sorted(members))
        raw = members[name]
        op = rng.choice(("bytes", "header", "shape", "json") if kind == "trajectory" else ("bytes", "header", "shape"))
        if op == "bytes":
            raw = mutate_bytes(rng, raw, kind)
        elif op == "header":  # flip bytes inside the .npy header only
            head = bytearray(raw[:128])
            for _ in range(rng.randint(1, 4)):
                head[rng.randrange(len(head))] = rng.randrange(32, 127)
            raw = bytes(head) + raw[128:]
        elif op == "shape":  # a header claiming another shape, the data unchanged
            dims = rng.choice(((2**40,), (2**31, 3), (0, 3), (3,), (10**6, 10**6, 3), (7, 1)))
            descr = rng.choice(("<f8", "<i8", "<U100000", "|b1", "<c16"))
            head = io.BytesIO()
            np.lib.format.write_array_header_1_0(head, {"descr": descr, "fortran_order": False, "shape": dims})
            body = raw[np.lib.format.MAGIC_LEN:]
            end = body.find(b"\n")
            raw = head.getvalue() + (body[end + 1:] if end >= 0 else b"")
        else:
            name = "shapes.npy"
            text = _deep(rng, kind).decode()
            buf = io.BytesIO()
            np.save(buf, np.array(text))
            raw = buf.getvalue()
        members[name] = raw
    out = io.BytesIO()
    method = rng.choice((zipfile.ZIP_DEFLATED, zipfile.ZIP_STORED))
    with zipfile.ZipFile(out, "w", method) as z:
        for name, raw in members.items():
            z.writestr(name, raw)
    return out.getvalue()


def mutate_file(sample: bytes, kind: str, seed: int, index: int) -> bytes:
    """Mutation ``index`` of seed ``seed`` of a kind's sample (depends on nothing else)."""
    rng = random.Random(f"{seed}:{index}:{kind}")
    if kind in ("trajectory", "npz_mesh") and rng.random() < 0.75:
        return mutate_npz(rng, sample, kind)
    return mutate_bytes(rng, sample, kind)


# loading in a child -----------------------------------------------------------------------------
def _load(kind: str, path: Path) -> None:
    if kind == "scene":
        scenefile.read_scene(path)
    elif kind == "trajectory":
        trajectory.load_trajectory(path)
    elif kind == "mjcf":
        mjcf.read_mjcf(path)
    else:
        meshfile.load_mesh(path, static=kind == "stl")


def _status(key: str) -> int:
    """A /proc/self/status figure (kB), e.g. VmSize, VmHWM, VmRSS."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return 0


def load_in_child(kind: str, path: Path, cap_mb: int = CAP_MB, timeout: int = TIMEOUT_S) -> dict:
    """Load path in a forked child under RLIMIT_AS (its size at the fork + cap_mb) and an alarm;
    {"outcome": "loaded" | "error" | "crash" | "timeout", "type", "message", "memory" (bool: the
    error says memory ran out), "peak_kb" (growth of the child's peak RSS), "signal"}."""
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns
        code = 0
        try:
            os.close(read_end)
            faulthandler.disable()  # a crash is reported by the parent, with its reproducer
            start = _status("VmRSS")
            cap = _status("VmSize") * 1024 + cap_mb * 2**20
            resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
            signal.alarm(timeout)
            result = {"outcome": "loaded", "type": "", "message": ""}
            try:
                _load(kind, path)
            except BaseException as e:  # noqa: B902 - every outcome is reported
                message = str(e)
                result = {"outcome": "error", "type": type(e).__name__, "message": message[:300],
                          "memory": isinstance(e, MemoryError) or "out of memory" in message
                          or "MemoryError" in message}
            signal.alarm(0)
            result["peak_kb"] = max(_status("VmHWM") - start, 0)
            os.write(write_end, json.dumps(result).encode())
        except BaseException:  # noqa: B902
            code = 3
        finally:
            os._exit(code)
    os.close(write_end)
    chunks = []
    while True:
        chunk = os.read(read_end, 65536)
        if not chunk:
            break
        chunks.append(chunk)
    os.close(read_end)
    _, status = os.waitpid(pid, 0)
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        return {"outcome": "timeout" if sig == signal.SIGALRM else "crash", "signal": sig, "type": "", "message": ""}
    if not chunks:
        return {"outcome": "crash", "signal": 0, "type": "", "message": f"child exited {os.WEXITSTATUS(status)}"}
    return json.loads(b"".join(chunks))


# the run ----------------------------------------------------------------------------------------
@dataclass
class Summary:
    """What a run saw: files per kind, loaded, errors by type, failures (reproducers), peak memory."""
    tried: Counter = field(default_factory=Counter)
    loaded: int = 0
    errors: Counter = field(default_factory=Counter)
    failures: list = field(default_factory=list)
    peak_kb: int = 0
    seconds: float = 0.0

    def line(self) -> str:
        kinds = ", ".join(f"{k} {self.tried[k]}" for k in KINDS)
        errors = ", ".join(f"{t} {c}" for t, c in self.errors.most_common()) or "none"
        counts = Counter(f["outcome"] for f in self.failures)
        return (f"files tried {sum(self.tried.values())} ({kinds}); loaded {self.loaded}; errors: {errors}; "
                f"undocumented errors {counts['undocumented']}, crashes {counts['crash']}, timeouts "
                f"{counts['timeout']}, memory cap reached {counts['memory']}; peak memory of a child "
                f"{self.peak_kb / 1024:.1f} MiB over its start (cap {CAP_MB} MiB); {self.seconds:.1f} s")


def run(n: int, seed: int, start: int = 0, keep: Path | None = None, report=None) -> Summary:
    """Mutations start..start+n-1 of seed, each loaded in a child (module doc); ``report(text)``
    gets each failure's line; ``keep``: a folder to keep the mutated files in."""
    summary = Summary()
    began = time.perf_counter()
    old_cache = os.environ.get("SIGNORINI_CACHE")
    with tempfile.TemporaryDirectory(prefix="signorini-fuzz-files-") as tmp:
        folder = Path(tmp)
        os.environ["SIGNORINI_CACHE"] = str(folder / "cache")  # decompositions of mutated meshes stay here
        try:
            base = samples(folder)
            for index in range(start, start + n):
                kind = KINDS[index % len(KINDS)]
                data = mutate_file(base[kind], kind, seed, index)
                name = "scene.toml" if kind == "scene" else "model.xml" if kind == "mjcf" else f"file{_SUFFIX[kind]}"
                path = folder / name
                path.write_bytes(data)
                if keep is not None:
                    Path(keep).mkdir(parents=True, exist_ok=True)
                    (Path(keep) / f"{seed}_{index}_{kind}{_SUFFIX[kind]}").write_bytes(data)
                result = load_in_child(kind, path)
                summary.tried[kind] += 1
                summary.peak_kb = max(summary.peak_kb, result.get("peak_kb", 0))
                outcome = result["outcome"]
                if outcome == "loaded":
                    summary.loaded += 1
                    continue
                if outcome == "error":
                    summary.errors[result["type"]] += 1
                    if result["type"] not in DOCUMENTED[kind]:
                        outcome = "undocumented"
                    elif result.get("memory"):
                        outcome = "memory"
                    else:
                        continue
                failure = {**result, "outcome": outcome, "kind": kind, "index": index}
                summary.failures.append(failure)
                if report is not None:
                    report(f"FAIL {outcome}: {kind} {seed}:{index} ({result.get('type') or 'signal ' + str(result.get('signal'))}: "
                           f"{result.get('message', '')[:200]}); reproduce: python -m signorini.fuzz_files 1 {seed} "
                           f"--start {index} --keep DIR")
        finally:
            if old_cache is None:
                os.environ.pop("SIGNORINI_CACHE", None)
            else:
                os.environ["SIGNORINI_CACHE"] = old_cache
    summary.seconds = time.perf_counter() - began
    return summary


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m signorini.fuzz_files", description=__doc__.split("\n\n")[0])
    parser.add_argument("n", type=int, nargs="?", default=600, help="mutated files to try (default 600)")
    parser.add_argument("seed", type=int, nargs="?", default=0, help="seed (default 0)")
    parser.add_argument("--start", type=int, default=0, help="first mutation index (default 0)")
    parser.add_argument("--keep", type=Path, help="a folder to keep the mutated files in")
    args = parser.parse_args(argv)
    summary = run(args.n, args.seed, args.start, args.keep, report=print)
    print(summary.line())
    return 1 if summary.failures else 0


if __name__ == "__main__":
    sys.exit(main())
