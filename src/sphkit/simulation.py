"""The time-step loop: builds the methods a scene names and advances them in the survey's order.

One step (DESIGN.md, "Data flow of one time step"):

1. every ``zsort_every`` steps, reorder the fluid along a z-order curve;
2. neighbour search (fluid-fluid CSR lists; fluid-boundary lists from the boundary model);
3. density ``rho_i = sum_j m_j W_ij + sum_b rho0 V_b W_ib`` (:func:`core.operators.density_cpu`);
4. time step: CFL ``cfl_factor * 0.4 * 2r / max|v|`` clamped to [dt_min, dt_max], and the pressure
   solver's own limit (acoustic limit of WCSPH);
5. the pressure solver's pre-force hook where it has one (DFSPH: factors and the divergence-free
   solve on the current velocities);
6. accelerations: gravity, then the non-pressure forces (viscosity, vorticity, surface tension,
   drag), then the pressure
   solver, which adds the pressure acceleration (PBF: the acceleration that lands on its
   corrected positions);
7. symplectic Euler;
8. emitters (:mod:`sphkit.emitters`): particles in an emitter's region move with it, then the
   layers due by the new time are added;
9. stability guard: NaN/inf velocities or a speed above ``configuration.max_velocity`` raise
   :class:`InstabilityError` with a diagnosis (step, time, max velocity, CFL number, density error).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from sphkit.boundary.akinci2012 import Akinci2012
from sphkit.boundary.band2018 import MLSPressureExtrapolation
from sphkit.boundary.bender2019 import Bender2019
from sphkit.boundary.koschier2017 import Koschier2017
from sphkit.boundary.maps import MapGeometry
from sphkit.boundary.maps_hydrostatic import WallMomentForce
from sphkit.boundary.rigid import INSET, RigidBodies, body_from_mesh, box_wall, mesh_wall
from sphkit.core.kernels import hexagonal_volume, kernel_id, lattice_volume
from sphkit.core.neighbors import neighbor_lists, zorder_permutation
from sphkit.core.operators import density_cpu
from sphkit.core.particles import ParticleSet
from sphkit.core.solver import PairGradients, SolverStats
from sphkit.core.state import SimState
from sphkit.core.timestep import (
    cfl_time_step,
    max_speed,
    speed_check,
    symplectic_euler,
    wrap_periodic,
)
from sphkit.drag.gissler2017 import Gissler2017
from sphkit.drag.macklin2014 import Macklin2014
from sphkit.emitters import FluidEmitter
from sphkit.geometry import GeometryError
from sphkit.geometry.mesh_sampling import sample_mesh_surface, sample_mesh_volume
from sphkit.geometry.meshes import load_mesh, section_segments
from sphkit.geometry.sampling import box_wall_distance, box_walls, hexagonal_block, lattice_block
from sphkit.pressure.dfsph import DFSPH
from sphkit.pressure.iisph import IISPH
from sphkit.pressure.pbf import PBF
from sphkit.pressure.pcisph import PCISPH
from sphkit.pressure.wcsph import WCSPH
from sphkit.scene.schema import PressureConfig, Scene, SceneError
from sphkit.surface_tension.akinci2013 import Akinci2013
from sphkit.surface_tension.becker2007 import BeckerTeschner2007
from sphkit.surface_tension.he2014 import He2014
from sphkit.surface_tension.mueller2003 import Mueller2003
from sphkit.viscosity.bender2017 import Bender2017
from sphkit.viscosity.peer2015 import Peer2015
from sphkit.viscosity.peer2016 import Peer2016
from sphkit.viscosity.standard import StandardViscosity
from sphkit.viscosity.takahashi2015 import Takahashi2015
from sphkit.viscosity.weiler2018 import Weiler2018
from sphkit.viscosity.xsph import XSPH
from sphkit.vorticity.confinement import VorticityConfinement
from sphkit.vorticity.micropolar_bender2017 import MicropolarBender2017

#: pressure solvers by scene name and by SPlisHSPlasH ``simulationMethod`` number
PRESSURE_SOLVERS: dict[str, type] = {"wcsph": WCSPH, "pcisph": PCISPH, "pbf": PBF,
                                      "iisph": IISPH, "dfsph": DFSPH}
PRESSURE_SOLVER_NUMBERS: dict[int, str] = {0: "wcsph", 1: "pcisph", 2: "pbf", 3: "iisph",
                                           4: "dfsph"}


def build_pressure_solver(p: PressureConfig):
    """The pressure solver a scene's ``configuration.pressure`` names, with its parameters."""
    if p.method == "wcsph":
        return WCSPH(equation=p.equation, stiffness=p.stiffness, exponent=p.exponent,
                     acoustic_cfl=p.acoustic_cfl)
    common = dict(max_error=p.max_error, min_iterations=p.min_iterations,
                  max_iterations=p.max_iterations)
    if p.method == "dfsph":
        return DFSPH(**common, max_error_v=p.max_error_v, max_iterations_v=p.max_iterations_v,
                     divergence_solver=p.divergence_solver)
    if p.method == "iisph":
        return IISPH(**common)
    if p.method == "pcisph":
        return PCISPH(**common)
    if p.method == "pbf":
        return PBF(**common, epsilon=p.pbf_epsilon, s_corr=p.pbf_s_corr, s_corr_k=p.pbf_s_corr_k,
                   s_corr_n=p.pbf_s_corr_n, s_corr_dq=p.pbf_s_corr_dq,
                   velocity_update=p.pbf_velocity_update)
    raise SceneError(
        f"configuration.pressure.method: {p.method!r} is not implemented yet; expected one of "
        f"{sorted(PRESSURE_SOLVERS)}"
    )
