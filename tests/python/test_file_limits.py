"""Loaders with limits (issue 26): hostile or careless files are refused with the loader's one
documented error (SceneFileError, MJCFError, ValueError for trajectories and meshes) naming the
file and the key, in little memory (measured in a child process under RLIMIT_AS), and the meshes a
scene or MJCF file names stay inside its folder (or folders passed explicitly), with an error that
does not tell whether an outside path exists. The tests use only the public loaders, so each one
runs against the code before the limits too (where it fails)."""
import io
import json
import os
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest

import signorini as sg

trimesh = pytest.importorskip("trimesh")

PYTHON = str(Path(sg.__file__).resolve().parents[1])

# the child: imports first, then caps its address space at what it has plus cap_mb, runs the code
# and prints the exception it ended with (type, message), how far its peak RSS grew (MiB) and the
# code's own measure ``_peak`` if it set one
_CHILD = """
import json, resource, sys, time
import numpy as np, trimesh
import signorini as sg
from signorini import mjcf, scenefile, trajectory, meshfile
def _vm():
    for line in open("/proc/self/status"):
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
_cap = _vm() + {cap} * 2**20
resource.setrlimit(resource.RLIMIT_AS, (_cap, _cap))
_rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
_out = {{"error": None, "message": ""}}
try:
{code}
except BaseException as _e:
    _out = {{"error": type(_e).__name__, "message": str(_e)[:4000]}}
_out["rss_mb"] = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - _rss0) / 1024
_out["peak"] = globals().get("_peak")  # set by code that measures with tracemalloc
print("RESULT " + json.dumps(_out))
"""


def in_child(code: str, cap_mb: int = 512, timeout: float = 120.0) -> dict:
    """Run code in a fresh interpreter capped at cap_mb MiB more than it holds after its imports;
    {"error": exception type name or None, "message", "rss_mb": peak RSS growth, "peak": _peak or None}."""
    source = _CHILD.format(cap=cap_mb, code=textwrap.indent(textwrap.dedent(code), "    "))
    env = {**os.environ, "PYTHONPATH": PYTHON}
    try:
        done = subprocess.run([sys.executable, "-c", source], capture_output=True, text=True, timeout=timeout,
                              env=env)
    except subprocess.TimeoutExpired:
        pytest.fail(f"the load took more than {timeout} s")
    lines = [x for x in done.stdout.splitlines() if x.startswith("RESULT ")]
    assert lines, f"the child died (return code {done.returncode}): {done.stderr[-2000:]}"
    return json.loads(lines[-1][len("RESULT "):])


# trajectories -----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def trajectory_file(tmp_path_factory):
    """A valid trajectory of two bodies (a plane and a box), 4 steps, with contacts."""
    w = sg.World(gravity=(0, 0, -9.81))
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Box((0.1, 0.1, 0.1)), density=100.0, position=(0, 0, 0.1))
    rec = sg.Recorder(w, stride=1)
    rec.step(1 / 240, 4)
    return sg.save_trajectory(tmp_path_factory.mktemp("traj") / "run.npz", rec.record())


def rewrite(src: Path, dst: Path, **members) -> Path:
    """A copy of the .npz src with some members replaced (values are arrays, or bytes for a raw
    .npy member)."""
    with np.load(src) as z:
        data = {k: z[k] for k in z.files}
    raw = {k: v for k, v in members.items() if isinstance(v, bytes)}
    data.update({k: v for k, v in members.items() if not isinstance(v, bytes)})
    with zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as z:
        for k, v in data.items():
            if k in raw:
                z.writestr(f"{k}.npy", raw[k])
                continue
            buf = io.BytesIO()
            np.save(buf, np.asarray(v), allow_pickle=False)
            z.writestr(f"{k}.npy", buf.getvalue())
    return dst


def npy_header(shape, descr="<f8") -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": descr, "fortran_order": False, "shape": shape})
    return buf.getvalue()


