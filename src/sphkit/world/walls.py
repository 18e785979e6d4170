"""The walls of a world: boundary particles (Akinci et al. 2012) or map geometries.

With a particle boundary model, scene ``boxes`` become lattice walls (lattices that continue
the fluid's, each particle with the fluid's lattice volume for its cell, boundary field
``cell_volume``: it stands for the fluid particle missing there, so the boundary pressure is
mirrored fully: boundary field ``pressure_mirror`` 1), static ``meshes`` their surface samples,
moving meshes (rigid bodies) their surface samples moved ``inset_depth(dim)`` r into the mesh,
and emitter housings their surface samples. With a map model (density or volume maps) boxes
and meshes become signed distances instead (:func:`map_geometries`).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from sphkit.boundary.maps import MapGeometry
from sphkit.boundary.rigid import inset_depth, inset_samples
from sphkit.core.kernels import lattice_volume
from sphkit.core.state import SimState
from sphkit.core.timestep import Domain, outside_count
from sphkit.geometry.mesh_sampling import sample_mesh_surface
from sphkit.geometry.meshes import section_segments
from sphkit.geometry.sampling import (
    box_face_factors,
    box_shell,
    box_wall_distance,
)
from sphkit.scene.schema import Scene, SceneError
from sphkit.world.emitters import HOUSING_WALL
from sphkit.world.fluid import check_start_speed, periodic_clip, periodic_mask
from sphkit.world.meshes import SceneMeshes


def gravity_axis(state: SimState) -> int:
    """The axis of gravity (the 'up' of an open box); the last axis without gravity."""
    g = state.gravity
    return int(np.argmax(np.abs(g))) if np.any(g) else state.dim - 1


def moving_meshes(scene: Scene) -> list[int]:
    """Indices of the scene's moving meshes (kinematic or dynamic rigid bodies), in body
    order: body k + 1 is ``scene.meshes[moving_meshes(scene)[k]]``."""
    return [k for k, mb in enumerate(scene.meshes) if mb.moving]


def _no_section(k: int, geometry_file: str) -> SceneError:
    """The error of ``scene.meshes[k]`` in 2D when it does not cross the plane z = 0."""
    return SceneError(f"meshes[{k}]: {geometry_file!r} does not cross the plane z = 0; "
                      "expected a mesh whose section is the 2D boundary")


def mesh_section(mesh: Any, k: int, geometry_file: str) -> tuple[np.ndarray, np.ndarray]:
    """The segments (a, b) of ``scene.meshes[k]``'s section with the plane z = 0, the mesh's 2D
    boundary for every boundary model; a :class:`SceneError` naming the mesh where it does not
    cross the plane."""
    a, b = section_segments(mesh)
    if len(a) == 0:
        raise _no_section(k, geometry_file)
    return a, b


def add_wall_particles(state: SimState, scene: Scene, meshes: SceneMeshes,
                       housings: list) -> None:
    """Sample boxes, meshes and emitter housings into ``state.boundary``."""
    r, dim = state.r, state.dim
    up = gravity_axis(state)
    bd = state.boundary
    lattice = lattice_volume(2.0 * r, state.kid, state.h, dim)  # the fluid's (world.fluid)
    for k, box in enumerate(scene.boxes):
        pts, cell = box_shell(box.min, box.max, r, layers=box.layers,
                              open_top_axis=up if box.open_top else None)
        # lattice walls continue the fluid's lattice: each particle stands for the fluid
        # particle missing there, with the fluid's lattice volume for its cell (static_volumes);
        # the boundary pressure is mirrored fully in the iterative solvers
        # (core.ppe.kappa_accel_cached)
        cell = lattice * cell / (2.0 * r) ** dim
        keep = periodic_mask(state, pts)
        pts, cell = pts[keep], cell[keep]
        dist, normal = box_wall_distance(pts, box.min, box.max)
        extra = {}
        if box.viscosity_factors is not None:
            extra["viscosity_factor"] = box_face_factors(pts, box.min, box.max,
                                                         box.viscosity_factors)
        bd.add(pts, name=f"boxes[{k}]", pressure_mirror=1.0, wall_distance=dist,
               wall_normal=normal, cell_volume=cell, **extra)
    bodies = moving_meshes(scene)
    for k in range(len(scene.meshes)):
        mesh = meshes.mesh(k)
        pts = sample_mesh_surface(mesh, r, dim)
        if dim == 2 and len(pts) == 0:  # no section with z = 0: no particles, say so
            raise _no_section(k, scene.meshes[k].geometry_file)
        if k in bodies:  # a moving rigid body (sphkit.boundary.rigid)
            # the fluid rests at the mesh surface (see inset_samples); 2D: the section's
            # samples (z = 0) move along the side faces' normals, which lie in the plane
            p3 = np.zeros((len(pts), 3))
            p3[:, :dim] = pts
            pts = inset_samples(mesh, p3, inset_depth(dim) * r)[:, :dim]
            # pressure mirrored fully as at the box walls, so that fluid squeezed between a
            # body and a box wall is pushed as the gradient of its density (see RigidBodies)
            bd.add(pts, name=f"meshes[{k}]", rigid_body=bodies.index(k) + 1,
                   pressure_mirror=1.0)
            continue
        bd.add(periodic_clip(state, pts), name=f"meshes[{k}]")
    for k, (em, cfg) in enumerate(zip(housings, scene.emitters, strict=True)):
        if cfg.housing:
            pts = sample_mesh_surface(em.housing_mesh(), r, dim)
            bd.add(periodic_clip(state, pts), name=f"emitters[{k}].housing")


def map_geometries(state: SimState, scene: Scene, meshes: SceneMeshes,
                   moving_inset: float, emitters: list | None = None) -> list[MapGeometry]:
    """Boxes and meshes as signed distances for density and volume maps.

    Boxes are containers (the fluid inside, ``invert``), analytic; an open box extends to
    infinity along the gravity axis. Emitter housings (``emitters``, unless ``housing`` is
    false) are their walls, :data:`sphkit.world.emitters.HOUSING_WALL` r thick
    (:meth:`sphkit.world.emitters.FluidEmitter.housing_walls`),
    each a map with the automatic grid. Meshes: 3D triangle meshes, in 2D the section of the
    mesh with the plane z = 0 (as for boundary particles). A moving mesh's map lives in its
    body's frame (:mod:`sphkit.boundary.maps`, "Moving rigid bodies"), its surface moved
    ``moving_inset`` r into the mesh.
    """
    from sphkit.geometry.sdf import BoxDistance, MeshDistance, PolygonDistance

    dim = state.dim
    bc = scene.configuration.boundary
    res = tuple(bc.map_resolution) if bc.map_resolution else None
    up = gravity_axis(state)
    out = []
    fields = []  # the scene field that set each geometry's map resolution
    for k, box in enumerate(scene.boxes):
        open_axis = up if box.open_top else None
        out.append(MapGeometry(f"boxes[{k}]", BoxDistance(box.min, box.max, open_axis),
                               invert=True, resolution=res,
                               extend_axis=-1 if open_axis is None else open_axis))
        fields.append("configuration.boundary.map_resolution")
    bodies = moving_meshes(scene)
    for k, mb in enumerate(scene.meshes):
        mesh = meshes.mesh(k)
        if dim == 3:
            sdf = MeshDistance(mesh.vertices, mesh.faces)
        else:
            sdf = PolygonDistance(*mesh_section(mesh, k, mb.geometry_file))
        mres = tuple(mb.map_resolution) if mb.map_resolution else res
        body, thick = 0, mb.map_thickness
        if k in bodies:  # a moving body: its map lives in its frame
            body = bodies.index(k) + 1
            thick -= moving_inset * state.r
        out.append(MapGeometry(f"meshes[{k}]", sdf, invert=mb.invert,
                               thickness=thick, resolution=mres, body=body))
        fields.append(f"meshes[{k}].map_resolution" if mb.map_resolution
                      else "configuration.boundary.map_resolution")
    coarse_map_warnings(out, fields, scene, state.h)
    check_automatic_maps(out, scene, state.h)
    # emitter housings (SPlisHSPlasH's housing is a boundary model of every kind), on the
    # automatic grid: no scene field sets their resolution
    for k, em in enumerate(emitters or []):
        if not scene.emitters[k].housing:
            continue
        for j, wall in enumerate(em.housing_walls(HOUSING_WALL * state.r)):
            if dim == 3:
                sdf = MeshDistance(wall.vertices, wall.faces)
            else:
                sdf = PolygonDistance(*section_segments(wall))
            out.append(MapGeometry(f"emitters[{k}].housing[{j}]", sdf))
    return out


#: largest map cell, in kernel supports h, before :func:`coarse_map_warnings` warns
MAP_CELL_LIMIT = 1.5


#: largest cell of an automatic map grid, in kernel supports h, before
#: :func:`check_automatic_maps` refuses the geometry
MAP_CELL_REFUSE = 100.0


def check_automatic_maps(geometries: list[MapGeometry], scene: Scene, h: float) -> None:
    """Refuse (:class:`SceneError`, naming the box or mesh) a geometry whose automatic map grid
    (no resolution given), held to :data:`sphkit.boundary.maps.MAX_AUTO_POINTS` lattice points,
    has cells coarser than :data:`MAP_CELL_REFUSE` kernel supports: such a map cannot place a
    wall within the kernel's reach. Found by fuzz.py --seed 105: a box 5.6e16 m high with 2D
    density maps took 65 s to build and then claimed the whole fluid block as wall."""
    from sphkit.boundary.maps import MAX_AUTO_POINTS, map_domain

    for geom in geometries:
        if geom.resolution is not None:
            continue
        _lo, res, cell = map_domain(geom, h)
        if cell.max() > MAP_CELL_REFUSE * h:
            raise SceneError(
                f"{scene.field(geom.name)}: its map spans {float((res * cell).max()):.3g} m, and "
                f"the automatic map grid (at most {MAX_AUTO_POINTS:,} lattice points) has cells "
                f"of {cell.max():.3g} m, {cell.max() / h:.3g} times the kernel support h = "
                f"{h:.3g} m; expected a geometry whose map fits cells of at most "
                f"{MAP_CELL_REFUSE:g} h, a map resolution set, or boundary particles "
                "(configuration.boundary.method akinci2012)")


def coarse_map_warnings(geometries: list[MapGeometry], fields: list[str], scene: Scene,
                        h: float) -> list[str]:
    """A warning (``UserWarning``, one per scene field; also returned) for each map grid that a
    scene's resolution makes coarser than :data:`MAP_CELL_LIMIT` kernel supports: its wall
    terms are interpolated from nodes farther apart than the kernel reaches. Measured
    (validation/README.md, "The 2D columns at r = 5 mm"): a 2D column with PCISPH and density
    maps at SPlisHSPlasH's default 20 cells rests at a pressure slope of 1.40 rho0 g with cells
    of 2.1-2.4 h, and at 1.022 with 60 cells (0.7-0.8 h). ``fields``: the scene field that set
    each geometry's resolution. The automatic grid (no resolution given) has cells of h."""
    from sphkit.boundary.maps import map_domain

    notes: dict[str, str] = {}
    if scene.configuration.boundary.method == "koschier2017" and scene.configuration.dim == 2:
        return []  # built on cells of at most h / 2 whatever the resolution (MAX_CELL_2D)
    for geom, field in zip(geometries, fields, strict=True):
        if geom.resolution is None or field in notes:
            continue
        _lo, res, cell = map_domain(geom, h)
        if cell.max() > MAP_CELL_LIMIT * h:
            need = [int(n) for n in np.ceil(res * cell / h)]
            notes[field] = (
                f"{scene.field(field)}: {list(geom.resolution)[:len(res)]} gives "
                f"{geom.name} map cells of up to {cell.max():.3g} m, {cell.max() / h:.1f} times "
                f"the kernel support h = {h:.3g} m; a map this coarse misplaces the wall's "
                f"density and pressure; expected at least {need} cells (cells of h), or no "
                "resolution for the automatic grid")
    for note in notes.values():
        warnings.warn(note, UserWarning, stacklevel=3)
    return list(notes.values())


