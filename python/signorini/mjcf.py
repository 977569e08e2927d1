"""MJCF import: the rigid-body subset of MuJoCo's model files, read with the standard library's
``xml.etree`` (MuJoCo itself is not needed).

    w = sg.load_mjcf("model.xml")            # the World
    scene = sg.read_mjcf("model.xml")        # a scenefile.Scene: the World, dt = option timestep, names
    model = sg.import_mjcf("model.xml")      # an MJCFModel: the Scene, bodies, joints, actuators, set_ctrl

What is imported:

- ``<worldbody>`` geoms, and the geoms of bodies without joints under it, become static bodies,
  one per geom: ``plane`` (the geom's z axis is the normal), ``box``, ``sphere``, ``capsule``,
  ``cylinder``, ``ellipsoid`` (equal radii: a sphere; unequal, static only: the convex hull of a
  subdivided icosphere stretched to the radii) and ``mesh`` (a ``TriangleMesh`` of the file);
- a body with a ``<freejoint/>`` (or ``<joint type="free"/>``) directly under ``<worldbody>``
  (or in a ``<frame>`` there) becomes a dynamic body; its geoms and those of its joint-less child bodies (welded to it, as in
  MuJoCo) are one shape, a ``Compound`` when there are several or the geom is not at the body
  origin. The body frame is MuJoCo's body frame (``pos``/``quat``...); its centre of mass goes
  where MuJoCo puts it. Mesh geoms of dynamic bodies are the convex hull of the mesh, as MuJoCo
  collides with them;
- masses: every geom's ``density`` (default 1000 kg/m^3) or ``mass``; the geoms of one body must
  share one density (signorini bodies have uniform density). An ``<inertial>`` element is
  accepted when it agrees (1e-9 relative) with the geoms at that mass, since signorini derives
  inertia from shapes; otherwise it is an error naming the body;
- poses: ``pos`` with one of ``quat``, ``euler`` (``compiler eulerseq``), ``axisangle``,
  ``xyaxes``, ``zaxis``, or ``fromto`` for capsules, cylinders, boxes and ellipsoids; angles in
  degrees unless ``<compiler angle="radian"/>``;
- ``<default>`` classes (nested, with ``class`` and ``childclass``), ``<compiler meshdir/assetdir>``,
  ``<asset><mesh file scale/>`` (OBJ, STL, PLY, OFF, GLB through ``load_mesh``; or ``vertex``);
- ``<option gravity timestep cone>``; friction: the first (sliding) value of a geom's ``friction``
  (a body's geoms must agree). signorini combines two bodies' friction as sqrt(mu_A mu_B) where
  MuJoCo takes the larger one. A geom with ``condim`` 4 or 6 (MuJoCo's torsional friction) gives
  its body ``spinning_friction`` = the second (torsional) value of ``friction`` (a length, m, as in
  MuJoCo), other geoms 0 (MuJoCo's default condim 3 has none); a body's geoms must agree. A pair
  takes the larger value, as MuJoCo does (but a geom of condim 3 paired with one of condim 4
  brings its torsional value into the MuJoCo contact, and 0 here), and signorini applies it only
  at a contact that is its body pair's only point (see docs/conventions.md). As in MuJoCo, a
  ``friction`` with fewer than 3 values keeps the remaining ones of its default class (MuJoCo's
  own default ``1 0.005 0.0001``). The rolling (third) value is not imported. A geom of ``condim``
  1 (frictionless in MuJoCo) gives its body friction 0; MuJoCo takes the larger condim of a pair,
  so such a geom against one of condim 3 has friction there and none here (sqrt(0 mu) = 0).

Joints (docs/conventions.md, "MJCF joints and actuators"):

- a body with one ``hinge``, ``slide`` or ``ball`` joint (directly or in a ``<frame>`` of the
  body; ``pos`` and ``axis`` in the body's frame) is a moving body joined to its parent's body by
  ``sg.Revolute``, ``sg.Prismatic`` or ``sg.Spherical`` (anchor and axis converted to the world
  at the file's pose); its parent is the nearest moving ancestor, or, for a body whose ancestors
  are welded to the world, a static body named "world" (a 1 cm sphere colliding with nothing)
  added after the static geoms. Bodies without joints are welded to their moving ancestor (one
  shape) or to the world (static geoms), as before. ``<frame>`` (pos, orientation, childclass)
  poses what it holds. The joint's two bodies do not collide (MuJoCo's parent-child filter);
- ``ref``: MuJoCo's coordinate at the file's pose, where signorini's is 0: MuJoCo's qpos =
  ``joint_positions`` + ref (``MJCFModel.qpos``); ``range`` (limited by ``limited`` or the
  compiler's ``autolimits``) becomes the limits range - ref; ``stiffness`` (towards
  ``springref``) and ``damping`` are the joint's drive (``sg.Motor`` spring-damper, max force
  inf), ``frictionloss`` its ``friction``;
- actuators ``motor`` on a hinge or slide: the joint's effort (``World.set_joint_effort``), gear
  times the control clamped to ``forcerange``, beside the joint's spring and damper;
- actuators ``position`` (kp, kv) and ``velocity`` (kv) on a hinge or slide, with ``gear``
  (first value), ``ctrlrange`` (controls are clamped to it) and a symmetric ``forcerange``: the
  joint's drive, summed with its spring and damper (``_drive``); controls start at 0 as in MuJoCo
  and ``MJCFModel.set_ctrl`` changes them;
- ``<contact><exclude body1 body2>``: those bodies never collide (``disable_collision``);
  ``<option><flag contact="disable"/>`` makes every body collide with nothing (filter 0, 0) and
  ``gravity="disable"`` sets gravity to 0.

Refused (listed in the one error below): ``armature`` (it adds inertia to the joint coordinate
alone, which no rigid body's mass matrix does), a body with several joints (each signorini joint
joins two bodies; the massless bodies between chained joints are not possible, a body needs a
positive mass), a ball joint's range (a limit on its whole rotation angle), stiffness, damping or frictionloss, a hinge
range that minus ref reaches outside (-180, 180) degrees (signorini's hinge angle wraps there),
actuator types other than motor, position and velocity, actuators on ball joints, an asymmetric ``forcerange``, a ``forcerange`` on a joint
with stiffness or damping (the one drive would bound their sum), two actuators on one joint,
contact ``<pair>``s. Bad input (an error naming the line and element, before any body is added):
a joint on the world body, a zero axis, a range or ctrlrange with lo > hi, an unknown joint type,
a range without ``limited`` when autolimits is false, negative stiffness, damping, frictionloss,
kp or kv, an actuator naming no hinge or slide joint, gear 0, an exclude naming no body.

Ignored, because they do not change the rigid bodies: sites, cameras, lights, sensors,
keyframes, visual, statistic, size, custom, textures and materials, and the contact-tuning
attributes (solref, solimp, margin, gap, priority, contype, conaffinity, rgba, group).
Everything else (tendons, equality constraints, contact pairs, height fields, includes,
replicates, plugins...) is an ``MJCFError`` listing every unsupported element with its line, in
line order, inside ``<frame>``s too, so a model is never imported with a part silently missing.
Errors for a missing or malformed file, an unknown geom type or a bad value name the file, the
line and the element.

Limits: the file is at most ``MAX_MJCF_BYTES`` (64 MiB) and its elements nest at most
``MAX_MJCF_DEPTH`` (64) deep, counted by the expat parser as it reads, before any tree that deep
is built or walked; numbers are finite; ``<option timestep>`` lies in a scene file's dt bounds
(``scenefile.MIN_DT``, ``MAX_DT``: [1e-6, 1] s). Mesh files (``<mesh file>`` under ``meshdir``/``assetdir``)
resolve (symlinks followed) inside the MJCF file's folder or inside a folder passed as
``read_mjcf(path, package_dirs=[...])``; anything else (``meshdir="/"``, ``..``, an absolute path,
a symlink leading out) is refused with the same message whether or not that path exists. Running
out of memory or stack is an ``MJCFError`` too.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
import xml.parsers.expat as expat
from dataclasses import dataclass, field
from pathlib import Path
from typing import Collection, Optional

import numpy as np

from . import filecheck
from ._core import Box, Capsule, Compound, ConvexHull, Cylinder, Plane, Sphere, TriangleMesh
from .codec import matrix_to_quat

__all__ = ["load_mjcf", "read_mjcf", "import_mjcf", "MJCFModel", "MJCFJoint", "MJCFActuator", "MJCFError",
           "MAX_MJCF_BYTES", "MAX_MJCF_DEPTH"]

# limits (module doc): MuJoCo's menagerie models are under 1 MB of XML (meshes apart), 64 MiB is far
# above any hand-written or exported model while bounding the tree built in memory
MAX_MJCF_BYTES = 64 * 2**20
# a humanoid's kinematic tree nests bodies about 15 deep; 64 keeps the reader's recursion shallow
MAX_MJCF_DEPTH = 64
# the static body that bodies jointed to MuJoCo's world hang from (m): it collides with nothing
_ANCHOR_RADIUS = 0.01


class MJCFError(ValueError):
    """An MJCF file that cannot be imported: the message names the file, the line, the element and
    the problem (for unsupported elements, all of them)."""


# the rigid-body subset: what is read, and what is skipped because it does not change the bodies
_TOP_READ = {"compiler", "option", "default", "asset", "worldbody", "actuator", "contact"}
_TOP_IGNORED = {"size", "visual", "statistic", "sensor", "keyframe", "custom"}
_BODY_READ = {"geom", "body", "inertial", "freejoint", "joint"}
_BODY_IGNORED = {"site", "camera", "light"}
_TREE_TAGS = {"body", "geom", "inertial", "frame"}  # inside an unsupported element: listed by it
_ASSET_IGNORED = {"texture", "material"}
_GEOM_ATTRS = {"type", "size", "pos", "quat", "euler", "axisangle", "xyaxes", "zaxis", "fromto", "density", "mass",
               "friction", "condim", "mesh", "name", "class"}
_GEOM_IGNORED = {"rgba", "group", "material", "contype", "conaffinity", "solref", "solimp", "solmix",
                 "margin", "gap", "priority", "user", "fitscale", "shellinertia"}
_BODY_ATTRS = {"name", "pos", "quat", "euler", "axisangle", "xyaxes", "zaxis", "childclass"}
_BODY_IGNORED_ATTRS = {"mocap", "gravcomp", "user"}
_COMPILER_ATTRS = {"angle", "meshdir", "assetdir", "eulerseq", "inertiafromgeom", "autolimits"}
_COMPILER_IGNORED = {"texturedir", "discardvisual", "strippath", "inertiagrouprange", "fitaabb",
                     "usethread", "convexhull", "alignfree", "fusestatic"}
_OPTION_ATTRS = {"gravity", "timestep", "cone"}
_FRAME_ATTRS = {"name", "pos", "quat", "euler", "axisangle", "xyaxes", "zaxis", "childclass"}
# joints and actuators: what maps (module doc, "Joints"); the solver-tuning attributes are skipped
_JOINT_ATTRS = {"name", "class", "type", "pos", "axis", "range", "limited", "ref", "springref", "stiffness",
                "damping", "frictionloss", "armature"}
_JOINT_IGNORED = {"group", "user", "margin", "solreflimit", "solimplimit", "solreffriction", "solimpfriction"}
_ACTUATOR_ATTRS = {"name", "class", "joint", "gear", "ctrlrange", "ctrllimited", "forcerange", "forcelimited", "kv"}
_ACTUATOR_IGNORED = {"group", "user"}
# elements whose <default> values are read (the others are allowed in <default> and unused)
_DEFAULTED = ("geom", "mesh", "joint", "position", "velocity", "motor")
# MuJoCo's geom friction (sliding, torsional m, rolling m) and contact dimensions when not given
_MUJOCO_FRICTION = "1 0.005 0.0001"
_MUJOCO_CONDIM = 3


def _layered_friction(base: str, given: str) -> str:
    """A ``friction`` attribute over the one it inherits: MuJoCo reads up to 3 numbers into the
    inherited triple, so "0.7" over "0.5 0.02 0.001" is "0.7 0.02 0.001". A value that is not a
    list of numbers is kept as it is, for the reader to report."""
    try:
        inherited, own = [float(x) for x in base.split()], [float(x) for x in given.split()]
    except ValueError:
        return given
    if not 1 <= len(own) <= 3 or len(inherited) != 3:
        return given
    return " ".join(given.split() + base.split()[len(own):])


class _TooDeep(Exception):
    """An element nested deeper than MAX_MJCF_DEPTH: (line, tag)."""


def _parse_with_lines(text: bytes) -> tuple[ET.Element, dict]:
    """The element tree of an XML document and each element's line ({id(element): line}), from
    expat (ElementTree itself keeps no line numbers). Raises expat.ExpatError, or _TooDeep at the
    first element nested deeper than MAX_MJCF_DEPTH (before it is built)."""
    builder = ET.TreeBuilder()
    parser = expat.ParserCreate()
    lines: dict[int, int] = {}
    depth = [0]

    def start(tag, attrs):
        depth[0] += 1
        if depth[0] > MAX_MJCF_DEPTH:
            raise _TooDeep(parser.CurrentLineNumber, tag)
        lines[id(builder.start(tag, attrs))] = parser.CurrentLineNumber

    def end(tag):
        depth[0] -= 1
        builder.end(tag)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = builder.data
    parser.Parse(text, True)
    return builder.close(), lines


# rotations: conversions between the file's notations and (w, x, y, z) -----------------------------
def _qmul(a, b) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _qrot(q) -> np.ndarray:
    """Rotation matrix (3, 3) of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _axis_angle(axis, angle: float) -> np.ndarray:
    axis = np.asarray(axis, dtype=np.float64)
    n = np.linalg.norm(axis)
    if n == 0.0:
        raise ValueError("the rotation axis is zero")
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis / n])


