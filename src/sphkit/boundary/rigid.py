"""Rigid bodies coupled two-way with the fluid through boundary particles: Akinci et al. 2012,
"Versatile rigid-fluid coupling for incompressible SPH", ACM TOG 31(4).

A body is a closed triangle mesh whose surface is sampled into boundary particles (one layer,
:func:`sphkit.scene.sampling.sample_mesh_surface`). Three kinds:

* static: the particles never move (handled as any static wall);
* kinematic: a prescribed motion, constant velocity ``v`` of the pivot ``c0`` and constant
  angular velocity ``omega`` about it: ``x(t) = c0 + v t + R(t) (x(0) - c0)``,
  ``R(t) = exp([omega] t)``; the boundary velocity is ``v + omega x (x - c(t))``;
* dynamic: mass ``M = rho V`` and inertia tensor (body frame, about the centre of mass) of the
  closed mesh (trimesh mass properties), moved by gravity, the fluid and contacts.

Particles of a moving body keep the Akinci volume of Eq. (4) computed once in its body frame
from its own particles only, ``V_b = 1 / sum_k W_bk`` (the sum over the body's particles; the
sampling does not change as the body moves). Each step their positions and velocities (boundary
fields ``x``, ``v``; the solvers read ``v`` in their divergence terms) follow the body's pose,
and the boundary grid is rebuilt.

Fluid forces: the boundary pressure term of the paper's Eq. (10) acts on fluid particle i, and
its reaction on boundary particle b is minus it, ``F_b<-i = -m_i a_i<-b``, summed over the
body into a force ``F = sum_b F_b`` and a torque ``T = sum_b (x_b - c) x F_b``. The boundary
share of the pressure acceleration is taken from the very expression each solver applies, so
that momentum is conserved to round-off:

* WCSPH (:func:`sphkit.core.operators.pressure_accel_body`):
  ``a_i<-b = -rho0 V_b (p_i / rho_i^2 + p_i / rho0^2) grad W_ib``;
* DFSPH, IISPH, PCISPH (:func:`sphkit.core.ppe.kappa_accel_cached`):
  ``a_i<-b = -(1 + m_b) V_b k_i grad W_ib`` with ``k_i = p_i rho0 / rho_i^2`` (DFSPH: density
  and divergence solves together, IISPH) or ``k_i = p_i / rho0`` (PCISPH); ``m_b`` is the
  boundary field ``pressure_mirror``.

PBF moves positions and is not coupled (a scene with a dynamic body and PBF is rejected).
Viscous boundary forces are not transferred to bodies.

Dynamic bodies are advanced with symplectic Euler on linear and angular momentum:
``v += dt (F / M + g)``, ``omega += dt I_w^-1 (T - omega x I_w omega)`` with the world inertia
``I_w = R I R^T``, then contacts, then ``c += dt v``, ``R <- exp([omega] dt) R``.

Contacts with static walls (scene ``boxes``, analytic distance; static ``meshes``, their signed
distance on a lattice of spacing r): every boundary particle of the body is a contact point; a
projected Gauss-Seidel on velocity impulses enforces ``phi(x_p) - 1.2 r + dt u_p . n >= 0`` (the
particles lie 1.2 r inside the mesh, see :data:`INSET`; speculative contacts: restitution 0,
a penetrating point is pushed out at ``0.5 depth / dt``) with Coulomb friction
``|lambda_t| <= mu lambda_n``. Contacts between two bodies are not handled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np

from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.neighbors import neighbor_lists
from sphkit.core.sdf import tri_dist2
from sphkit.core.state import SimState

_JIT = dict(cache=True, fastmath=True)

#: depth of a moving body's particles below its mesh surface, in particle radii. Measured for the
#: cubic kernel (h = 4r): fluid on the 2r lattice next to one Akinci layer of spacing 2r
#: (V_b = 1.43 (2r)^3) has its rest density 2.2r from the layer (1064 kg/m^3 at 2r, 999 at
#: 2.2r, 972 at 2.3r for rho0 = 1000), so a layer 1.2r inside the mesh lets the fluid rest r
#: outside the surface, as on the lattice (the scene's fluid blocks) and at scene boxes.
INSET = 1.2


# ---------------------------------------------------------------------------------------------
# compiled passes


@numba.njit(parallel=True, **_JIT)
def _volumes(x, off, idx, h, kid, dim, V):
    """Akinci et al. 2012, Eq. (4): ``V_b = 1 / sum_k W_bk`` (self included)."""
    for b in numba.prange(x.shape[1]):
        s = kernel_w(kid, 0.0, h, dim)
        for k in range(off[b], off[b + 1]):
            j = idx[k]
            r2 = 0.0
            for d in range(dim):
                t = x[d, b] - x[d, j]
                r2 += t * t
            s += kernel_w(kid, np.sqrt(r2), h, dim)
        V[b] = 1.0 / s


@numba.njit(parallel=True, **_JIT)
def _pose(xl, body, c, R, v, w, x, bv):
    """World positions and velocities of the particles of moving bodies (body id > 0):
    ``x = c + R x_l``, ``v_b = v + omega x (R x_l)`` (3D)."""
    for b in numba.prange(x.shape[1]):
        k = body[b] - 1
        if k < 0:
            continue
        r0 = R[k, 0, 0] * xl[0, b] + R[k, 0, 1] * xl[1, b] + R[k, 0, 2] * xl[2, b]
        r1 = R[k, 1, 0] * xl[0, b] + R[k, 1, 1] * xl[1, b] + R[k, 1, 2] * xl[2, b]
        r2 = R[k, 2, 0] * xl[0, b] + R[k, 2, 1] * xl[1, b] + R[k, 2, 2] * xl[2, b]
        x[0, b] = c[k, 0] + r0
        x[1, b] = c[k, 1] + r1
        x[2, b] = c[k, 2] + r2
        bv[0, b] = v[k, 0] + w[k, 1] * r2 - w[k, 2] * r1
        bv[1, b] = v[k, 1] + w[k, 2] * r0 - w[k, 0] * r2
        bv[2, b] = v[k, 2] + w[k, 0] * r1 - w[k, 1] * r0


@numba.njit(parallel=True, **_JIT)
def _reaction(x, m, kf, boff, bidx, bx, bV, bmirror, use_mirror, body, c, h, kid, nchunk, out):
    """Per body: force and torque (about c) of the fluid on its boundary particles,
    ``F_b = sum_i m_i kf_i (1 + use_mirror m_b) V_b grad_i W_ib`` (the negative of the boundary
    share of ``m_i a_i``); ``out[chunk, body, 0:3]`` force, ``3:6`` torque, summed over chunks of
    fluid particles by the caller (no write races)."""
    n = x.shape[1]
    out[:] = 0.0
    per = (n + nchunk - 1) // nchunk
    for ch in numba.prange(nchunk):
        for i in range(ch * per, min(n, (ch + 1) * per)):
            fi = m[i] * kf[i]
            for kk in range(boff[i], boff[i + 1]):
                b = bidx[kk]
                k = body[b] - 1
                if k < 0:
                    continue
                d0 = x[0, i] - bx[0, b]
                d1 = x[1, i] - bx[1, b]
                d2 = x[2, i] - bx[2, b]
                r = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                s = fi * (1.0 + use_mirror * bmirror[b]) * bV[b] * kernel_dw(kid, r, h, 3)
                f0 = s * d0
                f1 = s * d1
                f2 = s * d2
                out[ch, k, 0] += f0
                out[ch, k, 1] += f1
                out[ch, k, 2] += f2
                q0 = bx[0, b] - c[k, 0]
                q1 = bx[1, b] - c[k, 1]
                q2 = bx[2, b] - c[k, 2]
                out[ch, k, 3] += q1 * f2 - q2 * f1
                out[ch, k, 4] += q2 * f0 - q0 * f2
                out[ch, k, 5] += q0 * f1 - q1 * f0


@numba.njit(**_JIT)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@numba.njit(**_JIT)
def _contacts(q, n, bias, inv_m, Iinv, v, w, mu, iterations):
    """Projected Gauss-Seidel on the velocity of one body: contact points at ``q`` (3, K)
    relative to the centre of mass, wall normals ``n`` (3, K), constraints ``u_p . n >= bias``
    (``u_p = v + w x q``), accumulated normal impulses >= 0 and Coulomb friction. ``v``, ``w``
    are updated in place."""
    K = q.shape[1]
    lam = np.zeros(K)
    lt = np.zeros((3, K))
    for _it in range(iterations):
        for p in range(K):
            q0, q1, q2 = q[0, p], q[1, p], q[2, p]
            n0, n1, n2 = n[0, p], n[1, p], n[2, p]
            c0, c1, c2 = _cross(w[0], w[1], w[2], q0, q1, q2)
            u0, u1, u2 = v[0] + c0, v[1] + c1, v[2] + c2
            un = u0 * n0 + u1 * n1 + u2 * n2
            # effective inverse mass along n: 1/M + n . ((I^-1 (q x n)) x q)
            a0, a1, a2 = _cross(q0, q1, q2, n0, n1, n2)
            b0 = Iinv[0, 0] * a0 + Iinv[0, 1] * a1 + Iinv[0, 2] * a2
            b1 = Iinv[1, 0] * a0 + Iinv[1, 1] * a1 + Iinv[1, 2] * a2
            b2 = Iinv[2, 0] * a0 + Iinv[2, 1] * a1 + Iinv[2, 2] * a2
            e0, e1, e2 = _cross(b0, b1, b2, q0, q1, q2)
            kn = inv_m + n0 * e0 + n1 * e1 + n2 * e2
            dl = (bias[p] - un) / kn
            new = max(lam[p] + dl, 0.0)
            dl = new - lam[p]
            lam[p] = new
            # friction: cancel the tangential velocity, |lambda_t| <= mu lambda_n
            t0 = u0 - un * n0
            t1 = u1 - un * n1
            t2 = u2 - un * n2
            ut = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            j0 = dl * n0
            j1 = dl * n1
            j2 = dl * n2
            if ut > 1e-12:
                t0 /= ut
                t1 /= ut
                t2 /= ut
                a0, a1, a2 = _cross(q0, q1, q2, t0, t1, t2)
                b0 = Iinv[0, 0] * a0 + Iinv[0, 1] * a1 + Iinv[0, 2] * a2
                b1 = Iinv[1, 0] * a0 + Iinv[1, 1] * a1 + Iinv[1, 2] * a2
                b2 = Iinv[2, 0] * a0 + Iinv[2, 1] * a1 + Iinv[2, 2] * a2
                e0, e1, e2 = _cross(b0, b1, b2, q0, q1, q2)
                kt = inv_m + t0 * e0 + t1 * e1 + t2 * e2
                d = -ut / kt
                o0 = lt[0, p] + d * t0
                o1 = lt[1, p] + d * t1
                o2 = lt[2, p] + d * t2
                mag = math.sqrt(o0 * o0 + o1 * o1 + o2 * o2)
                lim = mu * lam[p]
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
            v[0] += inv_m * j0
            v[1] += inv_m * j1
            v[2] += inv_m * j2
            a0, a1, a2 = _cross(q0, q1, q2, j0, j1, j2)
            w[0] += Iinv[0, 0] * a0 + Iinv[0, 1] * a1 + Iinv[0, 2] * a2
            w[1] += Iinv[1, 0] * a0 + Iinv[1, 1] * a1 + Iinv[1, 2] * a2
            w[2] += Iinv[2, 0] * a0 + Iinv[2, 1] * a1 + Iinv[2, 2] * a2


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


def inset_samples(mesh, pts: np.ndarray, depth: float) -> np.ndarray:
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


# ---------------------------------------------------------------------------------------------
# bodies


def rotation(omega: np.ndarray, t: float) -> np.ndarray:
    """``exp([omega] t)``: the rotation by angle ``|omega| t`` about ``omega`` (Rodrigues)."""
    w = np.asarray(omega, dtype=np.float64)
    ang = float(np.linalg.norm(w)) * t
    if ang == 0.0:
        return np.eye(3)
    k = w / np.linalg.norm(w)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(ang) * K + (1.0 - math.cos(ang)) * (K @ K)


@dataclass
class RigidBody:
    """One moving body (kinematic or dynamic); vectors in world coordinates, SI units.

    ``c`` is the centre of mass (dynamic) or the pivot (kinematic), ``R`` the rotation from the
    body frame, ``v`` / ``omega`` the velocity of c and the angular velocity. ``force`` and
    ``torque`` (about c) are the fluid's on the body in the last step."""

    name: str
    dynamic: bool
    c: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    mass: float = 0.0  #: [kg] (dynamic)
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  #: body frame [kg m^2]
    friction: float = 0.5
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    c0: np.ndarray | None = None  #: kinematic: pivot at t = 0
    force: np.ndarray = field(default_factory=lambda: np.zeros(3))
    torque: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def world_inertia(self) -> np.ndarray:
        """``I_w = R I R^T`` [kg m^2]."""
        return self.R @ self.inertia @ self.R.T

    def stats(self) -> dict:
        """Plain-dict state for step statistics (lists of floats): the pose is ``position`` (c)
        and ``rotation`` (R, row-major 3x3), so that a point of the body is at
        ``x = R x_body + c`` (``x_body``: its position in the body frame, which is the scene
        placement at t = 0 minus the t = 0 position)."""
        return {"name": self.name, "force": self.force.tolist(), "torque": self.torque.tolist(),
                "position": self.c.tolist(), "rotation": self.R.tolist(),
                "velocity": self.v.tolist(), "angular_velocity": self.omega.tolist()}


