"""URDF import: a robot's links, inertials, collision shapes and joints, read through yourdfpy
(``pip install yourdfpy``, the ``urdf`` extra; the package imports without it).

    w = sg.load_urdf("robot.urdf", fixed_base=True)         # a new World with the robot
    robot = sg.add_urdf(w, "robot.urdf", position=(1, 0, 0))  # into an existing World: a URDFRobot

Inputs: a URDF file (at most ``MAX_URDF_BYTES``); ``package_dirs``, folders (besides the file's own)
that mesh files may be read from and that ``package://name/...`` resolves against (as
``dir/name/...``, then ``dir/...``: pybullet_data's layout); the base pose ``position`` (3,) m and
``orientation`` (w, x, y, z) of the root link's frame, world. Output: the World (``load_urdf``) or
a ``URDFRobot`` naming each link's body index and each joint's index (``add_urdf``).

Frames and units: SI (m, kg, kg m^2, rad). Link frames are placed at the zero configuration
(every joint coordinate 0), root first: T_child = T_parent T_origin(joint). One signorini body per
group of links held together by ``fixed`` joints (the group's first link names it): its frame's
axes are that link's axes, its origin the group's centre of mass; its mass and inertia sum each
link's <inertial> exactly, I = sum_l R_l I_l R_l^T + m_l (|c_l - c|^2 E - (c_l - c)(c_l - c)^T), with
R_l the inertial frame's rotation (rpy) in the body's axes, so a principal frame turned against
the link frame and off-diagonal terms both carry over. The hinge and slider anchor is the child
link's origin, the axis the joint's <axis> (normalised) in the child frame; a joint's coordinate is
0 at load, the URDF's zero, with the URDF's sign.

What maps to what (docs/conventions.md, "URDF"):
- ``revolute`` -> ``sg.Revolute`` with its <limit> lower/upper (none when lower > upper, as
  pybullet; none when upper - lower >= 2 pi; a range reaching outside (-pi, pi) otherwise is an
  error, the hinge angle wraps there); ``continuous`` -> ``sg.Revolute`` without limits;
  ``prismatic`` -> ``sg.Prismatic`` with its limits; ``fixed`` -> the child link merged into its
  parent's body (the exact rigid mass matrix, no joint rows to converge); ``floating`` -> the child
  a free body; ``planar`` and unknown types are refused. A revolute or prismatic joint needs a
  <limit> (as in the URDF standard and pybullet). <limit effort velocity>: kept per joint,
  ``URDFRobot.motor`` makes a ``sg.Motor`` with max force = effort and the speed clamped to
  +-velocity; no motor is set at load (the joints are limp). <dynamics damping friction> (with
  ``dynamics=True``, the default): damping c (N m s/rad or N s/m) is the joint's drive
  ``sg.Motor(0, inf, damping=c)``, friction f (N m or N) its Coulomb ``friction=f``; a velocity
  motor set by ``URDFRobot.set_motor`` takes the damper's place while it is on, and removing it
  (``set_motor(name, None)``) puts the damper back (``URDFRobot.motor``). ``dynamics=False`` loads
  the joints limp and frictionless, as pybullet with its joint damping zeroed. <mimic>,
  <calibration>, <safety_controller>, transmissions and gazebo tags are not imported.
- inertials: a link without <inertial> gets mass 1 kg and inertia E kg m^2 at its origin, as
  pybullet does (a root link named ``world`` gets mass 0). A root link of mass 0 makes a static
  robot base, as pybullet's; ``fixed_base=True`` makes the root body static whatever its mass. A
  moving body (a link group past a movable joint) needs a positive total mass and a positive
  definite inertia; a mass < 0 is an error.
- collisions: <box>, <cylinder> (along z), <sphere> and <mesh filename scale> (OBJ, STL, PLY, OFF,
  GLB through ``signorini.meshfile``, DAE through trimesh): a mesh collides as its convex hull (as
  pybullet's default). A link group with several shapes is a ``Compound``; one without any gets a
  placeholder sphere of 1 cm that collides with nothing (filter group 0, mask 0). Visuals are not
  read. pybullet's <contact> extension: ``lateral_friction``, ``spinning_friction`` and
  ``restitution`` of the group's first link set the body's material (default friction 0.5).
- collisions inside the robot: a joint's two bodies never collide (``collide_connected`` False);
  with ``self_collision=False`` (the default, as pybullet's) no two bodies of the robot collide.

Bad input (a missing or malformed file, a link or joint without a name or named twice, a joint
whose parent or child link does not exist, a loop or a link with two parents, an unknown joint
type, a number that is malformed, NaN or infinite, a missing mesh file, a zero axis, a negative
mass, a negative <dynamics> damping or friction, a moving link without mass or inertia, a name
already taken in the World) raises ``URDFError`` (FileNotFoundError for the file itself) naming
the file, the element (link or joint name, with its line) and the problem, before any body is
added: the World is unchanged.
"""
from __future__ import annotations

