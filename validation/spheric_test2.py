"""SPHERIC Test 2: 3D dam break with a box on the floor (Kleefsman et al. 2005), water heights
and the pressures on the box.

MARIN's experiment (Kleefsman, Fekken, Veldman, Iwanowski & Buchner 2005, J. Comput. Phys.
206, 363-393): a tank 3.22 m long, 1 m wide, 1 m high; water 1.228 m long and 0.55 m deep at
its far end (x > 1.992 m) is released at t = 0 and hits a box 0.161 x 0.403 x 0.161 m on the
floor (0.6635 <= x <= 0.8245 m, across the tank's middle). References
(``validation/data/kleefsman2005_marin_heights.csv`` and ``kleefsman2005_marin_pressure.csv``,
which name their sources and which rows they hold): the water heights at four vertical gauges
on the tank's centre line, x = 0.496 (in the box's lee), 0.992, 1.488 and 2.638 m (in the
reservoir), and the pressures at the eight sensors on the box, P1-P4 on the face the water hits
(0.021, 0.061, 0.101, 0.141 m above the floor), P5-P8 on the top (0.021-0.141 m behind that
face), all 0.176 m from one side of the box (the SPHERIC Test 2 description's Fig. 7).

Scene (sphkit axes: y up, z across, the tank's centre line at z = 0.5 m): rho0 = 1000 kg/m^3, nu
= 1e-6 m^2/s (standard viscosity), g = 9.81, DFSPH (``--solver``), a closed box of Akinci
particles (two layers) and the box as a static mesh (surface-sampled Akinci particles), wall
pressures solved in the PPE (``configuration.boundary.solved``: the default MLS walls pumped
energy into 3D flows, validation/README.md "Dam break in 3D"), free-slip, cubic spline h = 4r,
CFL step (dt_max 4 ms), no settling. Height at a gauge: along the vertical line at the gauge,
the highest point where the fluid's kernel sum ``sum_j V_j W`` (a Shepard fluid fraction: 1
inside, about 0.5 at a free surface) is at least 0.5, sampled every r/2 (the analogue of the VOF
fraction 0.5 that Lethe's post-processing uses); a layer thinner than about h/2 reads 0.
Pressure at a sensor: the Shepard average of the fluid pressure at the sensor's point on the
box's surface (``validation/_probes.py``, as ``dam_break_impact.py``), after every step, 0 while
the kernel sum there is below :data:`WET`. Measures per sensor, for the runs as for the
experiment (less each sensor's offset while dry): the first impact's peak (0.35 <= t <= 0.6 s)
raw and of a 10 ms running mean, their times, the arrival (first p > 500 Pa) and the mean over
0.1 s from it (the impact's impulse without its timing), the rms of p less its running mean over
0.5-1 s (the noise), the means over the windows :data:`P_WINDOWS`.

Run ``python validation/spheric_test2.py`` (``--r 0.025``, ``--t-end 2``, ``--solver dfsph``:
another pressure solver with its defaults, its plots then suffixed by its name). Prints the heights
at the tabulated times and the mean |h_sim - h_exp| per gauge over t <= t_end, the pressure
table, and saves ``validation/spheric_test2.png`` (heights) and ``spheric_test2_pressure.png``
when matplotlib is installed.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from _plotting import pyplot
from _probes import Probe, window_mean

from sphkit.core.kernels import Kernel
from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

G = 9.81
RHO0 = 1000.0
NU = 1e-6
TANK = (3.22, 1.0, 1.0)  # length x, height y, width z [m]
WATER = (1.992, 0.55)  # water from x = 1.992 m to the far wall, 0.55 m deep
BOX = ((0.6635, 0.0, 0.2985), (0.8245, 0.161, 0.7015))  # the obstacle, sphkit axes
GAUGES = (0.496, 0.992, 1.488, 2.638)  # x of the height gauges [m], at z = 0.5
DATA = Path(__file__).resolve().parent / "data" / "kleefsman2005_marin_heights.csv"
COLUMNS = {0.496: "h_x0496", 0.992: "h_x0992", 1.488: "h_x1488", 2.638: "h_x2638"}
P_DATA = DATA.with_name("kleefsman2005_marin_pressure.csv")
#: the pressure sensors (SPHERIC Test 2 description, Fig. 7): P1-P4 on the face the water hits
#: (x = 0.8245) 0.021-0.141 m above the floor, P5-P8 on the top 0.021-0.141 m behind that face,
#: all 0.176 m from one side of the box
SENSOR_Z = BOX[0][2] + 0.176
SENSORS = np.array([[BOX[1][0], y, SENSOR_Z] for y in (0.021, 0.061, 0.101, 0.141)]
                   + [[BOX[1][0] - d, BOX[1][1], SENSOR_Z] for d in (0.021, 0.061, 0.101, 0.141)])
#: least sum_j V_j W at a sensor for it to read the fluid: a point on the box's face under water
#: reaches only 0.05-0.12 here (medians over 0.5-0.7 s at r = 0.015-0.03 m), against about 0.5
#: on dam_break_impact.py's walls, whose threshold 0.1 would read this face dry most of the time
WET = 0.01
DRY = 0.35  # the experiment's sensors are dry before this [s]: their offsets are the means here
FIRST = (0.35, 0.6)  # the first impact's peak on the face is looked for here [s]
SMOOTH = 0.01  # running mean [s] for the smoothed peaks (the SPH step is 2-4 ms)
PLOT_SMOOTH = 0.02  # the plot's running mean [s]: the SPH pressures scatter by 0.4-0.8 kPa
ARRIVE = 500.0  # arrival: first p above this [Pa] (5 cm of water; 20x the dry sensors' rms)
P_WINDOWS = ((0.38, 0.5), (0.5, 0.7), (0.7, 1.0), (1.0, 1.5), (1.5, 2.0))  # mean p [s]
LOADED = 0.1  # the mean over this long from the arrival [s]: the impact without its timing
SCATTER = (0.5, 1.0)  # rms of p less its running mean over this window [s]: the noise


def experiment() -> tuple[np.ndarray, dict[float, np.ndarray]]:
    """t and the heights per gauge x from ``validation/data``."""
    rows = [s for s in DATA.read_text().splitlines() if s and not s.startswith("#")]
    head = rows[0].split(",")
    d = np.array([[float(v) for v in s.split(",")] for s in rows[1:]])
    return d[:, 0], {x: d[:, head.index(c)] for x, c in COLUMNS.items()}


def pressure_experiment() -> tuple[np.ndarray, np.ndarray]:
    """t and P1..P8 [Pa], (8, n), from ``validation/data``, each less its mean while dry
    (t < :data:`DRY`: the record is not zeroed)."""
    rows = [s for s in P_DATA.read_text().splitlines() if s and not s.startswith("#")]
    d = np.array([[float(v) for v in s.split(",")] for s in rows[1:]])
    t, p = d[:, 0], d[:, 1:].T
    return t, p - p[:, t < DRY].mean(axis=1, keepdims=True)


def running_mean(t: np.ndarray, p: np.ndarray, window: float = SMOOTH) -> np.ndarray:
    """Mean of p over [t - w/2, t + w/2] at each t, from the integral of its piecewise-linear
    interpolant (irregular samples: the SPH steps)."""
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(t))])
    lo, hi = np.clip(t - 0.5 * window, t[0], t[-1]), np.clip(t + 0.5 * window, t[0], t[-1])
    return (np.interp(hi, t, integral) - np.interp(lo, t, integral)) / np.maximum(hi - lo, 1e-12)


def pressure_measures(t: np.ndarray, p: np.ndarray) -> list[dict]:
    """Per sensor: the peak within :data:`FIRST` and its time, raw and of the
    :data:`SMOOTH` running mean; the arrival (first p > :data:`ARRIVE`) and the mean over
    :data:`LOADED` from it; the rms of p less its running mean over :data:`SCATTER`; the means
    over :data:`P_WINDOWS` (NaN where the series ends earlier or the sensor stays dry)."""
    out = []
    sel = (t >= FIRST[0]) & (t <= FIRST[1])
    sc = (t >= SCATTER[0]) & (t <= SCATTER[1])
    for q in p:
        qs = running_mean(t, q)
        if sel.any():
            k, ks = np.argmax(q[sel]), np.argmax(qs[sel])
            peaks = {"peak": float(q[sel][k]), "t_peak": float(t[sel][k]),
                     "peak_s": float(qs[sel][ks]), "t_peak_s": float(t[sel][ks])}
        else:
            peaks = dict.fromkeys(("peak", "t_peak", "peak_s", "t_peak_s"), math.nan)
        arrival = float(t[np.argmax(q > ARRIVE)]) if (q > ARRIVE).any() else math.nan
        out.append({**peaks, "arrival": arrival,
                    "loaded": (window_mean(t, q, arrival, arrival + LOADED)
                               if arrival == arrival else math.nan),
                    "scatter": (float(np.sqrt(np.mean((q - qs)[sc] ** 2))) if sc.sum() > 2
                                else math.nan),
                    "means": [window_mean(t, q, a, b) for a, b in P_WINDOWS]})
    return out


def _box_obj(folder: Path) -> Path:
    import trimesh

    box = trimesh.creation.box(bounds=[list(BOX[0]), list(BOX[1])])
    path = folder / "obstacle.obj"
    box.export(path)
    return path


def scene(r: float, folder: Path, solver: str = "dfsph") -> Scene:
    """The tank, water and box of the module docstring with particle radius ``r``; ``solver``:
    the pressure solver (its defaults; WCSPH's stiffness SPlisHSPlasH's 50,000 Pa)."""
    data = {
        "name": "spheric-test2",
        "configuration": {
            "dim": 3, "particle_radius": r, "gravity": [0.0, -G, 0.0],
            "pressure": {"method": solver},
            "time": {"dt": 1e-4, "dt_min": 1e-7, "dt_max": 4e-3},
            "boundary": {"solved": True},
            "start": {"settle": False},
        },
        "materials": [{"density0": RHO0, "viscosity": {"method": "standard", "coefficient": NU}}],
        "fluid_blocks": [{"start": [WATER[0], 0.0, 0.0], "end": [TANK[0], WATER[1], TANK[2]]}],
        "boxes": [{"min": [0.0, 0.0, 0.0], "max": list(TANK), "layers": 2}],
        "meshes": [{"geometry_file": str(_box_obj(folder))}],
    }
    return Scene.model_validate(data)


class Gauges:
    """Water height along vertical lines (module docstring)."""

    def __init__(self, sim: Simulation) -> None:
        st = sim.state
        self.kernel = Kernel(st.kid, st.h, 3)
        self.h = st.h
        self.ys = np.arange(0.0, TANK[1], 0.5 * st.r)

    def __call__(self, sim: Simulation) -> np.ndarray:
        f = sim.fluid
        x = np.asarray(f["x"])
        V = np.asarray(f["m"]) / np.asarray(f["rho"])
        out = []
        for xg in GAUGES:
            near = (np.abs(x[0] - xg) < self.h) & (np.abs(x[2] - 0.5 * TANK[2]) < self.h)
            if not near.any():
                out.append(0.0)
                continue
            dx = (x[0, near] - xg) ** 2 + (x[2, near] - 0.5 * TANK[2]) ** 2
            r = np.sqrt(dx[None, :] + (self.ys[:, None] - x[1, near][None, :]) ** 2)
            s = (self.kernel.w(r) * V[near][None, :]).sum(axis=1)
            wet = np.nonzero(s >= 0.5)[0]
            out.append(float(self.ys[wet[-1]]) if len(wet) else 0.0)
        return np.array(out)


def run(sim: Simulation, t_end: float, every: float = 0.01) -> dict:
    """Step to t_end; the gauges every ``every`` seconds (at the first step past each), the
    pressure sensors (:class:`_probes.Probe` at :data:`SENSORS`, on the box's surface) after
    every step."""
    g, probe = Gauges(sim), Probe(SENSORS, sim, wet=WET)
    ts, hs = [0.0], [g(sim)]
    tp, ps = [0.0], [probe(sim)]
    nxt = every
    while sim.time < t_end:
        sim.step()
        tp.append(sim.time)
        ps.append(probe(sim))
        if sim.time >= nxt:
            ts.append(sim.time)
            hs.append(g(sim))
            nxt += every
    return {"t": np.array(ts), "h": np.array(hs).T, "tp": np.array(tp), "p": np.array(ps).T,
            "steps": sim.step_count, "n": sim.fluid.n}


def gauge_errors(o: dict, te: np.ndarray, he: dict[float, np.ndarray]) -> np.ndarray:
    """``|h_sim - h_exp|`` [m] (gauges, rows) at the experiment's rows ``te`` up to the run's
    end: the run's heights (:func:`run`'s ``o``) interpolated to those times."""
    keep = te <= o["t"][-1]
    return np.array([np.abs(np.interp(te[keep], o["t"], o["h"][i]) - he[x][keep])
                     for i, x in enumerate(GAUGES)])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--r", type=float, nargs="+", default=[0.025], help="particle radii [m]")
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--solver", default="dfsph",
                    choices=["dfsph", "iisph", "pcisph", "pbf", "wcsph"],
                    help="pressure solver (default dfsph)")
    ap.add_argument("--save", type=Path, help="write the runs' gauges to this .npz")
    ap.add_argument("--load", type=Path, nargs="*", default=[],
                    help="print and plot runs saved with --save (runs nothing)")
    args = ap.parse_args(argv)
    logging.getLogger("sphkit").setLevel(logging.ERROR)
    te, he = experiment()
    results: dict = {}
    loaded: dict = {}
    for path in args.load:
        with np.load(path) as d:
            for name in d.files:
                r, f = name.split("|")
                loaded.setdefault(float(r), {})[f] = d[name]
    with tempfile.TemporaryDirectory() as tmp:
        for r in sorted(loaded) if args.load else args.r:
            if args.load:
                o = loaded[r]
                o["n"], o["steps"], o["wall"] = (int(o["info"][0]), int(o["info"][1]),
                                                 float(o["info"][2]))
            else:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    sim = Simulation(scene(r, Path(tmp), args.solver))
                t0 = time.perf_counter()
                o = run(sim, args.t_end)
                o["wall"] = time.perf_counter() - t0
                o["info"] = np.array([o["n"], o["steps"], o["wall"]])
            results[r] = o
            if args.save:
                np.savez_compressed(args.save, **{f"{q}|{f}": v[f] for q, v in results.items()
                                                  for f in ("t", "h", "tp", "p", "info") if f in v})
            print(f"{args.solver}, r = {r} m: {o['n']} fluid particles, {o['steps']} steps, "
                  f"{o['wall']:.0f} s")
            keep = te <= o["t"][-1]
            print(f"{'t':>6s}" + "".join(f"{'x=' + str(x):>16s}" for x in GAUGES)
                  + "   (sim / exp [m])")
            for k in np.nonzero(keep)[0]:
                print(f"{te[k]:6.3f}" + "".join(
                    f"{np.interp(te[k], o['t'], o['h'][i]):8.3f}/{he[x][k]:.3f}"
                    for i, x in enumerate(GAUGES)))
            err = gauge_errors(o, te, he).mean(axis=1)
            print("mean |h_sim - h_exp| [m]: " + ", ".join(
                f"x = {x}: {e:.3f}" for x, e in zip(GAUGES, err, strict=True)), flush=True)
    tpe, pe = pressure_experiment()
    for line in pressure_table(results, tpe, pe):
        print(line)
    _plot(results, te, he, args.solver)
    _plot_pressure(results, tpe, pe, args.solver)
    return 0


def pressure_table(results: dict, tpe: np.ndarray, pe: np.ndarray) -> list[str]:
    """Per sensor, the experiment's measures and each run's (runs saved without pressures are
    left out)."""
    w = " ".join(f"{a:g}-{b:g}" for a, b in P_WINDOWS)
    lines = [f"pressures [Pa] at P1-P8: first-impact peak ({FIRST[0]:g} <= t <= {FIRST[1]:g} s) "
             f"raw and of the {SMOOTH * 1e3:g} ms running mean, their t [s]; arrival (first p > "
             f"{ARRIVE:g} Pa) [s] and the mean over {LOADED:g} s from it; scatter: rms of p less "
             f"its running mean over {SCATTER[0]:g}-{SCATTER[1]:g} s; means over t = {w} s",
             f"{'series':10s}{'s':>2s}{'peak':>7s}{'t':>7s}{'peak_s':>7s}{'t':>7s}{'arrive':>7s}"
             f"{'loaded':>7s}{'scatter':>8s}"
             + "".join(f"{f'{a:g}-{b:g}':>9s}" for a, b in P_WINDOWS)]
    series = [("MARIN", tpe, pe)] + [(f"r = {r}", o["tp"], o["p"])
                                     for r, o in sorted(results.items()) if "p" in o]
    for k in range(len(SENSORS)):
        for name, t, p in series:
            m = pressure_measures(t, p[k : k + 1])[0]
            lines.append(f"{name:10s}{k + 1:2d}{m['peak']:7.0f}{m['t_peak']:7.3f}"
                         f"{m['peak_s']:7.0f}{m['t_peak_s']:7.3f}{m['arrival']:7.3f}"
                         f"{m['loaded']:7.0f}{m['scatter']:8.0f}"
                         + "".join(f"{v:9.0f}" for v in m["means"]))
    return lines


def _plot(results: dict, te: np.ndarray, he: dict, solver: str = "dfsph") -> None:
    plt = pyplot()
    if plt is None:
        return
    fig, axes = plt.subplots(2, 2, figsize=(12, 7))
    for i, (x, ax) in enumerate(zip(GAUGES, axes.ravel(), strict=True)):
        ax.plot(te, he[x], "ko", ms=3, label="MARIN (Kleefsman 2005)")
        for r, o in results.items():
            ax.plot(o["t"], o["h"][i], lw=1, label=f"{solver.upper()} r = {r} m")
        ax.set_title(f"gauge at x = {x} m", fontsize=9)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("h [m]")
        if i == 0:
            ax.legend(fontsize=7)
    path = Path(__file__).with_name(f"spheric_test2{_suffix(solver)}.png")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    print(f"plot: {path}")


def _suffix(solver: str) -> str:
    """The plots' file-name suffix: none for DFSPH (the committed plots), else the solver's."""
    return "" if solver == "dfsph" else f"_{solver}"


def _plot_pressure(results: dict, tpe: np.ndarray, pe: np.ndarray, solver: str = "dfsph"
                   ) -> None:
    plt = pyplot()
    if plt is None or not any("p" in o for o in results.values()):
        return
    fig, axes = plt.subplots(2, 4, figsize=(18, 7))
    for k, ax in enumerate(axes.ravel()):
        ax.plot(tpe, pe[k], "-", color="0.7", lw=0.5, label="MARIN (Kleefsman 2005)")
        ax.plot(tpe, running_mean(tpe, pe[k], PLOT_SMOOTH), "k-", lw=1,
                label=f"MARIN, {PLOT_SMOOTH * 1e3:g} ms mean")
        for r, o in sorted(results.items()):
            if "p" in o:
                ax.plot(o["tp"], running_mean(o["tp"], o["p"][k], PLOT_SMOOTH), lw=1,
                        label=f"{solver.upper()} r = {r} m, {PLOT_SMOOTH * 1e3:g} ms mean")
        x, y, _ = SENSORS[k]
        face = f"front, {y:.3f} m up" if k < 4 else f"top, {BOX[1][0] - x:.3f} m behind the front"
        ax.set_title(f"P{k + 1} ({face})", fontsize=9)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("p [Pa]")
        ax.set_xlim(0.3, 2.0)
        if k == 0:
            ax.legend(fontsize=7)
    fig.tight_layout()
    path = Path(__file__).with_name(f"spheric_test2_pressure{_suffix(solver)}.png")
    fig.savefig(path, dpi=90, bbox_inches="tight")
    print(f"plot: {path}")


if __name__ == "__main__":
    sys.exit(main())
