"""Hinge joints with target-velocity motors between rigid bodies, by sequential impulses:
Catto 2005, "Iterative Dynamics with Temporal Coherence", Game Developers Conference (projected
Gauss-Seidel on the velocity constraints of joints and contacts, Baumgarte stabilisation of the
position drift); the hinge's constraint rows as in Bender, Erleben & Trinkle 2014, "Interactive
Simulation of Rigid Body Dynamics in Computer Graphics", Computer Graphics Forum 33(1), Sec. 4
(velocity-based constraints: joints and motors). :class:`BodyJoints` is a base class of
:class:`sphkit.boundary.rigid.RigidBodies`.

A joint connects body A and body B (either may be a static wall: infinite mass, fixed in space,
its frame the world frame; or a kinematic body: infinite mass, moving as prescribed). At t = 0
the anchor ``p`` and the unit axis ``a`` are stored in both bodies' frames, ``p_A = R_A^T (p -
c_A)``, ``a_A = R_A^T a`` (and B's). Each step, with ``r_X = R_X p_X`` (anchor offsets from the
centres), the world anchors ``x_X = c_X + r_X``, the world axes ``a = R_A a_A``, ``b = R_B a_B``,
two unit vectors ``t1, t2`` perpendicular to ``a`` and the point velocities ``u_X = v_X + w_X x
r_X``, the velocity constraints are

* point (3 rows, ball joint): ``u_A - u_B = -(beta / dt) (x_A - x_B)``;
* alignment (2 rows): ``t_i . (w_A - w_B) = (beta / dt) t_i . (a x b)`` -- the rotation
  vector ``a x b`` turns a onto b, so the drift of the axes is taken back at the rate beta / dt;
* motor (1 row, target-velocity motors only): ``a . (w_A - w_B) = omega_target(t)``.

Baumgarte's ``beta`` = :data:`BETA`. Each row block is solved exactly for its impulse with the
other rows held (``K lambda = -(J u - bias)``, ``K = J M^-1 J^T``: the 3x3 point block
``K = (1/M_A + 1/M_B) 1 - [r_A] I_A^-1 [r_A] - [r_B] I_B^-1 [r_B]``, the 2x2 alignment block
``K_ij = t_i . (I_A^-1 + I_B^-1) t_j``, the motor ``a . (I_A^-1 + I_B^-1) a``; infinite masses
contribute 0) and applied as equal and opposite impulses, ``+lambda`` at ``r_A`` on A and
``-lambda`` at ``r_B`` on B, so that the joint's impulses conserve the bodies' total linear and
angular momentum. The joints' blocks are swept after the contacts' rows
(:func:`sphkit.boundary.rigid.contacts._contact_sweep`) in every Gauss-Seidel iteration
(:func:`solve`), after the bodies' velocity update and before their positions advance, so the
motor row, solved last, holds its target exactly at the end of the step's solve. The impulses
are not warm-started (nothing is carried between steps), and the motor's target is a function
of the time, so a checkpoint needs no joint state. The motor has no torque limit.

2D (bodies moving in the xy-plane, turning about z): the axis must be z, the alignment rows are
left out (the bodies cannot tilt), the point rows act in the plane.

Target sequences (PositionBasedDynamics' ``MotorJoint``, ``TimeStepController::step``): time /
value pairs ``[t0, v0, t1, v1, ...]``, interpolated linearly between the times; before ``t0``
the first value, after the last time the last value, or, with ``repeat``, the time taken modulo
``t_last - t0`` (:func:`sequence_value`). sphkit drives the step from t to t + dt to the
target at its midpoint ``t + dt / 2``: the body then turns by ``dt target(t + dt / 2)``, the
sequence's exact integral over the step wherever it is linear (with the target at the step's
start the paddle of MotorScene2 lagged: over 0.1-1 s it turned at a mean -0.483 rad/s against the
sequence's -0.5). PositionBasedDynamics evaluates the sequence at the end of a step for the next
one (a lag of one step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numba
import numpy as np

from sphkit.boundary.rigid.contacts import _apply, _contact_sweep, _cross, _point_velocity

if TYPE_CHECKING:
    from sphkit.boundary.rigid.bodies import RigidBody

_JIT = dict(cache=True, fastmath=True)

#: Baumgarte factor: the fraction of the joint's position and axis drift taken back per step
#: (Catto 2005 suggests 0.1-0.2)
BETA = 0.2


def sequence_value(seq: np.ndarray | list[float], t: float, repeat: bool) -> float:
    """The target of the time / value pairs ``seq = [t0, v0, t1, v1, ...]`` at time t [s]:
    linear between the times, the first value before t0, the last after the last time; with
    ``repeat`` the time wraps, ``t0 + (t - t0) mod (t_last - t0)`` (module docstring)."""
    s = np.asarray(seq, dtype=np.float64)
    ts, vs = s[0::2], s[1::2]
    if repeat and ts.size > 1 and ts[-1] > ts[0] and t > ts[-1]:
        t = ts[0] + math.fmod(t - ts[0], ts[-1] - ts[0])
    if t <= ts[0]:
        return float(vs[0])
    if t >= ts[-1]:
        return float(vs[-1])
    k = int(np.searchsorted(ts, t, side="right"))  # ts[k - 1] <= t < ts[k]
    alpha = (t - ts[k - 1]) / (ts[k] - ts[k - 1])
    return float((1.0 - alpha) * vs[k - 1] + alpha * vs[k])


@dataclass
class Joint:
    """A hinge between bodies ``a`` and ``b`` (indices into the bodies; -1: a static wall)
    with its anchor and axis in each body's frame (a static wall's frame is the world's), and
    an optional target-velocity motor (``target_velocity`` [rad/s] or a ``sequence`` of time /
    value pairs, ``repeat``): the relative angular velocity ``(w_A - w_B) . a`` is driven to
    the target. ``omega_rel`` [rad/s], ``last_target`` [rad/s], ``force`` [N] (the joint's
    point force on A) and ``torque`` [N m] (the motor's, about the axis, on A) are the last
    step's."""

    name: str
    a: int
    b: int
    anchor_a: np.ndarray
    anchor_b: np.ndarray
    axis_a: np.ndarray
    axis_b: np.ndarray
    target_velocity: float | None = None
    sequence: np.ndarray | None = None
    repeat: bool = False
    omega_rel: float = 0.0
    last_target: float = 0.0
    torque: float = 0.0
    force: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def motor(self) -> bool:
        """Whether the joint drives its relative angular velocity."""
        return self.target_velocity is not None or self.sequence is not None

    def target(self, t: float) -> float:
        """The motor's target [rad/s] at time t (0 without a motor)."""
        if self.sequence is not None:
            return sequence_value(self.sequence, t, self.repeat)
        return 0.0 if self.target_velocity is None else float(self.target_velocity)

    def stats(self) -> dict:
        """Plain-dict state for the step statistics of the joint's bodies."""
        out = {"joint": self.name, "relative_angular_velocity": self.omega_rel,
               "force": self.force.tolist()}
        if self.motor:
            out.update(target_velocity=self.last_target, motor_torque=self.torque)
        return out


def hinge(name: str, bodies: list[RigidBody], a: int, b: int, position, axis,
          target_velocity: float | None = None, sequence=None, repeat: bool = False) -> Joint:
    """A hinge through ``position`` [m] along ``axis`` between bodies a and b (-1: a static
    wall) placed as they are now (t = 0)."""
    p = np.asarray(position, dtype=np.float64)
    u = np.asarray(axis, dtype=np.float64)
    u = u / np.linalg.norm(u)

    def local(k: int) -> tuple[np.ndarray, np.ndarray]:
        if k < 0:
            return p.copy(), u.copy()
        bk = bodies[k]
        return bk.R.T @ (p - bk.c), bk.R.T @ u

    pa, ua = local(a)
    pb, ub = local(b)
    seq = None if sequence is None else np.asarray(sequence, dtype=np.float64)
    return Joint(name, a, b, pa, pb, ua, ub, target_velocity, seq, repeat)


@numba.njit(**_JIT)
def _apply_angular(k, L0, L1, L2, Iinv, w):
    """Angular impulse L on body k (k < 0: a static wall, nothing turns)."""
    if k < 0:
        return
    w[k, 0] += Iinv[k, 0, 0] * L0 + Iinv[k, 0, 1] * L1 + Iinv[k, 0, 2] * L2
    w[k, 1] += Iinv[k, 1, 0] * L0 + Iinv[k, 1, 1] * L1 + Iinv[k, 1, 2] * L2
    w[k, 2] += Iinv[k, 2, 0] * L0 + Iinv[k, 2, 1] * L1 + Iinv[k, 2, 2] * L2


@numba.njit(**_JIT)
def _quad(k, x0, x1, x2, y0, y1, y2, Iinv):
    """``x . I_k^-1 y`` (0 for a static wall)."""
    if k < 0:
        return 0.0
    return (x0 * (Iinv[k, 0, 0] * y0 + Iinv[k, 0, 1] * y1 + Iinv[k, 0, 2] * y2)
            + x1 * (Iinv[k, 1, 0] * y0 + Iinv[k, 1, 1] * y1 + Iinv[k, 1, 2] * y2)
            + x2 * (Iinv[k, 2, 0] * y0 + Iinv[k, 2, 1] * y1 + Iinv[k, 2, 2] * y2))


@numba.njit(**_JIT)
def _point_block(k, r0, r1, r2, inv_m, Iinv, K):
    """Add body k's ``1/M 1 - [r] I^-1 [r]`` to the 3x3 K (column j: ``e_j / M +
    (I^-1 (r x e_j)) x r``)."""
    if k < 0:
        return
    for j in range(3):
        e0 = 1.0 if j == 0 else 0.0
        e1 = 1.0 if j == 1 else 0.0
        e2 = 1.0 if j == 2 else 0.0
        c0, c1, c2 = _cross(r0, r1, r2, e0, e1, e2)
        b0 = Iinv[k, 0, 0] * c0 + Iinv[k, 0, 1] * c1 + Iinv[k, 0, 2] * c2
        b1 = Iinv[k, 1, 0] * c0 + Iinv[k, 1, 1] * c1 + Iinv[k, 1, 2] * c2
        b2 = Iinv[k, 2, 0] * c0 + Iinv[k, 2, 1] * c1 + Iinv[k, 2, 2] * c2
        d0, d1, d2 = _cross(b0, b1, b2, r0, r1, r2)
        K[0, j] += inv_m[k] * e0 + d0
        K[1, j] += inv_m[k] * e1 + d1
        K[2, j] += inv_m[k] * e2 + d2


@numba.njit(**_JIT)
def _solve3(K, b0, b1, b2):
    """``K^-1 b`` for a symmetric positive 3x3 K (cofactors); zeros when K is singular."""
    c00 = K[1, 1] * K[2, 2] - K[1, 2] * K[2, 1]
    c01 = K[0, 2] * K[2, 1] - K[0, 1] * K[2, 2]
    c02 = K[0, 1] * K[1, 2] - K[0, 2] * K[1, 1]
    det = K[0, 0] * c00 + K[1, 0] * c01 + K[2, 0] * c02
    if not abs(det) > 0.0:
        return 0.0, 0.0, 0.0
    c10 = K[1, 2] * K[2, 0] - K[1, 0] * K[2, 2]
    c11 = K[0, 0] * K[2, 2] - K[0, 2] * K[2, 0]
    c12 = K[0, 2] * K[1, 0] - K[0, 0] * K[1, 2]
    c20 = K[1, 0] * K[2, 1] - K[1, 1] * K[2, 0]
    c21 = K[0, 1] * K[2, 0] - K[0, 0] * K[2, 1]
    c22 = K[0, 0] * K[1, 1] - K[0, 1] * K[1, 0]
    return ((c00 * b0 + c01 * b1 + c02 * b2) / det, (c10 * b0 + c11 * b1 + c12 * b2) / det,
            (c20 * b0 + c21 * b1 + c22 * b2) / det)


@numba.njit(**_JIT)
def _joint_sweep(ja, jb, ra, rb, err, ax, t1, t2, align, ang, motor, target, rate, inv_m, Iinv,
                 v, w, imp):
    """One Gauss-Seidel sweep over the joints (module docstring): joint j between bodies
    ``ja[j]``, ``jb[j]`` (-1: static), anchor offsets ``ra``, ``rb`` (3, J) from the centres,
    anchor drift ``err = x_A - x_B`` (3, J), world axis ``ax`` and its perpendiculars ``t1``,
    ``t2`` (3, J), alignment error ``ang[:, j] = t_i . (a x b)`` (2, J) where ``align[j]``
    (3D), ``motor[j]`` with ``target[j]`` [rad/s]; ``rate`` = beta / dt. ``v``, ``w`` are
    updated in place; ``imp`` (J, 4) accumulates the point impulse (0:3) and the motor's (3)."""
    K = np.zeros((3, 3))
    for j in range(ja.shape[0]):
        a, b = ja[j], jb[j]
        ra0, ra1, ra2 = ra[0, j], ra[1, j], ra[2, j]
        rb0, rb1, rb2 = rb[0, j], rb[1, j], rb[2, j]
        # point rows: u_A - u_B = -rate err
        ua0, ua1, ua2 = _point_velocity(a, ra0, ra1, ra2, v, w)
        ub0, ub1, ub2 = _point_velocity(b, rb0, rb1, rb2, v, w)
        K[:] = 0.0
        _point_block(a, ra0, ra1, ra2, inv_m, Iinv, K)
        _point_block(b, rb0, rb1, rb2, inv_m, Iinv, K)
        l0, l1, l2 = _solve3(K, -(ua0 - ub0 + rate * err[0, j]),
                             -(ua1 - ub1 + rate * err[1, j]), -(ua2 - ub2 + rate * err[2, j]))
        _apply(a, ra0, ra1, ra2, l0, l1, l2, inv_m, Iinv, v, w)
        _apply(b, rb0, rb1, rb2, -l0, -l1, -l2, inv_m, Iinv, v, w)
        imp[j, 0] += l0
        imp[j, 1] += l1
        imp[j, 2] += l2
        a0, a1, a2 = ax[0, j], ax[1, j], ax[2, j]
        if align[j]:  # alignment rows (3D)
            p0, p1, p2 = t1[0, j], t1[1, j], t1[2, j]
            q0, q1, q2 = t2[0, j], t2[1, j], t2[2, j]
            dw0 = (w[a, 0] if a >= 0 else 0.0) - (w[b, 0] if b >= 0 else 0.0)
            dw1 = (w[a, 1] if a >= 0 else 0.0) - (w[b, 1] if b >= 0 else 0.0)
            dw2 = (w[a, 2] if a >= 0 else 0.0) - (w[b, 2] if b >= 0 else 0.0)
            k11 = _quad(a, p0, p1, p2, p0, p1, p2, Iinv) + _quad(b, p0, p1, p2, p0, p1, p2, Iinv)
            k12 = _quad(a, p0, p1, p2, q0, q1, q2, Iinv) + _quad(b, p0, p1, p2, q0, q1, q2, Iinv)
            k22 = _quad(a, q0, q1, q2, q0, q1, q2, Iinv) + _quad(b, q0, q1, q2, q0, q1, q2, Iinv)
            det = k11 * k22 - k12 * k12
            if det > 0.0:
                c1 = rate * ang[0, j] - (p0 * dw0 + p1 * dw1 + p2 * dw2)
                c2 = rate * ang[1, j] - (q0 * dw0 + q1 * dw1 + q2 * dw2)
                m1 = (k22 * c1 - k12 * c2) / det
                m2 = (k11 * c2 - k12 * c1) / det
                L0 = m1 * p0 + m2 * q0
                L1 = m1 * p1 + m2 * q1
                L2 = m1 * p2 + m2 * q2
                _apply_angular(a, L0, L1, L2, Iinv, w)
                _apply_angular(b, -L0, -L1, -L2, Iinv, w)
        if motor[j]:
            km = _quad(a, a0, a1, a2, a0, a1, a2, Iinv) + _quad(b, a0, a1, a2, a0, a1, a2, Iinv)
            if km > 0.0:
                dw0 = (w[a, 0] if a >= 0 else 0.0) - (w[b, 0] if b >= 0 else 0.0)
                dw1 = (w[a, 1] if a >= 0 else 0.0) - (w[b, 1] if b >= 0 else 0.0)
                dw2 = (w[a, 2] if a >= 0 else 0.0) - (w[b, 2] if b >= 0 else 0.0)
                lm = (target[j] - (a0 * dw0 + a1 * dw1 + a2 * dw2)) / km
                _apply_angular(a, lm * a0, lm * a1, lm * a2, Iinv, w)
                _apply_angular(b, -lm * a0, -lm * a1, -lm * a2, Iinv, w)
                imp[j, 3] += lm


@numba.njit(**_JIT)
def solve(ia, ib, qa, qb, n, bias, mu, ja, jb, ra, rb, err, ax, t1, t2, align, ang, motor,
          target, rate, inv_m, Iinv, v, w, iterations, imp):
    """Projected Gauss-Seidel over all constraints of the bodies: per iteration one sweep over
    the contacts (:func:`sphkit.boundary.rigid.contacts._contact_sweep`, arguments ``ia`` ..
    ``mu``) and one over the joints (:func:`_joint_sweep`, ``ja`` .. ``rate``, ``imp``)."""
    lam = np.zeros(ia.shape[0])
    lt = np.zeros((3, ia.shape[0]))
    for _it in range(iterations):
        _contact_sweep(ia, ib, qa, qb, n, bias, mu, inv_m, Iinv, v, w, lam, lt)
        _joint_sweep(ja, jb, ra, rb, err, ax, t1, t2, align, ang, motor, target, rate, inv_m,
                     Iinv, v, w, imp)


def _perpendiculars(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors perpendicular to the unit vector a and to each other."""
    e = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = np.cross(a, e)
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(a, t1)


class BodyJoints:
    """The joints of the moving bodies, a base class of
    :class:`sphkit.boundary.rigid.RigidBodies`: their rows of the step (:meth:`_joint_rows`),
    the solve of joints and contacts together (:meth:`_constrain`) and the bodies'
    accelerations as the joints let them be, for the fluid's pressure solves
    (:meth:`_joint_accel`). It reads the attributes
    ``bodies``, ``joints`` and ``contact_iterations``."""

    bodies: list[RigidBody]
    joints: list[Joint]
    contact_iterations: int

    @property
    def joined(self) -> set[frozenset[int]]:
        """The pairs of bodies joined by a joint (they do not collide)."""
        return {frozenset((j.a, j.b)) for j in self.joints}

    def _frame(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Centre and rotation of body k (a static wall, k < 0: the world frame)."""
        if k < 0:
            return np.zeros(3), np.eye(3)
        return self.bodies[k].c, self.bodies[k].R

    def _joint_rows(self, dt: float, time: float, dim: int) -> tuple:
        """The joints' arrays for :func:`_joint_sweep` at the bodies' present poses, for the
        step from ``time`` to ``time + dt`` (motor targets at its midpoint)."""
        nj = len(self.joints)
        ra, rb, err, ax = (np.zeros((3, nj)) for _ in range(4))
        t1, t2 = np.zeros((3, nj)), np.zeros((3, nj))
        ang = np.zeros((2, nj))
        align = np.zeros(nj, dtype=np.bool_)
        motor = np.zeros(nj, dtype=np.bool_)
        target = np.zeros(nj)
        for j, jt in enumerate(self.joints):
            ca, Ra = self._frame(jt.a)
            cb, Rb = self._frame(jt.b)
            ra[:, j] = Ra @ jt.anchor_a
            rb[:, j] = Rb @ jt.anchor_b
            err[:, j] = (ca + ra[:, j]) - (cb + rb[:, j])
            a = Ra @ jt.axis_a
            ax[:, j] = a
            if dim == 3:
                b = Rb @ jt.axis_b
                p, q = _perpendiculars(a)
                t1[:, j], t2[:, j] = p, q
                e = np.cross(a, b)
                ang[:, j] = (p @ e, q @ e)
                align[j] = True
            motor[j] = jt.motor
            target[j] = jt.target(time + 0.5 * dt)  # the step's mean: exact turn on a ramp
        ja = np.array([jt.a for jt in self.joints], dtype=np.int64)
        jb = np.array([jt.b for jt in self.joints], dtype=np.int64)
        return ja, jb, ra, rb, err, ax, t1, t2, align, ang, motor, target, BETA / dt

    def _constrain(self, contacts: tuple, inv_m: np.ndarray, Iinv: np.ndarray, v: np.ndarray,
                   w: np.ndarray, dt: float, time: float, dim: int) -> None:
        """Solve the contacts' rows ``contacts`` (:meth:`~sphkit.boundary.rigid.contacts.
        BodyContacts._contact_rows`) and the joints together on the velocities ``v``, ``w``
        (bodies, 3; updated in place) and record each joint's relative angular velocity, force
        and motor torque."""
        rows = self._joint_rows(dt, time, dim)
        imp = np.zeros((len(self.joints), 4))
        solve(*contacts, *rows, inv_m, Iinv, v, w, self.contact_iterations, imp)
        ax = rows[5]
        for j, jt in enumerate(self.joints):
            dw = (w[jt.a] if jt.a >= 0 else 0.0) - (w[jt.b] if jt.b >= 0 else 0.0)
            jt.omega_rel = float(ax[:, j] @ dw) if np.ndim(dw) else 0.0
            jt.force = imp[j, :3] / dt
            jt.torque = float(imp[j, 3] / dt)
            jt.last_target = float(rows[11][j])

    def _joint_accel(self, acc: np.ndarray, dt: float, time: float, dim: int,
                     homogeneous: bool) -> np.ndarray:
        """The accelerations ``acc`` (bodies, 6: linear, angular) of the bodies as the joints
        let them be, for the fluid's pressure solves (:class:`~sphkit.boundary.rigid.coupling.
        FluidCoupling`): the step's velocities ``v + dt a`` go through the joints' solve
        (:func:`solve` without contacts) and ``(v' - v) / dt`` comes back; ``homogeneous``: the
        response to a pressure field, a linear map, solved with zero drift and zero motor
        targets (a motor holds its relative angular velocity, so it takes any torque). Without
        joints ``acc`` itself."""
        if not self.joints:
            return acc
        nb = len(self.bodies)
        inv_m = np.array([1.0 / b.mass if b.dynamic else 0.0 for b in self.bodies])
        Iinv = np.array([np.linalg.inv(b.world_inertia()) if b.dynamic else np.zeros((3, 3))
                         for b in self.bodies]).reshape(nb, 3, 3)
        rows = list(self._joint_rows(dt, time, dim))
        if homogeneous:
            v, w = acc[:, :3].copy(), acc[:, 3:].copy()
            rows[4] = np.zeros_like(rows[4])  # drift
            rows[9] = np.zeros_like(rows[9])  # misalignment
            rows[11] = np.zeros_like(rows[11])  # motor targets
        else:
            v0 = np.array([b.v for b in self.bodies], dtype=np.float64).reshape(nb, 3)
            w0 = np.array([b.omega for b in self.bodies], dtype=np.float64).reshape(nb, 3)
            v, w = v0 + dt * acc[:, :3], w0 + dt * acc[:, 3:]
        z = np.zeros((3, 0))
        imp = np.zeros((len(self.joints), 4))
        solve(np.zeros(0, np.int64), np.zeros(0, np.int64), z, z, z, np.zeros(0), np.zeros(0),
              *rows, inv_m, Iinv, v, w, self.contact_iterations, imp)
        out = np.empty_like(acc)
        if homogeneous:
            out[:, :3], out[:, 3:] = v, w
        else:
            out[:, :3], out[:, 3:] = (v - v0) / dt, (w - w0) / dt
        for k, b in enumerate(self.bodies):  # kinematic bodies keep theirs
            if not b.dynamic:
                out[k] = acc[k]
        return out

    def joint_stats(self, k: int) -> list[dict]:
        """The statistics of the joints body k takes part in."""
        return [jt.stats() for jt in self.joints if k in (jt.a, jt.b)]
