"""Dam break: impact pressure on the downstream wall against Lobovsky et al. 2014 (H = 300 mm).

Lobovsky, Botia-Vera, Castellana, Mas-Soler & Souto-Iglesias 2014 (J. Fluids Struct. 48,
407-434): a water column H = 0.3 m high and L = 2H = 0.6 m long at the left end of a tank
1.61 m long collapses at t = 0 and hits the downstream wall (x = 1.61 m) at T = t sqrt(g/H)
of about 2.45; pressure sensors on that wall at 3, 15, 30 and 80 mm above the floor (sensors
1-4). Reference (``validation/data/lobovsky2014_h300_event5_pressure.csv``, which names its
source): the measured time histories of one event, p / (rho g H) against T. The ensemble
statistics of the paper's repetitions were not available, so the comparison is with one event.

Scene (2D, ``dim 2``; ``--dim 3`` gives the same tank 0.15 m wide, the channel of PySPH's 3D
model of the experiment, sensors on its centre line): rho0 = 1000 kg/m^3, nu = 1e-6 m^2/s
(standard viscosity), g = 9.81, box walls of Akinci particles (two layers, MLS boundary
pressure, open top, 2H high; fluid thrown over the top may leave the tank: ``domain_margin``
null), cubic spline h = 4r, CFL step, hydrostatic start; ``per_h``
particles across H (r = H / (2 per_h)). WCSPH: Tait, B = rho0 c^2 / 7 with c = 10 sqrt(2 g H)
= 24.3 m/s (Mach 0.1 against Ritter's front speed 2 sqrt(g H)), as ``dam_break.py``.

Pressure probe (``validation/_probes.py``, one per sensor, at the sensor's point on the wall
surface): the Shepard (kernel-normalised) average of the fluid pressure,
``p_s = sum_j p_j V_j W(x_s - x_j) / sum_j V_j W(x_s - x_j)``, fluid particles only, V_j =
m_j / rho_j, the simulation's kernel and support; the sensor reads 0 (dry) while
``sum_j V_j W`` < 0.1 (a full neighbourhood gives 1, a point on a wall about 0.5): the probe
of DualSPHysics' MeasureTool and TrixiParticles' interpolated pressure. Sampled after every
step. Measures per sensor: the peak of the raw series and of its 2 ms running mean (the same
mean applied to the experiment; SPH impact peaks are single-step spikes), their times T, and
the time-weighted mean over 3 <= T <= 4 (the wall loaded by the run-up, after the first
impact; the experiment's record is not evenly sampled), the first impact's impulse (the
integral of p dT over 2.3 <= T <= 3.2); at sensor 1 the arrival time (first p > 0.1 rho g H).
Sensor 4 (y = 0.267 H) is also compared with Buchner 2002's sensor P1
(``validation/data/buchner2002_p1_pressure.csv``: the same tank and column in units of H,
the same height): the means over 3-4 and 4-5.3 and the second impact's peak (T 5.3-6.5).

Run ``python validation/dam_break_impact.py`` (``--per-h 10 20 40``, ``--solvers dfsph
wcsph``, ``--t-end 7``, ``--quick``: 10 and 20 across to T = 4, ``--no-slip``: Morris et al.'s
no-slip walls, the standard viscosity's wall term with nu_b = nu). Prints the table and saves
``validation/dam_break_impact.png`` (each run's 10 ms running mean against the experiment)
when matplotlib is installed.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from _plotting import pyplot
from _probes import Probe, window_mean

from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

G = 9.81  # [m/s^2]
RHO0 = 1000.0  # [kg/m^3]
NU = 1e-6  # [m^2/s]
H = 0.3  # column height [m]
L = 0.6  # column length [m]
TANK = 1.61  # tank length [m]
WIDTH = 0.15  # tank width in 3D [m]
SENSORS = (0.003, 0.015, 0.030, 0.080)  # sensor heights on the downstream wall [m]
WINDOW = 0.002  # running mean [s]
PLOT_WINDOW = 0.01  # the plot's running mean [s]: the SPH wall pressures are spiky
PLATEAU = (3.0, 4.0)  # mean pressure window in T
IMPULSE = (2.3, 3.2)  # the first impact's pressure impulse: integral of p dT over this window
DATA = Path(__file__).resolve().parent / "data" / "lobovsky2014_h300_event5_pressure.csv"
#: Buchner 2002's sensor P1 (MARIN, H = 0.6 m, the same tank in units of H), at sensor 4's height
DATA_P1 = DATA.with_name("buchner2002_p1_pressure.csv")
#: sensor 4 (y = 0.267 H) against both experiments: the windows of its means, in T
S4_WINDOWS = ((3.0, 4.0), (4.0, 5.3))
S4_SECOND = (5.3, 6.5)  # the second impact (the plunging wave's return) is looked for here


def experiment() -> tuple[np.ndarray, np.ndarray]:
    """T and p / (rho g H) of the four sensors, (4, n), from ``validation/data``."""
    rows = [s for s in DATA.read_text().splitlines() if s and not s.startswith("#")]
    d = np.array([[float(v) for v in s.split(",")] for s in rows[1:]])
    return d[:, 0], d[:, 1:].T


def experiment_p1() -> tuple[np.ndarray, np.ndarray]:
    """T and p / (rho g H) of Buchner 2002's sensor P1 (digitised, irregular samples)."""
    rows = [s for s in DATA_P1.read_text().splitlines() if s and not s.startswith("#")]
    d = np.array([[float(v) for v in s.split(",")] for s in rows[1:]])
    return d[:, 0], d[:, 1]


