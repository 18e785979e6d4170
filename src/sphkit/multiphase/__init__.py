"""Several fluids in one scene: the phase model of the fluid (Solenthaler & Pajarola 2008).

Every fluid particle carries its material index ``phase``, its rest density ``rho0`` and rest
volume ``V0`` (fields of the fluid set). The pressure solvers and boundary models read the
per-particle rest density through :class:`sphkit.core.state.RestArrays` (number densities,
the neighbour weight ``rho0_j / rho0_i`` in the pressure sums). The non-pressure forces of each
material act within its phase (:class:`PhaseForce`), as SPlisHSPlasH's
``forall_fluid_neighbors_in_same_phase`` does.

Between two phases (scene ``interfaces[]``, not in SPlisHSPlasH): a viscosity
(:mod:`sphkit.multiphase.morris1997`, Morris et al. 1997 over the pairs of unlike phases) and an
interface tension (:mod:`sphkit.multiphase.hu2006`, the surface stress of Hu & Adams 2006),
each one force over the whole fluid with a (P, P) table of coefficients by phase
(built from the scene by :mod:`sphkit.world.build`).
"""

from sphkit.multiphase.phases import PhaseForce, pair_table, phase_lists, phase_state

__all__ = ["PhaseForce", "pair_table", "phase_lists", "phase_state"]
