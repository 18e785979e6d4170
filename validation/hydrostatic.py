"""Hydrostatic column study: pressure slope of every pressure solver and boundary model, with the
mirrored and the accurate boundary pressure; a dam break as sanity check of the same settings.

    python validation/hydrostatic.py [--dim 2|3] [--scenes splishsplash boxes]
        [--solvers wcsph pcisph pbf iisph dfsph] [--boundaries akinci2012 koschier2017 bender2019]
        [--boundary-pressure mirror accurate] [--until 2.5] [--average 1.0] [--gap 3] [--radius R]
        [--map-resolution N]
        [--widths 0.6] [--eta E] [--dt-max T] [--lattice square hexagonal] [--dambreak]

Each row is one water column at rest, 0.5 m high in 2D (r = 1 cm), 0.4 m in 3D (r = 2 cm;
``--radius`` changes r, not the sizes), in a tank W wide (``--widths``, default 0.6 m), written
two ways (``--scenes``):

* ``splishsplash``: a SPlisHSPlasH JSON scene translated by sphkit, with SPlisHSPlasH's default
  settings (no solver block: maxError 0.01 %, 100 iterations, CFL factor 0.5, dt at most
  5 ms; WCSPH with the stiffness 50,000 of its shipped scenes), standard viscosity 0.01 as its
  shipped scenes set it, walls from ``benchmarks/scenes/UnitBox.obj`` as its scenes write them
  (a ``RigidBodies`` entry with ``isWall``, ``mapInvert``; ``boundaryHandlingMethod`` 0, 1, 2 for
  akinci2012, koschier2017, bender2019) and the fluid block drawn from the walls and shifted by
  r like ``DamBreakModel_2D.json`` (its first particle sits ``--gap`` r = 3 r off the walls; 2:
  the block drawn from the walls unshifted);
* ``boxes``: sphkit's own scene with sphkit's defaults (``boxes`` walls: two layers of lattice
  particles for akinci2012, a signed distance for the maps), the block 2r inside the box.

``--eta`` and ``--dt-max`` override the solvers' ``max_error`` [%] and ``time.dt_max`` [s] of
both kinds (the defaults are the scenes' own). Boundary pressure (``--boundary-pressure``):
``mirror`` (``configuration.boundary.pressure: "mirror"``) and ``accurate`` -- MLS extrapolation
(Band et al. 2018, ``"mls"``) for boundary particles, the hydrostatic wall pressure
(``"hydrostatic"``) for maps; ``default`` runs whatever the scene resolves to when it names none.
PBF has no boundary pressure term: its ``mls`` rows measure only that the option does not hurt.

Each column runs to ``--until`` (2.5 s); the table gives the least-squares slope of pressure over
height in the middle 80 % of the column as a multiple of rho0 g (1 is exact), from the pressures
and heights averaged per particle over the last ``--average`` (1.0) s; the same slope of the
particles at least 3r from the side walls ("inner"); the slope of every step in that window fitted
to that step's pressures (mean, standard deviation, range: the per-step value swings where a
solver stops at its iteration limit or the column still moves); the range of the slope frame by
frame (25 frames/s) from 1 s on; "wall": how much more pressure the particles within 3r of a
side wall carry than the inner ones at the same height, in % of rho0 g H (the mean deviation
from rho0 g (top + r - y) over the middle 80 %; a wall that carries none of the weight of the
fluid beside it shows up here); iterations and wall time per step; mean speed at the end.

``--dambreak``: SPlisHSPlasH's ``DamBreakModel_2D.json`` (2D) or ``DamBreakModel.json`` (3D, r =
0.04 m to keep it short) from the pysplishsplash wheel, with the solver, boundary model and
boundary pressure of each row (vorticity off): whether it runs to 2 s, the front (largest x of
a particle) at 0.2, 0.3 and 0.4 s, the largest speed, iterations and wall time per step.

Older results (validation/README.md) were taken with ``--scenes boxes --boundaries akinci2012
--eta 0.05 --dt-max 0.002 --widths 0.3 0.6 --until 2.0 --average 0.5`` and WCSPH stiffness 1e5.
With matplotlib installed, ``validation/hydrostatic.png`` shows pressure against depth.
"""

from __future__ import annotations

import argparse
import itertools
import json
import logging
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from _plotting import pyplot

