"""MJCF import: the same files loaded by signorini and (when installed) by MuJoCo give the same
masses, inertias (principal moments and frames) and initial poses within 1e-9; everything outside
the subset is an error listing it; bad files name the file, the line and the element."""
import math

import numpy as np
import pytest

import signorini as sg
from signorini import meshes

trimesh = pytest.importorskip("trimesh")

# free bodies of every geom type and pose notation, defaults with classes and childclass, a welded
# child body (fusestatic: MuJoCo merges it into its parent as signorini does), meshes from files
MODEL = """<mujoco model="everything">
  <compiler angle="{angle}" meshdir="assets" fusestatic="true" eulerseq="{eulerseq}"/>
  <option gravity="0 0 -9.81" timestep="0.004" cone="elliptic"/>
  <default>
    <geom density="500" friction="0.7 0.005 0.0001" rgba="0.5 0.5 0.5 1"/>
    <default class="heavy">
      <geom density="2000"/>
      <default class="heavier"><geom density="4000"/></default>
    </default>
  </default>
  <asset>
    <mesh name="cube" file="cube.stl" scale="0.1 0.2 0.3"/>
    <mesh file="ball.obj"/>
    <texture name="grid" type="2d" builtin="checker" width="8" height="8"/>
  </asset>
  <worldbody>
    <light pos="0 0 3"/>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <geom name="ramp" type="box" size="1 1 0.05" pos="3 0 0.2" euler="0 {a15} 0"/>
    <body name="shelf" pos="-3 0 0">
      <geom name="post" type="cylinder" fromto="0 0 0 0 0 1" size="0.05"/>
      <geom name="knob" type="ellipsoid" size="0.1 0.1 0.1" pos="0 0 1"/>
      <geom name="bump" type="ellipsoid" size="0.2 0.1 0.05" pos="0.5 0 0"/>
    </body>
    <body name="tumbler" pos="1 0 0.5" euler="{a10} {a20} {a30}">
      <freejoint/>
      <site name="marker" pos="0 0 0"/>
      <geom type="box" size="0.1 0.2 0.3"/>
      <geom type="sphere" size="0.1" pos="0.2 0 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0.1 0.2" size="0.05"/>
    </body>
    <body name="dumbbell" pos="0 1 1" axisangle="1 1 0 {a45}" childclass="heavy">
      <freejoint/>
      <geom type="cylinder" size="0.1 0.2" quat="0.9 0.1 0.2 0.3" pos="0.1 0.1 0"/>
      <body pos="0 0 0.3" zaxis="1 0 1"><geom type="box" size="0.05 0.05 0.05"/></body>
    </body>
    <body name="brick" pos="2 2 1" xyaxes="0 1 0 -1 0 0.2">
      <freejoint/>
      <geom class="heavier" type="box" fromto="-0.1 0 0 0.2 0.1 0" size="0.05 0.02"/>
    </body>
    <body name="block" pos="-1 -1 1" quat="0.5 0.5 0.5 0.5">
      <freejoint/>
      <geom type="mesh" mesh="cube" pos="0.05 0 0"/>
    </body>
    <body name="ball" pos="-2 -1 1">
      <joint type="free"/>
      <geom type="mesh" mesh="ball" mass="3.0"/>
    </body>
    <body name="weighed" pos="1 -2 1">
      <freejoint/>
      <inertial pos="0 0 0" mass="2.5" diaginertia="{i_box} {i_box} {i_box}"/>
      <geom type="box" size="0.1 0.1 0.1"/>
    </body>
    <body name="pill" pos="0 -3 1">
      <freejoint/>
      <geom type="capsule" size="0.05 0.2" mass="1.5"/>
    </body>
  </worldbody>
  <sensor><framepos objtype="site" objname="marker"/></sensor>
</mujoco>
"""


