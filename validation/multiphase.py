"""Two fluids of different rest density (Solenthaler & Pajarola 2008; sphkit.multiphase).

    python validation/multiphase.py [--solvers pcisph pbf iisph dfsph] [--radius 0.01]
        [--until 3.0] [--ratio 10] [--study layers hydrostatic] [--settle 1.5] [--average 0.5]
        [--jitter 0.1] [--viscosity 0.01] [--symmetric-walls] [--dim 3] [--depth 0.2]
        [--interface-viscosity 0.01] [--interface-tension 1.0] [--solved-walls [density]]
        [--mls-walls] [--max-error 0.05]
        [--study bubbles --blob 1 4 9] [--every 0.5]

Two studies in 2D, each a closed box 0.4 m wide, the fluid filling its width (lattice blocks from
the walls, sphkit's start-up; each layer 0.3 m (``--layer``) rounded to whole rows of 2r,
``layer_height``, so that the two blocks meet on one lattice), standard viscosity
``--viscosity`` (0.01 m^2/s, the value of SPlisHSPlasH's multiphase scenes) in each phase
(within the phase, as SPlisHSPlasH), heavy rest density 1000 kg/m^3, light ``1000 / --ratio``:

* ``layers``: heavy over light, two layers 0.3 m each -- Rayleigh-Taylor unstable; the
  sampled particles are moved by a random displacement of up to ``--jitter`` r along each axis
  (seed 1) before sphkit's start-up relaxes and weighs them (``_perturbed_world``), the
  perturbation that starts the instability (on the exact lattice a column at 1:2 stayed
  heavy on top for 3 s: its equilibrium is unstable but nothing disturbs it). After
  ``--until`` (3 s) the phases should lie in two layers, heavy below. The table counts the
  particles more than two layers (4r) inside the other phase: heavy above ``y_s + 4r`` or light
  below ``y_s - 4r``, ``y_s`` the height that would split the column into the two phases if they
  were perfectly layered (between the N_heavy-th and the next particle by height); the largest
  such depth; the largest speed at the end; iterations and wall time per step.
* ``hydrostatic``: light over heavy at rest, 0.3 m each. After ``--settle`` s the pressure and
  height of every particle are averaged over ``--average`` s, and the least-squares slope of
  pressure over height is fitted in each layer (the particles more than h from the interface,
  the free surface and the floor) and given as a multiple of its own rho0 g (1 is exact;
  target within 2 %); the same fits without the particles within 3r of a side wall ("in":
  where the walls carry the fluid beside them differently from the fluid's own pressure, the
  two differ); the same fits over the particles more than 2h from the layer's ends ("2h": at
  a density ratio of 1:10 the pressure ripples from row to row within about 2h of the
  interface in every wall configuration, a periodic column without side walls included, and
  a fit that starts h from the interface starts inside the ripple; validation/README.md, "The
  light layer's steepness at 1:10 is the interface's ripple"); also the pressure jump across
  the interface against the light layer's weight rho0_light g H_light. ``--realizations K``:
  K runs per solver, the first from the lattice, the others from the lattice jittered by up to
  ``--jitter`` r (seeds 1, 2, ...), and the mean and standard deviation of their whole-layer
  fits (validation/README.md, "Realizations: how far a 2D column's fit moves with its start").

* ``bubbles``: light particles in a heavy column at rest (``--study bubbles``, not in the
  default list): a heavy layer 0.3 m under a light one 0.04 m, both filling the box's width;
  before the start-up, ``--blob`` k (1, 4, 9) heavy particles nearest to each of four points
  (the floor's middle, (0.3, 0.06), the middle (0.2, 0.15), (0.3, 0.25) m) become light ones:
  the blob's mean height [r] every ``--every`` s shows whether buoyancy lifts it. One light
  particle is the straggler that ``layers`` counts; a blob of 9 is a bubble a few particles
  across.

* ``rest``: light over heavy at rest (``--study rest``, not in the default list) for ``--until``
  s: every second the particles more than two layers (4r) inside the other phase (counted as
  in ``layers``: heavy above the split + light below it), the deepest in layers of 2r, and the
  largest speed: whether the interface stays sharp (no spurious mixing, no blow-up).

``--interface-viscosity``: the viscosity between the two phases (scene ``interfaces``,
Morris et al. 1997, kinematic [m^2/s]; default none, SPlisHSPlasH's phases).
``--interface-tension``: an interface tension between them (Hu & Adams 2006, scene
``interfaces[].tension``, ``hu2006`` [N/m; N in 2D]; default none). ``--phase-tension METHOD
COEFF``: a surface tension within each material instead (``materials[].surface_tension``, no
adhesion; validation/README.md, "Cohesion within each phase against the stragglers").

``--dim 3``: the same column in 3D, ``--depth`` (0.2 m) deep along z between walls (a coarse
slab; run it with ``--radius 0.02``: 0.4 x 0.6 x 0.2 m is 750 particles at r = 2 cm). For the
``hydrostatic`` study use a square tank at r = 1 cm with layers 0.6 m deep, ``--depth 0.4
--radius 0.01 --layer 0.6`` (20 x 20 particles across, 30 rows of 2r per layer, 24,000
particles): at r = 2 cm a layer has 7-8 rows, of which the fit (h away from the layer's ends)
keeps 3-4, and one density already reads 3-9 % steep there (validation/README.md, "The
two-layer column in a square 3D tank"); at 15 rows (0.3 m) the fit resolves the slope to about
+-3 % and its first light row lies in the interface's ripple ("The light layer's steepness at
1:10 is the interface's ripple").
"""