from sphkit import registry
from sphkit.scene.schema import Scene
from sphkit.scene.splishsplash import from_splishsplash
from sphkit.simulation import Simulation

G = 9.81
RHO0 = 1000.0
ROOT = Path(__file__).resolve().parent.parent
UNIT_BOX = ROOT / "benchmarks" / "scenes" / "UnitBox.obj"
SOLVERS = ("wcsph", "pcisph", "pbf", "iisph", "dfsph")
BOUNDARIES = ("akinci2012", "koschier2017", "bender2019")
#: SPlisHSPlasH's simulationMethod and boundaryHandlingMethod numbers of sphkit's methods
SIM_NUMBER = {m.name: m.splishsplash for m in registry.methods("pressure")}
BHM_NUMBER = {m.name: m.splishsplash for m in registry.methods("boundary")}


def accurate(boundary: str) -> str:
    """The accurate boundary pressure of a boundary model: MLS for particles, hydrostatic for
    maps."""
    return "mls" if registry.get("boundary", boundary).kind == "particles" else "hydrostatic"


#: floating-point type of the runs (``--precision``) and of their pair cache (``--pair-cache``)
PRECISION = "float64"
PAIR_CACHE = "auto"


def _set_pressure(scene: Scene, bp: str, cache: str, eta: float | None,
                  dt_max: float | None) -> Scene:
    d = scene.model_dump()
    cfg = d["configuration"]
    cfg["precision"] = PRECISION
    cfg["pair_cache"] = PAIR_CACHE
    cfg["boundary"]["map_cache_dir"] = cache
    if bp != "default":
        cfg["boundary"]["pressure"] = bp
    else:
        cfg["boundary"].pop("pressure", None)
    if eta is not None:
        cfg["pressure"]["max_error"] = eta
    if dt_max is not None:
        cfg["time"]["dt_max"] = dt_max
    return Scene.model_validate(d)


def splishsplash_column(method: str, boundary: str, dim: int, width: float,
                        gap: float = 3.0, radius: float | None = None,
                        map_resolution: int | None = None) -> dict:
    """The column as a SPlisHSPlasH scene (dict), default settings, UnitBox.obj walls
    (``map_resolution``: the walls' ``mapResolution`` cells per axis; None: SPlisHSPlasH's
    default, 20)."""
    r = radius or (0.01 if dim == 2 else 0.02)
    hgt = 0.5 if dim == 2 else 0.4
    cfg: dict = {"sim2D": dim == 2, "particleRadius": r, "simulationMethod": SIM_NUMBER[method],
                 "boundaryHandlingMethod": BHM_NUMBER[boundary], "gravitation": [0, -G, 0]}
    if method == "wcsph":
        cfg["WCSPH"] = {"stiffness": 50000.0, "exponent": 7}
    s = (gap - 2.0) * r  # SPlisHSPlasH puts the first particle 2r inside the block
    wall: dict = {"geometryFile": str(UNIT_BOX), "translation": [0, 0.4, 0],
                  "rotationAxis": [1, 0, 0], "rotationAngle": 0,
                  "scale": [width, 0.8, width if dim == 3 else 1.0],
                  "isDynamic": False, "isWall": True, "mapInvert": True, "mapThickness": 0.0}
    if map_resolution is not None:
        wall["mapResolution"] = [map_resolution] * 3
    return {
        "Configuration": cfg,
        "Materials": [{"id": "Fluid", "density0": RHO0, "viscosityMethod": 1,
                       "Standard viscosity": {"viscosity": 0.01}}],
        "RigidBodies": [wall],
        "FluidBlocks": [{"denseMode": 0, "start": [-width / 2, 0.0, -width / 2],
                         "end": [width / 2 - 2 * s, hgt, width / 2 - 2 * s],
                         "translation": [s, s, s if dim == 3 else 0.0]}],
    }


def boxes_column(method: str, boundary: str, dim: int, width: float,
                 lattice: str = "square", radius: float | None = None) -> Scene:
    """The column in sphkit's format: block 2r off the side walls, ``boxes`` walls."""
    r = radius or (0.01 if dim == 2 else 0.02)
    hgt = 0.5 if dim == 2 else 0.4
    gap = 2 * r
    return Scene.model_validate({
        "configuration": {"dim": dim, "particle_radius": r, "gravity": [0.0, -G, 0.0][:dim],
                          "pressure": {"method": method}, "boundary": {"method": boundary}},
        "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": [gap, 0.0, gap][:dim],
                          "end": [width - gap, hgt, width - gap][:dim], "lattice": lattice}],
        "boxes": [{"min": [0.0] * dim, "max": [width, hgt + 0.1, width][:dim], "layers": 2}],
    })


