"""Mass properties of the shapes (docs/conventions.md, "Mass properties").

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


def shape_volume(shape):
    """Volume (m^3) of a shape dict (sphere, box or mesh)."""
    kind = shape["type"]
    if kind == "sphere":
        return volume_sphere(shape["radius"])
    if kind == "box":
        return volume_box(shape["half_extents"])
    if kind == "mesh":
        return mesh_volume_integrals(shape["vertices"], shape["faces"])[0]
    raise ValueError(f"shape {kind!r} has no volume")


def mass_properties(shape, density=None, mass=None):
    """Mass properties of a shape dict, given exactly one of density (kg/m^3) or mass (kg).

    Dispatches to ``mass_properties_sphere``, ``_box`` or ``_mesh``; a given mass uses
    density = mass / volume.  Planes have no mass (they are static only): ValueError.
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
    raise ValueError(f"shape {kind!r} has no mass properties")
