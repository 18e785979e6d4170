"""Rigid bodies from their meshes: mass properties (:func:`body_from_mesh`) and the boundary
particles moved into the mesh (:data:`INSET`, :func:`inset_samples`), so that the fluid rests at
the mesh surface.

A dynamic body has the mass ``M = rho V`` and the inertia tensor (body frame, about the centre of
mass) of its closed mesh (trimesh mass properties); in 2D those of the mesh's section with
z = 0 per metre of depth (:func:`sphkit.geometry.meshes.section_mass_properties`). A kinematic
body turns about its rotation centre (default: the mesh's centre of mass).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np

from sphkit.boundary.rigid.bodies import RigidBody
from sphkit.geometry.meshes import open_flux, section_mass_properties
from sphkit.geometry.sdf import tri_dist2

if TYPE_CHECKING:
    import trimesh

Vector = Sequence[float] | np.ndarray
_JIT = dict(cache=True, fastmath=True)

#: depth of a moving body's particles below its mesh surface, in particle radii. Measured for the
#: cubic kernel (h = 4r): fluid on the 2r lattice next to one Akinci layer of spacing 2r
#: (V_b = 1.43 (2r)^3) has its rest density 2.2r from the layer (1064 kg/m^3 at 2r, 999 at
#: 2.2r, 972 at 2.3r for rho0 = 1000), so a layer 1.2r inside the mesh lets the fluid rest r
#: outside the surface, as on the lattice (the scene's fluid blocks) and at scene boxes.
INSET = 1.2
#: the depth in 2D. Measured (DFSPH, a 2D tank 0.4 m wide and 0.2 m deep, r = 1 cm, at rest
#: after 1.5 s): the fluid's bottom layer rests 2.36 r above an Akinci floor sampled on the
#: mesh (2.39 r off the side walls), 1.36 r more than on the lattice; with 1.2 r a floating
#: square of density 500 and side 12 r sat 43-45 % submerged instead of 50 %.
INSET_2D = 1.3


#: the largest :func:`~sphkit.geometry.meshes.open_flux` of a dynamic body's mesh that is not
#: watertight: its volume moves by at most 0.1 % with the origin (the faces close geometrically)
OPEN_FLUX = 1e-3


def inset_depth(dim: int) -> float:
    """The depth [r] of a moving body's particles below its mesh in ``dim`` dimensions."""
    return INSET_2D if dim == 2 else INSET


@numba.njit(parallel=True, **_JIT)
def _faces_at(p, V, F, tol2, out):
    """out[k, :] = ids of up to out.shape[1] triangles within sqrt(tol2) of point k (-1: none)."""
    for k in numba.prange(p.shape[0]):
        c = 0
        for f in range(F.shape[0]):
            a, b, e = F[f, 0], F[f, 1], F[f, 2]
            d2 = tri_dist2(p[k, 0], p[k, 1], p[k, 2], V[a, 0], V[a, 1], V[a, 2], V[b, 0],
                           V[b, 1], V[b, 2], V[e, 0], V[e, 1], V[e, 2])
            if d2 <= tol2 and c < out.shape[1]:
                out[k, c] = f
                c += 1
        for j in range(c, out.shape[1]):
            out[k, j] = -1


def inset_samples(mesh: trimesh.Trimesh, pts: np.ndarray, depth: float) -> np.ndarray:
    """Move surface samples ``pts`` (M, 3) of a closed mesh ``depth`` into it: along the face
    normal, at edges and corners by the least-norm ``d`` with ``n_f . d = -depth`` for every
    face plane the sample lies on (a box's samples end up on the box shrunk by ``depth``), so
    that the fluid rests at the mesh surface (see :data:`INSET`)."""
    V = np.asarray(mesh.vertices, dtype=np.float64)
    F = np.asarray(mesh.faces, dtype=np.int64)
    N = np.asarray(mesh.face_normals, dtype=np.float64)
    ids = np.empty((len(pts), 8), dtype=np.int64)
    tol = 1e-6 * float(np.max(mesh.extents))
    _faces_at(np.ascontiguousarray(pts, dtype=np.float64), V, F, tol * tol, ids)
    out = np.array(pts, dtype=np.float64)
    for k in range(len(pts)):  # setup only, not in a time step
        f = ids[k][ids[k] >= 0]
        if f.size == 0:
            continue
        n = np.unique(np.round(N[f], 6), axis=0)
        d = np.linalg.lstsq(n, -depth * np.ones(len(n)), rcond=None)[0]
        out[k] += d
    return out


