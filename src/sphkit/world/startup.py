"""How the fluid of a world starts: removed from inside walls, consistent next to them, and at
rest under its own weight. Run once by :func:`sphkit.world.build_world`, before the first step.

Users write fluid blocks up to the walls (SPlisHSPlasH's scenes place the first particle 2r off
the wall surface, or a block overlaps a wall), but every boundary model claims some space next
to its surface: lattice-sampled fluid there starts too dense (7 % at Akinci particles, 6 % at
density maps, 22 % at 3D volume maps, for the first particle 2r off the surface), so the
first pressure solve cannot converge and a state equation explodes. A fluid column sampled at
rest density also lacks its hydrostatic compression, so a WCSPH column drops and bounces
("breathes") for seconds. The start-up, in this order (``configuration.start`` switches its
parts):

1. **Inside walls and bodies** (always): a fluid particle is removed, with one warning per fluid
   object naming it, the count and the walls, when it lies on the solid side of a wall's or
   body's geometry -- outside a box's interior but within the support radius h of it; inside a
   closed (watertight) mesh, or outside a closed container mesh (``invert``) within h of it
   (signed distance on a lattice of spacing r, interpolated) -- or inside the boundary model's
   own solid (:meth:`sphkit.core.methods.BoundaryModel.inside`): density and volume maps, map
   distance ``phi <= 0`` (their surface moved into the fluid by the wall's thickness);
   boundary particles, closer than r to one (the particles overlap by more than a radius), or
   closer than 1.5 r to a static closed mesh's surface (its samples lie on the
   surface: :attr:`sphkit.boundary.akinci2012.Akinci2012.start_reach`); volume maps, closer
   than 1.5 r to a static closed mesh's surface or a box's wall face (the map claims more room
   than boundary particles: :attr:`sphkit.boundary.bender2019.Bender2019.start_reach`; measured
   on the geometry, not on the interpolated map).
2. **Hydrostatic start** (``start.hydrostatic``, default on; as DualSPHysics starts its
   fluid): each particle's depth is measured along gravity from the top of its connected column
   of fluid -- the particles in the same column 2r wide (across gravity) with no vertical gap
   wider than h between them, the free surface r above the highest particle centre -- and
   ``p = rho0 |g| depth``. The start density is the solver's
   :meth:`~sphkit.core.methods.PressureSolver.compressed_density` of p (WCSPH: the inverse of
   its Tait or linear state equation, so that its first pressure is p; rho0 for PCISPH, PBF,
   IISPH and DFSPH; IISPH takes p as the warm start of its first solve; DFSPH's first solve
   starts from zero, because a hydrostatic kappa given to fluid that is not yet in contact
   with the floor (a block 3r above a density-map floor falls 2r first) stayed in its warm
   starts and left the 2D column's slope 5 % steep for seconds). Fluid under a body starts with the
   pressure of its own column below the body; a column that does not rest on a wall (its
   lowest particle has no boundary neighbour below it: fluid in the air) starts at p = 0, and
   so does all fluid when gravity has a component along a periodic axis (a driven flow).
3. **Relaxation** (``start.relax``, default on): Jacobi sweeps of the position projection of
   the clamped density constraint (:func:`sphkit.core.relaxation.relax_pass`, PBF's, without
   gravity or time; bodies held still) move the particles that sit in a wall's range out of
   it, until no particle is more than 1 % denser than its start density (or
   ``start.relax_iterations``). A particle the sweeps moved onto the solid side of a wall (the
   test of step 1; in the concave corner of a surface-sampled container, where every fluid
   neighbour pushes it towards the corner, it can leave between the samples) goes back where
   it was sampled.
4. **Masses** (with ``start.relax``): each particle's mass is set so that its summation density
   is its start density (:func:`sphkit.core.relaxation.mass_pass`, to 1e-6). Where the kernel
   was filled as sampled (the summation density with the lattice masses reached the rest
   density) the mass may rise up to 5 % above that, to fill the
   thin spots the relaxation left; at a free surface it never rises above it, so the surface
   keeps its mass and its kernel's deficit. Masses are the
   variable because sphkit's densities are sums of masses
   (``rho_i = sum_j m_j W_ij + sum_b rho0 V_b W_ib``): a compressed WCSPH column thus holds its
   hydrostatic density exactly on its sampling lattice, with the particles where the user put
   them. A particle whose mass would drop below half its lattice mass (the boundary claims most
   of its volume) is removed with a warning instead.

Afterwards the fluid's ``rho`` and ``p`` fields hold the start state, and every particle's
volume is ``V0 = m / rho0``. :class:`StartReport` records what was done.
"""

