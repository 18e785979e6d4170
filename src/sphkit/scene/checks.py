"""Checks across fields of a scene, before a world is built from it.

The scene model (:mod:`sphkit.scene.schema`) validates each field on its own; what a scene
must satisfy across fields -- that every method it names can do what the scene asks of it
(periodic domains, dynamic rigid bodies), that the boundary pressure fits the boundary model,
that 2D bodies move in the plane -- is checked here, against the capabilities of the methods in
:mod:`sphkit.registry`. Every check raises :class:`~sphkit.scene.schema.SceneError` naming the
field, the value and what was expected (``sphkit run`` exits with code 2).

Also here: the particle budget (:func:`check_budget`: the particles a scene needs, estimated from
the extents of its blocks, boxes, meshes and emitters and the particle radius before anything is
sampled, against ``configuration.max_particles``) and the warnings about fluid that is probably
not where the user meant it (:func:`scene_warnings`: a block outside every box, overlapping
blocks).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence

from sphkit import registry
from sphkit.scene.schema import Box, Material, Scene, SceneError

#: the pressure solvers a transport velocity (``configuration.transport``) works with: its
#: shift assumes the explicit step of a state equation (the iterative solvers correct positions
#: or velocities towards rest density on their own, which the shift would undo)
TRANSPORT_PRESSURE = ("wcsph",)

#: the roles whose methods must support ``configuration.periodic_x`` (and ``periodic_y``)
PERIODIC_ROLES = ("pressure", "viscosity", "vorticity", "surface_tension", "drag")


def fluid_materials(scene: Scene) -> list[Material]:
    """The materials of the scene's fluid (blocks, files, meshes, emitters), in the order of
    ``materials``; the first when there is no fluid. Several are phases of one fluid
    (:mod:`sphkit.multiphase`): the pressure solver and the boundary model must read each
    particle's own rest density (registry capability ``multiphase``)."""
    used = scene.fluid_material_ids() or {scene.materials[0].id}
    mats = [m for m in scene.materials if m.id in used]
    if len(mats) > 1:
        cfg = scene.configuration
        for role, where, name in (("pressure", "configuration.pressure.method",
                                   cfg.pressure.method),
                                  ("boundary", "configuration.boundary.method",
                                   cfg.boundary.method)):
            ok = registry.with_capability(role, "multiphase")
            if name not in ok:
                raise SceneError(
                    f"{where}: {name!r} does not support several fluid materials yet (the "
                    f"fluid uses {sorted(m.id for m in mats)}); expected one of {sorted(ok)}")
    return mats


def fluid_material(scene: Scene) -> Material:
    """The first material of the scene's fluid (:func:`fluid_materials`)."""
    return fluid_materials(scene)[0]


def _periodic(scene: Scene, mat: Material, axis: str = "x") -> None:
    """The methods of ``mat`` support a periodic ``axis`` (x: capability ``periodic``, y:
    ``periodic_y``); no moving bodies."""
    cfg = scene.configuration
    k = scene.materials.index(mat)
    field, cap = f"configuration.periodic_{axis}", "periodic" if axis == "x" else "periodic_y"
    for role in PERIODIC_ROLES:
        if role == "pressure":
            where, name = "configuration.pressure.method", cfg.pressure.method
        else:
            where, name = f"materials[{k}].{role}.method", getattr(mat, role).method
        ok = registry.with_capability(role, cap)
        if name != "none" and name not in ok:
            expected = sorted(ok) if role == "pressure" else sorted(("none", *ok))
            raise SceneError(f"{where}: {name!r} does not support {field} yet; "
                             f"expected one of {expected}")
        if role == "viscosity" and (mat.viscosity.xsph or mat.viscosity.xsph_boundary) and (
                "xsph" not in ok):
            raise SceneError(f"materials[{k}].viscosity.xsph: XSPH does not support {field} "
                             "yet; expected 0")
    if any(mb.moving for mb in scene.meshes):
        k = next(k for k, mb in enumerate(scene.meshes) if mb.moving)
        raise SceneError(f"meshes[{k}]: moving rigid bodies do not support {field} yet")


