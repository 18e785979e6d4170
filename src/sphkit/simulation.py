"""The time-step loop: advances a :class:`~sphkit.world.World` in the survey's order.

The world (particles, walls, bodies, emitters and the methods a scene names) is built once by
:func:`sphkit.world.build_world`; one step (DESIGN.md, "One time step"; docs/architecture.md):

1. neighbour search: every ``zsort_every`` steps the fluid is reordered along a z-order curve;
   fluid-fluid CSR lists (with ``neighbor_skin`` > 0 cut from Verlet lists reused across steps,
   :class:`sphkit.core.verlet.VerletLists`), fluid-boundary lists from the boundary model;
2. densities ``rho_i = rho0_i (sum_j V0_j W_ij + sum_b V_b W_ib)`` (number densities of the
   particles' own rest densities, Solenthaler & Pajarola 2008; with the solver's cached pair
   gradients in the same pass where it uses them), the boundary pressure's view (``coupling``);
3. time step: CFL ``cfl_factor * 0.4 * 2r / max|v|`` (fluid and moving boundary) clamped to
   [dt_min, dt_max], and the pressure solver's own limit (WCSPH: acoustic and local stiffness);
4. the pressure solver's ``pre_forces`` (DFSPH: factors and the divergence-free solve on the
   current velocities; a no-op for the others);
5. accelerations: gravity, then the non-pressure forces (viscosity, vorticity, surface tension,
   drag, the boundary model's own, the elasticity of solid materials), then the pressure
   solver, which adds the pressure acceleration (PBF: the acceleration that lands on its
   corrected positions); bodies that yield to the pressure take their non-pressure velocity
   change before the solve (strong coupling);
6. the fluid's force on the rigid bodies from the solver's boundary share of its pressure;
7. symplectic Euler (pinned solid particles are put back at rest; a transport velocity's
   shift, :mod:`sphkit.transport`), then the bodies move (the boundary model follows them);
8. emitters (:mod:`sphkit.world.emitters`): particles in an emitter's region move with it;
   animation fields (:mod:`sphkit.world.animation`) set their particle field inside their
   regions; then the emitters' layers due by the new time are added;
9. stability guard: NaN/inf velocities, a speed above ``configuration.max_velocity``, fluid outside
   the domain (the static walls' bounding box plus ``configuration.domain_margin`` h, computed once,
   for scenes with a container: fluid that leaked through) or, with a fixed time step (``time.cfl``
   off), a CFL number above ``configuration.max_cfl`` raise :class:`InstabilityError` with a
   diagnosis (which of them, step, time, max velocity, CFL number, density error).

On a device (``device="cuda"``) the fields stay there between steps and each pass is a kernel
body launched there (:mod:`sphkit.backend`); :meth:`Simulation.host` copies them back.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from sphkit.core import arrays
from sphkit.core.arrays import on_device
from sphkit.core.hashgrid import DeviceSearch
from sphkit.core.krylov import KrylovStats
from sphkit.core.neighbors import Grid, NeighborList
from sphkit.core.operators import density_cpu
from sphkit.core.particles import ParticleSet
from sphkit.core.solver import PairGradients, SolverStats, log
from sphkit.core.timestep import (
    WallCfl,
    cfl_time_step,
    diagnosis,
    instability,
    iteration_controlled_step,
    max_speed,
    step_check,
    symplectic_euler,
    wrap_periodic,
)
from sphkit.core.verlet import VerletLists
from sphkit.core.zorder import zorder_permutation
from sphkit.scene.schema import Scene
from sphkit.world import World, build_world, resolve_device
from sphkit.world.emitters import animated, emit_all
from sphkit.world.fluid import phase_statistics
from sphkit.world.settle import SettlePlan


@dataclass
class StepStats:
    """Statistics of one time step (SI units; errors as fractions of rho0)."""

    step: int
    time: float
    dt: float
    n_fluid: int
    max_velocity: float
    cfl: float  #: max|v| dt / (2r)
    density_error_avg: float
    density_error_max: float
    iterations: int = 1  #: pressure-solver iterations (1 for WCSPH)
    #: times the step was computed again with half the step after a failed solve (time.retries)
    rejected: int = 0
    divergence_iterations: int = 0  #: DFSPH's divergence-solver iterations
    divergence_error: float = 0.0  #: DFSPH's average divergence error (fraction of rho0)
    viscosity_iterations: int = 0  #: implicit viscosity solver's iterations (CG or Jacobi)
    #: its final residual: relative |b - A v| / |b| of the CG solves; bender2017: the average
    #: strain-rate error [1/s]
    viscosity_residual: float = 0.0
    #: moving rigid bodies: name, force and torque of the fluid on the body [N, N m] (torque
    #: about its centre of mass or, kinematic, its pivot), position, velocity, angular velocity
    rigid_bodies: list = field(default_factory=list)
    #: several fluid materials: per material of the fluid its id, particle count and the
    #: average and largest compression ``max(rho / rho0 - 1, 0)`` of the step's densities
    #: (before the pressure solve) over its particles; empty for one fluid
    phases: list = field(default_factory=list)

    def as_dict(self) -> dict:
        """Plain-dict form (for manifests and logs)."""
        return asdict(self)


class InstabilityError(RuntimeError):
    """The simulation became unstable; ``stats`` holds the step that showed it."""

    def __init__(self, message: str, stats: StepStats) -> None:
        super().__init__(message)
        self.stats = stats


class Simulation:
    """An SPH simulation built from a :class:`~sphkit.scene.schema.Scene`.

    Example::

        sim = Simulation.from_scene("dambreak-2d")
        sim.run(until=0.5)
        x = sim.positions   # (N, dim) NumPy view
    """

    def __init__(self, scene: Scene | World, settle: bool = True, device: str = "auto") -> None:
        """Step the world of ``scene`` (built here with :func:`sphkit.world.build_world`, or
        given ready-built). ``settle``: run the world's settling before t = 0, if it has one
        (:mod:`sphkit.world.settle`; ``configuration.start.settle``). ``device``: ``auto``,
        ``cpu`` or ``cuda`` (:func:`sphkit.world.resolve_device`: ``cuda`` is refused,
        naming the methods, while a method of the scene does not run on the GPU; ``auto`` then
        runs on the CPU); the device it runs on is :attr:`device`."""
        #: the device the time step runs on ("cpu" or "cuda")
        self.device = resolve_device(scene.scene if isinstance(scene, World) else scene, device)
        world = scene if isinstance(scene, World) else build_world(scene, self.device)
        self.world = world
        self.scene = world.scene
        self.dim = world.state.dim
        self.dtype = world.state.fluid.dtype
        self.material = world.material
        self.state = world.state
        self.pressure = world.pressure
        self.boundary_model = world.boundary_model
        self.forces = world.forces
        self.solids = world.solids
        self.rigid = world.rigid
        self.emitters = world.emitters
        self._lattice_volume = world.lattice_volume
        self._domain = world.domain
        self._wall_cfl = WallCfl()  # the guard's CFL number at the walls
        #: a failed solve's step is computed again at most this often (time.retries)
        self.state.retries = self.scene.configuration.time.retries if world.repeatable else 0
        self._empty_at_init = self.state.fluid.n == 0  # methods reading the fluid: at emission
        self.time = 0.0
        self.step_count = 0
        self.dt = self.scene.configuration.time.dt
        self._dt_control = self.dt  #: the step before a frame's landing cut it (cflMethod 2)
        self.last: StepStats | None = None
        self.last_solver: SolverStats | None = None
        self._frame = -1
        skin = self.scene.configuration.neighbor_skin
        #: Verlet lists of the fluid (``configuration.neighbor_skin`` > 0), else None
        self._verlet = VerletLists(skin) if skin > 0.0 else None
        self._search = DeviceSearch(self.state.dim, self.state.h)  # the fluid's, on a device
        if self.device == "cpu":  # the step's search rows and pair gradients in one kept block
            self.state.scratch = arrays.Scratch()
        if settle and world.settle is not None:
            rep = world.start
            rep.settle_steps, rep.settle_time, rep.settle_speed = self.settle(world.settle)

    def settle(self, plan: SettlePlan) -> tuple[int, float, float]:
        """Run the start-up's settling ``plan`` before t = 0 (:mod:`sphkit.world.settle`): the
        step with every velocity damped by ``exp(-gamma dt)``, the fluid of columns in the air
        held in place, until the fluid's root mean square speed is below ``plan.speed`` (after
        at least ``plan.min_time``) or ``plan.max_time``; then the velocities are zeroed and the
        clock reset. Returns (steps, settled time [s], root mean square speed at the end
        [m/s]); (0, 0, nan) when it became unstable and was undone (with a warning)."""
        f = self.state.fluid
        saved = {name: arr.copy() for name, arr in f.fields.items()}
        steps, speed = 0, math.inf
        try:
            while self.time < plan.max_time:
                s = self.step()
                self.host()
                steps += 1
                v = f["v"]
                v *= math.exp(-plan.gamma * s.dt)
                if len(plan.held_ids):
                    k = np.flatnonzero(np.isin(f["id"], plan.held_ids))
                    f["x"][:, k] = plan.held_x[:, np.searchsorted(plan.held_ids, f["id"][k])]
                    v[:, k] = 0.0
                speed = float(np.sqrt((v * v).sum(axis=0).mean())) if f.n else 0.0
                if speed < plan.speed and self.time >= plan.min_time:
                    break
        except InstabilityError as e:
            for name, arr in saved.items():
                f.fields[name][...] = arr
            warnings.warn(f"the start-up's settling became unstable "
                          f"({str(e).splitlines()[0]}); the fluid starts as sampled",
                          UserWarning, stacklevel=2)
            steps, speed = 0, math.nan
        settled = self.time
        f["v"] = 0.0
        self.reset_clock()
        return steps, settled, speed

    def reset_clock(self) -> None:
        """Start the clock again at t = 0, step 0 (after the start-up's settling), with the
        scene's first time step and no statistics of a previous step."""
        self.time, self.step_count = 0.0, 0
        self.dt = self._dt_control = self.scene.configuration.time.dt
        self.last = self.last_solver = None
        self._frame = -1

    # -- construction ---------------------------------------------------------------------------
    @classmethod
    def from_scene(cls, src: str | Path | Scene | dict, device: str = "auto") -> Simulation:
        """Build from a built-in scene name, a scene file (sphkit or SPlisHSPlasH) or a Scene,
        on ``device`` (see :meth:`__init__`)."""
        if isinstance(src, Scene):
            return cls(src, device=device)
        from sphkit.scene.files import load_scene

        return cls(load_scene(src), device=device)

    # -- checkpoints ----------------------------------------------------------------------------
    def checkpoint_state(self) -> dict:
        """The clock and the state of components outside the particle fields (JSON-ready)."""
        return {"time": self.time, "step_count": self.step_count, "dt": self.dt,
                "dt_control": self._dt_control,
                "frame": self._frame, "last": None if self.last is None else self.last.as_dict(),
                "emitters": [em.state() for em in self.emitters],
                "empty_at_init": self._empty_at_init, "rigid_bodies": self.rigid.state(),
                # a solver's own state across steps (PCISPH's adaptive step bound), if any
                "pressure": self.pressure.checkpoint_state()}

    def save_checkpoint(self, path: str | Path, extra: dict | None = None,
                        keep: int | None = None) -> Path:
        """Write everything needed to continue this run to ``path`` (see
        :mod:`sphkit.io.checkpoint`); ``extra`` is stored for the caller."""
        from sphkit.io.checkpoint import write_checkpoint

        self.host()
        return write_checkpoint(path, {"fluid": self.state.fluid, "boundary": self.state.boundary},
                                self.checkpoint_state(), self.scene.model_dump(mode="json"),
                                extra=extra, keep=keep)

    @classmethod
    def from_checkpoint(cls, src) -> Simulation:
        """Continue a run from a checkpoint (a file, a :class:`~sphkit.io.checkpoint.Checkpoint`,
        or an output folder: its newest). The scene is the one stored in the checkpoint; its
        files (meshes, particle files) must still exist. On the CPU, with the same versions and
        thread count, the continued run repeats the uninterrupted one bit for bit."""
        from sphkit.io.checkpoint import Checkpoint, CheckpointError, read_checkpoint

        ck = src if isinstance(src, Checkpoint) else read_checkpoint(src)
        try:
            scene = Scene.model_validate(ck.meta["scene"])
        except Exception as e:
            raise CheckpointError(f"{str(ck.path)!r}: its scene is not valid here ({e})") from None
        sim = cls(scene, settle=False)  # the checkpoint holds the state, settled or not
        sim.restore_checkpoint(ck)
        return sim

    def restore_checkpoint(self, ck) -> None:
        """Load a :class:`~sphkit.io.checkpoint.Checkpoint` of this scene into this simulation."""
        from sphkit.io.checkpoint import CheckpointError

        st = self.state
        self.host()
        if self._verlet is not None:  # the lists are searched afresh after a restore
            self._verlet = VerletLists(self._verlet.skin)
        sets = ck.meta["sets"]
        try:
            old_bx = st.boundary["x"].copy()
            st.boundary.set_state(sets["boundary"], ck.arrays.get("boundary", {}))
            if old_bx.shape != st.boundary["x"].shape or not np.array_equal(old_bx,
                                                                             st.boundary["x"]):
                # the walls moved since the checkpoint's scene was sampled: rebuild the boundary
                # model's structures from the stored walls, keep the stored fields
                self.boundary_model.init(st)
                st.boundary.set_state(sets["boundary"], ck.arrays.get("boundary", {}))
            st.fluid.set_state(sets["fluid"], ck.arrays.get("fluid", {}))
        except (ValueError, KeyError) as e:
            raise CheckpointError(f"{str(ck.path)!r}: {e}") from None
        s = ck.meta["state"]
        self.time = float(s["time"])
        self.step_count = int(s["step_count"])
        self.dt = float(s["dt"])
        self._dt_control = float(s.get("dt_control", self.dt))  # older checkpoints: the step
        self._frame = int(s["frame"])
        st.time, st.step = self.time, self.step_count
        self.last = None if s.get("last") is None else StepStats(**s["last"])
        emitters = s.get("emitters", [])
        if len(emitters) != len(self.emitters):
            raise CheckpointError(f"{str(ck.path)!r}: {len(emitters)} emitter state(s) for "
                                  f"{len(self.emitters)} emitter(s)")
        for em, es in zip(self.emitters, emitters, strict=True):
            em.set_state(es)
        self._empty_at_init = bool(s.get("empty_at_init", False))
        try:
            self.rigid.set_state(s.get("rigid_bodies", []))
        except ValueError as e:
            raise CheckpointError(f"{str(ck.path)!r}: {e}") from None
        if self.rigid.bodies:
            self.boundary_model.rebuild(st)  # the grid of the stored body positions
        if st.fluid.n and not self._empty_at_init:
            self.pressure.init(st)  # re-derive what solvers compute from the fluid
        self.pressure.restore_checkpoint_state(s.get("pressure", {}))
        for solid in self.solids:  # rest lists from the stored rest positions
            solid.init(st)

    # -- user-facing state ----------------------------------------------------------------------
    def host(self) -> None:
        """The fields back on the host after steps on a device (frames, checkpoints, views)."""
        self.state.fluid.to("cpu")
        self.state.boundary.to("cpu")

    def _resident(self) -> None:
        """The particle fields on :attr:`device` for the step (copied there after :meth:`host`)."""
        self.state.fluid.to(self.device)
        self.state.boundary.to(self.device)

    @property
    def fluid(self) -> ParticleSet:
        """The fluid particles (fields x, v, a, m, rho, p, id), on the host."""
        self.host()
        return self.state.fluid

    @property
    def boundary(self) -> ParticleSet:
        """The boundary particles (fields x, V, v, id), on the host."""
        self.host()
        return self.state.boundary

    @property
    def positions(self) -> np.ndarray:
        """Fluid positions (N, dim), a view."""
        return self.fluid.view("x")

    @property
    def velocities(self) -> np.ndarray:
        """Fluid velocities (N, dim), a view."""
        return self.fluid.view("v")

    @property
    def densities(self) -> np.ndarray:
        """Fluid densities (N,)."""
        return self.fluid["rho"]

    @property
    def pressures(self) -> np.ndarray:
        """Fluid pressures (N,)."""
        return self.fluid["p"]

    @property
    def ids(self) -> np.ndarray:
        """Stable particle ids (N,)."""
        return self.fluid["id"]

    # -- stepping -------------------------------------------------------------------------------
    def _neighbors(self) -> None:
        self._resident()
        st = self.state
        k = self.scene.configuration.zsort_every
        reordered = bool(k and self.step_count % k == 0)
        x = st.fluid["x"]
        if reordered:  # on a device the permutation is found and applied there
            st.fluid.permute(self._search.zorder(x) if on_device(x)
                             else zorder_permutation(x, st.h))
        st.nl_ff = NeighborList.empty(0)  # the last step's lists go first (a lower peak)
        x = st.fluid["x"]
        if self._verlet is not None:  # configuration.neighbor_skin: lists reused across steps
            st.nl_ff = self._verlet.lists(x, st.h, st.periodic, rebuild=reordered)
        elif on_device(x):  # the hashed grid's passes as kernel bodies, where the fluid is
            st.nl_ff = self._search.lists(x)
        else:  # the fluid's grid serves the boundary's search too (its cells)
            st.fluid_grid = grid = Grid(x, st.h)
            st.nl_ff = grid.query_own(x, st.periodic, scratch=st.scratch, slot="fluid")
        self.boundary_model.update(st)
        st.fluid_grid = None

    def compute_density(self) -> None:
        """Fluid densities from the current neighbour lists (fluid + boundary)."""
        st = self.state
        f, b = st.fluid, st.boundary
        st.hold_rest()  # rest densities and masses as they are now, to the pressure solve's end
        if self.pressure.uses_pair_gradients:
            # one pass for the densities and the solver's cached pair gradients
            st.pair_grads = PairGradients(st, with_density=True, scratch=st.scratch)
        else:
            st.pair_grads = None
            rest = st.rest()
            density_cpu(f["x"], rest.mu, st.nl_ff.offsets, st.nl_ff.indices, b["x"], b["V"],
                        st.nl_fb.offsets, st.nl_fb.indices, st.rho0, st.h, st.kid, st.dim,
                        f["rho"], st.pair_period, c=rest.c)
        st.coupling.prepare(st)  # a boundary pressure model's view of this step (MLS)

    def _time_step(self) -> float:
        tc = self.scene.configuration.time
        if not tc.cfl:
            return tc.dt
        st = self.state
        # moving boundary particles obey the CFL condition too
        vmax = max(max_speed(st.fluid["v"], None), self.rigid.max_speed(st))
        dt = cfl_time_step(vmax, st.r, tc.cfl_factor, tc.dt_min, tc.dt_max)
        if self.step_count and tc.iteration_control and self.last is not None:
            dt = min(dt, iteration_controlled_step(self._dt_control, self.last.iterations,
                                                   tc.dt_min))
        dt = min(dt, self.pressure.max_time_step(st))
        for solid in self.solids:  # an explicit elasticity's own bound
            dt = min(dt, solid.max_time_step(st))
        for force in self.forces:  # an explicit viscosity's diffusion bound
            dt = min(dt, force.max_time_step(st))
        # the rule's last step, before a frame's landing and the first step's cut (as
        # SPlisHSPlasH 2.19, whose second step is the CFL one with cflMethod 2 too:
        # validation/README.md, "The step with iteration control against SPlisHSPlasH")
        self._dt_control = float(dt)
        if self.step_count == 0:  # a run starts with the scene's initial step (timeStepSize)
            dt = min(dt, tc.dt)
        return float(dt)

    def step(self, land_at: float | None = None) -> StepStats:
        """Advance one time step; raises :class:`InstabilityError` when the state blows up.

        ``land_at``: a time ahead that the steps must land on exactly (a frame time). The
        interval left to it is split into equal steps no longer than the step the CFL condition
        and the solver allow (so no sliver step is left before it), and the step that reaches it
        ends at ``land_at`` itself."""
        st = self.state
        f = st.fluid
        st.step = self.step_count + 1  # the step being computed (named in solver warnings)
        if f.n == 0:  # nothing to simulate before the first emission
            return self._empty_step(land_at)
        self._neighbors()  # neighbour search (and the boundary's neighbours)
        self.compute_density()  # densities
        dt = self._time_step()  # CFL step and the solver's own bound
        lands = False
        if land_at is not None and land_at > self.time:
            parts = math.ceil((land_at - self.time) / dt * (1.0 - 1e-12))
            dt, lands = (land_at - self.time) / parts, parts == 1
        self.rigid.begin_step(st)  # this step's body frames
        st.animated = animated(self.emitters, f, self.time + dt)  # moved, not solved for
        ps = self._forces_and_pressure(dt)
        rejected = 0  # a failed solve: the step again with the solver's shrunk bound
        while rejected < st.retries and self.pressure.rejects(ps):
            rejected += 1
            dt, lands = min(0.5 * dt, self.pressure.max_time_step(st)), False
            self._dt_control = dt  # the step taken is the last step of iteration_control
            log.warning("step %d: the pressure solve failed (error %.3g%%, %d iterations, a "
                        "particle moved %.2g r); computed again with dt %.4g s (time.retries)",
                        st.step, 100 * ps.density_error_avg, ps.iterations, ps.displacement, dt)
            ps = self._forces_and_pressure(dt)
        if self.rigid.bodies:  # the fluid's push on the bodies
            self.rigid.fluid_forces(st, self.pressure.boundary_reaction(st))
        st.pair_grads = None  # positions change: the cache is stale
        st.hold_rest(False)
        symplectic_euler(f["x"], f["v"], f["a"], dt)  # integrate
        for force in self.forces:  # a transport velocity's share of the displacement
            force.advect(st, dt)
        for solid in self.solids:  # pinned solid particles stay at rest
            solid.constrain(st)
        self.rigid.advance(st, dt, self.time)  # move the bodies (the boundary follows)
        for a, lo, L in st.periodic_axes:  # periodic domain along x (and y)
            wrap_periodic(f["x"], lo, L, a)
        for em in self.emitters:
            em.animate(f, self.time + dt, dt)
        for an in self.world.animation_fields:  # regions imposing a field (SPlisHSPlasH's)
            an.apply(f, self.time + dt, dt)
        self.dt = dt
        self.time = land_at if lands else self.time + dt
        self.step_count += 1
        st.time, st.step = self.time, self.step_count
        self._emit()
        vmax, bad, clean = step_check(f["x"], f["v"], self._domain)
        stats = StepStats(step=self.step_count, time=self.time, dt=dt, n_fluid=f.n,
                          max_velocity=vmax, cfl=vmax * dt / (2.0 * st.r),
                          density_error_avg=ps.density_error_avg,
                          density_error_max=ps.density_error_max, iterations=ps.iterations,
                          divergence_iterations=ps.divergence_iterations,
                          divergence_error=ps.divergence_error, rejected=rejected,
                          rigid_bodies=[b.stats() for b in self.rigid.bodies])
        if len(self.world.materials) > 1:
            stats.phases = phase_statistics(f, self.world.materials, self.scene.materials)
        ks = self._viscosity_stats()  # an implicit viscosity reports its solve
        if ks is not None:
            stats.viscosity_iterations, stats.viscosity_residual = ks.iterations, ks.residual
        self.last, self.last_solver = stats, ps
        self._stability_guard(stats, bad, clean)
        return stats

    def _forces_and_pressure(self, dt: float) -> SolverStats:
        """The non-pressure forces and the pressure solve of a step of ``dt`` [s]."""
        st = self.state
        self.pressure.pre_forces(st, dt)  # DFSPH: factors and the divergence-free solve
        arrays.fill_rows(st.fluid["a"], st.gravity)  # non-pressure forces
        for force in self.forces:
            force.apply(st, dt)
        for solid in self.solids:  # elasticity of the solid materials
            solid.apply(st, dt)
        st.coupling.predict(st, dt)  # yielding bodies take their non-pressure velocity change
        return self.pressure.solve(st, dt)  # pressure

    def _viscosity_stats(self) -> KrylovStats | None:
        """The last solve of the material's viscosity, when it is implicit (several fluids:
        the first material's implicit one)."""
        for force, role in zip(self.forces, self.world.force_roles, strict=True):
            if role == "viscosity" and force.stats is not None:
                return force.stats
        return None

    def _emit(self) -> None:
        """Add the emitters' layers due by the current time."""
        f = self.state.fluid
        if self.emitters:
            emit_all(self.emitters, f, self.time, self.scene, self._lattice_volume)
        if self._empty_at_init and f.n:  # e.g. PCISPH's template reads the fluid's volume
            self.pressure.init(self.state)
            self._empty_at_init = False

    def _empty_step(self, land_at: float | None = None) -> StepStats:
        """A step without fluid (an emitter starts later): the clock advances by time.dt, or
        lands on ``land_at`` (a frame) where that is nearer, as a step with fluid does."""
        dt = self.scene.configuration.time.dt
        lands = land_at is not None and self.time < land_at <= self.time + dt
        if lands:
            dt = land_at - self.time
        self.dt = dt
        self.time = land_at if lands else self.time + dt
        self.step_count += 1
        self.state.time, self.state.step = self.time, self.step_count
        self._emit()
        stats = StepStats(step=self.step_count, time=self.time, dt=dt, n_fluid=self.state.fluid.n,
                          max_velocity=0.0, cfl=0.0, density_error_avg=0.0,
                          density_error_max=0.0, iterations=0)
        self.last, self.last_solver = stats, None
        return stats

    def _stability_guard(self, s: StepStats, bad: int, clean: bool = False) -> None:
        """Raise :class:`InstabilityError` when the step shows the run blowing up or leaking
        (:func:`sphkit.core.timestep.instability`; ``clean``: :func:`sphkit.core.timestep.
        step_check` found the positions finite and inside the domain)."""
        cfg = self.scene.configuration
        what, advice = instability(cfg, self.state.fluid["x"], s, bad, self._domain, clean,
                                   self.scene.field, self._wall_cfl(cfg, s, self.state))
        if self.rigid.diverged:  # a body's pose stopped being finite (its particles stayed)
            what, advice = self.rigid.divergence(), ""
        if what:  # fields named as the scene wrote them (a translated scene's own first)
            raise InstabilityError(diagnosis(s, what, advice, self.scene.field), s)

    def run(self, until: float | None = None, fps: float | None = None,
            on_frame: Callable[[Simulation, int], None] | None = None,
            on_step: Callable[[Simulation, StepStats], None] | None = None,
            after_step: Callable[[Simulation], bool] | None = None,
            exact_frames: bool = False) -> bool:
        """Step until simulated time ``until`` (default: the scene's), calling ``on_frame(sim, k)``
        at t = 0 and after the first step at or after each ``k / fps`` (default: the scene's
        output fps; at most once per step: when a step is longer than ``1 / fps`` the frames it
        passes over are skipped and ``k`` jumps) and ``on_step`` after each step.
        ``after_step(sim)`` is called once the step's frame is written (checkpoints); when it
        returns True the run stops there. Returns True when ``until`` was reached.

        ``exact_frames``: the steps land exactly on every frame time ``k / fps`` and on
        ``until`` (:meth:`step`'s ``land_at``; the steps before a frame are shortened evenly), so
        that frame ``k`` is the state at ``k / fps`` itself rather than at the first step after
        it: datasets of frame differences (:mod:`sphkit.io.datasets`) need it, since at a high
        frame rate that lag is as large as a frame's change of velocity."""
        until = self.scene.configuration.time.until if until is None else float(until)
        fps = self.scene.output.fps if fps is None else float(fps)
        if not 0.0 < fps < math.inf or math.isnan(until):
            raise ValueError(f"fps {fps}, until {until}: expected a positive finite frame rate "
                             "[1/s] and a simulated end time [s]")
        if self._frame < 0:
            if self.step_count == 0 and self.state.fluid.n:
                self._neighbors()
                self.compute_density()
            self._frame = 0
            if on_frame:
                self.host()
                on_frame(self, 0)
        while self.time < until - 1e-12:
            if exact_frames:
                stats = self.step(min((self._frame + 1) / fps, until))
            elif self.state.fluid.n:
                stats = self.step()
            else:  # a step without fluid (time.dt, any length) lands on until, not past it
                stats = self.step(until)
            if on_step:
                on_step(self, stats)
            if self.time >= (self._frame + 1) / fps - 1e-9:
                # at most one frame per step: frame k is the first step at or after k / fps, so
                # the frames a long step passes over are skipped, not written all at once
                self._frame = max(self._frame + 1, math.floor((self.time + 1e-9) * fps))
                if on_frame:
                    self.host()
                    on_frame(self, self._frame)
            if after_step is not None and after_step(self):
                return False
        return True
