"""Where a solver's step goes, pass by pass, beside SPlisHSPlasH's own timers (issue 22's profile).

    python benchmarks/passes.py [--solvers dfsph iisph pbf] [--radii 0.0125 0.00625]
                                [--until 0.1] [--threads 2] [--codes sphkit,splishsplash]
                                [--json FILE]

For each solver and particle radius, the benchmark dam break (``scenes/dambreak_<solver>.json``:
SPlisHSPlasH's DamBreakModel set-up with Akinci walls, the radius replaced: 0.0125 m gives
59,319 fluid particles, 0.00625 m 493,039) runs from t = 0 to ``--until`` in both codes, each
in its own subprocess with ``--threads`` threads.

**sphkit** (after an untimed warm-up on the 0.025 m copy in the same process, so that loading
the compiled passes is not timed) times every step and, on their own:

* the *parts* of the step, as the simulation calls them: the neighbour search
  (``Simulation._neighbors``), the densities with the cached pair gradients
  (``compute_density``), the solver's work before the forces (``pre_forces``: DFSPH's factor and
  divergence solve), the non-pressure forces, the pressure solve, and the rest of the step;
* every compiled *pass* run through :func:`sphkit.backend.launch`, ``launch_reduce`` or
  ``launch_sum`` (by body), and the search's grid construction, queries and z-order sort; per
  pass its calls and ms per step, its share of the step, a *bytes model* (the distinct arrays a
  call is given, each counted once: the CSR lists, the cached pair gradients, the fields; a
  lower bound of its memory traffic, without the neighbours' values gathered again) and the
  bandwidth this implies, as a fraction of the **stream bandwidth** measured in the same
  process (a ``prange`` triad ``a = b + s c`` over three 128 MB float64 arrays with the same
  threads, 24 bytes an element). A pass near 100 % is bound by memory bandwidth; one far below
  by latency (the gathers) or arithmetic.

**SPlisHSPlasH** (the pysplishsplash wheel through ``_splishsplash_runner.py``) prints its own
timers when the run ends ("Time sum: <part>"): the step (``SimStep``), ``neighborhood_search``,
``precomputeValues`` (its cached gradients), ``computeDFSPHFactor``, ``divergenceSolve``,
``computeNonPressureForces``, ``pressureSolve`` (IISPH also ``predictAdvection``); they are
printed in ms per step next to sphkit's parts, with the ratio of the step and of the neighbour
search. Needs an idle machine, like every timing.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import vs_splishsplash as vs  # noqa: E402 - the runners live beside this script
from scaling import scene_at  # noqa: E402 - the scene copies live beside this script

#: sphkit's parts of a step: (label, object attribute path on the simulation, method name)
PARTS = (("neighbour search", "", "_neighbors"),
         ("densities and cached pair gradients", "", "compute_density"),
         ("solver before the forces (DFSPH: factor, divergence solve)", "pressure", "pre_forces"),
         ("non-pressure forces", "forces", "apply"),
         ("pressure solve", "pressure", "solve"))


@numba.njit(parallel=True, cache=False)
def _triad(a, b, c, s):
    for i in numba.prange(a.shape[0]):
        a[i] = b[i] + s * c[i]


def stream_bandwidth(n: int = 1 << 24, repeat: int = 7) -> float:
    """Best bytes per second of the triad ``a = b + s c`` over float64 arrays of n elements."""
    a, b, c = np.zeros(n), np.ones(n), np.full(n, 2.0)
    _triad(a, b, c, 3.0)
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        _triad(a, b, c, 3.0)
        best = min(best, time.perf_counter() - t)
    return 3 * 8 * n / best


def _nbytes(args: tuple) -> int:
    seen: dict[int, int] = {}
    for a in args:
        if isinstance(a, np.ndarray):
            seen.setdefault(id(a), a.nbytes)
    return sum(seen.values())


class Recorder:
    """Calls, seconds and bytes of every timed pass or part, by name."""

    def __init__(self) -> None:
        self.on = False
        self.calls: dict[str, list[float]] = {}

    def timed(self, fn, name_of, bytes_of=lambda a, o: 0):
        def inner(*args, **kwargs):
            if not self.on:
                return fn(*args, **kwargs)
            t = time.perf_counter()
            out = fn(*args, **kwargs)
            c = self.calls.setdefault(name_of(args), [0, 0.0, 0])
            c[0] += 1
            c[1] += time.perf_counter() - t
            c[2] += bytes_of(args, out)
            return out
        return inner


def install_passes(rec: Recorder) -> None:
    """Wrap the backend's launches in every loaded sphkit module, and the neighbour search."""
    import sphkit.core.neighbors as nb
    import sphkit.simulation as sm

    bl = importlib.import_module("sphkit.backend.launch")  # the module (the package's
    # attribute of that name is the function)
    wrapped = {fn: rec.timed(fn, lambda a: a[0].__name__, lambda a, _o: _nbytes(a[2:]))
               for fn in (bl.launch, bl.launch_reduce, bl.launch_sum)}
    for name, mod in list(sys.modules.items()):
        if name.startswith("sphkit") and mod is not None:
            for attr in ("launch", "launch_reduce", "launch_sum"):
                fn = getattr(mod, attr, None)
                if fn in wrapped:
                    setattr(mod, attr, wrapped[fn])
    nb.Grid.query = rec.timed(
        nb.Grid.query, lambda a: "search: Grid.query",
        lambda a, o: _nbytes(a[1:2]) + o.offsets.nbytes + o.indices.nbytes)
    nb.Grid.query_own = rec.timed(
        nb.Grid.query_own, lambda a: "search: Grid.query_own",
        lambda a, o: _nbytes(a[1:2]) + o.offsets.nbytes + o.indices.nbytes)
    nb.Grid.__init__ = rec.timed(
        nb.Grid.__init__, lambda a: "search: Grid build",
        lambda a, _o: _nbytes(a[1:2]) + a[0].sorted_x.nbytes + a[0].sorted_index.nbytes)
    sm.zorder_permutation = rec.timed(sm.zorder_permutation, lambda a: "search: z-order sort",
                                      lambda a, o: _nbytes(a[:1]) + o.nbytes)