from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, field

import numpy as np

from sphkit.core.methods import BoundaryModel, PressureSolver
from sphkit.core.neighbors import neighbor_lists
from sphkit.core.operators import density_cpu
from sphkit.core.pairs import min_image_rows
from sphkit.core.relaxation import mass_pass, relax_pass
from sphkit.core.state import SimState
from sphkit.core.timestep import wrap_periodic
from sphkit.scene.schema import Scene, SceneError
from sphkit.world.meshes import SceneMeshes
from sphkit.world.settle import SettlePlan, plan_settle
from sphkit.world.walls import gravity_axis

#: relaxation stops once no particle's density exceeds its start density by more than this
RELAX_TOLERANCE = 0.01
#: a particle's density constraint up to this counts as met (0: the interior of a lattice sits
#: at its target to round-off)
RELAX_MET = 1e-6
#: largest displacement of one relaxation sweep [r]
RELAX_STEP = 0.25
#: the masses' fixed point stops at this largest relative density deviation
MASS_TOLERANCE = 1e-6
MASS_ITERATIONS = 200
#: a particle whose consistent mass is below this share of its lattice mass is removed
MIN_MASS_SHARE = 0.5
#: how far above its lattice mass (times the start compression) the mass of a particle with a
#: filled kernel may go, to fill what the relaxation left thin
MASS_SLACK = 0.05
#: most lattice points of a mesh's signed distance for the inside test (coarser above)
MAX_SDF_POINTS = 4_000_000


@dataclass
class StartReport:
    """What the start-up did (densities as fractions of the start density; counts per fluid
    object)."""

    removed_inside: dict[str, int] = field(default_factory=dict)
    removed_close: dict[str, int] = field(default_factory=dict)
    hydrostatic: bool = False
    #: compression ``max(rho / rho_start - 1, 0)`` (mean, max) as sampled, with the lattice
    #: masses times the start compression
    sampled_error: tuple[float, float] = (0.0, 0.0)
    relax_iterations: int = 0
    #: the same after the relaxation (before the masses)
    relaxed_error: tuple[float, float] = (0.0, 0.0)
    max_displacement: float = 0.0  #: largest distance a particle was moved [m]
    #: particles the relaxation moved onto a wall's solid side, put back where they were sampled
    held_back: int = 0
    mass_iterations: int = 0
    #: smallest and largest mass over lattice mass times start compression
    min_mass_share: float = 1.0
    max_mass_share: float = 1.0
    #: the density error (mean, max) of the start, with its masses: ``|rho / rho_start - 1|``
    #: where the kernel is filled, the compression at a free surface
    start_error: tuple[float, float] = (0.0, 0.0)
    #: the settling before t = 0 (:mod:`sphkit.world.settle`): steps, settled time [s] and the
    #: root mean square speed of the fluid at its end [m/s] (0 steps: none)
    settle_steps: int = 0
    settle_time: float = 0.0
    settle_speed: float = 0.0

    def to_dict(self) -> dict[str, object]:
        """Plain-dict form (``manifest.json``'s ``start``)."""
        def plain(v: object) -> object:
            if isinstance(v, dict):
                return {str(k): plain(x) for k, x in v.items()}
            if isinstance(v, (tuple, list)):
                return [plain(x) for x in v]
            return v.item() if isinstance(v, np.generic) else v

        return {k: plain(v) for k, v in asdict(self).items()}


# ---------------------------------------------------------------------------------------------
# 1. inside walls and bodies


