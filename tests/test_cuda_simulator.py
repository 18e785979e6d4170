"""The GPU path: the density and pressure-force bodies compiled as CUDA kernels.

Runs in a subprocess with NUMBA_ENABLE_CUDASIM=1 (the simulator must be chosen before numba.cuda
is imported), on a small 2D and 3D case, and compares with the CPU prange drivers; where a CUDA
GPU is present the same script also runs on it (skipped otherwise, e.g. in CI).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent(
    """
    import numpy as np
    from sphkit.backend import cuda as bc
    from sphkit.core.kernels import lattice_volume
    from sphkit.core.neighbors import Grid, neighbor_lists
    from sphkit.core.operators import density_cpu, pressure_accel_cpu
    assert bc.available()
    rng = np.random.default_rng(3)
    for dim in (2, 3):
        r = 0.05
        h = 4 * r
        n = 6
        g = np.stack(np.meshgrid(*[np.arange(n) * 2 * r + r] * dim, indexing="ij"))
        x = g.reshape(dim, -1) + rng.uniform(-0.2 * r, 0.2 * r, (dim, n ** dim))
        bx = np.stack(np.meshgrid(*[np.arange(-1, n + 1) * 2 * r + r] * dim, indexing="ij"))
        bx = bx.reshape(dim, -1)
        bx = np.ascontiguousarray(bx[:, (bx < 0).any(axis=0)])  # a floor/wall shell below 0
        bV = rng.uniform(0.5, 1.5, bx.shape[1]) * (2 * r) ** dim
        m = np.full(x.shape[1], 1000.0 * lattice_volume(2 * r, 0, h, dim))
        nl = neighbor_lists(x, h)
        nb = Grid(bx, h).query(x)
        args = (x, m, nl.offsets, nl.indices, bx, bV, nb.offsets, nb.indices, 1000.0, h, 0, dim)
        rho = np.empty(x.shape[1])
        density_cpu(*args, rho)
        rho_gpu = bc.density_cuda(*args)
        assert np.abs(rho_gpu - rho).max() <= 1e-12 * rho.max(), np.abs(rho_gpu - rho).max()
        p = rng.uniform(0, 1e4, x.shape[1])
        a = np.zeros_like(x)
        pargs = (x, m, rho, p, nl.offsets, nl.indices, bx, bV, nb.offsets, nb.indices,
                 1000.0, h, 0, dim)
        pressure_accel_cpu(*pargs, a)
        a_gpu = bc.pressure_accel_cuda(*pargs, np.zeros_like(x))
        err = np.abs(a_gpu - a).max() / np.abs(a).max()
        assert err <= 1e-12, err
        print("dim", dim, "ok", x.shape[1], "particles")
    """
)


def test_bodies_match_cpu_under_cuda_simulator() -> None:
    """Tolerance 1e-12 relative: same formulas and summation order, only rounding differs
    (fastmath on the CPU may reassociate)."""
    _run_script(dict(os.environ, NUMBA_ENABLE_CUDASIM="1"))


def _without_simulator() -> dict:
    return {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}


def _run_script(env: dict) -> None:
    """Run SCRIPT in a subprocess with ``env``; both dimensions must report a match."""
    res = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "dim 2 ok" in res.stdout and "dim 3 ok" in res.stdout


def _cuda_gpu() -> bool:
    """Whether numba.cuda sees a real GPU (asked in a subprocess, without the simulator)."""
    try:
        res = subprocess.run([sys.executable, "-c",
                              "from numba import cuda; print(cuda.is_available())"],
                             env=_without_simulator(), capture_output=True, text=True,
                             timeout=120)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return res.returncode == 0 and res.stdout.strip().endswith("True")


@pytest.mark.skipif(not _cuda_gpu(), reason="no CUDA GPU")
def test_bodies_match_cpu_on_gpu() -> None:
    """The same kernels on a real GPU. Tolerance 1e-12 relative: the GPU contracts a * b + c
    into fused multiply-adds, which changes only the last bits of each term."""
    _run_script(_without_simulator())