def _z_to(v) -> np.ndarray:
    """The shortest rotation taking the z axis onto v (MuJoCo's convention for zaxis and fromto)."""
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(v)
    if n < 1e-14:
        raise ValueError("the direction is zero")
    v = v / n
    axis = np.cross([0.0, 0.0, 1.0], v)
    s = np.linalg.norm(axis)
    if s < 1e-14:
        return np.array([1.0, 0.0, 0.0, 0.0]) if v[2] > 0 else np.array([0.0, 1.0, 0.0, 0.0])
    return _axis_angle(axis / s, math.atan2(s, v[2]))


@dataclass
class _Pose:
    """A frame: position (3,) and unit quaternion (4,) in the parent frame."""
    p: np.ndarray = field(default_factory=lambda: np.zeros(3))
    q: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))

    def then(self, child: "_Pose") -> "_Pose":
        """The child frame composed onto this one (parent-from-child)."""
        return _Pose(self.p + _qrot(self.q) @ child.p, _qmul(self.q, child.q))

    def is_identity(self) -> bool:
        return not np.any(self.p) and self.q[0] == 1.0 and not np.any(self.q[1:])


# the reader --------------------------------------------------------------------------------------
@dataclass
class _Part:
    shape: object
    pose: _Pose              # in the dynamic body's frame (static: the world)
    density: Optional[float]  # kg/m^3, or None when the geom gives a mass
    mass: Optional[float]
    friction: float
    spinning_friction: float  # m, MuJoCo's torsional friction where condim >= 4, else 0
    element: ET.Element
    body: Optional[str] = None  # the MuJoCo body it belongs to ("world" for the world's own), if named


