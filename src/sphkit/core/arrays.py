"""Element-wise passes over particle arrays as kernel bodies: the glue of a time step (fills,
copies, ``y += a x``, products and quotients of fields, gathers) written once for the CPU and
the GPU (:func:`sphkit.backend.launch` runs them where their arrays are).

The bodies are compiled *without* fast math: each does exactly the IEEE operations NumPy's
element-wise expression of the same formula does, in the same order (``v + dt * a`` is one
product and one sum, both rounded, never a fused multiply-add; ``x / d`` a true division, never
a product with a reciprocal), so replacing a NumPy expression by its body leaves the CPU's
results unchanged to the last bit. A scalar factor is passed in the array's own precision, as
NumPy casts a Python float for a float32 array, so float32 fields are computed in float32 as
there. (On a GPU the compiler may still fuse a product and a sum:
results agree with the CPU's to rounding.)

The allocating helpers (:func:`empty`, :func:`zeros`, :func:`full`) put the array on the device
of ``like`` (NumPy's own functions on the CPU).
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from sphkit.backend import device_of, launch, launch_reduce, on_device, specialize, to_host
from sphkit.backend import empty as backend_empty
from sphkit.core.pairs import set_vector

#: the passes and helpers, and where arrays are (the step reaches the backend through core)
__all__ = ["above_body", "absent", "add_body", "added", "any_above", "any_differs", "axpy",
           "axpy_body", "axpy_into", "axpy_rows_body", "axpy_rows_into_body", "copied",
           "copy_body", "copy_into", "differs_body", "divide_body", "divided", "divided_by",
           "empty", "empty_like", "fill", "fill_body", "fill_rows", "fill_rows_body", "full",
           "gather_body", "gather_rows_body", "gathered", "multiplied", "multiply_body",
           "on_device", "quotient_body", "reciprocal", "reciprocal_body", "scale_body", "scaled",
           "Scratch", "to_host", "zeros"]

_BODY = dict(cache=True, inline="always")


@numba.njit(**_BODY)
def fill_body(i, out, value):
    """``out[i] = value``."""
    out[i] = value


@numba.njit(**_BODY)
def fill_rows_body(i, out, v0, v1, v2, dim):
    """``out[:, i] = (v0, v1, v2)[:dim]`` (gravity into the accelerations)."""
    set_vector(out, i, dim, v0, v1, v2)


specialize(fill_rows_body, "dim")  # an element loop: unrolled per dimension


@numba.njit(**_BODY)
def axpy_rows_body(i, y, alpha, x, dim):
    """``y[:, i] += alpha * x[:, i]``."""
    for d in range(dim):
        y[d, i] += alpha * x[d, i]


specialize(axpy_rows_body, "dim")  # an element loop: unrolled per dimension


@numba.njit(**_BODY)
def axpy_body(i, y, alpha, x):
    """``y[i] += alpha * x[i]``."""
    y[i] += alpha * x[i]


@numba.njit(**_BODY)
def axpy_rows_into_body(i, y, alpha, x, out, dim):
    """``out[:, i] = y[:, i] + alpha * x[:, i]``."""
    for d in range(dim):
        out[d, i] = y[d, i] + alpha * x[d, i]


specialize(axpy_rows_into_body, "dim")  # an element loop: unrolled per dimension


@numba.njit(**_BODY)
def scale_body(i, x, alpha, out):
    """``out[i] = x[i] * alpha``."""
    out[i] = x[i] * alpha


@numba.njit(**_BODY)
def divide_body(i, x, d, out):
    """``out[i] = x[i] / d``."""
    out[i] = x[i] / d


@numba.njit(**_BODY)
def add_body(i, x, y, out):
    """``out[i] = x[i] + y[i]``."""
    out[i] = x[i] + y[i]


@numba.njit(**_BODY)
def multiply_body(i, x, y, out):
    """``out[i] = x[i] * y[i]``."""
    out[i] = x[i] * y[i]


@numba.njit(**_BODY)
def reciprocal_body(i, x, out):
    """``out[i] = 1 / x[i]``."""
    out[i] = 1.0 / x[i]


@numba.njit(**_BODY)
def differs_body(i, x, value):
    """1 where ``x[i] != value``, else 0 (reduced: does any entry differ)."""
    return 1.0 if x[i] != value else 0.0


@numba.njit(**_BODY)
def copy_body(i, x, out):
    """``out[i] = x[i]`` (converted to ``out``'s type)."""
    out[i] = x[i]


@numba.njit(**_BODY)
def above_body(i, x, value):
    """1 where ``x[i] > value``, else 0 (reduced: is any entry above)."""
    return 1.0 if x[i] > value else 0.0


@numba.njit(**_BODY)
def gather_body(i, src, perm, out):
    """``out[i] = src[perm[i]]``."""
    out[i] = src[perm[i]]


@numba.njit(**_BODY)
def gather_rows_body(i, src, perm, out, rows):
    """``out[:, i] = src[:, perm[i]]``."""
    j = perm[i]
    for d in range(rows):
        out[d, i] = src[d, j]


def empty(shape: int | tuple[int, ...], dtype: Any, like: Any) -> Any:
    """An uninitialised array on the device of ``like`` (an empty one on the GPU too)."""
    dev = device_of(like)
    if dev == "cpu":
        return np.empty(shape, dtype=dtype)
    shape = (shape,) if isinstance(shape, int | np.integer) else tuple(shape)
    if 0 in shape:  # a zero-size allocation on the device: slice one of a single entry
        one = backend_empty(tuple(max(s, 1) for s in shape), dtype, dev)
        return one[tuple(slice(0, s) for s in shape)]
    return backend_empty(shape, dtype, dev)


class Scratch:
    """One block of CPU memory reused, step after step, for the step's largest temporaries that
    never live at the same time: the neighbour search's fixed-stride rows (fluid-fluid, then
    fluid-boundary) and the simulation's pair-gradient cache.

    A fresh array of tens of megabytes is mapped anew by the C allocator on every step (above
    glibc's mmap threshold they always are) and each of its pages is faulted in and zeroed by
    the kernel as the pass first writes it; the block is allocated once and grows only when a
    step needs more (by :attr:`GROWTH`). :meth:`take` hands out views into it: **a take
    invalidates every view taken before** (their memory is reused), so only a holder that is
    done with its views before the next take may use the block. The simulation's step is such a
    holder (:class:`sphkit.core.state.SimState` ``scratch``; measured in benchmarks/README.md,
    "The step's large temporaries in one block").
    """

    #: the block grows to this times what a take asks for, so that the next steps' slightly
    #: larger lists fit without a new block
    GROWTH: float = 1.125
    #: every view starts on a multiple of this many bytes (a cache line): the compiled passes'
    #: vector loops then meet the same alignment in every step and every run
    ALIGN: int = 64

    def __init__(self) -> None:
        self._block = np.empty(0, dtype=np.float64)
        self._raw = self._block.view(np.uint8)  # the block's bytes
        self._first = 0  # the first aligned byte of the block
        self._views: dict[tuple, list[np.ndarray]] = {}  # the last takes' views, by their specs
        self._kept: dict[str, Scratch] = {}
        #: per slot, the row width (slots per query point) its neighbour search last grew to:
        #: the next step's search starts there instead of overflowing and searching twice
        #: (:meth:`sphkit.core.neighbors.Grid.query`)
        self.widths: dict[str, int] = {}

    @property
    def nbytes(self) -> int:
        """The block's size in bytes."""
        return int(self._block.nbytes)

    def take(self, *specs: tuple[tuple[int, ...], Any]) -> list[np.ndarray]:
        """C-contiguous arrays of the given ``(shape, dtype)`` laid one after the other in the
        block, each starting on :attr:`ALIGN` bytes; their contents are undefined. The same
        specs give the same views while the block stands (a step's searches ask for the same
        rows every step)."""
        views = self._views.get(specs)
        if views is not None:
            return views
        a = self.ALIGN
        sizes = [math.prod(shape) * np.dtype(dt).itemsize for shape, dt in specs]
        spans = [(n + a - 1) // a * a for n in sizes]
        need = sum(spans) + a  # + a: room to align the first view
        if need > self._block.nbytes:
            self._block = np.empty(int(need * self.GROWTH) // 8 + 1, dtype=np.float64)
            self._raw = self._block.view(np.uint8)
            self._first = -self._raw.ctypes.data % a
            self._views = {}
        raw, at = self._raw, self._first
        out = []
        for (shape, dt), n, span in zip(specs, sizes, spans, strict=True):
            out.append(raw[at:at + n].view(dt).reshape(shape))
            at += span
        if len(self._views) >= 8:  # the pair caches' sizes change every step
            self._views = {}
        self._views[specs] = out
        return out

    def kept(self, slot: str, size: int, dtype: Any) -> np.ndarray:
        """A 1D array of ``size`` entries of ``dtype`` (contents undefined) in memory of its own
        kept for ``slot`` from step to step (a :class:`Scratch` of the slot's own, so grown and
        aligned as :meth:`take`): for results that live through the step while :meth:`take`
        reuses the block, such as the step's neighbour lists (the fluid's 55 MB of indices at
        493k particles were mapped and faulted in afresh every step: their compaction 17 -> 4
        ms). **A view stays valid until the next call for the same slot**, which reuses its
        memory."""
        if slot not in self._kept:
            self._kept[slot] = Scratch()
        return self._kept[slot].take(((size,), dtype))[0]


_ABSENT: dict[tuple[tuple[int, ...], np.dtype], np.ndarray] = {}


def absent(shape: int | tuple[int, ...], dtype: Any, like: Any) -> Any:
    """An array with no entries (a ``shape`` with a 0) of ``dtype`` on the device of ``like``:
    what a kernel body reads as "no such array" (no weights, no boundary sums). On the CPU one
    array per shape and type, kept for the process (nothing can be written into it): the
    iteration passes ask for a few every sweep."""
    if device_of(like) != "cpu":
        return empty(shape, dtype, like)
    key = ((shape,) if isinstance(shape, int) else tuple(shape), np.dtype(dtype))
    a = _ABSENT.get(key)
    if a is None:
        if 0 not in key[0]:
            raise ValueError(f"absent: shape {shape} has entries; expected a 0 in it")
        a = _ABSENT[key] = np.empty(key[0], dtype=key[1])
    return a


def empty_like(a: Any) -> Any:
    """An uninitialised array of ``a``'s shape and dtype, where ``a`` is."""
    return empty(a.shape, a.dtype, a)


def fill(a: Any, value: float) -> None:
    """Every entry of the C-contiguous ``a`` (on either device) set to ``value``."""
    if a.size:
        launch(fill_body, a.size, a.reshape(a.size), value)


def full(shape: int | tuple[int, ...], value: float, dtype: Any, like: Any) -> Any:
    """An array of ``value`` on the device of ``like`` (``np.full`` on the CPU)."""
    if device_of(like) == "cpu":
        return np.full(shape, value, dtype=dtype)
    out = empty(shape, dtype, like)
    fill(out, value)
    return out


def zeros(shape: int | tuple[int, ...], dtype: Any, like: Any) -> Any:
    """Zeros on the device of ``like``."""
    return full(shape, 0, dtype, like)


def fill_rows(a: Any, values: np.ndarray) -> None:
    """``a[:, i] = values`` for every column of ``a`` (dim, N)."""
    v = [float(t) for t in values] + [0.0] * (3 - len(values))
    launch(fill_rows_body, a.shape[1], a, v[0], v[1], v[2], a.shape[0])


def axpy(y: Any, alpha: float, x: Any) -> None:
    """``y += alpha * x`` for (dim, N) or (N,) arrays (``y += x`` with alpha 1, exactly)."""
    if y.ndim == 1:
        launch(axpy_body, y.shape[0], y, y.dtype.type(alpha), x)
    else:
        launch(axpy_rows_body, y.shape[1], y, y.dtype.type(alpha), x, y.shape[0])


def axpy_into(y: Any, alpha: float, x: Any) -> Any:
    """A new (dim, N) array ``y + alpha * x``."""
    out = empty_like(y)
    launch(axpy_rows_into_body, y.shape[1], y, y.dtype.type(alpha), x, out, y.shape[0])
    return out


def scaled(x: Any, alpha: float, out: Any = None) -> Any:
    """``x * alpha`` (N,) into ``out`` (new when None)."""
    out = empty_like(x) if out is None else out
    launch(scale_body, x.shape[0], x, x.dtype.type(alpha), out)
    return out


def divided(x: Any, d: float) -> Any:
    """A new (N,) array ``x / d``."""
    out = empty_like(x)
    launch(divide_body, x.shape[0], x, x.dtype.type(d), out)
    return out


def multiplied(x: Any, y: Any, out: Any = None) -> Any:
    """``x * y`` (N,) into ``out`` (new when None)."""
    out = empty_like(x) if out is None else out
    launch(multiply_body, x.shape[0], x, y, out)
    return out


def reciprocal(x: Any) -> Any:
    """A new (N,) array ``1 / x``."""
    out = empty_like(x)
    launch(reciprocal_body, x.shape[0], x, out)
    return out


def any_differs(x: Any, value: float) -> bool:
    """Whether an entry of the (N,) array ``x`` differs from ``value`` (one scalar read back
    from the device)."""
    return launch_reduce(differs_body, x.shape[0], x, value)[1] > 0.0


def copy_into(out: Any, a: Any) -> None:
    """``out[...] = a`` for C-contiguous arrays of the same size (``out[:] = a``)."""
    if a.size:
        launch(copy_body, a.size, a.reshape(a.size), out.reshape(out.size))


def copied(a: Any, dtype: Any = None) -> Any:
    """A C-contiguous copy of ``a`` (of ``dtype``; None: ``a``'s), where ``a`` is
    (``np.array(a, dtype=dtype)`` on the CPU)."""
    if device_of(a) == "cpu":
        return np.array(a, dtype=dtype)
    out = empty(a.shape, a.dtype if dtype is None else dtype, a)
    copy_into(out, a)
    return out


def any_above(x: Any, value: float) -> bool:
    """Whether an entry of the (N,) array ``x`` is above ``value`` (``np.any(x > value)``; one
    scalar read back from the device)."""
    return launch_reduce(above_body, x.shape[0], x, value)[1] > 0.0


def gathered(a: Any, perm: Any) -> Any:
    """A new array of ``a`` (N,) or (rows, N) with its columns taken at ``perm`` (N,)."""
    out = empty_like(a)
    n = perm.shape[0]
    if a.ndim == 1:
        launch(gather_body, n, a, perm, out)
    else:
        launch(gather_rows_body, n, a, perm, out, a.shape[0])
    return out


@numba.njit(**_BODY)
def quotient_body(i, x, y, out):
    """``out[i] = x[i] / y[i]``."""
    out[i] = x[i] / y[i]


def added(x: Any, y: Any) -> Any:
    """A new (N,) array ``x + y`` (element-wise)."""
    out = empty_like(x)
    launch(add_body, x.shape[0], x, y, out)
    return out


def divided_by(x: Any, y: Any) -> Any:
    """A new (N,) array ``x / y`` (element-wise)."""
    out = empty_like(x)
    launch(quotient_body, x.shape[0], x, y, out)
    return out