def domain_box(state: SimState, scene: Scene, meshes: SceneMeshes,
               emitters: list, housings: bool = True) -> Domain | None:
    """The region the fluid must stay in, for the step's stability guard: the bounding box of
    the static boundaries (boxes, static meshes, map geometries, emitter housings) widened by
    ``configuration.domain_margin`` kernel supports h, unbounded above the walls (against
    gravity: fluid thrown up comes back) and along a periodic axis; fluid above the walls' top
    (the bounding box's, against gravity) is not checked at all: a splash thrown over the top of
    an open box flies beside it, not through a wall (validation/README.md, "Where WCSPH's
    dam-break impact lost a particle"). Where the fluid is shut in -- every container a closed
    box (no ``open_top``, no container mesh) and every fluid particle and emitter inside one
    (:func:`_shut_in`) -- the top is bounded too: fluid above it went through the lid
    (validation/README.md, "WCSPH's speed of sound against the fall"). None: no check (the
    margin is null, the scene has no container: no box and no static mesh with the fluid
    inside it (``invert``), only solid obstacles the fluid may fall off or drain through -- a
    slab, a box with a hole --, moving
    bodies or emitter housings, or an emitter reuses particles, which then leave its
    ``reuse_box`` by design and wait outside it). ``housings`` False: the walls alone."""
    margin = scene.configuration.domain_margin
    if any(e.reuse_box is not None for e in scene.emitters):
        return None
    dim = state.dim
    bodies = moving_meshes(scene)
    lo, hi = [], []
    for box in scene.boxes:
        lo.append(np.asarray(box.min, float))
        hi.append(np.asarray(box.max, float))
    for k in range(len(scene.meshes)):
        if k not in bodies:
            b = meshes.mesh(k).bounds
            lo.append(b[0, :dim])
            hi.append(b[1, :dim])
    mesh_containers = sum(scene.meshes[k].invert for k in range(len(scene.meshes))
                          if k not in bodies)
    containers = len(scene.boxes) + mesh_containers
    if margin is None or not containers:
        return None
    for em, cfg in zip(emitters, scene.emitters, strict=True):
        if cfg.housing and housings:
            b = em.housing_mesh().bounds
            lo.append(b[0, :dim])
            hi.append(b[1, :dim])
    pad = margin * state.h
    box_lo, box_hi = np.min(lo, axis=0) - pad, np.max(hi, axis=0) + pad
    g = state.gravity
    up, top, sgn = -1, 0.0, 1.0
    if np.any(g) and not (mesh_containers == 0 and _shut_in(state, scene)):
        up = gravity_axis(state)
        if g[up] < 0:
            box_hi[up] = np.inf
            top = float(np.max(hi, axis=0)[up])
        else:
            box_lo[up] = -np.inf
            top, sgn = float(np.min(lo, axis=0)[up]), -1.0
    for a, _lo, _L in state.periodic_axes:
        box_lo[a], box_hi[a] = -np.inf, np.inf
        if a == up:
            up = -1
    return Domain(box_lo, box_hi, up, top, sgn)


