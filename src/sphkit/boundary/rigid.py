"""Rigid bodies coupled two-way with the fluid through boundary particles: Akinci et al. 2012,
"Versatile rigid-fluid coupling for incompressible SPH", ACM TOG 31(4).

A body is a closed triangle mesh whose surface is sampled into boundary particles (one layer,
:func:`sphkit.geometry.mesh_sampling.sample_mesh_surface`). Three kinds:

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

Boundary particles of moving bodies mirror the pressure fully (boundary field
``pressure_mirror`` = 1, as the lattice walls of scene ``boxes``). With SPlisHSPlasH's
one-sided term (0) on the body and full mirroring (1) on the floor, a fluid particle squeezed
between them is pushed by ``k_i sum_b (1 + m_b) V_b grad W_ib``, which does not vanish where
its density is stationary (``sum_b V_b grad W_ib = 0``): the push is not the gradient of the
density constraint, and the pressure of the squeezed film (up to 1e7 Pa at r = 12.5 mm) drove
its particles at 30-100 m/s and blew up a DFSPH run when a heavy cube landed. Equal factors on
both sides make the push vanish there. Measured: the floating cube's submerged fraction
(``tests/test_rigid.py``, strong coupling on) moved from 0.52 to 0.48 (Archimedes: 0.5).
Static ``meshes`` keep 0, so a body squeezing fluid against a static mesh meets the same
mismatch the other way round (not tested yet).

Strong coupling in the iterative solvers (DFSPH, IISPH; Gissler et al. 2019, "Interlinked SPH
pressure solvers for strong fluid-rigid coupling", ACM TOG 38(1), in its simplest form): each
Jacobi sweep of :func:`sphkit.core.solver.jacobi_ppe` asks :meth:`RigidBodies.pressure_response`
for the accelerations of the bodies' particles under the sweep's pressure,
``a_b = F(k) / M + (I_w^-1 T(k)) x (x_b - c)``, and the divergence of the relative
acceleration enters the solve, so that the film under a landing body stops the body instead of
being expelled at whatever speed a prescribed wall would need. The body is then advanced with
the force of the converged pressure, as before (momentum is conserved to round-off).
Measured on the landing cube: without it the landing cube bounced, penetrated the floor by
6-11 mm and the fluid reached 15 m/s; with it, 0 mm and 2-4 m/s.

PBF moves positions and is not coupled (a scene with a dynamic body and PBF is rejected).
Viscous boundary forces are not transferred to bodies.

Density and volume maps (:mod:`sphkit.boundary.maps`, "Moving rigid bodies"): a body has no
particles of its own; each step the map model writes one virtual boundary particle per fluid
particle near the body (boundary fields ``x``, ``V``, ``v`` the body's surface velocity,
``rigid_body`` the body's number, ``pressure_mirror`` 0), and :meth:`RigidBodies.fluid_forces`
and :meth:`RigidBodies.pressure_response` sum the same reactions over them (the solvers treat a
virtual particle as any boundary particle, so momentum is conserved to round-off as well). The
contact points of such a body are its mesh vertices only; :meth:`RigidBodies.place` leaves the
virtual particles to the map model.

2D: a body is the section of its mesh with z = 0 and moves in the xy-plane; vectors stay 3D
internally with z = 0 (angular velocity (0, 0, w)), mass and polar moment per metre of depth
come from the section (:func:`sphkit.geometry.meshes.section_mass_properties`), its contact
points are the ends of the section's segments, and the compiled passes read and write the (2, N)
fields. Measured
(tests/test_rigid_2d.py): momentum exchange to round-off, a floating square 0.48 submerged, a
heavy square (density 2000) sinks and rests flat on the floor.

A landing body must reach the pressure solves with the velocity the step will give it, as the
fluid does (2026-11-26, validation/README.md "Rigid bodies: the body's velocity in the solves").
Two inconsistencies made DFSPH stop a landing body twice or too late:

* the divergence solve's impulse: the body yielded to the divergence pressure inside that solve
  but kept its old velocity for the density solve, which stopped it again (2D: 6300 N on a
  20 kg/m body, 30x its weight, blew up at t = 0.195 s). The yielding boundary now takes its
  velocity change ``dt a_b(kappa^v)`` (:mod:`sphkit.pressure.dfsph`);
* gravity: the fluid enters the density solve with ``v* = v + dt a`` (gravity included), the
  bodies entered with ``v`` only, so the solve saw every dynamic body stop falling for the step
  while the fluid around it fell, and :meth:`RigidBodies.advance` added ``dt g`` afterwards,
  unopposed, to be stopped by the next step's solves. :meth:`RigidBodies.predict` now advances
  the boundary velocities of dynamic bodies by their non-pressure accelerations (gravity and the
  gyroscopic term) before the solve, Gissler et al. 2019's ``v_r* = v_r + dt F_r^ext / M_r``.

Neither is counted twice: the body's own ``v`` and ``omega`` change only in :meth:`advance`,
by ``dt (F / M + g)`` with F the reaction of both solves' pressure (``p`` holds kappa + kappa^v)
and the contacts; the solves only see the boundary particles' velocities, which
:meth:`advance` sets from the new pose. With the divergence impulse alone, the 2D heavy square
came to rest on a fluid layer 1.7 r above the floor, rocking, and the 3D cube slid 25.7 mm (>
r) after landing; with both, the 2D square lands flat (centre 0.00 mm above rest, 6e-12 m/s)
and the 3D cube drifts 6.0 mm. The landing is still chaotic (see below): over 10 neighbouring
3D set-ups the drift is 1.0-32 mm (2 beyond r; main before: 4.3-24.9 mm, 4 beyond r); of 7
neighbouring 2D set-ups 4 land flat (3 at rest by t = 1.2 s), 2 turn over by 90 degrees at
landing and 1 blows up after landing (main before: 2 land flat, 1 rocks on a layer, 4 blow up).

Landing through water needs the last fluid layer under the body to go. In this discrete model a
single layer between two walls is at rest density (each wall's Akinci volumes stand for the fluid
beyond it), so the squeezed film thins by spacing out (particles 3.2 r apart, 1.6 r gap) rather
than draining, and a sparse film has no lateral pressure gradient to drive it out. What ejects it
is a runaway of the one-sided Jacobi iterations: with full mirroring on both sides (m_b = 1 on
body and floor) the pressure operator of two particles stacked between them is indefinite
(largest eigenvalue of the 2x2 block +4e-4 against -1.5e-3 one-sided, measured), and all the
particles under a body push it at once (Jacobi-scaled coupling eigenvalues up to 5-11, against
0.1 while sinking). Removing both (one-sided term near bodies, a mass-splitting bound on the
Jacobi diagonals; branch rigid2d's history, before the gravity prediction above) stopped
every blow-up but left the body on the last layer (2D: 1.5-1.7 r above the floor; 3D: tilted,
rocking), as volume maps do (3.5 r). So the landing relies on the runaway, in 3D (fluid ejected
at 1.7-2.8 m/s) as in 2D. The runaway is also what throws a landing body: in the 3D set-up
that slid 32 mm the cube lands on one edge, is kicked up at 0.19 m/s and spun at 6 rad/s, and
rocks on the last layer for 0.4 s (validation/README.md). A Jacobi that is
stable in the body mode and still drains the last layer is not there yet.

Dynamic bodies are advanced with symplectic Euler on linear and angular momentum:
``v += dt (F / M + g)``, ``omega += dt I_w^-1 (T - omega x I_w omega)`` with the world inertia
``I_w = R I R^T``, then contacts, then ``c += dt v``, ``R <- exp([omega] dt) R``.

Contacts, all solved together by a projected Gauss-Seidel on velocity impulses
(:func:`_contacts`): the contact points of a body are its boundary particles, which keep a
distance ``1.2 r`` (they lie that deep in the mesh, see :data:`INSET`), and its mesh vertices,
which keep 0 (the extreme points of a tilted body, which the particles' margin does not
cover). They meet

* the static walls (scene ``boxes``, analytic distance; static ``meshes``, their signed distance
  on a lattice of spacing r, interpolated trilinearly);
* every other moving body whose bounding sphere is within reach: the points of body A are
  taken into the frame of body B and meet B's signed distance, a lattice of spacing r in B's
  frame (:func:`body_sdf`, compiled trilinear interpolation :func:`_sdf_at`); for two dynamic
  bodies both directions are contacts. Kinematic bodies take part with infinite mass.

Each contact enforces ``phi(x_p) - margin + dt u_rel . n >= 0`` (speculative contacts:
restitution 0; a penetrating point is pushed out at ``0.5 depth / dt``) with Coulomb friction
``|lambda_t| <= mu lambda_n`` (mu: the body's friction at walls, the geometric mean of two
bodies' between them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np

from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.neighbors import neighbor_lists
from sphkit.core.particles import ParticleSet
from sphkit.core.state import SimState
from sphkit.geometry.meshes import oriented_section, section_mass_properties
from sphkit.geometry.rotations import rotation_exp
from sphkit.geometry.sdf import tri_dist2

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
    ``x = c + R x_l``, ``v_b = v + omega x (R x_l)``; c, v, w, R 3D, the fields (dim, N) (2D:
    the third coordinate is 0, the body turns about z)."""
    dim = x.shape[0]
    for b in numba.prange(x.shape[1]):
        k = body[b] - 1
        if k < 0:
            continue
        l2 = xl[2, b] if dim == 3 else 0.0
        r0 = R[k, 0, 0] * xl[0, b] + R[k, 0, 1] * xl[1, b] + R[k, 0, 2] * l2
        r1 = R[k, 1, 0] * xl[0, b] + R[k, 1, 1] * xl[1, b] + R[k, 1, 2] * l2
        r2 = R[k, 2, 0] * xl[0, b] + R[k, 2, 1] * xl[1, b] + R[k, 2, 2] * l2
        x[0, b] = c[k, 0] + r0
        x[1, b] = c[k, 1] + r1
        bv[0, b] = v[k, 0] + w[k, 1] * r2 - w[k, 2] * r1
        bv[1, b] = v[k, 1] + w[k, 2] * r0 - w[k, 0] * r2
        if dim == 3:
            x[2, b] = c[k, 2] + r2
            bv[2, b] = v[k, 2] + w[k, 0] * r1 - w[k, 1] * r0


