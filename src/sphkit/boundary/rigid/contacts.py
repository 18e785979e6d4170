"""Contacts of rigid bodies with the static walls and with each other; :class:`BodyContacts` is
a base class of :class:`sphkit.boundary.rigid.RigidBodies`.

Contacts, all solved together (and with the joints,
:mod:`sphkit.boundary.rigid.joints_catto2005`) by a projected Gauss-Seidel on velocity impulses
(:func:`_contact_sweep`): the contact points of a body are its boundary particles, which keep a
distance ``1.2 r`` in 3D, 1.3 r in 2D (they lie that deep in the mesh, see
:func:`sphkit.boundary.rigid.construction.inset_depth`), and its mesh vertices, which keep 0 (the
extreme points of a tilted body, which the particles' margin does not cover); both keep the
scene's ``configuration.contact_tolerance`` on top (a skin around every mesh: SPlisHSPlasH's
PositionBasedDynamics ``contactTolerance``, whose contacts start within the tolerance of a
surface and push back to it). They meet

* the static walls (scene ``boxes``, analytic distance; static ``meshes``, their signed distance
  on a lattice of spacing r, interpolated trilinearly);
* every other moving body whose bounding sphere is within reach: the points of body A are
  taken into the frame of body B and meet B's signed distance, a lattice of spacing r in B's
  frame (:func:`body_sdf`, compiled trilinear interpolation :func:`_sdf_at`); for two dynamic
  bodies both directions are contacts. Kinematic bodies take part with infinite mass.

Each contact enforces ``phi(x_p) - margin + dt u_rel . n >= 0`` (speculative contacts; a
penetrating point is pushed out at ``0.5 depth / dt``) with Coulomb friction
``|lambda_t| <= mu lambda_n`` (mu: the body's friction at walls, the geometric mean of two
bodies' between them). With a restitution e > 0 (the body's at walls, the geometric mean of two
bodies'), a contact that the point reaches within the step (``phi - margin + dt u0 . n < 0``)
at a normal speed ``-u0 . n`` above ``2 |g| dt`` (below it the contact rests) enforces
``u_rel . n >= -e u0 . n`` instead, ``u0`` the velocity before the contacts: Newton's
restitution law at the contact, as PositionBasedDynamics' velocity solve does for
SPlisHSPlasH's bodies.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np

from sphkit.core.state import SimState
from sphkit.geometry.meshes import oriented_section

if TYPE_CHECKING:
    import trimesh

    from sphkit.boundary.rigid.bodies import RigidBody

Vector = Sequence[float] | np.ndarray
#: a wall's distance at points p (3, K) -> (K,), positive in free space
Distance = Callable[[np.ndarray], np.ndarray]
_JIT = dict(cache=True, fastmath=True)


@numba.njit(**_JIT)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@numba.njit(**_JIT)
def _apply(k, q0, q1, q2, j0, j1, j2, inv_m, Iinv, v, w):
    """Impulse j at offset q on body k (k < 0: a static wall, nothing moves)."""
    if k < 0:
        return
    v[k, 0] += inv_m[k] * j0
    v[k, 1] += inv_m[k] * j1
    v[k, 2] += inv_m[k] * j2
    a0, a1, a2 = _cross(q0, q1, q2, j0, j1, j2)
    w[k, 0] += Iinv[k, 0, 0] * a0 + Iinv[k, 0, 1] * a1 + Iinv[k, 0, 2] * a2
    w[k, 1] += Iinv[k, 1, 0] * a0 + Iinv[k, 1, 1] * a1 + Iinv[k, 1, 2] * a2
    w[k, 2] += Iinv[k, 2, 0] * a0 + Iinv[k, 2, 1] * a1 + Iinv[k, 2, 2] * a2


@numba.njit(**_JIT)
def _point_velocity(k, q0, q1, q2, v, w):
    if k < 0:
        return 0.0, 0.0, 0.0
    c0, c1, c2 = _cross(w[k, 0], w[k, 1], w[k, 2], q0, q1, q2)
    return v[k, 0] + c0, v[k, 1] + c1, v[k, 2] + c2


@numba.njit(**_JIT)
def _inv_mass_along(k, q0, q1, q2, n0, n1, n2, inv_m, Iinv):
    """``1/M + n . ((I^-1 (q x n)) x q)`` of body k along the unit vector n (0 for walls)."""
    if k < 0:
        return 0.0
    a0, a1, a2 = _cross(q0, q1, q2, n0, n1, n2)
    b0 = Iinv[k, 0, 0] * a0 + Iinv[k, 0, 1] * a1 + Iinv[k, 0, 2] * a2
    b1 = Iinv[k, 1, 0] * a0 + Iinv[k, 1, 1] * a1 + Iinv[k, 1, 2] * a2
    b2 = Iinv[k, 2, 0] * a0 + Iinv[k, 2, 1] * a1 + Iinv[k, 2, 2] * a2
    e0, e1, e2 = _cross(b0, b1, b2, q0, q1, q2)
    return inv_m[k] + n0 * e0 + n1 * e1 + n2 * e2


@numba.njit(**_JIT)
def _contact_sweep(ia, ib, qa, qb, n, bias, mu, inv_m, Iinv, v, w, lam, lt):
    """One projected Gauss-Seidel sweep over the contacts, on the velocities of the bodies:
    contact p pushes body ``ia[p]`` along the unit normal ``n[:, p]`` and body ``ib[p]`` (-1: a
    static wall) the other way, at offsets ``qa``, ``qb`` (3, K) from their centres.
    Constraints: relative normal velocity ``(u_a - u_b) . n >= bias`` (``u = v + w x q``) with
    accumulated normal impulses ``lam`` >= 0, and Coulomb friction ``|lambda_t| <= mu lambda_n``
    (accumulated tangential impulses ``lt`` (3, K)). ``v``, ``w`` (bodies, 3) are updated in
    place (kinematic bodies carry inv_m = 0, Iinv = 0 and keep their velocities); the sweeps
    of all constraints are run by :func:`sphkit.boundary.rigid.joints_catto2005.solve`."""
    K = ia.shape[0]
    for p in range(K):
        a, b = ia[p], ib[p]
        qa0, qa1, qa2 = qa[0, p], qa[1, p], qa[2, p]
        qb0, qb1, qb2 = qb[0, p], qb[1, p], qb[2, p]
        n0, n1, n2 = n[0, p], n[1, p], n[2, p]
        ua0, ua1, ua2 = _point_velocity(a, qa0, qa1, qa2, v, w)
        ub0, ub1, ub2 = _point_velocity(b, qb0, qb1, qb2, v, w)
        u0, u1, u2 = ua0 - ub0, ua1 - ub1, ua2 - ub2
        un = u0 * n0 + u1 * n1 + u2 * n2
        kn = (_inv_mass_along(a, qa0, qa1, qa2, n0, n1, n2, inv_m, Iinv)
              + _inv_mass_along(b, qb0, qb1, qb2, n0, n1, n2, inv_m, Iinv))
        if kn <= 0.0:
            continue
        dl = (bias[p] - un) / kn
        new = max(lam[p] + dl, 0.0)
        dl = new - lam[p]
        lam[p] = new
        j0 = dl * n0
        j1 = dl * n1
        j2 = dl * n2
        # friction: cancel the tangential relative velocity, |lambda_t| <= mu lambda_n
        t0 = u0 - un * n0
        t1 = u1 - un * n1
        t2 = u2 - un * n2
        ut = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        if ut > 1e-12:
            t0 /= ut
            t1 /= ut
            t2 /= ut
            kt = (_inv_mass_along(a, qa0, qa1, qa2, t0, t1, t2, inv_m, Iinv)
                  + _inv_mass_along(b, qb0, qb1, qb2, t0, t1, t2, inv_m, Iinv))
            d = -ut / kt
            o0 = lt[0, p] + d * t0
            o1 = lt[1, p] + d * t1
            o2 = lt[2, p] + d * t2
            mag = math.sqrt(o0 * o0 + o1 * o1 + o2 * o2)
            lim = mu[p] * lam[p]
            if mag > lim:
                o0 *= lim / mag
                o1 *= lim / mag
                o2 *= lim / mag
            j0 += o0 - lt[0, p]
            j1 += o1 - lt[1, p]
            j2 += o2 - lt[2, p]
            lt[0, p] = o0
            lt[1, p] = o1
            lt[2, p] = o2
        _apply(a, qa0, qa1, qa2, j0, j1, j2, inv_m, Iinv, v, w)
        _apply(b, qb0, qb1, qb2, -j0, -j1, -j2, inv_m, Iinv, v, w)


@numba.njit(parallel=True, **_JIT)
def _sdf_at(p, phi, lo, sp, out, grad):
    """Trilinear interpolation of the lattice signed distance ``phi`` (origin lo, spacing sp)
    at the points p (3, K), and its gradient (the trilinear's derivative); points outside the
    lattice get +inf (no contact)."""
    nx, ny, nz = phi.shape
    for k in numba.prange(p.shape[1]):
        fx = (p[0, k] - lo[0]) / sp
        fy = (p[1, k] - lo[1]) / sp
        fz = (p[2, k] - lo[2]) / sp
        if not (0.0 <= fx < nx - 1 and 0.0 <= fy < ny - 1 and 0.0 <= fz < nz - 1):
            out[k] = np.inf
            grad[0, k] = 0.0
            grad[1, k] = 0.0
            grad[2, k] = 1.0
            continue
        i, j, m = int(fx), int(fy), int(fz)
        tx, ty, tz = fx - i, fy - j, fz - m
        c000, c100 = phi[i, j, m], phi[i + 1, j, m]
        c010, c110 = phi[i, j + 1, m], phi[i + 1, j + 1, m]
        c001, c101 = phi[i, j, m + 1], phi[i + 1, j, m + 1]
        c011, c111 = phi[i, j + 1, m + 1], phi[i + 1, j + 1, m + 1]
        c00 = c000 + tx * (c100 - c000)
        c10 = c010 + tx * (c110 - c010)
        c01 = c001 + tx * (c101 - c001)
        c11 = c011 + tx * (c111 - c011)
        c0 = c00 + ty * (c10 - c00)
        c1 = c01 + ty * (c11 - c01)
        out[k] = c0 + tz * (c1 - c0)
        gx0 = (c100 - c000) + ty * ((c110 - c010) - (c100 - c000))
        gx1 = (c101 - c001) + ty * ((c111 - c011) - (c101 - c001))
        grad[0, k] = (gx0 + tz * (gx1 - gx0)) / sp
        grad[1, k] = ((c10 - c00) + tz * ((c11 - c01) - (c10 - c00))) / sp
        grad[2, k] = (c1 - c0) / sp


class BodyContacts:
    """The contacts of the moving bodies, a base class of
    :class:`sphkit.boundary.rigid.RigidBodies`: every dynamic body's contact points against the
    static walls and against the signed distance of every other body near it (module
    docstring), solved with the joints by :func:`sphkit.boundary.rigid.joints_catto2005.solve`
    (:meth:`_contact_rows`, :func:`_contact_sweep`). It reads the
    attributes ``bodies``, ``meshes``, ``walls``, ``margin``, ``contact_tolerance``,
    ``contact_iterations`` and
    ``joined`` and the
    particle selections ``_sel`` that :meth:`~sphkit.boundary.rigid.RigidBodies.init` sets."""

    bodies: list[RigidBody]
    meshes: list
    walls: list
    margin: float
    contact_tolerance: float
    contact_iterations: int
    joined: set[frozenset[int]]  #: pairs of bodies joined by a joint (they do not collide)
    _sel: list[np.ndarray]

    def _init_contacts(self, state: SimState) -> None:
        """Per body: its mesh vertices in the body frame (contact points), its signed distance
        lattice (:func:`body_sdf`) and its bounding radius about c (particles and vertices)."""
        bd = state.boundary
        self._verts, self._sdf, self._radius = [], [], []
        for k, rb in enumerate(self.bodies):
            if k < len(self.meshes):
                vl = rb.R.T @ (_contact_vertices(self.meshes[k], state.dim) - rb.c[:, None])
                self._sdf.append(body_sdf(self.meshes[k], rb.c, state.r))
            else:
                vl = np.zeros((3, 0))
                self._sdf.append((np.zeros(3), 1.0, np.full((2, 2, 2), np.inf)))
            xl = np.zeros((3, self._sel[k].size))
            xl[: state.dim] = bd["x_body"][:, self._sel[k]]
            self._verts.append(np.ascontiguousarray(vl))
            self._radius.append(float(np.max(np.linalg.norm(np.concatenate([vl, xl], axis=1),
                                                            axis=0), initial=0.0)))

    def _points(self, state: SimState, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Contact points of body k in world coordinates (3, K) and the distance each keeps from
        other surfaces: its boundary particles (``margin``, they lie that deep in the mesh) and
        its mesh vertices (0: the corners, which the particles' margin does not cover when the
        body is tilted)."""
        b = self.bodies[k]
        xp = np.zeros((3, self._sel[k].size))  # 2D: z = 0
        xp[: state.dim] = state.boundary["x"][:, self._sel[k]]
        xv = b.c[:, None] + b.R @ self._verts[k]
        marg = np.concatenate([np.full(xp.shape[1], self.margin), np.zeros(xv.shape[1])])
        return np.concatenate([xp, xv], axis=1), marg + self.contact_tolerance

    @staticmethod
    def _row_velocity(k: np.ndarray, q: np.ndarray, v: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Velocities (3, K) of the contact points at offsets ``q`` of bodies ``k`` (-1: a
        static wall, zero)."""
        kk = np.maximum(k, 0)
        u = v[kk].T + np.cross(w[kk], q.T).T
        return np.where(k >= 0, u, 0.0)

    def _contact_rows(self, state: SimState, v: np.ndarray, w: np.ndarray, dt: float
                      ) -> tuple[np.ndarray, ...]:
        """The contacts of this step (module docstring) for :func:`_contact_sweep`: every
        dynamic body's points against the static walls, and the points of each body against
        the signed distance of every other body near it (both directions for two dynamic
        bodies), as ``(ia, ib, qa, qb, n, bias, mu)`` (no contact: K = 0 rows); ``v``, ``w``
        (bodies, 3) are the bodies' velocities before the contacts."""
        nb = len(self.bodies)
        joined = self.joined
        pts = [self._points(state, k) for k in range(nb)]
        speed = []  # fastest point of each body [m/s]
        for k, b in enumerate(self.bodies):
            q = pts[k][0] - b.c[:, None]
            u = v[k][:, None] + np.cross(w[k], q.T).T
            speed.append(float(np.max(np.linalg.norm(u, axis=0))) if q.shape[1] else 0.0)
        ia, ib, qa, qb, nn, phis = [], [], [], [], [], []

        def add(a: int, bk: int, sel: np.ndarray, x: np.ndarray, n: np.ndarray,
                phi: np.ndarray) -> None:
            ia.append(np.full(sel.size, a))
            ib.append(np.full(sel.size, bk))
            qa.append(x - self.bodies[a].c[:, None])
            qb.append(x - (self.bodies[bk].c[:, None] if bk >= 0 else 0.0))
            nn.append(n)
            phis.append(phi)

        for a, ba in enumerate(self.bodies):
            x, marg = pts[a]
            if ba.dynamic:
                reach = dt * speed[a] + 1e-9
                for dist, _name in self.walls:
                    phi = dist(x) - marg
                    near = np.flatnonzero(phi < reach)
                    if near.size:
                        add(a, -1, near, x[:, near], _normals(dist, x[:, near]), phi[near])
            for bk, bb in enumerate(self.bodies):
                if bk == a or not (ba.dynamic or bb.dynamic) or frozenset((a, bk)) in joined:
                    continue  # joined bodies do not collide
                reach = dt * (speed[a] + speed[bk]) + 1e-9
                if (np.linalg.norm(ba.c - bb.c)
                        > self._radius[a] + self._radius[bk] + reach + self.contact_tolerance):
                    continue  # bounding spheres apart
                xl = np.ascontiguousarray(bb.R.T @ (x - bb.c[:, None]))
                phi = np.empty(xl.shape[1])
                grad = np.empty_like(xl)
                lo, sp, lat = self._sdf[bk]
                _sdf_at(xl, lat, lo, sp, phi, grad)
                phi -= marg
                near = np.flatnonzero(phi < reach)
                if near.size:
                    gn = grad[:, near]
                    n = bb.R @ (gn / np.maximum(np.linalg.norm(gn, axis=0), 1e-12))
                    add(a, bk, near, x[:, near], n, phi[near])
        if not ia:
            z = np.zeros((3, 0))
            return (np.zeros(0, np.int64), np.zeros(0, np.int64), z, z.copy(), z.copy(),
                    np.zeros(0), np.zeros(0))
        phi = np.concatenate(phis)
        # speculative: phi + dt u.n >= 0; penetration pushed out at half its depth per step
        bias = np.where(phi >= 0.0, -phi / dt, -0.5 * phi / dt)
        ia_, ib_ = np.concatenate(ia), np.concatenate(ib)
        qa_, qb_, n_ = (np.ascontiguousarray(np.concatenate(a, axis=1)) for a in (qa, qb, nn))

        def pair(values: list[float]) -> np.ndarray:  # the body's at a wall, else the mean
            x = np.array(values)
            return np.where(ib_ >= 0, np.sqrt(x[ia_] * x[np.maximum(ib_, 0)]), x[ia_])

        mu = pair([b.friction for b in self.bodies])
        e = pair([b.restitution for b in self.bodies])
        if np.any(e > 0.0):  # restitution: a contact met this step leaves at -e u.n
            un = np.einsum("ij,ij->j", self._row_velocity(ia_, qa_, v, w)
                           - self._row_velocity(ib_, qb_, v, w), n_)
            rest = max(2.0 * float(np.linalg.norm(state.gravity)) * dt, 1e-3)  # resting contact
            hit = (e > 0.0) & (un < -rest) & (phi + dt * un < 0.0)
            bias = np.where(hit, np.maximum(bias, -e * un), bias)
        return ia_.astype(np.int64), ib_.astype(np.int64), qa_, qb_, n_, bias, mu


def _normals(dist, p: np.ndarray, eps: float = 1e-5) -> np.ndarray:
    """Unit gradients of the distance at points p (3, K) by central differences."""
    g = np.empty_like(p)
    for d in range(3):
        e = np.zeros((3, 1))
        e[d] = eps
        g[d] = (dist(p + e) - dist(p - e)) / (2.0 * eps)
    return g / np.maximum(np.linalg.norm(g, axis=0), 1e-12)


def body_sdf(mesh: trimesh.Trimesh, c: np.ndarray, r: float, max_points: int = 96
             ) -> tuple[np.ndarray, float, np.ndarray]:
    """Signed distance of a body's closed mesh (placed at t = 0, centre c, so that the body
    frame is the scene frame shifted by c) on a lattice in its body frame: ``(lo, spacing,
    phi)``, spacing r (coarser for large bodies: at most ``max_points`` per axis), 3 spacings
    beyond the mesh on every side (:func:`sphkit.geometry.sdf.mesh_sdf_lattice`)."""
    from sphkit.geometry.sdf import mesh_sdf_lattice

    V = np.asarray(mesh.vertices, dtype=np.float64) - np.asarray(c, dtype=np.float64)
    sp = max(r, float(np.max(V.max(axis=0) - V.min(axis=0))) / (max_points - 7))
    lo = V.min(axis=0) - 3.0 * sp
    shape = np.ceil((V.max(axis=0) + 3.0 * sp - lo) / sp).astype(np.int64) + 1
    phi = mesh_sdf_lattice(V, mesh.faces, lo, [sp] * 3, shape)
    return lo, sp, np.ascontiguousarray(phi)


def box_wall(lo: Vector, hi: Vector, open_axis: int | None) -> Distance:
    """Distance to the walls of a container box [lo, hi] (positive inside; open_axis: no lid)."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64).copy()
    if open_axis is not None:
        hi[open_axis] = np.inf

    def dist(p: np.ndarray) -> np.ndarray:
        return np.minimum(p - lo[:, None], hi[:, None] - p).min(axis=0)

    return dist


def mesh_wall(mesh: trimesh.Trimesh, invert: bool = False, spacing: float = 0.01) -> Distance:
    """Distance to a static mesh (positive outside the mesh; ``invert``: a container), from its
    signed distance on a lattice of the given spacing [m] (:func:`sphkit.geometry.sdf.
    mesh_sdf_lattice`) interpolated trilinearly."""
    from scipy.interpolate import RegularGridInterpolator

    from sphkit.geometry.sdf import mesh_sdf_lattice

    lo = np.asarray(mesh.bounds[0], dtype=np.float64) - 3.0 * spacing
    hi = np.asarray(mesh.bounds[1], dtype=np.float64) + 3.0 * spacing
    shape = np.ceil((hi - lo) / spacing).astype(np.int64) + 1
    d = mesh_sdf_lattice(mesh.vertices, mesh.faces, lo, [spacing] * 3, shape)
    axes = [lo[k] + spacing * np.arange(shape[k]) for k in range(3)]
    f = RegularGridInterpolator(axes, -d if invert else d, bounds_error=False, fill_value=None)

    def dist(p: np.ndarray) -> np.ndarray:
        return f(p.T)

    return dist


def _contact_vertices(mesh, dim: int) -> np.ndarray:
    """Contact points of a body's mesh (3, K): its vertices; 2D: the ends of its section's
    segments (z = 0)."""
    if dim == 3:
        return np.asarray(mesh.vertices, dtype=np.float64).T
    a, _b = oriented_section(mesh)
    return np.concatenate([a.T, np.zeros((1, len(a)))])
