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
  the particles in the region at the step's start (:func:`animated`, ``state.animated``) are
  left out of PCISPH's, IISPH's and DFSPH's solves (:func:`sphkit.core.ppe.held`; SPlisHSPlasH's
  DFSPH skips its ``AnimatedByEmitter`` particles so);
* housing: a box (cylinder) of boundary particles around the emitter, ``2h`` long along d and
  centred on ``x0``, open towards d (SPlisHSPlasH's ``EmitterBox.obj``/``EmitterCylinder.obj``
  scaled by ``Emitter::getSize``), unless ``housing`` is false; with density and volume maps
  its walls, :data:`HOUSING_WALL` (2r) thick outside that box, are map geometries
  (:meth:`FluidEmitter.housing_walls`).

Emitted particles get the lattice mass ``rho0 V`` of the scene's fluid blocks. ``max_particles``
(SPlisHSPlasH's per-material ``maxEmitterParticles``) caps the particles the emitters of a
material add (the smallest limit among them counts).

Reuse (``reuse_box``; SPlisHSPlasH's ``emitterReuseParticles`` with ``emitterBoxMin`` and
``emitterBoxMax``, ``EmitterSystem::reuseParticles`` and ``Emitter::emitParticles``): before the
emitters of a material emit, its particles outside the box are collected (in index order) and
slowed to 0.95 of their velocity, so that those waiting do not set the CFL step; a layer takes
them first, each started afresh at its layer position with the emitter's velocity and keeping
its id (:meth:`sphkit.core.particles.ParticleSet.renew`), and only the rest of the layer adds
new particles (within ``max_particles``, which counts the new ones, as SPlisHSPlasH's fluid
model's capacity).
"""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING, Any

import numba
import numpy as np

from sphkit.backend import launch, to_device, to_host
from sphkit.core import arrays
from sphkit.core.particles import ParticleSet
from sphkit.geometry.rotations import rotation_matrix

if TYPE_CHECKING:
    from sphkit.core.methods import BoundaryModel
    from sphkit.core.state import SimState
    from sphkit.scene.schema import Scene
    from sphkit.world.meshes import SceneMeshes

#: SPlisHSPlasH starts animating (clearing) the emitter region this long before start_time [s]
CLEAR_AHEAD = 0.25
#: thickness of a housing's map walls [particle radii] (:meth:`FluidEmitter.housing_walls`):
#: 2r, so that fluid resting at a map wall on either side (1-2.6 r off its surface) lies a
#: kernel support apart and does not interact through it. SPlisHSPlasH's housing meshes are
#: thinner still (``EmitterCylinder.obj``: walls a tenth of the housing's size). With walls h
#: (4r) thick, ``Emitter_2D.json``'s second housing left a gap of 6r to the tank's wall, into
#: which the pool spilled over it; single particles there were pressed together by the two
#: volume-map walls and one was thrown through the tank's wall at 470 m/s (2.54 s; with
#: other tolerances or IISPH at 2.7-3.0 s); with 2r walls (gap 8r) every variant ran 4 s
#: (validation/README.md, "Emitter_2D.json's gap behind its second housing")
HOUSING_WALL = 2.0


@numba.njit(inline="always", cache=True, fastmath=True)
def in_region(i, x, dim, x0, R, lo, hi, hy, hz, circle, r2):
    """Whether particle ``i`` lies in the emitter region (local coordinates ``u = R^T (x -
    x0)``: ``lo <= u0 <= hi`` and ``|u1| <= hy, |u2| <= hz`` (box) or ``u1^2 + u2^2 <= r2``
    (cylinder))."""
    u0 = 0.0
    u1 = 0.0
    u2 = 0.0
    for d in range(dim):
        t = x[d, i] - x0[d]
        u0 += R[d, 0] * t
        u1 += R[d, 1] * t
        u2 += R[d, 2] * t
    if u0 < lo or u0 > hi:
        return False
    if circle:
        return u1 * u1 + u2 * u2 <= r2
    return abs(u1) <= hy and abs(u2) <= hz


@numba.njit(inline="always", cache=True, fastmath=True)
def mark_body(i, x, dim, x0, R, lo, hi, hy, hz, circle, r2, out):
    """``out[i] = 1`` where particle ``i`` lies in the emitter region (:func:`in_region`)."""
    if in_region(i, x, dim, x0, R, lo, hi, hy, hz, circle, r2):
        out[i] = 1


@numba.njit(inline="always", cache=True, fastmath=True)
def animate_body(i, x, v, dim, x0, R, lo, hi, hy, hz, circle, r2, vel, dt):
    """Move particle ``i`` rigidly with ``vel`` if it lies in the emitter region
    (:func:`in_region`)."""
    if not in_region(i, x, dim, x0, R, lo, hi, hy, hz, circle, r2):
        return
    for d in range(dim):
        x[d, i] -= dt * (v[d, i] - vel[d])
        v[d, i] = vel[d]


@numba.njit(inline="always", cache=True, fastmath=True)
def outside_body(i, x, phase, which, lo, hi, dim, v, slow, flag):
    """``flag[i] = 1`` and ``v_i *= slow`` where particle i (of phase ``which``; -1: any) lies
    outside the box ``[lo, hi]``, else ``flag[i] = 0``."""
    out = 0
    if which < 0 or phase[i] == which:
        for d in range(dim):
            if x[d, i] < lo[d] or x[d, i] > hi[d]:
                out = 1
    flag[i] = out
    if out:
        for d in range(dim):
            v[d, i] *= slow


#: SPlisHSPlasH's factor on the velocity of particles waiting outside the reuse box, per step
REUSE_SLOW = 0.95


class ReusePool:
    """The particles of one material outside its emitters' ``reuse_box`` at this emission,
    handed to the layers in index order (:meth:`take`)."""

    def __init__(self, fluid: ParticleSet, box, phase: int) -> None:
        """Collect (and slow) the particles of material index ``phase`` (all particles when the
        set has no ``phase`` field) outside ``box`` (``min``, ``max``)."""
        dim, dev = fluid.dim, fluid.device
        lo = np.full(dim, -np.inf)
        hi = np.full(dim, np.inf)
        k = min(dim, len(box.min))
        lo[:k], hi[:k] = box.min[:k], box.max[:k]
        flag = np.zeros(fluid.n, dtype=np.int8)
        phases = fluid["phase"] if "phase" in fluid.specs else np.zeros(0, dtype=np.int64)
        which = phase if "phase" in fluid.specs else -1
        if fluid.n:
            d_flag = to_device(flag, dev) if dev != "cpu" else flag
            launch(outside_body, fluid.n, fluid["x"], phases, which, to_device(lo, dev),
                   to_device(hi, dev), dim, fluid["v"], REUSE_SLOW, d_flag)
            flag = to_host(d_flag) if dev != "cpu" else flag
        self.index = np.flatnonzero(flag)
        self.used = 0

    def take(self, m: int) -> np.ndarray:
        """The next at most ``m`` particles' indices."""
        out = self.index[self.used:self.used + m]
        self.used += len(out)
        return out


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
        self.reuse_box = getattr(cfg, "reuse_box", None)  #: SPlisHSPlasH's emitter box
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
             budget: float = math.inf, phase: int = 0, pool: ReusePool | None = None) -> int:
        """Add the layers due by time ``t`` to ``fluid`` (fields x, v, m, V0, rho, rho0 and
        ``phase``, the index of the emitter's material, where the set has it), at most
        ``budget`` new particles (a layer is cut short, later ones are skipped, as SPlisHSPlasH
        does at ``maxEmitterParticles``); a layer first takes the particles of ``pool`` (reuse,
        module docstring). Returns how many new particles were added."""
        added = 0
        vel = self.speed * self.direction
        values = dict(m=mass, V0=volume, rho=rho0, rho0=rho0, v=vel[: self.dim])
        if "phase" in fluid.specs:
            values["phase"] = phase
        while True:
            tk = self.layer_time(self.count)
            if tk > t or tk > self.end:
                return added
            x = (self.x0 + self.offsets + (t - tk) * vel)[:, : self.dim]
            reused = pool.take(len(x)) if pool is not None else np.zeros(0, dtype=np.int64)
            if len(reused):
                fluid.renew(reused, x[: len(reused)], **values)
                x = x[len(reused):]
            take = int(min(len(x), max(budget - added, 0)))
            if take:
                fluid.add(x[:take], name=self.name, **values)
            self.count += 1
            self.emitted += take
            added += take

    def animates(self, t: float) -> bool:
        """Whether the region moves particles at time ``t`` (from :data:`CLEAR_AHEAD` before
        ``start_time`` to ``end_time``)."""
        return self.start - CLEAR_AHEAD <= t <= self.end

    def _region(self, dev: str) -> tuple:
        """The region arguments of :func:`in_region` after the particle's (``dim`` to
        ``r2``), on device ``dev``."""
        half = 0.5 * self.size
        return (self.dim, to_device(self.x0, dev), to_device(self.R, dev), -0.5 * self.h,
                1.5 * self.h, float(half[1]), float(half[2]), self.circle,
                float(half[1] * half[1]))

    def animate(self, fluid: ParticleSet, t: float, dt: float) -> None:
        """After the integration of the step ending at time ``t``: particles in the emitter region
        move rigidly with its velocity (see the module docstring)."""
        if fluid.n == 0 or not self.animates(t):
            return
        dev = fluid.device
        launch(animate_body, fluid.n, fluid["x"], fluid["v"], *self._region(dev),
               to_device(self.velocity(t).astype(fluid.dtype), dev), float(dt))

    def mark(self, fluid: ParticleSet, t: float, out) -> bool:
        """``out[i] = 1`` (int8 (N,)) for the particles in the region that the step ending at
        time ``t`` animates (the others are left as they are); returns whether it animates
        then."""
        if fluid.n == 0 or not self.animates(t):
            return False
        launch(mark_body, fluid.n, fluid["x"], *self._region(fluid.device), out)
        return True

    def _housing_extent(self) -> np.ndarray:
        """The housing box's extent in the emitter's frame (``size``; in 2D ``2h`` along z,
        the solid whose z = 0 section is the 2D housing)."""
        size = self.size.copy()
        if self.dim == 2:
            size[2] = 2.0 * self.h
        return size

    def _place(self, mesh, offset=(0.0, 0.0, 0.0), axis_along_x: bool = False):
        """``mesh``, given in the emitter's frame about ``offset``, placed in the scene (its
        rotation R and position x0); ``axis_along_x``: first turn a z-axis solid (trimesh's
        cylinders) to the emit axis."""
        T = np.eye(4)
        R = self.R @ rotation_matrix([0.0, 1.0, 0.0], math.pi / 2) if axis_along_x else self.R
        T[:3, :3] = R
        T[:3, 3] = self.x0 + self.R @ np.asarray(offset, dtype=float)
        mesh.apply_transform(T)
        return mesh

    def housing_mesh(self):
        """The housing as a triangle mesh (trimesh), open towards the emit direction: a box
        (cylinder) of ``size`` centred on ``x0``; in 2D its section with z = 0 is sampled."""
        import trimesh

        size = self._housing_extent()
        if self.circle:
            mesh = trimesh.creation.cylinder(radius=0.5 * size[1], height=size[0], sections=48)
            mesh = self._place(mesh, axis_along_x=True)
        else:
            mesh = self._place(trimesh.creation.box(extents=size))
        front = (mesh.face_normals @ self.direction) > 0.99
        return trimesh.Trimesh(mesh.vertices, mesh.faces[~front], process=False)

    def housing_walls(self, thickness: float) -> list:
        """The housing as closed solids for density and volume maps (trimesh meshes, placed as
        :meth:`housing_mesh`): walls ``thickness`` thick outside the housing's box, the back
        wall behind it (against the emit direction) and the side walls around it, open towards
        the emit direction, without overlaps (each is its own map); a circle emitter's side
        wall is a tube. In 2D the solids reach ``h`` on both sides of z = 0 (their section is
        the 2D wall)."""
        import trimesh

        t = float(thickness)
        s0, s1, s2 = self._housing_extent()
        back = [-0.5 * (s0 + t), 0.0, 0.0]
        if self.circle:
            radius = 0.5 * s1
            return [self._place(trimesh.creation.annulus(r_min=radius, r_max=radius + t,
                                                         height=s0, sections=48),
                                axis_along_x=True),
                    self._place(trimesh.creation.cylinder(radius=radius + t, height=t,
                                                          sections=48), back, True)]
        walls = [self._place(trimesh.creation.box(extents=[t, s1 + 2 * t, s2 + 2 * t]), back)]
        for sign in (-1.0, 1.0):
            walls.append(self._place(trimesh.creation.box(extents=[s0, t, s2 + 2 * t]),
                                     [0.0, sign * 0.5 * (s1 + t), 0.0]))
            if self.dim == 3:
                walls.append(self._place(trimesh.creation.box(extents=[s0, s1, t]),
                                         [0.0, 0.0, sign * 0.5 * (s2 + t)]))
        return walls

    # -- checkpoints ---------------------------------------------------------------------------
    def state(self) -> dict:
        """What a checkpoint needs: the layers and particles emitted so far."""
        return {"count": self.count, "emitted": self.emitted}

    def set_state(self, state: dict) -> None:
        """Restore :meth:`state`."""
        self.count = int(state["count"])
        self.emitted = int(state["emitted"])


def animated(emitters: list[FluidEmitter], fluid: ParticleSet, t: float) -> Any:
    """The particles the emitters' regions move in the step ending at time ``t``, at their
    positions now: int8 (N,), 1 where animated (``SimState.animated``); None where no emitter
    animates then."""
    if not emitters:
        return None
    mask = arrays.zeros(fluid.n, np.int8, like=fluid["x"])
    return mask if any([em.mark(fluid, t, mask) for em in emitters]) else None


def layer_warnings(state: SimState, scene: Scene, meshes: SceneMeshes, model: BoundaryModel,
                   emitters: list[FluidEmitter]) -> list[str]:
    """Warn (``UserWarning``, one per emitter; also returned) where an emitter's layer lies
    inside a wall or closer to its surface than the boundary model lets a fluid block start
    (the test of step 1 on the layer's positions): those particles are emitted there anyway, as
    SPlisHSPlasH emits them, and the walls throw them out. Found with a scene sized in
    particles run at twice its radius (``Emitter.json``: its second emitter, a circle 7
    particles across, reached into the floor, and the run stopped as unstable at 2.1 s;
    validation/README.md, "PCISPH at an emitter")."""
    import dataclasses

    from sphkit.world.startup import inside_walls, wall_label

    notes = []
    for k, em in enumerate(emitters):
        layer = ParticleSet(state.dim, state.fluid.dtype)
        layer.add(np.ascontiguousarray((em.x0 + em.offsets)[:, : state.dim]))
        probe = dataclasses.replace(state, fluid=layer)
        where, names = inside_walls(probe, scene, meshes, model, model.start_reach * state.r)
        hit = where >= 0
        if not hit.any():
            continue
        walls = ", ".join(wall_label(scene, names[w]) for w in np.unique(where[hit]))
        near = f" or within {model.start_reach:g} r of" if model.start_reach > 0 else ""
        notes.append(f"{scene.field(f'emitters[{k}]')}: {int(hit.sum())} of the "
                     f"{em.per_layer} particles of its layer start inside{near} {walls}; they "
                     "are emitted there and thrown out; expected an emitter whose layer "
                     "(width x height in particle diameters) fits between the walls")
    for note in notes:
        warnings.warn(note, UserWarning, stacklevel=3)
    return notes


def emit_all(emitters: list[FluidEmitter], fluid: ParticleSet, t: float, scene,
             lattice_volume: float) -> None:
    """The layers of every emitter due by time ``t``: each material's emitters share its
    particle cap (the smallest ``max_particles`` among them, counting new particles) and its
    reuse pool (particles outside the first ``reuse_box`` among them), each particle with the
    lattice mass ``rho0 V`` of its material."""
    pools: dict[str, ReusePool | None] = {}
    for em in emitters:
        mat = scene.material(em.material)
        group = [e for e in emitters if e.material == em.material]
        caps = [e.max_particles for e in group if e.max_particles is not None]
        budget = min(caps) - sum(e.emitted for e in group) if caps else math.inf
        phase = scene.materials.index(mat)
        if em.material not in pools:
            box = next((e.reuse_box for e in group if e.reuse_box is not None), None)
            pools[em.material] = None if box is None else ReusePool(fluid, box, phase)
        em.emit(fluid, t, mat.density0 * lattice_volume, lattice_volume, mat.density0, budget,
                phase=phase, pool=pools[em.material])