@numba.njit(parallel=True, **_JIT)
def _reaction(x, m, kf, boff, bidx, bx, bV, bmirror, use_mirror, body, c, h, kid, nchunk, out):
    """Per body: force and torque (about c) of the fluid on its boundary particles,
    ``F_b = sum_i m_i kf_i (1 + use_mirror m_b) V_b grad_i W_ib`` (the negative of the boundary
    share of ``m_i a_i``); ``out[chunk, body, 0:3]`` force, ``3:6`` torque, summed over chunks of
    fluid particles by the caller (no write races)."""
    n = x.shape[1]
    dim = x.shape[0]
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
                d2 = x[2, i] - bx[2, b] if dim == 3 else 0.0
                r = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                s = fi * (1.0 + use_mirror * bmirror[b]) * bV[b] * kernel_dw(kid, r, h, dim)
                f0 = s * d0
                f1 = s * d1
                f2 = s * d2
                out[ch, k, 0] += f0
                out[ch, k, 1] += f1
                out[ch, k, 2] += f2
                q0 = bx[0, b] - c[k, 0]
                q1 = bx[1, b] - c[k, 1]
                q2 = bx[2, b] - c[k, 2] if dim == 3 else 0.0
                out[ch, k, 3] += q1 * f2 - q2 * f1
                out[ch, k, 4] += q2 * f0 - q0 * f2
                out[ch, k, 5] += q0 * f1 - q1 * f0


