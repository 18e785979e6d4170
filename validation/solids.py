"""Elastic cantilevers against Euler-Bernoulli beam theory (corotated SPH, becker2009).

Two cases, each at several resolutions (particles across the thickness):

* ``sag``: a 3D beam of square section h x h and free length L, clamped at x = 0 by a fixed box
  over three particle layers behind it, sags under gravity. The static tip deflection is
  compared with Euler-Bernoulli's ``w = q L^4 / (8 E I)`` (``q``: the weight per length of the
  free part, from the particles' masses; ``I = h^4 / 12``), and with Timoshenko's, which adds the
  shear term ``q L^2 / (2 kappa G A)`` (kappa = 5/6; 1 % here). The static state is reached by
  mass-proportional velocity damping ``v <- v exp(-c dt)`` after every step, with ``c`` twice
  the first-mode angular frequency (critical damping of mode 1; damping does not change a
  static state); the run lasts 12 / omega_1 and the table shows the deflection's last relative
  change over the final 10 % of the run. The tip deflection is the mean over the last particle
  layer, whose centres lie at x = L - r: the table compares it with Euler-Bernoulli's (and
  Timoshenko's) tip ``w(L)`` and, like with like, with their ``w(L - r)`` (1.7 % lower at 4
  particles across, 0.8 % at 8). ``--clamp face``: ``elasticity.clamp`` "face" (pinned
  particles rigid, the free particles' fits sample the fixed box's face; sphkit.solids.rest).
  ``--static N`` (peer2018): the static state directly,
  by N backward Euler steps of ``omega_1 dt = 1e4`` with the velocities zeroed after each
  (Newton steps on the equilibrium; the CG to a relative residual of 1e-10).
* ``mode``: the 2D clamped plate of Gray, Monaghan & Swift 2001 (L = 0.2 m, H = 0.02 m,
  E = 2 MPa, nu = 0.3375, rho = 1000 kg/m^3; plane strain), no gravity, started with the
  velocity of the first bending mode (tip speed 0.05 m/s, tip amplitude 1 % of L); the period
  from the tip's zero crossings over two periods against ``omega = (k L)^2 / L^2
  sqrt(E H^2 / (12 rho (1 - nu^2)))``, kL = 1.875.

* ``float``: a 2D elastic block (height H = 0.1 m, width 2H: upright is its stable floating
  position for densities 0.5 x water; E 1 MPa, density ``--density`` x water) released at
  rest half as deep as Archimedes' depth in water (DFSPH, depth 2.5 H; the water sampled
  around it) in a tank 6 H wide, for ``--float-time`` s. Its submerged depth -- the water
  surface (the mean of the columns' highest particles plus r, within 1.5 H of either wall,
  averaging the two sides, so the tank's sloshing mode cancels) minus its bottom (its centroid
  less the rest height of the centroid above the bottom face) -- averaged over the second half
  of the run (it bobs at about 2 Hz), against Archimedes' ``d = m / (rho_water w)``, m the
  block's mass per unit length, w its width (its lattice cells). ``--dim 3``: a ball of
  diameter 0.1 m in water 0.15 m deep (:func:`floating_ball`).
* ``sheet``: a 2D sheet clamped at both ends under water poured on it, against its dead-load
  twin and Euler-Bernoulli's clamped-clamped deflection (:func:`sheet`).

No pressure in ``sag`` and ``mode`` (WCSPH with stiffness 0, as SPlisHSPlasH's Beam scenes):
the solid alone. The time
step is the explicit model's bound (``0.4 * 2r / c``, c the P-wave speed) times ``--dt-factor``
(the implicit ``--method peer2018``, ``kugelstadt2021`` and ``kee2023`` may take larger steps;
kugelstadt2021 prints its factorisation time and memory, kee2023 its last step's iterations;
kee2023 takes ``--solver newton|lbfgs`` and ``--material-model corotated|stable_neo_hookean``).
Run::

    PYTHONPATH=src python validation/solids.py [--case sag|mode|both|float|sheet]
        [--layers 4 6 8] [--static N] [--dim 2|3] [--float-alpha 0.1] [--clamp face]
        [--method becker2009|peer2018|kugelstadt2021|kee2023] [--dt-factor 1]
        [--density 0.5] [--float-time 3]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

RHO, G = 1000.0, 9.81
KL = 1.8751040687  # first root of 1 + cos(kL) cosh(kL) = 0


def _time_step(r: float, E: float, nu: float) -> float:
    """The explicit model's step ``0.4 * 2r / c``, c the P-wave speed (Becker2009's bound)."""
    mu, lam = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    return 0.4 * 2 * r / math.sqrt((lam + 2 * mu) / RHO)


#: the elasticity options of the runs (``--gradient``, ``--support``, ``--rotation``)
OPTIONS: dict = {"gradient_correction": "quadratic", "rest_support": 1.5, "rotation": "moment",
                 "clamp": "particles"}
#: the elasticity model (``--method``) and the multiple of the explicit step it runs with
#: (``--dt-factor``; an implicit model may exceed 1)
#: (``--static N``: N backward Euler steps of omega_1 dt = 1e4 for the sag, peer2018)
MODEL: dict = {"method": "becker2009", "dt_factor": 1.0, "static": 0}


def _scene(dim: int, start: list[float], end: list[float], r: float, E: float, nu: float,
           gravity: float, alpha: float) -> Scene:
    g = [0.0] * dim
    g[1] = -gravity
    return Scene.model_validate({
        "name": "cantilever",
        "configuration": {"dim": dim, "particle_radius": r, "gravity": g,
                          "pressure": {"method": "wcsph", "stiffness": 0.0},
                          "time": {"cfl": False,
                                   "dt": MODEL["dt_factor"] * _time_step(r, E, nu),
                                   "dt_min": 1e-7}, "zsort_every": 0},
        "materials": [{"id": "solid", "density0": RHO,
                       "elasticity": {"method": MODEL["method"], "youngs_modulus": E,
                                      "poisson_ratio": nu, "alpha": alpha, **OPTIONS,
                                      "fixed_boxes": [{"min": [-1.0] * dim,
                                                       "max": [0.0] + [1.0] * (dim - 1)}]}}],
        "fluid_blocks": [{"start": start, "end": end, "material": "solid"}],
    })


def sag(layers: int, alpha: float, L: float = 1.0, h: float = 0.1, E: float = 3e8,
        nu: float = 0.3) -> dict:
    """The 3D cantilever under gravity (module docstring)."""
    r = h / (2 * layers)
    scene = _scene(3, [-6 * r, 0.0, 0.0], [L, h, h], r, E, nu, G, alpha)
    if MODEL["static"]:
        # backward Euler with omega_1 dt = 1e4 and the velocities zeroed after each step: a
        # Newton step on the static equilibrium (the inertia 1e-8 of the stiffness); the
        # solve to 1e-10, however many CG iterations that takes
        omega_est = KL ** 2 * math.sqrt(E * h ** 4 / 12.0 / (RHO * h * h * L ** 4))
        scene.configuration.time.dt = 1e4 / omega_est
        scene.materials[0].elasticity.max_iterations = 100000
        scene.materials[0].elasticity.max_error = 1e-10
    sim = Simulation(scene)
    f = sim.fluid
    dt = sim.scene.configuration.time.dt
    x0 = f["solid_x0"]
    free = x0[0] > 0.0
    q = f["m"][free].sum() * G / L
    inertia = h ** 4 / 12.0
    w_eb = q * L ** 4 / (8 * E * inertia)
    w_timo = w_eb + q * L ** 2 / (2 * (5 / 6) * E / (2 * (1 + nu)) * h * h)
    # the same at the tip particles' own x (the last layer's centres, L - r): like with like
    xt = float(np.mean(x0[0, x0[0] > L - 2 * r]))
    w_eb_x = q / (24 * E * inertia) * (xt ** 4 - 4 * L * xt ** 3 + 6 * L ** 2 * xt ** 2)
    w_timo_x = w_eb_x + q * (L * xt - xt ** 2 / 2) / ((5 / 6) * E / (2 * (1 + nu)) * h * h)
    omega = KL ** 2 * math.sqrt(E * inertia / (q / G * L ** 4))
    c = 2.0 * omega
    steps = MODEL["static"] or int(math.ceil(12.0 / omega / dt))
    tip_sel = x0[0] > L - 2 * r
    history = []
    t0 = time.perf_counter()
    for k in range(steps):
        sim.step()
        f["v"] *= 0.0 if MODEL["static"] else math.exp(-c * dt)
        if k % 50 == 0 or k == steps - 1 or MODEL["static"]:
            tip = f["solid_x0"][0] > L - 2 * r
            history.append(float(np.mean(f["solid_x0"][1, tip] - f["x"][1, tip])))
    wall = time.perf_counter() - t0
    w = history[-1]
    ref = history[-max(2, len(history) // 10)]
    return {"layers": layers, "r": r, "n": f.n, "steps": steps, "dt": dt, "alpha": alpha,
            "w": w, "w_eb": w_eb, "w_timo": w_timo, "err_eb": w / w_eb - 1.0,
            "err_timo": w / w_timo - 1.0, "w_eb_x": w_eb_x, "err_eb_x": w / w_eb_x - 1.0,
            "err_timo_x": w / w_timo_x - 1.0, "change": abs(w - ref) / abs(w), "wall": wall,
            "tip_particles": int(tip_sel.sum()), "factor": _factor(sim)}


def _factor(sim: Simulation) -> str:
    """kugelstadt2021: its factorisations' unknowns, time and memory; kee2023: its solver's
    iterations in the last step; other models: ''."""
    solve = getattr(sim.solids[0], "solve_stats", None)
    if solve:
        return ", ".join(f"{k} {v:.3g}" for k, v in solve.items()) + " (last step)"
    stats = getattr(sim.solids[0], "factor_stats", [])
    cg_stats = getattr(sim.solids[0], "stats", None)
    if not stats and cg_stats is not None:
        return (f"CG {cg_stats.iterations} iterations, relative residual "
                f"{cg_stats.residual:.1e} (last step)")
    return "; ".join(f"factorised {s['n']:.0f} unknowns, {s['nnz']:.0f} nonzeros -> "
                     f"{s['factor_nnz']:.0f} in the factor, {s['bytes'] / 1e6:.2f} MB, "
                     f"{s['seconds']:.3f} s" for s in stats)


def _mode_shape(x: np.ndarray, L: float) -> np.ndarray:
    k = KL / L
    s = (math.cosh(KL) + math.cos(KL)) / (math.sinh(KL) + math.sin(KL))
    return np.cosh(k * x) - np.cos(k * x) - s * (np.sinh(k * x) - np.sin(k * x))


def mode(layers: int, alpha: float, L: float = 0.2, H: float = 0.02, E: float = 2e6,
         nu: float = 0.3375, tip_speed: float = 0.05) -> dict:
    """The 2D clamped plate's first mode (module docstring)."""
    r = H / (2 * layers)
    sim = Simulation(_scene(2, [-6 * r, -H / 2], [L, H / 2], r, E, nu, 0.0, alpha))
    f = sim.fluid
    dt = sim.scene.configuration.time.dt
    x0 = f["solid_x0"]
    free = x0[0] > 0.0
    f["v"][1, free] = tip_speed * _mode_shape(x0[0, free], L) / _mode_shape(np.array([L]), L)
    e_plane = E / (1 - nu * nu)
    omega = KL ** 2 / L ** 2 * math.sqrt(e_plane * H ** 2 / (12 * RHO))
    period = 2 * math.pi / omega
    steps = int(math.ceil(2.3 * period / dt))
    tip = x0[0] > L - 2 * r
    ts, ys = [], []
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
        ts.append(sim.time)
        ys.append(float(np.mean(f["x"][1, tip] - x0[1, tip])))
    wall = time.perf_counter() - t0
    ys_a, ts_a = np.array(ys), np.array(ts)
    cross = np.flatnonzero((ys_a[:-1] > 0) & (ys_a[1:] <= 0))  # downward zero crossings
    tc = ts_a[cross] - ys_a[cross] * (ts_a[cross + 1] - ts_a[cross]) / (ys_a[cross + 1]
                                                                        - ys_a[cross])
    measured = float(np.mean(np.diff(tc))) if tc.size >= 2 else float("nan")
    return {"layers": layers, "r": r, "n": f.n, "steps": steps, "dt": dt, "alpha": alpha,
            "period": measured, "period_eb": period, "err": period / measured - 1.0
            if measured == measured else float("nan"),
            "amplitude": float(np.abs(ys_a).max()), "wall": wall, "factor": _factor(sim)}


