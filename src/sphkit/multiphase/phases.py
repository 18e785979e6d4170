"""Non-pressure forces within one phase (Solenthaler & Pajarola 2008, "Density contrast SPH
interfaces", SCA; SPlisHSPlasH's ``forall_fluid_neighbors_in_same_phase``).

Each material of a scene with several fluids has its own viscosity, vorticity, surface tension
and drag. SPlisHSPlasH evaluates them per fluid model over the neighbours of the same model, so
a force of one material acts on its particles only and sees the other phases as empty space
(surface tension then acts at the interface as at a free surface). :class:`PhaseForce` does the
same for any :class:`~sphkit.core.methods.NonPressureForce`, unchanged: it runs the force on a
*phase state* -- the particles of its phase (every field, gathered), their fluid neighbours of
the same phase (the step's CSR lists filtered and renumbered, :func:`phase_lists`), their
boundary neighbours, and the material's rest density as ``state.rho0`` -- and scatters the
fields back. A scene with one fluid material runs its forces on the whole state, as before.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from sphkit.core.methods import NonPressureForce
from sphkit.core.neighbors import NeighborList
from sphkit.core.state import SimState

#: fields a force never changes: they are not written back
_READ_ONLY = ("x", "id", "phase", "rho0", "m", "V0")


def phase_lists(nl: NeighborList, member: np.ndarray) -> NeighborList:
    """The CSR lists ``nl`` of N points restricted to the pairs whose both ends have
    ``member`` (N,) True, renumbered to the members' order (row k = the k-th member)."""
    counts = np.diff(nl.offsets)
    rows = np.repeat(np.arange(counts.shape[0]), counts)
    keep = member[rows] & member[nl.indices]
    new = np.cumsum(member) - 1  # new index of each member
    sel_rows = new[rows[keep]]
    n = int(member.sum())
    off = np.zeros(n + 1, dtype=nl.offsets.dtype)
    np.cumsum(np.bincount(sel_rows, minlength=n), out=off[1:])
    return NeighborList(off, new[nl.indices[keep]].astype(nl.indices.dtype))


def phase_state(state: SimState, index: np.ndarray, rho0: float) -> SimState:
    """The state of the fluid particles ``index`` (sorted) alone: a new fluid set holding their
    fields, their fluid neighbours among themselves, their boundary neighbours, rest density
    ``rho0`` [kg/m^3]; boundary, constants and coupling shared with ``state``."""
    f = state.fluid
    sub = f.empty_like()
    sub._grow(index.shape[0])
    for name, spec in f.specs.items():
        a = f[name]
        sub.fields[name][...] = a[index] if spec.kind == "scalar" else a[:, index]
    sub.next_id = f.next_id
    member = np.zeros(f.n, dtype=bool)
    member[index] = True
    return replace(state, fluid=sub, rho0=float(rho0), nl_ff=phase_lists(state.nl_ff, member),
                   nl_fb=state.nl_fb.rows(index), pair_grads=None)


def pair_table(table: Any, name: str) -> np.ndarray:
    """``table`` as a symmetric (P, P) float64 array of non-negative numbers (ValueError naming
    ``name`` otherwise)."""
    t = np.asarray(table, dtype=np.float64)
    if t.ndim != 2 or t.shape[0] != t.shape[1] or not np.all(np.isfinite(t)) or np.any(t < 0):
        raise ValueError(f"{name}: {table!r}; expected a square table of finite numbers >= 0")
    if not np.array_equal(t, t.T):
        raise ValueError(f"{name}: the table is not symmetric; expected one value per pair")
    return t


class PhaseForce(NonPressureForce):
    """A non-pressure force of one material acting on its phase only (module docstring)."""

    def __init__(self, force: NonPressureForce, phase: int, rho0: float) -> None:
        self.force = force
        self.phase = int(phase)
        self.rho0 = float(rho0)  #: the material's rest density [kg/m^3]
        self.name = force.name
        self._ready = False  # the force's init ran (it waits for the phase's first particles)

    @property
    def stats(self):  # noqa: ANN201 - the wrapped force's (KrylovStats | None)
        """The wrapped force's last solve."""
        return self.force.stats

    def _index(self, state: SimState) -> np.ndarray:
        return np.flatnonzero(state.fluid["phase"] == self.phase)

    def _run(self, state: SimState, call) -> bool:  # noqa: ANN001
        """``call(phase state)`` and the fields back; False when the phase has no particles."""
        index = self._index(state)
        if index.shape[0] == 0:
            return False
        sub = phase_state(state, index, self.rho0)
        call(sub)
        f = state.fluid
        for name, spec in sub.fluid.specs.items():
            if name not in f.specs:  # registered by the force: the whole fluid gets it
                f.register(name, spec.kind, spec.dtype, spec.fill)
            if name in _READ_ONLY:
                continue
            if spec.kind == "scalar":
                f[name][index] = sub.fluid[name]
            else:
                f[name][:, index] = sub.fluid[name]
        return True

    def init(self, state: SimState) -> None:
        """The force's own init on the phase (fields it registers go to the whole fluid); a
        phase without particles yet (an emitter's) is initialised at its first step."""
        self._ready = self._run(state, self.force.init)

    def max_time_step(self, state: SimState) -> float:
        """The wrapped force's own bound (it depends on the material, not on the phase's
        particles)."""
        return self.force.max_time_step(state)

    def apply(self, state: SimState, dt: float) -> None:
        """The force on the particles of the phase and their neighbours in it."""
        def call(sub: SimState) -> None:
            if not self._ready:
                self.force.init(sub)
                self._ready = True
            self.force.apply(sub, dt)

        self._run(state, call)