@numba.njit(parallel=True, **_JIT)
def _reaction_cached(m, k, boff, bidx, gwb, bmirror, bx, body, c, nchunk, out):
    """:func:`_reaction` from the cached ``gwb = V_b grad W_ib`` of a Jacobi sweep and its
    pressure field k (acceleration units, ``a_i<-b = -(1 + m_b) k_i V_b grad W_ib``)."""
    n = k.shape[0]
    dim = bx.shape[0]
    out[:] = 0.0
    per = (n + nchunk - 1) // nchunk
    for ch in numba.prange(nchunk):
        for i in range(ch * per, min(n, (ch + 1) * per)):
            fi = m[i] * k[i]
            if fi == 0.0:
                continue
            for kk in range(boff[i], boff[i + 1]):
                b = bidx[kk]
                bk = body[b] - 1
                if bk < 0:
                    continue
                s = fi * (1.0 + bmirror[b])
                f0 = s * gwb[0, kk]
                f1 = s * gwb[1, kk]
                f2 = s * gwb[2, kk] if dim == 3 else 0.0
                out[ch, bk, 0] += f0
                out[ch, bk, 1] += f1
                out[ch, bk, 2] += f2
                q0 = bx[0, b] - c[bk, 0]
                q1 = bx[1, b] - c[bk, 1]
                q2 = bx[2, b] - c[bk, 2] if dim == 3 else 0.0
                out[ch, bk, 3] += q1 * f2 - q2 * f1
                out[ch, bk, 4] += q2 * f0 - q0 * f2
                out[ch, bk, 5] += q0 * f1 - q1 * f0


