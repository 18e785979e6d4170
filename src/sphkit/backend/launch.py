"""One kernel body for the CPU and the GPU: :func:`launch` and :func:`launch_reduce`
(DESIGN.md, "Compute backend").

Writing a body
--------------
A *body* holds the physics of one particle::

    @numba.njit(cache=True, fastmath=True, inline="always")
    def density_body(i, x, m, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim, rho, L):
        xi0, xi1, xi2 = point(x, i, dim)
        s = m[i] * kernel_w(kid, 0.0, h, dim)
        for k in pair_slots(off, i):
            j = idx[k]
            s += m[j] * kernel_w(kid, distance(xi0, xi1, xi2, x, j, dim, L), h, dim)
        ...  # the boundary neighbours
        rho[i] = s

    launch(density_body, n, x, m, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim, rho, L)

Its first argument is the particle index i; the others are arrays (NumPy or CUDA device arrays)
and scalars (int, float, bool), never Python objects. It reads what it needs, writes the outputs
of particle i (``rho[i]``, ``a[:, i]``; it must not write another particle's entries), allocates
nothing, raises nothing, and calls only the scalar ``inline="always"`` helpers of
:mod:`sphkit.core.pairs` and :mod:`sphkit.core.kernels` (or other such helpers). It is compiled
with ``numba.njit(inline="always")`` (not ``parallel``) and the fast-math flags its pass needs;
the flags travel with it (the passes over cached pair values use
:data:`sphkit.core.ppe.GATHER_FASTMATH`).

Running it
----------
``launch(body, n, *args, device=None)`` runs ``body(i, *args)`` for ``i = 0 .. n-1`` on the
device its arrays are on (:func:`device_of`: ``"cuda"`` as soon as one argument is a CUDA device
array, else ``"cpu"``; a ``device`` given explicitly overrides it), so the code around a launch
is the same for both devices: the data decide where it runs (DESIGN.md: the state stays on the
device between steps, in the same ParticleSet fields):

* ``device="cpu"`` (default): a ``numba.prange`` loop over i that calls the body. The loop (the
  *driver*) is generated once per body and number of arguments, with explicit parameters, and
  compiled with ``parallel=True``, ``cache=True`` and the body's own ``fastmath`` flags. Numba
  splices the ``inline="always"`` body into it before type inference, so the driver is the loop
  one would write by hand around the body's code, and as fast. (Measured on the DFSPH benchmark
  scene, 6,859 particles, one thread: :func:`sphkit.core.ppe.kappa_accel_cached` took 228 us
  written by hand, 220 us as an inlined body, 339 us as a body called as a separate function and
  418 us called through ``*args``: the call blocks the optimizations across the pair loops.)
  The driver is cached on disk next to the body (``__pycache__`` of the body's module, named
  after the body): a second process loads it instead of compiling it, and editing the body's
  file invalidates it as it does the body. (A closure or a function-typed argument would not do:
  Numba keys their cache entries on objects that differ in every process.)
  A body parameter named in :data:`CONSTANT_PARAMS` (the kernel id ``kid``) is compiled into
  the driver as a constant: one driver per value met (named after it, so each has its own cache
  entry), in which the kernel's dispatch (:func:`sphkit.core.kernels.kernel_w`: the cubic
  spline inlined, the other kernels one call away) folds to the kernel in use. Without the call
  in the pair loop the compiler vectorises it: the standard viscosity's pass took 0.87 ms with
  the id as an argument and 0.51 ms with it a constant, the densities and pair gradients 0.78
  and 0.66 ms (DFSPH benchmark scene, 6,859 particles, two threads; ``benchmarks/README.md``).
  :func:`specialize` sets other constants for a body (the dimension of the pressure solvers'
  iteration passes) or none (a body whose vectorised form is slower).
* ``device="cuda"``: the body is compiled once as a CUDA device function
  (``cuda.jit(device=True)`` of its Python source: the same source, the helpers it calls become
  device functions too) and called from a generated ``cuda.jit`` kernel with one thread per
  particle (:mod:`sphkit.backend.cuda`, which is imported only then: importing sphkit or running
  on the CPU never imports ``numba.cuda``). Arrays should be device arrays (they stay on the
  device); host arrays are copied in and back by numba.cuda on every launch.

Reductions
----------
A body may instead *return* a per-particle value ``e_i >= 0`` (e.g. a residual; 0 for particles
that do not count). ``launch_reduce(body, n, *args, device=...)`` runs it like :func:`launch`
and returns ``(sum_i e_i, max(0, max_i e_i))`` as Python floats. On the CPU the sum and the
maximum are reduced in the same ``prange`` loop (no per-particle array, no second pass over
memory); on the GPU each block reduces its values in shared memory and adds them to the result
with one atomic operation per block. The two sums are added in different orders, so they agree
to rounding, not bit for bit. ``launch_sum(body, n, *args)`` returns the sum alone, of values
of any sign (a dot product: :mod:`sphkit.core.krylov`); on the CPU its loop holds only the sum,
which the compiler vectorises as it does a hand-written ``prange`` sum (with the maximum in the
same loop it does not: the last bits of a long sum differ).

Primitives that are not per-particle bodies
-------------------------------------------
Two steps of a counting sort write entries that belong to no single particle, and a few array
helpers hide where the arrays live; each has a CPU and a CUDA version:

* :func:`histogram`: ``counts[b]`` = how many ``bins[i] == b``, and ``rank[i]`` = the place of i
  within its bin (index order on the CPU; the order of the atomic increments on the GPU, which
  is not reproducible from run to run);
* :func:`exclusive_scan`: ``out[0] = 0``, ``out[k + 1] = out[k] + counts[k]`` (on the GPU a
  block-wise Hillis-Steele scan in shared memory, the block totals scanned recursively); returns
  the total, the one scalar read back;
* :func:`empty`, :func:`to_device`, :func:`to_host`: allocate on, copy to and copy from the
  device (NumPy arrays, unchanged, on the CPU).
"""

