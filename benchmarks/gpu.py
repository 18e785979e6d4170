"""The GPU's kernel passes against the CPU's: neighbour search and the passes of a DFSPH step
that run as kernel bodies today (issue 18).

    python benchmarks/gpu.py [--sizes 1e6 4e6 16e6] [--cpu-size 1e6] [--repeat 5]
                             [--iterations 5] [--steps K] [--json FILE]

On a 3D block of fluid on a lattice (spacing 2r, jittered by 0.1 r, h = 4r, about 33
neighbours) over a floor of two layers of boundary particles, every pass that the time step will
run on the device is launched through :func:`sphkit.backend.launch` with its arrays resident on
the GPU and timed (median of ``--repeat``, after one warm-up launch that compiles):

* ``search``: :class:`sphkit.core.hashgrid.HashGrid` builds the fluid's and the walls' grids and
  queries both (fluid-fluid without self, fluid-boundary);
* ``density+grads``: the density and the cached pair gradients (DFSPH's and IISPH's first pass);
* ``diagonal``: the PPE diagonal from the cached gradients (DFSPH's factor);
* ``viscosity``: the standard (Morris) viscosity with the boundary term;
* ``jacobi``: one Jacobi iteration of the pressure solves (the kappa acceleration, then the
  sweep with its residual reduction, one scalar pair read back).

It prints per pass the time, particles/s and an estimate of the bytes it moves (each particle's
own fields once, and per pair its index and the neighbour's gathered fields) against the
device's copy bandwidth measured here (a device-to-device copy of 1 GB; ``--peak`` for a spec
value instead), the GPU memory per particle (the device's free memory before and after the set-up),
and a *ported-pass step*: search + density+grads + diagonal + viscosity + ``--iterations``
Jacobi iterations of each of the two DFSPH solves, as particle-steps/s: a bound from the passes
alone (the whole step, with its glue and iteration control: ``--steps``). The same passes then
run on the CPU (``--cpu-size`` particles, NUMBA_NUM_THREADS threads) for the ratio.

``--steps K`` also times K whole DFSPH steps (after a warm-up step) of a 3D dam break at each
size through ``Simulation(..., device="cuda")``, with every field resident on the device
(:func:`dam_scene`: DFSPH, Akinci walls with mirrored boundary pressure, standard viscosity; in
each device's default precision, float32 on the GPU, unless ``--precision``), and on the CPU at
``--cpu-size`` with ``--cpu-threads`` threads (2: the issue's two cores): steps/s,
particle-steps/s, iterations per step, the modelled bytes a step moves per second and their
fraction of the copy bandwidth, GPU memory per particle, and issue 18's targets (2e8 fluid
particle-steps/s at 16M particles, 50x the two-core CPU at 1M) met or missed. The issue's run on
a GPU machine: ``python benchmarks/gpu.py --steps 10 --json gpu.json``; ``--only cuda|cpu``
runs one device's rows, ``--no-passes`` the whole steps alone, and the JSON is rewritten after
every row. ``benchmarks/gpu_session.sh`` is a lease's whole run (this script's rows, the CPU's
beside them, the agreement check).

Without a GPU (numba-cuda finds none) only the CPU rows run. Under ``NUMBA_ENABLE_CUDASIM=1`` the
script runs the simulator for a check of the script itself (``--sizes 300 --cpu-size 300``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time

import numpy as np

from sphkit.backend import cuda_available, launch, to_device
from sphkit.core.hashgrid import HashGrid, hash_origin
from sphkit.core.kernels import lattice_volume
from sphkit.core.ppe import (
    density_pair_gradients,
    diagonal_cached,
    jacobi_sweep,
    kappa_accel_cached,
)
from sphkit.viscosity.standard import standard_body

R = 0.005  #: particle radius [m]
RHO0 = 1000.0


def block(n_target: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """About ``n_target`` fluid particles in a cube on a jittered lattice (3, N), and two floor
    layers of boundary particles under it (3, Nb)."""
    n = max(2, round(n_target ** (1 / 3)))
    s = 2 * R
    g = (np.arange(n) + 0.5) * s
    x = np.stack(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1)
    x += np.random.default_rng(seed).uniform(-0.1 * R, 0.1 * R, x.shape)
    gb = (np.arange(-2, n + 2) + 0.5) * s
    fx, fy, fz = np.meshgrid(gb, gb, np.array([-0.5, -1.5]) * s, indexing="ij")
    bx = np.stack([fx, fy, fz]).reshape(3, -1)
    return np.ascontiguousarray(x), np.ascontiguousarray(bx)


class Passes:
    """The arrays of one block on ``device`` and its passes as closures."""

    def __init__(self, x: np.ndarray, bx: np.ndarray, device: str) -> None:
        self.device = dev = device
        self.n, self.nb = n, nb = x.shape[1], bx.shape[1]
        h = 4 * R
        self.h = h
        V0 = lattice_volume(2 * R, 0, h, 3)

        def on(a: np.ndarray):  # noqa: ANN202 - a NumPy or a device array
            return to_device(np.ascontiguousarray(a), dev)

        self.x, self.bx = on(x), on(bx)
        self.m = on(np.full(n, RHO0 * V0))
        self.V = on(np.full(n, V0))
        self.c = on(np.ones(n))
        self.rho0 = on(np.full(n, RHO0))  # each particle's rest density (the viscosity's)
        self.bV = on(np.full(nb, (2 * R) ** 3))
        self.bv = on(np.zeros((3, nb)))
        self.bn = on(np.zeros((3, nb)))
        self.bd = on(np.zeros(nb))
        self.bf = on(np.ones(nb))  # the walls' factors on the viscous wall term
        self.mirror = on(np.zeros(nb))
        self.kb = on(np.zeros(0))
        self.v = on(np.random.default_rng(1).normal(0.0, 0.1, (3, n)))
        self.rho = on(np.empty(n))
        self.a = on(np.zeros((3, n)))
        self.D = on(np.empty(n))
        self.q = on(np.full(n, 1e-6))
        self.k = on(np.full(n, 1e-6))
        self.s = on(np.full(n, -1e-4))
        self.w = on(np.ones(n))
        self.scale = on(np.full(n, 0.5))
        self.active = on(np.ones(n, dtype=np.bool_))
        origin = hash_origin(np.full(3, 0.5 * n ** (1 / 3) * 2 * R), h)
        self.grid = HashGrid(3, h, origin, device=dev)
        self.walls = HashGrid(3, h, origin, device=dev)
        self.search()
        self.pairs, self.bpairs = int(self.nl.indices.shape[0]), int(self.nb_.indices.shape[0])
        self.gw = to_device(np.empty((3, max(self.pairs, 1))), dev)
        self.gwb = to_device(np.empty((3, max(self.bpairs, 1))), dev)

    def sync(self) -> None:
        """Wait for the device's queued work."""
        if self.device == "cuda":
            from numba import cuda

            cuda.synchronize()

    def search(self) -> None:
        """Both grids built, both queries run."""
        self.grid.build(self.x)
        self.walls.build(self.bx)
        self.nl = self.grid.query(self.x, exclude_self=True)
        self.nb_ = self.walls.query(self.x)

    # the passes through the step's own wrappers (their arguments as the step passes them)
    def density_grads(self) -> None:
        """The density and the cached pair gradients."""
        density_pair_gradients(self.x, self.m, self.nl.offsets, self.nl.indices, self.bx,
                               self.bV, self.nb_.offsets, self.nb_.indices, RHO0, self.h, 0, 3,
                               self.rho, self.gw, self.gwb, 0.0, V=self.V, c=self.c)

    def diagonal(self) -> None:
        """The PPE diagonal from the cached gradients."""
        diagonal_cached(self.nl.offsets, self.nb_.offsets, self.nb_.indices, self.mirror,
                        self.gw, self.gwb, 3, self.D)

    def viscosity(self) -> None:
        """The standard viscosity from the cached pair gradients, boundary term included."""
        launch(standard_body, self.n, self.x, self.v, self.m, self.rho0, self.rho,
               self.nl.offsets, self.nl.indices, self.gw, True, self.bx, self.bv, self.bV,
               self.bn, self.bd, self.bf, self.nb_.offsets, self.nb_.indices, 1e-3, 1e-3, 0.0,
               0.01, RHO0, self.h, 0, 3, 0.0, self.a)

    def jacobi(self) -> tuple[float, float]:
        """One Jacobi iteration: kappa acceleration, then the sweep with its reduction."""
        kappa_accel_cached(self.k, self.kb, self.nl.offsets, self.nl.indices, self.nb_.offsets,
                           self.nb_.indices, self.mirror, self.gw, self.gwb, 3, self.a)
        return jacobi_sweep(self.a, self.bv, self.nl.offsets, self.nl.indices,
                            self.nb_.offsets, self.nb_.indices, self.gw, self.gwb, 3, self.q,
                            self.s, 1.0, self.scale, 0.5, self.active, self.w, self.k)

    def bytes_moved(self, name: str) -> float:
        """:func:`pass_bytes` of this block (float64 fields)."""
        return pass_bytes(name, self.n, self.pairs, self.bpairs, 8)