def body_from_mesh(name: str, mesh: trimesh.Trimesh, dynamic: bool, density: float,
                   velocity: Vector | None, angular_velocity: Vector | None,
                   rotation_center: Vector | None, friction: float, dim: int = 3,
                   restitution: float = 0.0) -> RigidBody:
    """A body from its closed mesh (placed at t = 0): mass properties for dynamic bodies (about
    the centre of mass), the pivot for kinematic ones; its contacts' ``friction`` and
    ``restitution``. 2D: the body is the section of the mesh with z = 0, moving in the
    xy-plane: mass per unit depth ``density * area`` [kg/m] and the polar moment ``density *
    J`` [kg m^2/m] (put on all three axes; only z turns), velocity (vx, vy, 0) and angular
    velocity (0, 0, w)."""
    contact = {"friction": friction, "restitution": restitution}
    v = np.zeros(3) if velocity is None else np.asarray(velocity, dtype=np.float64)
    w = np.zeros(3) if angular_velocity is None else np.asarray(angular_velocity, np.float64)
    if dim == 2:
        if v[2] != 0.0 or w[0] != 0.0 or w[1] != 0.0:
            raise ValueError(f"{name}: velocity {v.tolist()}, angular_velocity {w.tolist()}; "
                             "expected motion in the xy-plane in 2D: velocity (vx, vy, 0), "
                             "angular_velocity (0, 0, w)")
        area, cen, j = section_mass_properties(mesh)
        if not area > 0.0:
            raise ValueError(f"{name}: its section with z = 0 is not a closed region; expected "
                             "a closed mesh crossing z = 0")
        com = np.array([cen[0], cen[1], 0.0])
        if dynamic:
            return RigidBody(name, True, com, v, w, mass=density * area,
                             inertia=np.eye(3) * density * j, **contact)
        c = com if rotation_center is None else np.asarray(rotation_center, dtype=np.float64)
        c = np.array([c[0], c[1], 0.0])
        return RigidBody(name, False, c.copy(), v, w, c0=c.copy(), **contact)
    if dynamic:
        if not mesh.is_volume:
            flux = open_flux(mesh) if mesh.is_winding_consistent else float("inf")
            if not flux <= OPEN_FLUX:
                raise ValueError(f"{name}: the mesh is not a closed volume (watertight, "
                                 "consistently wound); expected one for a dynamic body's mass")
            warnings.warn(f"{name}: the mesh is not watertight, but its faces close (net vector "
                          f"area {flux:.1e} of its volume over its diagonal): its mass and "
                          "inertia are integrated over the surface as given", stacklevel=2)
        vol = float(mesh.volume)
        com = np.asarray(mesh.center_mass, dtype=np.float64)
        inertia = np.asarray(mesh.moment_inertia, dtype=np.float64) * density  # unit density
        return RigidBody(name, True, com.copy(), v, w, mass=density * vol, inertia=inertia,
                         **contact)
    if rotation_center is not None:
        c = np.asarray(rotation_center, dtype=np.float64)
    else:
        c = np.asarray(mesh.center_mass if mesh.is_volume else mesh.centroid, dtype=np.float64)
    return RigidBody(name, False, c.copy(), v, w, c0=c.copy(), **contact)