def column(kind: str, method: str, boundary: str, bp: str, dim: int, width: float, cache: str,
           eta: float | None = None, dt_max: float | None = None, lattice: str = "square",
           gap: float = 3.0, radius: float | None = None,
           map_resolution: int | None = None) -> Scene:
    """One column scene (see the module docstring)."""
    if kind == "splishsplash":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scene = from_splishsplash(splishsplash_column(method, boundary, dim, width, gap,
                                                          radius, map_resolution))
    else:
        scene = boxes_column(method, boundary, dim, width, lattice, radius)
    return _set_pressure(scene, bp, cache, eta, dt_max)


def slope(y: np.ndarray, p: np.ndarray, sel: np.ndarray | None = None) -> float:
    """Least-squares dp/dy over the middle 80 % of the column height, in units of -rho0 g."""
    lo, top = y.min(), y.max()
    m = (y > lo + 0.1 * (top - lo)) & (y < lo + 0.9 * (top - lo))
    if sel is not None:
        m &= sel
    return float(-np.polyfit(y[m], p[m], 1)[0] / (RHO0 * G))


def measure(scene: Scene, until: float = 2.5, average: float = 1.0,
            frames_from: float = 1.0, fps: float = 25.0) -> dict:
    """Run the column; the statistics of the module docstring (``status`` "unstable: ..." if
    the run stopped)."""
    t0 = time.perf_counter()
    sim = Simulation(scene)
    dim, r = sim.dim, sim.state.r
    n = sim.fluid.n
    p_sum, x_sum = np.zeros(n), np.zeros((n, dim))
    steps, its, frame_slopes, walls = [], [], [], []
    start = until - average

    def on_step(s: Simulation, st) -> None:
        if s.time <= start + 1e-9:
            return
        o = s.fluid.order_by_id()
        p_sum[:] += s.pressures[o]
        x_sum[:] += s.positions[o]
        steps.append(slope(s.positions[:, 1], s.pressures))
        its.append(st.iterations)

    def on_frame(s: Simulation, k: int) -> None:
        if s.time >= frames_from - 1e-9:
            frame_slopes.append(slope(s.positions[:, 1], s.pressures))

    status = "ok"
    t_step = time.perf_counter()
    n_steps0 = sim.step_count
    try:
        sim.run(until=until, fps=fps, on_step=on_step, on_frame=on_frame)
    except Exception as e:  # InstabilityError: report it as the row
        status = "unstable: " + str(e).split(":")[0]
    walls.append((time.perf_counter() - t_step) / max(sim.step_count - n_steps0, 1))
    out = {"n": n, "status": status, "time": time.perf_counter() - t0,
           "ms_per_step": 1e3 * walls[0]}
    if status != "ok" or not steps:
        return out
    k = len(steps)
    p, x = p_sum / k, x_sum / k
    y = x[:, 1]
    hor = [0] + ([2] if dim == 3 else [])
    lo = x[:, hor].min(axis=0) - 1.0 * r
    hi = x[:, hor].max(axis=0) + 1.0 * r
    inner = np.all((x[:, hor] > lo + 3 * r) & (x[:, hor] < hi - 3 * r), axis=1)
    st = np.array(steps)
    fr = np.array(frame_slopes) if frame_slopes else np.array([np.nan])
    top = y.max()
    mid = (y > y.min() + 0.1 * (top - y.min())) & (y < y.min() + 0.9 * (top - y.min()))
    dev = (p - RHO0 * G * (top + r - y)) / (RHO0 * G * (top - y.min() + 2 * r))
    out.update({
        "slope": slope(y, p), "inner": slope(y, p, inner),
        "wall": 100 * float(dev[mid & ~inner].mean() - dev[mid & inner].mean()),
        "step_mean": float(st.mean()), "step_std": float(st.std()),
        "step_min": float(st.min()), "step_max": float(st.max()),
        "frame_min": float(fr.min()), "frame_max": float(fr.max()),
        "iterations": float(np.mean(its)),
        "vmean": float(np.linalg.norm(sim.velocities, axis=1).mean()),
        "y": y, "p": p, "x": x,
    })
    return out


