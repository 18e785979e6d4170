"""Scenes as users write them: fluid blocks up to the walls, in SPlisHSPlasH's format, for every
pressure solver and every boundary model (sphkit.world.startup).

    python validation/startup.py [--dim 3] [--radius 0.015] [--until 3] [--solvers ...]
                                 [--boundaries ...] [--cases dambreak float column]
                                 [--before 0.3]

1. ``dambreak``: a tank (benchmarks/scenes/UnitBox.obj scaled to 0.8 x 0.6 x 0.4 m, floor at
   y = 0, ``mapInvert``) with a fluid block of 0.3 x 0.3 m (across the tank's depth in 3D)
   written from the floor and 0.2 r off the left, front and back walls -- SPlisHSPlasH puts the
   first particle 2r inside a block, so the fluid starts 2.2 r off the walls and 2 r off the
   floor. ``float``: the same tank filled to 0.24 m from wall to wall (0.2 r off each), with a
   cube of side 0.12 m and density 500 (a dynamic ``RigidBodies`` entry) placed 30 %
   submerged off centre; the fluid inside it is removed at the start. For every solver
   (``simulationMethod`` 0-4; WCSPH with stiffness 50,000) and boundary model
   (``boundaryHandlingMethod`` 0-2), each scene runs to ``--until`` (3 s) with the start-up on
   (the default): the table gives the particles removed at the start, the first step's
   iterations, whether its solve converged and its density error (average / max), the largest
   speed, whether the run stayed stable, how many particles left the tank (outside the tank's
   inner box by more than 0.1 r), the body's submerged fraction averaged over the last second
   (counted on a grid of points in the rotated cube below the free surface: the top layer of the
   fluid away from the body, plus r) and the wall time. ``--before T`` (default 0.3 s) also
   runs the dam break with the start-up off (``configuration.start``: ``relax`` and
   ``hydrostatic`` false, the behaviour before it) for T seconds: its first step and whether it
   stayed stable.
2. ``column``: the 2D column at rest of the issue -- SPlisHSPlasH format, WCSPH with stiffness
   50,000, Akinci walls from UnitBox.obj scaled to a 0.6 m wide tank, water 0.5 m deep from wall
   to wall and from the floor (r = 1 cm), to ``--until``: the least-squares slope of the
   particle pressures over height (middle 80 % of the column) per frame (25 frames/s) as a
   multiple of rho0 g, its range over the frames after 1 s and its mean, the mean particle
   speed after 1 s and the range of the column's top; with the start-up on (with and without
   its settling, ``start.settle``) and off.

Results in validation/README.md ("Start-up: fluid at the walls, hydrostatic start").
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from sphkit.scene.files import load_scene
from sphkit.scene.schema import SceneError
from sphkit.simulation import InstabilityError, Simulation

UNIT_BOX = Path(__file__).resolve().parent.parent / "benchmarks" / "scenes" / "UnitBox.obj"
SOLVERS = {"wcsph": 0, "pcisph": 1, "pbf": 2, "iisph": 3, "dfsph": 4}
BOUNDARIES = {"akinci2012": 0, "koschier2017": 1, "bender2019": 2}
TANK = (0.8, 0.6, 0.4)  # width, height, depth [m]
DAM = (0.3, 0.3)  # width, height [m]
POOL, SIDE, DRAFT0 = 0.24, 0.12, 0.3  # water depth, cube side [m], start submerged fraction
GAP = 0.2  # the blocks' distance from the side walls [r]
BODY_MAP = 10  # the floating body's map cells per axis (SPlisHSPlasH's default is 20)


def splishsplash_scene(folder: Path, case: str, solver: str, boundary: str, dim: int, r: float,
                       until: float, tank=TANK, fluid=None) -> Path:
    """A SPlisHSPlasH scene file of the case in ``folder`` (UnitBox.obj copied beside it)."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(UNIT_BOX, folder / "UnitBox.obj")
    w, hgt, d = tank
    d = d if dim == 3 else 1.0
    z = [-d / 2 + GAP * r, d / 2 - GAP * r] if dim == 3 else [-0.5, 0.5]
    if case == "float":
        start, end = [-w / 2 + GAP * r, 0.0, z[0]], [w / 2 - GAP * r, POOL, z[1]]
    else:
        fw, fh = fluid or DAM
        start, end = [-w / 2 + GAP * r, 0.0, z[0]], [-w / 2 + fw, fh, z[1]]
    cfg = {"particleRadius": r, "simulationMethod": SOLVERS[solver],
           "boundaryHandlingMethod": BOUNDARIES[boundary], "gravitation": [0, -9.81, 0],
           "timeStepSize": 0.001, "cflMethod": 1, "cflFactor": 1, "cflMaxTimeStepSize": 0.005,
           "stopAt": until, "WCSPH": {"stiffness": 50000, "exponent": 7}}
    if dim == 2:
        cfg["sim2D"] = True
    bodies = [{"geometryFile": "UnitBox.obj", "translation": [0, hgt / 2, 0],
               "scale": [w, hgt, d], "isDynamic": False, "isWall": True, "mapInvert": True,
               "mapThickness": 0.0, "mapResolution": [20, 15, 10 if dim == 3 else 1]}]
    if case == "float":
        bodies.append({"geometryFile": "UnitBox.obj",
                       "translation": [0.1, POOL - DRAFT0 * SIDE + SIDE / 2, 0],
                       "scale": [SIDE, SIDE, SIDE if dim == 3 else 1.0], "isDynamic": True,
                       "density": 500, "mapInvert": False,
                       "mapResolution": [BODY_MAP, BODY_MAP, BODY_MAP if dim == 3 else 1]})
    scene = {"Configuration": cfg,
             "Materials": [{"id": "Fluid", "density0": 1000, "viscosityMethod": 1,
                            "Standard viscosity": {"viscosity": 0.01}}],
             "RigidBodies": bodies,
             "FluidBlocks": [{"denseMode": 0, "start": start, "end": end}]}
    path = folder / "scene.json"
    path.write_text(json.dumps(scene, indent=1))
    return path