def _mesh_distance(mesh, dim: int, pts: np.ndarray, r: float) -> np.ndarray:
    """Signed distance of a closed mesh (3D) or its section with z = 0 (2D) at the points
    pts (M, dim), negative inside: exact on a lattice of spacing r (coarser past
    :data:`MAX_SDF_POINTS`) over the points' bounding box, interpolated linearly."""
    from scipy.interpolate import RegularGridInterpolator

    from sphkit.geometry.meshes import section_segments
    from sphkit.geometry.sdf import mesh_sdf_lattice, polygon_sdf_lattice

    lo = pts.min(axis=0) - 2.0 * r
    hi = pts.max(axis=0) + 2.0 * r
    sp = r
    while np.prod(np.ceil((hi - lo) / sp) + 1) > MAX_SDF_POINTS:
        sp *= 1.25
    shape = (np.ceil((hi - lo) / sp) + 1).astype(np.int64)
    if dim == 3:
        d = mesh_sdf_lattice(np.asarray(mesh.vertices, float), np.asarray(mesh.faces),
                             lo, [sp] * 3, shape)
    else:
        a, b = section_segments(mesh)
        if len(a) == 0:
            return np.full(len(pts), np.inf)
        d = polygon_sdf_lattice(a, b, lo, [sp] * 2, shape)
    # a lattice that misses the surface's band has distances +-inf, of the right sign: keep
    # the sign, interpolate finite numbers
    d = np.where(np.isfinite(d), d, np.copysign(1e30, d))
    axes = [lo[k] + sp * np.arange(shape[k]) for k in range(dim)]
    return RegularGridInterpolator(axes, d, bounds_error=False, fill_value=1e30)(pts)


def _geometry_inside(state: SimState, scene: Scene, meshes: SceneMeshes, reach: float = 0.0,
                     box_reach: float = 0.0) -> tuple[np.ndarray, list[str]]:
    """Fluid particles on the solid side of a box's or closed mesh's geometry (module
    docstring, item 1), or closer than ``reach`` [m] to a static closed mesh's surface (the
    boundary model's :attr:`~sphkit.core.methods.BoundaryModel.start_reach`) or than
    ``box_reach`` [m] to a box's wall face (the open top is no wall): an index into the names
    (``boxes[k]``, ``meshes[k]``), -1 free."""
    x = state.fluid.view("x")
    n, dim, h, r = len(x), state.dim, state.h, state.r
    out = np.full(n, -1, dtype=np.int64)
    names: list[str] = []
    up = gravity_axis(state)
    for k, box in enumerate(scene.boxes):
        lo = np.asarray(box.min, float)
        hi = np.asarray(box.max, float).copy()
        if box.open_top:
            hi[up] = np.inf
        excess = np.maximum(np.maximum(lo - x, x - hi), 0.0)
        dist = np.linalg.norm(excess, axis=1)
        hit = (dist > 0.0) & (dist < h)
        if box_reach > 0.0:  # inside, but closer to a wall face than the reach
            hit |= (dist == 0.0) & (np.minimum(x - lo, hi - x).min(axis=1) < box_reach)
        hit &= out < 0
        out[hit] = len(names)
        names.append(f"boxes[{k}]")
    for k, mb in enumerate(scene.meshes):
        mesh = meshes.mesh(k)
        name = len(names)
        names.append(f"meshes[{k}]")
        if not mesh.is_watertight:  # no inside: only the model's own test applies
            continue
        blo = np.asarray(mesh.bounds[0], float)[:dim] - h
        bhi = np.asarray(mesh.bounds[1], float)[:dim] + h
        near = np.all((x >= blo) & (x <= bhi), axis=1) & (out < 0)
        if not near.any():
            continue
        d = _mesh_distance(mesh, dim, x[near], r)
        claim = 0.0 if mb.moving else reach
        hit = (d > -claim) & (d < h) if mb.invert else d < claim
        idx = np.flatnonzero(near)[hit]
        out[idx] = name
    return out, names


def _object_of(state: SimState) -> tuple[np.ndarray, list[str]]:
    """Each fluid particle's object (index into the names ``fluid_blocks[k]``, ...)."""
    f = state.fluid
    names = [o.name for o in f.objects]
    obj = f.object_index(f["id"]) if names else np.zeros(f.n, int)
    return obj, names


