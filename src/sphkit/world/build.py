"""``build_world(scene) -> World``: everything a simulation steps, built once from a scene.

DESIGN.md, "One time step": building a world -- sampling the fluid and the walls, loading each
mesh once, building maps and rigid bodies, constructing the methods the scene names from the
registry, checking the scene across its fields -- happens here, never in the step. The
:class:`World` holds the state (particle sets and constants) and the built methods;
:class:`sphkit.simulation.Simulation` steps it.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sphkit import registry
from sphkit.backend import cuda_available
from sphkit.boundary.rigid import RigidBodies
from sphkit.core.coupling import BoundaryCoupling
from sphkit.core.kernels import kernel_id, lattice_volume
from sphkit.core.methods import BoundaryModel, Elasticity, NonPressureForce, PressureSolver
from sphkit.core.particles import ParticleSet
from sphkit.core.state import SimState
from sphkit.core.timestep import Domain
from sphkit.core.viscous import register_wall_fields
from sphkit.core.zorder import zorder_permutation
from sphkit.geometry import GeometryError
from sphkit.multiphase import PhaseForce
from sphkit.scene.checks import check_budget, check_device, check_scene, device_precision
from sphkit.scene.schema import Material, Scene, SceneError
from sphkit.world.animation import AnimationField
from sphkit.world.bodies import rigid_bodies
from sphkit.world.emitters import FluidEmitter, layer_warnings
from sphkit.world.fluid import add_fluid
from sphkit.world.meshes import SceneMeshes
from sphkit.world.settle import SettlePlan
from sphkit.world.startup import StartReport, start_fluid
from sphkit.world.walls import add_wall_particles, check_emitters, domain_box, map_geometries


@dataclass
class World:
    """A built scene: the state and the methods that act on it.

    ``forces`` are the non-pressure forces in the order the step applies them (viscosity,
    vorticity, surface tension, drag, the forces between phases, then the boundary model's
    own), ``force_roles`` their roles (``"viscosity"``, ..., ``"interface_tension"``,
    ``"boundary"``).
    """

    scene: Scene
    state: SimState
    material: Material  #: the first material of the fluid (the reference rest density)
    pressure: PressureSolver
    boundary_model: BoundaryModel
    rigid: RigidBodies
    emitters: list[FluidEmitter]
    #: volume 1 / sum_k W of the 2r lattice: the rest volume of sampled and emitted fluid [m^dim]
    lattice_volume: float
    forces: list[NonPressureForce] = field(default_factory=list)
    force_roles: list[str] = field(default_factory=list)
    #: the box (lo, hi) [m] the fluid must stay in (the static walls' bounding box plus
    #: ``configuration.domain_margin`` h; infinite bounds are open; fluid above the walls' top
    #: is not checked, :class:`~sphkit.core.timestep.Domain`); None: not checked
    domain: Domain | None = None
    #: what the start-up did (:mod:`sphkit.world.startup`): removed particles, relaxation,
    #: masses, the start density error
    start: StartReport = field(default_factory=StartReport)
    #: the settling the simulation runs before t = 0 (:mod:`sphkit.world.settle`), or None
    settle: SettlePlan | None = None
    #: regions imposing a particle field after every step (:mod:`sphkit.world.animation`)
    animation_fields: list[AnimationField] = field(default_factory=list)
    #: the materials of the fluid, in the order of ``scene.materials`` (several: phases)
    materials: list[Material] = field(default_factory=list)
    #: the elasticity of each elastic material (its particles: the objects it names)
    solids: list[Elasticity] = field(default_factory=list)

    @property
    def repeatable(self) -> bool:
        """Whether a step can be computed again with another time step from the state at its
        start, without a copy of that state (``configuration.time.retries``): no moving bodies,
        no elastic solids, no solved walls (a solve keeps their pressures as the next one's warm
        start), and every non-pressure force only adds to the acceleration
        (:attr:`~sphkit.core.methods.NonPressureForce.repeatable`)."""
        walls_solved = self.state.coupling.solved and self.state.boundary.n > 0
        return (not self.rigid.bodies and not self.solids and not walls_solved
                and all(force.repeatable for force in self.forces))


def _state(scene: Scene, mats: list[Material]) -> SimState:
    """Empty particle sets with the fields every method reads, and the constants (the first
    material's rest density is the reference, ``state.rho0``)."""
    mat = mats[0]
    cfg = scene.configuration
    dim = cfg.dim
    dtype = np.dtype(cfg.precision)
    fluid = ParticleSet(dim, dtype)
    for name in ("v", "a"):
        fluid.register(name, "vector")
    for name in ("m", "V0", "rho", "p"):  # V0 = m / rho0, the rest volume
        fluid.register(name)
    # particles added without a rest density (by hand, through the API) get the reference one,
    # not 0 (which would make every rest-density ratio 0 and the first step NaN)
    fluid.register("rho0", fill=mat.density0)
    if len(mats) > 1:  # several fluids: the index of each particle's material in materials
        fluid.register("phase", "scalar", np.int64)
    boundary = ParticleSet(dim, dtype)
    boundary.register("pressure_mirror")
    # lattice walls (scene boxes): the fluid's lattice volume for the particle's cell; 0 (every
    # other boundary particle): Akinci's volume (boundary.akinci2012.static_volumes)
    boundary.register("cell_volume", optional=True)
    boundary.register("rigid_body", "scalar", np.int64)  # 1-based moving body, 0 static
    # box walls: normal into the wall and distance behind its surface (Morris 1997 no-slip), the
    # standard viscosity's factor on its wall term (boxes[].viscosity_factors; 1 elsewhere)
    register_wall_fields(boundary)
    g = np.zeros(dim)
    g[:] = cfg.gravity[:dim]
    r = cfg.particle_radius
    state = SimState(fluid=fluid, boundary=boundary, dim=dim, h=4.0 * r,
                     kid=kernel_id(cfg.kernel), r=r, rho0=mat.density0,
                     gravity=g.astype(dtype), pair_cache=cfg.pair_cache)
    if cfg.periodic_x is not None:
        state.period_lo = float(cfg.periodic_x[0])
        state.period = float(cfg.periodic_x[1] - cfg.periodic_x[0])
    if cfg.periodic_y is not None:
        state.period_lo_y = float(cfg.periodic_y[0])
        state.period_y = float(cfg.periodic_y[1] - cfg.periodic_y[0])
    return state


def _forces(scene: Scene, mats: list[Material]) -> tuple[list[NonPressureForce], list[str]]:
    """The non-pressure forces the fluid's materials name, in the order of the step (by role,
    then by material). Several materials: each acts within its phase
    (:class:`sphkit.multiphase.PhaseForce`)."""
    forces, roles = [], []
    for role in registry.OPTIONAL_ROLES:
        for mat in mats:
            conf = getattr(mat, role)
            if conf.method == "none":
                continue
            built = [registry.get(role, conf.method).load().from_config(conf)]
            if role == "viscosity" and (conf.xsph or conf.xsph_boundary):
                xsph = registry.get("viscosity", "xsph").load()  # SPlisHSPlasH's XSPH beside
                built.append(xsph(conf.xsph, conf.xsph_boundary))
            if len(mats) > 1:
                built = [PhaseForce(f, scene.materials.index(mat), mat.density0) for f in built]
            forces.extend(built)
            roles.extend([role] * len(built))
    return forces, roles


def _interfaces(scene: Scene, mats: list[Material]) -> tuple[list[NonPressureForce],
                                                             list[str]]:
    """The forces between phases the scene's ``interfaces`` name: per role and method, one
    force over the whole fluid, built with ``from_config((table, options))`` -- the (P, P)
    table of coefficients by phase (P materials; 0 where no interface names the pair) and the
    method's other options, which every interface of that method must give alike. An interface
    whose materials are not both in the fluid does nothing (a warning)."""
    fluid_ids = {m.id for m in mats} if len(mats) > 1 else set()
    P = len(scene.materials)
    tables: dict[tuple[str, str], tuple[np.ndarray, Any, int]] = {}
    for k, itf in enumerate(scene.interfaces):
        missing = [mid for mid in itf.materials if mid not in fluid_ids]
        if missing:
            warnings.warn(f"{scene.field(f'interfaces[{k}].materials')}: {missing} not among "
                          f"the fluid's phases ({sorted(fluid_ids) or 'a single fluid'}); the "
                          "interface does nothing", UserWarning, stacklevel=3)
            continue
        a, b = (scene.materials.index(scene.material(mid)) for mid in itf.materials)
        for role, part, conf in (("interface_viscosity", "viscosity", itf.viscosity),
                                 ("interface_tension", "tension", itf.tension)):
            if conf.method == "none" or conf.coefficient == 0.0:
                continue
            t, first, k0 = tables.setdefault((role, conf.method), (np.zeros((P, P)), conf, k))
            t[a, b] = t[b, a] = conf.coefficient
            options = conf.model_dump(exclude={"coefficient"})
            if options != first.model_dump(exclude={"coefficient"}):
                raise SceneError(
                    f"interfaces[{k}].{part}: {options}; expected the options of "
                    f"interfaces[{k0}].{part} ({first.model_dump(exclude={'coefficient'})}): one "
                    f"{conf.method!r} force acts on every interface that names it")
    forces, roles = [], []
    for (role, method), (t, first, _) in tables.items():
        forces.append(registry.get(role, method).load().from_config((t, first)))
        roles.append(role)
    return forces, roles


def _solids(scene: Scene) -> list[Elasticity]:
    """The elasticity of each elastic material, bound to the particle-set objects of the
    material (fluid blocks, files and meshes; solids are not emitted, see scene.checks)."""
    solids = []
    for k, mat in enumerate(scene.materials):
        if not mat.elastic:
            continue
        objects = tuple(
            f"{kind}[{k}]"
            for kind, items in (("fluid_blocks", scene.fluid_blocks),
                                ("fluid_files", scene.fluid_files),
                                ("fluid_meshes", scene.fluid_meshes))
            for k, item in enumerate(items) if item.material == mat.id)
        if not objects:
            continue
        try:  # a combination of fields the method refuses (its message names the field)
            solid = registry.get("elasticity", mat.elasticity.method).load().from_config(
                mat.elasticity)
        except ValueError as e:
            raise SceneError(f"materials[{k}].{e}") from None
        solid.objects = objects
        solids.append(solid)
    return solids


def resolve_device(scene: Scene, device: str) -> str:
    """The device the scene's time step runs on for the asked ``device`` ("auto", "cpu" or
    "cuda"; :func:`sphkit.scene.checks.check_device` with numba-cuda's GPU probe)."""
    return check_device(scene, device, cuda_available)


def scene_for_device(scene: Scene, device: str) -> Scene:
    """``scene`` as it runs on the resolved ``device``: a copy in float32 on the GPU when it
    leaves ``configuration.precision`` unset (:func:`sphkit.scene.checks.device_precision`),
    else ``scene`` itself."""
    precision = device_precision(scene, device)
    if precision == scene.configuration.precision:
        return scene
    scene = scene.model_copy(deep=True)
    scene.configuration.precision = precision
    return scene


def build_world(scene: Scene, device: str = "cpu") -> World:
    """Build the world of a scene for the resolved ``device`` (its precision:
    :func:`scene_for_device`; raises :class:`~sphkit.scene.schema.SceneError` naming the field
    when the scene cannot be built)."""
    scene = scene_for_device(scene, device)
    try:
        return _build(scene)
    except GeometryError as e:  # a mesh that cannot be loaded or sampled: the user's input
        raise SceneError(scene.as_written(str(e))) from None
    except SceneError as e:
        raise SceneError(scene.as_written(str(e))) from None


def _build(scene: Scene) -> World:
    mats = check_scene(scene)
    mat = mats[0]
    cfg = scene.configuration
    state = _state(scene, mats)
    r, h, dim = state.r, state.h, state.dim
    boundary_info = registry.get("boundary", cfg.boundary.method)
    maps = boundary_info.kind == "maps"
    meshes = SceneMeshes(scene)
    # the particle budget, before anything is sampled (the meshes are loaded, not sampled)
    check_budget(scene, meshes.particle_estimates(r, dim, walls=not maps))
    emitters = [FluidEmitter(e, dim, r, h, name=f"emitters[{k}]")
                for k, e in enumerate(scene.emitters)]
    # an emitter outside the walls (its housing would widen the domain to it)
    check_emitters(domain_box(state, scene, meshes, emitters, housings=False), scene,
                   emitters)
    add_fluid(state, scene, meshes)
    if not maps:  # maps: boxes and meshes become signed distances (map_geometries)
        add_wall_particles(state, scene, meshes, emitters)
    if state.fluid.n == 0 and not emitters:
        if scene.fluid_blocks or scene.fluid_files or scene.fluid_meshes:
            raise SceneError(
                f"fluid_blocks, fluid_files: the scene has no fluid particles of radius "
                f"{scene.field('configuration.particle_radius')} = {r:g} m; expected at least "
                "one (or an emitter)"
            )
        # an empty scene (SPlisHSPlasH's Empty.json: its GUI opens it): nothing to simulate
        warnings.warn(f"{scene.field('fluid_blocks')}: the scene has no fluid (no fluid "
                      "blocks, files, meshes or emitters); it runs with 0 particles",
                      UserWarning, stacklevel=2)
    pressure = registry.get("pressure", cfg.pressure.method).load().from_config(cfg.pressure)
    model_cls = boundary_info.load()
    if maps:
        model = model_cls(map_geometries(state, scene, meshes, model_cls.moving_inset(state.dim),
                                         emitters),
                          cache_dir=cfg.boundary.map_cache_dir, cache=cfg.boundary.map_cache)
        # the symmetric term is V_b k_i alone: no wall moment of an extrapolated pressure
        # either (with WCSPH the moment pumped energy into an inviscid dam break: +8 % in 4 s
        # in 2D, +55 % in 3 s in 3D; validation/README.md, "WCSPH's walls by default")
        model.hydrostatic = (cfg.boundary.pressure == "hydrostatic"
                             and not cfg.boundary.symmetric)
        model.symmetric = bool(cfg.boundary.symmetric)
    else:
        model = model_cls()
    forces, roles = _forces(scene, mats)
    if cfg.transport.method != "none":  # a transport velocity (:mod:`sphkit.transport`)
        pb = cfg.transport.background_pressure  # unset: rho0 c^2 of the state equation
        pb = state.rho0 * pressure.acoustic_speed(state) ** 2 if pb is None else pb
        tv = registry.get("transport", cfg.transport.method).load()
        forces.append(tv.from_config((cfg.transport, pb)))
        roles.append("transport")
    between, between_roles = _interfaces(scene, mats)
    forces += between
    roles += between_roles
    bd = state.boundary
    if bd.n:
        bd.permute(zorder_permutation(bd["x"], h))
    model.init(state)
    extra = model.forces()
    forces += extra
    roles += ["boundary"] * len(extra)
    bp = registry.get("boundary_pressure", cfg.boundary.pressure)
    pressure_model = None
    if bp.target is not None and pressure.uses_boundary_pressure:  # a model of its own (MLS)
        # static boundary particles only: rigid bodies keep their own boundary term
        pressure_model = bp.load()(bd["rigid_body"] == 0)
        pressure_model.init(state)
    rigid = rigid_bodies(state, scene, meshes)
    if rigid.bodies:
        rigid.init(state)
    rigid.bind(model, state)  # the boundary model follows the bodies (a grid, or body frames)
    # the one way the solvers meet the boundary: mirror weights, the boundary pressure model,
    # the bodies that yield to the pressure (strong coupling)
    state.coupling = BoundaryCoupling(pressure=pressure_model, moving=rigid, model=model,
                                      symmetric=cfg.boundary.symmetric,
                                      solved=cfg.boundary.solved)
    # the fluid's start: out of the walls, consistent next to them, hydrostatic
    start, settle = start_fluid(state, scene, meshes, model, pressure)
    layer_warnings(state, scene, meshes, model, emitters)
    sound_speed_warning(state, scene, pressure)
    kernel_warning(scene)
    for force in forces:
        force.init(state)
    pressure.init(state)
    solids = _solids(scene)  # the rest configuration: the particles after the start-up
    for solid in solids:
        solid.init(state)
    animations = [AnimationField(a, dim) for a in scene.animation_fields]
    for k, an in enumerate(animations):
        if an.field not in state.fluid.fields:
            warnings.warn(f"{scene.field(f'animation_fields[{k}].field')}: "
                          f"{scene.animation_fields[k].field!r}: the fluid has no such field "
                          "(angular velocity: micropolar vorticity only); the region does nothing",
                          UserWarning, stacklevel=2)
    return World(scene=scene, state=state, material=mat, pressure=pressure,
                 boundary_model=model, rigid=rigid, emitters=emitters,
                 lattice_volume=lattice_volume(2.0 * r, state.kid, h, dim), forces=forces,
                 force_roles=roles, domain=domain_box(state, scene, meshes, emitters),
                 start=start, animation_fields=animations, materials=mats,
                 solids=solids, settle=settle)


def kernel_warning(scene: Scene) -> str | None:
    """Warn (``UserWarning``, also returned) when the scene's kernel is poly6 in 3D (in 2D
    SPlisHSPlasH's numbers other than 0 and 1 read as the cubic spline): its gradient
    vanishes as two particles close in, so the pressure stops keeping them apart (the pairing
    instability; Mueller et al. 2003 use poly6 for densities and the spiky kernel for the
    pressure). Measured (validation/README.md, "Kernels other than the cubic spline"): in the
    built-in 3D dam break the closest pairs fall to 0.01-0.1 r within 0.25 s with every
    solver, DFSPH and IISPH stop as unstable at 0.17-0.2 s, where the cubic, Wendland and
    spiky kernels keep every pair at least 1.1 r apart; SPlisHSPlasH's scenes run with it
    because SPlisHSPlasH's AVX build (the pysplishsplash wheel) computes the densities, and
    DFSPH its gradients, with the cubic spline whatever ``kernel`` says."""
    cfg = scene.configuration
    if cfg.kernel != "poly6" or cfg.dim != 3:
        return None
    note = (f"{scene.field('configuration.kernel')}: poly6's gradient vanishes as two particles "
            "close in, so the pressure does not keep them apart and particles merge in pairs "
            "(the pairing instability; the built-in 3D dam break with it goes unstable at "
            "0.2 s); SPlisHSPlasH's AVX build computes its densities (and DFSPH its gradients) "
            "with the cubic spline whatever this says; expected the cubic spline, Wendland or "
            "spiky (SPlisHSPlasH's kernel 0, 1 or 3)")
    warnings.warn(note, UserWarning, stacklevel=3)
    return note


#: the ratio of a state equation's speed of sound to the fastest speed the fluid is expected to
#: reach below which :func:`sound_speed_warning` warns: there the density varies by (v / c)^2 =
#: 4 % and more (Monaghan's c >= 10 v keeps it near 1 %)
SOUND_SPEED_RATIO = 5.0


def sound_speed_warning(state: SimState, scene: Scene, pressure: PressureSolver) -> str | None:
    """Warn (``UserWarning``, also returned) when the pressure solver's speed of sound c (a
    state equation's: WCSPH, with several fluids the lightest one's, the fastest; the
    incompressible solvers have none) is below
    :data:`SOUND_SPEED_RATIO` times the fastest speed v the fluid is expected to reach: its
    start speed and the fall from its highest particle (and each emitter's layer) to the
    lowest of the fluid and the static boundary particles, ``v = sqrt(v0^2 + 2 |g| H)``, or an
    emitter's speed. Weakly compressible SPH compresses by about (v / c)^2 where the fluid
    moves at v, and fluid that hits a wall near the speed of sound bounces off faster than it
    came: the built-in 3D dam break (1.23 m of water) with WCSPH's default stiffness, 50,000
    Pa (c = 18.7 m/s, 3.8 v), threw particles at 15 m/s through its walls (validation/README.md,
    "WCSPH's speed of sound against the fall"). The stiffness that gives c = 10 v is named
    (the stiffness scales with c^2 in the Tait and the linear equation)."""
    c = pressure.acoustic_speed(state)
    f = state.fluid
    if not math.isfinite(c) or not f.n:
        return None
    x, v = np.asarray(f["x"], float), np.asarray(f["v"], float)
    v0 = float(np.sqrt((v * v).sum(axis=0)).max())
    g = np.asarray(state.gravity, float)[:state.dim]
    gn = float(np.linalg.norm(g))
    cfg = scene.configuration
    falls = gn > 0.0 and not state.gravity_along_period
    up = -g / gn if falls else np.zeros_like(g)
    heights = up @ x
    low = float(heights.min())
    b = state.boundary
    if falls and b.n:
        static = np.asarray(b["rigid_body"]) == 0
        if static.any():
            low = min(low, float((up @ np.asarray(b["x"], float)[:, static]).min()))
    top = float(heights.max())
    speed = math.sqrt(v0 * v0 + 2.0 * gn * max(top - low, 0.0)) if falls else v0
    what = (f"the fluid reaches falling {top - low:.3g} m (its highest particle to the lowest "
            "fluid or wall particle)" if falls else "the fluid moves at")
    for k, em in enumerate(scene.emitters):
        drop = float(up @ np.asarray(em.position[:state.dim], float)) - low if falls else 0.0
        ve = math.sqrt(em.velocity ** 2 + 2.0 * gn * max(drop, 0.0))
        if ve > speed:
            speed, what = ve, f"{scene.field(f'emitters[{k}]')}'s fluid reaches"
    if speed <= 0.0 or c >= SOUND_SPEED_RATIO * speed:
        return None
    ratio = (speed / c) ** 2
    squeeze = f"{100.0 * ratio:.0f} %" if ratio < 1.0 else "more than 100 % (supersonic flow)"
    field_name = scene.field("configuration.pressure.stiffness")
    stiffness = cfg.pressure.stiffness
    note = (f"{field_name}: {stiffness:g} gives a speed of sound of {c:.3g} m/s, {c / speed:.1f} "
            f"times the {speed:.3g} m/s {what}; weakly compressible SPH then compresses by "
            f"about (v/c)^2 = {squeeze} where the fluid moves that fast, and fluid hitting a "
            "wall bounces off faster than it came and can pass through it; "
            f"expected a speed of sound of at least 10 times that speed: a stiffness of "
            f"{stiffness * (10.0 * speed / c) ** 2:.3g} or more (or an incompressible solver)")
    warnings.warn(note, UserWarning, stacklevel=3)
    return note