import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from . import filecheck
from ._core import Box, Compound, ConvexHull, Cylinder, Sphere
from .codec import matrix_to_quat
from .joints import Motor, Prismatic, Revolute

__all__ = ["load_urdf", "add_urdf", "URDFError", "URDFRobot", "URDFJoint", "MAX_URDF_BYTES"]

# a robot's URDF is well under 1 MB (meshes apart); the MJCF reader's bound
MAX_URDF_BYTES = 64 * 2**20
# the placeholder of a body without collision shapes (m): collides with nothing, only gives a shape
_PLACEHOLDER_RADIUS = 0.01
_MOVING = ("revolute", "continuous", "prismatic")
_KNOWN = _MOVING + ("fixed", "floating", "planar")
# attributes read as numbers (checked for syntax and finiteness before yourdfpy reads them)
_NUMERIC = {"xyz", "rpy", "value", "ixx", "ixy", "ixz", "iyy", "iyz", "izz", "lower", "upper", "effort",
            "velocity", "size", "radius", "length", "scale", "damping", "friction"}


class URDFError(ValueError):
    """A URDF file that cannot be imported: the message names the file, the element (link or joint,
    with its line) and the problem."""


@dataclass(frozen=True)
class URDFJoint:
    """One URDF joint as imported: ``index`` is the World's joint index (-1 for fixed joints, merged,
    and floating ones, free); lower/upper the limits applied (rad or m; NaN: none); effort (N m or
    N) and velocity (rad/s or m/s) the <limit>'s motor bounds (inf when not given); damping (N m
    s/rad or N s/m) and friction (N m or N) the <dynamics> applied (0 when not given, or loaded
    with ``dynamics=False``)."""
    name: str
    type: str
    parent: str
    child: str
    index: int
    lower: float
    upper: float
    effort: float
    velocity: float
    damping: float = 0.0
    friction: float = 0.0


@dataclass
class URDFRobot:
    """A robot added to a World: ``bodies`` maps every link name to its body index (links merged by
    fixed joints share one), ``joints`` every joint name to a URDFJoint, ``root`` is the base's body."""
    world: object
    name: str
    root: int
    bodies: dict = field(default_factory=dict)
    joints: dict = field(default_factory=dict)

    @property
    def joint_indices(self) -> list:
        """The World joint indices of the movable joints, in file order."""
        return [j.index for j in self.joints.values() if j.index >= 0]

    def motor(self, joint: str, speed: Optional[float]) -> Optional[Motor]:
        """The drive of URDF joint ``joint``: for a ``speed``, a rigid velocity motor with target
        ``speed`` clamped to +-<limit velocity> and max force (torque) <limit effort>; for None, the
        file's damper ``Motor(0, inf, damping=c)`` (None when the joint has no damping).

        The velocity motor replaces the damper while it is on (a joint has one drive slot), as a
        velocity controller is meant: the joint follows the command whenever the effort allows
        (pybullet's VELOCITY_CONTROL, a ROS velocity controller). A damper in parallel would only
        load the motor by c * speed, within its effort; what is lost is that share of the effort
        while the motor is saturated. Folding c into the motor as its gain instead would make it
        a soft servo lagging its command by load / c (2 rad/s under 1 N m with KUKA's c = 0.5)."""
        j = self.joints[joint]
        if j.index < 0:
            raise ValueError(f"URDF joint {joint!r} ({j.type}) has no motor: it is not a World joint")
        if speed is None:
            return Motor(0.0, math.inf, damping=j.damping) if j.damping > 0.0 else None
        return Motor(float(np.clip(speed, -j.velocity, j.velocity)), j.effort)

    def set_motor(self, joint: str, speed: Optional[float]) -> None:
        """Sets joint ``joint``'s velocity motor in the World (``motor``'s limits), or with None
        switches it off: the joint goes back to the file's damper (limp when it has none)."""
        j = self.joints[joint]
        self.world.set_joint_motor(j.index, self.motor(joint, speed))