#: boundary models by scene name and SPlisHSPlasH ``boundaryHandlingMethod`` number
BOUNDARY_MODELS: dict[str, type] = {"akinci2012": Akinci2012, "koschier2017": Koschier2017,
                                     "bender2019": Bender2019}
BOUNDARY_MODEL_NUMBERS: dict[int, str] = {0: "akinci2012", 1: "koschier2017", 2: "bender2019"}
#: viscosity models by scene name and SPlisHSPlasH ``viscosityMethod`` number
VISCOSITY_MODELS: dict[str, type] = {"standard": StandardViscosity, "xsph": XSPH,
                                     "weiler2018": Weiler2018, "bender2017": Bender2017,
                                     "peer2015": Peer2015, "peer2016": Peer2016,
                                     "takahashi2015": Takahashi2015}
#: (SPlisHSPlasH 2.16+ numbering; XSPH is its separate per-material filter, not a number)
VISCOSITY_MODEL_NUMBERS: dict[int, str] = {1: "standard", 2: "bender2017", 3: "peer2015",
                                           4: "peer2016", 5: "takahashi2015", 6: "weiler2018"}
#: vorticity models by scene name and SPlisHSPlasH ``vorticityMethod`` number
VORTICITY_MODELS: dict[str, type] = {"micropolar": MicropolarBender2017,
                                      "confinement": VorticityConfinement}
VORTICITY_MODEL_NUMBERS: dict[int, str] = {1: "micropolar", 2: "confinement"}
#: surface tension models by scene name and SPlisHSPlasH ``surfaceTensionMethod`` number
SURFACE_TENSION_MODELS: dict[str, type] = {"becker2007": BeckerTeschner2007,
                                            "akinci2013": Akinci2013, "he2014": He2014,
                                            "mueller2003": Mueller2003}
SURFACE_TENSION_MODEL_NUMBERS: dict[int, str] = {1: "becker2007", 2: "akinci2013", 3: "he2014"}
#: drag models by scene name and SPlisHSPlasH ``dragMethod`` number
DRAG_MODELS: dict[str, type] = {"macklin2014": Macklin2014, "gissler2017": Gissler2017}
DRAG_MODEL_NUMBERS: dict[int, str] = {1: "macklin2014", 2: "gissler2017"}


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
    divergence_iterations: int = 0  #: DFSPH's divergence-solver iterations
    divergence_error: float = 0.0  #: DFSPH's average divergence error (fraction of rho0)
    viscosity_iterations: int = 0  #: implicit viscosity solver's iterations (CG or Jacobi)
    #: its final residual: relative |b - A v| / |b| of the CG solves; bender2017: the average
    #: strain-rate error [1/s]
    viscosity_residual: float = 0.0
    #: moving rigid bodies: name, force and torque of the fluid on the body [N, N m] (torque
    #: about its centre of mass or, kinematic, its pivot), position, velocity, angular velocity
    rigid_bodies: list = field(default_factory=list)

    def as_dict(self) -> dict:
        """Plain-dict form (for manifests and logs)."""
        return asdict(self)


#: methods whose pair loops take minimum-image distances (configuration.periodic_x)
PERIODIC_METHODS = {"pressure": {"wcsph", "dfsph"},
                    "viscosity": {"none", "standard", "weiler2018", "bender2017", "peer2015",
                                  "peer2016", "takahashi2015"}, "vorticity": {"none"},
                    "surface_tension": {"none", "becker2007", "akinci2013", "he2014",
                                        "mueller2003"}}


def _check_periodic(scene: Scene, mat) -> None:
    used = {"pressure": scene.configuration.pressure.method,
            "viscosity": mat.viscosity.method, "vorticity": mat.vorticity.method,
            "surface_tension": mat.surface_tension.method}
    for role, name in used.items():
        if name not in PERIODIC_METHODS[role]:
            where = ("configuration.pressure.method" if role == "pressure"
                     else f"materials[{scene.materials.index(mat)}].{role}.method")
            raise SceneError(
                f"{where}: {name!r} does not support configuration.periodic_x yet; expected one "
                f"of {sorted(PERIODIC_METHODS[role])}"
            )


