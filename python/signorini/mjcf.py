"""MJCF import: the rigid-body subset of MuJoCo's model files, read with the standard library's
``xml.etree`` (MuJoCo itself is not needed).

    w = sg.load_mjcf("model.xml")            # the World
    scene = sg.read_mjcf("model.xml")        # a scenefile.Scene: the World, dt = option timestep, names

What is imported:

- ``<worldbody>`` geoms, and the geoms of bodies without joints under it, become static bodies,
  one per geom: ``plane`` (the geom's z axis is the normal), ``box``, ``sphere``, ``capsule``,
  ``cylinder``, ``ellipsoid`` (equal radii: a sphere; unequal, static only: the convex hull of a
  subdivided icosphere stretched to the radii) and ``mesh`` (a ``TriangleMesh`` of the file);
- a body with a ``<freejoint/>`` (or ``<joint type="free"/>``) directly under ``<worldbody>``
  becomes a dynamic body; its geoms and those of its joint-less child bodies (welded to it, as in
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

Ignored, because they do not change the rigid bodies: sites, cameras, lights, sensors,
keyframes, visual, statistic, size, custom, textures and materials, and the contact-tuning
attributes (solref, solimp, margin, gap, priority, contype, conaffinity, rgba, group).
Everything else (hinge, slide and ball joints, actuators, tendons, equality constraints, contact
pairs and excludes, height fields, includes, frames, plugins...) is an ``MJCFError`` listing every
unsupported element with its line, in line order, the joints inside a ``<frame>`` too (as MuJoCo
writes a converted URDF), so a model is never imported with a part silently missing.
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

__all__ = ["load_mjcf", "read_mjcf", "MJCFError", "MAX_MJCF_BYTES", "MAX_MJCF_DEPTH"]

# limits (module doc): MuJoCo's menagerie models are under 1 MB of XML (meshes apart), 64 MiB is far
# above any hand-written or exported model while bounding the tree built in memory
MAX_MJCF_BYTES = 64 * 2**20
# a humanoid's kinematic tree nests bodies about 15 deep; 64 keeps the reader's recursion shallow
MAX_MJCF_DEPTH = 64


class MJCFError(ValueError):
    """An MJCF file that cannot be imported: the message names the file, the line, the element and
    the problem (for unsupported elements, all of them)."""


# the rigid-body subset: what is read, and what is skipped because it does not change the bodies
_TOP_READ = {"compiler", "option", "default", "asset", "worldbody"}
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
_COMPILER_ATTRS = {"angle", "meshdir", "assetdir", "eulerseq", "inertiafromgeom"}
_COMPILER_IGNORED = {"autolimits", "texturedir", "discardvisual", "strippath", "inertiagrouprange", "fitaabb",
                     "usethread", "convexhull", "alignfree", "fusestatic"}
_OPTION_ATTRS = {"gravity", "timestep", "cone"}
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


class _Reader:
    def __init__(self, path: Path, package_dirs=()):
        self.path = path
        self.package_dirs = [Path(d) for d in package_dirs]
        self.unsupported: list[tuple[float, str]] = []  # (line, what), listed in line order
        try:
            filecheck.check_size(path, MAX_MJCF_BYTES)
            text = path.read_bytes()
        except FileNotFoundError:
            raise FileNotFoundError(f"MJCF file {str(path)!r} does not exist") from None
        except filecheck.FileLimitError as e:
            raise MJCFError(f"MJCF file {str(path)!r}: {e}") from None
        except OSError as e:
            raise MJCFError(f"MJCF file {str(path)!r}: unreadable: {e}") from None
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
        self.defaults: dict[str, dict[str, dict[str, str]]] = {"main": {}}
        self.meshes: dict[str, ET.Element] = {}
        self.current: Optional[ET.Element] = None  # the free body being read

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
            if self.inertia_from_geom not in ("auto", "true", "false"):
                raise self.error(el, f"inertiafromgeom must be auto, true or false, got {self.inertia_from_geom!r}")
        settings = {}
        dt = None
        for el in self.root.iter("option"):
            self.check_attrs(el, _OPTION_ATTRS, {"integrator", "iterations", "tolerance", "solver", "jacobian",
                                                 "ls_iterations", "noslip_iterations", "impratio", "o_margin"})
            for child in el:
                if child.tag != "flag":
                    self.skip(child)
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
            if child.tag in ("geom", "mesh"):
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

    def body_parts(self, body: ET.Element, frame: _Pose, cls: str, dynamic: bool, parts: list) -> None:
        """Adds the geoms of a body and its welded (joint-less) children to parts, posed in
        ``frame`` (the dynamic body's frame, or the world for static ones)."""
        for child in body:
            if child.tag in _BODY_IGNORED:
                continue
            if child.tag == "geom":
                attrs = self.attrs(child, cls)
                self.check_attrs(child, _GEOM_ATTRS, _GEOM_IGNORED)
                shape, pose = self.geom_shape(child, attrs, dynamic)
                density, mass, mu = self.geom_mass(child, attrs)
                spin = self.geom_spinning_friction(child, attrs)
                pose = frame.then(pose)
                if isinstance(shape, str):
                    # a plane: the geom's z axis is the normal, through the geom's origin
                    n = _qrot(pose.q)[:, 2]
                    shape, pose = Plane(n, float(n @ pose.p)), _Pose()
                parts.append(_Part(shape, pose, density, mass, mu, spin, child))
            elif child.tag == "body":
                self.check_attrs(child, _BODY_ATTRS, _BODY_IGNORED_ATTRS)
                joints = [j for j in child if j.tag in ("joint", "freejoint")]
                for j in joints:
                    kind = "free" if j.tag == "freejoint" else self.attrs(j, cls).get("type", "hinge")
                    self.skip(j, "a free joint with other joints, or on a body not directly under <worldbody>"
                              if kind == "free" else f"{kind} joint")
                inner = self.attrs(child, cls).get("childclass", cls)
                self.body_parts(child, frame.then(self.pose(child, self.attrs(child, cls))), inner, dynamic, parts)
            elif child.tag == "inertial":
                if dynamic and body is not self.current:
                    self.skip(child, "an inertial on a welded child body")
            elif child.tag in ("joint", "freejoint"):
                pass  # read by the caller
            else:
                self.skip_tree(child)


def read_mjcf(path, *, package_dirs=()):
    """The ``scenefile.Scene`` of an MJCF file: its World (static geoms, then the free bodies in file
    order), dt from ``<option timestep>`` (MuJoCo's default 0.002 s), 500 steps, body names (the
    body's name, or the geom's for static ones). Mesh files are read from inside the MJCF file's
    folder and the folders in ``package_dirs`` (paths) only; limits in the module doc. Raises
    FileNotFoundError or MJCFError naming the file, the line, the element and the problem; nothing
    is half built."""
    path = Path(path)
    try:
        return _read_mjcf(path, package_dirs)
    except (RecursionError, MemoryError) as e:
        raise MJCFError(f"MJCF file {str(path)!r}: out of memory or stack reading it ({type(e).__name__})") from None


def _read_mjcf(path: Path, package_dirs):
    from .scenefile import Scene  # pydantic loads only when a file is read
    from .world import World, mass_properties

    reader = _Reader(path, package_dirs)
    settings, dt = reader.read()
    worldbodies = reader.root.findall("worldbody")
    if not worldbodies:
        raise MJCFError(f"MJCF file {str(path)!r}: no <worldbody>")

    # static geoms: the worldbody's own and those of joint-less bodies under it; free bodies apart
    static_parts: list[_Part] = []
    free: list[tuple[ET.Element, _Pose, str]] = []
    reader.current = None
    for wb in worldbodies:
        for child in wb:
            if child.tag == "body":
                reader.check_attrs(child, _BODY_ATTRS, _BODY_IGNORED_ATTRS)
                attrs = reader.attrs(child, "main")
                joints = [j for j in child if j.tag in ("joint", "freejoint")]
                kinds = ["free" if j.tag == "freejoint" else reader.attrs(j, "main").get("type", "hinge") for j in joints]
                if kinds == ["free"]:
                    free.append((child, reader.pose(child, attrs), attrs.get("childclass", "main")))
                    continue
                # a body without joints is welded to the world: its geoms are static (body_parts
                # lists any joints it has as unsupported)
                holder = ET.Element("worldbody")
                holder.append(child)
                reader.body_parts(holder, _Pose(), "main", False, static_parts)
            elif child.tag == "geom":
                holder = ET.Element("worldbody")
                holder.append(child)
                reader.body_parts(holder, _Pose(), "main", False, static_parts)
            elif child.tag not in _BODY_IGNORED:
                reader.skip_tree(child)

    # each free body: its parts in its own frame
    bodies = []
    for body, pose, cls in free:
        parts: list[_Part] = []
        reader.current = body
        reader.body_parts(body, _Pose(), cls, True, parts)
        bodies.append((body, pose, parts))
    if reader.unsupported:
        listed = "\n  ".join(reader.unsupported_list())
        raise MJCFError(f"MJCF file {str(path)!r}: outside the subset signorini imports (free bodies and static "
                        f"geoms; see signorini.mjcf):\n  {listed}")

    world = World(**settings)
    names: list[str] = []
    try:
        for part in static_parts:
            try:
                world.add_static(part.shape, position=part.pose.p, orientation=part.pose.q, friction=part.friction,
                                 spinning_friction=part.spinning_friction)
            except (TypeError, ValueError) as e:
                raise reader.error(part.element, str(e)) from None
            names.append(part.element.get("name") or f"static_{len(names)}")
        for body, pose, parts in bodies:
            _add_free_body(reader, world, body, pose, parts, mass_properties)
            names.append(body.get("name") or f"body_{len(names)}")
    except MJCFError:
        raise
    return Scene(name=path.stem, world=world, dt=dt if dt is not None else 0.002, steps=500,
                 description=f"imported from {path.name}", names=tuple(names))


def _add_free_body(reader: _Reader, world, body: ET.Element, pose: _Pose, parts: list, mass_properties) -> None:
    """Adds one free body: its parts as one shape (a Compound unless a single geom sits at the
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
        world.add_body(shape, position=position, orientation=pose.q, friction=parts[0].friction,
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