# the file ---------------------------------------------------------------------------------------
class _File:
    """The URDF text, its lxml tree (for lines and pybullet's <contact>) and yourdfpy's Robot."""

    def __init__(self, path: Path):
        self.path = path
        text = filecheck.read_limited(path, MAX_URDF_BYTES, "URDF file", URDFError)
        # pybullet_data writes <?xml version="0.0" ?> (table.urdf), which libxml2 refuses: a
        # declaration of a version other than 1.x is dropped
        text = re.sub(rb'^\s*<\?xml[^>]*version\s*=\s*["\'](?!1\.)[^"\']*["\'][^>]*\?>', b"", text, count=1)
        try:
            from lxml import etree
            import yourdfpy
        except ImportError as e:
            raise ImportError(f"URDF import needs yourdfpy ({e}): pip install yourdfpy "
                              "(or pip install 'signorini[urdf]')") from None
        try:
            self.root = etree.fromstring(text, etree.XMLParser(remove_comments=True, resolve_entities=False,
                                                               no_network=True, huge_tree=False))
        except etree.XMLSyntaxError as e:
            raise URDFError(f"URDF file {str(path)!r}: malformed XML: {e}") from None
        if self.root.tag != "robot":
            raise URDFError(f"URDF file {str(path)!r}: the root element is <{self.root.tag}>, not <robot>")
        self.elements: dict = {}  # (tag, name) -> lxml element
        self.check_structure()
        try:
            self.robot = yourdfpy.URDF.load(io.BytesIO(text), build_scene_graph=False, load_meshes=False,
                                            build_collision_scene_graph=False, load_collision_meshes=False).robot
        except Exception as e:  # yourdfpy raises many types; the checks above catch the usual ones
            raise URDFError(f"URDF file {str(path)!r}: yourdfpy cannot read it: {type(e).__name__}: {e}") from None

    def where(self, tag: str, name: str) -> str:
        el = self.elements.get((tag, name))
        line = f"line {el.sourceline} " if el is not None else ""
        return f"{line}<{tag} name={name!r}>"

    def error(self, tag: str, name: str, problem: str) -> URDFError:
        return URDFError(f"URDF file {str(self.path)!r}: {self.where(tag, name)}: {problem}")

    def check_structure(self) -> None:
        """Names present and unique, joints with a type, a parent and a child, numbers well formed and
        finite: checked on the XML, so each error names its element and line."""
        for el in self.root:
            if el.tag not in ("link", "joint"):
                continue
            name = el.get("name")
            if not name:
                raise URDFError(f"URDF file {str(self.path)!r}: line {el.sourceline} <{el.tag}> has no name")
            if (el.tag, name) in self.elements:
                raise URDFError(f"URDF file {str(self.path)!r}: line {el.sourceline} <{el.tag} name={name!r}>: "
                                f"a second {el.tag} of that name (the first is at line "
                                f"{self.elements[(el.tag, name)].sourceline})")
            self.elements[(el.tag, name)] = el
            if el.tag == "joint":
                kind = el.get("type")
                if kind not in _KNOWN:
                    raise self.error("joint", name, f"unknown or missing joint type {kind!r} (URDF types: "
                                                    f"{', '.join(_KNOWN)}; planar is not imported)")
                for end in ("parent", "child"):
                    sub = el.find(end)
                    if sub is None or not sub.get("link"):
                        raise self.error("joint", name, f"no <{end} link=...>")
            for sub in el.iter():
                for key, value in sub.attrib.items():
                    if key not in _NUMERIC:
                        continue
                    try:
                        numbers = [float(x) for x in value.split()]
                    except ValueError:
                        numbers = None
                    if not numbers or not all(math.isfinite(x) for x in numbers):
                        raise self.error(el.tag, name, f"line {sub.sourceline} <{sub.tag} {key}={value!r}>: "
                                                       "not a list of finite numbers")

    def contact(self, link: str) -> dict:
        """pybullet's <contact> extension of a link: the material keywords it gives."""
        out = {}
        el = self.elements.get(("link", link))
        contact = el.find("contact") if el is not None else None
        if contact is not None:
            for key, kw in (("lateral_friction", "friction"), ("spinning_friction", "spinning_friction"),
                            ("restitution", "restitution")):
                sub = contact.find(key)
                if sub is not None and sub.get("value") is not None:
                    out[kw] = float(sub.get("value"))
        return out