from __future__ import annotations

import argparse
import logging
import time
import warnings

import numpy as np

from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation
from sphkit.world import World, build
from sphkit.world.build import build_world

G = 9.81
WIDTH = 0.4
LAYER = 0.3
#: the pressure solvers' tolerance [%] (``--max-error``): SPlisHSPlasH's multiphase scenes' 0.05
MAX_ERROR = 0.05


def layer_height(r: float) -> float:
    """LAYER rounded to a whole number of lattice spacings 2r, so that the two blocks meet on
    one lattice: each block holds ``floor(height / 2r)`` rows, so at r = 2 cm two 0.3 m blocks
    held 7 rows each with a gap of 3r instead of 2r between them, and the upper layer fell by r
    at the start (0.3 m at r = 1 cm and 1.5 cm is already whole)."""
    rows = max(round(LAYER / (2.0 * r)), 1)
    return LAYER if abs(rows * 2.0 * r - LAYER) < 1e-9 else rows * 2.0 * r


def scene(method: str, r: float, heavy_on_top: bool, ratio: float,
          viscosity: float = 0.01, symmetric: bool = False, dim: int = 2,
          depth: float = 0.2, interface_viscosity: float = 0.0,
          solved: bool | str | None = None, interface_tension: float = 0.0,
          phase_tension: tuple[str, float] | None = None) -> Scene:
    """Two layers of :func:`layer_height` m (LAYER rounded) in a box WIDTH m wide (and
    ``depth`` m deep in 3D; module docstring); ``phase_tension``: (method, coefficient) of a
    surface tension within each material (no adhesion to the walls)."""
    lower, upper = ("light", "heavy") if heavy_on_top else ("heavy", "light")
    layer = layer_height(r)
    visc = {"method": "standard", "coefficient": viscosity}
    tension = ({} if phase_tension is None else
               {"surface_tension": {"method": phase_tension[0],
                                    "coefficient": phase_tension[1],
                                    "boundary_coefficient": 0.0}})
    pressure: dict = {"method": method, "max_error": MAX_ERROR}
    if method == "wcsph":
        pressure = {"method": "wcsph", "stiffness": 1e5, "exponent": 7.0}
    z = [0.0] if dim == 3 else []
    zd = [depth] if dim == 3 else []
    return Scene.model_validate({
        "configuration": {"dim": dim, "particle_radius": r, "gravity": [0.0, -G, *z],
                          "pressure": pressure, "time": {"dt_max": 0.002},
                          "boundary": {"symmetric": symmetric,
                                       **({} if solved is None else {"solved": solved})}},
        "materials": [{"id": "heavy", "density0": 1000.0, "viscosity": visc, **tension},
                      {"id": "light", "density0": 1000.0 / ratio, "viscosity": visc,
                       **tension}],
        "fluid_blocks": [{"start": [0.0, 0.0, *z], "end": [WIDTH, layer, *zd],
                          "material": lower},
                         {"start": [0.0, layer, *z], "end": [WIDTH, 2 * layer, *zd],
                          "material": upper}],
        "boxes": [{"min": [0.0, 0.0, *z], "max": [WIDTH, 2 * layer + 0.2, *zd]}],
        "interfaces": [{"materials": ["heavy", "light"],
                        **({"viscosity": {"method": "morris1997",
                                          "coefficient": interface_viscosity}}
                           if interface_viscosity > 0 else {}),
                        **({"tension": {"method": "hu2006", "coefficient": interface_tension}}
                           if interface_tension > 0 else {})}]
        if interface_viscosity > 0 or interface_tension > 0 else [],
    })