class _Reader:
    def __init__(self, path: Path, package_dirs=()):
        self.path = path
        self.package_dirs = [Path(d) for d in package_dirs]
        self.unsupported: list[tuple[float, str]] = []  # (line, what), listed in line order
        text = filecheck.read_limited(path, MAX_MJCF_BYTES, "MJCF file", MJCFError)
        try:
            self.root, self.lines = _parse_with_lines(text)
        except expat.ExpatError as e:
            raise MJCFError(f"MJCF file {str(path)!r}: malformed XML: {e}") from None
        except _TooDeep as e:
            line, tag = e.args
            raise MJCFError(f"MJCF file {str(path)!r}: line {line} <{tag}>: elements nested deeper than "
                            f"{MAX_MJCF_DEPTH} levels (limit)") from None
        if self.root.tag != "mujoco":
            raise MJCFError(f"MJCF file {str(path)!r}: the root element is <{self.root.tag}>, not <mujoco>")
        self.angle_scale = math.pi / 180.0
        self.eulerseq = "xyz"
        self.meshdir = path.parent
        self.inertia_from_geom = "auto"
        self.autolimits = True  # MuJoCo 3's default: a range given makes a joint limited
        self.contacts_off = False  # <option><flag contact="disable"/>
        self.defaults: dict[str, dict[str, dict[str, str]]] = {"main": {}}
        self.meshes: dict[str, ET.Element] = {}

    # errors ------------------------------------------------------------------------------------
    def where(self, el: ET.Element) -> str:
        name = el.get("name")
        return f"line {self.lines.get(id(el), '?')} <{el.tag}{' name=' + repr(name) if name else ''}>"

    def error(self, el: ET.Element, problem: str) -> MJCFError:
        return MJCFError(f"MJCF file {str(self.path)!r}: {self.where(el)}: {problem}")

    def skip(self, el: ET.Element, why: str = "") -> None:
        self.unsupported.append((self.lines.get(id(el), math.inf),
                                 f"{self.where(el)}{' (' + why + ')' if why else ''}"))

    def skip_tree(self, el: ET.Element) -> None:
        """An unsupported element of the body tree (a ``<frame>``, ``<replicate>``...) and,
        inside it, every element that is unsupported anywhere (joints above all), so the error
        lists each joint a model has wherever it sits."""
        self.skip(el, "with everything inside it" if len(el) else "")
        for inner in el.iter():
            if inner is el:
                continue
            if inner.tag in ("joint", "freejoint"):
                self.skip(inner, "free joint" if inner.tag == "freejoint" else f"{inner.get('type', 'hinge')} joint")
            elif inner.tag not in _TREE_TAGS and inner.tag not in _BODY_IGNORED:
                self.skip(inner)

    def unsupported_list(self) -> list[str]:
        """The unsupported elements in file (line) order, each once."""
        listed: list[str] = []
        for _, what in sorted(self.unsupported, key=lambda item: item[0]):
            if what not in listed:
                listed.append(what)
        return listed

    def check_attrs(self, el: ET.Element, known: Collection[str], ignored: Collection[str] = frozenset()) -> None:
        extra = sorted(set(el.attrib) - set(known) - set(ignored))
        if extra:
            self.skip(el, f"attribute{'s' if len(extra) > 1 else ''} {', '.join(extra)}")

    # values ------------------------------------------------------------------------------------
    def numbers(self, el: ET.Element, attrs: dict, key: str, count=None) -> Optional[np.ndarray]:
        text = attrs.get(key)
        if text is None:
            return None
        try:
            values = np.array([float(x) for x in text.split()], dtype=np.float64)
        except ValueError:
            raise self.error(el, f"{key}={text!r} is not a list of numbers") from None
        if count is not None and len(values) not in ((count,) if isinstance(count, int) else count):
            raise self.error(el, f"{key}={text!r} must have {count} numbers")
        if not np.all(np.isfinite(values)):
            raise self.error(el, f"{key}={text!r} must be finite")
        return values

    def given(self, el: ET.Element, attrs: dict, key: str, count=None) -> np.ndarray:
        """``numbers`` of an attribute the caller knows is there."""
        values = self.numbers(el, attrs, key, count)
        if values is None:
            raise self.error(el, f"{key} is missing")
        return values

    def pose(self, el: ET.Element, attrs: dict) -> _Pose:
        """pos and the one orientation attribute given (quat, euler, axisangle, xyaxes, zaxis)."""
        p = self.numbers(el, attrs, "pos", 3)
        given = [k for k in ("quat", "euler", "axisangle", "xyaxes", "zaxis") if k in attrs]
        if len(given) > 1:
            raise self.error(el, f"more than one orientation: {', '.join(given)}")
        q = np.array([1.0, 0.0, 0.0, 0.0])
        try:
            if given == ["quat"]:
                q = self.given(el, attrs, "quat", 4)
                if not np.any(q):
                    raise ValueError("quat is zero")
                q = q / np.linalg.norm(q)
            elif given == ["axisangle"]:
                a = self.given(el, attrs, "axisangle", 4)
                q = _axis_angle(a[:3], a[3] * self.angle_scale)
            elif given == ["euler"]:
                e = self.given(el, attrs, "euler", 3) * self.angle_scale
                for axis, angle in zip(self.eulerseq, e):
                    qi = _axis_angle(np.eye(3)["xyz".index(axis.lower())], angle)
                    # lower case: axes that turn with the frame (post-multiply); upper case: fixed axes
                    q = _qmul(q, qi) if axis.islower() else _qmul(qi, q)
            elif given == ["zaxis"]:
                q = _z_to(self.given(el, attrs, "zaxis", 3))
            elif given == ["xyaxes"]:
                xy = self.given(el, attrs, "xyaxes", 6)
                x = xy[:3] / np.linalg.norm(xy[:3])
                y = xy[3:] - (xy[3:] @ x) * x
                y = y / np.linalg.norm(y)
                q = matrix_to_quat(np.column_stack([x, y, np.cross(x, y)]))
        except (ValueError, ZeroDivisionError) as e:
            raise self.error(el, str(e)) from None
        return _Pose(np.zeros(3) if p is None else p, q)

    def attrs(self, el: ET.Element, cls: str) -> dict:
        """The element's attributes over its class's defaults (an explicit class= wins)."""
        name = el.get("class", cls)
        if name not in self.defaults:
            raise self.error(el, f"unknown default class {name!r} (known: {', '.join(sorted(self.defaults))})")
        inherited = self.defaults[name].get(el.tag, {})
        out = {**inherited, **el.attrib}
        if el.tag == "geom" and "friction" in el.attrib:
            out["friction"] = _layered_friction(inherited.get("friction", _MUJOCO_FRICTION), el.attrib["friction"])
        return out

    # sections ----------------------------------------------------------------------------------
    def read(self):
        for el in self.root:
            if el.tag in _TOP_IGNORED:
                continue
            if el.tag not in _TOP_READ:
                self.skip(el)
        for el in self.root.iter("compiler"):
            self.check_attrs(el, _COMPILER_ATTRS, _COMPILER_IGNORED)
            angle = el.get("angle", "degree")
            if angle not in ("degree", "radian"):
                raise self.error(el, f"angle must be 'degree' or 'radian', got {angle!r}")
            self.angle_scale = 1.0 if angle == "radian" else math.pi / 180.0
            seq = el.get("eulerseq", self.eulerseq)
            if len(seq) != 3 or any(c not in "xyzXYZ" for c in seq):
                raise self.error(el, f"eulerseq must be three of x, y, z, X, Y, Z, got {seq!r}")
            self.eulerseq = seq
            for key in ("assetdir", "meshdir"):
                if key in el.attrib:
                    self.meshdir = self.path.parent / el.get(key)
            self.inertia_from_geom = el.get("inertiafromgeom", self.inertia_from_geom)
            autolimits = el.get("autolimits", "true" if self.autolimits else "false")
            if autolimits not in ("true", "false"):
                raise self.error(el, f"autolimits must be true or false, got {autolimits!r}")
            self.autolimits = autolimits == "true"
            if self.inertia_from_geom not in ("auto", "true", "false"):
                raise self.error(el, f"inertiafromgeom must be auto, true or false, got {self.inertia_from_geom!r}")
        settings = {}
        dt = None
        self.gravity_off = False
        for el in self.root.iter("option"):
            self.check_attrs(el, _OPTION_ATTRS, {"integrator", "iterations", "tolerance", "solver", "jacobian",
                                                 "ls_iterations", "noslip_iterations", "impratio", "o_margin"})
            for child in el:
                if child.tag != "flag":
                    self.skip(child)
                    continue
                # flags that change the bodies' motion; the others tune MuJoCo's solver
                for key in ("contact", "gravity"):
                    value = child.get(key, "enable")
                    if value not in ("enable", "disable"):
                        raise self.error(child, f"{key} must be enable or disable, got {value!r}")
                if child.get("contact") == "disable":
                    self.contacts_off = True
                if child.get("gravity") == "disable":
                    self.gravity_off = True
            g = self.numbers(el, el.attrib, "gravity", 3)
            if g is not None:
                settings["gravity"] = g
            if "timestep" in el.attrib:
                dt = float(self.given(el, el.attrib, "timestep", 1)[0])
                from .scenefile import MAX_DT, MIN_DT  # a scene file's bounds (pydantic loads only here)

                if not MIN_DT <= dt <= MAX_DT:
                    raise self.error(el, f"timestep={dt!r} must lie in [{MIN_DT:g}, {MAX_DT:g}] s")
            cone = el.get("cone")
            if cone is not None:
                if cone not in ("pyramidal", "elliptic"):
                    raise self.error(el, f"cone must be pyramidal or elliptic, got {cone!r}")
                settings["friction_cone"] = "pyramid" if cone == "pyramidal" else "cone"
        if self.gravity_off:
            settings["gravity"] = np.zeros(3)
        for top in self.root.findall("default"):
            self.read_defaults(top, {}, top=True)
        for asset in self.root.findall("asset"):
            for el in asset:
                if el.tag == "mesh":
                    self.check_attrs(el, {"name", "file", "scale", "vertex", "class"}, {"inertia", "maxhullvert",
                                                                                      "smoothnormal"})
                    name = el.get("name") or (Path(el.get("file", "")).stem if el.get("file") else None)
                    if not name:
                        raise self.error(el, "a mesh needs a name or a file")
                    self.meshes[name] = el
                elif el.tag not in _ASSET_IGNORED:
                    self.skip(el)
        return settings, dt

    def read_defaults(self, el: ET.Element, inherited: dict, top: bool = False) -> None:
        name = el.get("class", "main" if top else None)
        if name is None:
            raise self.error(el, "a nested default needs a class")
        own = {tag: dict(values) for tag, values in inherited.items()}
        for child in el:
            if child.tag == "default":
                continue
            if child.tag in _DEFAULTED:
                values = own.setdefault(child.tag, {})
                friction = values.get("friction", _MUJOCO_FRICTION)
                values.update(child.attrib)
                if child.tag == "geom" and "friction" in child.attrib:
                    values["friction"] = _layered_friction(friction, child.attrib["friction"])
            elif child.tag not in _BODY_IGNORED and child.tag not in ("joint", "site", "camera", "light", "motor",
                                                                       "position", "velocity", "general",
                                                                       "tendon", "equality", "pair", "material"):
                self.skip(child)
        self.defaults[name] = own
        for child in el.findall("default"):
            self.read_defaults(child, own)

    # bodies -------------------------------------------------------------------------------------
    def geom_shape(self, el: ET.Element, attrs: dict, dynamic: bool):
        """(shape, pose in the parent frame) of a geom."""
        kind = attrs.get("type", "sphere")
        size = self.numbers(el, attrs, "size")
        size = np.zeros(0) if size is None else size
        fromto = self.numbers(el, attrs, "fromto", 6)
        pose = self.pose(el, attrs)
        if fromto is not None:
            if kind not in ("capsule", "cylinder", "box", "ellipsoid"):
                raise self.error(el, f"fromto is for capsules, cylinders, boxes and ellipsoids, not {kind}")
            a, b = fromto[:3], fromto[3:]
            try:
                pose = _Pose(0.5 * (a + b), _z_to(b - a))
            except ValueError:
                raise self.error(el, "fromto's two points are the same") from None
            half = 0.5 * float(np.linalg.norm(b - a))
            if len(size) < 1:
                raise self.error(el, f"a {kind} with fromto needs its radius as size")
            # MuJoCo: the sizes across the segment both equal the first size value
            r = float(size[0])
            size = np.array([r, half]) if kind in ("capsule", "cylinder") else np.array([r, r, half])

        def need(n: int):
            if len(size) < n:
                raise self.error(el, f"a {kind} needs {n} size value{'s' if n > 1 else ''}, got {len(size)}")

        try:
            if kind == "plane":
                if dynamic:
                    raise self.error(el, "a plane can only belong to the world (a static geom)")
                return "plane", pose  # placed by the caller, which knows the world frame
            if kind == "sphere":
                need(1)
                return Sphere(float(size[0])), pose
            if kind == "capsule":
                need(2)
                return Capsule(float(size[0]), float(size[1])), pose
            if kind == "cylinder":
                need(2)
                return Cylinder(float(size[0]), float(size[1])), pose
            if kind == "box":
                need(3)
                return Box(size[:3]), pose
            if kind == "ellipsoid":
                need(3)
                if size[0] == size[1] == size[2]:
                    return Sphere(float(size[0])), pose
                if dynamic:
                    raise self.error(el, "an ellipsoid with unequal radii can only be static (signorini has no "
                                         "ellipsoid shape; a static one becomes a 642-vertex convex hull)")
                from .meshes import icosphere

                v, _ = icosphere(1.0, 3)
                return ConvexHull(v * size[:3]), pose
            if kind == "mesh":
                return self.mesh_shape(el, attrs, dynamic), pose
        except (TypeError, ValueError) as e:
            if isinstance(e, MJCFError):
                raise
            raise self.error(el, str(e)) from None
        known = "plane, sphere, capsule, cylinder, box, ellipsoid, mesh"
        raise self.error(el, f"unknown or unsupported geom type {kind!r} (supported: {known})")

    def mesh_shape(self, el: ET.Element, attrs: dict, dynamic: bool):
        name = attrs.get("mesh")
        if name is None or name not in self.meshes:
            raise self.error(el, f"mesh {name!r} is not an <asset> mesh (known: {', '.join(sorted(self.meshes)) or 'none'})")
        mesh_el = self.meshes[name]
        mattrs = self.attrs(mesh_el, "main")
        scale = self.numbers(mesh_el, mattrs, "scale", (1, 3))
        scale = np.ones(3) if scale is None else (np.repeat(scale, 3) if len(scale) == 1 else scale)
        if "file" in mattrs:
            from .meshfile import read_mesh_arrays

            try:
                file = filecheck.inside(mattrs["file"], self.meshdir, [self.path.parent, *self.package_dirs],
                                        "mesh file")
                vertices, faces, _ = read_mesh_arrays(file)
            except (FileNotFoundError, ValueError) as e:
                raise self.error(mesh_el, str(e)) from None
            vertices = vertices * scale
        elif "vertex" in mattrs:
            vertices = self.given(mesh_el, mattrs, "vertex").reshape(-1, 3) * scale
            faces = None
        else:
            raise self.error(mesh_el, "a mesh needs a file or vertex")
        # MuJoCo collides with a mesh's convex hull; a static one keeps its triangles (terrain)
        if dynamic or faces is None:
            return ConvexHull(vertices)
        return TriangleMesh(vertices, faces)

    def geom_condim(self, el: ET.Element, attrs: dict) -> int:
        """A geom's contact dimensions: 1 (frictionless), 3 (sliding), 4 (+ torsional), 6 (+ rolling)."""
        condim = attrs.get("condim", str(_MUJOCO_CONDIM))
        if condim.strip() not in ("1", "3", "4", "6"):
            raise self.error(el, f"condim={condim!r} must be 1, 3, 4 or 6")
        return int(condim)

    def geom_spinning_friction(self, el: ET.Element, attrs: dict) -> float:
        """A geom's spinning friction (m): the torsional value of its friction when its condim is 4
        or 6 (MuJoCo's torsional friction), else 0."""
        if self.geom_condim(el, attrs) < 4:
            return 0.0
        # attrs' friction is layered over its classes' and MuJoCo's (``attrs``): all three values
        friction = self.numbers(el, {"friction": attrs.get("friction", _MUJOCO_FRICTION)}, "friction", (1, 2, 3))
        return float(friction[1]) if len(friction) > 1 else float(_MUJOCO_FRICTION.split()[1])

    def geom_mass(self, el: ET.Element, attrs: dict):
        """(density or None, mass or None, sliding friction) of a geom; the friction is 0 where
        the geom's condim is 1 (frictionless)."""
        mass = self.numbers(el, attrs, "mass", 1)
        density = self.numbers(el, attrs, "density", 1)
        friction = self.numbers(el, attrs, "friction", (1, 2, 3))
        mu = 1.0 if friction is None else float(friction[0])
        if self.geom_condim(el, attrs) == 1:
            mu = 0.0
        if mass is not None:
            return None, float(mass[0]), mu
        return (1000.0 if density is None else float(density[0])), None, mu

    def geom_part(self, el: ET.Element, cls: str, frame: _Pose, dynamic: bool, body: Optional[str]) -> _Part:
        """A geom as a part posed in ``frame``'s parent (the moving body's frame, or the world)."""
        attrs = self.attrs(el, cls)
        self.check_attrs(el, _GEOM_ATTRS, _GEOM_IGNORED)
        shape, pose = self.geom_shape(el, attrs, dynamic)
        density, mass, mu = self.geom_mass(el, attrs)
        spin = self.geom_spinning_friction(el, attrs)
        pose = frame.then(pose)
        if isinstance(shape, str):
            # a plane: the geom's z axis is the normal, through the geom's origin
            n = _qrot(pose.q)[:, 2]
            shape, pose = Plane(n, float(n @ pose.p)), _Pose()
        return _Part(shape, pose, density, mass, mu, spin, el, body)

    def body_joints(self, el: ET.Element, cls: str, frame: _Pose) -> list:
        """The joints of a body (or of <worldbody>): its <joint> and <freejoint> children and those
        of the <frame>s in it, as (element, default class, the pose of the joint's parent element in
        the body's frame)."""
        out = []
        for child in el:
            if child.tag in ("joint", "freejoint"):
                out.append((child, cls, frame))
            elif child.tag == "frame":
                out += self.body_joints(child, self.class_of(child, cls), frame.then(self.pose(child, child.attrib)))
        return out

    def class_of(self, el: ET.Element, cls: str) -> str:
        """The default class an element's children use (its childclass, else the inherited one)."""
        inner = el.get("childclass", cls)
        if inner not in self.defaults:
            raise self.error(el, f"unknown default class {inner!r} (known: {', '.join(sorted(self.defaults))})")
        return inner

    def walk(self, el: ET.Element, frame: _Pose, cls: str, owner: Optional[int], top: bool, body: Optional[str],
             static_parts: list, links: list) -> None:
        """Reads the children of ``el`` (<worldbody>, <body> or <frame>), whose frame is ``frame`` in
        its owner's: the moving body ``links[owner]`` or, for None, the world (static geoms).
        ``top``: ``el`` is <worldbody> or a frame in it (where free bodies may be); ``body``: the
        MuJoCo body ``el`` belongs to. A body without joints is welded to its owner; a body with
        joints is a new moving body (a _Link) whose parent is the owner."""
        parts = static_parts if owner is None else links[owner].parts
        owner_pose = _Pose() if owner is None else links[owner].pose
        for child in el:
            tag = child.tag
            if tag in _BODY_IGNORED or tag in ("joint", "freejoint"):
                continue  # joints: read with their body (body_joints)
            if tag == "inertial":
                if el.tag != "body":
                    self.skip(child, "an inertial outside a body")
                elif owner is not None and links[owner].element is not el:
                    self.skip(child, "an inertial on a welded child body")
            elif tag == "geom":
                parts.append(self.geom_part(child, cls, frame, owner is not None, body))
            elif tag == "frame":
                self.check_attrs(child, _FRAME_ATTRS)
                self.walk(child, frame.then(self.pose(child, child.attrib)), self.class_of(child, cls), owner, top,
                          body, static_parts, links)
            elif tag == "body":
                self.check_attrs(child, _BODY_ATTRS, _BODY_IGNORED_ATTRS)
                attrs = self.attrs(child, cls)
                inner = self.class_of(child, cls)
                here = frame.then(self.pose(child, attrs))
                name = child.get("name")
                joints = self.body_joints(child, inner, _Pose())
                if not joints:
                    if owner is not None and name:
                        links[owner].welded.append(name)
                    self.walk(child, here, inner, owner, False, name, static_parts, links)
                    continue
                kinds = ["free" if j.tag == "freejoint" else self.attrs(j, c).get("type", "hinge") for j, c, _ in joints]
                if "free" in kinds and (len(kinds) > 1 or not top):
                    for (j, _, _), kind in zip(joints, kinds):
                        if kind == "free":
                            self.skip(j, "a free joint with other joints, or on a body not directly under <worldbody>")
                elif len(joints) > 1:
                    self.skip(child, f"{len(joints)} joints on one body ({', '.join(kinds)}): a signorini joint joins "
                                     "two bodies, and the massless bodies between chained joints are not possible "
                                     "(every moving body needs a positive mass)")
                links.append(_Link(child, name, owner_pose.then(here), inner, owner, joints))
                self.walk(child, _Pose(), inner, len(links) - 1, False, name, static_parts, links)
            else:
                self.skip_tree(child)

    # joints and actuators -----------------------------------------------------------------------
    def limited(self, el: ET.Element, attrs: dict, flag: str, key: str, scale: float = 1.0):
        """A range attribute (``range``, ``ctrlrange``, ``forcerange``) as (lo, hi) when it is
        limited (``limited``/``ctrllimited``/``forcelimited``, "auto" by the compiler's
        autolimits), else None; lo > hi is an error."""
        value = attrs.get(flag, "auto")
        if value not in ("true", "false", "auto"):
            raise self.error(el, f"{flag} must be true, false or auto, got {value!r}")
        given = self.numbers(el, attrs, key, 2)
        if value == "auto" and given is not None and not self.autolimits:
            raise self.error(el, f"{key} is given without {flag} while the compiler's autolimits is false "
                                 f"(set {flag} or autolimits)")
        if value == "false" or (value == "auto" and given is None):
            return None
        lo, hi = (0.0, 0.0) if given is None else (float(given[0]) * scale, float(given[1]) * scale)
        if lo > hi:
            raise self.error(el, f"{key}={attrs[key]!r}: the lower bound is above the upper one")
        return lo, hi

    def nonnegative(self, el: ET.Element, attrs: dict, key: str, default: float = 0.0) -> float:
        value = self.numbers(el, attrs, key, 1)
        if value is None:
            return default
        if value[0] < 0.0:
            raise self.error(el, f"{key}={attrs[key]!r} must be >= 0")
        return float(value[0])

    def joint_plan(self, link: "_Link") -> Optional["_JointPlan"]:
        """The checked joint of a moving body (None for a free body or one already listed as
        unsupported): anchor and axis in the world, limits and spring in signorini's coordinate."""
        if len(link.joints) != 1:
            return None
        el, cls, frame = link.joints[0]
        if el.tag == "freejoint":
            self.check_attrs(el, {"name"}, {"group", "align"})
            return None
        attrs = self.attrs(el, cls)
        kind = attrs.get("type", "hinge")
        if kind == "free":
            return None
        if kind not in ("hinge", "slide", "ball"):
            raise self.error(el, f"unknown joint type {kind!r} (MJCF: free, ball, slide, hinge)")
        extra = sorted(set(attrs) - _JOINT_ATTRS - _JOINT_IGNORED)
        if extra:
            self.skip(el, f"attribute{'s' if len(extra) > 1 else ''} {', '.join(extra)}")
        R = _qrot(link.pose.q)
        local = frame.then(_Pose(self.numbers(el, attrs, "pos", 3) if "pos" in attrs else np.zeros(3)))
        anchor = link.pose.p + R @ local.p
        axis = self.numbers(el, attrs, "axis", 3)
        axis = np.array([0.0, 0.0, 1.0]) if axis is None else axis
        n = float(np.linalg.norm(axis))
        if kind != "ball" and not n > 1e-14:
            raise self.error(el, f"axis={attrs.get('axis')!r} is zero")
        axis = R @ _qrot(frame.q) @ (axis / n if n > 0 else axis)
        scale = self.angle_scale if kind == "hinge" else 1.0
        ref = self.numbers(el, attrs, "ref", 1)
        ref = 0.0 if ref is None or kind == "ball" else float(ref[0]) * scale
        springref = self.numbers(el, attrs, "springref", 1)
        springref = 0.0 if springref is None or kind == "ball" else float(springref[0]) * scale
        values = {key: self.nonnegative(el, attrs, key) for key in ("stiffness", "damping", "frictionloss", "armature")}
        rng = self.limited(el, attrs, "limited", "range", self.angle_scale if kind in ("hinge", "ball") else 1.0)
        if values["armature"]:
            self.skip(el, "armature: a rotor inertia added to the joint's coordinate alone, which no rigid body's "
                          "mass matrix has")
        if kind == "ball":
            for key in ("stiffness", "damping", "frictionloss"):
                if values[key]:
                    self.skip(el, f"{key} of a ball joint (signorini's ball joint has no drive or friction)")
            if rng is not None:
                self.skip(el, "range of a ball joint (MuJoCo limits the whole rotation angle, twist included; "
                              "signorini's ball joint limits the swing of one axis and the twist about it, "
                              "Spherical(cone=..., twist=...))")
            rng = None
        limits = None
        if rng is not None:
            limits = (rng[0] - ref, rng[1] - ref)
            if kind == "hinge" and not (-math.pi < limits[0] and limits[1] < math.pi):
                unit = "degrees" if self.angle_scale != 1.0 else "rad"
                self.skip(el, f"range {attrs['range']} {unit} minus ref reaches outside (-180, 180) degrees, where "
                              "signorini's hinge angle wraps")
        name = el.get("name")
        return _JointPlan(el, kind, name, anchor, axis, ref, springref, rng, limits, **values)

    def read_actuators(self, plans: dict) -> list:
        """The motor, position and velocity actuators on hinge and slide joints (``plans``: joint name ->
        _JointPlan), checked; every other actuator is listed as unsupported."""
        out: list[MJCFActuator] = []
        driven: dict = {}
        for top in self.root.findall("actuator"):
            self.check_attrs(top, set())
            for el in top:
                if el.tag not in ("position", "velocity", "motor"):
                    self.skip(el, f"{el.tag} actuator (motor, position and velocity actuators are imported)")
                    continue
                attrs = self.attrs(el, "main")
                known = _ACTUATOR_ATTRS | ({"kp"} if el.tag == "position" else set())
                extra = sorted(set(attrs) - known - _ACTUATOR_IGNORED)
                if extra:
                    self.skip(el, f"attribute{'s' if len(extra) > 1 else ''} {', '.join(extra)}")
                    continue
                joint = attrs.get("joint")
                if joint is None:
                    raise self.error(el, "an actuator needs a joint")
                plan = plans.get(joint)
                if plan is None:
                    raise self.error(el, f"joint {joint!r} is not a hinge or slide joint of the model "
                                         f"(known: {', '.join(sorted(plans)) or 'none'})")
                if plan.kind == "ball":
                    self.skip(el, f"an actuator on ball joint {joint!r}")
                    continue
                gear = self.numbers(el, attrs, "gear", (1, 2, 3, 4, 5, 6))
                gear = 1.0 if gear is None else float(gear[0])
                if gear == 0.0:
                    raise self.error(el, "gear is 0: the actuator does nothing")
                ctrl = self.limited(el, attrs, "ctrllimited", "ctrlrange")
                force = self.limited(el, attrs, "forcelimited", "forcerange")
                kp = self.nonnegative(el, attrs, "kp", 1.0) if el.tag == "position" else 0.0
                kv = self.nonnegative(el, attrs, "kv", 1.0 if el.tag == "velocity" else 0.0)
                if el.tag == "motor":
                    pass  # its force is the joint's effort, clamped to forcerange, beside any drive
                elif force is not None and force[0] != -force[1]:
                    self.skip(el, f"forcerange {attrs['forcerange']} is not symmetric about 0 (a joint drive's "
                                  "force bound is)")
                elif force is not None and (plan.stiffness or plan.damping):
                    self.skip(el, f"forcerange with joint {joint!r}'s stiffness or damping (signorini's one drive "
                                  "per joint would bound their sum)")
                if joint in driven:
                    self.skip(el, f"a second actuator on joint {joint!r} (the first is at line {driven[joint]})")
                driven[joint] = self.lines.get(id(el), "?")
                out.append(MJCFActuator(el.get("name"), el.tag, joint, gear, kp, kv, ctrl, force))
        return out

    def read_excludes(self, known: Collection[str]) -> list:
        """<contact><exclude body1 body2/> pairs of body names; other contact elements are listed
        as unsupported."""
        out = []
        for top in self.root.findall("contact"):
            self.check_attrs(top, set())
            for el in top:
                if el.tag != "exclude":
                    self.skip(el, "contact pairs are not imported (<exclude> is)" if el.tag == "pair" else "")
                    continue
                self.check_attrs(el, {"name", "body1", "body2"})
                pair = (el.get("body1"), el.get("body2"))
                for b in pair:
                    if b is None:
                        raise self.error(el, "an exclude needs body1 and body2")
                    if b not in known:
                        raise self.error(el, f"body {b!r} is not a body of the model")
                out.append((el, *pair))
        return out