@pytest.mark.slow
def test_trajectory_bomb_is_refused_from_its_headers_in_little_memory(trajectory_file, tmp_path):
    # reproducer: a few MB of deflated zeros standing for 3.17 GB of positions
    path = tmp_path / "bomb.npz"
    rows = 3_170_000_000 // 24
    with np.load(trajectory_file) as z:
        data = {k: z[k] for k in z.files if k != "frame_positions"}
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as z:
        for k, v in data.items():
            buf = io.BytesIO()
            np.save(buf, v)
            z.writestr(f"{k}.npy", buf.getvalue())
        with z.open("frame_positions.npy", "w", force_zip64=True) as f:
            f.write(npy_header((rows, 1, 3)))
            zeros = bytes(1 << 22)
            left = rows * 24
            while left:
                f.write(zeros[:min(left, len(zeros))])
                left -= min(left, len(zeros))
    assert path.stat().st_size < 20e6
    out = in_child(f"sg.load_trajectory({str(path)!r})", cap_mb=256)
    assert out["error"] == "ValueError", out
    assert "bomb.npz" in out["message"] and "positions" in out["message"] and "limit" in out["message"]
    # refused from the headers: memory grew by far less than the file's own size
    assert out["rss_mb"] < 3 * path.stat().st_size / 2**20 + 16, out


def write_zeros_member(z: zipfile.ZipFile, name: str, shape, descr="<f8", last: bytes = b"") -> None:
    """A member of deflated zeros of the given shape (its last bytes ``last``), streamed in."""
    with z.open(f"{name}.npy", "w", force_zip64=True) as f:
        f.write(npy_header(shape, descr))
        left = int(np.prod(shape)) * np.dtype(descr).itemsize - len(last)
        zeros = bytes(1 << 22)
        while left:
            f.write(zeros[:min(left, len(zeros))])
            left -= min(left, len(zeros))
        f.write(last)


def test_a_consistent_trajectory_of_deflated_zeros_is_refused_by_its_ratio_in_little_memory(trajectory_file, tmp_path):
    # reproducer: every array agreeing with the others, all under the 1 GiB cap, ~1 GB of deflated
    # zeros in a few MB; it was decompressed in full before its values were checked (a NaN at the
    # very end of positions)
    path = tmp_path / "zeros.npz"
    with np.load(trajectory_file) as z:
        data = {k: z[k] for k in z.files if not k.startswith("contact_")}
    data["has_contacts"] = np.array(False)
    m = int(np.count_nonzero(data["moving"]))  # the bodies with frame arrays (format 2)
    frames = int(0.98 * 2**30 / (m * 13 * 8 + 4 * 8))  # just under the 1 GiB cap
    big = {"frame_positions": (frames, m, 3), "frame_orientations": (frames, m, 4), "frame_velocities": (frames, m, 3),
           "frame_angular_velocities": (frames, m, 3), "time": (frames,), "frame_step": (frames,),
           "kinetic_energy": (frames,), "potential_energy": (frames,)}
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as z:
        for k, v in data.items():
            if k not in big:
                buf = io.BytesIO()
                np.save(buf, v)
                z.writestr(f"{k}.npy", buf.getvalue())
        for k, shape in big.items():
            descr = "<i8" if k == "frame_step" else "<f8"
            write_zeros_member(z, k, shape, descr, np.float64(np.nan).tobytes() if k == "frame_positions" else b"")
    size = path.stat().st_size
    claimed = sum(int(np.prod(s)) * 8 for s in big.values())
    assert claimed < 2**30 < claimed * 1.1 and size < 8e6  # under the 1 GiB cap
    assert claimed > 64 * size  # over the ratio bound (MAX_TRAJECTORY_RATIO), which refuses it
    out = in_child(f"""
        import tracemalloc
        tracemalloc.start()
        try:
            sg.load_trajectory({str(path)!r})
        finally:
            _peak = tracemalloc.get_traced_memory()[1]  # bytes, numpy's arrays included
    """, cap_mb=512)
    assert out["error"] == "ValueError", out
    message = out["message"]
    assert "zeros.npz" in message and "orientations.npy" in message, message  # the largest array
    assert "over the limit of 64:1" in message and "max_ratio=None" in message, message
    # refused from the headers: memory grew by a small multiple of the file's own size at most
    assert out["rss_mb"] < 3 * size / 2**20 + 16, out
    assert out["peak"] < 3 * size, out


