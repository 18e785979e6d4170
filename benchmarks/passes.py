"""Per-pass time, bytes and bandwidth of a solver's step against the machine's stream bandwidth.

    python benchmarks/passes.py [--solvers dfsph iisph pbf] [--radii 0.0125 0.00625]
                                [--start 0.06] [--steps 10] [--threads 2] [--json FILE]

For each solver and particle radius it builds the benchmark dam break
(``scenes/dambreak_<solver>.json``, SPlisHSPlasH's DamBreakModel set-up with Akinci walls, the
radius replaced: 0.0125 m gives 59,319 fluid particles, 0.00625 m 493,039), steps to t =
``--start`` untimed (compilation, the first splash) and then times ``--steps`` steps, each
compiled pass on its own:

* every pass run through :func:`sphkit.backend.launch`, :func:`~sphkit.backend.launch_reduce`
  or :func:`~sphkit.backend.launch_sum` (the per-particle bodies of the design: density, pair
  gradients, the Jacobi sweeps, viscosity, ...), by body;
* the neighbour search: the grids' construction (``Grid.__init__``: cell sort) and the queries
  (``Grid.query``: scan and compaction), and the z-order sort of the fluid;
* the rest of the step (Python glue, NumPy element-wise work, the solver's bookkeeping) as the
  difference to the step's wall time.

Per pass: calls and milliseconds per step, its share of the step, a *bytes model* (the bytes
of the distinct arrays a call is given, each counted once: the CSR lists, the cached pair
gradients and the fields, so a lower bound of the memory traffic, which ignores the neighbours'
values gathered again from cache or memory) and the bandwidth this implies, as a fraction of
the machine's stream bandwidth, measured in the same process just before the steps (a
``prange`` triad ``a = b + s c`` over three 128 MB float64 arrays with the same threads; bytes
counted as 3 x 8 per element). A pass near 100 % is bound by memory bandwidth; one far below
it is bound by latency (gathers) or arithmetic. Every run is its own subprocess with
``NUMBA_NUM_THREADS`` threads. Needs an idle machine, like every timing.
"""

from __future__ import annotations

import argparse
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
from scaling import scene_at  # noqa: E402 - the scene copies live beside this script


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
    """Time and bytes of every launched pass and search call, by name."""

    def __init__(self) -> None:
        self.on = False
        self.calls: dict[str, list[float]] = {}  # name -> [calls, seconds, bytes]

    def add(self, name: str, seconds: float, nbytes: int) -> None:
        c = self.calls.setdefault(name, [0, 0.0, 0])
        c[0] += 1
        c[1] += seconds
        c[2] += nbytes

    def timed(self, fn, name_of, bytes_of):
        def inner(*args, **kwargs):
            if not self.on:
                return fn(*args, **kwargs)
            t = time.perf_counter()
            out = fn(*args, **kwargs)
            self.add(name_of(args), time.perf_counter() - t, bytes_of(args, out))
            return out
        return inner


def install(rec: Recorder) -> None:
    """Wrap the backend's launches in every loaded sphkit module, and the neighbour search."""
    import importlib

    import sphkit.core.neighbors as nb
    import sphkit.simulation as sm

    bl = importlib.import_module("sphkit.backend.launch")  # the module (the package's
    # attribute of that name is the function)

    originals = {bl.launch: "launch", bl.launch_reduce: "launch_reduce",
                 bl.launch_sum: "launch_sum"}
    wrapped = {fn: rec.timed(fn, lambda a: a[0].__name__, lambda a, _o: _nbytes(a[2:]))
               for fn in originals}
    for name, mod in list(sys.modules.items()):
        if not name.startswith("sphkit") or mod is None:
            continue
        for attr in ("launch", "launch_reduce", "launch_sum"):
            fn = getattr(mod, attr, None)
            if fn in wrapped:
                setattr(mod, attr, wrapped[fn])

    def list_bytes(args, out):
        return _nbytes(args[1:2]) + out.offsets.nbytes + out.indices.nbytes

    def grid_bytes(args, _out):
        g = args[0]
        return _nbytes((args[1],)) + g.sorted_x.nbytes + g.sorted_index.nbytes

    nb.Grid.query = rec.timed(nb.Grid.query, lambda a: "neighbour search: Grid.query",
                              list_bytes)
    nb.Grid.__init__ = rec.timed(nb.Grid.__init__, lambda a: "neighbour search: Grid build",
                                 grid_bytes)
    sm.zorder_permutation = rec.timed(sm.zorder_permutation,
                                      lambda a: "neighbour search: z-order sort",
                                      lambda a, o: _nbytes(a[:1]) + o.nbytes)


