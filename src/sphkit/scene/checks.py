"""Checks across fields of a scene, before a world is built from it.

The scene model (:mod:`sphkit.scene.schema`) validates each field on its own; what a scene
must satisfy across fields -- that every method it names can do what the scene asks of it
(periodic domains, dynamic rigid bodies), that the boundary pressure fits the boundary model,
that 2D bodies move in the plane -- is checked here, against the capabilities of the methods in
:mod:`sphkit.registry`. Every check raises :class:`~sphkit.scene.schema.SceneError` naming the
field, the value and what was expected (``sphkit run`` exits with code 2).
"""

from __future__ import annotations

from sphkit import registry
from sphkit.scene.schema import Material, Scene, SceneError

#: the roles whose methods must support ``configuration.periodic_x``
PERIODIC_ROLES = ("pressure", "viscosity", "vorticity", "surface_tension", "drag")


def fluid_material(scene: Scene) -> Material:
    """The one material of the scene's fluid (several are refused: multiphase is not there)."""
    used = ({b.material for b in scene.fluid_blocks} | {f.material for f in scene.fluid_files}
            | {b.material for b in scene.fluid_meshes}
            | {e.material for e in scene.emitters}) or {scene.materials[0].id}
    if len(used) > 1:
        raise SceneError(
            f"fluid_blocks: materials {sorted(used)}; multiphase fluids are not supported yet, "
            "expected all blocks to use one material"
        )
    return scene.material(next(iter(used)))


def _periodic(scene: Scene, mat: Material) -> None:
    cfg = scene.configuration
    k = scene.materials.index(mat)
    for role in PERIODIC_ROLES:
        if role == "pressure":
            where, name = "configuration.pressure.method", cfg.pressure.method
        else:
            where, name = f"materials[{k}].{role}.method", getattr(mat, role).method
        ok = registry.with_capability(role, "periodic")
        if name != "none" and name not in ok:
            expected = sorted(ok) if role == "pressure" else sorted(("none", *ok))
            raise SceneError(f"{where}: {name!r} does not support configuration.periodic_x yet; "
                             f"expected one of {expected}")
    if any(mb.dynamic or mb.kinematic for mb in scene.meshes):
        k = next(k for k, mb in enumerate(scene.meshes) if mb.dynamic or mb.kinematic)
        raise SceneError(f"meshes[{k}]: moving rigid bodies do not support "
                         "configuration.periodic_x yet")


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


def _bodies(scene: Scene) -> None:
    solver = scene.configuration.pressure.method
    for k, mb in enumerate(scene.meshes):
        if not (mb.dynamic or mb.kinematic):
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


def check_scene(scene: Scene) -> Material:
    """Check the scene across its fields; returns the material of its fluid."""
    mat = fluid_material(scene)
    if scene.configuration.periodic_x is not None:
        _periodic(scene, mat)
    _boundary_pressure(scene)
    _lattices(scene)
    _bodies(scene)
    return mat
