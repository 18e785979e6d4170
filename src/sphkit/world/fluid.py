"""The fluid of a world: blocks, particle files and filled meshes sampled into particles.

Every fluid particle gets the lattice volume ``V0 = 1 / sum_k W(|k| 2r)`` of its lattice (square,
or hexagonal in 2D), the mass ``m = rho0 V0``, the rest density ``rho0`` and, in a fluid of
several materials, the ``phase`` (index in ``scene.materials``) of its material, so that the
interior of freshly sampled fluid is at rest density (README, "mass of lattice-sampled fluid").
"""

from __future__ import annotations

import warnings

import numpy as np

from sphkit.core.kernels import block_volume, hexagonal_volume, lattice_volume
from sphkit.core.particles import ParticleSet
from sphkit.core.state import SimState
from sphkit.geometry.mesh_sampling import lattice_volume_points, sample_mesh_volume
from sphkit.geometry.sampling import DENSE_LATTICES, dense_block, hexagonal_block, lattice_block
from sphkit.scene.schema import Material, Scene, SceneError
from sphkit.world.meshes import SceneMeshes


def _phase(fluid: ParticleSet, scene: Scene, mat: Material) -> dict:
    """``{"phase": index of mat}`` where the fluid has the field (several materials)."""
    return {"phase": scene.materials.index(mat)} if "phase" in fluid.specs else {}


def periodic_mask(state: SimState, pts: np.ndarray) -> np.ndarray:
    """Which points (M, dim) lie inside ``[lo, lo + L)`` along each periodic axis (all of them
    otherwise)."""
    r = state.r
    keep = np.ones(len(pts), dtype=bool)
    for a, lo, L in state.periodic_axes:
        keep &= (pts[:, a] >= lo - 1e-9 * r) & (pts[:, a] < lo + L - 1e-9 * r)
    return keep


def periodic_clip(state: SimState, pts: np.ndarray) -> np.ndarray:
    """The points inside ``[lo, lo + L)`` along each periodic axis (all of them otherwise)."""
    return pts[periodic_mask(state, pts)]


def add_fluid(state: SimState, scene: Scene, meshes: SceneMeshes) -> None:
    """Sample the scene's fluid blocks, particle files and fluid meshes into ``state.fluid``."""
    r, dim = state.r, state.dim
    vol = lattice_volume(2.0 * r, state.kid, state.h, dim)
    fluid = state.fluid
    for k, blk in enumerate(scene.fluid_blocks):
        bvol = vol
        if blk.lattice == "hexagonal":  # spacing 2r, V = 1 / sum_k W over that lattice
            raw = hexagonal_block(blk.start, blk.end, r)
            bvol = hexagonal_volume(2.0 * r, state.kid, state.h)
        elif blk.lattice in DENSE_LATTICES:  # V from a block of that lattice 6h wide
            raw = dense_block(blk.start, blk.end, r, blk.lattice)
            side = [6.0 * state.h] * dim
            bvol = block_volume(dense_block([0.0] * dim, side, r, blk.lattice), state.kid,
                                state.h)
        else:
            raw = lattice_block(blk.start, blk.end, r)
        pts = periodic_clip(state, raw)
        if len(pts) == 0 and len(raw):  # every particle outside the periodic range
            a, lo, L = next((a, lo, L) for a, lo, L in state.periodic_axes
                            if not np.any((raw[:, a] >= lo) & (raw[:, a] < lo + L)))
            name = scene.field(f"configuration.periodic_{'xy'[a]}")
            raise SceneError(
                f"fluid_blocks[{k}]: start {blk.start} end {blk.end} lies outside the periodic "
                f"range {name} = [{lo:g}, {lo + L:g}) along {'xy'[a]}; expected a block that "
                "overlaps it")
        if len(pts) == 0:
            raise SceneError(
                f"fluid_blocks[{k}]: start {blk.start} end {blk.end} holds no particle of "
                f"radius configuration.particle_radius = {r}; expected a block at least 2r = "
                f"{2 * r} wide on every axis"
            )
        mat = scene.material(blk.material)
        vel = start_velocity(pts, blk.velocity, blk.angular_velocity)
        check_start_speed(scene, f"fluid_blocks[{k}]", vel, blk)
        fluid.add(pts, name=f"fluid_blocks[{k}]", m=mat.density0 * bvol, V0=bvol, v=vel,
                  rho=mat.density0, rho0=mat.density0, **_phase(fluid, scene, mat))
    for k, ff in enumerate(scene.fluid_files):
        _add_fluid_file(state, scene, meshes, k, ff, vol)
    for k, fm in enumerate(scene.fluid_meshes):
        pts = sample_mesh_volume(meshes.fluid_mesh(k), r, dim, invert=fm.invert,
                                 lattice=fm.lattice)
        if len(pts) == 0:
            raise SceneError(
                f"fluid_meshes[{k}]: {fm.geometry_file!r} holds no particle of radius "
                f"configuration.particle_radius = {r}; "
                "expected a closed mesh at least 2r wide" + (" that crosses z = 0" if dim == 2
                                                             else "")
            )
        mat = scene.material(fm.material)
        vel = start_velocity(pts, fm.velocity, fm.angular_velocity)
        check_start_speed(scene, f"fluid_meshes[{k}]", vel, fm)
        mvol = vol
        if fm.lattice != "square":  # V from a sample of that lattice 6h wide
            mvol = block_volume(lattice_volume_points(r, fm.lattice, dim, 6.0 * state.h),
                                state.kid, state.h)
        fluid.add(pts, name=f"fluid_meshes[{k}]", m=mat.density0 * mvol, V0=mvol, v=vel,
                  rho=mat.density0, rho0=mat.density0, **_phase(fluid, scene, mat))


