"""How long Numba compiles: :class:`CompileWatch`, a listener on Numba's compile events (its
Event API, ``numba.core.event``, event kind ``"numba:compile"``).

A compiled pass is compiled once per machine and kind of scene (its types, its compiled-in
constants) and then loaded from Numba's cache on disk (``__pycache__`` beside each module); a
run that meets a pass for the first time spends most of its first step compiling (the default
dam break's first run: about a minute of compilation on two cores, `benchmarks/README.md`,
"Compile time"). Numba signals a compilation, not a load from the cache, so the watch sees
exactly the time a run would not spend the next time.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from numba.core import event


class CompileWatch(event.Listener):
    """Numba's compilations while started (:meth:`start` ... :meth:`stop`): their number and
    their wall time, a compilation nested in another (a callee compiled while its caller's
    types are inferred) counted within the outer one; ``on_first`` is called as the first one
    starts (to say why the run pauses)."""

    def __init__(self, on_first: Callable[[], None] | None = None) -> None:
        #: called (once) as the first compilation starts; None: nothing
        self.on_first = on_first
        #: seconds spent compiling
        self.seconds = 0.0
        #: compilations (the outermost of a nest)
        self.count = 0
        self._depth = 0
        self._t0 = 0.0
        self._on = False

    def on_start(self, ev: Any) -> None:  # noqa: ARG002 - Numba's Listener interface
        """A compilation starts."""
        if self._depth == 0:
            if self.count == 0 and self.on_first is not None:
                self.on_first()
            self.count += 1
            self._t0 = time.perf_counter()
        self._depth += 1

    def on_end(self, ev: Any) -> None:  # noqa: ARG002 - Numba's Listener interface
        """A compilation ended."""
        self._depth -= 1
        if self._depth == 0:
            self.seconds += time.perf_counter() - self._t0

    def start(self) -> CompileWatch:
        """Listen to Numba's compilations (returns the watch)."""
        if not self._on:
            event.register("numba:compile", self)
            self._on = True
        return self

    def stop(self) -> None:
        """Stop listening (the counts stay)."""
        if self._on:
            event.unregister("numba:compile", self)
            self._on = False