def test_the_ratio_bound_has_a_floor_and_can_be_lifted(tmp_path):
    from signorini import filecheck

    path = tmp_path / "zeros.npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        write_zeros_member(z, "a", (1 << 20,))  # 8 MiB of zeros in about 8 KB
    size = path.stat().st_size
    with pytest.raises(filecheck.RatioLimitError, match=r"a\.npy and the other arrays hold 8,388,608 bytes"):
        filecheck.read_npz(path, 1 << 30, max_ratio=64, ratio_floor=1 << 20)
    assert filecheck.read_npz(path, 1 << 30, max_ratio=64, ratio_floor=8 << 20)["a"].shape == (1 << 20,)
    assert filecheck.read_npz(path, 1 << 30, max_ratio=(8 << 20) / size, ratio_floor=0)["a"].shape == (1 << 20,)
    assert filecheck.read_npz(path, 1 << 30)["a"].shape == (1 << 20,)


def test_load_trajectory_max_ratio_is_checked_and_lifts_the_bound(trajectory_file, monkeypatch):
    ratio = sum(i.file_size for i in zipfile.ZipFile(trajectory_file).infolist()) / trajectory_file.stat().st_size
    monkeypatch.setattr(sg.trajectory, "TRAJECTORY_RATIO_FLOOR", 0)
    with pytest.raises(ValueError, match=r"run\.npz: .*over the limit of 1:1.*max_ratio=None"):
        sg.load_trajectory(trajectory_file, max_ratio=1)
    assert sg.load_trajectory(trajectory_file, max_ratio=ratio * 2).frames == 5
    assert sg.load_trajectory(trajectory_file, max_ratio=None).frames == 5
    for bad, error in ((0, ValueError), (-1.0, ValueError), (float("nan"), ValueError), ("64", TypeError),
                       (True, TypeError)):
        with pytest.raises(error, match="max_ratio"):
            sg.load_trajectory(trajectory_file, max_ratio=bad)


@pytest.mark.parametrize("name", ["boxes", "shapes"])
def test_the_projects_own_recordings_stay_far_under_the_ratio_bound(name, tmp_path):
    """The recordings of the built-in scenes hold at most about 8 bytes per byte of file (README
    "Files"; shapes 8.2 in format 2, whose float32 frames shrink less than its meshes and step
    arrays): under a sixth of MAX_TRAJECTORY_RATIO, so the bound refuses none of them."""
    from signorini import output, scenes

    scene = scenes.build(name)
    path = sg.save_trajectory(tmp_path / f"{name}.npz", output.run(scene, progress=False))
    ratio = sum(i.file_size for i in zipfile.ZipFile(path).infolist()) / path.stat().st_size
    assert ratio < sg.trajectory.MAX_TRAJECTORY_RATIO / 6, ratio
    assert sg.load_trajectory(path, max_ratio=sg.trajectory.MAX_TRAJECTORY_RATIO / 6).frames > 1


def test_npy_header_claiming_2_40_items_is_a_value_error(trajectory_file, tmp_path):
    # reproducer: numpy's _ArrayMemoryError escaped
    path = rewrite(trajectory_file, tmp_path / "huge.npz", time=npy_header((2**40,)) + bytes(64))
    with pytest.raises(ValueError, match=r"huge\.npz.*time.*\(1099511627776,\)"):
        sg.load_trajectory(path)


def test_deeply_nested_shapes_json_is_a_value_error(trajectory_file, tmp_path):
    # reproducer: RecursionError from json
    path = rewrite(trajectory_file, tmp_path / "deep.npz", shapes=np.array("[" * 100_000 + "]" * 100_000))
    with pytest.raises(ValueError, match=r"deep\.npz.*nested deeper"):
        sg.load_trajectory(path)