@contextmanager
def _scene_errors() -> Iterator[None]:
    """Geometry that cannot be loaded or sampled (:class:`sphkit.geometry.GeometryError`) as a
    :class:`SceneError` with the same message, so that the user sees exit code 2."""
    try:
        yield
    except GeometryError as e:
        raise SceneError(str(e)) from e


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

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        cfg = scene.configuration
        self.dim = cfg.dim
        self.dtype = np.dtype(cfg.precision)
        r = cfg.particle_radius
        h = 4.0 * r
        kid = kernel_id(cfg.kernel)
        used = ({b.material for b in scene.fluid_blocks} | {f.material for f in scene.fluid_files}
                | {b.material for b in scene.fluid_meshes}
                | {e.material for e in scene.emitters}) or {scene.materials[0].id}
        if len(used) > 1:
            raise SceneError(
                f"fluid_blocks: materials {sorted(used)}; multiphase fluids are not supported yet, "
                "expected all blocks to use one material"
            )
        mat = scene.material(next(iter(used)))
        self.material = mat
        g = np.zeros(self.dim)
        g[:] = cfg.gravity[: self.dim]

        fluid = ParticleSet(self.dim, self.dtype)
        for name in ("v", "a"):
            fluid.register(name, "vector")
        for name in ("m", "V0", "rho", "p"):  # V0 = m / rho0, the rest volume
            fluid.register(name)
        boundary = ParticleSet(self.dim, self.dtype)
        boundary.register("pressure_mirror")
        boundary.register("rigid_body", "scalar", np.int64)  # 1-based moving body, 0 static
        boundary.register("wall_normal", "vector")  # box walls: into the wall (Morris 1997 no-slip)
        boundary.register("wall_distance")  # box walls: distance behind the wall surface [m]
        self._rigid_meshes: list = []  # (k, mesh) of the scene's moving meshes
        self.state = SimState(fluid=fluid, boundary=boundary, dim=self.dim, h=h, kid=kid, r=r,
                              rho0=mat.density0, gravity=g.astype(self.dtype))
        if cfg.periodic_x is not None:
            self.state.period_lo = float(cfg.periodic_x[0])
            self.state.period = float(cfg.periodic_x[1] - cfg.periodic_x[0])
            _check_periodic(scene, mat)
        bm_cls = BOUNDARY_MODELS[cfg.boundary.method]
        self._maps = getattr(bm_cls, "uses_maps", False)  # walls as maps, not particles
        self.emitters = [FluidEmitter(e, self.dim, r, h, name=f"emitters[{k}]")
                         for k, e in enumerate(scene.emitters)]
        with _scene_errors():
            self._sample(scene)
        if fluid.n == 0 and not self.emitters:
            raise SceneError(
                "fluid_blocks, fluid_files: the scene has no fluid particles; expected at least one"
                " (or an emitter)"
            )
        self._lattice_volume = lattice_volume(2.0 * r, kid, h, self.dim)
        self._empty_at_init = fluid.n == 0  # methods that read the fluid initialise at emission

        self.pressure = build_pressure_solver(cfg.pressure)
        if self._maps:
            with _scene_errors():
                geometries = self._map_geometries(scene)
            self.boundary_model = bm_cls(geometries, cache_dir=cfg.boundary.map_cache_dir,
                                         cache=cfg.boundary.map_cache)
            self.boundary_model.hydrostatic = cfg.boundary.pressure == "hydrostatic"
        elif cfg.boundary.pressure == "hydrostatic":
            raise SceneError(
                "configuration.boundary.pressure: 'hydrostatic' acts through the map of a wall; "
                "expected configuration.boundary.method 'koschier2017' or 'bender2019', got "
                f"{cfg.boundary.method!r}")
        else:
            self.boundary_model = bm_cls()
        self.forces: list = []
        vis = mat.viscosity
        if vis.method == "standard":
            self.forces.append(StandardViscosity(vis.coefficient, vis.boundary_coefficient,
                                                 vis.boundary_velocity, vis.morris_beta_max,
                                                 vis.laplacian_eps))
        elif vis.method == "xsph":
            self.forces.append(XSPH(vis.coefficient, vis.boundary_coefficient))
        elif vis.method == "weiler2018":
            self.forces.append(Weiler2018(vis.coefficient, vis.boundary_coefficient,
                                          vis.max_iterations or 100, vis.max_error,
                                          vis.boundary_velocity, vis.morris_beta_max,
                                          vis.laplacian_eps))
        elif vis.method == "takahashi2015":
            self.forces.append(Takahashi2015(vis.coefficient, vis.max_iterations or 100,
                                             vis.max_error))
        elif vis.method == "bender2017":
            self.forces.append(Bender2017(vis.coefficient, vis.max_iterations or 50,
                                          vis.max_error))
        elif vis.method == "peer2015":
            self.forces.append(Peer2015(vis.coefficient, vis.max_iterations or 50, vis.max_error))
        elif vis.method == "peer2016":
            self.forces.append(Peer2016(vis.coefficient, vis.max_iterations or 50, vis.max_error,
                                        vis.max_iterations_omega or 50, vis.max_error_omega))
        vort = mat.vorticity
        if vort.method == "micropolar":
            self.forces.append(MicropolarBender2017(vort.coefficient, vort.viscosity_omega,
                                                    vort.inertia_inverse))
        elif vort.method == "confinement":
            self.forces.append(VorticityConfinement(vort.coefficient))
        st_cfg = mat.surface_tension
        if st_cfg.method != "none":
            self.forces.append(SURFACE_TENSION_MODELS[st_cfg.method](
                st_cfg.coefficient, st_cfg.boundary_coefficient))
        if mat.drag.method != "none":
            self.forces.append(DRAG_MODELS[mat.drag.method](mat.drag.coefficient,
                                                            mat.drag.air_velocity))

        if boundary.n:
            boundary.permute(zorder_permutation(boundary["x"], h))
        self.boundary_model.init(self.state)
        if self._maps and self.boundary_model.hydrostatic:
            self.forces.append(WallMomentForce(self.boundary_model))
        if cfg.boundary.pressure == "mls":
            if self._maps:
                raise SceneError(
                    "configuration.boundary.pressure: 'mls' extrapolates the pressure to boundary "
                    f"particles; expected configuration.boundary.method 'akinci2012', got "
                    f"{cfg.boundary.method!r}")
            # static boundary particles only: rigid bodies keep their own boundary term
            self.state.boundary_pressure = MLSPressureExtrapolation(
                boundary["rigid_body"] == 0)
            self.state.boundary_pressure.init(self.state)
        with _scene_errors():
            self.rigid = self._rigid_bodies(scene)
        for force in self.forces:
            if hasattr(force, "init"):
                force.init(self.state)
        self.pressure.init(self.state)
        self.time = 0.0
        self.step_count = 0
        self.dt = cfg.time.dt
        self.last: StepStats | None = None
        self.last_solver: SolverStats | None = None
        self._frame = -1

    # -- construction ---------------------------------------------------------------------------
    @classmethod
    def from_scene(cls, src: str | Path | Scene | dict) -> Simulation:
        """Build from a built-in scene name, a scene file (sphkit or SPlisHSPlasH) or a Scene."""
        if isinstance(src, Scene):
            return cls(src)
        from sphkit.scene.loader import load_scene

        return cls(load_scene(src))

    def _resolve(self, path: str) -> Path:
        p = Path(path)
        if not p.is_absolute() and self.scene.source:
            p = Path(self.scene.source).parent / p
        return p

    def _sample(self, scene: Scene) -> None:
        st = self.state
        r, dim = st.r, self.dim
        vol = lattice_volume(2.0 * r, st.kid, st.h, dim)

        def clip(pts: np.ndarray) -> np.ndarray:  # periodic along x: keep [lo, lo + L)
            if st.period <= 0.0:
                return pts
            lo = st.period_lo
            return pts[(pts[:, 0] >= lo - 1e-9 * r) & (pts[:, 0] < lo + st.period - 1e-9 * r)]

        for k, blk in enumerate(scene.fluid_blocks):
            bvol = vol
            if blk.lattice == "hexagonal":  # spacing 2r, V = 1 / sum_k W over that lattice
                if dim != 2:
                    raise SceneError(f"fluid_blocks[{k}].lattice: 'hexagonal' in {dim}D; "
                                     "expected 'square' (the hexagonal lattice is 2D only)")
                pts = clip(hexagonal_block(blk.start, blk.end, r))
                bvol = hexagonal_volume(2.0 * r, st.kid, st.h)
            else:
                pts = clip(lattice_block(blk.start, blk.end, r))
            if len(pts) == 0:
                raise SceneError(
                    f"fluid_blocks[{k}]: start {blk.start} end {blk.end} holds no particle of "
                    f"radius {r}; expected a block at least 2r = {2 * r} wide on every axis"
                )
            mat = scene.material(blk.material)
            vel = np.zeros(dim) if blk.velocity is None else np.asarray(blk.velocity, float)
            st.fluid.add(pts, name=f"fluid_blocks[{k}]", m=mat.density0 * bvol, V0=bvol, v=vel,
                         rho=mat.density0)
        for k, ff in enumerate(scene.fluid_files):
            self._add_fluid_file(k, ff, vol)
        for k, fm in enumerate(scene.fluid_meshes):
            mesh = load_mesh(self._resolve(fm.geometry_file), fm.translation,
                             fm.rotation_axis, fm.rotation_angle, fm.scale)
            pts = sample_mesh_volume(mesh, r, dim, invert=fm.invert)
            if len(pts) == 0:
                raise SceneError(
                    f"fluid_meshes[{k}]: {fm.geometry_file!r} holds no particle of radius {r}; "
                    "expected a closed mesh at least 2r wide" + (" that crosses z = 0" if dim == 2
                                                                 else "")
                )
            mat = scene.material(fm.material)
            vel = np.zeros(dim) if fm.velocity is None else np.asarray(fm.velocity, float)
            st.fluid.add(pts, name=f"fluid_meshes[{k}]", m=mat.density0 * vol, V0=vol, v=vel,
                         rho=mat.density0)
        if self._maps:
            # boxes and meshes become maps (see _map_geometries); a moving mesh's map lives in
            # its body's frame (sphkit.boundary.maps, "Moving rigid bodies")
            for k, mb in enumerate(scene.meshes):
                if mb.dynamic or mb.kinematic:
                    self._rigid_meshes.append((k, load_mesh(
                        self._resolve(mb.geometry_file), mb.translation, mb.rotation_axis,
                        mb.rotation_angle, mb.scale)))
            return
        up = int(np.argmax(np.abs(st.gravity))) if np.any(st.gravity) else dim - 1
        for k, box in enumerate(scene.boxes):
            pts = box_walls(box.min, box.max, r, layers=box.layers,
                            open_top_axis=up if box.open_top else None)
            # lattice walls whose Akinci volumes stand for the missing fluid: the boundary
            # pressure is mirrored fully in the iterative solvers (core.ppe.kappa_accel_cached)
            pts = clip(pts)
            dist, normal = box_wall_distance(pts, box.min, box.max)
            st.boundary.add(pts, name=f"boxes[{k}]", pressure_mirror=1.0, wall_distance=dist,
                            wall_normal=normal)
        for k, mb in enumerate(scene.meshes):
            mesh = load_mesh(self._resolve(mb.geometry_file), mb.translation,
                             mb.rotation_axis, mb.rotation_angle, mb.scale)
            pts = sample_mesh_surface(mesh, r, dim)
            if mb.dynamic or mb.kinematic:  # a moving rigid body (sphkit.boundary.rigid)
                from sphkit.boundary.rigid import inset_samples

                # the fluid rests at the mesh surface (see inset_samples); 2D: the section's
                # samples (z = 0) move along the side faces' normals, which lie in the plane
                p3 = np.zeros((len(pts), 3))
                p3[:, :dim] = pts
                pts = inset_samples(mesh, p3, INSET * r)[:, :dim]
                self._rigid_meshes.append((k, mesh))
                # pressure mirrored fully as at the box walls, so that fluid squeezed between a
                # body and a box wall is pushed as the gradient of its density (see RigidBodies)
                st.boundary.add(pts, name=f"meshes[{k}]", rigid_body=len(self._rigid_meshes),
                                pressure_mirror=1.0)
                continue
            st.boundary.add(clip(pts), name=f"meshes[{k}]")
        for k, (em, cfg) in enumerate(zip(self.emitters, scene.emitters, strict=True)):
            if cfg.housing:
                pts = sample_mesh_surface(em.housing_mesh(), r, dim)
                st.boundary.add(clip(pts), name=f"emitters[{k}].housing")

    def _rigid_bodies(self, scene: Scene) -> RigidBodies:
        """The scene's kinematic and dynamic meshes as rigid bodies; static boxes and meshes are
        the walls dynamic bodies collide with."""
        bodies = []
        for k, mesh in self._rigid_meshes:
            mb = scene.meshes[k]
            if self.dim == 2:  # the body moves in the xy-plane
                for fname, ok in (("velocity", lambda u: u[2] == 0.0),
                                  ("angular_velocity", lambda u: u[0] == 0.0 and u[1] == 0.0)):
                    u = getattr(mb, fname)
                    if u is not None and not ok(u):
                        raise SceneError(
                            f"meshes[{k}].{fname}: {list(u)}; expected motion in the xy-plane "
                            "in 2D: velocity (vx, vy, 0), angular_velocity (0, 0, w)")
            if mb.dynamic and scene.configuration.pressure.method == "pbf":
                raise SceneError(f"meshes[{k}].dynamic: true is not coupled to pressure method "
                                 "'pbf'; expected one of dfsph, iisph, pcisph, wcsph")
            if self.state.period > 0.0:
                raise SceneError(f"meshes[{k}]: moving rigid bodies do not support "
                                 "configuration.periodic_x yet")
            try:
                bodies.append(body_from_mesh(f"meshes[{k}]", mesh, mb.dynamic, mb.density,
                                             mb.velocity, mb.angular_velocity,
                                             mb.rotation_center, mb.friction, self.dim))
            except ValueError as e:
                raise SceneError(f"meshes[{k}].geometry_file: {mb.geometry_file!r}: {e}") from None
        walls = []
        if any(b.dynamic for b in bodies):
            up = int(np.argmax(np.abs(self.state.gravity))) if np.any(self.state.gravity) else 2
            for k, box in enumerate(scene.boxes):
                lo = list(box.min) + [-np.inf] * (3 - self.dim)  # 2D: no walls along z
                hi = list(box.max) + [np.inf] * (3 - self.dim)
                walls.append((box_wall(lo, hi, up if box.open_top else None), f"boxes[{k}]"))
            for k, mb in enumerate(scene.meshes):
                if not (mb.dynamic or mb.kinematic):
                    mesh = load_mesh(self._resolve(mb.geometry_file), mb.translation,
                                     mb.rotation_axis, mb.rotation_angle, mb.scale)
                    walls.append((mesh_wall(mesh, mb.invert, self.state.r), f"meshes[{k}]"))
        rigid = RigidBodies(bodies, scene.configuration.pressure.method, walls,
                            margin=INSET * self.state.r,
                            meshes=[mesh for _k, mesh in self._rigid_meshes])
        if bodies:
            rigid.init(self.state)
            if self._maps:  # the moving meshes' maps are queried in their bodies' frames
                self.boundary_model.bind_bodies(rigid.bodies)
            self.boundary_model.rebuild(self.state)
        if rigid.any_dynamic:  # strong coupling: the pressure solves see the bodies give way
            self.state.boundary_response = rigid.pressure_response
        return rigid

    def _add_fluid_file(self, k: int, ff, vol: float) -> None:
        """Fluid from a particle file (``scene.fluid_files[k]``), with the lattice volume."""
        import warnings

        from sphkit.io.particle_files import (
            ParticleFileError,
            load_fluid_particles,
            spacing_warning,
        )

        st = self.state
        try:
            x, v = load_fluid_particles(
                self._resolve(ff.file), self.dim, translation=ff.translation, scale=ff.scale,
                rotation_axis=ff.rotation_axis, rotation_angle=ff.rotation_angle,
                velocity=ff.velocity, angular_velocity=ff.angular_velocity,
                use_file_velocity=ff.use_file_velocity)
        except ParticleFileError as e:
            raise SceneError(f"fluid_files[{k}].file: {e}") from None
        if len(x) == 0:
            raise SceneError(f"fluid_files[{k}].file: {ff.file!r} holds no particles; "
                             "expected at least one")
        note = spacing_warning(x, st.r, f"fluid_files[{k}] ({ff.file})")
        if note:
            warnings.warn(note, UserWarning, stacklevel=3)
        mat = self.scene.material(ff.material)
        st.fluid.add(x, name=f"fluid_files[{k}]", m=mat.density0 * vol, V0=vol, v=v,
                     rho=mat.density0)

    def _map_geometries(self, scene: Scene) -> list[MapGeometry]:
        """Boxes and meshes as signed distances for density and volume maps.

        Boxes are containers (the fluid inside, ``invert``), analytic; an open box extends to
        infinity along the gravity axis. Meshes: 3D triangle meshes, in 2D the section of the
        mesh with the plane z = 0 (as for boundary particles).
        """
        from sphkit.geometry.sdf import BoxDistance, MeshDistance, PolygonDistance

        st, dim = self.state, self.dim
        bc = scene.configuration.boundary
        res = tuple(bc.map_resolution) if bc.map_resolution else None
        up = int(np.argmax(np.abs(st.gravity))) if np.any(st.gravity) else dim - 1
        out = []
        for k, box in enumerate(scene.boxes):
            open_axis = up if box.open_top else None
            out.append(MapGeometry(f"boxes[{k}]", BoxDistance(box.min, box.max, open_axis),
                                   invert=True, resolution=res,
                                   extend_axis=-1 if open_axis is None else open_axis))
        for k, mb in enumerate(scene.meshes):
            mesh = load_mesh(self._resolve(mb.geometry_file), mb.translation,
                             mb.rotation_axis, mb.rotation_angle, mb.scale)
            if dim == 3:
                sdf = MeshDistance(mesh.vertices, mesh.faces)
            else:
                a, b = section_segments(mesh)
                if len(a) == 0:
                    raise SceneError(
                        f"meshes[{k}]: {mb.geometry_file!r} does not cross the plane z = 0; "
                        "expected a mesh whose section is the 2D boundary"
                    )
                sdf = PolygonDistance(a, b)
            mres = tuple(mb.map_resolution) if mb.map_resolution else res
            body, thick = 0, mb.map_thickness
            if mb.dynamic or mb.kinematic:  # a moving body: its map lives in its frame
                body = [j for j, _m in self._rigid_meshes].index(k) + 1
                thick -= BOUNDARY_MODELS[bc.method].moving_inset_in_radii * st.r
            out.append(MapGeometry(f"meshes[{k}]", sdf, invert=mb.invert,
                                   thickness=thick, resolution=mres, body=body))
        return out

    # -- checkpoints ----------------------------------------------------------------------------
    def checkpoint_state(self) -> dict:
        """The clock and the state of components outside the particle fields (JSON-ready)."""
        return {"time": self.time, "step_count": self.step_count, "dt": self.dt,
                "frame": self._frame, "last": None if self.last is None else self.last.as_dict(),
                "emitters": [em.state() for em in self.emitters],
                "empty_at_init": self._empty_at_init, "rigid_bodies": self.rigid.state()}

    def save_checkpoint(self, path: str | Path, extra: dict | None = None,
                        keep: int | None = None) -> Path:
        """Write everything needed to continue this run to ``path`` (see
        :mod:`sphkit.io.checkpoint`); ``extra`` is stored for the caller."""
        from sphkit.io.checkpoint import write_checkpoint

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
        sim = cls(scene)
        sim.restore_checkpoint(ck)
        return sim

    def restore_checkpoint(self, ck) -> None:
        """Load a :class:`~sphkit.io.checkpoint.Checkpoint` of this scene into this simulation."""
        from sphkit.io.checkpoint import CheckpointError

        st = self.state
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

    # -- user-facing state ----------------------------------------------------------------------
    @property
    def fluid(self) -> ParticleSet:
        """The fluid particles (fields x, v, a, m, rho, p, id)."""
        return self.state.fluid

    @property
    def boundary(self) -> ParticleSet:
        """The boundary particles (fields x, V, v, id)."""
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
        st = self.state
        k = self.scene.configuration.zsort_every
        if k and self.step_count % k == 0:
            st.fluid.permute(zorder_permutation(st.fluid["x"], st.h))
        st.nl_ff = neighbor_lists(st.fluid["x"], st.h, st.periodic)
        self.boundary_model.update(st)

    def compute_density(self) -> None:
        """Fluid densities from the current neighbour lists (fluid + boundary)."""
        st = self.state
        f, b = st.fluid, st.boundary
        if getattr(self.pressure, "uses_pair_gradients", False):
            # one pass for the densities and the solver's cached pair gradients
            st.pair_grads = PairGradients(st, with_density=True)
        else:
            st.pair_grads = None
            density_cpu(f["x"], f["m"], st.nl_ff.offsets, st.nl_ff.indices, b["x"], b["V"],
                        st.nl_fb.offsets, st.nl_fb.indices, st.rho0, st.h, st.kid, st.dim,
                        f["rho"], st.period)
        if st.boundary_pressure is not None:  # MLS coefficients of this step's pairs
            st.boundary_pressure.prepare(st)

    def _time_step(self) -> float:
        tc = self.scene.configuration.time
        if not tc.cfl:
            return tc.dt
        st = self.state
        vmax = max_speed(st.fluid["v"], None)
        if self.rigid.bodies:  # moving boundary particles obey the CFL condition too
            vmax = max(vmax, max_speed(st.boundary["v"], None))
        dt = cfl_time_step(vmax, st.r, tc.cfl_factor, tc.dt_min, tc.dt_max)
        return float(min(dt, self.pressure.max_time_step(st)))

    def step(self) -> StepStats:
        """Advance one time step; raises :class:`InstabilityError` when the state blows up."""
        st = self.state
        f = st.fluid
        st.step = self.step_count + 1  # the step being computed (named in solver warnings)
        if f.n == 0:  # nothing to simulate before the first emission
            return self._empty_step()
        self._neighbors()
        self.compute_density()
        dt = self._time_step()
        if self.rigid.bodies:
            self.rigid.begin_step(st)
        pre = getattr(self.pressure, "pre_forces", None)
        if pre is not None:  # DFSPH: factors and the divergence-free solve
            pre(st, dt)
        a = f["a"]
        a[:] = st.gravity[:, None]
        for force in self.forces:
            force.apply(st, dt)
        if st.boundary_response is not None:  # strong coupling: the solve sees the bodies'
            self.rigid.predict(st, dt)  # predicted velocities (gravity), as the fluid's
        ps = self.pressure.solve(st, dt)
        if self.rigid.bodies:  # fluid forces on the bodies, from this step's pressure
            self.rigid.fluid_forces(st)
        st.pair_grads = None  # positions change: the cache is stale
        symplectic_euler(f["x"], f["v"], f["a"], dt)
        if self.rigid.bodies:  # move the bodies and their particles; new boundary grid
            self.rigid.advance(st, dt, self.time)
            self.boundary_model.rebuild(st)
        if st.period > 0.0:
            wrap_periodic(f["x"], st.period_lo, st.period)
        for em in self.emitters:
            em.animate(f, self.time + dt, dt)
        self.dt = dt
        self.time += dt
        self.step_count += 1
        st.time, st.step = self.time, self.step_count
        self._emit()
        vmax, bad = speed_check(f["v"])
        stats = StepStats(step=self.step_count, time=self.time, dt=dt, n_fluid=f.n,
                          max_velocity=vmax, cfl=vmax * dt / (2.0 * st.r),
                          density_error_avg=ps.density_error_avg,
                          density_error_max=ps.density_error_max, iterations=ps.iterations,
                          divergence_iterations=ps.divergence_iterations,
                          divergence_error=ps.divergence_error,
                          rigid_bodies=[b.stats() for b in self.rigid.bodies])
        for force in self.forces:  # implicit non-pressure solvers report their solve
            ks = getattr(force, "stats", None)
            if ks is not None:
                stats.viscosity_iterations, stats.viscosity_residual = ks.iterations, ks.residual
        self.last, self.last_solver = stats, ps
        limit = self.scene.configuration.max_velocity
        if bad or vmax > limit or not np.all(np.isfinite(f["x"])):
            raise InstabilityError(self._diagnosis(stats, bad, limit), stats)
        return stats

    def _emit(self) -> None:
        """Add the emitters' layers due by the current time."""
        if not self.emitters:
            return
        f = self.state.fluid
        for em in self.emitters:
            rho0 = self.scene.material(em.material).density0
            group = [e for e in self.emitters if e.material == em.material]
            caps = [e.max_particles for e in group if e.max_particles is not None]
            budget = min(caps) - sum(e.emitted for e in group) if caps else float("inf")
            em.emit(f, self.time, rho0 * self._lattice_volume, self._lattice_volume, rho0,
                    budget)
        if self._empty_at_init and f.n:  # e.g. PCISPH's template reads the fluid's volume
            self.pressure.init(self.state)
            self._empty_at_init = False

    def _empty_step(self) -> StepStats:
        """A step without fluid (an emitter starts later): the clock advances by time.dt."""
        dt = self.scene.configuration.time.dt
        self.dt = dt
        self.time += dt
        self.step_count += 1
        self.state.time, self.state.step = self.time, self.step_count
        self._emit()
        stats = StepStats(step=self.step_count, time=self.time, dt=dt, n_fluid=self.state.fluid.n,
                          max_velocity=0.0, cfl=0.0, density_error_avg=0.0,
                          density_error_max=0.0, iterations=0)
        self.last, self.last_solver = stats, None
        return stats

    def _diagnosis(self, s: StepStats, bad: int, limit: float) -> str:
        what = (f"{bad} particle(s) with NaN/inf velocity" if bad
                else f"max velocity {s.max_velocity:.4g} m/s exceeds the limit {limit:.4g} m/s")
        return (
            f"simulation unstable at step {s.step}, time {s.time:.6g} s: {what}; "
            f"max velocity {s.max_velocity:.4g} m/s, dt {s.dt:.4g} s, CFL number {s.cfl:.3g}, "
            f"density error avg {100 * s.density_error_avg:.3g}% max "
            f"{100 * s.density_error_max:.3g}%. Try a smaller time step (time.dt_max, "
            f"time.cfl_factor) or a stiffer/iterative pressure solver."
        )

    def run(self, until: float | None = None, fps: float | None = None,
            on_frame: Callable[[Simulation, int], None] | None = None,
            on_step: Callable[[Simulation, StepStats], None] | None = None,
            after_step: Callable[[Simulation], bool] | None = None) -> bool:
        """Step until simulated time ``until`` (default: the scene's), calling ``on_frame(sim, k)``
        at t = 0 and every ``1/fps`` (default: the scene's output fps) and ``on_step`` after each
        step. ``after_step(sim)`` is called once the step's frames are written (checkpoints);
        when it returns True the run stops there. Returns True when ``until`` was reached."""
        until = self.scene.configuration.time.until if until is None else float(until)
        fps = self.scene.output.fps if fps is None else float(fps)
        if self._frame < 0:
            if self.step_count == 0 and self.state.fluid.n:
                self._neighbors()
                self.compute_density()
            self._frame = 0
            if on_frame:
                on_frame(self, 0)
        while self.time < until - 1e-12:
            stats = self.step()
            if on_step:
                on_step(self, stats)
            if on_frame is None:  # no callback: jump to the frame count (a large fps spun here)
                self._frame = max(self._frame, math.floor((self.time + 1e-9) * fps))
            while self.time >= (self._frame + 1) / fps - 1e-9:
                self._frame += 1
                if on_frame:
                    on_frame(self, self._frame)
            if after_step is not None and after_step(self):
                return False
        return True