# frames ----------------------------------------------------------------------------------------
def _transform(T) -> np.ndarray:
    return np.eye(4) if T is None else np.asarray(T, dtype=np.float64)


def _quat(T: np.ndarray) -> np.ndarray:
    return np.asarray(matrix_to_quat(np.ascontiguousarray(T[:3, :3])), dtype=np.float64)


def _from_pose(position, orientation) -> np.ndarray:
    q = np.asarray(orientation, dtype=np.float64)
    q = q / np.linalg.norm(q)
    w, x, y, z = q
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                 [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                 [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = position
    return T


# the plan: everything checked and built before the World changes -----------------------------
@dataclass
class _Group:
    """Links welded by fixed joints into one body: frame T (4, 4, world, the first link's), mass (kg),
    com (3,) and inertia (3, 3) in T's frame, collision parts [(shape, (p (3,), R (3, 3)))] in T's frame."""
    links: list
    T: np.ndarray
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    parts: list = field(default_factory=list)
    static: bool = False


def _plan(f: _File, base: np.ndarray, fixed_base: bool, package_dirs, dynamics: bool = True):
    robot = f.robot
    links = {link.name: link for link in robot.links}
    parent_of: dict = {}
    for j in robot.joints:
        for end in (j.parent, j.child):
            if end not in links:
                raise f.error("joint", j.name, f"link {end!r} does not exist (links: {', '.join(links) or 'none'})")
        if j.parent == j.child:
            raise f.error("joint", j.name, f"joins link {j.child!r} to itself (a loop)")
        if j.child in parent_of:
            raise f.error("joint", j.name, f"link {j.child!r} already has the parent joint {parent_of[j.child].name!r}"
                                           " (two parents: a loop; URDF describes trees)")
        parent_of[j.child] = j
        if j.type == "planar":
            raise f.error("joint", j.name, "planar joints are not imported (no two-dimensional joint)")
    roots = [name for name in links if name not in parent_of]
    if not roots:
        # walk up from a link until a link repeats: the joint into it closes the loop
        seen, link = [], next(iter(links))
        while link not in seen:
            seen.append(link)
            link = parent_of[link].parent
        loop = seen[seen.index(link):]
        raise f.error("joint", parent_of[link].name, f"closes a loop of links {loop + [link]} (every link has a "
                                                     "parent joint; URDF describes trees)")
    if len(roots) > 1:
        raise URDFError(f"URDF file {str(f.path)!r}: several root links {roots} (links not joined into one tree)")
    children: dict = {name: [] for name in links}
    for j in robot.joints:
        children[j.parent].append(j)
    # link frames at the zero configuration, root first (a link not reached sits on a loop)
    T_link = {roots[0]: base}
    order = [roots[0]]
    for name in order:
        for j in children[name]:
            T_link[j.child] = T_link[name] @ _transform(j.origin)
            order.append(j.child)
    missing = [n for n in links if n not in T_link]
    if missing:
        j = parent_of[missing[0]]
        raise f.error("joint", j.name, f"closes a loop (links {missing} are not reached from the root {roots[0]!r})")

    # links into groups: a fixed joint's child joins its parent's group
    # (rel: each link's frame in its group's, composed along the fixed joints: exact for the first)
    group_of: dict = {}
    groups: list[_Group] = []
    rel: dict = {}
    for name in order:
        j = parent_of.get(name)
        if j is not None and j.type == "fixed":
            g = group_of[j.parent]
            g.links.append(name)
            rel[name] = rel[j.parent] @ _transform(j.origin)
        else:
            g = _Group([name], T_link[name])
            groups.append(g)
            rel[name] = np.eye(4)
        group_of[name] = g
    root = group_of[roots[0]]
    root_mass = _inertial(f, links[roots[0]])[0]
    root.static = fixed_base or root_mass == 0.0

    for g in groups:
        _mass_properties(f, g, links, rel)
        for name in g.links:
            G = rel[name]
            for c in links[name].collisions:
                shape = _shape(f, name, c.geometry, package_dirs)
                Tc = G @ _transform(c.origin)
                g.parts.append((shape, (Tc[:3, 3].copy(), Tc[:3, :3].copy())))
        if not g.static:
            who = g.links[0] if len(g.links) == 1 else f"{g.links[0]} (with {', '.join(g.links[1:])} by fixed joints)"
            if not g.mass > 0.0:
                raise f.error("link", g.links[0], f"link {who} moves on a joint but has no mass (mass {g.mass:g} kg): "
                                                  "a moving link needs a positive mass")
            if np.linalg.eigvalsh(g.inertia).min() <= 0.0 or not np.isfinite(g.inertia).all():
                raise f.error("link", g.links[0], f"link {who}: its inertia {np.round(g.inertia, 12).tolist()} kg m^2 is "
                                                  "not positive definite (a moving link needs one)")

    # joints: kind, limits, motor bounds
    joint_plans = []
    for j in robot.joints:
        if j.type == "fixed":
            continue
        axis = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), dtype=np.float64)
        n = float(np.linalg.norm(axis))
        if j.type in _MOVING and not n > 0.0:
            raise f.error("joint", j.name, f"the axis {axis.tolist()} is zero")
        limit = j.limit
        if j.type in ("revolute", "prismatic") and limit is None:
            raise f.error("joint", j.name, f"a {j.type} joint needs a <limit> (URDF standard)")
        lower = upper = math.nan
        effort = velocity = math.inf
        if limit is not None:
            effort = math.inf if limit.effort is None else float(limit.effort)
            velocity = math.inf if limit.velocity is None else float(limit.velocity)
            if effort < 0 or velocity < 0:
                raise f.error("joint", j.name, f"<limit> effort {effort:g} and velocity {velocity:g} must be >= 0")
            if j.type in ("revolute", "prismatic"):
                lo = 0.0 if limit.lower is None else float(limit.lower)
                hi = 0.0 if limit.upper is None else float(limit.upper)
                if lo <= hi and not (j.type == "revolute" and hi - lo >= 2 * math.pi):
                    if j.type == "revolute" and not (-math.pi < lo and hi < math.pi):
                        raise f.error("joint", j.name, f"limits [{lo:g}, {hi:g}] rad reach outside (-pi, pi), where "
                                                       "signorini's hinge angle wraps; not imported")
                    lower, upper = lo, hi
        damping = friction = 0.0
        if j.dynamics is not None and j.type in _MOVING:
            damping = 0.0 if j.dynamics.damping is None else float(j.dynamics.damping)
            friction = 0.0 if j.dynamics.friction is None else float(j.dynamics.friction)
            if damping < 0 or friction < 0:
                raise f.error("joint", j.name, f"<dynamics> damping {damping:g} and friction {friction:g} must be >= 0")
            if not dynamics:
                damping = friction = 0.0
        joint_plans.append((j, axis / n if n > 0 else axis, lower, upper, effort, velocity, damping, friction))
    return order, links, T_link, group_of, groups, root, joint_plans