def sensor4_measures(T: np.ndarray, p: np.ndarray) -> list[float]:
    """Sensor 4 / P1: the means over :data:`S4_WINDOWS`, the peak of the plot's running mean
    (:data:`PLOT_WINDOW`, the same span in T for every series) within :data:`S4_SECOND` and its
    T (NaN where the series ends earlier)."""
    out = [window_mean(T, p, a, b) for a, b in S4_WINDOWS]
    sel = (T >= S4_SECOND[0]) & (T <= S4_SECOND[1])
    if T[-1] < S4_SECOND[1] or sel.sum() < 2:
        return [*out, math.nan, math.nan]
    q = running_mean(T, p, PLOT_WINDOW)[sel]
    return [*out, float(q.max()), float(T[sel][q.argmax()])]


def sensor4_table(results: dict) -> list[str]:
    """Sensor 4 (y = 0.267 H) of every run against Lobovsky's sensor 4 and Buchner's P1."""
    (a1, b1), (a2, b2) = S4_WINDOWS
    lines = [f"sensor 4 (y = 0.267 H) against two experiments at that height: mean over "
             f"{a1:g}-{b1:g} and {a2:g}-{b2:g}, peak of the {PLOT_WINDOW * 1e3:g} ms running "
             f"mean (dT = {PLOT_WINDOW * math.sqrt(G / H):.3f}) within {S4_SECOND[0]:g} <= T "
             f"<= {S4_SECOND[1]:g} (the second impact) and its T",
             f"{'series':24s}{'mean1':>8s}{'mean2':>8s}{'peak2':>8s}{'T':>7s}"]
    T, p = experiment()
    series = [("Lobovsky 2014 sensor 4", T, p[3]), ("Buchner 2002 P1", *experiment_p1())]
    series += [(f"{s} {d}D H/2r={n}", o["T"], o["p"][3])
               for (s, d, n), o in sorted(results.items())]
    for name, t, q in series:
        m = sensor4_measures(t, q)
        lines.append(f"{name:24s}{m[0]:8.3f}{m[1]:8.3f}{m[2]:8.3f}{m[3]:7.3f}")
    return lines