from __future__ import annotations

import ctypes
import functools
import os
import sys
import types
from typing import Any

import numba
import numpy as np
from numba.extending import overload

#: the devices :func:`launch` knows
DEVICES = ("cpu", "cuda")


# the CPU drivers, written out for a number of arguments; ``body`` is bound per body
_EACH = """
def driver(n, {params}):
    for i in numba.prange(n):
        body(i, {params})
"""
_SUM_MAX = """
def driver(n, {params}):
    tot = 0.0
    mx = 0.0
    for i in numba.prange(n):
        e = body(i, {params})
        tot += e
        mx = max(mx, e)
    return tot, mx
"""
_SUM = """
def driver(n, {params}):
    tot = 0.0
    for i in numba.prange(n):
        tot += body(i, {params})
    return tot
"""
_TEMPLATES = {"each": _EACH, "sum_max": _SUM_MAX, "sum": _SUM}
#: body parameters that the CPU driver compiles in as constants, one driver per value (module
#: docstring): the kernel id, whose value selects the kernel's code in every pair loop
CONSTANT_PARAMS = ("kid",)
_codes: dict[tuple[str, int, tuple[int, ...]], types.CodeType] = {}
_drivers: dict[tuple[Any, str, int, tuple[int, ...]], Any] = {}
_constant_at: dict[Any, tuple[int, ...]] = {}
_specialized: dict[Any, tuple[str, ...]] = {}
_fastmath_when: dict[Any, dict[str, Any]] = {}


def _template(kind: str, nargs: int, constants: tuple[int, ...] = ()) -> types.CodeType:
    """The code object of the driver template ``kind`` for ``nargs`` arguments after i; the
    arguments at the positions ``constants`` reach the body as the globals ``c<k>`` (the
    driver's own parameters stay, unused, so its signature is the body's)."""
    key = (kind, nargs, constants)
    if key not in _codes:
        params = ", ".join(f"a{k}" for k in range(nargs))
        src = _TEMPLATES[kind].format(params=params)
        if constants:
            passed = ", ".join(f"c{k}" if k in constants else f"a{k}" for k in range(nargs))
            src = src.replace(f"body(i, {params})", f"body(i, {passed})")
        scope: dict = {}
        exec(compile(src, "<sphkit.backend.launch driver>", "exec"), scope)
        _codes[key] = scope["driver"].__code__
    return _codes[key]


def _params(body: Any) -> tuple[str, ...]:
    """The names of ``body``'s parameters after i."""
    code = body.py_func.__code__
    return code.co_varnames[1:code.co_argcount]