@pytest.mark.parametrize("key, value, message", [
    ("mesh_vertex_offsets", np.array([0, 10**12, -5]), r"mesh_vertex_offsets must be 3 integers from 0"),
    ("mesh_face_offsets", np.array([0, 30, 2]), r"mesh_face_offsets"),
    ("frame_positions", "nan", r"positions holds a value that is not finite"),
    ("frame_orientations", "inf", r"orientations holds a value that is not finite"),
    ("masses", np.array([np.inf, -1.0]), r"masses must be > 0"),
    ("contact_body_b", "big", r"contact_body_b names a body outside"),
])
def test_values_a_trajectory_cannot_hold_are_refused(trajectory_file, tmp_path, key, value, message):
    # reproducer: offsets [0, 1e12, -5] and NaN positions were accepted
    with np.load(trajectory_file) as z:
        original = z[key]
    if isinstance(value, str):
        value, what = original.copy(), value
        value.flat[-1] = {"nan": np.nan, "inf": np.inf, "big": 99}[what]
    path = rewrite(trajectory_file, tmp_path / "bad.npz", **{key: value})
    with pytest.raises(ValueError, match=r"bad\.npz.*" + message):
        sg.load_trajectory(path)


def test_a_corrupt_deflate_stream_is_a_value_error(trajectory_file, tmp_path):
    # found by the loader fuzz: zlib.error escaped
    data = bytearray(trajectory_file.read_bytes())
    with zipfile.ZipFile(trajectory_file) as z:
        info = z.getinfo("frame_positions.npy")
    at = info.header_offset  # the local header's own name and extra lengths (bytes 26..30)
    start = at + 30 + int.from_bytes(data[at + 26:at + 28], "little") + int.from_bytes(data[at + 28:at + 30], "little")
    data[start] = 0xFF  # a deflate block of the reserved type 3
    path = tmp_path / "inflate.npz"
    path.write_bytes(bytes(data))
    with pytest.raises(ValueError, match=r"inflate\.npz.*frame_positions"):
        sg.load_trajectory(path)


def test_the_valid_trajectory_still_loads(trajectory_file):
    r = sg.load_trajectory(trajectory_file)
    assert r.frames == 5 and r.num_bodies == 2 and r.contacts is not None


# scene files ------------------------------------------------------------------------------------
def test_deep_dotted_key_is_refused_quickly_in_little_memory(tmp_path):
    # reproducer: a 100 KB file with a 50,000-deep dotted key took over 6 GB and 73 s
    path = tmp_path / "dotted.toml"
    path.write_text(".".join(["a"] * 50_000) + " = 1\n")
    assert path.stat().st_size < 110_000
    out = in_child(f"sg.load_scene({str(path)!r})", cap_mb=512, timeout=60)
    assert out["error"] == "SceneFileError", out
    assert "dotted.toml" in out["message"] and "line 1" in out["message"] and "deeper" in out["message"]
    assert out["rss_mb"] < 64, out


def test_deeply_nested_arrays_are_a_scene_file_error(tmp_path):
    # reproducer: 100,000 nested [ raised RecursionError
    path = tmp_path / "nested.toml"
    path.write_text("x = " + "[" * 100_000 + "]" * 100_000 + "\n")
    with pytest.raises(sg.SceneFileError, match=r"nested\.toml.*line 1: nested deeper than"):
        sg.load_scene(path)


def test_dt_and_steps_out_of_bounds_are_refused(tmp_path):
    # reproducer: dt = 1e-300 and steps = 2^63 - 1 were accepted
    path = tmp_path / "forever.toml"
    path.write_text("[scene]\ndt = 1e-300\nsteps = 9223372036854775807\n")
    with pytest.raises(sg.SceneFileError, match=r"forever\.toml.*scene\.dt: Input should be greater than or equal"
                                                  r".*scene\.steps: Input should be less than or equal"):
        sg.read_scene(path)


def test_oversized_scene_file_is_refused_before_reading(tmp_path):
    path = tmp_path / "big.toml"
    with open(path, "wb") as f:
        f.truncate(64 * 2**20)
    with pytest.raises(sg.SceneFileError, match=r"big\.toml.*over the limit"):
        sg.load_scene(path)


# MJCF -------------------------------------------------------------------------------------------
def test_deeply_nested_bodies_are_an_mjcf_error(tmp_path):
    # reproducer: 100,000 nested <body> raised RecursionError
    path = tmp_path / "deep.xml"
    path.write_text("<mujoco><worldbody>" + "<body>" * 100_000 + "</body>" * 100_000 + "</worldbody></mujoco>")
    with pytest.raises(sg.MJCFError, match=r"deep\.xml.*line 1 <body>: elements nested deeper than"):
        sg.load_mjcf(path)