def _level(solved: bool | str | None) -> str:
    """The level of the solved walls' constraint for the headings ("" for ``solved: true``)."""
    return f" ({solved} level)" if isinstance(solved, str) else ""


def _walls(symmetric: bool, solved: bool | str | None) -> str:
    """The wall term for the headings (None: the scene's default, which solves the walls at
    density level for IISPH, DFSPH and PCISPH where the rest densities differ by more than a
    factor 4, else MLS)."""
    if symmetric:
        return ", symmetric wall term"
    if solved is None:
        return ", default walls"
    return f", solved wall pressures{_level(solved)}" if solved else ", MLS walls"


def mixing(sim: Simulation) -> tuple[int, int, float]:
    """(heavy above y_s + 4r, light below y_s - 4r, largest depth inside the other phase in
    layers of 2r) of the module docstring."""
    f = sim.fluid
    y = f.view("x")[:, 1]
    heavy = f["phase"] == 0
    nh = int(heavy.sum())
    ys = np.sort(y)
    split = 0.5 * (ys[nh - 1] + ys[nh]) if 0 < nh < len(ys) else ys[-1]
    r = sim.state.r
    up = y[heavy] - split
    down = split - y[~heavy]
    deep = max(float(up.max(initial=0.0)), float(down.max(initial=0.0))) / (2 * r)
    return int((up > 4 * r).sum()), int((down > 4 * r).sum()), deep


def stragglers(sim: Simulation, depth: float) -> tuple[int, int, int, float]:
    """The light particles more than two layers below the split (as :func:`mixing`): (how
    many, how many are alone -- at most one other light particle within 2.5 r --, how many
    lie in the first row at a wall -- centre within 1.5 r of the floor or a side wall (and, in
    3D, the front and back at 0 and ``depth``) --, their mean vertical speed [m/s])."""
    f = sim.fluid
    x, v = f.view("x"), f.view("v")
    y = x[:, 1]
    heavy = f["phase"] == 0
    nh = int(heavy.sum())
    ys = np.sort(y)
    split = 0.5 * (ys[nh - 1] + ys[nh]) if 0 < nh < len(ys) else ys[-1]
    r = sim.state.r
    sel = ~heavy & (split - y > 4 * r)
    if not sel.any():
        return 0, 0, 0, 0.0
    xs, xl = x[sel], x[~heavy]
    d = np.sqrt(((xs[:, None, :] - xl[None, :, :]) ** 2).sum(axis=-1))
    alone = int(((d < 2.5 * r).sum(axis=1) - 1 <= 1).sum())
    wall = np.minimum(np.minimum(xs[:, 0], WIDTH - xs[:, 0]), xs[:, 1])
    if x.shape[1] == 3:
        wall = np.minimum(wall, np.minimum(xs[:, 2], depth - xs[:, 2]))
    return int(sel.sum()), alone, int((wall < 1.5 * r).sum()), float(v[sel, 1].mean())