def constant_positions(body: Any) -> tuple[int, ...]:
    """The positions (after i) of ``body``'s constant parameters: those named in
    :data:`CONSTANT_PARAMS`, or those given to :func:`specialize`."""
    pos = _constant_at.get(body)
    if pos is None:
        constant = _specialized.get(body, CONSTANT_PARAMS)
        pos = tuple(k for k, name in enumerate(_params(body)) if name in constant)
        _constant_at[body] = pos
    return pos


def specialize(body: Any, *names: str, fastmath_when: dict[str, Any] | None = None) -> Any:
    """Make ``body``'s constant parameters (compiled into its CPU drivers, one driver per value)
    exactly ``names`` instead of :data:`CONSTANT_PARAMS` (returns the body). Three uses:

    * more constants for the few passes that run many times a step, where a driver per value
      pays for its compilation: the dimension ``dim`` made constant takes 9-12 % off the
      pressure solvers' two iteration passes (DFSPH benchmark scene, 59,319 particles, two
      threads), in which the dimension's tests in every pair's gather stay otherwise, and lets
      the compiler unroll and vectorise the element loops over a vector's rows (PCISPH's
      prediction, 13.6 calls a step: 0.023 -> 0.006 ms at 6,859 particles); every body's would
      double the drivers compiled for a test run that covers 2D and 3D;
    * none, for a body that the constant kernel id makes slower: the vectorised form the
      compiler then chooses for some pair loops is slower than the scalar one (the volume maps'
      wall moments 0.27 -> 0.30 ms, 6,859 particles, two threads; every other body of the six
      benchmark scenes ran 15-40 % faster);
    * a switch beside the kernel id, where a branch left in the loop keeps the vectorised form
      slow: PBF's position correction with its artificial-pressure switch an argument ran 1.8x
      slower with the id a constant, and with both constants 0.87 -> 0.47 ms.

    ``fastmath_when`` ``{name: flags}``: the drivers in which the constant ``name`` is true are
    compiled with ``flags`` instead of the body's own, for a switch between a pair loop that
    evaluates the kernel (faster vectorised, ``fastmath=True``) and one that reads cached pair
    values (faster scalar, :data:`sphkit.core.ppe.GATHER_FASTMATH`): the standard viscosity's
    pass over the cached pair gradients, 3.3 -> 2.8 ms at 59,319 particles (two threads).
    """
    for name in (*names, *(fastmath_when or {})):
        if name not in _params(body):
            raise ValueError(f"{body.py_func.__name__}: no parameter {name!r} to specialize on")
    if not set(fastmath_when or {}) <= set(names):
        raise ValueError(f"{body.py_func.__name__}: fastmath_when names a parameter that is "
                         f"not constant; expected some of {names}")
    _specialized[body] = tuple(names)
    _fastmath_when[body] = dict(fastmath_when or {})
    _constant_at.pop(body, None)
    return body


def cpu_driver(body: Any, nargs: int, kind: str = "each", values: tuple[int, ...] = ()) -> Any:
    """The compiled CPU driver of ``body`` for ``nargs`` arguments after i (``kind`` ``"each"``:
    :func:`launch`, ``"sum_max"``: :func:`launch_reduce`, ``"sum"``: :func:`launch_sum`), built
    on first use and kept for the process; ``values``: those of the body's constant parameters
    (:func:`constant_positions`, in order), compiled in.

    The driver is the template's code with ``body`` bound as a global (not a closure) and with
    the body's file, first line and name (plus ``__launch_<kind>`` and, for each constant,
    ``__<name><value>``), so that Numba's cache stores it beside the body and checks it against
    the body's source file."""
    key = (body, kind, nargs, values)
    drv = _drivers.get(key)
    if drv is None:
        py = body.py_func
        pos = constant_positions(body) if values else ()
        if len(pos) != len(values):
            raise ValueError(f"{py.__name__}: {len(values)} constant values for the "
                             f"{len(pos)} constant parameters")
        names = _params(body)
        tag = "".join(f"__{names[k]}{int(v)}" for k, v in zip(pos, values, strict=True))
        name = f"{py.__name__}__launch_{kind}{tag}"
        qualname = f"{py.__qualname__}__launch_{kind}{tag}"
        code = _template(kind, nargs, pos).replace(
            co_filename=py.__code__.co_filename, co_firstlineno=py.__code__.co_firstlineno,
            co_name=name, co_qualname=qualname)
        scope = {"numba": numba, "body": body, "max": max}
        scope.update({f"c{k}": int(v) for k, v in zip(pos, values, strict=True)})
        fn = types.FunctionType(code, scope, name)
        fn.__qualname__ = qualname
        fn.__module__ = py.__module__
        fastmath = body.targetoptions.get("fastmath", False)
        when = _fastmath_when.get(body, {})
        for k, v in zip(pos, values, strict=True):
            if v and names[k] in when:  # specialize(..., fastmath_when=...)
                fastmath = when[names[k]]
        drv = numba.njit(parallel=True, cache=True, fastmath=fastmath)(fn)
        _drivers[key] = drv
    return drv