class RigidBodies:
    """The moving bodies of a scene, their boundary particles (boundary fields ``rigid_body``:
    1-based body number, 0 for static walls; ``x_body``: position in the body frame) and the
    walls they collide with.

    Args:
        bodies: the bodies, numbered 1.. in this order in the boundary field ``rigid_body``.
        meshes: the closed mesh of each body, placed in the scene at t = 0 (trimesh).
        solver: the pressure solver's scene name (chooses the reaction expression).
        walls: static obstacles for contacts as ``(distance(p (3, K)) -> (K,), name)``, where
            the distance is positive in free space, negative inside the wall.
        margin: distance [m] the particles keep from the walls: the depth they were moved into
            the mesh (:func:`inset_samples`), so that the mesh surface stops at the wall.
        contact_iterations: Gauss-Seidel sweeps over the contact points per step.
    """

    def __init__(self, bodies: list[RigidBody], solver: str, walls: list | None = None,
                 margin: float = 0.0, contact_iterations: int = 20) -> None:
        self.bodies = bodies
        self.margin = margin
        self.solver = solver
        self.walls = walls or []
        self.contact_iterations = contact_iterations

    @property
    def any_dynamic(self) -> bool:
        return any(b.dynamic for b in self.bodies)

    # -- setup ----------------------------------------------------------------------------------
    def init(self, state: SimState) -> None:
        """Body-frame coordinates and Akinci volumes of each body's own particles; velocities."""
        bd = state.boundary
        bd.register("x_body", "vector")
        body = bd["rigid_body"]
        # static walls: volumes from the static particles only (a body that starts close to a
        # wall must not shrink the wall's volumes for the rest of the run)
        sel0 = np.flatnonzero(body == 0)
        if self.bodies and sel0.size:
            xs = np.ascontiguousarray(bd["x"][:, sel0])
            nl = neighbor_lists(xs, state.h)
            V = np.empty(sel0.size, dtype=bd.dtype)
            _volumes(xs, nl.offsets, nl.indices, state.h, state.kid, state.dim, V)
            bd["V"][sel0] = V
        for k, rb in enumerate(self.bodies):
            sel = np.flatnonzero(body == k + 1)
            xs = bd["x"][:, sel]
            bd["x_body"][:, sel] = rb.R.T @ (xs - rb.c[:, None])
            xl = np.ascontiguousarray(bd["x_body"][:, sel])
            nl = neighbor_lists(xl, state.h)
            V = np.empty(sel.size, dtype=bd.dtype)
            _volumes(xl, nl.offsets, nl.indices, state.h, state.kid, state.dim, V)
            bd["V"][sel] = V
        self.place(state)

    def place(self, state: SimState) -> None:
        """Boundary positions and velocities from the bodies' poses."""
        if not self.bodies:
            return
        bd = state.boundary
        c = np.array([b.c for b in self.bodies])
        R = np.array([b.R for b in self.bodies])
        v = np.array([b.v for b in self.bodies])
        w = np.array([b.omega for b in self.bodies])
        _pose(bd["x_body"], bd["rigid_body"], c, R, v, w, bd["x"], bd["v"])

    # -- checkpoints ----------------------------------------------------------------------------
    def state(self) -> list[dict]:
        """The bodies' motion state (JSON-ready; floats round-trip exactly)."""
        return [{"c": b.c.tolist(), "R": b.R.tolist(), "v": b.v.tolist(),
                 "omega": b.omega.tolist(), "force": b.force.tolist(),
                 "torque": b.torque.tolist()} for b in self.bodies]

    def set_state(self, state: list[dict]) -> None:
        """Restore :meth:`state` (the boundary fields are restored with the particle set)."""
        if len(state) != len(self.bodies):
            raise ValueError(f"{len(state)} rigid body state(s) for {len(self.bodies)} bodies")
        for b, s in zip(self.bodies, state, strict=True):
            b.c, b.R, b.v, b.omega = (np.array(s[k], dtype=np.float64)
                                      for k in ("c", "R", "v", "omega"))
            b.force = np.array(s["force"], dtype=np.float64)
            b.torque = np.array(s["torque"], dtype=np.float64)

    # -- coupling -------------------------------------------------------------------------------
    def pressure_factor(self, state: SimState) -> tuple[np.ndarray, float]:
        """``(kf_i, use_mirror)`` with the boundary share of the solver's pressure acceleration
        ``a_i<-b = -kf_i (1 + use_mirror m_b) V_b grad W_ib`` (module docstring)."""
        f = state.fluid
        p, rho, rho0 = f["p"], f["rho"], state.rho0
        if self.solver == "wcsph":
            return rho0 * (p / rho ** 2 + p / rho0 ** 2), 0.0
        if self.solver in ("dfsph", "iisph"):
            return p * rho0 / rho ** 2, 1.0
        if self.solver == "pcisph":
            return p / rho0, 1.0
        raise ValueError(f"pressure solver {self.solver!r} is not coupled to rigid bodies")

    def fluid_forces(self, state: SimState) -> None:
        """Force and torque of the fluid on every body (after the pressure solve, before the
        fluid moves)."""
        if not self.bodies:
            return
        f, bd = state.fluid, state.boundary
        kf, use_mirror = self.pressure_factor(state)
        nb = len(self.bodies)
        nchunk = max(1, min(64, f.n // 256))
        out = np.empty((nchunk, nb, 6))
        c = np.array([b.c for b in self.bodies])
        _reaction(f["x"], f["m"], np.ascontiguousarray(kf), state.nl_fb.offsets,
                  state.nl_fb.indices, bd["x"], bd["V"], bd["pressure_mirror"], use_mirror,
                  bd["rigid_body"], c, state.h, state.kid, nchunk, out)
        tot = out.sum(axis=0)
        for k, b in enumerate(self.bodies):
            b.force = tot[k, :3].copy()
            b.torque = tot[k, 3:].copy()

    # -- time integration -----------------------------------------------------------------------
    def advance(self, state: SimState, dt: float, time: float) -> None:
        """Move the bodies from ``time`` to ``time + dt`` and place their particles."""
        g = np.zeros(3)
        g[: state.dim] = state.gravity
        bd = state.boundary
        for k, b in enumerate(self.bodies):
            if not b.dynamic:
                b.R = rotation(b.omega, time + dt)
                b.c = b.c0 + b.v * (time + dt)
                continue
            Iw = b.world_inertia()
            Iinv = np.linalg.inv(Iw)
            b.v = b.v + dt * (b.force / b.mass + g)
            b.omega = b.omega + dt * (Iinv @ (b.torque - np.cross(b.omega, Iw @ b.omega)))
            if self.walls:
                sel = np.flatnonzero(bd["rigid_body"] == k + 1)
                self._contact(b, bd["x"][:, sel], Iinv, dt)
            b.c = b.c + dt * b.v
            R = rotation(b.omega, dt) @ b.R
            u, _s, vt = np.linalg.svd(R)  # keep R orthonormal
            b.R = u @ vt
        self.place(state)

    def _contact(self, b: RigidBody, xp: np.ndarray, Iinv: np.ndarray, dt: float) -> None:
        """Velocity impulses against the static walls at the body's particles ``xp`` (3, K)."""
        q = xp - b.c[:, None]
        u = b.v[:, None] + np.cross(b.omega, q.T).T
        reach = dt * float(np.max(np.linalg.norm(u, axis=0))) if q.shape[1] else 0.0
        for dist, _name in self.walls:
            phi = dist(xp) - self.margin
            near = np.flatnonzero(phi < reach + 1e-9)
            if near.size == 0:
                continue
            n = _normals(dist, xp[:, near])
            # speculative: phi + dt u.n >= 0; penetration pushed out at half its depth per step
            bias = np.where(phi[near] >= 0.0, -phi[near] / dt, -0.5 * phi[near] / dt)
            v = b.v.copy()
            w = b.omega.copy()
            _contacts(np.ascontiguousarray(q[:, near]), np.ascontiguousarray(n), bias,
                      1.0 / b.mass, Iinv, v, w, b.friction, self.contact_iterations)
            b.v, b.omega = v, w


def _normals(dist, p: np.ndarray, eps: float = 1e-5) -> np.ndarray:
    """Unit gradients of the distance at points p (3, K) by central differences."""
    g = np.empty_like(p)
    for d in range(3):
        e = np.zeros((3, 1))
        e[d] = eps
        g[d] = (dist(p + e) - dist(p - e)) / (2.0 * eps)
    return g / np.maximum(np.linalg.norm(g, axis=0), 1e-12)


def box_wall(lo, hi, open_axis: int | None):
    """Distance to the walls of a container box [lo, hi] (positive inside; open_axis: no lid)."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64).copy()
    if open_axis is not None:
        hi[open_axis] = np.inf

    def dist(p: np.ndarray) -> np.ndarray:
        return np.minimum(p - lo[:, None], hi[:, None] - p).min(axis=0)

    return dist


def mesh_wall(mesh, invert: bool = False, spacing: float = 0.01):
    """Distance to a static mesh (positive outside the mesh; ``invert``: a container), from its
    signed distance on a lattice of the given spacing [m] (:func:`sphkit.core.sdf.
    mesh_sdf_lattice`) interpolated trilinearly."""
    from scipy.interpolate import RegularGridInterpolator

    from sphkit.core.sdf import mesh_sdf_lattice

    lo = np.asarray(mesh.bounds[0], dtype=np.float64) - 3.0 * spacing
    hi = np.asarray(mesh.bounds[1], dtype=np.float64) + 3.0 * spacing
    shape = np.ceil((hi - lo) / spacing).astype(np.int64) + 1
    d = mesh_sdf_lattice(mesh.vertices, mesh.faces, lo, [spacing] * 3, shape)
    axes = [lo[k] + spacing * np.arange(shape[k]) for k in range(3)]
    f = RegularGridInterpolator(axes, -d if invert else d, bounds_error=False, fill_value=None)

    def dist(p: np.ndarray) -> np.ndarray:
        return f(p.T)

    return dist


def body_from_mesh(name: str, mesh, dynamic: bool, density: float, velocity, angular_velocity,
                   rotation_center, friction: float) -> RigidBody:
    """A body from its closed mesh (placed at t = 0): mass properties for dynamic bodies (about
    the centre of mass), the pivot for kinematic ones."""
    v = np.zeros(3) if velocity is None else np.asarray(velocity, dtype=np.float64)
    w = np.zeros(3) if angular_velocity is None else np.asarray(angular_velocity, np.float64)
    if dynamic:
        if not mesh.is_volume:
            raise ValueError(f"{name}: the mesh is not a closed volume (watertight, "
                             "consistently wound); expected one for a dynamic body's mass")
        vol = float(mesh.volume)
        com = np.asarray(mesh.center_mass, dtype=np.float64)
        inertia = np.asarray(mesh.moment_inertia, dtype=np.float64) * density  # unit density
        return RigidBody(name, True, com.copy(), v, w, mass=density * vol, inertia=inertia,
                         friction=friction)
    if rotation_center is not None:
        c = np.asarray(rotation_center, dtype=np.float64)
    else:
        c = np.asarray(mesh.center_mass if mesh.is_volume else mesh.centroid, dtype=np.float64)
    return RigidBody(name, False, c.copy(), v, w, c0=c.copy(), friction=friction)