#: the bytes model of each pass: (float words, int bytes) per particle, per fluid pair and per
#: boundary pair -- its per-particle fields once, and per pair the neighbour index (4 B) and the
#: fields it gathers or writes
_MODEL = {
    "search": ((9, 48 + 256 + 16), (3, 4), (3, 4)),
    "density+grads": ((7, 16), (7, 4), (7, 4)),
    "diagonal": ((3, 16), (4, 4), (4, 4)),
    "viscosity": ((11, 16), (8, 4), (11, 4)),
    "jacobi": ((16, 16), (14, 8), (8, 8)),
}


def pass_bytes(name: str, n: int, pairs: int, bpairs: int, word: int) -> float:
    """A model of the bytes pass ``name`` reads and writes for ``n`` particles with ``pairs``
    fluid and ``bpairs`` boundary neighbours, with ``word``-byte floats (8: float64)."""
    (fp, ip), (fq, iq), (fb, ib) = _MODEL[name]
    return n * (fp * word + ip) + pairs * (fq * word + iq) + bpairs * (fb * word + ib)


def timed(fn, sync, repeat: int) -> float:  # noqa: ANN001 - a pass and the device's wait
    """Median wall time [s] of ``fn`` over ``repeat`` runs after one warm-up run."""
    fn()
    sync()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        sync()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def copy_bandwidth() -> float:
    """Bytes/s of a device-to-device copy of 1 GB (read + write counted)."""
    from numba import cuda

    nbytes = 1 << 30 if not os.environ.get("NUMBA_ENABLE_CUDASIM") else 1 << 16
    a = cuda.device_array(nbytes // 8, np.float64)
    b = cuda.device_array(nbytes // 8, np.float64)
    t = timed(lambda: b.copy_to_device(a), cuda.synchronize, 5)
    return 2 * nbytes / t


def free_memory() -> float | None:
    """The device's free memory [B], or None where it cannot be asked (the simulator)."""
    try:
        from numba import cuda

        free = float(cuda.current_context().get_memory_info()[0])
        return free if np.isfinite(free) else None
    except Exception:  # noqa: BLE001 - the simulator has no memory to ask about
        return None


PASSES = ("search", "density+grads", "diagonal", "viscosity", "jacobi")


def run_size(n_target: int, device: str, repeat: int, iterations: int) -> dict:
    """Time the passes on one block; returns the row."""
    x, bx = block(n_target)
    free0 = free_memory() if device == "cuda" else None
    P = Passes(x, bx, device)
    P.density_grads()
    P.sync()
    free1 = free_memory() if device == "cuda" else None
    fns = {"search": P.search, "density+grads": P.density_grads, "diagonal": P.diagonal,
           "viscosity": P.viscosity, "jacobi": P.jacobi}
    t = {name: timed(fns[name], P.sync, repeat) for name in PASSES}
    step = (t["search"] + t["density+grads"] + t["diagonal"] + t["viscosity"]
            + 2 * iterations * t["jacobi"])
    row = {"device": device, "particles": P.n, "boundary": P.nb,
           "pairs_per_particle": P.pairs / P.n, "seconds": t,
           "bytes": {name: P.bytes_moved(name) for name in PASSES},
           "ported_step_s": step, "particle_steps_per_s": P.n / step,
           "memory_per_particle": None if free0 is None or free1 is None
           else (free0 - free1) / P.n}
    return row


def dam_scene(n_target: int, precision: str | None = None, depth: float | None = None,
              relax: bool = False) -> dict:
    """A 3D dam break of about ``n_target`` fluid particles (spacing 2r) with the methods that
    run on the device: DFSPH, Akinci walls with mirrored boundary pressure, the standard
    viscosity; ``precision`` None: each device's default (float32 on the GPU, float64 on the
    CPU). ``relax`` False: no relaxation of the start (sphkit's default relaxes), which would
    cost minutes on the CPU at 16M particles; the fluid sampled against the walls then starts 5 %
    too dense there, and the density solve runs to its 100 iterations in the first steps.

    ``depth`` None: a column a x 2a x a in the corner of a box 4a x 3a x a (its depth grows with
    the particle count: 1.6 m at 1M, 4 m at 16M, where the density solve no longer converges in
    its 100 iterations); ``depth`` [m]: a column of that depth and a square footprint L x L in
    the corner of a box 3L x 2 depth x L, so that the iterations per step stay those of one
    column depth at every size."""
    cfg = {"dim": 3, "particle_radius": R, "pressure": {"method": "dfsph"},
           "boundary": {"method": "akinci2012", "pressure": "mirror"},
           "start": {"relax": relax}}
    if precision is not None:
        cfg["precision"] = precision
    if depth is None:
        k = max(2, round((n_target / 2) ** (1 / 3)))
        a = k * 2 * R
        block, box = [a, 2 * a, a], [4 * a, 3 * a, a]
    else:
        layers = max(2, round(depth / (2 * R)))
        w = max(2, round(math.sqrt(n_target / layers)))
        L, H = w * 2 * R, layers * 2 * R
        block, box = [L, H, L], [3 * L, 2 * H, L]
    return {"name": "dambreak-gpu",
            "configuration": cfg,
            "materials": [{"viscosity": {"method": "standard", "coefficient": 1e-6}}],
            "fluid_blocks": [{"start": [0, 0, 0], "end": block}],
            "boxes": [{"min": [0, 0, 0], "max": box}]}


def run_steps(n_target: int, device: str, steps: int, precision: str | None = None,
              bandwidth: float | None = None, depth: float | None = None,
              relax: bool = False, warmup: int = 1) -> dict:
    """Whole DFSPH time steps of :func:`dam_scene` through ``Simulation(device=...)`` (the
    fields resident on the device): one warm-up step (compiles), then ``steps`` timed. The
    bytes a step moves are modelled as its passes' (:func:`pass_bytes`: the search, the density
    with the pair gradients, the diagonal, the viscosity and one Jacobi iteration per iteration
    of the two solves; the glue between them left out, so the model is a lower bound)."""
    from sphkit.scene.schema import Scene
    from sphkit.simulation import Simulation

    free0 = free_memory() if device == "cuda" else None
    t0 = time.perf_counter()
    sim = Simulation(Scene.model_validate(dam_scene(n_target, precision, depth, relax)),
                     device=device)
    build = time.perf_counter() - t0
    for _ in range(max(1, warmup)):  # the first compiles; the start's steps saturate the solve
        sim.step()
    free1 = free_memory() if device == "cuda" else None
    its, its_v = [], []
    t0 = time.perf_counter()
    for _ in range(steps):
        st = sim.step()
        its.append(st.iterations)
        its_v.append(st.divergence_iterations)
    t = (time.perf_counter() - t0) / steps  # each step reads its iterations' errors back: synced
    st = sim.state
    n = st.fluid.n
    pairs, bpairs = int(st.nl_ff.indices.shape[0]), int(st.nl_fb.indices.shape[0])
    word = np.dtype(st.fluid["x"].dtype).itemsize
    model = sum(pass_bytes(name, n, pairs, bpairs, word) for name in PASSES[:-1]) + (
        np.mean(its) + np.mean(its_v)) * pass_bytes("jacobi", n, pairs, bpairs, word)
    return {"device": device, "particles": n, "boundary": st.boundary.n,
            "precision": str(np.dtype(st.fluid["x"].dtype)),
            "build_s": build, "step_s": t, "steps_per_s": 1.0 / t, "particle_steps_per_s": n / t,
            "iterations": float(np.mean(its)), "divergence_iterations": float(np.mean(its_v)),
            "model_bytes_per_step": float(model), "model_bandwidth": float(model / t),
            "bandwidth_fraction": None if bandwidth is None else float(model / t / bandwidth),
            "memory_per_particle": None if free0 is None or free1 is None
            else (free0 - free1) / n}


def show_steps(row: dict) -> None:
    """Print one whole-step row."""
    mem = row["memory_per_particle"]
    frac = row["bandwidth_fraction"]
    print(f"{row['device']} ({row['precision']}): {row['particles']:,} fluid + "
          f"{row['boundary']:,} boundary particles (built in {row['build_s']:.0f} s): "
          f"{row['step_s'] * 1e3:.1f} ms a step, {row['steps_per_s']:.2f} steps/s, "
          f"{row['particle_steps_per_s']:.3e} particle-steps/s, {row['iterations']:.1f} + "
          f"{row['divergence_iterations']:.1f} iterations a step, "
          f"{row['model_bandwidth'] / 1e9:.1f} GB/s (model)"
          + (f" = {frac:.0%} of the copy bandwidth" if frac is not None else "")
          + (f", {mem:,.0f} B of GPU memory per particle" if mem is not None else ""))


def show(row: dict, bandwidth: float | None) -> None:
    """Print one size's rows."""
    n = row["particles"]
    mem = row["memory_per_particle"]
    print(f"\n{row['device']}: {n:,} fluid + {row['boundary']:,} boundary particles, "
          f"{row['pairs_per_particle']:.1f} neighbours each"
          + (f", {mem:,.0f} B of GPU memory per particle" if mem is not None else ""))
    print(f"  {'pass':<15}{'ms':>10}{'particles/s':>14}{'GB/s (model)':>14}"
          + (f"{'of copy bw':>12}" if bandwidth else ""))
    for name in PASSES:
        s = row["seconds"][name]
        gbs = row["bytes"][name] / s
        frac = f"{gbs / bandwidth:>11.0%}" if bandwidth else ""
        print(f"  {name:<15}{s * 1e3:>10.3f}{n / s:>14.3e}{gbs / 1e9:>14.1f} {frac}")
    print(f"  ported-pass step: {row['ported_step_s'] * 1e3:.2f} ms, "
          f"{row['particle_steps_per_s']:.3e} particle-steps/s")


def use_cpu_threads(n: int) -> int:
    """Give the CPU rows ``n`` Numba threads (at most those Numba started with); the count."""
    import numba

    numba.set_num_threads(max(1, min(n, numba.config.NUMBA_NUM_THREADS)))
    return numba.get_num_threads()


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; returns the exit code."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[1e6, 4e6, 16e6],
                    help="GPU block sizes (particles)")
    ap.add_argument("--cpu-size", type=float, default=1e6, help="CPU block size (0: none)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--iterations", type=int, default=5,
                    help="Jacobi iterations per solve in the ported-pass step")
    ap.add_argument("--peak", type=float, default=None,
                    help="device bandwidth [B/s] for the fraction (default: the measured copy)")
    ap.add_argument("--json", type=str, default=None, help="write the rows to this file")
    ap.add_argument("--steps", type=int, default=0,
                    help="also time this many whole DFSPH steps of a dam break at each size "
                    "(Simulation(device=...)), after the passes")
    ap.add_argument("--precision", choices=("float32", "float64"), default=None,
                    help="of the whole steps (default: each device's, float32 on the GPU)")
    ap.add_argument("--cpu-threads", type=int, default=2,
                    help="threads of the CPU rows (the issue's ratio is against two cores)")
    ap.add_argument("--only", choices=("cuda", "cpu"), default=None,
                    help="run only this device's rows (e.g. the CPU rows in a second process "
                    "beside the GPU's; --json of each, the ratio read from the two)")
    ap.add_argument("--depth", type=float, default=None,
                    help="the whole steps' column depth [m] (default: a x 2a x a, deeper with "
                    "size); e.g. 0.4: the same depth at every size, a square footprint")
    ap.add_argument("--warmup", type=int, default=1,
                    help="untimed steps before the timed ones (the first compiles; a dam break's "
                    "first steps run the density solve to its 100 iterations)")
    ap.add_argument("--relax", action="store_true",
                    help="the whole steps' scene relaxes its start (sphkit's default; minutes "
                    "on the CPU at 16M particles)")
    ap.add_argument("--no-passes", action="store_true",
                    help="skip the per-pass timings: the whole steps (--steps) only")
    args = ap.parse_args(argv)
    rows: list[dict] = []

    def save() -> None:  # after every row, so a run cut short keeps what it measured
        if args.json:
            tmp = f"{args.json}.part"
            with open(tmp, "w") as fh:
                json.dump(rows, fh, indent=1)
            os.replace(tmp, args.json)

    bw = None
    gpu = cuda_available() and args.only != "cpu"
    if args.only == "cuda":
        args.cpu_size = 0
    if gpu:
        from numba import cuda

        name = cuda.get_current_device().name if hasattr(cuda, "get_current_device") else "?"
        bw = args.peak or copy_bandwidth()
        print(f"GPU: {name.decode() if isinstance(name, bytes) else name}, "
              f"copy bandwidth {bw / 1e9:.0f} GB/s" + (" (given)" if args.peak else
                                                      " (measured, device-to-device)"))
        save()
        for n in [] if args.no_passes else args.sizes:
            row = run_size(int(n), "cuda", args.repeat, args.iterations)
            show(row, bw)
            rows.append(row)
            save()
    elif args.only != "cpu":
        print("no CUDA GPU found: the CPU rows only")
    if args.cpu_size > 0 and not args.no_passes:
        print(f"\nCPU: {use_cpu_threads(args.cpu_threads)} thread(s)")
        row = run_size(int(args.cpu_size), "cpu", max(1, min(args.repeat, 3)), args.iterations)
        show(row, None)
        rows.append(row)
        save()
        same = [r for r in rows if r["device"] == "cuda" and r["particles"] == row["particles"]]
        if same:
            g = same[0]
            print("\nGPU / CPU speed-up at the same size: "
                  + ", ".join(f"{name} {row['seconds'][name] / g['seconds'][name]:.1f}x"
                              for name in PASSES)
                  + f"; ported-pass step {row['ported_step_s'] / g['ported_step_s']:.1f}x")
    if args.steps > 0:
        print(f"\nwhole DFSPH steps of a 3D dam break ({args.steps} timed after "
              f"{max(1, args.warmup)} untimed):")
        for n in (args.sizes if gpu else []):
            rows.append(run_steps(int(n), "cuda", args.steps, args.precision, bw, args.depth,
                                  args.relax, args.warmup))
            show_steps(rows[-1])
            save()
        ratio = None
        if args.cpu_size > 0:
            use_cpu_threads(args.cpu_threads)
            rows.append(run_steps(int(args.cpu_size), "cpu", args.steps, args.precision,
                                  depth=args.depth, relax=args.relax, warmup=args.warmup))
            show_steps(rows[-1])
            save()
            same = [r for r in rows if r["device"] == "cuda" and "step_s" in r
                    and abs(r["particles"] - rows[-1]["particles"]) <= 0.01 * r["particles"]]
            if same:
                ratio = rows[-1]["step_s"] / same[0]["step_s"]
                print(f"GPU / CPU whole step at the same size: {ratio:.1f}x")
        steps = [r for r in rows if r["device"] == "cuda" and "step_s" in r]
        if steps:  # issue 18's targets
            big = max(steps, key=lambda r: r["particles"])
            print(f"targets: {big['particle_steps_per_s']:.2e} particle-steps/s at "
                  f"{big['particles']:,} particles (target 2e8 at 16M: "
                  f"{'met' if big['particle_steps_per_s'] >= 2e8 else 'missed'}); "
                  + ("no CPU ratio" if ratio is None else
                     f"{ratio:.1f}x the CPU at {rows[-1]['particles']:,} (target 50x at 1M: "
                     f"{'met' if ratio >= 50 else 'missed'})"))
    save()
    return 0


if __name__ == "__main__":
    sys.exit(main())