def _remove(state: SimState, where: np.ndarray, walls: list[str], what: str,
            counts: dict[str, int]) -> None:
    """Remove the fluid particles with ``where >= 0`` (an index into walls), warn once per
    fluid object, and count them per object."""
    hit = where >= 0
    if not hit.any():
        return
    obj, names = _object_of(state)
    involved = ", ".join(walls[w] for w in np.unique(where[hit]))
    for o in np.unique(obj[hit]):
        sel = hit & (obj == o)
        by_wall = np.bincount(where[sel], minlength=len(walls))
        parts = ", ".join(f"{walls[w]} ({c})" for w, c in enumerate(by_wall) if c)
        name = names[o] if names else "fluid"
        count = int(sel.sum())
        counts[name] = counts.get(name, 0) + count
        warnings.warn(f"{name}: {count} particle(s) {what} {parts}; removed", UserWarning,
                      stacklevel=4)
    state.fluid.compact(~hit)
    if state.fluid.n == 0:
        raise SceneError(
            f"{', '.join(sorted(counts))}: every fluid particle was removed, they all "
            f"{what} {involved}; expected fluid inside the walls (move the fluid off the "
            "walls, or make a container mesh a container)")


def inside_walls(state: SimState, scene: Scene, meshes: SceneMeshes, model: BoundaryModel,
                 reach: float) -> tuple[np.ndarray, list[str]]:
    """The test of step 1: the fluid particles on a wall's or body's solid side (geometry,
    ``reach`` [m] from a static closed mesh included, and from a box's faces where the model's
    walls stand on them, :attr:`~sphkit.core.methods.BoundaryModel.reach_at_boxes`) or inside
    the boundary model's own solid, as an index into the returned wall names, -1 free."""
    geo, geo_names = _geometry_inside(state, scene, meshes, reach,
                                      reach if model.reach_at_boxes else 0.0)
    own, own_names = model.inside(state)
    names = geo_names + [n for n in own_names if n not in geo_names]
    where = geo.copy()
    free = where < 0
    if own_names:
        remap = np.array([names.index(n) for n in own_names], dtype=np.int64)
        where[free & (own >= 0)] = remap[own[free & (own >= 0)]]
    return where, names


def remove_inside(state: SimState, scene: Scene, meshes: SceneMeshes, model: BoundaryModel,
                  report: StartReport) -> None:
    """Step 1 of the module docstring."""
    where, names = inside_walls(state, scene, meshes, model, model.start_reach * state.r)
    _remove(state, where, [wall_label(scene, n) for n in names], "start inside",
            report.removed_inside)


def wall_label(scene: Scene, name: str) -> str:
    """A wall (``boxes[k]``, ``meshes[k]``, ...) as messages name it: the field the user wrote,
    and for a mesh that is a solid (not ``invert``) the field that would make it a container."""
    label = scene.field(name)
    if name.startswith("meshes[") and not scene.meshes[int(name[7:name.index("]")])].invert:
        label += f" (a solid body: {scene.field(name + '.invert')} false)"
    return label


# ---------------------------------------------------------------------------------------------
# 2. hydrostatic depth


def column_depth(x: np.ndarray, gravity: np.ndarray, r: float, h: float,
                 supported: np.ndarray | None = None,
                 rho0: np.ndarray | None = None) -> np.ndarray:
    """Depth [m] of each point of x (N, dim) below the free surface of its connected column
    (module docstring, item 2): columns 2r wide across gravity, split where the vertical gap
    exceeds h, the surface r above the column's highest point. ``supported`` (N,) bool: the
    points that rest on a wall below them; a column whose lowest point does not (fluid in the
    air, falling) has depth 0 throughout. Zero without gravity.

    ``rho0`` (N,): instead the weight of the column above each point per unit area and
    gravity, ``int rho0 dz`` [kg/m^2] up to the surface (layers of several fluids; the rest
    density changes half-way between neighbouring points of a column)."""
    n, dim = x.shape
    g = np.asarray(gravity, float)[:dim]
    gn = float(np.linalg.norm(g))
    if n == 0 or gn == 0.0:
        return np.zeros(n)
    up = -g / gn
    height = x @ up
    basis = np.linalg.svd(up[None, :])[2][1:]  # orthonormal directions across gravity
    u = x @ basis.T
    # bins of 2r from the lowest point, offset a quarter bin so that square (k) and hexagonal
    # (k + 1/2) lattice columns sit inside a bin, not on its edge
    key = np.floor((u - u.min(axis=0)) / (2.0 * r) + 0.25).astype(np.int64)
    _, col = np.unique(key, axis=0, return_inverse=True)
    col = col.ravel()
    order = np.lexsort((height, col))
    cs, hs = col[order], height[order]
    new = np.ones(n, dtype=bool)
    new[1:] = (cs[1:] != cs[:-1]) | (hs[1:] - hs[:-1] > h)
    run = np.cumsum(new) - 1
    last = np.flatnonzero(np.append(new[1:], True))  # the highest point of each run
    if rho0 is None:
        depth_sorted = hs[last][run] + r - hs
    else:
        rs = np.asarray(rho0, dtype=float)[order]
        seg = np.zeros(n)  # the weight between a point and the next one up its run
        inner = ~new[1:]
        seg[:-1][inner] = 0.5 * (rs[:-1] + rs[1:])[inner] * (hs[1:] - hs[:-1])[inner]
        above = np.cumsum(seg[::-1])[::-1]  # suffix sums; a run's top adds nothing
        depth_sorted = above - above[last][run] + r * rs[last][run]
    if supported is not None:  # a run rests on what its lowest point rests on
        depth_sorted[~supported[order][np.flatnonzero(new)][run]] = 0.0
    depth = np.empty(n)
    depth[order] = depth_sorted
    return depth


