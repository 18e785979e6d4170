"""sphkit and SPlisHSPlasH side by side at growing particle counts: time and memory per particle.

    python benchmarks/scaling.py [--solver dfsph|wcsph|pcisph|pbf|iisph|all] [--radii R,R,...]
                                 [--large] [--until T] [--repeat 3] [--threads 2]
                                 [--codes sphkit,splishsplash] [--precision float32] [--skin S]
                                 [--json FILE]

Runs the DamBreakModel dam break of ``scenes/dambreak_<solver>.json`` (SPlisHSPlasH's setup,
Akinci walls; the same file in both codes) with the particle radius replaced: by default 0.025,
0.0125 and 0.00625 m (6,859, 59,319 and 493,039 fluid particles; ``--large`` adds 0.005 m,
970,299), each scene to ``--until`` simulated seconds; a fixed time step (the WCSPH scene's) is
scaled with the radius (:func:`scene_at`). Each code runs each size in its own
subprocess (``benchmarks/vs_splishsplash.py``'s runners: SPlisHSPlasH through the
pysplishsplash wheel with its ``LD_PRELOAD``, ``OMP_NUM_THREADS``; sphkit with
``NUMBA_NUM_THREADS`` after an untimed warm-up on the smallest size, so that neither Numba's
compilation nor the warm-up's particles count), ``--repeat`` times alternating the codes, and
the fastest run of each code is reported (timing needs an otherwise idle machine).

Per size and code it prints the fluid and boundary particles, steps, milliseconds per step,
pressure iterations per step (DFSPH: ``+`` divergence iterations), microseconds per
particle-step (wall time / steps / fluid particles), the peak resident memory of the child
process (``ru_maxrss``) in MB and in bytes per fluid particle, the same less the process's
resident memory before the scene was built (Python, Numba's compiled code, the wheel: ``net
B/p``), and the ratio sphkit / SPlisHSPlasH of the wall time per simulated second (below 1:
sphkit is faster) and of the peak memory. ``--precision`` and ``--skin`` set sphkit's
``configuration.precision`` and ``configuration.neighbor_skin`` (Verlet lists) for its runs.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import vs_splishsplash as vs  # noqa: E402 - the runners live beside this script

SOLVERS = ("wcsph", "pcisph", "pbf", "iisph", "dfsph")
RADII = (0.025, 0.0125, 0.00625)
LARGE = 0.005


def scene_at(solver: str, radius: float, until: float | None, folder: Path) -> Path:
    """A copy of ``scenes/dambreak_<solver>.json`` with the particle radius (and ``stopAt``)
    replaced and absolute mesh paths. A scene with a fixed step (``cflMethod`` 0: the WCSPH
    one) gets its ``timeStepSize`` scaled with the radius, as the acoustic step condition ``dt ~
    h / c`` asks (1 ms at the file's 0.025 m: 0.5 ms at 0.0125, 0.25 ms at 0.00625; at 0.00625
    the file's 1 ms is a CFL number of about 2 and the run goes unstable)."""
    src = vs.SCENES / f"dambreak_{solver}.json"
    data = json.loads(src.read_text())
    cfg = data.setdefault("Configuration", {})
    if cfg.get("cflMethod", 1) == 0 and "timeStepSize" in cfg:
        cfg["timeStepSize"] = cfg["timeStepSize"] * radius / cfg.get("particleRadius", 0.025)
    cfg["particleRadius"] = radius
    if until is not None:
        cfg["stopAt"] = until
    for block in data.values():
        for entry in block if isinstance(block, list) else []:
            for key in vs.FILE_FIELDS:
                name = entry.get(key) if isinstance(entry, dict) else None
                if isinstance(name, str) and name and not Path(name).is_absolute():
                    entry[key] = str((src.parent / name).resolve())
    path = folder / f"dambreak_{solver}_r{radius:g}.json"
    path.write_text(json.dumps(data, indent=1))
    return path


COLUMNS = (f"{'solver':7s} {'r [m]':>8s} {'code':12s} {'fluid':>8s} {'bound.':>7s} "
           f"{'steps':>5s} {'ms/step':>8s} {'it/step':>11s} {'us/p-step':>9s} {'peak MB':>8s} "
           f"{'B/p':>6s} {'net B/p':>7s}")


def _row(solver: str, radius: float, code: str, r: dict) -> str:
    head = f"{solver:7s} {radius:8.5f} {code:12s}"
    if "unavailable" in r:
        return f"{head} not available: {r['unavailable']}"
    if "error" in r:
        return f"{head} failed: {r['error']}"
    steps = max(r["steps"], 1)
    n = max(r["n_fluid"], 1)
    its = "-" if r.get("iterations") is None else f"{r['iterations']:.2f}"
    if r.get("method") in ("dfsph", "DFSPH"):
        its += f"+{r['divergence_iterations']:.2f}"
    peak = r.get("maxrss", 0)
    net = peak - r.get("rss_base", 0)
    return (f"{head} {r['n_fluid']:8d} {r['n_boundary'] or 0:7d} {r['steps']:5d} "
            f"{1e3 * r['wall'] / steps:8.2f} {its:>11s} {1e6 * r['wall'] / steps / n:9.3f} "
            f"{peak / 1e6:8.1f} {peak / n:6.0f} {net / n:7.0f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solver", default="dfsph", choices=SOLVERS + ("all",),
                    help="the dam break of which solver (default dfsph; all: the five)")
    ap.add_argument("--radii", metavar="LIST",
                    help="particle radii [m], comma-separated (default 0.025,0.0125,0.00625)")
    ap.add_argument("--large", action="store_true",
                    help=f"also r = {LARGE} m (about a million fluid particles)")
    ap.add_argument("--until", type=float, default=0.5, metavar="T",
                    help="simulated end time [s] of every run (default 0.5)")
    ap.add_argument("--repeat", type=int, default=3, metavar="N",
                    help="runs per code and size, alternating the codes; the fastest is "
                         "reported (default 3)")
    ap.add_argument("--threads", type=int, default=2, help="threads for both codes (default 2)")
    ap.add_argument("--codes", default="sphkit,splishsplash", metavar="LIST",
                    help="sphkit, splishsplash or both (default)")
    ap.add_argument("--precision", choices=("float64", "float32"),
                    help="sphkit's configuration.precision (default: float64)")
    ap.add_argument("--skin", type=float, metavar="S",
                    help="sphkit's configuration.neighbor_skin: Verlet lists with a skin of S h "
                         "(default: none, a search every step)")
    ap.add_argument("--json", type=Path, metavar="FILE", help="also write the results as JSON")
    args = ap.parse_args()
    config: dict = {}
    if args.precision:
        config["precision"] = args.precision
    if args.skin is not None:
        if not 0.0 <= args.skin <= 1.0:
            ap.error(f"--skin: got {args.skin}; expected a fraction of h in [0, 1]")
        config["neighbor_skin"] = args.skin
    try:
        radii = (tuple(float(v) for v in args.radii.split(",")) if args.radii else RADII)
    except ValueError:
        ap.error(f"--radii: got {args.radii!r}; expected positive numbers, comma-separated")
    if not radii or not all(r > 0 for r in radii):
        ap.error(f"--radii: got {args.radii!r}; expected positive numbers, comma-separated")
    if args.large:
        radii = radii + (LARGE,)
    if not args.until > 0:
        ap.error(f"--until: got {args.until}; expected a positive time in seconds")
    if args.repeat < 1 or args.threads < 1:
        ap.error(f"--repeat {args.repeat}, --threads {args.threads}: expected at least 1")
    codes = {c.strip().lower() for c in args.codes.split(",") if c.strip()}
    if not codes or not codes <= {"sphkit", "splishsplash"}:
        ap.error(f"--codes: got {args.codes!r}; expected sphkit, splishsplash or both")
    solvers = SOLVERS if args.solver == "all" else (args.solver,)
    print(f"# {time.strftime('%Y-%m-%d %H:%M')} {args.threads} threads each, to t = {args.until} "
          f"s, fastest of {args.repeat}; sphkit settings {config or 'default'}; B/p: peak "
          "resident bytes per fluid particle, net B/p: less the process before the scene")
    print(COLUMNS, flush=True)
    results = []
    with tempfile.TemporaryDirectory(prefix="sphkit-scaling-") as tmp:
        folder = Path(tmp)
        for solver in solvers:
            (folder / "warm").mkdir(exist_ok=True)  # sphkit's warm-up: the smallest size
            warm = scene_at(solver, max(radii), 0.01, folder / "warm")
            for radius in radii:
                path = scene_at(solver, radius, args.until, folder)
                runs: dict[str, list[dict]] = {"sphkit": [], "splishsplash": []}
                for _ in range(args.repeat):
                    if "sphkit" in codes:
                        runs["sphkit"].append(vs.run_sphkit(path, args.threads, warm, config))
                    if "splishsplash" in codes:
                        runs["splishsplash"].append(vs.run_splishsplash(path, args.threads))
                    if any("wall" not in r for rs in runs.values() for r in rs):
                        break  # a failure: no point in repeating
                best = {c: vs._fastest(rs) for c, rs in runs.items() if rs}
                for code, label in (("sphkit", "sphkit"), ("splishsplash", "SPlisHSPlasH")):
                    if code in best:
                        print(_row(solver, radius, label, best[code]), flush=True)
                entry = {"solver": solver, "radius": radius, "until": args.until, "config": config,
                         **best, "runs": runs, "ratio": None, "memory_ratio": None}
                sk, sp = best.get("sphkit", {}), best.get("splishsplash", {})
                if "wall" in sk and "wall" in sp and sk["sim_time"] > 0 and sp["sim_time"] > 0:
                    entry["ratio"] = vs._per_sim_s(sk) / vs._per_sim_s(sp)
                    if sp.get("maxrss"):
                        entry["memory_ratio"] = sk.get("maxrss", 0) / sp["maxrss"]
                    print(f"{solver:7s} {radius:8.5f} ratio sphkit/SPlisHSPlasH: time per "
                          f"simulated second {entry['ratio']:.2f}, peak memory "
                          f"{entry['memory_ratio'] or float('nan'):.2f}", flush=True)
                results.append(entry)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