def _load(path: Path, start: bool, settle: bool = True):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_scene(path)
        if not start:
            scene.configuration.start.relax = False
            scene.configuration.start.hydrostatic = False
        if not settle:
            scene.configuration.start.settle = False
        sim = Simulation(scene)
    return sim, [str(w.message) for w in caught if "removed" in str(w.message)]


def _outside(x: np.ndarray, dim: int, r: float, tank=TANK) -> int:
    w, hgt, d = tank
    out = (x[:, 0] < -w / 2 - 0.1 * r) | (x[:, 0] > w / 2 + 0.1 * r) | (x[:, 1] < -0.1 * r)
    if dim == 3:
        out |= (x[:, 2] < -d / 2 - 0.1 * r) | (x[:, 2] > d / 2 + 0.1 * r)
    return int(out.sum())


def far_from_body(x: np.ndarray, c: np.ndarray, side: float, dim: int) -> np.ndarray:
    """The fluid particles farther than ``side`` from a body centred at ``c`` horizontally."""
    far = np.abs(x[0] - c[0]) > side
    if dim == 3:
        far |= np.abs(x[2] - c[2]) > side
    return far


def water_level(x: np.ndarray, far: np.ndarray, r: float, layers: float) -> float:
    """The pool's free surface: the mean height of the top layer (the highest 1/``layers`` of
    the particles ``far``, see :func:`far_from_body`) plus r."""
    yy = np.sort(x[1, far])
    return float(yy[-max(int(len(yy) / layers), 1):].mean() + r)


def run(folder: Path, case: str, solver: str, boundary: str, dim: int, r: float, until: float,
        start: bool = True) -> dict:
    """One run of a matrix case; returns its row."""
    path = splishsplash_scene(folder / f"{case}-{solver}-{boundary}", case, solver, boundary,
                              dim, r, until)
    t0 = time.time()
    try:
        sim, removed = _load(path, start)
    except SceneError as e:  # a combination sphkit refuses (PF with a dynamic body)
        return {"case": case, "solver": solver, "boundary": boundary, "refused": str(e)}
    build = time.time() - t0
    row = {"case": case, "solver": solver, "boundary": boundary, "n": sim.fluid.n,
           "removed": sum(sim.world.start.removed_inside.values())
           + sum(sim.world.start.removed_close.values()),
           "relax": sim.world.start.relax_iterations, "build": build, "status": "stable",
           "vmax": 0.0, "fraction": None}
    body = sim.rigid.bodies[0] if sim.rigid.bodies else None
    if body is not None:
        g = (np.arange(24) + 0.5) / 24 * SIDE - SIDE / 2
        gz = g if dim == 3 else [0.0]
        grid = np.stack(np.meshgrid(g, g, gz, indexing="ij")).reshape(3, -1)
    layers = POOL / (2 * r)
    frac = []
    t0 = time.time()
    try:
        while sim.time < until - 1e-9:
            st = sim.step()
            if st.step == 1:
                ps = sim.last_solver
                row.update(its=st.iterations, converged=bool(ps.converged),
                           err=(st.density_error_avg, st.density_error_max))
            row["vmax"] = max(row["vmax"], st.max_velocity)
            if body is not None and sim.time > until - 1.0:
                x = sim.fluid["x"]
                level = water_level(x, far_from_body(x, body.c, SIDE, dim), r, layers)
                frac.append(float(np.mean((body.c[:, None] + body.R @ grid)[1] < level)))
    except InstabilityError as e:
        row["status"] = f"unstable at {e.stats.time:.3g} s ({e.stats.max_velocity:.3g} m/s)"
        if "its" not in row:
            row.update(its=e.stats.iterations, converged=False,
                       err=(e.stats.density_error_avg, e.stats.density_error_max))
    row["wall"] = time.time() - t0
    row["time"] = sim.time
    row["outside"] = _outside(sim.positions, dim, r)
    row["fraction"] = float(np.mean(frac)) if frac else None
    return row