def dambreak(method: str, boundary: str, bp: str, dim: int, cache: str,
             until: float = 2.0) -> dict:
    """SPlisHSPlasH's dam break of the wheel with this solver, boundary model and pressure."""
    from sphkit.scene.splishsplash import wheel

    path = wheel.scene_file("DamBreakModel_2D.json" if dim == 2 else "DamBreakModel.json")
    if path is None:
        raise SystemExit("the SPlisHSPlasH scenes need the pysplishsplash wheel")
    data = json.loads(path.read_text())
    c = data["Configuration"]
    c["simulationMethod"] = SIM_NUMBER[method]
    c["boundaryHandlingMethod"] = BHM_NUMBER[boundary]
    if dim == 3:
        c["particleRadius"] = 0.04
    if method == "wcsph":
        c["WCSPH"] = {"stiffness": 50000.0}
    data["Materials"][0]["vorticityMethod"] = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = from_splishsplash(data, path=path)
    scene = _set_pressure(scene, bp, cache, None, None)
    t0 = time.perf_counter()
    sim = Simulation(scene)
    front: dict[float, float] = {}
    vmax, its = [0.0], []

    def on_frame(s: Simulation, k: int) -> None:
        for t in (0.2, 0.3, 0.4):
            if abs(s.time - t) < 1e-6 or (t not in front and s.time > t):
                front[t] = float(s.positions[:, 0].max())

    def on_step(s: Simulation, st) -> None:
        vmax[0] = max(vmax[0], st.max_velocity)
        its.append(st.iterations)

    status = "ok"
    try:
        sim.run(until=until, fps=10, on_frame=on_frame, on_step=on_step)
    except Exception as e:
        status = f"unstable at t = {sim.time:.3f} s"
        logging.getLogger(__name__).debug("%s", e)
    wall = time.perf_counter() - t0
    return {"n": sim.fluid.n, "status": status, "front": front, "vmax": vmax[0],
            "iterations": float(np.mean(its)) if its else float("nan"),
            "ms_per_step": 1e3 * wall / max(sim.step_count, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=2, choices=[2, 3])
    ap.add_argument("--scenes", nargs="+", default=["splishsplash", "boxes"],
                    choices=["splishsplash", "boxes"])
    ap.add_argument("--solvers", nargs="+", default=list(SOLVERS), choices=SOLVERS)
    ap.add_argument("--boundaries", nargs="+", default=list(BOUNDARIES), choices=BOUNDARIES)
    ap.add_argument("--boundary-pressure", nargs="+", default=["mirror", "accurate"],
                    choices=["mirror", "accurate", "default"],
                    help="mirror, the accurate one of each boundary model (mls / hydrostatic), "
                    "or the scene's default")
    ap.add_argument("--widths", type=float, nargs="+", default=[0.6])
    ap.add_argument("--until", type=float, default=2.5, help="simulated time [s]")
    ap.add_argument("--average", type=float, default=1.0,
                    help="averaging window at the end [s]")
    ap.add_argument("--radius", type=float, default=None,
                    help="particle radius r [m] (default 0.01 in 2D, 0.02 in 3D)")
    ap.add_argument("--gap", type=float, default=3.0,
                    help="splishsplash: distance of the first particle from the walls [r]")
    ap.add_argument("--map-resolution", type=int, default=None,
                    help="splishsplash: the walls' mapResolution, cells per axis (maps only; "
                    "default SPlisHSPlasH's 20)")
    ap.add_argument("--eta", type=float, default=None,
                    help="max_error [%%] of the iterative solvers (default: the scene's)")
    ap.add_argument("--dt-max", type=float, default=None,
                    help="time.dt_max [s] (default: the scene's)")
    ap.add_argument("--lattice", nargs="+", default=["square"], choices=["square", "hexagonal"],
                    help="boxes: fluid_blocks[].lattice (hexagonal is 2D only)")
    ap.add_argument("--dambreak", action="store_true",
                    help="run the dam break of each row instead of the column")
    ap.add_argument("--precision", choices=("float64", "float32"), default="float64",
                    help="floating-point type of the particle fields (default float64)")
    ap.add_argument("--pair-cache", choices=("auto", "float64", "float32"), default="auto",
                    help="floating-point type of the solvers' cached pair gradients "
                    "(configuration.pair_cache; auto: float64 at these sizes)")
    args = ap.parse_args()
    global PRECISION, PAIR_CACHE
    PRECISION = args.precision
    PAIR_CACHE = args.pair_cache
    logging.disable(logging.WARNING)
    rows = []
    for b, bp in itertools.product(args.boundaries, args.boundary_pressure):
        rows.append((b, accurate(b) if bp == "accurate" else bp))
    with tempfile.TemporaryDirectory() as cache:
        if args.dambreak:
            _dambreaks(args, rows, cache)
            return
        _columns(args, rows, cache)


def _columns(args: argparse.Namespace, rows: list[tuple[str, str]], cache: str) -> None:
    print(f"Hydrostatic columns, {args.dim}D, {PRECISION}, {args.until} s, averages over the last "
          f"{args.average} s; slope / rho0 g")
    print("| scene | solver | boundary | pressure | width | n | slope | inner | per step: mean "
          "+- std [min, max] | per frame from 1 s [min, max] | wall [%] | iterations | ms/step "
          "| mean speed [m/s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    curves = []
    lattices = [lat for lat in args.lattice if lat == "square" or args.dim == 2]
    for kind, (b, bp), method, w, lat in itertools.product(
            args.scenes, rows, args.solvers, args.widths, lattices):
        if kind == "splishsplash" and lat != "square":
            continue  # SPlisHSPlasH samples blocks on the square lattice (denseMode 0)
        scene = column(kind, method, b, bp, args.dim, w, cache, args.eta, args.dt_max, lat,
                       args.gap, args.radius, args.map_resolution)
        used = scene.configuration.boundary.pressure
        res = measure(scene, args.until, args.average)
        name = f"{kind}" + (f" ({lat})" if lat != "square" else "")
        if res["status"] != "ok":
            print(f"| {name} | {method} | {b} | {used} | {w:.2f} | {res['n']} | "
                  f"{res['status']} | | | | | | | |", flush=True)
            continue
        print(f"| {name} | {method} | {b} | {used} | {w:.2f} | {res['n']} | "
              f"{res['slope']:.4f} | {res['inner']:.4f} | {res['step_mean']:.3f} +- "
              f"{res['step_std']:.3f} [{res['step_min']:.3f}, {res['step_max']:.3f}] | "
              f"[{res['frame_min']:.3f}, {res['frame_max']:.3f}] | {res['wall']:+.1f} | "
              f"{res['iterations']:.1f} | "
              f"{res['ms_per_step']:.1f} | {res['vmean']:.4f} |", flush=True)
        curves.append((f"{kind} {method} {b} {used}", res))
    _plot(curves)


def _dambreaks(args: argparse.Namespace, rows: list[tuple[str, str]], cache: str) -> None:
    print(f"SPlisHSPlasH dam break ({args.dim}D), 2 s")
    print("| solver | boundary | pressure | n | status | front at 0.2 / 0.3 / 0.4 s [m] | "
          "max speed [m/s] | iterations | ms/step |")
    print("|---|---|---|---|---|---|---|---|---|")
    for (b, bp), method in itertools.product(rows, args.solvers):
        d = dambreak(method, b, bp, args.dim, cache)
        fr = " / ".join(f"{d['front'].get(t, float('nan')):.3f}" for t in (0.2, 0.3, 0.4))
        print(f"| {method} | {b} | {bp} | {d['n']} | {d['status']} | {fr} | {d['vmax']:.1f} | "
              f"{d['iterations']:.1f} | {d['ms_per_step']:.1f} |", flush=True)


def _plot(curves: list) -> None:
    if not curves:
        return
    plt = pyplot()
    if plt is None:
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    for name, res in curves:
        depth = res["y"].max() - res["y"]
        ax.plot(depth, res["p"] / 1000.0, ".", ms=1, label=name)
    d = np.linspace(0, max(c[1]["y"].max() - c[1]["y"].min() for c in curves), 10)
    ax.plot(d, RHO0 * G * d / 1000.0, "k-", label="rho0 g depth")
    ax.set_xlabel("depth [m]")
    ax.set_ylabel("pressure [kPa]")
    ax.legend(fontsize=4)
    out = Path(__file__).with_name("hydrostatic.png" if PRECISION == "float64"
                                   else f"hydrostatic.{PRECISION}.png")
    fig.savefig(out, dpi=120, bbox_inches="tight")
    print(f"plot: {out}")


if __name__ == "__main__":
    main()