@dataclass
class _Link:
    """A moving body of the tree: its <body> and name (None if unnamed), its frame (world, MuJoCo's
    body frame), default class, its joints [(element, class, pose of the joint's parent element in
    the body's frame)], its parent (an index in the links; None: the world), the named bodies
    welded to it, and its parts (its own frame)."""
    element: ET.Element
    name: Optional[str]
    pose: _Pose
    cls: str
    parent: Optional[int]
    joints: list
    welded: list = field(default_factory=list)
    parts: list = field(default_factory=list)


@dataclass
class _JointPlan:
    """A checked hinge, slide or ball joint: anchor and unit axis (3,) world at the file's pose;
    ref and springref, range (lo, hi) in MuJoCo's coordinate (rad, m); limits in signorini's
    (range - ref) or None."""
    element: ET.Element
    kind: str
    name: Optional[str]
    anchor: np.ndarray
    axis: np.ndarray
    ref: float
    springref: float
    range: Optional[tuple]
    limits: Optional[tuple]
    stiffness: float
    damping: float
    frictionloss: float
    armature: float


@dataclass(frozen=True)
class MJCFJoint:
    """A hinge, slide or ball joint as imported. ``index``: its World joint; ``body`` and
    ``parent``: the child's and the parent's body indices (a body jointed to MuJoCo's world hangs
    from the static body named "world"). MuJoCo's units and coordinate (rad, m): ``ref`` is the
    coordinate at the file's pose, where signorini's is 0, so MuJoCo's qpos is
    ``World.joint_positions[index] + ref``; ``lower``/``upper`` the range (NaN: not limited; the
    World's limits are these minus ref); ``stiffness`` (N m/rad, N/m) pulling towards
    ``springref``, ``damping`` (N m s/rad, N s/m), ``frictionloss`` (N m, N)."""
    name: str
    type: str
    index: int
    body: int
    parent: int
    ref: float
    lower: float
    upper: float
    stiffness: float
    springref: float
    damping: float
    frictionloss: float


