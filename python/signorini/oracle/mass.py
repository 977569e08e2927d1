"""Mass properties of the shapes (docs/conventions.md, "Mass properties"; the capsule, cylinder
and compound formulas as in cpp/include/signorini/mass_properties.hpp).

Every function returns ``(m, com, I)``:
    m   -- mass, kg (float)
    com -- centre of mass, (3,), m, in the frame the shape is given in
    I   -- inertia tensor about the COM, (3, 3), kg m^2, in the same axes

Density ``rho`` is in kg/m^3.  A body given ``mass`` instead of ``density`` uses
rho = mass / volume (``mass_properties``).
"""

import numpy as np


def volume_sphere(radius):
    """Volume of a ball of radius ``radius`` (m) -> m^3."""
    return 4.0 / 3.0 * np.pi * radius**3


def volume_box(half_extents):
    """Volume of a box with half extents (a, b, c), (3,) m -> m^3."""
    a, b, c = np.asarray(half_extents, dtype=float)
    return 8.0 * a * b * c


def mass_properties_sphere(radius, density):
    """Solid sphere of radius r (m) and density rho (kg/m^3).

    m = rho 4/3 pi r^3,  com = 0,  I = 2/5 m r^2 I3.
    """
    m = density * volume_sphere(radius)
    I = 2.0 / 5.0 * m * radius**2 * np.eye(3)
    return m, np.zeros(3), I


def mass_properties_box(half_extents, density):
    """Solid box with half extents (a, b, c), (3,) m, centred on the origin, box axes.

    m = 8 rho a b c,  com = 0,  I = m/3 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2).
    """
    a, b, c = np.asarray(half_extents, dtype=float)
    m = density * volume_box(half_extents)
    I = m / 3.0 * np.diag([b**2 + c**2, a**2 + c**2, a**2 + b**2])
    return m, np.zeros(3), I


def mesh_volume_integrals(vertices, faces):
    """Volume integrals of a closed, outward-oriented triangle mesh (divergence theorem).

    The solid is cut into signed tetrahedra (0, v0, v1, v2), one per face.  For one such
    tetrahedron with edge matrix E = [v0 v1 v2] (columns):
        V_f          = det(E) / 6                                      (signed volume)
        int x dV     = V_f (v0 + v1 + v2) / 4                          (first moment)
        int x x^T dV = V_f / 20 (v0 v0^T + v1 v1^T + v2 v2^T + s s^T),  s = v0 + v1 + v2
    (the origin is the fourth vertex and contributes nothing).  Summing over faces gives the
    integrals over the solid; the signs cancel the parts outside it.

    Inputs:  vertices (n, 3) m, faces (k, 3) int, counter-clockwise seen from outside.
    Outputs: V (float, m^3), first moment (3,) m^4, second moment C = int x x^T dV (3, 3) m^5,
             all about the origin of the vertices' frame.
    """
    X = np.asarray(vertices, dtype=float)
    F = np.asarray(faces, dtype=np.int64)
    v0, v1, v2 = X[F[:, 0]], X[F[:, 1]], X[F[:, 2]]        # (k, 3) each
    V_f = np.einsum("ki,ki->k", v0, np.cross(v1, v2)) / 6.0  # det[v0 v1 v2] / 6, (k,)
    s = v0 + v1 + v2                                        # (k, 3)
    V = V_f.sum()
    first = (V_f[:, None] * s).sum(axis=0) / 4.0
    outer = (np.einsum("ki,kj->kij", v0, v0) + np.einsum("ki,kj->kij", v1, v1)
             + np.einsum("ki,kj->kij", v2, v2) + np.einsum("ki,kj->kij", s, s))
    C = (V_f[:, None, None] * outer).sum(axis=0) / 20.0
    return V, first, C


def mass_properties_mesh(vertices, faces, density):
    """Solid bounded by a closed, outward-oriented triangle mesh, uniform density.

    Inputs:  vertices (n, 3) m in any frame, faces (k, 3) int, density rho kg/m^3.
    Outputs: m (kg), com (3,) in the vertices' frame, I (3, 3) about the COM in the
             vertices' axes.
    m = rho V, com = (int x dV) / V, and with C_com = int (x - com)(x - com)^T dV
    = C - V com com^T (parallel-axis theorem), I = rho (tr(C_com) I3 - C_com).
    """
    V, first, C = mesh_volume_integrals(vertices, faces)
    if not V > 0.0:
        raise ValueError(f"mesh volume {V} is not positive: mesh not closed or inward-oriented")
    com = first / V
    C_com = C - V * np.outer(com, com)
    m = density * V
    I = density * (np.trace(C_com) * np.eye(3) - C_com)
    return m, com, I


def volume_cylinder(radius, half_height):
    """Volume of a cylinder of radius r and half height h (m) -> m^3: pi r^2 (2 h)."""
    return np.pi * radius**2 * 2.0 * half_height


def volume_capsule(radius, half_length):
    """Volume of a capsule (radius r, segment half length h, m) -> m^3: pi r^2 2h + 4/3 pi r^3."""
    return volume_cylinder(radius, half_length) + volume_sphere(radius)


def mass_properties_cylinder(radius, half_height, density):
    """Solid cylinder of radius r and half height h (m) about the z axis, centred on the origin.

    With H = 2 h the full height: m = rho pi r^2 H,  com = 0,
    I = diag(m (3 r^2 + H^2) / 12, m (3 r^2 + H^2) / 12, m r^2 / 2).
    """
    r, h = float(radius), float(half_height)
    m = density * volume_cylinder(r, h)
    I_xx = m * (r**2 / 4.0 + h**2 / 3.0)  # = m (3 r^2 + (2h)^2) / 12
    return m, np.zeros(3), np.diag([I_xx, I_xx, 0.5 * m * r**2])