def resting_on_walls(state: SimState) -> np.ndarray:
    """Fluid particles with a boundary neighbour below them (within 60 degrees of straight
    down, from this state's fluid-boundary lists): what a column of fluid can rest on."""
    f, b = state.fluid, state.boundary
    nl = state.nl_fb
    counts = np.diff(nl.offsets)
    out = np.zeros(f.n, dtype=bool)
    if len(nl.indices) == 0 or not np.any(state.gravity):
        return out
    up = -np.asarray(state.gravity, float) / float(np.linalg.norm(state.gravity))
    rows = np.repeat(np.arange(f.n), counts)
    d = min_image_rows(f["x"][:, rows] - b["x"][:, nl.indices], state.pair_period)
    below = (up @ d) > 0.5 * np.sqrt((d * d).sum(axis=0))
    out[rows[below]] = True
    return out


def start_density(state: SimState, lists: _Lists, pressure: PressureSolver,
                  hydrostatic: bool) -> tuple[np.ndarray, np.ndarray]:
    """The start pressure p [Pa] and density [kg/m^3] of every fluid particle."""
    f = state.fluid
    rho0 = f["rho0"]
    # a flow, not a column
    if not hydrostatic or not np.any(state.gravity) or state.gravity_along_period:
        return np.zeros(f.n), rho0.astype(float).copy()
    lists.update(state)
    g = float(np.linalg.norm(state.gravity))
    if state.rest().uniform:
        depth = column_depth(f.view("x"), state.gravity, state.r, state.h,
                             resting_on_walls(state))
        p = rho0 * g * depth
    else:  # layers of several fluids: the weight of the column above
        p = g * column_depth(f.view("x"), state.gravity, state.r, state.h,
                             resting_on_walls(state), rho0=rho0)
    return p, np.asarray(pressure.compressed_density(p, rho0), dtype=float)


# ---------------------------------------------------------------------------------------------
# 3.-4. relaxation and masses


class _Lists:
    """The fluid-fluid and fluid-boundary lists of the state being started, rebuilt only when
    the fluid moved or changed since they were built (the start-up's steps ask for them at
    unchanged positions)."""

    def __init__(self, model: BoundaryModel) -> None:
        self.model = model
        self._x: np.ndarray | None = None  # the fluid positions they were built for

    def update(self, state: SimState) -> None:
        """Make ``state.nl_ff`` and ``state.nl_fb`` those of the current fluid positions."""
        x = state.fluid["x"]
        if self._x is not None and self._x.shape == x.shape and np.array_equal(self._x, x):
            return
        state.nl_ff = neighbor_lists(x, state.h, state.periodic)
        self.model.update(state)
        self._x = x.copy()


def _density(state: SimState, m: np.ndarray, out: np.ndarray) -> np.ndarray:
    """The summation density with the masses m (number density of the particles' own rest
    densities, :func:`sphkit.core.operators.density_body`)."""
    f, b = state.fluid, state.boundary
    rest = state.rest()
    mu = m if rest.uniform else m / rest.c
    # in the fields' precision: the start masses (lattice mass times rho_start / rho0) come in
    # float64, and a float32 run would compile the density pass a second time for them
    mu = mu.astype(f.dtype, copy=False)
    density_cpu(f["x"], mu, state.nl_ff.offsets, state.nl_ff.indices, b["x"], b["V"],
                state.nl_fb.offsets, state.nl_fb.indices, state.rho0, state.h, state.kid,
                state.dim, out, state.pair_period, c=rest.c)
    return out


