"""Several fluids in one scene: the phase model of the fluid (Solenthaler & Pajarola 2008).

Every fluid particle carries its material index ``phase``, its rest density ``rho0`` and rest
volume ``V0`` (fields of the fluid set). The pressure solvers and boundary models read the
per-particle rest density through :class:`sphkit.core.state.RestArrays` (number densities,
the neighbour weight ``rho0_j / rho0_i`` in the pressure sums). The non-pressure forces of each
material act within its phase (:class:`PhaseForce`), as SPlisHSPlasH's
``forall_fluid_neighbors_in_same_phase`` does.
"""

from sphkit.multiphase.phases import PhaseForce, phase_lists, phase_state

__all__ = ["PhaseForce", "phase_lists", "phase_state"]
