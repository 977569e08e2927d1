"""MJCF joints and actuators (issue 23): hinge, slide and ball joints in body trees, ranges and ref,
damping, springs and friction, position and velocity actuators, contact excludes. The three models
of tests/python/data/mjcf_joints (a pendulum, a double pendulum, a 7-link planar arm) fall limp in
signorini and in MuJoCo (RK4 at dt 1/1000, the reference) from the same start: the joint angles agree
within 1e-2 rad after 1 s, and the joint-space mass matrices at the start within 1e-9 relative (the
signorini one built here from the bodies' masses, inertias and poses and the joints' axes)."""
import math
from pathlib import Path

import numpy as np
import pytest

import signorini as sg
from signorini.mjcf import import_mjcf

mujoco = pytest.importorskip("mujoco")

DATA = Path(__file__).parent / "data" / "mjcf_joints"
MODELS = ["pendulum", "double_pendulum", "arm7"]
DT = 1e-3


def write(tmp_path, text, name="model.xml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def wrapped(angle):
    """Angles (rad) into [-pi, pi): signorini's hinge angle wraps, MuJoCo's does not."""
    return (np.asarray(angle) + math.pi) % (2 * math.pi) - math.pi


def rotation(q) -> np.ndarray:
    """The rotation matrix (3, 3) of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def run_both(path, steps, **solver):
    """MuJoCo (RK4, its file's options) and signorini (``solver`` settings, sleeping off) stepped
    ``steps`` times at DT from the file's pose: (MuJoCo's qpos, signorini's) after."""
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.timestep = DT
    d = mujoco.MjData(m)
    model = import_mjcf(path)
    model.world.set_solver(**solver)
    model.world.set_sleep(sleeping=False)
    np.testing.assert_allclose(model.qpos(), d.qpos, rtol=0, atol=1e-12)
    for _ in range(steps):
        mujoco.mj_step(m, d)
        model.world.step(DT)
    return d.qpos.copy(), model.qpos()


# the settings each solver needs on these models: the soft step's joints are springs (joint_hertz,
# at most a quarter of the substep rate), so the light links of the arm need substeps and sweeps to
# follow MuJoCo's rigid joints (with the defaults: 0.028 rad off after 1 s, docs "MJCF")
SOLVERS = {
    "pgs": dict(solver="pgs"),
    "soft": dict(solver="soft", substeps=32, soft_iterations=4, relax_iterations=4),
}


@pytest.mark.parametrize("solver", SOLVERS)
@pytest.mark.parametrize("name", MODELS)
def test_limp_models_fall_as_in_mujoco(name, solver):
    mj, ours = run_both(DATA / f"{name}.xml", 1000, **SOLVERS[solver])
    difference = np.abs(wrapped(ours - mj)).max()
    print(f"{name} ({solver}): max |q - q_mujoco| after 1 s = {difference:.2e} rad")
    assert difference < 1e-2
    # they did move: each model turns far from its start
    assert np.abs(mj).max() > 1.0


@pytest.mark.parametrize("name", MODELS)
def test_mass_matrix_at_the_start_equals_mujocos(name):
    m = mujoco.MjModel.from_xml_path(str(DATA / f"{name}.xml"))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    expected = np.zeros((m.nv, m.nv))
    if hasattr(d, "qM"):  # MuJoCo 3: from the sparse qM; MuJoCo 4 reads mjData itself
        mujoco.mj_fullM(m, expected, d.qM)
    else:
        mujoco.mj_fullM(m, d, expected)
    M = import_mjcf(DATA / f"{name}.xml").mass_matrix()
    relative = np.abs(M - expected).max() / np.abs(expected).max()
    print(f"{name}: mass matrix relative difference {relative:.1e}")
    assert relative < 1e-9


def test_joints_map_onto_the_world(tmp_path):
    # a slide, a ball and a hinge with range, ref, damping, a spring and friction; a frame; radians
    path = write(tmp_path, """<mujoco>
  <compiler angle="radian"/>
  <default><joint damping="0.5"/></default>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="cart" pos="0 0 1">
      <joint name="rail" type="slide" axis="1 0 0" range="-0.5 0.5" ref="0.1"/>
      <geom type="box" size="0.2 0.1 0.05"/>
      <frame pos="0.2 0 0" euler="0 0 1.5707963267948966">
        <body name="arm">
          <joint name="pivot" axis="1 0 0" range="-1 1" ref="0.25" stiffness="3" springref="0.5" frictionloss="0.2"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.03"/>
          <body name="bob" pos="0 0 -0.5"><joint name="ball" type="ball" damping="0"/><geom size="0.05"/></body>
        </body>
      </frame>
    </body>
  </worldbody>
</mujoco>""")
    model = import_mjcf(path)
    w = model.world
    assert list(model.joints) == ["rail", "pivot", "ball"]
    rail, pivot, ball = (w.joint(model.joints[n].index) for n in model.joints)
    assert (rail["kind"], pivot["kind"], ball["kind"]) == ("Prismatic", "Revolute", "Spherical")
    # the cart hangs from the world's anchor body (static, colliding with nothing)
    anchor = model.joints["rail"].parent
    assert model.scene.names[anchor] == "world" and w.collision_filters[1][anchor] == 0
    assert model.joints["pivot"].parent == model.joints["rail"].body == model.bodies["cart"][0]
    # limits in signorini's coordinate: the range minus ref
    assert (rail["lower"], rail["upper"]) == pytest.approx((-0.6, 0.4))
    assert (pivot["lower"], pivot["upper"]) == pytest.approx((-1.25, 0.75))
    # the frame turns the hinge's x axis onto y (world)
    R = rotation(w.orientations[model.joints["pivot"].body])
    np.testing.assert_allclose(R @ pivot["axis_b"], [0, 1, 0], atol=1e-12)
    # damping 0.5 (the default class) and the spring (k 3 towards springref - ref = 0.25) as one drive
    assert not rail["motor_stiffness"] and rail["motor_damping"] == 0.5 and rail["motor_max_force"] == math.inf
    assert (pivot["motor_stiffness"], pivot["motor_damping"], pivot["motor_position"]) == pytest.approx((3, 0.5, 0.25))
    assert pivot["friction"] == 0.2 and not ball["motor"]
    np.testing.assert_allclose(model.qpos(), [0.1, 0.25])
    # jointed pairs do not collide; the world's other bodies (the floor) do, as in MuJoCo
    assert w.disabled_pairs == []
    # the joint-space mass matrix is the hinges' and slides': a ball joint (3 of MuJoCo's
    # coordinates) is refused by name
    with pytest.raises(ValueError, match="ball is a ball joint"):
        model.mass_matrix()


def test_actuators_drive_as_in_mujoco(tmp_path):
    # two wheels (hinges about their axle, no gravity torque): a velocity actuator and a position
    # servo with kv, gears, a clamped control; 1 s in both at dt 1/1000
    path = write(tmp_path, """<mujoco>
  <option timestep="0.001" integrator="implicitfast"><flag contact="disable"/></option>
  <worldbody>
    <body name="spinner" pos="0 0 1"><joint name="spin" axis="0 1 0"/>
      <geom type="cylinder" size="0.2 0.05" zaxis="0 1 0"/></body>
    <body name="servoed" pos="1 0 1"><joint name="turn" axis="0 1 0" damping="0.3"/>
      <geom type="cylinder" size="0.2 0.05" zaxis="0 1 0"/></body>
    <body name="pushed" pos="2 0 1"><joint name="push" axis="0 1 0" damping="0.1"/>
      <geom type="cylinder" size="0.2 0.05" zaxis="0 1 0"/></body>
  </worldbody>
  <actuator>
    <velocity name="speed" joint="spin" kv="2" gear="2" ctrlrange="-1 1"/>
    <position name="angle" joint="turn" kp="4" kv="0.5" gear="0.5"/>
    <motor name="torque" joint="push" gear="2" forcerange="-0.5 0.5"/>
  </actuator>
</mujoco>""")
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    model = import_mjcf(path)
    model.world.set_sleep(sleeping=False)
    assert [a.name for a in model.actuators] == ["speed", "angle", "torque"]
    # the first clamped to 1 by its ctrlrange; the motor's force to 0.5 by its forcerange, a torque
    # of gear * 0.5 = 1 N m on its wheel (the joint's effort) against its damper
    ctrl = [3.0, 0.8, 0.8]
    d.ctrl[:] = ctrl
    model.set_ctrl(ctrl)
    assert model.ctrl.tolist() == [1.0, 0.8, 0.8]
    assert model.world.joint(2)["effort"] == 1.0
    for _ in range(1000):
        mujoco.mj_step(m, d)
        model.world.step(DT)
    # the wheel's speed tends to ctrl / gear = 0.5 rad/s; the servo to ctrl / gear = 1.6 rad
    print("actuated:", model.qpos(), d.qpos, model.world.joint_velocities, d.qvel)
    np.testing.assert_allclose(model.world.joint_velocities, d.qvel, rtol=0, atol=2e-3)
    np.testing.assert_allclose(model.qpos(), d.qpos, rtol=0, atol=2e-3)
    assert abs(d.qvel[0] - 0.5) < 0.05 and abs(d.qpos[1] - 1.6) < 0.3


def test_excludes_and_the_contact_flag(tmp_path):
    text = """<mujoco>
  <option>{flag}</option>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="a" pos="0 0 1"><freejoint/><geom size="0.1"/>
      <body name="a_tip" pos="0.2 0 0"><geom size="0.05"/></body></body>
    <body name="b" pos="1 0 1"><freejoint/><geom size="0.1"/></body>
    <body name="c" pos="2 0 1"><freejoint/><geom size="0.1"/></body>
  </worldbody>
  <contact><exclude body1="a_tip" body2="b"/><exclude body1="world" body2="c"/></contact>
</mujoco>"""
    model = import_mjcf(write(tmp_path, text.format(flag="")))
    a, b, c = (model.bodies[n][0] for n in "abc")
    floor = model.bodies["world"][0]
    assert model.bodies["a_tip"] == [a]  # welded into a
    assert model.world.disabled_pairs == sorted([(a, b), (floor, c)])
    off = import_mjcf(write(tmp_path, text.format(flag='<flag contact="disable"/>')))
    groups, masks = off.world.collision_filters
    assert not groups.any() and not masks.any()
    # a gravity flag turns gravity off
    still = import_mjcf(write(tmp_path, text.format(flag='<flag gravity="disable"/>'), "still.xml"))
    assert not still.world.gravity.any()


def test_load_mjcf_and_read_mjcf_keep_their_return_types():
    w = sg.load_mjcf(DATA / "double_pendulum.xml")
    assert isinstance(w, sg.World) and w.num_joints == 2
    scene = sg.read_mjcf(DATA / "double_pendulum.xml")
    assert scene.names == ("world", "upper", "lower") and scene.dt == 0.001


@pytest.mark.parametrize("body, message", [
    ('<body><joint axis="0 0 0"/><geom size="0.1"/></body>', r"line 3 <joint>: axis='0 0 0' is zero"),
    ('<body><joint name="j" range="30 10"/><geom size="0.1"/></body>',
     r"line 3 <joint name='j'>: range='30 10': the lower bound is above the upper one"),
    ('<joint name="w"/><body><freejoint/><geom size="0.1"/></body>', r"line 3 <joint name='w'>: a joint on the world body"),
    ('<frame><joint name="w"/></frame>', r"line 3 <joint name='w'>: a joint on the world body"),
    ('<body><joint type="screw"/><geom size="0.1"/></body>', r"line 3 <joint>: unknown joint type 'screw'"),
    ('<body><joint/></body>', r"line 3 <body>: a jointed body needs at least one geom"),
    ('<body><joint name="j" range="0 10" limited="maybe"/><geom size="0.1"/></body>', r"line 3 <joint name='j'>: limited must be true, false or auto"),
    ('<body><joint name="j" damping="-1"/><geom size="0.1"/></body>', r"line 3 <joint name='j'>: damping='-1' must be >= 0"),
])
def test_bad_joints_name_the_line(tmp_path, body, message):
    path = write(tmp_path, f"<mujoco>\n<worldbody>\n{body}\n</worldbody>\n</mujoco>")
    with pytest.raises(sg.MJCFError, match=r"model\.xml'?: " + message):
        import_mjcf(path)


def test_autolimits_false_needs_limited(tmp_path):
    path = write(tmp_path, '<mujoco><compiler autolimits="false"/><worldbody><body><joint range="0 1"/>'
                           '<geom size="0.1"/></body></worldbody></mujoco>')
    with pytest.raises(sg.MJCFError, match=r"range is given without limited"):
        import_mjcf(path)
    limp = write(tmp_path, '<mujoco><compiler autolimits="false"/><worldbody><body><joint range="0 1" '
                           'limited="false"/><geom size="0.1"/></body></worldbody></mujoco>', "limp.xml")
    assert not import_mjcf(limp).world.joint(0)["has_limits"]


@pytest.mark.parametrize("actuator, message", [
    ('<velocity joint="nope"/>', r"line 8 <velocity>: joint 'nope' is not a hinge or slide joint"),
    ('<velocity joint="h" gear="0"/>', r"line 8 <velocity>: gear is 0"),
    ('<position joint="h" ctrlrange="1 0"/>', r"ctrlrange='1 0': the lower bound is above"),
])
def test_bad_actuators_name_the_line(tmp_path, actuator, message):
    path = write(tmp_path, f"""<mujoco>
<worldbody>
<body><joint name="h"/><geom size="0.1"/>
<body pos="0 0 -0.3"><joint name="b" type="ball"/><geom size="0.1"/></body>
</body>
</worldbody>
<actuator>
{actuator}
</actuator>
</mujoco>""")
    with pytest.raises(sg.MJCFError, match=message):
        import_mjcf(path)


def test_what_stays_outside_is_listed_in_one_error(tmp_path):
    path = write(tmp_path, """<mujoco>
<worldbody>
<body name="two"><joint name="h1"/><joint name="h2" axis="1 0 0"/><geom size="0.1"/></body>
<body name="rotor"><joint name="r" armature="0.01"/><geom size="0.1"/>
  <frame pos="0 0 -0.5"><body name="ballbody"><joint name="ball" type="ball" range="0 30"/><geom size="0.1"/></body></frame>
</body>
<body name="wide"><joint name="wide" range="-200 30"/><geom size="0.1"/></body>
<body name="shaft"><joint name="s" damping="1"/><geom size="0.1"/></body>
</worldbody>
<actuator>
<motor joint="r"/>
<general joint="r"/>
<velocity joint="s" forcerange="-1 1"/>
<velocity joint="wide" forcerange="-1 2"/>
<position joint="ball"/>
</actuator>
<contact><pair geom1="a" geom2="b"/></contact>
</mujoco>""")
    with pytest.raises(sg.MJCFError) as e:
        import_mjcf(path)
    listed = [line.strip() for line in str(e.value).split("\n")[1:]]
    assert [line.split(" (")[0] for line in listed] == [
        "line 3 <body name='two'>", "line 4 <joint name='r'>", "line 5 <joint name='ball'>",
        "line 7 <joint name='wide'>", "line 12 <general>", "line 13 <velocity>",
        "line 14 <velocity>", "line 15 <position>", "line 17 <pair>"], str(e.value)
    for needle in ("2 joints on one body", "armature", "whole rotation angle", "outside (-180, 180) degrees",
                   "general actuator", "stiffness or damping", "not symmetric",
                   "ball joint 'ball'", "contact pairs"):
        assert needle in str(e.value), needle