def test_mjcf_timestep_out_of_bounds_is_refused(tmp_path):
    path = tmp_path / "slow.xml"
    path.write_text('<mujoco><option timestep="1e-300"/><worldbody><geom type="sphere" size="1"/></worldbody></mujoco>')
    with pytest.raises(sg.MJCFError, match=r"slow\.xml.*line 1 <option>: timestep=1e-300 must lie in"):
        sg.read_mjcf(path)


def test_mjcf_mass_of_a_broken_mesh_geom_is_an_mjcf_error(tmp_path):
    # found by the loader fuzz: the free body's mass properties raised a bare ValueError
    write_ball(tmp_path / "ball.obj")
    path = tmp_path / "wide.xml"
    path.write_text('<mujoco><asset><mesh name="b" file="ball.obj" scale="2147483648 1 1"/></asset><worldbody>'
                    '<body name="x"><freejoint/><geom type="mesh" mesh="b" mass="1"/>'
                    '<geom type="sphere" size="0.1" pos="0.2 18446744073709551616 0"/></body></worldbody></mujoco>')
    with pytest.raises(sg.MJCFError, match=r"wide\.xml.*line 1 <(geom|body)"):
        sg.read_mjcf(path)


# paths ------------------------------------------------------------------------------------------
def write_ball(path: Path) -> Path:
    from signorini import meshes

    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.Trimesh(*meshes.icosphere(0.2, 1)).export(str(path))
    return path


def scene_naming(folder: Path, name: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "s.toml"
    path.write_text(f"[[bodies]]\nshape = {{ type = 'mesh', file = {json.dumps(name)} }}\ndensity = 1000\n")
    return path


def scene_error(path: Path, **kwargs) -> str:
    with pytest.raises(sg.SceneFileError) as e:
        sg.load_scene(path, **kwargs)
    return str(e.value)


@pytest.mark.parametrize("how", ["relative", "absolute"])
def test_scene_meshes_outside_the_folder_are_refused_without_telling_if_they_exist(tmp_path, how):
    # reproducer: file = "../../outside.obj" and absolute paths loaded; errors told existence
    messages = []
    for case in ("exists", "missing"):
        root = tmp_path / case
        outside = root / "outside.obj"
        if case == "exists":
            write_ball(outside)
        name = "../../outside.obj" if how == "relative" else str(outside)
        path = scene_naming(root / "a" / "b", name)
        message = scene_error(path)
        assert "outside the folders" in message and "bodies[0]" in message and "shape.file" in message
        messages.append(message.replace(str(root), "ROOT"))
    assert messages[0] == messages[1]


def test_a_symlink_leading_out_of_the_folder_is_refused(tmp_path):
    write_ball(tmp_path / "elsewhere" / "ball.obj")
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "link.obj").symlink_to(tmp_path / "elsewhere" / "ball.obj")
    assert "outside the folders" in scene_error(scene_naming(folder, "link.obj"))


def test_allow_paths_lets_a_scene_read_meshes_from_a_named_folder(tmp_path):
    write_ball(tmp_path / "assets" / "ball.obj")
    path = scene_naming(tmp_path / "scenes", "../assets/ball.obj")
    assert "outside the folders" in scene_error(path)
    w = sg.load_scene(path, allow_paths=[tmp_path / "assets"])
    assert w.num_bodies == 1
    assert sg.read_scene(path, allow_paths=[tmp_path / "assets"]).world.num_bodies == 1


MJCF_MESH = """<mujoco><compiler meshdir="{meshdir}"/><asset><mesh name="m" file="{file}"/></asset>
<worldbody><geom type="mesh" mesh="m"/></worldbody></mujoco>"""


def mjcf_error(path: Path, **kwargs) -> str:
    with pytest.raises(sg.MJCFError) as e:
        sg.load_mjcf(path, **kwargs)
    return str(e.value)


@pytest.mark.parametrize("meshdir, file", [("/", "{root}/outside.obj"), ("..", "outside.obj"),
                                           (".", "/{root}/outside.obj")])