def install_parts(sim, rec: Recorder) -> None:
    """Wrap the simulation's parts of a step (:data:`PARTS`)."""
    for label, owner, method in PARTS:
        objs = [sim] if not owner else getattr(sim, owner)
        for obj in objs if isinstance(objs, list) else [objs]:
            setattr(obj, method, rec.timed(getattr(obj, method), lambda a, k=label: k))


def child(scene: Path, warm: Path, out: Path) -> None:
    """sphkit's run (in the subprocess): the tables on stdout, the numbers as JSON in ``out``."""
    from sphkit.simulation import Simulation

    w = Simulation.from_scene(warm)  # loads the compiled passes, untimed
    for _ in range(3):
        w.step()
    del w
    gc.collect()
    bw = stream_bandwidth()
    passes, parts = Recorder(), Recorder()
    sim = Simulation.from_scene(scene)
    install_passes(passes)
    install_parts(sim, parts)
    until = sim.scene.configuration.time.until
    its = steps = 0
    passes.on = parts.on = True
    t0 = time.perf_counter()
    while sim.time < until - 1e-12:
        s = sim.step()
        steps += 1
        its += s.iterations + s.divergence_iterations
    wall = time.perf_counter() - t0
    n = sim.fluid.n
    rows = []
    for name, (calls, sec, nbytes) in passes.calls.items():
        gbs = nbytes / sec / 1e9 if sec > 0 else 0.0
        rows.append({"pass": name, "calls_per_step": calls / steps,
                     "ms_per_step": sec / steps * 1e3, "share": sec / wall,
                     "mb_per_call": nbytes / calls / 1e6, "gb_per_s": gbs,
                     "of_stream": gbs * 1e9 / bw})
    rows.sort(key=lambda r: -r["ms_per_step"])
    part_ms = {k: v[1] / steps * 1e3 for k, v in parts.calls.items()}
    out.write_text(json.dumps({"fluid": n, "boundary": sim.boundary.n, "steps": steps,
                               "ms_per_step": wall / steps * 1e3, "iterations": its / steps,
                               "stream_gb_per_s": bw / 1e9, "threads": numba.get_num_threads(),
                               "passes": rows, "parts": part_ms}, indent=1))


def run_sphkit(scene: Path, warm: Path, threads: int, folder: Path) -> dict:
    """sphkit's run in a subprocess with ``threads`` threads; ``{"error": ...}`` if it fails."""
    out = folder / f"{scene.stem}.sphkit.json"
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads))
    res = subprocess.run([sys.executable, __file__, "--child", str(scene), str(warm), str(out)],
                         env=env, capture_output=True, text=True, check=False)
    if res.returncode or not out.exists():
        tail = (res.stderr.strip() or res.stdout.strip()).splitlines()[-3:]
        return {"error": f"exit {res.returncode}: {' / '.join(tail)}"}
    return json.loads(out.read_text())


