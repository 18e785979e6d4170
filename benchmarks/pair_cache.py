"""Which form of the cached pair gradients is fastest in the PPE sweeps (measured, not kept).

    python benchmarks/pair_cache.py [--radius 0.0125] [--repeat 7] [--solver dfsph]

The pressure solvers' Jacobi sweeps (:mod:`sphkit.core.ppe`) read ``V_j grad W_ij`` of every
fluid pair from a cache filled once per step: 3 components a pair, 24 bytes in float64, the
largest array of a step (about 665 B per fluid particle at 493k). Two smaller forms were
candidates for issue 22's memory line:

* **vector, float32**: the same three components in 4 bytes each (half the bytes);
* **scalar**: one factor ``f_ij = V_j W'(r_ij) / r_ij`` a pair (8 or 4 bytes), the sweep
  recomputing ``x_i - x_j`` from the positions (``grad = f_ij (x_i - x_j)``: a third of the
  bytes, one more gather of ``x_j`` per pair).

This script builds the benchmark dam break (``scenes/dambreak_<solver>.json`` at the given
particle radius), steps three steps, takes the step's neighbour lists and cached gradients, and
times the two passes that dominate an iteration written four ways: the pressure acceleration of
a field k (``a_i = -sum_j (k_i + k_j) g_ij``, as ``kappa_accel_body``) and the divergence of a
vector field (``sum_j (v_i - v_j) . g_ij``, as ``_divergence_i``), with the library's gather
fast-math flags. Runs alternate between the forms (``--repeat`` rounds), so a loaded machine
slows all alike; the minimum and the median of each are printed, with each form's bytes per
fluid particle and its largest difference from the float64 vector form.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

from sphkit.core.ppe import GATHER_FASTMATH

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from scaling import scene_at  # noqa: E402 - the scene copies live beside this script

_F = dict(cache=False, fastmath=set(GATHER_FASTMATH), parallel=True)


@numba.njit(**_F)
def accel_vector(k, off, idx, g, a):
    """``a_i = -sum_j (k_i + k_j) g_ij`` from the (3, pairs) cache g (3D)."""
    for i in numba.prange(k.shape[0]):
        ki = k[i]
        a0 = a1 = a2 = 0.0
        for kk in range(off[i], off[i + 1]):
            s = ki + k[idx[kk]]
            a0 -= s * g[0, kk]
            a1 -= s * g[1, kk]
            a2 -= s * g[2, kk]
        a[0, i] = a0
        a[1, i] = a1
        a[2, i] = a2


@numba.njit(**_F)
def accel_scalar(k, off, idx, x, f, a):
    """The same from the scalar cache f (pairs,) and the positions x (3, N)."""
    for i in numba.prange(k.shape[0]):
        ki = k[i]
        xi0, xi1, xi2 = x[0, i], x[1, i], x[2, i]
        a0 = a1 = a2 = 0.0
        for kk in range(off[i], off[i + 1]):
            j = idx[kk]
            s = (ki + k[j]) * f[kk]
            a0 -= s * (xi0 - x[0, j])
            a1 -= s * (xi1 - x[1, j])
            a2 -= s * (xi2 - x[2, j])
        a[0, i] = a0
        a[1, i] = a1
        a[2, i] = a2


@numba.njit(**_F)
def divergence_vector(v, off, idx, g, out):
    """``sum_j (v_i - v_j) . g_ij`` from the (3, pairs) cache."""
    for i in numba.prange(v.shape[1]):
        v0, v1, v2 = v[0, i], v[1, i], v[2, i]
        s = 0.0
        for kk in range(off[i], off[i + 1]):
            j = idx[kk]
            s += (v0 - v[0, j]) * g[0, kk] + (v1 - v[1, j]) * g[1, kk] + (v2 - v[2, j]) * g[2, kk]
        out[i] = s


@numba.njit(**_F)
def divergence_scalar(v, off, idx, x, f, out):
    """The same from the scalar cache and the positions."""
    for i in numba.prange(v.shape[1]):
        v0, v1, v2 = v[0, i], v[1, i], v[2, i]
        xi0, xi1, xi2 = x[0, i], x[1, i], x[2, i]
        s = 0.0
        for kk in range(off[i], off[i + 1]):
            j = idx[kk]
            s += f[kk] * ((v0 - v[0, j]) * (xi0 - x[0, j]) + (v1 - v[1, j]) * (xi1 - x[1, j])
                          + (v2 - v[2, j]) * (xi2 - x[2, j]))
        out[i] = s


def build(radius: float, solver: str):
    """The dam break's state after three steps, with this step's lists and pair gradients."""
    from sphkit.scene.files import load_scene
    from sphkit.simulation import Simulation

    with tempfile.TemporaryDirectory(prefix="sphkit-paircache-") as tmp:
        sim = Simulation(load_scene(scene_at(solver, radius, None, Path(tmp))))
    for _ in range(3):
        sim.step()
    sim._neighbors()
    sim.compute_density()
    return sim.state


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--radius", type=float, default=0.0125, help="particle radius [m]")
    ap.add_argument("--repeat", type=int, default=7, help="alternating rounds")
    ap.add_argument("--solver", default="dfsph", choices=("pcisph", "iisph", "dfsph"))
    args = ap.parse_args()
    if not args.radius > 0 or args.repeat < 1:
        ap.error(f"--radius {args.radius}, --repeat {args.repeat}: expected a positive radius "
                 "and at least one round")
    st = build(args.radius, args.solver)
    if st.dim != 3 or st.pair_grads is None:
        ap.error("expected a 3D scene whose solver caches pair gradients")
    x = np.ascontiguousarray(st.fluid["x"], dtype=np.float64)
    off, idx = st.nl_ff.offsets, st.nl_ff.indices
    g64 = np.ascontiguousarray(st.pair_grads.gw, dtype=np.float64)
    n = x.shape[1]
    rows = np.repeat(np.arange(n), np.diff(off))
    d = x[:, rows] - x[:, idx]
    f64 = (g64 * d).sum(axis=0) / (d * d).sum(axis=0)  # g = f d exactly up to round-off
    del rows, d
    forms = {"vector float64": g64, "vector float32": g64.astype(np.float32),
             "scalar float64": f64, "scalar float32": f64.astype(np.float32)}
    rng = np.random.default_rng(1)
    k, v = rng.random(n), rng.random((3, n))
    a, out = np.empty_like(x), np.empty(n)

    def run(name: str, pass_: str) -> None:
        c = forms[name]
        if pass_ == "accel":
            (accel_vector(k, off, idx, c, a) if c.ndim == 2
             else accel_scalar(k, off, idx, x, c, a))
        else:
            (divergence_vector(v, off, idx, c, out) if c.ndim == 2
             else divergence_scalar(v, off, idx, x, c, out))

    ref = {}
    for p in ("accel", "divergence"):
        run("vector float64", p)
        ref[p] = (a if p == "accel" else out).copy()
    diff = {}
    for name in forms:
        for p in ("accel", "divergence"):
            run(name, p)  # compiles
            got = a if p == "accel" else out
            diff[name, p] = float(np.abs(got - ref[p]).max() / np.abs(ref[p]).max())
    times: dict[tuple[str, str], list[float]] = {}
    for _ in range(args.repeat):
        for name in forms:
            for p in ("accel", "divergence"):
                t = time.perf_counter()
                run(name, p)
                times.setdefault((name, p), []).append(time.perf_counter() - t)
    print(f"{n} fluid particles, {idx.shape[0] / n:.1f} pairs each, {numba.get_num_threads()} "
          f"threads, {args.repeat} alternating rounds")
    print(f"{'form':16s} {'B/particle':>10s} {'pass':>11s} {'min ms':>8s} {'median ms':>10s} "
          f"{'vs vector f64':>14s} {'max rel. diff':>14s}")
    for name, c in forms.items():
        for p in ("accel", "divergence"):
            ts = sorted(times[name, p])
            base = sorted(times["vector float64", p])
            print(f"{name:16s} {c.nbytes / n:10.1f} {p:>11s} {ts[0] * 1e3:8.2f} "
                  f"{ts[len(ts) // 2] * 1e3:10.2f} {ts[len(ts) // 2] / base[len(base) // 2]:14.2f} "
                  f"{diff[name, p]:14.2e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