def write_model(folder, angle="degree", eulerseq="xyz"):
    (folder / "assets").mkdir(exist_ok=True)
    v, f = meshes.box_mesh((1.0, 1.0, 1.0))
    trimesh.Trimesh(v, f).export(str(folder / "assets" / "cube.stl"))
    # MuJoCo keeps mesh vertices in single precision: give it float32 values, written in full
    v, f = meshes.icosphere(0.15, 2)
    trimesh.Trimesh(v.astype(np.float32).astype(np.float64), f).export(str(folder / "assets" / "ball.obj"), digits=17)
    k = 1.0 if angle == "degree" else math.pi / 180.0
    # the inertia of a 0.2 m cube of 2.5 kg: m (a^2 + a^2) / 12 with a = 0.2
    text = MODEL.format(angle=angle, eulerseq=eulerseq, a15=15 * k, a10=10 * k, a20=20 * k, a30=30 * k, a45=45 * k,
                        i_box=repr(2.5 * 0.08 / 12))
    path = folder / "model.xml"
    path.write_text(text)
    return path


def test_import_builds_statics_then_free_bodies_with_names(tmp_path):
    scene = sg.read_mjcf(write_model(tmp_path))
    w = scene.world
    assert scene.dt == 0.004 and scene.names[:5] == ("floor", "ramp", "post", "knob", "bump")
    assert scene.names[5:] == ("tumbler", "dumbbell", "brick", "block", "ball", "weighed", "pill")
    assert w.is_static[:5].all() and not w.is_static[5:].any()
    assert isinstance(w.shape(0), sg.Plane) and isinstance(w.shape(3), sg.Sphere)   # equal radii: a sphere
    assert isinstance(w.shape(4), sg.ConvexHull)                                      # a static ellipsoid
    assert isinstance(w.shape(6), sg.Compound) and len(w.shape(6).parts) == 2         # welded child body
    assert w.solver["friction_cone"] == "cone"
    np.testing.assert_array_equal(w.frictions, 0.7)
    assert w.masses[10] == 2.5 and w.masses[11] == 1.5 and w.masses[9] == pytest.approx(3.0, rel=1e-14)


@pytest.mark.parametrize("angle, eulerseq", [("degree", "xyz"), ("radian", "xyz"), ("degree", "ZYX"), ("radian", "zxz")])
def test_same_masses_inertias_and_poses_as_mujoco(tmp_path, angle, eulerseq):
    mujoco = pytest.importorskip("mujoco")
    path = write_model(tmp_path, angle, eulerseq)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    w = sg.load_mjcf(path)
    free = [b for b in range(1, m.nbody) if m.body_jntnum[b] > 0]
    ours = np.flatnonzero(~w.is_static)
    assert len(free) == len(ours) == 7
    worst = {"mass": 0.0, "moments": 0.0, "inertia": 0.0, "com": 0.0, "frame": 0.0}
    for i, b in zip(ours, free):
        scale = m.body_mass[b]
        worst["mass"] = max(worst["mass"], abs(w.masses[i] - m.body_mass[b]) / scale)
        # principal moments, and the whole tensor in world axes (the principal frames)
        moments = np.linalg.eigvalsh(w.inertias[i])
        worst["moments"] = max(worst["moments"], np.abs(moments - np.sort(m.body_inertia[b])).max() / moments.max())
        R, Ri = w.rotations[i], d.ximat[b].reshape(3, 3)
        I_world, I_mujoco = R @ w.inertias[i] @ R.T, Ri @ np.diag(m.body_inertia[b]) @ Ri.T
        worst["inertia"] = max(worst["inertia"], np.abs(I_world - I_mujoco).max() / moments.max())
        # the centre of mass where MuJoCo puts it; the body frame is MuJoCo's body frame
        worst["com"] = max(worst["com"], np.abs(w.positions[i] - d.xipos[b]).max())
        worst["frame"] = max(worst["frame"], np.abs(R - d.xmat[b].reshape(3, 3)).max())
    print(f"\nsignorini vs MuJoCo {mujoco.__version__} ({angle}, {eulerseq}), worst over 7 free bodies: "
          f"mass {worst['mass']:.1e} (relative), principal moments {worst['moments']:.1e}, inertia tensor "
          f"{worst['inertia']:.1e} (relative), com {worst['com']:.1e} m, frame {worst['frame']:.1e}")
    assert all(v < 1e-9 for v in worst.values()), worst
    # static geoms: MuJoCo's world frame of each geom; a plane's normal is its z axis
    np.testing.assert_allclose(w.shape(0).normal, d.geom_xmat[0].reshape(3, 3)[:, 2], atol=1e-12)
    ramp = m.geom("ramp").id
    np.testing.assert_allclose(w.positions[1], d.geom_xpos[ramp], atol=1e-12)
    np.testing.assert_allclose(w.rotations[1], d.geom_xmat[ramp].reshape(3, 3), atol=1e-12)
    np.testing.assert_allclose(w.gravity, m.opt.gravity, atol=0)