def _boundary_pressure(scene: Scene) -> None:
    bc = scene.configuration.boundary
    kind = registry.get("boundary", bc.method).kind
    model = registry.get("boundary_pressure", bc.pressure)
    if kind in model.boundary:
        return
    fits = sorted(m.name for m in registry.methods("boundary") if m.kind in model.boundary)
    what = {"hydrostatic": "'hydrostatic' acts through the map of a wall",
            "mls": "'mls' extrapolates the pressure to boundary particles"}.get(
        bc.pressure, f"{bc.pressure!r} acts on {' or '.join(model.boundary)}")
    expected = (f"'{fits[0]}'" if len(fits) == 1
                else " or ".join(f"'{n}'" for n in fits))
    raise SceneError(f"configuration.boundary.pressure: {what}; expected "
                     f"configuration.boundary.method {expected}, got {bc.method!r}")


def _free_surface(scene: Scene) -> None:
    """``pressure.free_surface: false`` (a closed domain, :mod:`sphkit.pressure.dfsph`) is
    DFSPH's and IISPH's, in a domain periodic along every axis without walls or bodies: next to
    a wall the signed pressures pull the fluid in (validation/README.md, "DFSPH in closed
    domains")."""
    cfg = scene.configuration
    if cfg.pressure.free_surface is not False:
        return
    what = "configuration.pressure.free_surface: false"
    if cfg.pressure.method not in ("dfsph", "iisph"):
        raise SceneError(f"{what} with configuration.pressure.method "
                         f"{cfg.pressure.method!r}; expected 'dfsph' or 'iisph' (or "
                         "free_surface true / null)")
    if cfg.dim == 3:  # no periodic_z: a 3D domain is never periodic along every axis
        raise SceneError(f"{what} needs a domain periodic along every axis, which 3D scenes "
                         "cannot have (periodic_x and periodic_y only); expected dim 2 (or "
                         "free_surface true / null)")
    missing = [f"configuration.periodic_{axis}" for axis in ("x", "y")
               if getattr(cfg, f"periodic_{axis}") is None]
    if missing:
        raise SceneError(f"{what} needs a domain periodic along every axis; "
                         f"{', '.join(missing)} not set (or free_surface true / null)")
    walls = [f"{kind}[0]" for kind in ("boxes", "meshes") if getattr(scene, kind)]
    if walls:
        raise SceneError(f"{what} with walls or bodies ({', '.join(walls)}); expected none: "
                         "next to a wall the signed pressures pull the fluid in (or "
                         "free_surface true / null)")


def _bodies(scene: Scene) -> None:
    solver = scene.configuration.pressure.method
    for k, mb in enumerate(scene.meshes):
        if not mb.moving:
            continue
        if scene.configuration.dim == 2:  # the body moves in the xy-plane
            for fname, ok in (("velocity", lambda u: u[2] == 0.0),
                              ("angular_velocity", lambda u: u[0] == 0.0 and u[1] == 0.0)):
                u = getattr(mb, fname)
                if u is not None and not ok(u):
                    raise SceneError(
                        f"meshes[{k}].{fname}: {list(u)}; expected motion in the xy-plane "
                        "in 2D: velocity (vx, vy, 0), angular_velocity (0, 0, w)")
        coupled = registry.with_capability("pressure", "dynamic_bodies")
        if mb.dynamic and solver not in coupled:
            raise SceneError(f"meshes[{k}].dynamic: true is not coupled to pressure method "
                             f"{solver!r}; expected one of {', '.join(sorted(coupled))}")


def _lattices(scene: Scene) -> None:
    dim = scene.configuration.dim
    for k, blk in enumerate(scene.fluid_blocks):
        if blk.lattice == "hexagonal" and dim != 2:
            raise SceneError(f"fluid_blocks[{k}].lattice: 'hexagonal' in {dim}D; "
                             "expected 'square' (the hexagonal lattice is 2D only)")


# -- the particle budget --------------------------------------------------------------------------
def _cells(extent: Sequence[float], r: float) -> list[float]:
    """Lattice sites of spacing 2r along each axis of an extent (at least one, as floats so
    that absurd scenes give a large number instead of an overflow)."""
    return [max(1.0, float(e) / (2.0 * r)) for e in extent]


def _box_walls(box: Box, r: float) -> float:
    """The wall particles of a box: ``layers`` lattice layers around its inside."""
    n = [c + 2.0 * box.layers for c in _cells([b - a for a, b in zip(box.min, box.max,
                                                                       strict=True)], r)]
    return 2.0 * box.layers * sum(math.prod(n[:i] + n[i + 1:]) for i in range(len(n)))