def scene(solver: str, per_h: int, dim: int = 2, wall: str = "free-slip",
          solved_walls: bool = False) -> Scene:
    """Lobovsky's tank with ``per_h`` particles across the column height H; ``solved_walls``:
    ``configuration.boundary.solved`` (in 3D the default MLS walls pump energy into a narrow
    channel's flow, validation/README.md "Dam break in 3D")."""
    r = H / (2 * per_h)
    pressure: dict = {"method": solver}
    if solver == "wcsph":
        c = 10.0 * math.sqrt(2.0 * G * H)
        pressure.update(equation="tait", exponent=7.0, stiffness=RHO0 * c * c / 7.0)
    visc: dict = {"method": "standard", "coefficient": NU}
    if wall == "no-slip":
        visc.update(boundary_coefficient=NU, boundary_velocity="morris1997")
    lo, hi, g = [0.0, 0.0], [TANK, 2.0 * H], [0.0, -G]
    start, end = [0.0, 0.0], [L, H]
    if dim == 3:  # y up, z across the channel
        lo, hi, g = lo + [0.0], hi + [WIDTH], g + [0.0]
        start, end = start + [0.0], end + [WIDTH]
    data = {
        "name": f"lobovsky-{solver}",
        "configuration": {
            "dim": dim, "particle_radius": r, "gravity": g, "pressure": pressure,
            "time": {"dt": 1e-4, "dt_min": 1e-7, "dt_max": 1e-3},
            "start": {"settle": False},  # the column is not at rest in its container
            "boundary": {"solved": solved_walls},
            # the tank is open at the top: WCSPH's impact throws lone particles over it, which
            # then fall beside the tank (validation/README.md, "Where WCSPH's dam-break impact
            # lost a particle"); they never reach the sensors
            "domain_margin": None,
        },
        "materials": [{"density0": RHO0, "viscosity": visc}],
        "fluid_blocks": [{"start": start, "end": end}],
        "boxes": [{"min": lo, "max": hi, "layers": 2, "open_top": True}],
    }
    return Scene.model_validate(data)


def sensor_points(dim: int) -> np.ndarray:
    """The sensors on the downstream wall's surface (centre line in 3D)."""
    pts = [[TANK, y] + ([0.5 * WIDTH] if dim == 3 else []) for y in SENSORS]
    return np.array(pts)


def run(sim: Simulation, t_end: float, dim: int = 2) -> dict:
    """Step to T = t_end: per step T and the four sensors' p / (rho g H)."""
    probe = Probe(sensor_points(dim), sim)
    s, unit = math.sqrt(G / H), RHO0 * G * H
    ts, ps = [0.0], [probe(sim) / unit]
    while sim.time * s < t_end:
        sim.step()
        ts.append(sim.time * s)
        ps.append(probe(sim) / unit)
    return {"T": np.array(ts), "p": np.array(ps).T, "steps": sim.step_count, "n": sim.fluid.n}


def running_mean(T: np.ndarray, p: np.ndarray, window: float = WINDOW) -> np.ndarray:
    """Mean of p over [T - w/2, T + w/2] (w = ``window`` seconds in T), from the integral of
    its piecewise-linear interpolant, at each T."""
    w = window * math.sqrt(G / H)
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(T))])
    lo, hi = np.clip(T - 0.5 * w, T[0], T[-1]), np.clip(T + 0.5 * w, T[0], T[-1])
    span = np.maximum(hi - lo, 1e-12)
    return (np.interp(hi, T, integral) - np.interp(lo, T, integral)) / span


def measures(T: np.ndarray, p: np.ndarray, t_first: float | None = None) -> list[dict]:
    """Per sensor: raw peak and time, peak of the running mean and time, plateau mean;
    ``t_first`` limits the peaks to T <= t_first (the first impact)."""
    out = []
    for k in range(p.shape[0]):
        keep = T <= (t_first if t_first is not None else np.inf)
        q, qs = p[k][keep], running_mean(T, p[k])[keep]
        plat = (T >= PLATEAU[0]) & (T <= PLATEAU[1])
        imp = (T >= IMPULSE[0]) & (T <= IMPULSE[1])
        q_i, T_i = p[k][imp], T[imp]
        out.append({"peak": float(q.max()), "T_peak": float(T[keep][q.argmax()]),
                    "peak_s": float(qs.max()), "T_peak_s": float(T[keep][qs.argmax()]),
                    "plateau": window_mean(T, p[k], *PLATEAU) if plat.sum() > 2 else math.nan,
                    "impulse": float(np.sum(0.5 * (q_i[1:] + q_i[:-1]) * np.diff(T_i))),
                    "arrival": float(T[np.argmax(p[k] > 0.1)]) if (p[k] > 0.1).any()
                    else math.nan})
    return out


