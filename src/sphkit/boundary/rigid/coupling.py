"""Rigid bodies and the fluid: the fluid's force and torque on the bodies (Akinci et al. 2012,
"Versatile rigid-fluid coupling for incompressible SPH", ACM TOG 31(4)) and the strong coupling of
the pressure solves (Gissler et al. 2019); :class:`FluidCoupling` is a base class of
:class:`sphkit.boundary.rigid.RigidBodies`.

Fluid forces: the boundary pressure term of Akinci et al.'s Eq. (10) acts on fluid particle i, and
its reaction on boundary particle b is minus it, ``F_b<-i = -m_i a_i<-b``, summed over the
body into a force ``F = sum_b F_b`` and a torque ``T = sum_b (x_b - c) x F_b``. The boundary
share of the pressure acceleration is taken from the very expression each solver applies, so
that momentum is conserved to round-off. Each solver states that share itself
(:meth:`sphkit.core.methods.PressureSolver.boundary_reaction`, ``a_i<-b = -k_i (1 + mirrored m_b)
V_b grad W_ib``), so the bodies never ask which solver runs:

* WCSPH (:func:`sphkit.core.operators.pressure_accel_body`):
  ``a_i<-b = -rho0 V_b (p_i / rho_i^2 + m_b p_i / rho0^2) grad W_ib`` at bodies (mirrored at
  Akinci bodies, one-sided at moving maps, :mod:`sphkit.pressure.wcsph`);
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
mismatch the other way round (not tested yet). Moving maps are one-sided (0) in every solver,
WCSPH included, against a mirrored floor where the floor mirrors (WCSPH's walls; the PPE
solvers' volume-map walls with their hydrostatic pressure): WCSPH has no Jacobi iterations to
run away, and the heavy body landed with either map in 2D and 3D (validation/landing.py;
validation/README.md, "The WCSPH float with maps").

Strong coupling in the iterative solvers (DFSPH, IISPH, PCISPH; Gissler et al. 2019,
"Interlinked SPH pressure solvers for strong fluid-rigid coupling", ACM TOG 38(1), in its simplest
form): the bodies are the state's moving boundary (:class:`sphkit.core.coupling.BoundaryCoupling`,
:class:`~sphkit.core.methods.MovingBoundary`). Each Jacobi sweep of
:func:`sphkit.core.solver.jacobi_ppe` asks :meth:`FluidCoupling.response` for the accelerations
of the bodies' particles under the sweep's pressure, ``a_b = F(k) / M + (I_w^-1 T(k)) x (x_b -
c)``, and the divergence of the relative acceleration enters the solve, so that the film under a
landing body stops the body instead of being expelled at whatever speed a prescribed wall would
need. The body is then advanced with the force of the converged pressure, as before (momentum is
conserved to round-off). Measured on the landing cube: without it the landing cube bounced,
penetrated the floor by 6-11 mm and the fluid reached 15 m/s; with it, 0 mm and 2-4 m/s.
PCISPH's sweeps predict the positions of the bodies' particles as they do the fluid's,
``x_b* = x_b + dt (v_b + dt a_b(p))`` (:meth:`sphkit.core.coupling.BoundaryCoupling.
displacement`), so that its predicted densities see the bodies give way.

PBF (Macklin & Mueller 2013, :mod:`sphkit.pressure.pbf`) moves positions, so its boundary share
is not a field times the step's gradients: each sweep corrects fluid particle i by ``dx_i<-b =
lambda_i V_b grad W(x*_i - x_b)`` at its predicted position x* (density maps place their virtual
particles anew for x* in every sweep). As SPlisHSPlasH's ``TimeStepPBF`` (``addForce`` of
``m_i dx / dt^2`` on the boundary neighbour in its position solve), the body of b takes ``-m_i
dx_i<-b / dt^2`` at x_b, pair by pair and summed over the sweeps
(:meth:`FluidCoupling.pair_reaction`, with the ``body`` numbers that
:meth:`sphkit.core.coupling.BoundaryCoupling.boundary_at` returns beside the neighbours), as
:attr:`sphkit.core.methods.BoundaryReaction.forces`; kinematic bodies report it too. Dynamic
bodies are coupled strongly here as well, in the form a positional solve takes: every sweep
places them where the reaction summed so far moves them in the step,
:meth:`FluidCoupling.motion` (``dt (V* + dt A(F))``, with :meth:`FluidCoupling.response`'s
accelerations and :meth:`FluidCoupling.predict`'s velocities), and the sweep's boundary
follows (:meth:`FluidCoupling.displaced`; maps queried at the predicted poses); their
samples also count in PBF's lambda denominator, so that a fluid particle squeezed between a
body and a wall does not throw the body (:mod:`sphkit.pressure.pbf`). Momentum is conserved to
round-off; angular momentum is not kept exactly by PBF's own pairs either. A heavy body landing
through water then comes to rest on the last fluid layer (2D) or lands (3D Akinci particles
and density maps); weakly coupled, as SPlisHSPlasH's, it was thrown (validation/README.md, "PBF:
strong coupling and a heavy body's landing").
Viscous boundary forces are not transferred to bodies.

A landing body must reach the pressure solves with the velocity the step will give it, as the
fluid does (2026-11-26, validation/README.md "Rigid bodies: the body's velocity in the solves").
Two inconsistencies made DFSPH stop a landing body twice or too late:

* the divergence solve's impulse: the body yielded to the divergence pressure inside that solve
  but kept its old velocity for the density solve, which stopped it again (2D: 6300 N on a
  20 kg/m body, 30x its weight, blew up at t = 0.195 s). The yielding boundary now takes its
  velocity change ``dt a_b(kappa^v)`` (:mod:`sphkit.pressure.dfsph`);
* gravity: the fluid enters the density solve with ``v* = v + dt a`` (gravity included), the bodies
  entered with ``v`` only, so the solve saw every dynamic body stop falling for the step while the
  fluid around it fell, and :meth:`~sphkit.boundary.rigid.RigidBodies.advance` added ``dt g``
  afterwards, unopposed, to be stopped by the next step's solves. :meth:`FluidCoupling.predict` now
  advances the boundary velocities of dynamic bodies by their non-pressure accelerations (gravity
  and the gyroscopic term) before the solve, Gissler et al. 2019's ``v_r* = v_r + dt F_r^ext /
  M_r``.

Neither is counted twice: the body's own ``v`` and ``omega`` change only in
:meth:`~sphkit.boundary.rigid.RigidBodies.advance`, by ``dt (F / M + g)`` with F the reaction of
both solves' pressure (``p`` holds kappa + kappa^v) and the contacts; the solves only see the
boundary particles' velocities, which :meth:`~sphkit.boundary.rigid.RigidBodies.advance` sets from
the new pose. With the divergence impulse alone, the 2D heavy square came to rest on a fluid layer
1.7 r above the floor, rocking, and the 3D cube slid 25.7 mm (> r) after landing; with both, the 2D
square lands flat (centre 0.00 mm above rest, 6e-12 m/s) and the 3D cube drifts 6.0 mm. The landing
is still chaotic (see below): over 10 neighbouring 3D set-ups the drift is 1.0-32 mm (2 beyond r;
main before: 4.3-24.9 mm, 4 beyond r); of 7 neighbouring 2D set-ups 4 land flat (3 at rest by t =
1.2 s), 2 turn over by 90 degrees at landing and 1 blows up after landing (main before: 2 land flat,
1 rocks on a layer, 4 blow up).

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
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numba
import numpy as np

from sphkit.core.kernels import kernel_dw
from sphkit.core.methods import BoundaryReaction, MovingBoundary
from sphkit.core.neighbors import NeighborList
from sphkit.core.pairs import pair_slots, point, separation
from sphkit.core.particles import ParticleSet
from sphkit.core.state import SimState

if TYPE_CHECKING:
    from sphkit.boundary.rigid.bodies import RigidBody

_JIT = dict(cache=True, fastmath=True)


@numba.njit(inline="always", **_JIT)
def _add_force(out, ch, k, bx, b, c, dim, f0, f1, f2):
    """Add the force (f0, f1, f2) on boundary particle b of body k, and its torque about the
    body's centre ``c[k]``, to ``out[ch, k]`` (force 0:3, torque 3:6)."""
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
def _reaction(x, m, kf, boff, bidx, bx, bV, bmirror, use_mirror, body, c, h, kid, nchunk, out):
    """Per body: force and torque (about c) of the fluid on its boundary particles,
    ``F_b = sum_i m_i kf_i (1 + use_mirror_i m_b) V_b grad_i W_ib`` (the negative of the
    boundary share of ``m_i a_i``; ``use_mirror`` (N,) per fluid particle);
    ``out[chunk, body, 0:3]`` force, ``3:6`` torque, summed over chunks of fluid particles by
    the caller (no write races). ``bmirror`` is not read where ``use_mirror`` is 0; x may be
    predicted positions (PBF's sweeps, boundary neighbours of
    :meth:`~sphkit.core.coupling.BoundaryCoupling.boundary_at` with their ``body``)."""
    n = x.shape[1]
    dim = x.shape[0]
    out[:] = 0.0
    per = (n + nchunk - 1) // nchunk
    for ch in numba.prange(nchunk):
        for i in range(ch * per, min(n, (ch + 1) * per)):
            fi = m[i] * kf[i]
            xi0, xi1, xi2 = point(x, i, dim)
            for kk in pair_slots(boff, i):
                b = bidx[kk]
                k = body[b] - 1
                if k < 0:
                    continue
                d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, 0.0)
                um = use_mirror[i]
                mir = 1.0 + um * bmirror[b] if um != 0.0 else 1.0
                s = fi * mir * bV[b] * kernel_dw(kid, r, h, dim)
                _add_force(out, ch, k, bx, b, c, dim, s * d0, s * d1, s * d2)


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
            for kk in pair_slots(boff, i):
                b = bidx[kk]
                bk = body[b] - 1
                if bk < 0:
                    continue
                s = fi * (1.0 + bmirror[b])
                _add_force(out, ch, bk, bx, b, c, dim, s * gwb[0, kk], s * gwb[1, kk],
                           s * gwb[2, kk] if dim == 3 else 0.0)


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