def _emitted(scene: Scene, k: int, r: float) -> float:
    """Particles emitter ``k`` adds until ``time.until`` (or its ``max_particles``)."""
    e = scene.emitters[k]
    dim = scene.configuration.dim
    per_layer = max(1.0, e.width / (2.0 * r))
    if dim == 3:
        per_layer *= max(1.0, (e.width if e.height is None else e.height) / (2.0 * r))
    end = scene.configuration.time.until if e.end_time is None else e.end_time
    end = min(end, scene.configuration.time.until)
    layers = 1.0 + max(0.0, end - e.start_time) * e.velocity / (2.0 * r)
    total = per_layer * layers
    if e.max_particles is not None:
        total = min(total, float(e.max_particles))
    return total + 4.0 * per_layer  # the first layer and the housing around it


def particle_estimate(scene: Scene,
                      extra: Sequence[tuple[str, float]] = ()) -> list[tuple[str, float]]:
    """The particles (and map grid points) each part of a scene needs, estimated from its
    extent and the particle radius without sampling anything: ``(field, count)`` pairs.

    ``extra`` adds the parts only a loaded mesh can tell (:mod:`sphkit.world`: mesh walls and
    fluid meshes, from their areas and bounding boxes). Particle files are not counted (their
    size bounds them).
    """
    cfg = scene.configuration
    r = cfg.particle_radius
    out: list[tuple[str, float]] = []
    for k, blk in enumerate(scene.fluid_blocks):
        extent = [b - a for a, b in zip(blk.start, blk.end, strict=True)]
        out.append((f"fluid_blocks[{k}]", math.prod(_cells(extent, r))))
    maps = registry.get("boundary", cfg.boundary.method).kind == "maps"
    for k, box in enumerate(scene.boxes):
        if not maps:
            out.append((f"boxes[{k}]", _box_walls(box, r)))
    for k in range(len(scene.emitters)):
        out.append((f"emitters[{k}]", _emitted(scene, k, r)))
    if maps:  # a grid given by the scene (the automatic one is bounded by the map module)
        for k, mb in enumerate(scene.meshes):
            res = mb.map_resolution or cfg.boundary.map_resolution
            if res:
                where = (f"meshes[{k}].map_resolution" if mb.map_resolution
                         else "configuration.boundary.map_resolution")
                out.append((where, math.prod(float(n) + 1.0 for n in res)))
    out.extend(extra)
    return out


def check_budget(scene: Scene, extra: Sequence[tuple[str, float]] = ()) -> None:
    """Refuse a scene that needs more than ``configuration.max_particles`` particles (see
    :func:`particle_estimate`), naming the count, the radius and the largest part."""
    cfg = scene.configuration
    parts = particle_estimate(scene, extra)
    total = sum(n for _, n in parts)
    if not total > cfg.max_particles:
        return
    where, n = max(parts, key=lambda p: p[1])
    what = "grid points" if "map_resolution" in where else "particles"
    raise SceneError(
        f"{scene.field(where)}: needs about {n:.3g} {what} of radius "
        f"{scene.field('configuration.particle_radius')} = "
        f"{cfg.particle_radius:g} m (the scene about {total:.3g} in all), more than the budget "
        f"of {cfg.max_particles:,} (configuration.max_particles, sphkit run --max-particles); "
        "expected a larger particle radius or a smaller extent")


# -- warnings ------------------------------------------------------------------------------------
def _inside(lo: Sequence[float], hi: Sequence[float], box: Box, up: int | None,
            tol: float) -> bool:
    """Whether [lo, hi] lies inside the box (an open box reaches up forever)."""
    for i, (a, b) in enumerate(zip(lo, hi, strict=True)):
        top = math.inf if (box.open_top and i == up) else box.max[i] + tol
        if a < box.min[i] - tol or b > top:
            return False
    return True