@dataclass(frozen=True)
class MJCFActuator:
    """A ``motor``, ``position`` or ``velocity`` actuator (``type``) on the hinge or slide ``joint`` (its
    MJCFJoint's name): the first ``gear`` value, ``kp``, ``kv``, ``ctrlrange`` and ``forcerange``
    as (lo, hi), or None when not limited."""
    name: Optional[str]
    type: str
    joint: str
    gear: float
    kp: float
    kv: float
    ctrlrange: Optional[tuple]
    forcerange: Optional[tuple]


def _drive(joint: MJCFJoint, actuator: Optional[MJCFActuator], u: float):
    """The ``Motor`` that gives a joint MuJoCo's passive spring and damper plus its actuator's force
    at control ``u``, or None when there is none. MuJoCo's generalised force on the joint (q its
    coordinate, g the gear) is -k (q - springref) - c q_dot plus g clamp(F) with F = kp (u - g q) -
    kv g q_dot (position) or kv (u - g q_dot) (velocity): a sum of linear springs and dampers, one
    spring-damper with stiffness K = k + kp g^2, damping C = c + kv g^2 and targets (k springref +
    kp g u) / K, (kv g u) / C (velocity) or 0. The clamp bounds the sum (a forcerange with k or c
    is refused at import), hence max_force = |g| forcerange."""
    from .joints import Motor

    g = actuator.gear if actuator is not None else 0.0
    kp = actuator.kp if actuator is not None and actuator.type == "position" else 0.0
    kv = actuator.kv if actuator is not None else 0.0
    K = joint.stiffness + kp * g * g
    C = joint.damping + kv * g * g
    if K == 0.0 and C == 0.0:
        return None
    position = (joint.stiffness * joint.springref + kp * g * u) / K - joint.ref if K > 0.0 else 0.0
    speed = kv * g * u / C if actuator is not None and actuator.type == "velocity" and C > 0.0 else 0.0
    limit = (math.inf if actuator is None or actuator.type == "motor" or actuator.forcerange is None
             else abs(g) * actuator.forcerange[1])
    return Motor(speed, limit, position=position, stiffness=K, damping=C)