def _level(x: np.ndarray, y: np.ndarray, lo: float, hi: float, r: float) -> float:
    """The mean over the columns (width 2r) of ``[lo, hi)`` of the highest particle's y plus r
    (the free surface)."""
    cols = np.floor((x - lo) / (2 * r)).astype(np.int64)
    ok = (x >= lo) & (x < hi)
    tops = np.full(int(round((hi - lo) / (2 * r))) + 1, -np.inf)
    np.maximum.at(tops, cols[ok], y[ok])
    return float(np.mean(tops[np.isfinite(tops)])) + r


def floating(layers: int, ratio: float = 0.5, until: float = 3.0, H: float = 0.1,
             E: float = 1e6, viscosity: float = 0.0, dt_max: float = 0.002,
             alpha: float = 0.1) -> dict:
    """The floating block (module docstring): ``layers`` particles across its height."""
    r = H / (2 * layers)
    s = 2 * r
    W, D = 6 * H, 2.5 * H
    bw = 2 * H
    x0 = round((W - bw) / 2 / s) * s  # on the water's lattice columns
    d0 = max(1, round(ratio * H / 2 / s)) * s  # released at half Archimedes' depth
    y0 = D - d0
    water = [([0.0, 0.0], [W, y0]), ([0.0, y0], [x0, D]), ([x0 + bw, y0], [W, D])]
    scene = Scene.model_validate({
        "name": "floating block",
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -G],
                          "pressure": {"method": "dfsph"},
                          "time": {"until": until, "dt_max": dt_max}},
        "materials": [{"id": "water", "density0": RHO,
                       "viscosity": {"method": "standard" if viscosity else "none",
                                     "coefficient": viscosity}},
                      {"id": "block", "density0": ratio * RHO,
                       "elasticity": {"method": MODEL["method"], "youngs_modulus": E,
                                      "poisson_ratio": 0.3, "alpha": alpha, **OPTIONS}}],
        "fluid_blocks": [{"start": a, "end": b, "material": "water"} for a, b in water]
        + [{"start": [x0, y0], "end": [x0 + bw, y0 + H], "material": "block"}],
        "boxes": [{"min": [0.0, 0.0], "max": [W, 2.5 * D]}]})
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # DFSPH's convergence warnings of the first steps
        sim = Simulation(scene)
        f = sim.fluid
        block = f["solid_slot"] >= 0
        mass = float(f["m"][block].sum())
        rest = f["solid_x0"][:, block]
        width = float(np.ptp(rest[0])) + s
        below = float(rest[1].mean() - rest[1].min()) + r  # centroid above the bottom face
        d_arch = mass / (RHO * width)
        depths, angles = [], []
        t0 = time.perf_counter()
        while sim.time < until - 1e-9:
            sim.step()
            if sim.time >= until / 2:
                block = f["solid_slot"] >= 0
                x, y = f["x"]
                level = 0.5 * (_level(x[~block], y[~block], 0.0, 1.5 * H, r)
                               + _level(x[~block], y[~block], W - 1.5 * H, W, r))
                depths.append(level - (float(y[block].mean()) - below))
                e = f["solid_x0"][:, block] - f["solid_x0"][:, block].mean(axis=1)[:, None]
                d = f["x"][:, block] - f["x"][:, block].mean(axis=1)[:, None]
                angles.append(math.degrees(math.atan2(float((e[0] * d[1] - e[1] * d[0]).sum()),
                                                      float((e * d).sum()))))
        wall = time.perf_counter() - t0
    d = np.array(depths)
    return {"layers": layers, "r": r, "n": f.n, "steps": sim.step_count, "d": float(d.mean()),
            "swing": float(d.max() - d.min()), "d_arch": d_arch, "err": d.mean() / d_arch - 1,
            "tilt": float(np.abs(angles).max()), "finite": bool(np.isfinite(f["x"]).all()),
            "wall": wall}