def column(folder: Path, until: float, start: bool, settle: bool = True) -> dict:
    """The 2D WCSPH column at rest (module docstring, item 2); ``settle``: the start-up's
    settling (``start.settle``, "auto" or off)."""
    r, w, hgt = 0.01, 0.6, 0.5
    path = splishsplash_scene(folder / f"column-{int(start)}", "dambreak", "wcsph",
                              "akinci2012", 2, r, until, tank=(w, hgt + 0.2, 1.0),
                              fluid=(w - GAP * r, hgt))
    sim, _ = _load(path, start, settle)
    rows = []

    def frame(s: Simulation, _k: int) -> None:
        y, p = s.positions[:, 1], s.pressures
        lo, top = y.min(), y.max()
        m = (y > lo + 0.1 * (top - lo)) & (y < lo + 0.9 * (top - lo))
        slope = -np.polyfit(y[m], p[m], 1)[0] / (1000.0 * 9.81)
        rows.append((s.time, slope, top, float(np.linalg.norm(s.velocities, axis=1).mean())))

    t0 = time.time()
    sim.run(until=until, fps=25, on_frame=frame)
    a = np.array(rows)
    late = a[a[:, 0] > 1.0 - 1e-9]
    return {"start": start, "settle": sim.world.start.settle_steps, "n": sim.fluid.n,
            "frames": len(late),
            "lo": late[:, 1].min(), "hi": late[:, 1].max(), "mean": late[:, 1].mean(),
            "within3": float(np.mean(np.abs(late[:, 1] - 1.0) <= 0.03)),
            "speed": late[:, 3].mean(), "top": (a[:, 2].min(), a[:, 2].max()),
            "t0": a[0, 1], "wall": time.time() - t0, "series": a}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=3, choices=[2, 3])
    ap.add_argument("--radius", type=float, default=None,
                    help="particle radius [m] (default 0.015 in 3D, 0.01 in 2D)")
    ap.add_argument("--until", type=float, default=3.0)
    ap.add_argument("--solvers", nargs="+", default=list(SOLVERS), choices=list(SOLVERS))
    ap.add_argument("--boundaries", nargs="+", default=list(BOUNDARIES),
                    choices=list(BOUNDARIES))
    ap.add_argument("--cases", nargs="+", default=["dambreak", "float", "column"],
                    choices=["dambreak", "float", "column"])
    ap.add_argument("--before", type=float, default=0.3,
                    help="run the dam break this long with the start-up off (0: not at all)")
    args = ap.parse_args()
    r = args.radius or (0.015 if args.dim == 3 else 0.01)
    folder = Path(tempfile.mkdtemp(prefix="sphkit-startup-"))
    matrix = [c for c in args.cases if c != "column"]
    if matrix:
        print(f"{args.dim}D, r = {r} m, {args.until} s; first step: iterations, converged, "
              "density error avg / max")
        print("| case | solver | boundary | particles (removed) | relax sweeps | first step | "
              "max speed [m/s] | run | outside | submerged | wall [s] |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
    for case in matrix:
        for solver in args.solvers:
            for boundary in args.boundaries:
                for start in ([True, False] if case == "dambreak" and args.before > 0
                              else [True]):
                    until = args.until if start else args.before
                    row = run(folder, case, solver, boundary, args.dim, r, until, start)
                    if "refused" in row:
                        print(f"| {case} | {solver} | {boundary} | refused: {row['refused']} |"
                              + " |" * 7, flush=True)
                        continue
                    e = row["err"]
                    first = (f"{row['its']}, {'yes' if row['converged'] else 'no'}, "
                             f"{100 * e[0]:.3g} / {100 * e[1]:.3g} %")
                    frac = "-" if row["fraction"] is None else f"{100 * row['fraction']:.1f} %"
                    label = case if start else f"{case} (start-up off, {until:g} s)"
                    print(f"| {label} | {solver} | {boundary} | {row['n']} ({row['removed']}) | "
                          f"{row['relax']} | {first} | {row['vmax']:.3g} | {row['status']} | "
                          f"{row['outside']} | {frac} | {row['wall']:.1f} |", flush=True)
    if "column" in args.cases:
        print("\n2D WCSPH column (stiffness 50,000, Akinci walls from UnitBox.obj, 0.6 x 0.5 m, "
              f"r = 1 cm), frames after 1 s of {args.until} s:")
        print("| start-up | settling steps | particles | slope at t = 0 | slope min / mean / "
              "max | frames within 3 % | mean speed [m/s] | top range [m] | wall [s] |")
        print("|---|---|---|---|---|---|---|---|---|")
        for start, settle in ((True, True), (True, False), (False, False)):
            c = column(folder, args.until, start, settle)
            label = ("on" if start else "off") + (", settle off" if start and not settle else "")
            print(f"| {label} | {c['settle']} | {c['n']} | {c['t0']:.3f} | {c['lo']:.3f} / "
                  f"{c['mean']:.3f} / {c['hi']:.3f} | {100 * c['within3']:.0f} % of "
                  f"{c['frames']} | {c['speed']:.4f} | {c['top'][0]:.4f} - {c['top'][1]:.4f} | "
                  f"{c['wall']:.1f} |", flush=True)


if __name__ == "__main__":
    main()