def simulate(solver: str, per_h: int, t_end: float, dim: int = 2,
             wall: str = "free-slip", solved: bool = False) -> dict | str:
    """One run; an error message if it blew up."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(scene(solver, per_h, dim, wall, solved))
    t0 = time.perf_counter()
    try:
        out = run(sim, t_end, dim)
    except InstabilityError as e:
        return f"unstable at t = {sim.time:.3f} s: {str(e).splitlines()[0]}"
    out["wall"] = time.perf_counter() - t0
    out["info"] = np.array([out["n"], out["steps"], out["wall"]])
    return out


FIRST = 3.2  # the first impact's peaks are looked for at T <= FIRST (sensor 4's is later)


def rows(key: tuple, o: dict | str, ref: list[dict]) -> list[str]:
    """Table lines of one run: one per sensor."""
    solver, dim, per_h = key
    head = f"{solver:6s}{dim:3d}{per_h:5d}"
    if isinstance(o, str):
        return [f"{head}  {o}"]
    m = measures(o["T"], o["p"], None)
    first = measures(o["T"], o["p"], FIRST)
    out = []
    for k in range(4):
        s = m[k] if k == 3 else first[k]
        e = ref[k]
        out.append(f"{head}{k + 1:4d}{s['peak']:8.2f}{s['T_peak']:7.3f}{s['peak'] / e['peak']:7.2f}"
                   f"{s['peak_s']:8.2f}{s['T_peak_s']:7.3f}{s['peak_s'] / e['peak_s']:7.2f}"
                   f"{s['impulse']:8.3f}{s['impulse'] / e['impulse']:7.2f}"
                   f"{s['plateau']:8.3f}{s['plateau'] - e['plateau']:+8.3f}"
                   f"{s['arrival']:8.3f}{o['n']:7d}{o['steps']:7d}{o['wall']:7.0f}")
    return out


def reference_measures() -> list[dict]:
    """The experiment's measures (first impact for sensors 1-3, the whole record for 4)."""
    T, p = experiment()
    m, first = measures(T, p, None), measures(T, p, FIRST)
    return [first[0], first[1], first[2], m[3]]


def save(path: Path, results: dict) -> None:
    """The runs' series in one .npz (``--load`` prints and plots them again)."""
    np.savez_compressed(path, **{
        f"{s}|{d}|{n}|{f}": np.asarray(r[f]) for (s, d, n), r in results.items()
        for f in ("T", "p", "info")})