def _cap_depth(volume: float, R: float) -> float:
    """The depth d of the spherical cap of radius R whose volume ``pi d^2 (3R - d) / 3`` is
    ``volume`` (bisection; 0 <= d <= 2R)."""
    lo, hi = 0.0, 2.0 * R
    for _ in range(100):
        d = 0.5 * (lo + hi)
        lo, hi = (d, hi) if math.pi * d * d * (3 * R - d) / 3 < volume else (lo, d)
    return 0.5 * (lo + hi)


def floating_ball(layers: int, ratio: float = 0.5, until: float = 2.0, D: float = 0.1,
                  E: float = 1e6, viscosity: float = 0.0, dt_max: float = 0.002,
                  alpha: float = 0.1) -> dict:
    """3D: an elastic ball (diameter D, ``layers`` particles across, E 1 MPa, alpha 0.1,
    density ``ratio`` x water) released at rest half as deep as Archimedes' depth in DFSPH
    water 1.5 D deep in a tank 3 D x 3 D (module docstring, ``float``). The ball is the
    lattice points within D/2 of its centre, the water the lattice points of the tank outside
    D/2 + r of it, both written to particle files; the depth is the water level (the highest
    particle plus r per lattice column, averaged over the columns farther than D from the
    ball's axis) minus the ball's bottom (its centroid less its equivalent radius, that of a
    sphere of the particles' lattice volume); Archimedes: the cap of that sphere whose volume
    is the ball's mass over the water's density."""
    import tempfile

    import meshio

    r = D / (2 * layers)
    s = 2 * r
    W, depth = 3 * D, 1.5 * D
    R = D / 2
    nx, ny = round(W / s), round(depth / s)
    grid = (np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nx), indexing="ij"),
                     axis=-1).reshape(-1, 3) + 0.5) * s
    c_xz = np.array([W / 2, W / 2])
    # the ball: a lattice of spacing 2r symmetric about its centre, the points within R
    k = np.arange(layers) - (layers - 1) / 2
    local = np.stack(np.meshgrid(k, k, k, indexing="ij"), axis=-1).reshape(-1, 3) * s
    local = local[np.linalg.norm(local, axis=1) <= R]
    v_ball = len(local) * s ** 3
    R_eq = (3 * v_ball / (4 * math.pi)) ** (1 / 3)
    d_arch = _cap_depth(ratio * v_ball, R_eq)
    centre = np.array([W / 2, depth - 0.5 * d_arch + R_eq, W / 2])  # half Archimedes' depth
    ball = local + centre
    water = grid[np.linalg.norm(grid - centre, axis=1) > R + r]
    tmp = tempfile.mkdtemp(prefix="sphkit_float3d_")
    files = []
    for name, pts in (("water", water), ("ball", ball)):
        path = f"{tmp}/{name}.vtk"
        meshio.write_points_cells(path, pts, [("vertex", np.arange(len(pts))[:, None])])
        files.append({"file": path, "material": name})
    scene = Scene.model_validate({
        "name": "floating ball",
        "configuration": {"dim": 3, "particle_radius": r, "gravity": [0.0, -G, 0.0],
                          "pressure": {"method": "dfsph"},
                          "time": {"until": until, "dt_max": dt_max}},
        "materials": [{"id": "water", "density0": RHO,
                       "viscosity": {"method": "standard" if viscosity else "none",
                                     "coefficient": viscosity}},
                      {"id": "ball", "density0": ratio * RHO,
                       "elasticity": {"method": MODEL["method"], "youngs_modulus": E,
                                      "poisson_ratio": 0.3, "alpha": alpha, **OPTIONS}}],
        "fluid_files": files,
        "boxes": [{"min": [0.0, 0.0, 0.0], "max": [W, 2.5 * depth, W]}]})
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # DFSPH's convergence warnings of the first steps
        sim = Simulation(scene)
        f = sim.fluid
        block = f["solid_slot"] >= 0
        mass = float(f["m"][block].sum())
        d_arch = _cap_depth(mass / RHO, R_eq)
        depths, speeds = [], []
        t0 = time.perf_counter()
        while sim.time < until - 1e-9:
            sim.step()
            if sim.time >= until / 2:
                block = f["solid_slot"] >= 0
                x = f["x"]
                wx = x[:, ~block]
                far = np.hypot(wx[0] - c_xz[0], wx[2] - c_xz[1]) > D
                cols = (np.floor(wx[0, far] / s) * nx + np.floor(wx[2, far] / s)).astype(
                    np.int64)
                tops = np.full(nx * nx + nx + 1, -np.inf)
                np.maximum.at(tops, np.clip(cols, 0, tops.size - 1), wx[1, far])
                level = float(np.mean(tops[np.isfinite(tops)])) + r
                depths.append(level - (float(x[1, block].mean()) - R_eq))
                speeds.append(float(np.abs(f["v"][:, block]).max()))
        wall = time.perf_counter() - t0
    d = np.array(depths)
    return {"layers": layers, "r": r, "n": f.n, "steps": sim.step_count, "d": float(d.mean()),
            "swing": float(d.max() - d.min()), "d_arch": d_arch, "err": d.mean() / d_arch - 1,
            "tilt": float(max(speeds)), "finite": bool(np.isfinite(f["x"]).all()),
            "wall": wall}