@dataclass
class MJCFModel:
    """An imported MJCF model (``import_mjcf``).

    - ``scene``: what ``read_mjcf`` gives (``scene.world``, ``scene.dt``, body names);
    - ``bodies``: MuJoCo body name -> list of body indices: a moving body's own (the bodies welded
      to it share it), a body welded to the world its static geoms', "world" every static body;
    - ``joints``: joint name -> ``MJCFJoint``, in file order (an unnamed one: "joint_<k>", k its
      World index);
    - ``actuators``: the ``MJCFActuator``s in MuJoCo's order (that of ``ctrl``);
    - ``ctrl``: (nu,) the controls in force, 0 at import as in MuJoCo's ``mjData``.
    """
    scene: object
    bodies: dict
    joints: dict
    actuators: list
    ctrl: np.ndarray

    @property
    def world(self):
        return self.scene.world

    def qpos(self) -> np.ndarray:
        """(n,) MuJoCo's coordinates of the hinge and slide joints, in file order: the World's
        ``joint_positions`` + ref (rad, m; a hinge's angle wraps within pi of ref)."""
        positions = self.world.joint_positions
        return np.array([positions[j.index] + j.ref for j in self.joints.values() if j.type != "ball"])

    def mass_matrix(self) -> np.ndarray:
        """(n, n) the joint-space mass matrix at the World's current poses, in ``qpos``'s order (kg,
        kg m, kg m^2), as MuJoCo's ``mj_fullM`` gives it for the same file: M = sum_b J_b^T diag(m_b E,
        I_b) J_b over the moving bodies b, J_b (6, n) mapping the joint rates to b's centre-of-mass
        velocity and angular velocity (world), column k nonzero for joint k on b's path to the
        world: a_k x (c_b - y_k) and a_k for a hinge about a_k through y_k, a_k and 0 for a slide.
        A model with a ball joint (three coordinates in MuJoCo's) is refused with ValueError."""
        joints = list(self.joints.values())
        balls = [name for name, j in self.joints.items() if j.type not in ("hinge", "slide")]
        if balls:
            raise ValueError(f"mass_matrix: hinge and slide joints only; {', '.join(balls)} "
                             f"{'is a ball joint' if len(balls) == 1 else 'are ball joints'}")
        w = self.world
        positions, rotations, masses, inertias = w.positions, w.rotations, w.masses, w.inertias
        parent_joint = {j.body: k for k, j in enumerate(joints)}
        M = np.zeros((len(joints), len(joints)))
        for b, joint in parent_joint.items():
            c, R = positions[b], rotations[b]
            I_world = R @ inertias[b] @ R.T
            J = np.zeros((6, len(joints)))
            k = joint
            while k is not None:
                j = joints[k]
                frame = w.joint(j.index)
                Rb = rotations[j.body]
                y = positions[j.body] + Rb @ frame["anchor_b"]
                a = Rb @ frame["axis_b"]
                if j.type == "hinge":
                    J[:3, k], J[3:, k] = np.cross(a, c - y), a
                else:
                    J[:3, k] = a
                k = parent_joint.get(j.parent)
            M += masses[b] * J[:3].T @ J[:3] + J[3:].T @ I_world @ J[3:]
        return M

    def set_ctrl(self, ctrl) -> None:
        """Sets MuJoCo's controls (nu,): each clamped to its actuator's ctrlrange and applied from
        the next step on: a position or velocity actuator's to its joint's drive
        (``World.set_joint_motor``), a motor's as its joint's effort g clamp(u, forcerange)
        (``World.set_joint_effort``)."""
        values = np.array(ctrl, dtype=np.float64).reshape(-1)
        if values.shape != (len(self.actuators),) or not np.all(np.isfinite(values)):
            raise ValueError(f"set_ctrl: expected {len(self.actuators)} finite controls, got {ctrl!r}")
        for k, a in enumerate(self.actuators):
            if a.ctrlrange is not None:
                values[k] = min(max(values[k], a.ctrlrange[0]), a.ctrlrange[1])
        for a, u in zip(self.actuators, values):
            joint = self.joints[a.joint]
            self.world.set_joint_motor(joint.index, _drive(joint, a, float(u)))
            if a.type == "motor":
                force = float(u) if a.forcerange is None else min(max(float(u), a.forcerange[0]), a.forcerange[1])
                self.world.set_joint_effort(joint.index, a.gear * force)
        self.ctrl = values