def child(scene: Path, start: float, steps: int, out: Path | None) -> None:
    from sphkit.simulation import Simulation

    rec = Recorder()
    sim = Simulation.from_scene(scene)
    install(rec)
    while sim.time < start:
        sim.step()
    bw = stream_bandwidth()
    its = 0.0
    rec.on = True
    t0 = time.perf_counter()
    for _ in range(steps):
        s = sim.step()
        its += s.iterations + s.divergence_iterations
    wall = time.perf_counter() - t0
    rec.on = False
    n = sim.fluid.n
    ms_step = wall / steps * 1e3
    print(f"{n} fluid and {sim.boundary.n} boundary particles, {steps} steps from t = {start} s,"
          f" {numba.get_num_threads()} threads: {ms_step:.1f} ms per step, "
          f"{its / steps:.1f} iterations per step; stream triad {bw / 1e9:.1f} GB/s")
    print(f"{'pass':52s} {'calls':>6s} {'ms/step':>8s} {'share':>6s} {'MB/call':>8s} "
          f"{'GB/s':>6s} {'stream':>7s}")
    rows = []
    counted = 0.0
    for name, (calls, sec, nbytes) in sorted(rec.calls.items(), key=lambda kv: -kv[1][1]):
        counted += sec
        gbs = nbytes / sec / 1e9 if sec > 0 else 0.0
        rows.append({"pass": name, "calls_per_step": calls / steps,
                     "ms_per_step": sec / steps * 1e3, "share": sec / wall,
                     "mb_per_call": nbytes / calls / 1e6, "gb_per_s": gbs,
                     "of_stream": gbs * 1e9 / bw})
        r = rows[-1]
        if r["share"] >= 0.002:
            print(f"{name:52s} {r['calls_per_step']:6.1f} {r['ms_per_step']:8.2f} "
                  f"{100 * r['share']:5.1f}% {r['mb_per_call']:8.2f} {gbs:6.2f} "
                  f"{100 * r['of_stream']:6.1f}%")
    rest = wall - counted
    print(f"{'the rest (Python glue, NumPy element-wise, bookkeeping)':52s} {'':6s} "
          f"{rest / steps * 1e3:8.2f} {100 * rest / wall:5.1f}%")
    if out:
        out.write_text(json.dumps({"fluid": n, "boundary": sim.boundary.n, "steps": steps,
                                   "ms_per_step": ms_step, "iterations": its / steps,
                                   "stream_gb_per_s": bw / 1e9, "passes": rows,
                                   "rest_ms_per_step": rest / steps * 1e3}, indent=1))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solvers", nargs="+", default=["dfsph", "iisph", "pbf"],
                    choices=("wcsph", "pcisph", "pbf", "iisph", "dfsph"))
    ap.add_argument("--radii", nargs="+", type=float, default=[0.0125, 0.00625],
                    help="particle radii [m]")
    ap.add_argument("--start", type=float, default=0.06, help="untimed simulated time [s]")
    ap.add_argument("--steps", type=int, default=10, help="timed steps")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", type=Path, metavar="FILE", help="all runs' numbers as JSON")
    ap.add_argument("--child", nargs=4, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        scene, start, steps, out = args.child
        child(Path(scene), float(start), int(steps), Path(out) if out != "-" else None)
        return 0
    if args.steps < 1 or args.threads < 1 or not all(r > 0 for r in args.radii):
        ap.error(f"--steps {args.steps}, --threads {args.threads}, --radii {args.radii}: "
                 "expected at least one step and thread and positive radii")
    results = []
    env = dict(os.environ, NUMBA_NUM_THREADS=str(args.threads))
    with tempfile.TemporaryDirectory(prefix="sphkit-passes-") as tmp:
        for solver in args.solvers:
            for radius in args.radii:
                path = scene_at(solver, radius, None, Path(tmp))
                out = Path(tmp) / f"{solver}_{radius}.out.json"
                print(f"\n== {solver}, particle radius {radius} m", flush=True)
                rc = subprocess.run([sys.executable, __file__, "--child", str(path),
                                     str(args.start), str(args.steps), str(out)],
                                    env=env, check=False).returncode
                if rc == 0 and out.exists():
                    r = json.loads(out.read_text())
                    r.update(solver=solver, radius=radius)
                    results.append(r)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
