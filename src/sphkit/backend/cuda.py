"""CUDA drivers for the per-particle bodies (numba.cuda; runs under NUMBA_ENABLE_CUDASIM=1).

Each body of :mod:`sphkit.core.operators` is wrapped once as a device function,
``cuda.jit(device=True)(body.py_func)``, and called from a ``cuda.jit`` kernel with one thread per
particle. The scalar ``@njit`` helpers inside the bodies (kernel value and gradient) are compiled
as device functions by numba-cuda (and called directly by the simulator), so CPU and GPU share
one source of physics (DESIGN.md, "Compute backend").

The kernels are built on first use; only importing this module imports numba.cuda (importing
sphkit itself never does).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import cuda

from sphkit.core.operators import density_body, pressure_accel_body


def available() -> bool:
    """True when numba.cuda can run kernels (a GPU, or the simulator)."""
    try:
        return bool(cuda.is_available())
    except Exception:  # noqa: BLE001 - any import/driver failure means "no CUDA"
        return False


@lru_cache(maxsize=1)
def _kernels():
    density_dev = cuda.jit(device=True)(density_body.py_func)
    pressure_dev = cuda.jit(device=True)(pressure_accel_body.py_func)

    @cuda.jit
    def density_kernel(x, m, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim, rho):
        i = cuda.grid(1)
        if i < x.shape[1]:
            rho[i] = density_dev(i, x, m, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim)

    @cuda.jit
    def pressure_kernel(x, m, rho, p, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim, a):
        i = cuda.grid(1)
        if i < x.shape[1]:
            pressure_dev(i, x, m, rho, p, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim, a)

    return density_kernel, pressure_kernel


def _launch(n: int, threads: int = 128) -> tuple[int, int]:
    return (n + threads - 1) // threads, threads


def density_cuda(x, m, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim) -> np.ndarray:
    """Densities of all fluid particles on the GPU (host arrays in, host array out)."""
    kern, _ = _kernels()
    d = [cuda.to_device(np.ascontiguousarray(a)) for a in (x, m, off, idx, bx, bV, boff, bidx)]
    rho = cuda.device_array(x.shape[1], dtype=x.dtype)
    blocks, threads = _launch(x.shape[1])
    kern[blocks, threads](*d, rho0, h, kid, dim, rho)
    return rho.copy_to_host()


def pressure_accel_cuda(x, m, rho, p, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim,
                        a) -> np.ndarray:
    """``a`` plus the symmetric pressure acceleration, computed on the GPU; returns the result."""
    _, kern = _kernels()
    d = [cuda.to_device(np.ascontiguousarray(v))
         for v in (x, m, rho, p, off, idx, bx, bV, boff, bidx)]
    da = cuda.to_device(np.ascontiguousarray(a))
    blocks, threads = _launch(x.shape[1])
    kern[blocks, threads](*d, rho0, h, kid, dim, da)
    return da.copy_to_host()