def scene_warnings(scene: Scene) -> list[str]:
    """What is probably not what the user meant, as warnings (``UserWarning``, one each; also
    returned): a fluid block not inside any box (when the scene has boxes and no container
    mesh) and fluid blocks that overlap (their particles are sampled twice there)."""
    cfg = scene.configuration
    r, dim = cfg.particle_radius, cfg.dim
    g = cfg.gravity[:dim]
    up = max(range(dim), key=lambda i: abs(g[i])) if any(g) else None
    notes = []
    if scene.boxes and not any(m.invert for m in scene.meshes):
        for k, blk in enumerate(scene.fluid_blocks):
            if not any(_inside(blk.start, blk.end, box, up, 0.5 * r) for box in scene.boxes):
                notes.append(
                    f"{scene.field(f'fluid_blocks[{k}]')} (start {blk.start}, end {blk.end}) is "
                    "not inside any of "
                    f"the {len(scene.boxes)} box(es): fluid outside them falls freely")
    blocks = scene.fluid_blocks
    for i in range(len(blocks)):
        for j in range(i + 1, len(blocks)):
            a, b = blocks[i], blocks[j]
            lo = [max(x, y) for x, y in zip(a.start, b.start, strict=True)]
            hi = [min(x, y) for x, y in zip(a.end, b.end, strict=True)]
            if all(h - l_ > 1e-6 * r for l_, h in zip(lo, hi, strict=True)):
                notes.append(
                    f"{scene.field(f'fluid_blocks[{i}]')} and {scene.field(f'fluid_blocks[{j}]')} "
                    f"overlap (from {lo} to {hi}): both "
                    "are sampled there, at twice the rest density; expected separate blocks")
    for note in notes:
        warnings.warn(note, UserWarning, stacklevel=3)
    return notes


def check_scene(scene: Scene) -> list[Material]:
    """Check the scene across its fields; returns the materials of its fluid (the first is
    the reference of the rest densities)."""
    mats = fluid_materials(scene)
    for axis in ("x", "y"):
        if getattr(scene.configuration, f"periodic_{axis}") is not None:
            for mat in mats:
                _periodic(scene, mat, axis)
    _boundary_pressure(scene)
    _free_surface(scene)
    _transport(scene, mats)
    _lattices(scene)
    _bodies(scene)
    _solids(scene)
    scene_warnings(scene)
    return mats


def _transport(scene: Scene, mats: list[Material]) -> None:
    """A transport velocity runs with the solvers of :data:`TRANSPORT_PRESSURE`, one fluid."""
    cfg = scene.configuration
    name = cfg.transport.method
    if name == "none":
        return
    if cfg.pressure.method not in TRANSPORT_PRESSURE:
        raise SceneError(f"configuration.transport.method: {name!r} does not support "
                         f"configuration.pressure.method {cfg.pressure.method!r} yet; expected "
                         f"one of {list(TRANSPORT_PRESSURE)} (or transport 'none')")
    if len(mats) > 1:
        raise SceneError(f"configuration.transport.method: {name!r} does not support several "
                         f"fluid materials yet ({sorted(m.id for m in mats)}); expected 'none'")


def _solids(scene: Scene) -> None:
    """Elastic materials: not emitted, not periodic; WCSPH without pressure (stiffness 0, as
    SPlisHSPlasH's Beam scenes) only when every material in use is an elastic solid."""
    cfg = scene.configuration
    for k, e in enumerate(scene.emitters):
        if scene.material(e.material).elastic:
            raise SceneError(f"emitters[{k}].material: {e.material!r} is an elastic solid; "
                             "expected a fluid material (solids are not emitted)")
    used = scene.fluid_material_ids() or {scene.materials[0].id}
    for k, m in enumerate(scene.materials):
        for axis in ("x", "y"):
            if m.elastic and getattr(cfg, f"periodic_{axis}") is not None:
                raise SceneError(f"materials[{k}].elasticity.method: {m.elasticity.method!r} "
                                 f"does not support configuration.periodic_{axis}; "
                                 "expected 'none'")
    p = cfg.pressure
    if p.method == "wcsph" and p.stiffness == 0.0:
        fluids = sorted(mid for mid in used if not scene.material(mid).elastic)
        if fluids:
            raise SceneError(f"configuration.pressure.stiffness: 0 with the fluid material(s) "
                             f"{fluids}; expected a number > 0 (0 turns the pressure off, "
                             "which only elastic solids may do without)")