def test_mjcf_meshes_outside_the_folder_are_refused_without_telling_if_they_exist(tmp_path, meshdir, file):
    # reproducer: meshdir="/" loaded any file on the machine
    messages = []
    for case in ("exists", "missing"):
        root = tmp_path / case
        if case == "exists":
            write_ball(root / "outside.obj")
        folder = root / "model"
        folder.mkdir(parents=True)
        path = folder / "m.xml"
        path.write_text(MJCF_MESH.format(meshdir=meshdir, file=file.format(root=str(root).lstrip("/"))))
        message = mjcf_error(path)
        assert "outside the folders" in message and "<mesh name='m'>" in message
        messages.append(message.replace(str(root), "ROOT").replace(str(root).lstrip("/"), "ROOT"))
    assert messages[0] == messages[1]


def test_package_dirs_let_an_mjcf_file_read_meshes_from_a_named_folder(tmp_path):
    write_ball(tmp_path / "assets" / "ball.obj")
    folder = tmp_path / "model"
    folder.mkdir()
    path = folder / "m.xml"
    path.write_text(MJCF_MESH.format(meshdir="../assets", file="ball.obj"))
    assert "outside the folders" in mjcf_error(path)
    assert sg.load_mjcf(path, package_dirs=[tmp_path / "assets"]).num_bodies == 1


# meshes -----------------------------------------------------------------------------------------
def test_mesh_npz_with_a_huge_header_or_bad_values_is_a_value_error(tmp_path):
    from signorini import meshes

    v, f = meshes.icosphere(0.2, 1)
    good = sg.meshfile.write_npz_mesh(tmp_path / "good.npz", v, f)
    assert len(sg.load_mesh(good).vertices) == len(v)
    huge = rewrite(good, tmp_path / "huge.npz", vertices=npy_header((2**40, 3)) + bytes(64))
    with pytest.raises(ValueError, match=r"huge\.npz.*vertices"):
        sg.load_mesh(huge)
    v_nan = v.copy()
    v_nan[3, 1] = np.nan
    with pytest.raises(ValueError, match=r"nan\.npz.*not finite"):
        sg.load_mesh(rewrite(good, tmp_path / "nan.npz", vertices=v_nan))
    f_out = f.copy()
    f_out[0, 0] = 10**9
    with pytest.raises(ValueError, match=r"faces\.npz.*faces"):
        sg.load_mesh(rewrite(good, tmp_path / "faces.npz", faces=f_out))


def test_oversized_mesh_file_is_refused_before_trimesh_reads_it(tmp_path):
    path = tmp_path / "big.stl"
    with open(path, "wb") as f:
        f.truncate(65 * 2**20)
    with pytest.raises(ValueError, match=r"big\.stl.*over the limit of 67,108,864"):
        sg.load_mesh(path)


def test_deep_mjcf_is_refused_in_little_memory(tmp_path):
    # 1.1 MB of nested bodies: refused at the 65th level, long before the tree is built
    path = tmp_path / "deep.xml"
    path.write_text("<mujoco><worldbody>" + "<body>" * 100_000 + "</body>" * 100_000 + "</worldbody></mujoco>")
    out = in_child(f"sg.load_mjcf({str(path)!r})", cap_mb=256)
    assert out["error"] == "MJCFError" and "nested deeper" in out["message"], out
    assert out["rss_mb"] < 16, out


@pytest.mark.slow
def test_unterminated_quotes_are_scanned_in_linear_time(trajectory_file, tmp_path):
    # the depth scans restarted a string match at every quote of '"\"\"\"...': quadratic (hours here)
    quotes = '"' + '\\"' * 200_000
    scene = tmp_path / "quotes.toml"
    scene.write_text("x = " + quotes + "\n")
    out = in_child(f"sg.load_scene({str(scene)!r})", timeout=60)
    assert out["error"] == "SceneFileError" and "not valid TOML" in out["message"], out
    path = rewrite(trajectory_file, tmp_path / "quotes.npz", shapes=np.array(quotes))
    out = in_child(f"sg.load_trajectory({str(path)!r})", timeout=60)
    assert out["error"] == "ValueError" and "quotes.npz" in out["message"], out