def _inertial(f: _File, link):
    """(mass kg, T (4, 4) inertial frame in the link frame, inertia (3, 3) in that frame) of a link."""
    i = link.inertial
    if i is None:
        # pybullet: mass 1 and unit inertia at the link origin; a root link named world is massless
        m = 0.0 if link.name == "world" else 1.0
        return m, np.eye(4), np.eye(3) * m
    m = 0.0 if i.mass is None else float(i.mass)
    if m < 0.0:
        raise f.error("link", link.name, f"mass {m:g} kg is negative")
    I = np.zeros((3, 3)) if i.inertia is None else np.asarray(i.inertia, dtype=np.float64)
    # a massless link with an inertia is kept: a static root (pybullet's) or merged into a moving
    # body; a moving body of no mass is refused in _mass_properties
    if np.linalg.eigvalsh(I).min() < -1e-12 * max(np.abs(I).max(), 1e-300):
        raise f.error("link", link.name, f"inertia {I.tolist()} kg m^2 has a negative principal moment")
    return m, _transform(i.origin), I


def _mass_properties(f: _File, g: _Group, links, rel) -> None:
    """Mass, centre of mass and inertia of a group in its frame (rel: each link's frame in it): the
    links' inertials summed exactly (parallel axis theorem about the group's centre of mass)."""
    items = []
    for name in g.links:
        m, Ti, I = _inertial(f, links[name])
        T = rel[name] @ Ti
        items.append((name, m, T[:3, 3], T[:3, :3] @ I @ T[:3, :3].T))
    M = sum(m for _, m, _, _ in items)
    g.mass = M
    if M > 0.0:
        g.com = sum(m * c for _, m, c, _ in items) / M
    elif len(items) == 1:
        g.com = items[0][2].copy()
    inertia = np.zeros((3, 3))
    for _, m, c, I in items:
        d = c - g.com
        inertia += I + m * (d @ d * np.eye(3) - np.outer(d, d))
    g.inertia = 0.5 * (inertia + inertia.T)
    # a moving massless link that carries an inertia is refused by name (the bad-input rule)
    if not g.static and M == 0.0:
        named = next((n for n, m, _, I in items if np.any(I)), g.links[0])
        raise f.error("link", named, "mass 0 kg with an inertia on a moving link (non-positive mass): "
                                     "a moving link needs a positive mass")