def methods_in_use(scene: Scene) -> list[tuple[str, str, str]]:
    """``(field, role, name)`` of every method the scene names (none-valued roles left out):
    the pressure solver, the boundary and its pressure, each material's forces and elasticity,
    each interface's forces."""
    cfg = scene.configuration
    used = [("configuration.pressure.method", "pressure", cfg.pressure.method),
            ("configuration.boundary.method", "boundary", cfg.boundary.method),
            ("configuration.boundary.pressure", "boundary_pressure", cfg.boundary.pressure),
            ("configuration.transport.method", "transport", cfg.transport.method)]
    for k, mat in enumerate(scene.materials):
        for role in (*registry.OPTIONAL_ROLES, *registry.SOLID_ROLES):
            used.append((f"materials[{k}].{role}.method", role, getattr(mat, role).method))
        if mat.viscosity.xsph or mat.viscosity.xsph_boundary:
            used.append((f"materials[{k}].viscosity.xsph", "viscosity", "xsph"))
    for k, face in enumerate(scene.interfaces):
        used.append((f"interfaces[{k}].viscosity.method", "interface_viscosity",
                     face.viscosity.method))
        used.append((f"interfaces[{k}].tension.method", "interface_tension",
                     face.tension.method))
    return [(f, role, name) for f, role, name in used if name not in (None, "none")]


def device_features(scene: Scene) -> list[str]:
    """The scene's fields that the step on a device does not run yet (empty: none), each as
    ``field value`` or ``field (what)``."""
    cfg = scene.configuration
    out = []
    for axis in ("x", "y"):
        if getattr(cfg, f"periodic_{axis}") is not None:
            out.append(f"configuration.periodic_{axis} (periodic)")
    if cfg.neighbor_skin > 0.0:
        out.append("configuration.neighbor_skin (Verlet lists)")
    if cfg.boundary.solved:
        out.append("configuration.boundary.solved (solved walls)")
    if len(scene.materials) > 1:
        out.append("materials (several fluids)")
    out += [f"animation_fields[{k}]" for k in range(len(scene.animation_fields))]
    out += [f"joints[{k}]" for k in range(len(scene.joints))]
    out += [f"meshes[{k}] (moving body)" for k, m in enumerate(scene.meshes)
            if m.dynamic or m.velocity is not None or m.angular_velocity is not None]
    return out


def check_device(scene: Scene, device: str, gpu_found: Callable[[], bool]) -> str:
    """The device the scene runs on for the asked ``device`` (one of
    :data:`sphkit.registry.DEVICE_CHOICES`).

    ``cuda`` needs a GPU (``gpu_found()``), every method in use to have the registry's
    ``gpu`` capability and none of the scene features that the device step lacks
    (:func:`device_features`); each that is missing is named in the error (no silent CPU
    fallback in the step). ``auto`` is ``cuda`` where all hold, else ``cpu``; ``gpu_found`` is
    asked only once the whole step runs on the GPU (it imports numba.cuda)."""
    if device not in registry.DEVICE_CHOICES:
        raise SceneError(f"device: {device!r}; expected one of "
                         f"{', '.join(registry.DEVICE_CHOICES)}")
    if device == "cpu":
        return "cpu"
    cpu_only = [f"{field} {name!r}" for field, role, name in methods_in_use(scene)
                if not registry.get(role, name).has("gpu")] + device_features(scene)
    if device == "auto":
        return "cuda" if not cpu_only and gpu_found() else "cpu"
    if cpu_only:
        raise SceneError("device 'cuda': the time step of these methods and features does not "
                         f"run on the GPU yet: {', '.join(cpu_only)}; expected device 'cpu' "
                         "(or 'auto')")
    if not gpu_found():
        raise SceneError("device 'cuda': no CUDA GPU found (numba.cuda.is_available() is False); "
                         "expected device 'cpu' (or 'auto')")
    return "cuda"


def device_precision(scene: Scene, device: str) -> str:
    """The floating-point type of a run of ``scene`` on the resolved ``device`` ("cpu" or
    "cuda"): ``configuration.precision`` where the scene (or ``--precision``) sets it, else
    float32 on the GPU (half the memory traffic of the memory-bound step) and float64 on the
    CPU."""
    cfg = scene.configuration
    if device == "cuda" and "precision" not in cfg.model_fields_set:
        return "float32"
    return cfg.precision