def _cpu(body: Any, args: tuple, kind: str) -> Any:
    """The CPU driver of ``body`` for these arguments (the values of its constant parameters
    among them)."""
    pos = _constant_at.get(body)
    if pos is None:
        pos = constant_positions(body)
    values = tuple([int(args[k]) for k in pos]) if pos else ()
    drv = _drivers.get((body, kind, len(args), values))  # the usual case: made before
    return drv if drv is not None else cpu_driver(body, len(args), kind, values)


#: the helpers compiled by their arguments' types (:func:`register_typed`) and their typing
#: functions; :mod:`sphkit.backend.cuda` registers them with numba.cuda when it is imported
TYPED: list[tuple[Any, Any]] = []


def register_typed(fn: Any, typer: Any) -> None:
    """Compile calls of the Python function ``fn`` in kernel bodies by ``typer`` (a Numba
    ``overload``: ``typer`` gets the arguments' Numba types and returns the implementation for
    them), on the CPU and on the GPU. For a choice by an argument's type (a float or a tuple):
    numba-cuda does not prune an ``isinstance`` branch as Numba's CPU compiler does, so the
    branch for the other type would be typed too and fail. Under the CUDA simulator device
    functions run as Python and call ``fn`` itself."""
    overload(fn, inline="always")(typer)
    TYPED.append((fn, typer))
    cuda_side = sys.modules.get("sphkit.backend.cuda")
    if cuda_side is not None:  # already imported: register there now
        cuda_side.register_typed(fn, typer)


#: the CUDA driver's library by platform (what numba-cuda loads; none on macOS)
_DRIVER = {"win32": ("nvcuda.dll",), "darwin": ()}


def _cuda_driver_present() -> bool:
    """Whether the CUDA driver's library can be loaded (a fraction of a millisecond, without
    importing ``numba.cuda``); ``NUMBA_CUDA_DRIVER`` (a driver of its own) and the CUDA
    simulator (``NUMBA_ENABLE_CUDASIM=1``) are left to numba-cuda to judge."""
    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1" or os.environ.get("NUMBA_CUDA_DRIVER"):
        return True
    for name in _DRIVER.get(sys.platform, ("libcuda.so.1", "libcuda.so")):
        try:
            ctypes.CDLL(name)
            return True
        except OSError:
            continue
    return False


@functools.cache
def cuda_available() -> bool:
    """Whether numba-cuda finds a usable CUDA GPU (asked once a process). Without a CUDA
    driver the answer is no at once; else ``numba.cuda`` is imported to ask (about 0.5 s, and
    :func:`device_of` then looks at its arguments): ask only when the answer matters."""
    if not _cuda_driver_present():
        return False
    try:
        from numba import cuda

        return bool(cuda.is_available())
    except Exception:  # noqa: BLE001 - a broken driver or toolkit means no GPU to run on
        return False


def _check(device: str) -> None:
    if device not in DEVICES:
        raise ValueError(f"device: {device!r}; expected one of {', '.join(DEVICES)}")


def on_device(a: Any) -> bool:
    """Whether ``a`` is a CUDA device array (numba.cuda's, or the simulator's)."""
    return hasattr(a, "copy_to_host")


#: argument types that are never device arrays (:func:`device_of` skips them without asking)
_HOST_TYPES = frozenset({np.ndarray, int, float, bool})


def device_of(*arrays: Any) -> str:
    """``"cuda"`` when one of ``arrays`` is a device array, else ``"cpu"``: the device a launch
    over them runs on. Device arrays exist only once ``numba.cuda`` (or its simulator) has been
    imported; before, every array is a host array and none is looked at (about 75 calls a DFSPH
    step, a fixed cost of small scenes)."""
    if "numba.cuda" not in sys.modules:
        return "cpu"
    for a in arrays:
        if type(a) not in _HOST_TYPES and hasattr(a, "copy_to_host"):
            return "cuda"
    return "cpu"