def _shape(f: _File, link: str, geometry, package_dirs):
    """A collision geometry as a signorini shape (its own frame)."""
    try:
        if geometry is None:
            raise ValueError("a <collision> without <geometry>")
        if geometry.box is not None:
            return Box(np.asarray(geometry.box.size, dtype=np.float64) / 2.0)
        if geometry.cylinder is not None:
            return Cylinder(float(geometry.cylinder.radius), float(geometry.cylinder.length) / 2.0)
        if geometry.sphere is not None:
            return Sphere(float(geometry.sphere.radius))
        if geometry.mesh is not None:
            return ConvexHull(_mesh_vertices(f, geometry.mesh, package_dirs))
        raise ValueError("a <geometry> without box, cylinder, sphere or mesh")
    except (TypeError, ValueError, FileNotFoundError) as e:
        if isinstance(e, URDFError):
            raise
        raise f.error("link", link, f"<collision>: {e}") from None


def _mesh_file(f: _File, name: str, package_dirs) -> Path:
    """The file a <mesh filename> names: relative to the URDF's folder, ``package://pkg/rest`` as
    dir/pkg/rest or dir/rest for dir in the URDF's folder and package_dirs, ``file://`` a path; the
    result must lie inside one of those folders (filecheck.inside)."""
    folders = [f.path.parent, *package_dirs]
    if name.startswith("package://"):
        rest = name[len("package://"):]
        tries = [rest, rest.split("/", 1)[1] if "/" in rest else rest]
        for d in folders:
            for t in tries:
                p = Path(d) / t
                if p.is_file():
                    return filecheck.inside(str(p), Path(d), folders, "mesh file")
        raise FileNotFoundError(f"mesh file {name!r} is not found under {[str(d) for d in folders]}")
    if name.startswith("file://"):
        name = name[len("file://"):]
    path = filecheck.inside(name, f.path.parent, folders, "mesh file")
    if not path.is_file():
        raise FileNotFoundError(f"mesh file {name!r} does not exist ({str(path)!r})")
    return path