class FluidCoupling(MovingBoundary):
    """The fluid side of the moving bodies, a base class of
    :class:`sphkit.boundary.rigid.RigidBodies`: the reaction of the boundary pressure terms on
    the bodies (:meth:`fluid_forces`), their response inside the pressure solves
    (:meth:`response`, the :class:`~sphkit.core.methods.MovingBoundary` of the state's
    coupling) and their predicted velocities (:meth:`predict`), both as the joints let the
    bodies move (``_joint_accel``, from the base class
    :class:`~sphkit.boundary.rigid.joints_catto2005.BodyJoints`). It reads the attribute
    ``bodies`` and caches this step's centres and inverse world inertias (:meth:`begin_step`)."""

    bodies: list[RigidBody]
    _ab: np.ndarray | None
    _vstar: np.ndarray  #: the bodies' velocities (bodies, 6) of :meth:`begin_step`, :meth:`predict`
    _cached: bool = False  #: whether :meth:`begin_step` has made the caches once

    @property
    def yields(self) -> bool:
        """Whether a body is dynamic: its particles yield to the fluid's pressure."""
        return any(b.dynamic for b in self.bodies)

    @property
    def reacts(self) -> bool:
        """Whether there are bodies (kinematic or dynamic) to take the fluid's reaction."""
        return bool(self.bodies)

    def yielding(self, state: SimState, body: np.ndarray | None = None) -> np.ndarray:
        """The boundary particles (N_b,) of dynamic bodies (``body``: other samples' body
        numbers, as :meth:`~sphkit.core.coupling.BoundaryCoupling.boundary_at` returns them)."""
        dynamic = np.array([False] + [b.dynamic for b in self.bodies])
        return dynamic[state.boundary["rigid_body"] if body is None else body]

    def fluid_forces(self, state: SimState, reaction: BoundaryReaction | None) -> None:
        """Force and torque of the fluid on every body (after the pressure solve, before the
        fluid moves) from the solver's boundary share of its pressure acceleration (None: the
        solver's pressure does not act on boundaries, the forces are 0)."""
        if not self.bodies:
            return
        if reaction is None:
            for b in self.bodies:
                b.force = np.zeros(3)
                b.torque = np.zeros(3)
            return
        if reaction.forces is not None:  # summed pair by pair inside the solve (PBF)
            for k, b in enumerate(self.bodies):
                b.force = np.array(reaction.forces[k, :3], dtype=float)
                b.torque = np.array(reaction.forces[k, 3:], dtype=float)
            return
        f, bd = state.fluid, state.boundary
        nb = len(self.bodies)
        nchunk = max(1, min(64, f.n // 256))
        out = np.empty((nchunk, nb, 6))
        c = np.array([b.c for b in self.bodies])
        mirrored = np.broadcast_to(np.asarray(reaction.mirrored, dtype=np.float64), (f.n,))
        _reaction(f["x"], f["m"], np.ascontiguousarray(reaction.k), state.nl_fb.offsets,
                  state.nl_fb.indices, bd["x"], bd["V"], bd["pressure_mirror"],
                  np.ascontiguousarray(mirrored), bd["rigid_body"], c, state.h, state.kid,
                  nchunk, out)
        tot = out.sum(axis=0)
        for k, b in enumerate(self.bodies):
            b.force = tot[k, :3].copy()
            b.torque = tot[k, 3:].copy()

    def pair_reaction(self, state: SimState, k: np.ndarray, x: np.ndarray, bx: np.ndarray,
                      bV: np.ndarray, lists: NeighborList, body: np.ndarray
                      ) -> np.ndarray | None:
        """Force and torque (bodies, 6) about this step's centres of the boundary share
        ``a_i<-b = -k_i V_b grad W(x_i - x_b)`` at the fluid positions x and the boundary
        neighbours ``(bx, bV, lists, body)`` (:meth:`sphkit.core.methods.MovingBoundary.
        pair_reaction`: ``F_b = m_i k_i V_b grad W``, pair by pair, torque at x_b); None
        without bodies. PBF sums it over its sweeps (module docstring, "PBF")."""
        if not self.bodies:
            return None
        f = state.fluid
        nchunk = max(1, min(64, f.n // 256))
        out = np.empty((nchunk, len(self.bodies), 6))
        _reaction(np.ascontiguousarray(x), f["m"], np.ascontiguousarray(k), lists.offsets,
                  lists.indices, bx, bV, bV, np.zeros(f.n), body, self._c, state.h, state.kid,
                  nchunk, out)
        return out.sum(axis=0)

    def response(self, k: np.ndarray, gwb: np.ndarray) -> np.ndarray:
        """Strong coupling (the state's moving boundary): the accelerations (3, N_b) of
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
        return self._boundary_accel(bd, self._accelerations(out.sum(axis=0)))

    def _accelerations(self, tot: np.ndarray) -> np.ndarray:
        """The bodies' linear and angular accelerations (bodies, 6) under the forces and torques
        ``tot`` (bodies, 6) about this step's centres, ``F / M`` and ``I_w^-1 T`` as the joints
        let them be (a linear map: :meth:`_joint_accel`, homogeneous); 0 for kinematic
        bodies."""
        st = self._state
        acc = np.zeros((len(self.bodies), 6))
        for j, b in enumerate(self.bodies):
            if b.dynamic:
                acc[j, :3] = tot[j, :3] / b.mass
                acc[j, 3:] = self._Iinv[j] @ tot[j, 3:]
        return self._joint_accel(acc, 1.0, st.time, st.dim, homogeneous=True)

    def motion(self, forces: np.ndarray | None, dt: float) -> np.ndarray:
        """Strong coupling of a positional solve (PBF): the rigid displacement (bodies, 6) of
        each dynamic body in the step under the forces and torques ``forces`` (bodies, 6; None:
        none yet) about this step's centres, ``dt (V* + dt A(forces))``: translation (0:3) and
        rotation vector (3:6), with ``V*`` the velocities of :meth:`predict` (non-pressure
        change included) and ``A`` :meth:`_accelerations`; 0 for kinematic bodies. Linear in
        the forces, as :meth:`response`; :meth:`displaced` places points with it."""
        acc = self._accelerations(forces) if forces is not None else 0.0
        out = dt * (self._vstar + dt * acc)
        out[[not b.dynamic for b in self.bodies]] = 0.0
        return out

    def displaced(self, motion: np.ndarray, bx: np.ndarray, body: np.ndarray) -> np.ndarray:
        """Points ``bx`` (dim, N) of the bodies ``body`` (N,; 1-based, 0: static) moved with
        their body's rigid displacement ``motion`` (:meth:`motion`), to first order in the
        rotation: ``x_b + u_k + theta_k x (x_b - c_k)`` (the pose itself turns by
        ``exp(theta_k)`` in :meth:`~sphkit.boundary.rigid.RigidBodies.advance`; the angle per
        step is small: the CFL step keeps the motion per step below a particle spacing)."""
        out = np.empty_like(bx)
        _point_accel(bx, body, self._c, motion, out)
        out += bx
        return out

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
        if not self.yields:
            return
        g = np.zeros(3)
        g[: state.dim] = state.gravity
        nb = len(self.bodies)
        acc = np.zeros((nb, 6))
        for k, b in enumerate(self.bodies):
            if b.dynamic:
                Iw = b.world_inertia()
                acc[k, :3] = g
                acc[k, 3:] = -(self._Iinv[k] @ np.cross(b.omega, Iw @ b.omega))
        acc = self._joint_accel(acc, dt, state.time, state.dim, homogeneous=False)
        self._vstar = self._vstar + dt * acc  # the bodies' V* (for motion)
        bd = state.boundary
        bd["v"] += dt * self._boundary_accel(bd, acc)

    def begin_step(self, state: SimState) -> None:
        """Cache this step's centres and world inverse inertias for :meth:`response`, and the
        bodies' velocities as :meth:`motion`'s ``V*`` until :meth:`predict` advances them."""
        self._state = state
        if not self.bodies and self._cached:
            return  # no bodies: the empty caches of the first step stand
        self._cached = True
        self._c = np.array([b.c for b in self.bodies])
        self._vstar = np.array([np.concatenate([b.v, b.omega]) for b in self.bodies]
                               ).reshape(len(self.bodies), 6)
        self._Iinv = [np.linalg.inv(b.world_inertia()) if b.dynamic else np.zeros((3, 3))
                      for b in self.bodies]