def write(tmp_path, text, name="bad.xml"):
    path = tmp_path / name
    path.write_text(text)
    return path


# torsional friction: condim 4 and 6 carry it, 3 and 1 do not (1 has no sliding friction either); a friction with fewer than 3 values
# keeps the rest of its default class (MuJoCo's own default 1 0.005 0.0001 at the root)
TORSION = """<mujoco>
  <default>
    <geom friction="0.5 0.02 0.001" condim="4"/>
    <default class="slick"><geom friction="0.7"/></default>
    <default class="flat"><geom condim="3"/></default>
    <default class="nested"><geom friction="0.6 0.03"/><default class="inner"><geom friction="0.8"/></default></default>
  </default>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <geom name="step" type="box" size="1 1 0.1" pos="3 0 0" class="flat"/>
    <body name="inherits" pos="0 0 1"><freejoint/><geom size="0.1"/></body>
    <body name="slick" pos="1 0 1"><freejoint/><geom class="slick" size="0.1"/></body>
    <body name="flat" pos="2 0 1"><freejoint/><geom class="flat" size="0.1" friction="0.9 0.04"/></body>
    <body name="rolling" pos="3 0 1"><freejoint/><geom size="0.1" friction="0.4 0.01" condim="6"/></body>
    <body name="inner" pos="4 0 1"><freejoint/><geom class="inner" size="0.1"/></body>
    <body name="plain" pos="5 0 1"><freejoint/><geom size="0.1" condim="3" friction="1"/></body>
    <body name="frictionless" pos="6 0 1"><freejoint/><geom size="0.1" condim="1" friction="0.8 0.02"/></body>
  </worldbody>
</mujoco>"""


def test_torsional_friction_of_condim_4_and_6_geoms_becomes_spinning_friction(tmp_path):
    w = sg.load_mjcf(write(tmp_path, TORSION, "torsion.xml"))
    np.testing.assert_array_equal(w.frictions, [0.5, 0.5, 0.5, 0.7, 0.9, 0.4, 0.8, 1.0, 0.0])
    np.testing.assert_array_equal(w.spinning_frictions, [0.02, 0.0, 0.02, 0.02, 0.0, 0.01, 0.03, 0.0, 0.0])
    mujoco = pytest.importorskip("mujoco")
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "torsion.xml"))
    # the same geoms in the same order (static ones first, then one geom per free body)
    np.testing.assert_array_equal(w.frictions, np.where(m.geom_condim > 1, m.geom_friction[:, 0], 0.0))
    np.testing.assert_array_equal(w.spinning_frictions, np.where(m.geom_condim >= 4, m.geom_friction[:, 1], 0.0))