def _perturbed_world(scene: Scene, jitter: float, seed: int = 1) -> World:
    """The world of ``scene`` with every fluid particle moved by a random displacement of up to
    ``jitter`` r along each axis (seed ``seed``) *before* the start-up (removal, relaxation,
    masses; sphkit.world.startup), so that the start-up makes the perturbed lattice consistent
    with the walls. (Moved after it, particles 2r off a wall moved up to 0.1 r towards it
    started up to 6 % compressed next to the 3D box's edges and the first solves diverged.)"""
    original = build.add_fluid

    def add_fluid(state, scene_, meshes):  # noqa: ANN001, ANN202 (build's own signature)
        original(state, scene_, meshes)
        x = state.fluid["x"]
        x += jitter * state.r * np.random.default_rng(seed).uniform(-1.0, 1.0, x.shape)

    build.add_fluid = add_fluid
    try:
        return build_world(scene)
    finally:
        build.add_fluid = original


def layers(methods: list[str], r: float, until: float, ratio: float, jitter: float,
           viscosity: float, symmetric: bool = False, dim: int = 2, depth: float = 0.2,
           interface_viscosity: float = 0.0, solved: bool | str | None = None,
           every: float = 0.0, interface_tension: float = 0.0,
           phase_tension: tuple[str, float] | None = None) -> None:
    """Heavy over light (module docstring, ``layers``); ``every`` > 0: a line every ``every``
    s with the counts and the light stragglers of :func:`stragglers`; ``phase_tension`` as
    :func:`scene`'s."""
    print(f"\nheavy over light, {dim}D, r = {r} m, rho0 1000 / {1000 / ratio:g}, until {until} s, "
          f"jitter {jitter} r, viscosity {viscosity} m^2/s"
          + _walls(symmetric, solved)
          + (f", interface viscosity {interface_viscosity} m^2/s" if interface_viscosity else "")
          + (f", interface tension {interface_tension} N" if interface_tension else "")
          + (f", {phase_tension[0]} {phase_tension[1]:g} within each phase"
             if phase_tension else ""))
    print(f"{'solver':8s} {'n':>5s} {'heavy up':>9s} {'light down':>10s} {'deepest':>8s} "
          f"{'vmax':>6s} {'its':>6s} {'ms/step':>8s}  note")
    for method in methods:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sim = Simulation(_perturbed_world(
                scene(method, r, True, ratio, viscosity, symmetric, dim, depth,
                      interface_viscosity, solved, interface_tension, phase_tension),
                jitter))
        its, steps, note = [], 0, ""
        next_t = every
        t0 = time.perf_counter()
        try:
            while sim.time < until - 1e-9:
                st = sim.step()
                its.append(st.iterations)
                steps += 1
                if every > 0 and sim.time >= next_t - 1e-9:
                    next_t += every
                    up, down, deep = mixing(sim)
                    n, alone, wall, vy = stragglers(sim, depth)
                    print(f"  {method} t = {sim.time:.1f} s: heavy up {up}, light down {down} "
                          f"(deepest {deep:.1f}): {alone} alone, {wall} in the first row at "
                          f"a wall, mean v_y {vy:+.3f} m/s", flush=True)
        except InstabilityError as e:
            note = f"unstable at t = {e.stats.time:.3f} s"
        wall = (time.perf_counter() - t0) / max(steps, 1) * 1e3
        up, down, deep = mixing(sim)
        vmax = float(np.sqrt((sim.fluid["v"] ** 2).sum(axis=0)).max())
        print(f"{method:8s} {sim.fluid.n:5d} {up:9d} {down:10d} {deep:8.1f} {vmax:6.2f} "
              f"{np.mean(its):6.1f} {wall:8.1f}  {note}", flush=True)


