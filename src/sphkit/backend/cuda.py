"""The CUDA side of :func:`sphkit.backend.launch` (numba-cuda; runs under
``NUMBA_ENABLE_CUDASIM=1`` too).

A body (:mod:`sphkit.backend.launch`) is compiled once as a device function,
``cuda.jit(device=True)`` of its Python source: the same source as on the CPU. The ``@njit``
helpers it calls (:mod:`sphkit.core.pairs`, :mod:`sphkit.core.kernels`, and the helpers those
call) are compiled the same way, each once, and the copy of the body that is compiled refers to
them instead of the CPU functions (:func:`device_function`): a CPU function cannot take device
arrays, and under the simulator, where device functions run as Python, the helpers then run as
Python too. A kernel with one thread per particle is generated for each body and number of
arguments (explicit parameters, no ``*args``) and kept for the process. The
reducing kernel (:func:`launch_reduce`) sums and maximizes the body's values over each block in
shared memory (a tree over :data:`THREADS` threads) and adds one partial result per block to the
output with ``cuda.atomic.add`` / ``cuda.atomic.max``.

The counting-sort primitives of :mod:`sphkit.backend.launch` are here too: :func:`histogram`
(one ``cuda.atomic.add`` per element, whose returned old value is the element's rank in its
bin) and :func:`exclusive_scan` (each block of :data:`THREADS` elements scanned in shared memory
by Hillis & Steele's doubling, the block totals scanned the same way, recursively, and added
back).

Only this module imports numba.cuda; :mod:`sphkit.backend.launch` imports it when a launch asks
for ``device="cuda"``.
"""

from __future__ import annotations

import importlib
import types
from typing import Any

import numba
import numpy as np
from numba import config, cuda
from numba.core.registry import CPUDispatcher

#: threads per block (a power of two: the block reduction halves it). The simulator runs every
#: thread of a block as a Python thread (about 0.5 ms each to start), so there a block has 16:
#: a launch over a few dozen particles then starts a few dozen threads, not 128
THREADS = 16 if config.ENABLE_CUDASIM else 128

_device_functions: dict[Any, Any] = {}
_kernels: dict[tuple[Any, int, bool], Any] = {}


def register_typed(fn: Any, typer: Any) -> None:
    """:func:`sphkit.backend.launch.register_typed` on the GPU: ``typer`` as an overload of
    ``fn`` in numba.cuda's typing, so a device function that calls ``fn`` compiles the
    implementation for its argument types (nothing under the simulator, where device functions
    run as Python and call ``fn``)."""
    if config.ENABLE_CUDASIM:
        return
    try:
        from numba.cuda.extending import overload as cuda_overload
    except ImportError:  # numba's own CUDA target: the generic overload with target="cuda"
        from numba.extending import overload

        def cuda_overload(f: Any, **kw: Any) -> Any:
            return overload(f, target="cuda", **kw)
    cuda_overload(fn, inline="always")(typer)


# the helpers registered before this module was imported (the package re-exports the function
# ``launch`` under the module's name: the module itself through importlib)
for _fn, _typer in importlib.import_module("sphkit.backend.launch").TYPED:
    register_typed(_fn, _typer)


def available() -> bool:
    """True when numba.cuda can run kernels (a GPU, or the simulator)."""
    try:
        return bool(cuda.is_available())
    except Exception:  # noqa: BLE001 - any import/driver failure means "no CUDA"
        return False


def device_function(fn: Any) -> Any:
    """The CUDA device function of the ``@njit`` function ``fn`` (a body or a helper), built once
    per function: ``cuda.jit(device=True)`` of a copy of its Python function whose global names
    that are ``@njit`` functions refer to their device functions."""
    dev = _device_functions.get(fn)
    if dev is None:
        py = fn.py_func
        scope = dict(py.__globals__)
        for name in py.__code__.co_names:
            obj = scope.get(name)
            if isinstance(obj, CPUDispatcher):
                scope[name] = device_function(obj)
        copy = types.FunctionType(py.__code__, scope, py.__name__, py.__defaults__,
                                  py.__closure__)
        copy.__qualname__ = py.__qualname__
        copy.__doc__ = py.__doc__
        dev = cuda.jit(device=True)(copy)
        _device_functions[fn] = dev
    return dev


_EACH = """
def kernel(n, {params}):
    i = cuda.grid(1)
    if i < n:
        dev(i, {params})
"""