@pytest.mark.parametrize("text, message", [
    ("<mujoco><worldbody><body><freejoint/><geom size='0.1' condim='2'/></body></worldbody></mujoco>",
     r"<geom>: condim='2' must be 1, 3, 4 or 6"),
    ("<mujoco><worldbody><body name='b'><freejoint/><geom size='0.1' condim='4'/>"
     "<geom type='box' size='0.1 0.1 0.1' pos='0.3 0 0'/></body></worldbody></mujoco>",
     r"<body name='b'>: its geoms have different torsional frictions \[0.0, 0.005\] m"),
])
def test_bad_torsional_friction_names_the_element(tmp_path, text, message):
    with pytest.raises(sg.MJCFError, match=r"bad\.xml'?: .*" + message):
        sg.load_mjcf(write(tmp_path, text))


def test_everything_outside_the_subset_is_listed_in_one_error(tmp_path):
    path = write(tmp_path, """<mujoco>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0"/>
      <geom type="capsule" size="0.05 0.2"/>
      <body name="forearm"><joint type="slide"/><geom type="sphere" size="0.1"/></body>
    </body>
    <body name="free"><freejoint/><geom type="sphere" size="0.1" hfield="x"/></body>
  </worldbody>
  <actuator><general joint="shoulder"/></actuator>
  <tendon/>
  <equality/>
  <contact><exclude body1="arm" body2="free"/></contact>
</mujoco>""")
    with pytest.raises(sg.MJCFError) as e:
        sg.load_mjcf(path)
    message = str(e.value)
    assert "bad.xml" in message
    # the hinge, the slide and the exclude are imported now (test_mjcf_joints.py); a general actuator is not
    for needle in ("line 8 <geom> (attribute hfield)", "line 10 <general> (general actuator", "line 11 <tendon>",
                   "line 12 <equality>"):
        assert needle in message, (needle, message)
    assert "<joint" not in message and "<contact>" not in message and "<exclude" not in message


def test_unsupported_elements_inside_frames_are_listed_in_line_order(tmp_path):
    # as MuJoCo writes a converted URDF (r2d2): the wheels' hinges sit in bodies inside <frame>s.
    # Frames and hinges are imported; what is not (armature, two joints on a body, a replicate) is
    # listed wherever it sits
    path = write(tmp_path, """<mujoco>
  <worldbody>
    <body name="ball" pos="0 0 2"><freejoint/><geom type="sphere" size="0.1" hfield="x"/></body>
    <body name="base" pos="0 0 1">
      <freejoint/><geom type="box" size="0.2 0.1 0.1"/>
      <frame name="left" pos="0 0.2 0">
        <body name="left_wheel"><joint name="left_hinge" armature="0.1"/><geom type="sphere" size="0.05"/></body>
        <frame><body name="left_rear"><joint name="a"/><joint name="b"/><geom type="sphere" size="0.05"/></body></frame>
      </frame>
      <frame name="right" pos="0 -0.2 0">
        <body name="right_wheel"><joint name="right_hinge" type="hinge"/><geom type="sphere" size="0.05"/></body>
        <replicate count="2"><geom size="0.1"/></replicate>
      </frame>
    </body>
    <frame name="top"><body name="lid"><joint name="lid_slide" type="slide"/><geom size="0.1"/></body></frame>
  </worldbody>
  <actuator><general joint="left_hinge"/></actuator>
</mujoco>""")
    with pytest.raises(sg.MJCFError) as e:
        sg.load_mjcf(path)
    listed = [line.strip() for line in str(e.value).split("\n")[1:]]
    assert [line.split(":")[0].split(" (")[0] for line in listed] == [
        "line 3 <geom>", "line 7 <joint name='left_hinge'>", "line 8 <body name='left_rear'>", "line 12 <replicate>",
        "line 17 <general>"], str(e.value)
    assert "armature" in listed[1] and "2 joints on one body" in listed[2] and "general actuator" in listed[4]