def sheet(layers: int = 4, water: bool = True, L: float = 0.4, H: float = 0.04,
          depth: float = 0.1, E: float = 1e7, nu: float = 0.3, until: float = 1.0,
          damping: float = 20.0, dt_max: float = 0.002) -> dict:
    """2D: an elastic sheet (thickness H, ``layers`` particles across, density 1000, E, nu;
    plane strain) spanning a tank wall to wall, clamped over three particle columns at each
    end (free span L), with water ``depth`` deep poured on it (DFSPH; ``water=False``: no
    water, the sheet's density raised by the water's weight per area instead, the dead-load
    twin of the same discretisation). All velocities are damped by ``exp(-damping dt)`` per
    step (a static state is sought; damping does not change it). The sheet's midspan
    deflection (the mean over its middle column) after ``until`` s against Euler-Bernoulli's
    clamped-clamped ``w = q L^4 / (384 E' I)``, ``E' = E / (1 - nu^2)``, ``I = H^3 / 12``,
    ``q`` the weight per length of water and sheet."""
    import warnings

    r = H / (2 * layers)
    s = 2 * r
    clamp = 3 * s
    Lt = L + 2 * clamp
    y0 = 0.1
    rho_s = RHO if water else RHO * (1.0 + depth / H)
    blocks = [{"start": [0.0, y0], "end": [Lt, y0 + H], "material": "sheet"}]
    if water:
        blocks.append({"start": [0.0, y0 + H], "end": [Lt, y0 + H + depth],
                       "material": "water"})
    scene = Scene.model_validate({
        "name": "sheet under water",
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -G],
                          "pressure": {"method": "dfsph"},
                          "time": {"until": until, "dt_max": dt_max}},
        "materials": [{"id": "water", "density0": RHO},
                      {"id": "sheet", "density0": rho_s,
                       "elasticity": {"method": MODEL["method"], "youngs_modulus": E,
                                      "poisson_ratio": nu, "alpha": 0.0, **OPTIONS,
                                      "fixed_boxes": [{"min": [-1.0, -1.0],
                                                       "max": [clamp, 1.0]},
                                                      {"min": [Lt - clamp, -1.0],
                                                       "max": [Lt + 1.0, 1.0]}]}}],
        "fluid_blocks": blocks,
        "boxes": [{"min": [0.0, 0.0], "max": [Lt, y0 + H + 3 * depth]}]})
    e_plane = E / (1 - nu * nu)
    q = G * (RHO * depth + RHO * H)  # water and sheet per length (the dead-load twin: same)
    w_eb = q * L ** 4 / (384 * e_plane * H ** 3 / 12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(scene)
        f = sim.fluid
        hist = []
        t0 = time.perf_counter()
        while sim.time < until - 1e-9:
            sim.step()
            f["v"] *= math.exp(-damping * sim.dt)
            mine = f["solid_slot"] >= 0
            x0 = f["solid_x0"][:, mine]
            mid = np.abs(x0[0] - Lt / 2) < r + 1e-9 * r
            if not mid.any():
                mid = np.abs(x0[0] - Lt / 2) < s
            hist.append((sim.time, float(np.mean(x0[1, mid] - f["x"][1, mine][mid]))))
        wall = time.perf_counter() - t0
    t, w = np.array(hist).T
    late = t >= 0.9 * until
    return {"layers": layers, "r": r, "n": f.n, "steps": sim.step_count, "w": float(w[-1]),
            "w_eb": w_eb, "err": float(w[-1]) / w_eb - 1.0, "max": float(w.max()),
            "change": float(np.ptp(w[late]) / abs(w[-1])), "wall": wall,
            "water": water, "finite": bool(np.isfinite(f["x"]).all())}


def main() -> None:
    """Run the cases and print the tables."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=("sag", "mode", "both", "float", "sheet"),
                    default="both")
    ap.add_argument("--layers", type=int, nargs="+", default=[4, 6, 8],
                    help="particles across the thickness")
    ap.add_argument("--alpha", type=float, nargs="+", default=[0.0, 0.1],
                    help="zero-energy-mode control factors")
    ap.add_argument("--gradient", choices=("none", "linear", "quadratic"), default="quadratic",
                    help="elasticity.gradient_correction")
    ap.add_argument("--support", type=float, default=1.5, help="elasticity.rest_support")
    ap.add_argument("--rotation", choices=("moment", "gradient"), default="moment",
                    help="elasticity.rotation (becker2009, peer2018)")
    ap.add_argument("--clamp", choices=("particles", "face"), default="particles",
                    help="elasticity.clamp: the pinned particles in the elastic sums")
    ap.add_argument("--method", choices=("becker2009", "peer2018", "kugelstadt2021", "kee2023"),
                    default="becker2009")
    ap.add_argument("--solver", choices=("newton", "lbfgs"), default="newton",
                    help="kee2023: the minimiser")
    ap.add_argument("--material-model", choices=("corotated", "stable_neo_hookean"),
                    default="corotated", help="kee2023: the energy density")
    ap.add_argument("--max-change", type=float, default=1e-6,
                    help="kee2023: max_position_change [m], the minimisation's stopping "
                    "tolerance (SPlisHSPlasH's maxError default 1e-6)")
    ap.add_argument("--dt-factor", type=float, default=1.0,
                    help="time step as a multiple of the explicit bound 0.4 * 2r / c")
    ap.add_argument("--static", type=int, default=0, metavar="N",
                    help="sag, peer2018: the static state by N backward Euler steps "
                    "of omega_1 dt = 1e4, velocities zeroed after each (Newton steps)")
    ap.add_argument("--sag-length", type=float, default=1.0,
                    help="sag: the free length L [m]; E is scaled by L^4 (3e8 Pa at 1 m) so "
                    "that Euler-Bernoulli's deflection stays 4.9 mm (small deflection)")
    ap.add_argument("--density", type=float, default=0.5,
                    help="float: the block's density as a multiple of the water's")
    ap.add_argument("--dim", type=int, choices=(2, 3), default=2,
                    help="float: 2 (a block) or 3 (a ball)")
    ap.add_argument("--float-time", type=float, default=3.0, help="float: simulated time [s]")
    ap.add_argument("--float-viscosity", type=float, default=0.0,
                    help="float: the water's kinematic viscosity (standard) [m^2/s]")
    ap.add_argument("--float-alpha", type=float, default=0.1,
                    help="float: the solid's zero-energy-mode control factor")
    ap.add_argument("--float-dt-max", type=float, default=0.002,
                    help="float: the largest (CFL) time step [s]")
    a = ap.parse_args()
    OPTIONS.update(gradient_correction=a.gradient, rest_support=a.support, rotation=a.rotation,
                   clamp=a.clamp)
    if a.method == "kee2023":
        OPTIONS.update(solver=a.solver, material_model=a.material_model,
                       max_position_change=a.max_change)
    if a.static and a.method != "peer2018":
        ap.error("--static needs --method peer2018 (becker2009 is explicit; kugelstadt2021's "
                 "static state depends on its step, kee2023's Newton caps its CG at "
                 "cg_max_iterations)")
    MODEL.update(method=a.method, dt_factor=a.dt_factor, static=a.static)
    print(f"{a.method}, dt {a.dt_factor:g} x explicit bound, gradient {a.gradient}, "
          f"clamp {a.clamp}, rest support {a.support:g} h, rotation {a.rotation}"
          + (f", {a.solver}, {a.material_model}, max change {a.max_change:g} m"
             if a.method == "kee2023" else ""))
    if a.case in ("sag", "both"):
        print(f"3D cantilever under gravity (L {a.sag_length:g} m, section 0.1 m, E "
              f"{3e8 * a.sag_length ** 4 / 1e6:g} MPa, nu 0.3)")
        print("| layers | r [m] | particles | alpha | steps | w [mm] | EB [mm] | w/EB - 1 | "
              "w/Timoshenko - 1 | EB at L - r [mm] | w/EB(L - r) - 1 | w/Timoshenko(L - r) - 1 "
              "| last change | wall [s] |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for n in a.layers:
            for al in a.alpha:
                s = sag(n, al, L=a.sag_length, E=3e8 * a.sag_length ** 4)
                print(f"| {n} | {s['r']:.5f} | {s['n']} | {al:g} | {s['steps']} | "
                      f"{1e3 * s['w']:.3f} | {1e3 * s['w_eb']:.3f} | {100 * s['err_eb']:+.1f} % "
                      f"| {100 * s['err_timo']:+.1f} % | {1e3 * s['w_eb_x']:.3f} | "
                      f"{100 * s['err_eb_x']:+.1f} % | {100 * s['err_timo_x']:+.1f} % | "
                      f"{s['change']:.1e} | {s['wall']:.0f} |",
                      flush=True)
                if s["factor"]:
                    print("  ", s["factor"], flush=True)
    if a.case in ("mode", "both"):
        print("2D clamped plate, first mode (Gray et al. 2001: L 0.2 m, H 0.02 m, E 2 MPa, "
              "nu 0.3375, plane strain)")
        print("| layers | r [m] | particles | alpha | steps | period [s] | EB [s] | "
              "omega/omega_EB - 1 | tip amplitude [mm] | wall [s] |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for n in a.layers:
            for al in a.alpha:
                m = mode(n, al)
                print(f"| {n} | {m['r']:.5f} | {m['n']} | {al:g} | {m['steps']} | "
                      f"{m['period']:.4f} | {m['period_eb']:.4f} | {100 * m['err']:+.1f} % | "
                      f"{1e3 * m['amplitude']:.2f} | {m['wall']:.0f} |", flush=True)
                if m["factor"]:
                    print("  ", m["factor"], flush=True)
    if a.case == "sheet":
        print(f"2D sheet (span 0.4 m, H 0.04 m, E 10 MPa, nu 0.3, clamped at both ends) under "
              f"water 0.1 m deep (DFSPH) or the same dead load; {a.float_time:g} s, "
              "velocities damped at 20 1/s")
        print("| layers | r [m] | load | particles | steps | midspan w [mm] | EB [mm] | "
              "w/EB - 1 | largest w [mm] | last 10 % swing | wall [s] |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for n in a.layers:
            for wet in (True, False):
                sh = sheet(n, wet, until=a.float_time, dt_max=a.float_dt_max)
                print(f"| {n} | {sh['r']:.5f} | {'water' if wet else 'dead load'} | "
                      f"{sh['n']} | {sh['steps']} | {1e3 * sh['w']:.3f} | "
                      f"{1e3 * sh['w_eb']:.3f} | {100 * sh['err']:+.1f} % | "
                      f"{1e3 * sh['max']:.3f} | {sh['change']:.1e} | {sh['wall']:.0f} |"
                      + ("" if sh["finite"] else " NaN"), flush=True)
    if a.case == "float":
        body, run, last, fmt = (
            ("3D ball (D 0.1 m", floating_ball, "ball's max speed [m/s]", ".3f") if a.dim == 3
            else ("2D block (H 0.1 m, width 0.2 m", floating, "max tilt [deg]", ".1f"))
        print(f"{body}, E 1 MPa) floating in DFSPH water (viscosity "
              f"{a.float_viscosity:g} m^2/s), density {a.density:g} x water, "
              f"{a.float_time:g} s, dt_max {a.float_dt_max:g} s, depth averaged over the "
              "second half")
        print("| layers | r [m] | particles | steps | depth [mm] | swing [mm] | Archimedes [mm] "
              f"| depth/Archimedes - 1 | {last} | wall [s] |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for n in a.layers:
            fl = run(n, a.density, a.float_time, viscosity=a.float_viscosity,
                     dt_max=a.float_dt_max, alpha=a.float_alpha)
            print(f"| {n} | {fl['r']:.5f} | {fl['n']} | {fl['steps']} | {1e3 * fl['d']:.2f} | "
                  f"{1e3 * fl['swing']:.2f} | {1e3 * fl['d_arch']:.2f} | "
                  f"{100 * fl['err']:+.1f} % | {fl['tilt']:{fmt}} | {fl['wall']:.0f} |"
                  + ("" if fl["finite"] else " NaN"), flush=True)

if __name__ == "__main__":
    main()