def mass_properties_capsule(radius, half_length, density):
    """Solid capsule: the points within r of the segment z in [-h, h] on the z axis (m).

    A cylinder of height 2 h (mass m_c = rho pi r^2 2h) and two hemispheres (m_s = rho 4/3 pi r^3
    together).  Second moments about the centre: the cylinder gives int x^2 dm = m_c r^2 / 4 and
    int z^2 dm = m_c h^2 / 3; the hemispheres int x^2 dm = m_s r^2 / 5 (as the whole ball) and
    int z^2 dm = m_s r^2 / 5 + 2 h m_s (3 r / 8) + m_s h^2 (each half shifted by h, its centroid
    3 r / 8 from its flat face).  I_zz = 2 int x^2 dm, I_xx = I_yy = int x^2 dm + int z^2 dm:
        I_zz = m_c r^2 / 2 + 2/5 m_s r^2
        I_xx = m_c (r^2 / 4 + h^2 / 3) + m_s (2/5 r^2 + 3/4 h r + h^2).
    com = 0; h = 0 is the sphere.
    """
    r, h = float(radius), float(half_length)
    m_c = density * volume_cylinder(r, h)
    m_s = density * volume_sphere(r)
    I_zz = 0.5 * m_c * r**2 + 0.4 * m_s * r**2
    I_xx = m_c * (r**2 / 4.0 + h**2 / 3.0) + m_s * (0.4 * r**2 + 0.75 * h * r + h**2)
    return m_c + m_s, np.zeros(3), np.diag([I_xx, I_xx, I_zz])


def mass_properties_hull(vertices, faces, density):
    """Convex hull given by its vertices (n, 3) m and outward triangles (k, 3): the closed-mesh
    routine (``mass_properties_mesh``) on its triangulation."""
    return mass_properties_mesh(vertices, faces, density)


def mass_properties_compound(parts, density):
    """Union of convex parts, each ``(shape dict, position (3,) m, rotation R (3, 3))`` with R the
    compound-from-part rotation; the parts should not overlap (an overlap counts twice).

    Each part p has (m_p, c_p, I_p) in its own frame.  In the compound frame its COM is
    x_p = R_p c_p + t_p and its inertia about x_p is R_p I_p R_p^T.  Then
        m = sum m_p,  com = sum m_p x_p / m,
        I = sum [ R_p I_p R_p^T + m_p (|d_p|^2 I3 - d_p d_p^T) ],  d_p = x_p - com
    (parallel-axis theorem), in compound axes.
    """
    props = []
    for shape, position, R in parts:
        m_p, c_p, I_p = mass_properties(shape, density=density)
        R = np.asarray(R, dtype=float)
        props.append((m_p, R @ c_p + np.asarray(position, dtype=float), R @ I_p @ R.T))
    m = sum(p[0] for p in props)
    com = sum(p[0] * p[1] for p in props) / m
    I = np.zeros((3, 3))
    for m_p, x_p, I_p in props:
        d = x_p - com
        I += I_p + m_p * (d @ d * np.eye(3) - np.outer(d, d))
    return m, com, I


def shape_volume(shape):
    """Volume (m^3) of a shape dict (sphere, box, mesh, capsule, cylinder, hull, compound: the sum
    of its parts).  Planes and triangle meshes have none: ValueError."""
    kind = shape["type"]
    if kind == "sphere":
        return volume_sphere(shape["radius"])
    if kind == "box":
        return volume_box(shape["half_extents"])
    if kind in ("mesh", "hull"):
        return mesh_volume_integrals(shape["vertices"], shape["faces"])[0]
    if kind == "capsule":
        return volume_capsule(shape["radius"], shape["half_length"])
    if kind == "cylinder":
        return volume_cylinder(shape["radius"], shape["half_height"])
    if kind == "compound":
        return sum(shape_volume(part) for part, _, _ in shape["parts"])
    raise ValueError(f"shape {kind!r} has no volume; it can only be static")


def mass_properties(shape, density=None, mass=None):
    """Mass properties of a shape dict, given exactly one of density (kg/m^3) or mass (kg).

    Dispatches to ``mass_properties_sphere``, ``_box``, ``_mesh``, ``_capsule``, ``_cylinder``,
    ``_hull`` or ``_compound``; a given mass uses density = mass / volume.  Planes and triangle
    meshes have no mass (they are static only): ValueError.
    Output: (m, com (3,), I (3, 3) about the COM), shape frame.
    """
    if (density is None) == (mass is None):
        raise ValueError("give exactly one of density or mass")
    if density is None:
        density = mass / shape_volume(shape)
    kind = shape["type"]
    if kind == "sphere":
        return mass_properties_sphere(shape["radius"], density)
    if kind == "box":
        return mass_properties_box(shape["half_extents"], density)
    if kind == "mesh":
        return mass_properties_mesh(shape["vertices"], shape["faces"], density)
    if kind == "capsule":
        return mass_properties_capsule(shape["radius"], shape["half_length"], density)
    if kind == "cylinder":
        return mass_properties_cylinder(shape["radius"], shape["half_height"], density)
    if kind == "hull":
        return mass_properties_hull(shape["vertices"], shape["faces"], density)
    if kind == "compound":
        return mass_properties_compound(shape["parts"], density)
    raise ValueError(f"shape {kind!r} has no mass properties; it can only be static")