def load(path: Path) -> dict:
    """The runs saved by :func:`save`."""
    out: dict = {}
    with np.load(path) as d:
        for name in d.files:
            s, dim, n, f = name.split("|")
            o = out.setdefault((s, int(dim), int(n)), {"n": 0, "steps": 0, "wall": math.nan})
            if f == "info":
                o["n"], o["steps"], o["wall"] = int(d[name][0]), int(d[name][1]), float(d[name][2])
            else:
                o[f] = d[name]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--per-h", type=int, nargs="+", default=[10, 20, 40],
                    help="particles across the column height H (default 10 20 40)")
    ap.add_argument("--solvers", nargs="+", default=["dfsph", "wcsph"])
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3))
    ap.add_argument("--t-end", type=float, default=7.0, help="end of the runs, T = t sqrt(g/H)")
    ap.add_argument("--quick", action="store_true", help="10 and 20 across, to T = 4")
    ap.add_argument("--solved-walls", action="store_true",
                    help="configuration.boundary.solved: wall pressures solved in the PPE")
    ap.add_argument("--no-slip", action="store_true",
                    help="Morris et al.'s no-slip walls (the standard viscosity's wall term, "
                    "nu_b = nu); the rows' solver is then labelled <solver>/ns")
    ap.add_argument("--save", type=Path, help="write the runs' series to this .npz")
    ap.add_argument("--load", type=Path, nargs="*", default=[],
                    help="print and plot runs saved with --save (runs nothing)")
    args = ap.parse_args(argv)
    if args.quick:
        args.per_h, args.t_end = [10, 20], 4.0
    logging.getLogger("sphkit").setLevel(logging.ERROR)
    ref = reference_measures()
    print(f"Dam break on Lobovsky et al. 2014's downstream wall (H = {H} m, tank {TANK} m, "
          f"{args.dim}D): p / (rho g H) at the sensors against T = t sqrt(g/H); peak: raw; "
          f"peak2ms: of the {WINDOW * 1e3:g} ms running mean; /exp: over the experiment's; "
          f"first impact (T <= {FIRST}) for sensors 1-3, whole run for sensor 4; impulse: "
          f"integral of p dT over {IMPULSE[0]:g} <= T <= {IMPULSE[1]:g}; plateau: mean "
          f"over {PLATEAU[0]:g} <= T <= {PLATEAU[1]:g} and its difference from the experiment's")
    print("experiment (one event): " + "; ".join(
        f"s{k + 1} peak {e['peak']:.2f} at {e['T_peak']:.3f}, 2 ms {e['peak_s']:.2f} at "
        f"{e['T_peak_s']:.3f}, impulse {e['impulse']:.3f}, plateau {e['plateau']:.3f}"
        for k, e in enumerate(ref))
        + f"; arrival at s1 T = {ref[0]['arrival']:.3f}")
    print(f"{'solver':6s}{'dim':>3s}{'H/2r':>5s}{'s':>4s}{'peak':>8s}{'T':>7s}{'/exp':>7s}"
          f"{'peak2ms':>8s}{'T':>7s}{'/exp':>7s}{'impulse':>8s}{'/exp':>7s}{'plateau':>8s}"
          f"{'d':>8s}{'arrive':>8s}"
          f"{'N':>7s}{'steps':>7s}{'wall':>7s}")
    results: dict = {}
    for path in args.load:
        for key, o in load(path).items():
            results[key] = o
            for line in rows(key, o, ref):
                print(line, flush=True)
    for solver in [] if args.load else args.solvers:
        for per_h in args.per_h:
            key = (solver + ("/ns" if args.no_slip else ""), args.dim, per_h)
            o = simulate(solver, per_h, args.t_end, args.dim,
                         "no-slip" if args.no_slip else "free-slip", solved=args.solved_walls)
            for line in rows(key, o, ref):
                print(line, flush=True)
            if not isinstance(o, str):
                results[key] = o
                if args.save:
                    save(args.save, results)
    for line in sensor4_table(results):
        print(line)
    _plot(results, args.dim)
    return 0


def _plot(results: dict, dim: int) -> None:
    plt = pyplot()
    if plt is None:
        return
    if not results:
        return
    T, p = experiment()
    solvers = sorted({k[0] for k in results})
    fig, axes = plt.subplots(len(solvers), 4, figsize=(18, 3.6 * len(solvers)), squeeze=False)
    for row, solver in zip(axes, solvers, strict=True):
        for k, ax in enumerate(row):
            ax.plot(T, p[k], "k-", lw=0.8, label="Lobovsky 2014 (one event)")
            if k == 3:
                ax.plot(*experiment_p1(), "-", color="0.55", lw=0.8, label="Buchner 2002 P1")
            for (s, _d, per_h), o in sorted(results.items()):
                if s == solver:
                    ax.plot(o["T"], running_mean(o["T"], o["p"][k], PLOT_WINDOW), lw=0.7,
                            label=f"{solver} H/2r={per_h} ({PLOT_WINDOW * 1e3:g} ms mean)")
            ax.set_xlim(2.0, max(o["T"][-1] for o in results.values()))
            ax.set_ylim(-0.1, 2.0 * p[k].max() + 0.5)
            ax.set_title(f"{solver}, sensor {k + 1}: {SENSORS[k] * 1e3:g} mm above the floor "
                         f"({dim}D)", fontsize=8)
            ax.set_xlabel("T = t sqrt(g/H)")
            ax.set_ylabel("p / (rho g H)")
            if k in (0, 3):
                ax.legend(fontsize=6)
    path = Path(__file__).with_name(f"dam_break_impact{'_3d' if dim == 3 else ''}.png")
    fig.savefig(path, dpi=80, bbox_inches="tight")
    print(f"plot: {path}")


if __name__ == "__main__":
    sys.exit(main())