def read_mjcf(path, *, package_dirs=()):
    """The ``scenefile.Scene`` of an MJCF file: its World (static geoms, then the moving bodies in
    file order, with their joints), dt from ``<option timestep>`` (MuJoCo's default 0.002 s), 500
    steps, body names (the body's name, or the geom's for static ones). Mesh files are read from
    inside the MJCF file's folder and the folders in ``package_dirs`` (paths) only; limits in the
    module doc. Raises FileNotFoundError or MJCFError naming the file, the line, the element and
    the problem; nothing is half built. ``import_mjcf`` gives the joints and actuators too."""
    return import_mjcf(path, package_dirs=package_dirs).scene


def import_mjcf(path, *, package_dirs=()) -> MJCFModel:
    """The ``MJCFModel`` of an MJCF file: ``read_mjcf``'s Scene with the bodies, joints and
    actuators by name, and ``set_ctrl`` for the actuators' controls."""
    path = Path(path)
    try:
        return _read_mjcf(path, package_dirs)
    except (RecursionError, MemoryError) as e:
        raise MJCFError(f"MJCF file {str(path)!r}: out of memory or stack reading it ({type(e).__name__})") from None


def _read_mjcf(path: Path, package_dirs) -> MJCFModel:
    from .joints import Prismatic, Revolute, Spherical
    from .scenefile import Scene  # pydantic loads only when a file is read
    from .world import World, mass_properties

    reader = _Reader(path, package_dirs)
    settings, dt = reader.read()
    worldbodies = reader.root.findall("worldbody")
    if not worldbodies:
        raise MJCFError(f"MJCF file {str(path)!r}: no <worldbody>")

    # the tree: static geoms (the world's and those of bodies welded to it) and moving bodies
    static_parts: list[_Part] = []
    links: list[_Link] = []
    for wb in worldbodies:
        for j, _, _ in reader.body_joints(wb, "main", _Pose()):
            raise reader.error(j, "a joint on the world body (MuJoCo's world does not move; put it in a <body>)")
        reader.walk(wb, _Pose(), "main", None, True, "world", static_parts, links)
    plans = [reader.joint_plan(link) for link in links]
    by_name = {p.name: p for p in plans if p is not None and p.name}
    actuators = reader.read_actuators(by_name)
    known = {"world"} | {p.body for p in static_parts if p.body} | {n for link in links for n in
                                                                    (link.name, *link.welded) if n}
    excludes = reader.read_excludes(known)
    if reader.unsupported:
        listed = "\n  ".join(reader.unsupported_list())
        raise MJCFError(f"MJCF file {str(path)!r}: outside the subset signorini imports (see signorini.mjcf):"
                        f"\n  {listed}")
    for link, plan in zip(links, plans):
        if not link.parts:
            raise reader.error(link.element, f"a {'free' if plan is None else 'jointed'} body needs at least one "
                                             "geom (signorini derives mass and inertia from shapes)")

    world = World(**settings)
    names: list[str] = []
    bodies: dict = {}
    for part in static_parts:
        try:
            index = world.add_static(part.shape, position=part.pose.p, orientation=part.pose.q, friction=part.friction,
                                     spinning_friction=part.spinning_friction)
        except (TypeError, ValueError) as e:
            raise reader.error(part.element, str(e)) from None
        names.append(part.element.get("name") or f"static_{len(names)}")
        bodies.setdefault("world", []).append(index)
        if part.body and part.body != "world":
            bodies.setdefault(part.body, []).append(index)
    anchor = None
    if any(link.parent is None and plan is not None for link, plan in zip(links, plans)):
        # what bodies hinged to MuJoCo's world hang from: a static body that collides with nothing
        anchor = world.add_static(Sphere(_ANCHOR_RADIUS), group=0, mask=0)
        names.append("world")
        bodies.setdefault("world", []).append(anchor)
    index_of: list[int] = []
    for link in links:
        index = _add_moving_body(reader, world, link.element, link.pose, link.parts, mass_properties)
        index_of.append(index)
        names.append(link.name or f"body_{len(names)}")
        for name in (link.name, *link.welded):
            if name:
                bodies[name] = [index]
    joints: dict = {}
    for link, plan, b in zip(links, plans, index_of):
        if plan is None:
            continue
        a = anchor if link.parent is None else index_of[link.parent]
        try:
            if plan.kind == "ball":
                description = Spherical(a, b, plan.anchor, name=plan.name)
            else:
                kind = Revolute if plan.kind == "hinge" else Prismatic
                extra = {"friction": plan.frictionloss} if plan.frictionloss else {}
                description = kind(a, b, anchor=plan.anchor, axis=plan.axis, limits=plan.limits, name=plan.name,
                                   **extra)
            index = world.add_joint(description)
        except (TypeError, ValueError) as e:
            raise reader.error(plan.element, str(e)) from None
        lower, upper = plan.range if plan.range is not None else (math.nan, math.nan)
        joints[plan.name or f"joint_{index}"] = MJCFJoint(plan.name or f"joint_{index}", plan.kind, index, b, a,
                                                          plan.ref, lower, upper, plan.stiffness, plan.springref,
                                                          plan.damping, plan.frictionloss)
    scene = Scene(name=path.stem, world=world, dt=dt if dt is not None else 0.002, steps=500,
                  description=f"imported from {path.name}", names=tuple(names))
    model = MJCFModel(scene, bodies, joints, actuators, np.zeros(len(actuators)))
    # the drives at control 0 (MuJoCo's start): passive springs and dampers, then the actuators
    driven = {a.joint for a in actuators}
    try:
        for joint in joints.values():
            motor = _drive(joint, None, 0.0) if joint.type != "ball" and joint.name not in driven else None
            if motor is not None:
                world.set_joint_motor(joint.index, motor)
        model.set_ctrl(np.zeros(len(actuators)))
    except (TypeError, ValueError) as e:
        raise MJCFError(f"MJCF file {str(path)!r}: {e}") from None
    # collisions: MuJoCo's excluded pairs, and none at all when the contact flag is off
    for el, b1, b2 in excludes:
        for i in bodies.get(b1, []):
            for j in bodies.get(b2, []):
                if i != j:
                    world.disable_collision(i, j)
    if reader.contacts_off:
        for i in range(world.num_bodies):
            world.set_collision_filter(i, 0, 0)
    return model