def layer_slopes(y: np.ndarray, p: np.ndarray, heavy: np.ndarray, interface: float,
                 top: float, rho_h: float, rho_l: float, margin: float,
                 where: np.ndarray | bool = True) -> tuple[float, float]:
    """The least-squares slope of pressure p over height y in the heavy and the light layer, in
    units of each layer's rho0 g, over the particles more than ``margin`` from the layer's ends
    (floor, ``interface``, free surface ``top``) and with ``where``; nan with fewer than three."""
    out = []
    for sel, rho in ((heavy & (y > margin) & (y < interface - margin), rho_h),
                     (~heavy & (y > interface + margin) & (y < top - margin), rho_l)):
        sel = sel & where
        out.append(-np.polyfit(y[sel], p[sel], 1)[0] / (rho * G) if sel.sum() > 2 else np.nan)
    return out[0], out[1]


def hydrostatic(methods: list[str], r: float, settle: float, average: float,
                ratio: float, viscosity: float, symmetric: bool = False, dim: int = 2,
                depth: float = 0.2, solved: bool | str | None = None,
                realizations: int = 1, jitter: float = 0.1) -> None:
    """Light over heavy at rest (module docstring, ``hydrostatic``); ``realizations`` K > 1:
    realization k > 0 starts from the lattice jittered by up to ``jitter`` r (seed k, before the
    start-up), a row each, then the mean and standard deviation of the K rows' whole-layer
    fits (a single run of a 15-row 2D column scatters by 2-3 points between windows)."""
    print(f"\nlight over heavy at rest, {dim}D, r = {r} m, rho0 1000 / {1000 / ratio:g}; slopes in "
          f"units of the layer's rho0 g, averaged {settle}-{settle + average} s"
          + _walls(symmetric, solved)
          + (f", {realizations} realizations (jitter {jitter} r)" if realizations > 1 else ""))
    print(f"{'solver':8s} {'heavy':>7s} {'light':>7s} {'heavy in':>8s} {'light in':>8s} "
          f"{'heavy 2h':>8s} {'light 2h':>8s} {'jump/rho_l g H_l':>17s} {'vmax':>6s} "
          f"{'ms/step':>8s}  note")
    for method in methods:
        fits = []
        for k in range(realizations):
            fit = _hydrostatic_run(method, r, settle, average, ratio, viscosity, symmetric, dim,
                                   depth, solved, jitter if k else 0.0, k)
            if fit is not None:
                fits.append(fit)
        if realizations > 1 and fits:
            f = np.array(fits)
            print(f"{'  mean':8s} {f[:, 0].mean():7.4f} {f[:, 1].mean():7.4f}   (std "
                  f"{f[:, 0].std():.4f} / {f[:, 1].std():.4f} over {len(fits)})", flush=True)