_SUM_MAX = """
def kernel(n, out, {params}):
    tot = cuda.shared.array(THREADS, float64)
    mx = cuda.shared.array(THREADS, float64)
    t = cuda.threadIdx.x
    i = cuda.grid(1)
    e = 0.0
    if i < n:
        e = dev(i, {params})
    tot[t] = e
    mx[t] = e
    cuda.syncthreads()
    w = THREADS // 2
    while w > 0:
        if t < w:
            tot[t] += tot[t + w]
            mx[t] = max(mx[t], mx[t + w])
        cuda.syncthreads()
        w //= 2
    if t == 0:
        cuda.atomic.add(out, 0, tot[0])
        cuda.atomic.max(out, 1, mx[0])
"""


def kernel_for(body: Any, nargs: int, reduce: bool = False) -> Any:
    """The ``cuda.jit`` kernel that calls ``body``'s device function for one particle per
    thread, for ``nargs`` arguments after i (``reduce``: the (sum, max) kernel)."""
    key = (body, nargs, reduce)
    kern = _kernels.get(key)
    if kern is None:
        params = ", ".join(f"a{k}" for k in range(nargs))
        src = (_SUM_MAX if reduce else _EACH).format(params=params)
        scope = {"cuda": cuda, "dev": device_function(body), "THREADS": THREADS,
                 "float64": numba.float64, "max": max}
        exec(compile(src, f"<sphkit.backend.cuda kernel of {body.py_func.__qualname__}>",
                     "exec"), scope)
        kern = cuda.jit(scope["kernel"])
        _kernels[key] = kern
    return kern


def _blocks(n: int) -> int:
    return (n + THREADS - 1) // THREADS


def launch(body: Any, n: int, args: tuple) -> None:
    """``body(i, *args)`` for ``i < n``, one GPU thread each."""
    if n > 0:
        kernel_for(body, len(args))[_blocks(n), THREADS](n, *args)


def launch_reduce(body: Any, n: int, args: tuple) -> tuple[float, float]:
    """``(sum, max)`` of ``body(i, *args)`` over ``i < n`` (max 0 when n = 0)."""
    out = cuda.to_device(np.zeros(2))
    if n > 0:
        kernel_for(body, len(args), True)[_blocks(n), THREADS](n, out, *args)
    tot, mx = out.copy_to_host()
    return float(tot), float(mx)


@cuda.jit
def _zero(a, n):
    i = cuda.grid(1)
    if i < n:
        a[i] = 0


@cuda.jit
def _count(bins, n, counts, rank):
    i = cuda.grid(1)
    if i < n:
        rank[i] = cuda.atomic.add(counts, bins[i], 1)


def histogram(bins: Any, counts: Any, rank: Any) -> None:
    """See :func:`sphkit.backend.launch.histogram`."""
    nb = counts.shape[0]
    if nb > 0:
        _zero[_blocks(nb), THREADS](counts, nb)
    n = bins.shape[0]
    if n > 0:
        _count[_blocks(n), THREADS](bins, n, counts, rank)


@cuda.jit
def _block_scan(a, n, out, sums):
    """Inclusive scan of each block's THREADS entries of ``a`` into ``out[i + 1]``; the block's
    total into ``sums[block]``."""
    tmp = cuda.shared.array(THREADS, numba.int64)
    t = cuda.threadIdx.x
    i = cuda.grid(1)
    v = 0
    if i < n:
        v = a[i]
    tmp[t] = v
    cuda.syncthreads()
    d = 1
    while d < THREADS:
        w = 0
        if t >= d:
            w = tmp[t - d]
        cuda.syncthreads()
        tmp[t] += w
        cuda.syncthreads()
        d *= 2
    if i < n:
        out[i + 1] = tmp[t]
    if t == THREADS - 1:
        sums[cuda.blockIdx.x] = tmp[t]


@cuda.jit
def _add_block_offsets(out, n, offsets):
    i = cuda.grid(1)
    if i < n:
        out[i + 1] += offsets[cuda.blockIdx.x]
    if i == 0:
        out[0] = 0


def exclusive_scan(counts: Any, out: Any) -> int:
    """See :func:`sphkit.backend.launch.exclusive_scan`; the total is the one scalar copied
    back."""
    n = counts.shape[0]
    if n == 0:
        out[0:1].copy_to_device(np.zeros(1, dtype=out.dtype))
        return 0
    nb = _blocks(n)
    sums = cuda.device_array(nb, dtype=np.int64)
    _block_scan[nb, THREADS](counts, n, out, sums)
    offsets = cuda.device_array(nb + 1, dtype=np.int64)
    if nb > 1:
        exclusive_scan(sums, offsets)
    else:
        offsets[0:1].copy_to_device(np.zeros(1, dtype=np.int64))
    _add_block_offsets[nb, THREADS](out, n, offsets)
    return int(out[n:n + 1].copy_to_host()[0])