def _add_moving_body(reader: _Reader, world, body: ET.Element, pose: _Pose, parts: list, mass_properties) -> int:
    """Adds one moving body (free or jointed) and returns its index: its parts as one shape (a Compound unless a single geom sits at the
    body origin), with one density, and its centre of mass placed where MuJoCo puts it."""
    if not parts:
        raise reader.error(body, "a free body needs at least one geom (signorini derives mass and inertia "
                                 "from shapes)")
    if len(parts) == 1 and parts[0].pose.is_identity():
        shape = parts[0].shape
    else:
        try:
            shape = Compound([(part.shape, (part.pose.p, part.pose.q)) for part in parts])
        except (TypeError, ValueError) as e:
            raise reader.error(body, str(e)) from None
    # one density for the whole body: each geom's density, or its mass over its volume
    densities = []
    for part in parts:
        if part.mass is not None:
            try:
                volume = mass_properties(part.shape, 1.0)[0]
            except (TypeError, ValueError) as e:
                raise reader.error(part.element, str(e)) from None
            densities.append(part.mass / volume)
        else:
            densities.append(part.density)
    if max(densities) - min(densities) > 1e-12 * max(abs(d) for d in densities):
        listed = ", ".join(f"{d:g}" for d in densities)
        raise reader.error(body, f"its geoms have different densities ({listed} kg/m^3); a signorini body has one "
                                 "uniform density")
    frictions = {part.friction for part in parts}
    if len(frictions) > 1:
        raise reader.error(body, f"its geoms have different frictions {sorted(frictions)}; a signorini body has one")
    spinning = {part.spinning_friction for part in parts}
    if len(spinning) > 1:
        raise reader.error(body, f"its geoms have different torsional frictions {sorted(spinning)} m (condim 4 or 6; "
                                 "0 for condim 1 or 3); a signorini body has one spinning friction")
    try:
        volume, com, inertia = mass_properties(shape, 1.0)
    except (TypeError, ValueError) as e:
        raise reader.error(body, str(e)) from None
    given_mass = parts[0].mass if len(parts) == 1 and parts[0].mass is not None else None
    density = densities[0]
    inertial = body.find("inertial")
    if inertial is not None and reader.inertia_from_geom != "true":
        given_mass = _check_inertial(reader, inertial, volume, com, inertia)
    elif inertial is None and reader.inertia_from_geom == "false":
        raise reader.error(body, "compiler inertiafromgeom='false' needs an <inertial> on every body")
    position = pose.p + _qrot(pose.q) @ np.asarray(com)
    kwargs = {"mass": given_mass} if given_mass is not None else {"density": density}
    try:
        return world.add_body(shape, position=position, orientation=pose.q, friction=parts[0].friction,
                              spinning_friction=parts[0].spinning_friction, **kwargs)
    except (TypeError, ValueError) as e:
        raise reader.error(body, str(e)) from None


def _check_inertial(reader: _Reader, el: ET.Element, volume: float, com, inertia) -> float:
    """The mass of an <inertial> that agrees with the geoms at that mass (1e-9 relative), else an
    error: signorini derives a body's inertia from its shapes."""
    reader.check_attrs(el, {"pos", "mass", "diaginertia", "fullinertia", "quat", "euler", "axisangle", "xyaxes",
                            "zaxis"})
    attrs = dict(el.attrib)
    mass = reader.numbers(el, attrs, "mass", 1)
    if mass is None:
        raise reader.error(el, "an inertial needs a mass")
    m = float(mass[0])
    pose = reader.pose(el, attrs)
    diag, full = reader.numbers(el, attrs, "diaginertia", 3), reader.numbers(el, attrs, "fullinertia", 6)
    if (diag is None) == (full is None):
        raise reader.error(el, "an inertial needs exactly one of diaginertia and fullinertia")
    if diag is not None:
        R = _qrot(pose.q)
        I_given = R @ np.diag(diag) @ R.T
    else:
        assert full is not None
        xx, yy, zz, xy, xz, yz = full
        I_given = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    I_geoms = (m / volume) * np.asarray(inertia)
    scale = max(np.abs(I_geoms).max(), 1e-300)
    size = max(np.linalg.norm(com), volume ** (1.0 / 3.0))
    if np.abs(I_given - I_geoms).max() > 1e-9 * scale or np.linalg.norm(pose.p - com) > 1e-9 * size:
        raise reader.error(el, "differs from the geoms' own inertia at this mass (signorini derives inertia and "
                               f"centre of mass from the shapes: com {np.round(com, 12).tolist()}, inertia "
                               f"{np.round(I_geoms, 12).tolist()}); remove it or set compiler inertiafromgeom='true'")
    return m


def load_mjcf(path, *, package_dirs=()):
    """The World of an MJCF file (see ``read_mjcf`` and the module doc for the subset, the limits
    and ``package_dirs``, the folders besides the file's own that mesh files may be read from)."""
    return read_mjcf(path, package_dirs=package_dirs).world