@numba.njit(parallel=True, **_JIT)
def _point_accel(bx, body, c, acc, ab):
    """``ab[:, b] = a_k + alpha_k x (x_b - c_k)`` for the particles of body k (acc[k] = (a,
    alpha)), 0 for static walls (fields (dim, N); 2D: the third coordinate is 0)."""
    dim = bx.shape[0]
    for b in numba.prange(bx.shape[1]):
        k = body[b] - 1
        if k < 0:
            for d in range(dim):
                ab[d, b] = 0.0
            continue
        q0 = bx[0, b] - c[k, 0]
        q1 = bx[1, b] - c[k, 1]
        q2 = bx[2, b] - c[k, 2] if dim == 3 else 0.0
        ab[0, b] = acc[k, 0] + acc[k, 4] * q2 - acc[k, 5] * q1
        ab[1, b] = acc[k, 1] + acc[k, 5] * q0 - acc[k, 3] * q2
        if dim == 3:
            ab[2, b] = acc[k, 2] + acc[k, 3] * q1 - acc[k, 4] * q0


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
def _contacts(ia, ib, qa, qb, n, bias, mu, inv_m, Iinv, v, w, iterations):
    """Projected Gauss-Seidel on the velocities of the bodies: contact p pushes body ``ia[p]``
    along the unit normal ``n[:, p]`` and body ``ib[p]`` (-1: a static wall) the other way, at
    offsets ``qa``, ``qb`` (3, K) from their centres. Constraints: relative normal velocity
    ``(u_a - u_b) . n >= bias`` (``u = v + w x q``) with accumulated normal impulses >= 0, and
    Coulomb friction ``|lambda_t| <= mu lambda_n``. ``v``, ``w`` (bodies, 3) are updated in place
    (kinematic bodies carry inv_m = 0, Iinv = 0 and keep their velocities)."""
    K = ia.shape[0]
    lam = np.zeros(K)
    lt = np.zeros((3, K))
    for _it in range(iterations):
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
        meshes: the closed mesh of each body as placed in the scene at t = 0 (trimesh): its
            vertices are contact points and its signed distance (a lattice in the body frame)
            is what other bodies collide with. Without meshes the bodies only meet the walls.
        margin: distance [m] the particles keep from the walls: the depth they were moved into
            the mesh (:func:`inset_samples`), so that the mesh surface stops at the wall.
        contact_iterations: Gauss-Seidel sweeps over the contact points per step.
    """

    def __init__(self, bodies: list[RigidBody], solver: str, walls: list | None = None,
                 margin: float = 0.0, contact_iterations: int = 20,
                 meshes: list | None = None) -> None:
        self.bodies = bodies
        self.meshes = meshes or []
        self.margin = margin
        self.solver = solver
        self.walls = walls or []
        self.contact_iterations = contact_iterations
        self._ab: np.ndarray | None = None  # _boundary_accel's buffer

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
            dim = state.dim
            bd["x_body"][:, sel] = rb.R[:dim, :dim].T @ (xs - rb.c[:dim, None])
            xl = np.ascontiguousarray(bd["x_body"][:, sel])
            nl = neighbor_lists(xl, state.h)
            V = np.empty(sel.size, dtype=bd.dtype)
            _volumes(xl, nl.offsets, nl.indices, state.h, state.kid, state.dim, V)
            bd["V"][sel] = V
        self._sel = [np.flatnonzero(body == k + 1) for k in range(len(self.bodies))]
        # bodies without particles (density / volume maps): the map model writes the virtual
        # boundary particles' positions and velocities each step, place() leaves them alone
        self._particles = bool(np.any(body > 0))
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
        self.place(state)

    def place(self, state: SimState) -> None:
        """Boundary positions and velocities from the bodies' poses."""
        if not self.bodies or not self._particles:
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

    def pressure_response(self, k: np.ndarray, gwb: np.ndarray) -> np.ndarray:
        """Strong coupling (the state's ``boundary_response``): the accelerations (3, N_b) of
        the boundary particles of dynamic bodies under the pressure field k of a Jacobi sweep,
        ``a = F(k) / M``, ``alpha = I_w^-1 T(k)`` (the reaction of the sweep's boundary pressure
        terms; gravity and the gyroscopic term are left out, they do not depend on k), so that
        the pressure solve sees the body give way instead of treating it as a prescribed wall;
        0 for static walls and kinematic bodies."""
        st = self._state
        f, bd = st.fluid, st.boundary
        nb = len(self.bodies)
        nchunk = max(1, min(64, f.n // 256))
        out = np.empty((nchunk, nb, 6))
        _reaction_cached(f["m"], k, st.nl_fb.offsets, st.nl_fb.indices, gwb,
                         bd["pressure_mirror"], bd["x"], bd["rigid_body"], self._c, nchunk, out)
        tot = out.sum(axis=0)
        acc = np.zeros((nb, 6))
        for j, b in enumerate(self.bodies):
            if b.dynamic:
                acc[j, :3] = tot[j, :3] / b.mass
                acc[j, 3:] = self._Iinv[j] @ tot[j, 3:]
        return self._boundary_accel(bd, acc)

    def _boundary_accel(self, bd: ParticleSet, acc: np.ndarray) -> np.ndarray:
        """Accelerations (dim, N_b) of the boundary particles from their bodies' linear and
        angular accelerations ``acc`` (bodies, 6) about this step's centres (0 on static walls),
        in a buffer reused across calls."""
        ab = self._ab
        if ab is None or ab.shape != bd["x"].shape:
            ab = self._ab = np.empty_like(bd["x"])
        _point_accel(bd["x"], bd["rigid_body"], self._c, acc, ab)
        return ab

    def predict(self, state: SimState, dt: float) -> None:
        """Strong coupling, before the pressure solve: the boundary velocities of dynamic bodies
        take the bodies' non-pressure velocity change of the step, ``dt (g + alpha_0 x (x_b -
        c))`` with the gyroscopic ``alpha_0 = -I_w^-1 (omega x I_w omega)`` (Gissler et al.
        2019: the rigid bodies are advected by their non-pressure forces, ``v_r* = v_r + dt
        F_r^ext / M_r``, before the solve, as the fluid is), so that the solve sees the bodies
        move as :meth:`advance` will move them. Without it a sinking body looked to the density
        solve as if it stopped falling in every step, while the fluid around it fell: the 2D
        heavy square of tests/test_rigid_2d.py then came to rest on a fluid layer 1.7 r above
        the floor, rocking, and the 3D heavy cube slid 26 mm after landing (module docstring).
        The boundary velocities are set from the poses again in :meth:`advance`."""
        g = np.zeros(3)
        g[: state.dim] = state.gravity
        nb = len(self.bodies)
        acc = np.zeros((nb, 6))
        for k, b in enumerate(self.bodies):
            if b.dynamic:
                Iw = b.world_inertia()
                acc[k, :3] = g
                acc[k, 3:] = -(self._Iinv[k] @ np.cross(b.omega, Iw @ b.omega))
        bd = state.boundary
        bd["v"] += dt * self._boundary_accel(bd, acc)

    def begin_step(self, state: SimState) -> None:
        """Cache this step's centres and world inverse inertias for :meth:`pressure_response`."""
        self._state = state
        self._c = np.array([b.c for b in self.bodies])
        self._Iinv = [np.linalg.inv(b.world_inertia()) if b.dynamic else np.zeros((3, 3))
                      for b in self.bodies]

    # -- time integration -----------------------------------------------------------------------
    def advance(self, state: SimState, dt: float, time: float) -> None:
        """Move the bodies from ``time`` to ``time + dt`` and place their particles: forces,
        then the contacts of all bodies at once (:meth:`_contact`), then the poses."""
        g = np.zeros(3)
        g[: state.dim] = state.gravity
        Iinv = np.zeros((len(self.bodies), 3, 3))
        for k, b in enumerate(self.bodies):
            if b.dynamic:
                Iw = b.world_inertia()
                Iinv[k] = np.linalg.inv(Iw)
                b.v = b.v + dt * (b.force / b.mass + g)
                b.omega = b.omega + dt * (Iinv[k] @ (b.torque - np.cross(b.omega, Iw @ b.omega)))
        if self.any_dynamic:
            self._contact(state, Iinv, dt)
        for b in self.bodies:
            if not b.dynamic:
                b.R = rotation_exp(b.omega, time + dt)
                b.c = b.c0 + b.v * (time + dt)
                continue
            b.c = b.c + dt * b.v
            R = rotation_exp(b.omega, dt) @ b.R
            u, _s, vt = np.linalg.svd(R)  # keep R orthonormal
            b.R = u @ vt
        self.place(state)

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
        return np.concatenate([xp, xv], axis=1), marg

    def _contact(self, state: SimState, Iinv: np.ndarray, dt: float) -> None:
        """Velocity impulses of all contacts (module docstring): every dynamic body's points
        against the static walls, and the points of each body against the signed distance of
        every other body near it (both directions for two dynamic bodies), solved together by
        :func:`_contacts`."""
        nb = len(self.bodies)
        v = np.array([b.v for b in self.bodies], dtype=np.float64)
        w = np.array([b.omega for b in self.bodies], dtype=np.float64)
        inv_m = np.array([1.0 / b.mass if b.dynamic else 0.0 for b in self.bodies])
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
                if bk == a or not (ba.dynamic or bb.dynamic):
                    continue
                reach = dt * (speed[a] + speed[bk]) + 1e-9
                if np.linalg.norm(ba.c - bb.c) > self._radius[a] + self._radius[bk] + reach:
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
            return
        phi = np.concatenate(phis)
        # speculative: phi + dt u.n >= 0; penetration pushed out at half its depth per step
        bias = np.where(phi >= 0.0, -phi / dt, -0.5 * phi / dt)
        ia_, ib_ = np.concatenate(ia), np.concatenate(ib)
        fr = np.array([b.friction for b in self.bodies])
        mu = np.where(ib_ >= 0, np.sqrt(fr[ia_] * fr[np.maximum(ib_, 0)]), fr[ia_])
        _contacts(ia_, ib_, np.ascontiguousarray(np.concatenate(qa, axis=1)),
                  np.ascontiguousarray(np.concatenate(qb, axis=1)),
                  np.ascontiguousarray(np.concatenate(nn, axis=1)), bias, mu, inv_m, Iinv, v, w,
                  self.contact_iterations)
        for k, b in enumerate(self.bodies):
            if b.dynamic:
                b.v, b.omega = v[k].copy(), w[k].copy()


def _normals(dist, p: np.ndarray, eps: float = 1e-5) -> np.ndarray:
    """Unit gradients of the distance at points p (3, K) by central differences."""
    g = np.empty_like(p)
    for d in range(3):
        e = np.zeros((3, 1))
        e[d] = eps
        g[d] = (dist(p + e) - dist(p - e)) / (2.0 * eps)
    return g / np.maximum(np.linalg.norm(g, axis=0), 1e-12)


def body_sdf(mesh, c: np.ndarray, r: float, max_points: int = 96
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


def body_from_mesh(name: str, mesh, dynamic: bool, density: float, velocity, angular_velocity,
                   rotation_center, friction: float, dim: int = 3) -> RigidBody:
    """A body from its closed mesh (placed at t = 0): mass properties for dynamic bodies (about
    the centre of mass), the pivot for kinematic ones. 2D: the body is the section of the mesh
    with z = 0, moving in the xy-plane: mass per unit depth ``density * area`` [kg/m] and the
    polar moment ``density * J`` [kg m^2/m] (put on all three axes; only z turns), velocity
    (vx, vy, 0) and angular velocity (0, 0, w)."""
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
                             inertia=np.eye(3) * density * j, friction=friction)
        c = com if rotation_center is None else np.asarray(rotation_center, dtype=np.float64)
        c = np.array([c[0], c[1], 0.0])
        return RigidBody(name, False, c.copy(), v, w, c0=c.copy(), friction=friction)
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