def launch(body: Any, n: int, *args: Any, device: str | None = None) -> None:
    """Run ``body(i, *args)`` for ``i`` in ``range(n)`` on ``device`` ("cpu" or "cuda"; None:
    where the arrays are, :func:`device_of`); see the module docstring."""
    if device is None:
        device = device_of(*args)
    _check(device)
    if device == "cpu":
        _cpu(body, args, "each")(n, *args)
    else:
        from sphkit.backend import cuda

        cuda.launch(body, n, args)


def launch_reduce(body: Any, n: int, *args: Any,
                  device: str | None = None) -> tuple[float, float]:
    """Run the value-returning ``body(i, *args)`` for ``i`` in ``range(n)`` on ``device`` (None:
    where the arrays are) and return ``(sum, max)`` of its values (the maximum is 0 when there
    are none); see the module docstring."""
    if device is None:
        device = device_of(*args)
    _check(device)
    if device == "cpu":
        tot, mx = _cpu(body, args, "sum_max")(n, *args)
        return float(tot), float(mx)
    from sphkit.backend import cuda

    return cuda.launch_reduce(body, n, args)


def launch_sum(body: Any, n: int, *args: Any, device: str | None = None) -> float:
    """The sum of the value-returning ``body(i, *args)`` over ``i`` in ``range(n)`` (values of
    any sign; None: where the arrays are). On the CPU the loop holds the sum alone, as a
    hand-written ``prange`` sum would (the maximum of :func:`launch_reduce` in the same loop
    changes how the compiler vectorises the sum, and so its last bits)."""
    if device is None:
        device = device_of(*args)
    _check(device)
    if device == "cpu":
        return float(_cpu(body, args, "sum")(n, *args))
    from sphkit.backend import cuda

    return cuda.launch_reduce(body, n, args)[0]


@numba.njit(cache=True)
def _histogram(bins, counts, rank):
    for b in range(counts.shape[0]):
        counts[b] = 0
    for i in range(bins.shape[0]):
        b = bins[i]
        rank[i] = counts[b]
        counts[b] += 1


@numba.njit(cache=True)
def _exclusive_scan(counts, out):
    s = 0
    out[0] = 0
    for k in range(counts.shape[0]):
        s += counts[k]
        out[k + 1] = s
    return s


def histogram(bins: Any, counts: Any, rank: Any, device: str = "cpu") -> None:
    """Count the integer ``bins`` (N,) into ``counts`` (zeroed here; one entry per bin, every
    bin index below its length) and write each element's ``rank`` (N,) within its bin."""
    _check(device)
    if device == "cpu":
        _histogram(bins, counts, rank)
    else:
        from sphkit.backend import cuda

        cuda.histogram(bins, counts, rank)


def exclusive_scan(counts: Any, out: Any, device: str = "cpu") -> int:
    """``out[0] = 0`` and ``out[k + 1] = sum(counts[:k + 1])`` (``out`` has one more entry than
    ``counts``); returns the total."""
    _check(device)
    if out.shape[0] != counts.shape[0] + 1:
        raise ValueError(f"exclusive_scan: out has {out.shape[0]} entries for "
                         f"{counts.shape[0]} counts; expected one more")
    if device == "cpu":
        return int(_exclusive_scan(counts, out))
    from sphkit.backend import cuda

    return cuda.exclusive_scan(counts, out)


def empty(shape: int | tuple[int, ...], dtype: Any, device: str = "cpu") -> Any:
    """An uninitialised array on ``device``."""
    _check(device)
    if device == "cpu":
        return np.empty(shape, dtype=dtype)
    from numba import cuda as nbcuda

    return nbcuda.device_array(shape, dtype=dtype)


def to_device(a: Any, device: str = "cpu") -> Any:
    """``a`` on ``device`` (a contiguous copy there; the array itself on the CPU)."""
    _check(device)
    if device == "cpu":
        return a
    from numba import cuda as nbcuda

    return nbcuda.to_device(np.ascontiguousarray(a))


def to_host(a: Any) -> np.ndarray:
    """A NumPy array of ``a`` (a copy from the device, or ``a`` itself)."""
    return a.copy_to_host() if hasattr(a, "copy_to_host") else np.asarray(a)