def _shut_in(state: SimState, scene: Scene) -> bool:
    """Whether closed boxes shut the fluid in: the scene has boxes, none with ``open_top``, and
    every fluid particle of the state and every emitter's position lies inside one of them
    (within r). (:func:`domain_box` asks only where no static mesh is a container.)"""
    if not scene.boxes or any(b.open_top for b in scene.boxes):
        return False
    dim, r = state.dim, state.r
    lo = np.array([b.min[:dim] for b in scene.boxes], float)[:, :, None] - r
    hi = np.array([b.max[:dim] for b in scene.boxes], float)[:, :, None] + r
    pts = [np.asarray(state.fluid["x"], float)] if state.fluid.n else []
    pts += [np.asarray(e.position[:dim], float)[:, None] for e in scene.emitters]
    for x in pts:
        inside = np.all((x[None] >= lo) & (x[None] <= hi), axis=1).any(axis=0)
        if not inside.all():
            return False
    return True


def check_emitters(domain: Domain | None, scene: Scene, emitters: list) -> None:
    """A :class:`SceneError` naming the emitter's position where its first layer would lie
    outside the domain (:func:`domain_box` of the walls without the emitters' housings): the
    step's guard would stop the run at its first emission, and an emitter far away (a
    position of 1e16 m) made a neighbour grid of 1e17 cells for its housing first; and one
    naming its velocity where that exceeds ``configuration.max_velocity``
    (:func:`sphkit.world.fluid.check_start_speed`, as for the fluid that starts in the scene)."""
    for k, e in enumerate(scene.emitters):  # the guard would stop the first emission
        if e.max_particles != 0:
            check_start_speed(scene, f"emitters[{k}]", np.array([e.velocity]), e)
    if domain is None:
        return
    for k, em in enumerate(emitters):
        if scene.emitters[k].max_particles == 0:
            continue
        x = np.ascontiguousarray((em.x0 + em.offsets)[:, : em.dim].T)
        if outside_count(x, *domain):
            lo = [float(v) for v in domain.lo]
            hi = [float(v) for v in domain.hi]
            at = list(scene.emitters[k].position)
            raise SceneError(
                f"{scene.field(f'emitters[{k}].position')}: got {at}: "
                f"expected an emitter whose layer lies inside the domain {lo} .. {hi} m (the "
                "static walls' bounding box plus configuration.domain_margin h); its particles "
                "would start outside it")