def report(solver: str, radius: float, sk: dict | None, sp: dict | None) -> None:
    """The pass table and the parts of both codes side by side."""
    print(f"\n== {solver}, particle radius {radius} m", flush=True)
    if sk is not None and "error" not in sk:
        print(f"sphkit: {sk['fluid']} fluid, {sk['boundary']} boundary particles, "
              f"{sk['steps']} steps, {sk['threads']} threads: {sk['ms_per_step']:.1f} ms per "
              f"step, {sk['iterations']:.2f} iterations per step; stream triad "
              f"{sk['stream_gb_per_s']:.1f} GB/s")
        print(f"  {'pass':44s} {'calls':>6s} {'ms/step':>8s} {'share':>6s} {'MB/call':>8s} "
              f"{'GB/s':>6s} {'stream':>7s}")
        for r in sk["passes"]:
            if r["share"] >= 0.002:
                print(f"  {r['pass']:44s} {r['calls_per_step']:6.1f} {r['ms_per_step']:8.2f} "
                      f"{100 * r['share']:5.1f}% {r['mb_per_call']:8.2f} {r['gb_per_s']:6.2f} "
                      f"{100 * r['of_stream']:6.1f}%")
    elif sk is not None:
        print(f"sphkit: {sk['error']}")
    if sp is not None and "error" in sp:
        print(f"SPlisHSPlasH: {sp['error']}")
        sp = None
    print(f"  {'part, ms per step':58s} {'sphkit':>8s}   {'SPlisHSPlasH part':28s} {'ms':>8s}")
    sk_parts = dict(sk.get("parts", {})) if sk and "error" not in sk else {}
    if sk_parts:
        sk_parts["the rest of the step"] = sk["ms_per_step"] - sum(sk_parts.values())
    sp_parts = ({k: v / max(sp["steps"], 1) * 1e3 for k, v in sp.get("parts", {}).items()
                 if k != "Regular triangle sampling"} if sp else {})
    left, right = list(sk_parts.items()), list(sp_parts.items())
    for k in range(max(len(left), len(right))):
        a = f"  {left[k][0]:58s} {left[k][1]:8.2f}" if k < len(left) else f"  {'':58s} {'':8s}"
        b = f"   {right[k][0]:28s} {right[k][1]:8.2f}" if k < len(right) else ""
        print(a + b)
    if sk_parts and sp_parts.get("SimStep"):
        sp_step = sp_parts["SimStep"]
        print(f"  ratio sphkit / SPlisHSPlasH per step: {sk['ms_per_step'] / sp_step:.2f} "
              f"({sk['ms_per_step']:.1f} / {sp_step:.1f} ms; steps {sk['steps']} / "
              f"{sp['steps']}, iterations {sk['iterations']:.2f} / "
              f"{sp['iterations'] + sp['divergence_iterations']:.2f})")
        if sp_parts.get("neighborhood_search"):
            a, b = sk_parts["neighbour search"], sp_parts["neighborhood_search"]
            print(f"  neighbour search: {a / b:.2f} ({a:.1f} / {b:.1f} ms); the rest of the "
                  f"step: {(sk['ms_per_step'] - a) / (sp_step - b):.2f} "
                  f"({sk['ms_per_step'] - a:.1f} / {sp_step - b:.1f} ms)")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solvers", nargs="+", default=["dfsph", "iisph", "pbf"],
                    choices=("wcsph", "pcisph", "pbf", "iisph", "dfsph"))
    ap.add_argument("--radii", nargs="+", type=float, default=[0.0125, 0.00625],
                    help="particle radii [m]")
    ap.add_argument("--until", type=float, default=0.1, help="simulated time of each run [s]")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--codes", default="sphkit,splishsplash",
                    help="comma-separated: sphkit, splishsplash")
    ap.add_argument("--json", type=Path, metavar="FILE", help="all runs' numbers as JSON")
    ap.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(*(Path(a) for a in args.child))
        return 0
    codes = set(args.codes.split(","))
    if args.threads < 1 or not args.until > 0 or not all(r > 0 for r in args.radii) \
            or not codes <= {"sphkit", "splishsplash"}:
        ap.error(f"--threads {args.threads}, --until {args.until}, --radii {args.radii}, "
                 f"--codes {args.codes}: expected at least one thread, a positive time and "
                 "radii, and codes among sphkit, splishsplash")
    results = []
    with tempfile.TemporaryDirectory(prefix="sphkit-passes-") as tmp:
        folder = Path(tmp)
        for solver in args.solvers:
            warm = scene_at(solver, 0.025, 0.01, folder)
            for radius in args.radii:
                scene = scene_at(solver, radius, args.until, folder)
                sk = run_sphkit(scene, warm, args.threads, folder) if "sphkit" in codes else None
                sp = vs.run_splishsplash(scene, args.threads) if "splishsplash" in codes else None
                report(solver, radius, sk, sp)
                results.append({"solver": solver, "radius": radius, "sphkit": sk,
                                "splishsplash": sp})
    if args.json:
        args.json.write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