def _mesh_vertices(f: _File, mesh, package_dirs) -> np.ndarray:
    """The vertices (n, 3) m of a <mesh>, scaled (one or three factors)."""
    if not mesh.filename:
        raise ValueError("a <mesh> without filename")
    path = _mesh_file(f, mesh.filename, package_dirs)
    if path.suffix.lower() == ".dae":
        vertices = _dae_vertices(path)
    else:
        from .meshfile import read_mesh_arrays

        vertices = read_mesh_arrays(path)[0]
    scale = np.ones(3) if mesh.scale is None else np.broadcast_to(np.asarray(mesh.scale, dtype=np.float64), (3,))
    if not (np.all(np.isfinite(scale)) and np.all(scale > 0)):
        raise ValueError(f"mesh scale {np.asarray(scale).tolist()} must be finite and > 0")
    return vertices * scale


def _dae_vertices(path: Path) -> np.ndarray:
    """The vertices (n, 3) of a COLLADA file's triangle meshes, each placed by its node (trimesh
    with pycollada)."""
    from .meshfile import MAX_MESH_BYTES
    import trimesh

    try:
        filecheck.check_size(path, MAX_MESH_BYTES)
        scene = trimesh.load_scene(str(path), file_type="dae")
        parts = [g.vertices for g in scene.dump() if isinstance(g, trimesh.Trimesh) and len(g.faces)]
    except filecheck.FileLimitError as e:
        raise ValueError(f"mesh file {str(path)!r}: {e}") from None
    except Exception as e:  # trimesh and pycollada raise many types for broken files
        raise ValueError(f"mesh file {str(path)!r}: unreadable as DAE: {type(e).__name__}: {e}") from None
    if not parts:
        raise ValueError(f"mesh file {str(path)!r}: holds no triangle mesh")
    vertices = np.concatenate(parts).astype(np.float64)
    if not np.all(np.isfinite(vertices)):
        raise ValueError(f"mesh file {str(path)!r}: a vertex coordinate is not finite")
    return vertices