def start_velocity(pts: np.ndarray, velocity: list[float] | None,
                   angular_velocity: list[float] | None) -> np.ndarray:
    """Initial velocities ``velocity + angular_velocity x (x - mean(x))`` of the points (M, dim)
    (SPlisHSPlasH's ``SimulatorBase::setInitialVelocity``; in 2D the z component of the
    angular velocity turns the block in its plane) -> (M, dim), or the constant velocity (dim,)
    when there is no rotation."""
    dim = pts.shape[1]
    if angular_velocity is None or not any(angular_velocity):
        return np.zeros(dim) if velocity is None else np.asarray(velocity, float)
    from sphkit.io.particle_files import initial_velocity

    x3 = np.zeros((len(pts), 3))
    x3[:, :dim] = pts
    v0 = None if velocity is None else list(velocity) + [0.0] * (3 - dim)
    return initial_velocity(x3, v0, angular_velocity)[:, :dim].copy()


def check_start_speed(scene: Scene, what: str, vel: np.ndarray, obj) -> None:
    """Raise :class:`SceneError` when the initial velocities (dim,) or (M, dim) of the scene's
    object ``obj`` (named ``what``: a fluid block, file or mesh, an emitter) exceed
    ``configuration.max_velocity``: the stability guard would stop the run at its first step
    (or emission) and blame the time step."""
    limit = scene.configuration.max_velocity
    speed = float(np.max(np.linalg.norm(np.atleast_2d(vel), axis=1), initial=0.0))
    if speed > limit:
        names = [f for f in ("velocity", "angular_velocity", "use_file_velocity")
                 if getattr(obj, f, None)]
        fields = ", ".join(scene.field(f"{what}.{f}") for f in names)
        raise SceneError(
            f"{scene.field(what)}: the fluid starts at up to {speed:.4g} m/s ({fields}), "
            f"over {scene.field('configuration.max_velocity')} = {limit:g} m/s, the speed that "
            "stops a run as unstable; expected a slower start (or a higher max_velocity)")


def _add_fluid_file(state: SimState, scene: Scene, meshes: SceneMeshes, k: int, ff,
                    vol: float) -> None:
    """Fluid from a particle file (``scene.fluid_files[k]``), with the lattice volume."""
    from sphkit.io.particle_files import (
        ParticleFileError,
        load_fluid_particles,
        spacing_warning,
    )

    try:
        x, v = load_fluid_particles(
            meshes.path(ff.file), state.dim, translation=ff.translation, scale=ff.scale,
            rotation_axis=ff.rotation_axis, rotation_angle=ff.rotation_angle,
            velocity=ff.velocity, angular_velocity=ff.angular_velocity,
            use_file_velocity=ff.use_file_velocity)
    except ParticleFileError as e:
        raise SceneError(f"fluid_files[{k}].file: {e}") from None
    if len(x) == 0:
        raise SceneError(f"fluid_files[{k}].file: {ff.file!r} holds no particles; "
                         "expected at least one")
    note = spacing_warning(x, state.r, f"fluid_files[{k}] ({ff.file})")
    if note:
        warnings.warn(note, UserWarning, stacklevel=4)
    check_start_speed(scene, f"fluid_files[{k}]", v, ff)
    mat = scene.material(ff.material)
    state.fluid.add(x, name=f"fluid_files[{k}]", m=mat.density0 * vol, V0=vol, v=v,
                    rho=mat.density0, rho0=mat.density0, **_phase(state.fluid, scene, mat))


def phase_statistics(fluid: ParticleSet, materials: list[Material],
                     scene_materials: list[Material]) -> list[dict]:
    """Per material of the fluid (``materials``, each found in the scene's list for its
    ``phase`` index): id, particles, compression of the densities (avg, max)."""
    out = []
    for mat in materials:
        sel = fluid["phase"] == scene_materials.index(mat)
        e = np.maximum(fluid["rho"][sel] / fluid["rho0"][sel] - 1.0, 0.0)
        out.append({"material": mat.id, "particles": int(sel.sum()),
                    "density_error_avg": float(e.mean()) if e.size else 0.0,
                    "density_error_max": float(e.max()) if e.size else 0.0})
    return out