def _constraint(state: SimState, target: np.ndarray) -> tuple[float, float]:
    """(mean, max) of the relaxation's clamped constraint ``C_i = rho_hat_i / t_i - 1`` at the
    current positions (:func:`sphkit.core.relaxation.relax_pass`'s, values up to
    :data:`RELAX_MET` counted as 0), from the summation density with the start masses:
    ``rho_hat_i = rho_i / rho0_i`` is the same sum of the start volumes (rounding apart)."""
    f = state.fluid
    rho = _density(state, f["m"] * target, np.empty(f.n, dtype=f.dtype))
    return _compression(rho, f["rho0"] * target, RELAX_MET)


def _compression(rho: np.ndarray, target: np.ndarray, met: float = 0.0) -> tuple[float, float]:
    """(mean, max) of ``max(rho / target - 1, 0)``, values up to ``met`` counted as 0."""
    e = np.maximum(rho / target - 1.0, 0.0)
    if met > 0.0:
        e = np.where(e > met, e, 0.0)
    return (float(e.mean()), float(e.max())) if len(e) else (0.0, 0.0)


def _round_off(dtype: np.dtype) -> float:
    """The relative density deviation below which a start-up test counts as equal: 1e-6, or in
    float32 32 units of round-off (a summation density of float32 positions and masses carries
    a few 1e-7: an interior particle at exactly its start density would otherwise count as thin
    by chance, and start with another mass than in float64)."""
    return max(1e-6, 32.0 * float(np.finfo(dtype).eps))


def filled(state: SimState, lists: _Lists) -> np.ndarray:
    """The fluid particles whose kernel is filled as sampled: their summation density with the
    lattice masses reaches their rest density (to :func:`_round_off`: 1e-6 in float64), the
    walls counted at rest density as the density sums count them. (Compared with the start
    masses and the start density instead, a compressed particle next to a box's lattice wall,
    whose particles stand for fluid at rest density, counted as a free surface and kept its
    kernel's deficit.) The others lie at a free surface."""
    f = state.fluid
    lists.update(state)
    rho = _density(state, f["m"], np.empty(f.n, dtype=f.dtype))
    return rho >= f["rho0"] * (1.0 - _round_off(f.dtype))


def relax(state: SimState, lists: _Lists, target: np.ndarray, iterations: int,
          report: StartReport) -> None:
    """Step 3 of the module docstring (``target``: start density over rho0)."""
    f = state.fluid
    x0 = f["x"].copy()
    V = f["V0"] * target  # the start masses: lattice mass times the start compression
    # the sampled constraint through the density pass every run compiles anyway: where no
    # particle is near the tolerance nothing moves, and the projection's passes are neither run
    # nor compiled (a first run of the default dam break: about 10 s of compilation less)
    lists.update(state)
    report.sampled_error = report.relaxed_error = _constraint(state, target)
    report.relax_iterations = 0
    if report.sampled_error[1] <= 0.5 * RELAX_TOLERANCE:
        report.max_displacement = 0.0
        return
    for k in range(iterations + 1):
        lists.update(state)
        b = state.boundary
        avg, mx, dx = relax_pass(f["x"], V, target, state.nl_ff, state.nl_fb, b["x"], b["V"],
                                 state.h, state.kid, state.dim, state.pair_period,
                                 RELAX_STEP * state.r, tol=RELAX_MET)
        if k == 0:
            report.sampled_error = (avg, mx)
        report.relaxed_error = (avg, mx)
        report.relax_iterations = k
        if mx <= RELAX_TOLERANCE or k == iterations:
            break
        f["x"] += dx
        for a, lo, L in state.periodic_axes:
            wrap_periodic(f["x"], lo, L, a)
    d = min_image_rows(f["x"] - x0, state.pair_period)
    report.max_displacement = float(np.sqrt((d * d).sum(axis=0)).max()) if f.n else 0.0


def hold_back(state: SimState, scene: Scene, meshes: SceneMeshes, model: BoundaryModel,
              x0: np.ndarray, report: StartReport) -> None:
    """Put the particles that the relaxation moved onto the solid side of a wall or body (the
    test of step 1) back where they were sampled (``x0``); the masses then make them
    consistent there. The relaxation pushes a particle away from its compressed neighbours as
    much as from the walls: in the concave corner of a surface-sampled container every fluid
    neighbour lies on one side, and a particle sampled r from both walls left through the
    corner, between the samples."""
    crossed = inside_walls(state, scene, meshes, model, 0.0)[0] >= 0
    report.held_back = int(crossed.sum())
    if report.held_back:
        state.fluid["x"][:, crossed] = x0[:, crossed]