def _hydrostatic_run(method: str, r: float, settle: float, average: float, ratio: float,
                     viscosity: float, symmetric: bool, dim: int, depth: float,
                     solved: bool | str | None, jitter: float,
                     seed: int) -> tuple[float, float] | None:
    """One run of :func:`hydrostatic` (a table row); its whole-layer fits, None if unstable."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = scene(method, r, False, ratio, viscosity, symmetric, dim, depth, solved=solved)
        sim = Simulation(_perturbed_world(sc, jitter, seed) if jitter > 0 else sc)
    note = "" if seed == 0 else f"realization {seed}"
    t0 = time.perf_counter()
    steps = 0
    try:
        sim.run(until=settle)
        f = sim.fluid
        n = f.n
        order = f.order_by_id()
        p_sum, y_sum, k = np.zeros(n), np.zeros(n), 0
        x_sum = np.zeros((n, dim))
        while sim.time < settle + average - 1e-9:
            sim.step()
            steps += 1
            order = f.order_by_id()
            p_sum += f["p"][order]
            y_sum += f.view("x")[order, 1]
            x_sum += f.view("x")[order]
            k += 1
    except InstabilityError as e:
        print(f"{method:8s} unstable at t = {e.stats.time:.3f} s", flush=True)
        return None
    wall = (time.perf_counter() - t0) / max(steps + 1, 1) * 1e3
    f = sim.fluid
    order = f.order_by_id()
    p, y = p_sum / k, y_sum / k
    phase = f["phase"][order]
    h = sim.state.h
    heavy = phase == 0
    top = y.max() + r
    interface = 0.5 * (y[heavy].max() + y[~heavy].min())
    rho_h, rho_l = 1000.0, 1000.0 / ratio
    across = x_sum[:, [0] + ([2] if dim == 3 else [])] / k
    extent = [WIDTH] + ([depth] if dim == 3 else [])
    inner = np.all((across > 3 * r) & (across < np.array(extent) - 3 * r), axis=1)
    layers = (y, p, heavy, interface, top, rho_h, rho_l)
    slope_h, slope_l = layer_slopes(*layers, h)
    # the same fits without the particles within 3r of a side wall ("in"): where the
    # walls' share of the support differs from the fluid's, it shows as the difference
    in_h, in_l = layer_slopes(*layers, h, inner)
    # the same fits 2h from each end of a layer ("2h": beyond the interface's ripple)
    far_h, far_l = layer_slopes(*layers, 2 * h)
    # the jump: the heavy layer's fit at the interface against the light layer's weight
    sel_h = heavy & (y > h) & (y < interface - h)
    p_int = np.polyval(np.polyfit(y[sel_h], p[sel_h], 1), interface)
    jump = p_int / (rho_l * G * (top - interface))
    vmax = float(np.sqrt((f["v"] ** 2).sum(axis=0)).max())
    print(f"{method:8s} {slope_h:7.4f} {slope_l:7.4f} {in_h:8.4f} {in_l:8.4f} "
          f"{far_h:8.4f} {far_l:8.4f} {jump:17.3f} {vmax:6.3f} {wall:8.1f}  "
          f"{note}", flush=True)
    return slope_h, slope_l


def rest(methods: list[str], r: float, until: float, ratio: float, viscosity: float,
         symmetric: bool = False, dim: int = 2, depth: float = 0.2,
         solved: bool | str | None = None, every: float = 1.0) -> None:
    """Light over heavy at rest for ``until`` s: the interface should stay sharp (module
    docstring, ``rest``)."""
    print(f"\nlight over heavy at rest, {dim}D, r = {r} m, rho0 1000 / {1000 / ratio:g}, "
          f"until {until} s; particles more than two layers (4r) inside the other phase, "
          "the deepest in layers of 2r, the largest speed [m/s]")
    for method in methods:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sim = Simulation(scene(method, r, False, ratio, viscosity, symmetric, dim, depth,
                                   solved=solved))
        row, next_t, note = [], every, ""
        t0 = time.perf_counter()
        steps = 0
        try:
            while sim.time < until - 1e-9:
                sim.step()
                steps += 1
                if sim.time >= next_t - 1e-9:
                    up, down, deep = mixing(sim)
                    vmax = float(np.sqrt((sim.fluid["v"] ** 2).sum(axis=0)).max())
                    row.append(f"{sim.time:.0f} s: {up}+{down} ({deep:.1f}, {vmax:.3f})")
                    next_t += every
        except InstabilityError as e:
            note = f"unstable at t = {e.stats.time:.3f} s"
        wall = (time.perf_counter() - t0) / max(steps, 1) * 1e3
        print(f"{method:8s} n = {sim.fluid.n}: " + "; ".join(row)
              + f"  [{wall:.0f} ms/step] {note}", flush=True)


#: bubbles: where the blobs start [m] (module docstring)
BUBBLES = {"floor": (0.2, 0.0), "low": (0.3, 0.06), "middle": (0.2, 0.15), "high": (0.3, 0.25)}


def _bubble_world(scene: Scene, blob: int, ratio: float) -> tuple[World, dict[str, list[int]]]:
    """The world of ``scene`` with the ``blob`` heavy particles nearest to each point of
    BUBBLES turned into the light phase (phase 1, its rest density and mass) before the
    start-up; the ids of each blob."""
    original = build.add_fluid
    ids: dict[str, list[int]] = {}

    def add_fluid(state, scene_, meshes):  # noqa: ANN001, ANN202 (build's own signature)
        original(state, scene_, meshes)
        f = state.fluid
        x = f["x"]
        for name, (px, py) in BUBBLES.items():
            d2 = (x[0] - px) ** 2 + (x[1] - py) ** 2
            sel = np.argsort(np.where(f["phase"] == 0, d2, np.inf))[:blob]
            f["phase"][sel] = 1
            f["rho0"][sel] = 1000.0 / ratio
            f["rho"][sel] = 1000.0 / ratio
            f["m"][sel] = f["V0"][sel] * (1000.0 / ratio)
            ids[name] = [int(i) for i in f["id"][sel]]

    build.add_fluid = add_fluid
    try:
        return build_world(scene), ids
    finally:
        build.add_fluid = original


def bubbles(methods: list[str], r: float, until: float, ratio: float, viscosity: float,
            blob: int, symmetric: bool = False, solved: bool | str | None = None,
            every: float = 0.5) -> None:
    """Blobs of ``blob`` light particles in a heavy column at rest (module docstring,
    ``bubbles``; 2D)."""
    print(f"\nbubbles of {blob} light particle(s) in a heavy column, 2D, r = {r} m, rho0 1000 / "
          f"{1000 / ratio:g}, viscosity {viscosity} m^2/s"
          + _walls(symmetric, solved)
          + f"; the blob's mean height [r] every {every} s (heavy top at {LAYER / r:.0f} r)")
    for method in methods:
        sc = scene(method, r, False, ratio, viscosity, symmetric, solved=solved)
        sc = sc.model_copy(update={"fluid_blocks": [
            sc.fluid_blocks[0],
            sc.fluid_blocks[1].model_copy(update={"end": [WIDTH, LAYER + 0.04]})]})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            world, ids = _bubble_world(sc, blob, ratio)
            sim = Simulation(world)
        rows: dict[str, list[str]] = {name: [] for name in ids}
        next_t, note = 0.0, ""

        try:
            while True:
                if sim.time >= next_t - 1e-9:
                    where = {int(i): k for k, i in enumerate(sim.fluid["id"])}
                    y = sim.fluid.view("x")[:, 1]
                    for name, members in ids.items():
                        rows[name].append(f"{np.mean([y[where[i]] for i in members]) / r:5.1f}")
                    next_t += every
                if sim.time >= until - 1e-9:
                    break
                sim.step()
        except InstabilityError as e:
            note = f"unstable at t = {e.stats.time:.3f} s"
        for name, row in rows.items():
            print(f"{method:8s} {name:7s} " + " ".join(row) + f"  {note}", flush=True)


def main() -> None:
    global MAX_ERROR, LAYER
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--solvers", nargs="+", default=["pcisph", "pbf", "iisph", "dfsph"])
    ap.add_argument("--study", nargs="+", default=["layers", "hydrostatic"],
                    choices=["layers", "hydrostatic", "rest", "bubbles"])
    ap.add_argument("--radius", type=float, default=0.01)
    ap.add_argument("--until", type=float, default=3.0)
    ap.add_argument("--ratio", type=float, default=10.0)
    ap.add_argument("--settle", type=float, default=1.5)
    ap.add_argument("--average", type=float, default=0.5)
    ap.add_argument("--jitter", type=float, default=0.1,
                    help="layers: the start lattice's jitter [r]; hydrostatic: that of "
                         "realizations 1, 2, ...")
    ap.add_argument("--realizations", type=int, default=1,
                    help="hydrostatic: runs per solver, the first from the lattice, the others "
                         "jittered (--jitter); the mean and spread of their fits")
    ap.add_argument("--viscosity", type=float, default=0.01)
    ap.add_argument("--max-error", type=float, default=MAX_ERROR,
                    help="the pressure solvers' tolerance [%%] (SPlisHSPlasH's multiphase "
                    "scenes: 0.05; its DFSPH default: 0.01)")
    ap.add_argument("--symmetric-walls", action="store_true",
                    help="configuration.boundary.symmetric: the walls' term V_b k_i alone")
    ap.add_argument("--solved-walls", nargs="?", const=True, default=None,
                    choices=["velocity", "density"],
                    help="configuration.boundary.solved: the walls' pressures solved in the PPE "
                         "(alone or 'velocity': the rate held; 'density': the density held); "
                         "left out: the scene's default (density level for IISPH, DFSPH and "
                         "PCISPH where the rest densities differ by more than a factor 4, else "
                         "the MLS boundary pressure)")
    ap.add_argument("--mls-walls", action="store_const", const=False, dest="solved_walls",
                    help="configuration.boundary.solved false: the MLS boundary pressure (the "
                         "default of fluids of one rest density)")
    ap.add_argument("--dim", type=int, default=2, choices=[2, 3])
    ap.add_argument("--depth", type=float, default=0.2, help="3D: depth of the box along z [m]")
    ap.add_argument("--layer", type=float, default=LAYER,
                    help="each layer's height [m] (rounded to whole rows of 2r): deeper layers "
                         "give the hydrostatic fits more rows")
    ap.add_argument("--interface-viscosity", type=float, default=0.0,
                    help="layers: viscosity between the phases [m^2/s] (0: none)")
    ap.add_argument("--interface-tension", type=float, default=0.0,
                    help="layers: interface tension between the phases (hu2006) [N/m; N in "
                         "2D] (0: none)")
    ap.add_argument("--phase-tension", nargs=2, metavar=("METHOD", "COEFF"), default=None,
                    help="layers: a surface tension within each material (akinci2013, he2014, "
                         "becker2007, ...) and its coefficient (none by default)")
    ap.add_argument("--every", type=float, default=0.0,
                    help="layers: print the counts and the stragglers every EVERY s (0: at "
                         "the end only)")
    ap.add_argument("--blob", type=int, nargs="+", default=[1, 9],
                    help="bubbles: particles per blob (one table each)")
    args = ap.parse_args()
    MAX_ERROR, LAYER = args.max_error, args.layer
    logging.getLogger("sphkit").setLevel(logging.ERROR)
    if "hydrostatic" in args.study:
        hydrostatic(args.solvers, args.radius, args.settle, args.average, args.ratio,
                    args.viscosity, args.symmetric_walls, args.dim, args.depth,
                    args.solved_walls, args.realizations, args.jitter)
    if "rest" in args.study:
        rest(args.solvers, args.radius, args.until, args.ratio, args.viscosity,
             args.symmetric_walls, args.dim, args.depth, args.solved_walls)
    if "bubbles" in args.study:
        for blob in args.blob:
            bubbles(args.solvers, args.radius, args.until, args.ratio, args.viscosity, blob,
                    args.symmetric_walls, args.solved_walls)
    if "layers" in args.study:
        layers(args.solvers, args.radius, args.until, args.ratio, args.jitter, args.viscosity,
               args.symmetric_walls, args.dim, args.depth, args.interface_viscosity,
               args.solved_walls, args.every, args.interface_tension,
               None if args.phase_tension is None
               else (args.phase_tension[0], float(args.phase_tension[1])))


if __name__ == "__main__":
    main()