# the World ---------------------------------------------------------------------------------------
def add_urdf(world, path, fixed_base: bool = False, package_dirs=(), *, position=(0.0, 0.0, 0.0),
             orientation=(1.0, 0.0, 0.0, 0.0), self_collision: bool = False, prefix: str = "",
             dynamics: bool = True) -> URDFRobot:
    """Adds the robot of a URDF file to ``world`` and returns its URDFRobot (module doc).

    ``fixed_base``: the root link's body is static (also when the root link's mass is 0, as in
    pybullet). ``position`` (3,) m, ``orientation`` (w, x, y, z): the root link frame in the world.
    ``self_collision``: False (pybullet's default) keeps all the robot's bodies from colliding with
    each other; True only jointed pairs. ``prefix`` goes before every body and joint name (two
    copies of a robot in one World). ``dynamics``: the joints' <dynamics> damping (a damper in the
    joint's motor slot) and friction are applied; False loads them limp and frictionless. Raises
    FileNotFoundError, URDFError (naming the file, the element and the problem) or ImportError
    (yourdfpy missing) before the World changes."""
    path = Path(path)
    package_dirs = [Path(d) for d in package_dirs]
    f = _File(path)
    try:
        base = _from_pose(np.asarray(position, dtype=np.float64), orientation)
    except (TypeError, ValueError) as e:
        raise URDFError(f"URDF file {str(path)!r}: bad base pose: {e}") from None
    if not np.all(np.isfinite(base)):
        raise URDFError(f"URDF file {str(path)!r}: the base pose must be finite and the orientation non-zero")
    try:
        plan = _plan(f, base, fixed_base, package_dirs, bool(dynamics))
        order, links, T_link, group_of, groups, root, joint_plans = plan
    except RecursionError as e:
        raise URDFError(f"URDF file {str(path)!r}: out of stack reading it ({type(e).__name__})") from None

    # names: free in the world before anything is added
    for g in groups:
        if prefix + g.links[0] in world.names:
            raise f.error("link", g.links[0], f"the World already has a body named {prefix + g.links[0]!r}")
    for j, *_ in joint_plans:
        if j.type in _MOVING and world.find_joint(prefix + j.name) >= 0:
            raise f.error("joint", j.name, f"the World already has a joint named {prefix + j.name!r}")

    added: list[int] = []
    try:
        body_of: dict = {}
        for g in groups:
            mat = f.contact(g.links[0])
            name = prefix + g.links[0]
            # a static body's frame is its first link's; a moving body's origin is its centre of
            # mass (nothing is re-centred when the inertia is given)
            origin = np.zeros(3) if g.static else g.com
            if g.parts:
                shape, filt = Compound([(s, (p - origin, R)) for s, (p, R) in g.parts]), {}
            else:
                shape, filt = Sphere(_PLACEHOLDER_RADIUS), dict(group=0, mask=0)
            if g.static:
                index = world.add_static(shape, position=g.T[:3, 3], orientation=_quat(g.T), name=name, **filt, **mat)
            else:
                index = world.add_body(shape, mass=g.mass, inertia=g.inertia, position=g.T[:3, :3] @ g.com + g.T[:3, 3],
                                       orientation=_quat(g.T), name=name, **filt, **mat)
            added.append(index)
            for link in g.links:
                body_of[link] = index
        joints: dict = {}
        for j in f.robot.joints:
            if j.type == "fixed":
                joints[j.name] = URDFJoint(j.name, j.type, j.parent, j.child, -1, math.nan, math.nan, math.inf, math.inf)
        for j, axis, lower, upper, effort, velocity, damping, friction in joint_plans:
            a, b = body_of[j.parent], body_of[j.child]
            index = -1
            if j.type in _MOVING:
                T = T_link[j.child]
                limits = None if math.isnan(lower) else (lower, upper)
                kind = Prismatic if j.type == "prismatic" else Revolute
                damper = Motor(0.0, math.inf, damping=damping) if damping > 0.0 else None
                index = world.add_joint(kind(a, b, anchor=T[:3, 3], axis=T[:3, :3] @ axis, limits=limits,
                                             motor=damper, friction=friction, name=prefix + j.name))
            else:  # floating: a free body
                world.disable_collision(a, b)
            joints[j.name] = URDFJoint(j.name, j.type, j.parent, j.child, index, lower, upper, effort, velocity,
                                       damping, friction)
        if not self_collision:
            for k, a in enumerate(added):
                for b in added[k + 1:]:
                    world.disable_collision(a, b)
    except (TypeError, ValueError) as e:
        # the core's own checks (a shape pair it cannot collide with the World's...): undone
        if added:
            world.remove_bodies(added)
        raise URDFError(f"URDF file {str(path)!r}: {e}") from None
    ordered = {j.name: joints[j.name] for j in f.robot.joints}
    return URDFRobot(world, f.robot.name, body_of[order[0]], {n: body_of[n] for n in order}, ordered)


def load_urdf(path, fixed_base: bool = False, package_dirs=(), *, world=None, **options):
    """The World of a URDF file (a new ``sg.World()``, or ``world`` with the robot added); the
    options (``position``, ``orientation``, ``self_collision``, ``prefix``, ``dynamics``) and errors as
    ``add_urdf``'s. The URDFRobot of the import: ``add_urdf``."""
    from .world import World

    w = World() if world is None else world
    add_urdf(w, path, fixed_base, package_dirs, **options)
    return w
