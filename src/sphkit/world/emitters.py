"""Fluid emitters: layers of particles fed into the scene while it runs.

The emitter of SPlisHSPlasH (``SPlisHSPlasH/Emitter.cpp``, ``emitParticles`` and
``emitParticlesCircle``; ``Simulator/SimulatorBase.cpp``, ``createEmitters``), in sphkit's SI
scene fields (:class:`sphkit.scene.schema.Emitter`):

* frame: position ``x0`` and rotation ``R`` (``rotation_angle`` about ``rotation_axis``); the
  emit direction is ``d = R e_x``, the layer spans ``R e_z`` (width) and ``R e_y`` (height);
* layer: box -- ``n_w = round(width / 2r)`` by ``n_h = round(height / 2r)`` particles at
  ``(i - (n_w - 1)/2) 2r R e_z + (j - (n_h - 1)/2) 2r R e_y``; circle -- the points of the
  ``n_w x n_w`` grid within ``n_w r`` of the centre. In 2D SPlisHSPlasH turns every emitter into
  a box of width 1, so a layer is a line of ``round(width / 2r)`` particles along ``R e_y``;
* timing: layer k is due at ``t_k = start_time + k 2r / v`` (one particle diameter of travel per
  layer), for ``t_k <= end_time``; at the end of the step that reaches ``t_k`` it is added at
  ``x0 + offsets + (t - t_k) v d`` with velocity ``v d``, as SPlisHSPlasH places a late layer. A
  step longer than ``2r / v`` adds every layer it passed (SPlisHSPlasH adds one per step), so
  the count after time t is exactly ``#{k : t_k <= min(t, end_time)}``;
* animation: from 0.25 s before ``start_time`` to ``end_time`` the particles inside the emitter
  region -- a box (cylinder) reaching ``h/2`` behind the layer and ``3h/2`` ahead of it along d,
  one particle diameter wider than the layer on each side -- move rigidly with ``v d`` instead
  of being integrated (``ParticleState::AnimatedByEmitter``); before ``start_time`` they are
  pushed out at ``10 r / 0.25 s``. Here this is applied after the integration: a particle found
  in the region gets ``v = v_e`` and ``x = x_new - dt (v_new - v_e)``, which is ``x_old + dt v_e``
  for the symplectic Euler step (a kernel body, :func:`animate_body`, run where the fluid is);
* housing: a box (cylinder) of boundary particles around the emitter, ``2h`` long along d and
  centred on ``x0``, open towards d (SPlisHSPlasH's ``EmitterBox.obj``/``EmitterCylinder.obj``
  scaled by ``Emitter::getSize``), unless ``housing`` is false.

Emitted particles get the lattice mass ``rho0 V`` of the scene's fluid blocks. ``max_particles``
(SPlisHSPlasH's per-material ``maxEmitterParticles``) caps the particles the emitters of a
material add (the smallest limit among them counts). Not done: SPlisHSPlasH's particle reuse
(``emitterReuseParticles``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sphkit.backend import launch, to_device
from sphkit.core.particles import ParticleSet
from sphkit.geometry.rotations import rotation_matrix

#: SPlisHSPlasH starts animating (clearing) the emitter region this long before start_time [s]
CLEAR_AHEAD = 0.25


@numba.njit(inline="always", cache=True, fastmath=True)
def animate_body(i, x, v, dim, x0, R, lo, hi, hy, hz, circle, r2, vel, dt):
    """Move particle ``i`` rigidly with ``vel`` if it lies in the emitter region (local
    coordinates ``u = R^T (x - x0)``: ``lo <= u0 <= hi`` and ``|u1| <= hy, |u2| <= hz`` (box) or
    ``u1^2 + u2^2 <= r2`` (cylinder))."""
    u0 = 0.0
    u1 = 0.0
    u2 = 0.0
    for d in range(dim):
        t = x[d, i] - x0[d]
        u0 += R[d, 0] * t
        u1 += R[d, 1] * t
        u2 += R[d, 2] * t
    if u0 < lo or u0 > hi:
        return
    if circle:
        if u1 * u1 + u2 * u2 > r2:
            return
    elif abs(u1) > hy or abs(u2) > hz:
        return
    for d in range(dim):
        x[d, i] -= dt * (v[d, i] - vel[d])
        v[d, i] = vel[d]


class FluidEmitter:
    """One emitter of a scene (``scene.emitters[k]``) for a simulation of dimension ``dim`` with
    particle radius ``r`` and kernel support ``h`` [m]."""

    def __init__(self, cfg, dim: int, r: float, h: float, name: str = "emitter") -> None:
        self.name = name
        self.dim = dim
        self.r = r
        self.h = h
        self.speed = float(cfg.velocity)
        self.start = float(cfg.start_time)
        self.end = math.inf if cfg.end_time is None else float(cfg.end_time)
        self.material = cfg.material
        self.max_particles = getattr(cfg, "max_particles", None)
        self.emitted = 0  #: particles emitted so far
        x0 = np.zeros(3)
        x0[: len(cfg.position)] = cfg.position
        self.x0 = x0
        axis = [0.0, 0.0, 1.0] if dim == 2 else cfg.rotation_axis
        self.R = rotation_matrix(axis, float(cfg.rotation_angle))
        self.direction = self.R[:, 0].copy()
        diam = 2.0 * r
        n_w = max(1, int(round(cfg.width / diam)))
        height = cfg.width if cfg.height is None else cfg.height
        n_h = max(1, int(round(height / diam)))
        self.circle = cfg.shape == "circle"
        if dim == 2:  # SPlisHSPlasH: every 2D emitter is a box of width 1
            n_h, n_w, self.circle = n_w, 1, False
        elif self.circle:
            n_h = n_w
        self.n_w, self.n_h = n_w, n_h
        i = (np.arange(n_w) - 0.5 * (n_w - 1)) * diam
        j = (np.arange(n_h) - 0.5 * (n_h - 1)) * diam
        ii, jj = np.meshgrid(i, j, indexing="ij")
        ii, jj = ii.ravel(), jj.ravel()
        if self.circle:
            keep = ii * ii + jj * jj <= (0.5 * n_w * diam) ** 2
            ii, jj = ii[keep], jj[keep]
        self.offsets = (np.outer(ii, self.R[:, 2]) + np.outer(jj, self.R[:, 1]))  # (M, 3)
        self.period = diam / self.speed  #: time between layers [s]
        self.count = 0  #: layers emitted so far
        # housing and animation region (Emitter::getSize): 2h along d, one diameter around
        self.size = np.array([2.0 * h, n_h * diam + 2.0 * diam, n_w * diam + 2.0 * diam])
        if self.circle:
            self.size[1] = self.size[2] = n_w * diam + 2.0 * diam

    @property
    def per_layer(self) -> int:
        """Particles per emitted layer."""
        return len(self.offsets)

    def layer_time(self, k: int) -> float:
        """When layer ``k`` (0-based) is due [s]."""
        return self.start + k * self.period

    def velocity(self, t: float) -> np.ndarray:
        """The region's velocity at time t: the emission velocity, or SPlisHSPlasH's clearing
        speed ``10 r / 0.25 s`` along d before ``start_time``."""
        speed = self.speed if self.start <= t <= self.end else 10.0 * self.r / CLEAR_AHEAD
        return speed * self.direction

    def emit(self, fluid: ParticleSet, t: float, mass: float, volume: float, rho0: float,
             budget: float = math.inf, phase: int = 0) -> int:
        """Add the layers due by time ``t`` to ``fluid`` (fields x, v, m, V0, rho, rho0 and
        ``phase``, the index of the emitter's material, where the set has it), at most
        ``budget`` particles (a layer is cut short, later ones are skipped, as SPlisHSPlasH does
        at ``maxEmitterParticles``); return how many particles were added."""
        added = 0
        vel = self.speed * self.direction
        extra = {"phase": phase} if "phase" in fluid.specs else {}
        while True:
            tk = self.layer_time(self.count)
            if tk > t or tk > self.end:
                return added
            x = self.x0 + self.offsets + (t - tk) * vel
            take = int(min(len(x), max(budget - added, 0)))
            if take:
                fluid.add(x[:take, : self.dim], name=self.name, m=mass, V0=volume, rho=rho0,
                          rho0=rho0, v=vel[: self.dim], **extra)
            self.count += 1
            self.emitted += take
            added += take

    def animate(self, fluid: ParticleSet, t: float, dt: float) -> None:
        """After the integration of the step ending at time ``t``: particles in the emitter region
        move rigidly with its velocity (see the module docstring)."""
        if fluid.n == 0 or not (self.start - CLEAR_AHEAD <= t <= self.end):
            return
        vel = self.velocity(t)
        h = self.h
        half = 0.5 * self.size
        r_cyl = half[1]
        dev = fluid.device
        launch(animate_body, fluid.n, fluid["x"], fluid["v"], self.dim, to_device(self.x0, dev),
               to_device(self.R, dev), -0.5 * h, 1.5 * h, float(half[1]), float(half[2]),
               self.circle, float(r_cyl * r_cyl), to_device(vel.astype(fluid.dtype), dev),
               float(dt))

    def housing_mesh(self):
        """The housing as a triangle mesh (trimesh), open towards the emit direction: a box
        (cylinder) of ``size`` centred on ``x0``; in 2D its section with z = 0 is sampled."""
        import trimesh

        size = self.size.copy()
        if self.dim == 2:
            size[2] = 2.0 * self.h
        if self.circle:
            mesh = trimesh.creation.cylinder(radius=0.5 * size[1], height=size[0], sections=48)
            turn = np.eye(4)
            turn[:3, :3] = rotation_matrix([0.0, 1.0, 0.0], math.pi / 2)
            mesh.apply_transform(turn)
        else:
            mesh = trimesh.creation.box(extents=size)
        front = mesh.face_normals[:, 0] > 0.99 * np.linalg.norm(mesh.face_normals, axis=1)
        mesh = trimesh.Trimesh(mesh.vertices, mesh.faces[~front], process=False)
        T = np.eye(4)
        T[:3, :3] = self.R
        T[:3, 3] = self.x0
        mesh.apply_transform(T)
        return mesh

    # -- checkpoints ---------------------------------------------------------------------------
    def state(self) -> dict:
        """What a checkpoint needs: the layers and particles emitted so far."""
        return {"count": self.count, "emitted": self.emitted}

    def set_state(self, state: dict) -> None:
        """Restore :meth:`state`."""
        self.count = int(state["count"])
        self.emitted = int(state["emitted"])