def consistent_masses(state: SimState, lists: _Lists, rho_start: np.ndarray,
                      two_sided: np.ndarray, report: StartReport) -> np.ndarray:
    """Step 4 of the module docstring: the masses, and the removal of the particles the
    boundary claims (then the masses again, for the rest). Returns which of the particles it
    was given it kept."""
    f = state.fluid
    kept = np.ones(f.n, dtype=bool)
    for last in (False, False, True):
        lists.update(state)
        m0 = f["m"] * (rho_start / f["rho0"])  # lattice mass times the start compression
        m = m0.copy()
        cap = np.where(two_sided, m0 * (1.0 + MASS_SLACK), m0)
        rho = np.empty(f.n, dtype=f.dtype)
        for k in range(MASS_ITERATIONS):
            err = mass_pass(m, cap, rho_start, _density(state, m, rho))
            report.mass_iterations = k + 1
            if err <= MASS_TOLERANCE:
                break
        share = m / m0
        close = share < MIN_MASS_SHARE
        if last or not close.any():  # (the third round keeps what is left)
            break
        _remove(state, np.where(close, 0, -1), ["the boundary model"],
                "start so close to the walls that most of their volume belongs to",
                report.removed_close)
        kept[np.flatnonzero(kept)[close]] = False
        rho_start = rho_start[~close]
        two_sided = two_sided[~close]
    f["V0"] = f["V0"] * (m / f["m"])  # unchanged to the last bit where the mass is
    f["m"] = m
    report.min_mass_share = float(share.min()) if f.n else 1.0
    report.max_mass_share = float(share.max()) if f.n else 1.0
    rho = _density(state, f["m"], np.empty(f.n, dtype=f.dtype))
    f["rho"] = rho
    e = rho / rho_start - 1.0
    e = np.where(two_sided, np.abs(e), np.maximum(e, 0.0))
    report.start_error = (float(e.mean()), float(e.max())) if f.n else (0.0, 0.0)
    return kept


def start_fluid(state: SimState, scene: Scene, meshes: SceneMeshes, model: BoundaryModel,
                pressure: PressureSolver) -> tuple[StartReport, SettlePlan | None]:
    """Steps 1-4 of the module docstring on the built state (walls, maps and bodies in place,
    the methods not yet initialised); ``state.fluid`` ends with its start masses, volumes,
    positions, densities and pressures. Also returns the settling the simulation runs before
    t = 0 (:mod:`sphkit.world.settle`), or None."""
    cfg = scene.configuration.start
    report = StartReport(hydrostatic=cfg.hydrostatic and bool(np.any(state.gravity)))
    f = state.fluid
    if f.n == 0:
        return report, None
    remove_inside(state, scene, meshes, model, report)
    lists = _Lists(model)
    p, rho_start = start_density(state, lists, pressure, cfg.hydrostatic)
    two_sided = filled(state, lists)
    if cfg.relax:
        x0 = f["x"].copy()
        relax(state, lists, rho_start / f["rho0"], cfg.relax_iterations, report)
        hold_back(state, scene, meshes, model, x0, report)
        p, rho_start = start_density(state, lists, pressure, cfg.hydrostatic)  # after the moves
        kept = consistent_masses(state, lists, rho_start, two_sided, report)
        p, two_sided = p[kept], two_sided[kept]
    else:
        c = rho_start / f["rho0"]
        f["m"] = f["m"] * c
        f["V0"] = f["V0"] * c
        lists.update(state)
        f["rho"] = _density(state, f["m"], np.empty(f.n, dtype=f.dtype))
        report.sampled_error = report.relaxed_error = _compression(f["rho"], rho_start)
    f["p"] = p
    plan = None
    if report.hydrostatic and np.any(p > 0.0):
        lists.update(state)
        depth = column_depth(f.view("x"), state.gravity, state.r, state.h,
                             resting_on_walls(state))
        plan = plan_settle(state, scene, pressure, p, depth, two_sided)
    return report, plan