@pytest.mark.parametrize("text, message", [
    ("<mujoco><worldbody><geom type='sphere' size='0.1'></worldbody></mujoco>", r"malformed XML: mismatched tag: line 1"),
    ("<robot/>", r"root element is <robot>"),
    ("<mujoco><worldbody><body><freejoint/><geom type='hfield'/></body></worldbody></mujoco>",
     r"line 1 <geom>: unknown or unsupported geom type 'hfield'"),
    ("<mujoco><worldbody><body><freejoint/><geom type='sphere'/></body></worldbody></mujoco>",
     r"<geom>: a sphere needs 1 size value, got 0"),
    ("<mujoco><worldbody><body><freejoint/><geom type='sphere' size='-1'/></body></worldbody></mujoco>",
     r"<geom>.*radius"),
    ("<mujoco><worldbody><body name='b'><freejoint/><geom type='sphere' size='0.1'/>"
     "<geom type='box' size='0.1 0.1 0.1' density='10'/></body></worldbody></mujoco>",
     r"<body name='b'>: its geoms have different densities \(1000, 10 kg/m\^3\)"),
    ("<mujoco><worldbody><body name='b'><freejoint/><inertial pos='0 0 0' mass='1' diaginertia='1 1 1'/>"
     "<geom type='sphere' size='0.1'/></body></worldbody></mujoco>", r"<inertial>: differs from the geoms' own inertia"),
    ("<mujoco><worldbody><body><freejoint/><geom type='plane' size='1 1 1'/></body></worldbody></mujoco>",
     r"a plane can only belong to the world"),
    ("<mujoco><worldbody><body><freejoint/><geom class='nope' size='1'/></body></worldbody></mujoco>",
     r"unknown default class 'nope'"),
    ("<mujoco><worldbody><body><freejoint/><geom type='mesh' mesh='m'/></body></worldbody></mujoco>",
     r"mesh 'm' is not an <asset> mesh"),
    ("<mujoco><asset><mesh file='gone.stl'/></asset><worldbody><body><freejoint/><geom type='mesh' mesh='gone'/>"
     "</body></worldbody></mujoco>", r"<mesh>: mesh file .*gone\.stl.* does not exist"),
    ("<mujoco><worldbody><body><freejoint/><geom type='box' size='1 1 1' euler='0 0 1' quat='1 0 0 0'/></body>"
     "</worldbody></mujoco>", r"more than one orientation: quat, euler"),
    ("<mujoco><worldbody><body><freejoint/><geom type='sphere' size='x'/></body></worldbody></mujoco>",
     r"size='x' is not a list of numbers"),
    ("<mujoco><worldbody><body name='empty'><freejoint/></body></worldbody></mujoco>",
     r"<body name='empty'>: a free body needs at least one geom"),
    ("<mujoco><compiler angle='gradian'/><worldbody/></mujoco>", r"angle must be 'degree' or 'radian'"),
])
def test_bad_files_name_the_file_line_and_element(tmp_path, text, message):
    with pytest.raises(sg.MJCFError, match=r"bad\.xml'?: .*" + message):
        sg.load_mjcf(write(tmp_path, text))


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"nowhere\.xml"):
        sg.load_mjcf(tmp_path / "nowhere.xml")


def test_imported_world_steps_and_saves_as_a_scene_file(tmp_path):
    scene = sg.read_mjcf(write_model(tmp_path))
    path = sg.save_scene(scene, tmp_path / "imported.toml")
    again = sg.read_scene(path)
    assert again.names == scene.names
    # compound parts turned by the import are written as the quaternions of their rotation
    # matrices (a bit or two off): the same bodies within rounding, not bit for bit
    np.testing.assert_allclose(again.world.masses, scene.world.masses, rtol=1e-14)
    np.testing.assert_allclose(again.world.inertias, scene.world.inertias, rtol=1e-13, atol=1e-16)
    np.testing.assert_allclose(again.world.positions, scene.world.positions, rtol=0, atol=1e-15)
    scene.world.step(scene.dt, 50)
    again.world.step(again.dt, 50)
    np.testing.assert_allclose(again.world.positions, scene.world.positions, rtol=0, atol=1e-9)
    # everything falls: every free body is lower after 0.2 s
    assert np.all(scene.world.positions[5:, 2] < sg.load_mjcf(write_model(tmp_path)).positions[5:, 2])
