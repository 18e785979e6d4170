"""The corotated SPH solid shared by the elasticity models (not a method of its own).

:class:`CorotatedSolid` holds what :mod:`sphkit.solids.becker2009` (explicit) and
:mod:`sphkit.solids.peer2018` (implicit) share: the parameters of a material's
``elasticity``, the rest configuration (:mod:`sphkit.solids.rest`), the gradient weights
(:mod:`sphkit.solids.gradients`) and the explicit corotated force of
:mod:`sphkit.solids.corotation` (Becker, Ihmsen & Teschner 2009, with Ganzenmüller 2015's
zero-energy-mode control), which the explicit model applies as it is and the implicit model
takes as its right-hand side.
"""


from __future__ import annotations

import math
from typing import Any

import numpy as np

from sphkit.core.methods import Elasticity
from sphkit.core.state import SimState
from sphkit.solids.corotation import (
    clamp_shifts,
    energy,
    forces,
    gradient_rotations,
    lame,
    rotations,
    stresses,
    work_arrays,
)
from sphkit.solids.gradients import gradient_weights, reverse_pairs
from sphkit.solids.plasticity import FIELDS as PLASTIC_FIELDS
from sphkit.solids.plasticity import check_parameters
from sphkit.solids.rest import RestConfiguration

#: iterations of the rotation extraction per step (SPlisHSPlasH: 10)
ROTATION_ITERATIONS = 10
#: ``rotation="gradient"``: the polar rotation of F, iterated (warm-started) until the
#: correction is below this angle [rad] (a few iterations per step), at most this many times
GRADIENT_ROTATION_TOLERANCE = 1e-14
GRADIENT_ROTATION_ITERATIONS = 50

#: the plastic state of a purely elastic solid (never read)
_NO_PLASTIC = (np.zeros((3, 0)), np.zeros((3, 0)), np.zeros(0))


class CorotatedSolid(Elasticity):
    """A corotated SPH solid: parameters, rest configuration, gradient weights, the explicit
    elastic and hourglass accelerations (module docstring)."""

    @classmethod
    def from_config(cls, config: Any) -> CorotatedSolid:
        """From a material's ``elasticity`` (``youngs_modulus`` [Pa], ``poisson_ratio``,
        ``alpha``, ``max_neighbors``, ``fixed_boxes``, ``yield_stress`` and ``hardening``
        [Pa])."""
        return cls(config.youngs_modulus, config.poisson_ratio, config.alpha,
                   config.max_neighbors, list(config.fixed_boxes), config.gradient_correction,
                   config.rest_volume, config.rest_support, config.yield_stress,
                   config.hardening, config.rotation, config.clamp)

    def __init__(self, youngs_modulus: float = 1e5, poisson_ratio: float = 0.3,
                 alpha: float = 0.0, max_neighbors: int = -1,
                 fixed_boxes: list | None = None, gradient_correction: str = "quadratic",
                 rest_volume: str = "particle", rest_support: float = 1.5,
                 yield_stress: float | None = None, hardening: float = 0.0,
                 rotation: str = "moment", clamp: str = "particles") -> None:
        if not youngs_modulus > 0:
            raise ValueError(f"elasticity.youngs_modulus: {youngs_modulus!r}; expected a "
                             "number > 0 [Pa]")
        if not -1.0 < poisson_ratio < 0.5:
            raise ValueError(f"elasticity.poisson_ratio: {poisson_ratio!r}; expected a number "
                             "in (-1, 0.5)")
        if not alpha >= 0:
            raise ValueError(f"elasticity.alpha: {alpha!r}; expected a number >= 0")
        self.youngs_modulus = float(youngs_modulus)
        self.poisson_ratio = float(poisson_ratio)
        self.alpha = float(alpha)
        self.max_neighbors = int(max_neighbors)
        self.fixed_boxes = fixed_boxes or []
        if gradient_correction not in ("none", "linear", "quadratic"):
            raise ValueError(f"elasticity.gradient_correction: {gradient_correction!r}; "
                             "expected 'none', 'linear' or 'quadratic'")
        self.gradient_correction = gradient_correction
        self.rest_volume = rest_volume
        if not 1.0 <= rest_support <= 2.0:
            raise ValueError(f"elasticity.rest_support: {rest_support!r}; expected a number "
                             "in [1, 2] (multiple of the support radius h)")
        self.rest_support = float(rest_support)
        self.mu, self.lam = lame(self.youngs_modulus, self.poisson_ratio)
        #: von Mises yield stress and linear hardening modulus [Pa] (solids.plasticity);
        #: yield stress 0: purely elastic
        self.yield_stress, self.hardening = check_parameters(yield_stress, hardening)
        if rotation not in ("moment", "gradient"):
            raise ValueError(f"elasticity.rotation: {rotation!r}; expected 'moment' or "
                             "'gradient'")
        #: the corotated frame: "moment", the rotation of the moment matrix (Becker et al.
        #: 2009, SPlisHSPlasH); "gradient", the polar rotation of the deformation gradient
        #: (keeps angular momentum; solids.corotation)
        self.rotation = rotation
        if clamp not in ("particles", "face"):
            raise ValueError(f"elasticity.clamp: {clamp!r}; expected 'particles' or 'face'")
        #: the pinned particles' part in the elastic sums (ElasticityConfig.clamp)
        self.clamp = clamp
        self.rest: RestConfiguration | None = None
        self.work: dict[str, np.ndarray] = {}
        self.G = np.zeros((0, 3))  #: gradient weights per rest pair (solids.gradients)
        #: the face clamp's shift per particle (row-major 3 x 3; zero without it;
        #: solids.corotation.clamp_shifts)
        self.C = np.zeros((0, 9))
        self.rev = np.zeros(0, np.int64)  #: the reverse pair of each rest pair

    def init(self, state: SimState) -> None:
        """Claim the solid's particles, store (or, after a restore, reload) the rest
        configuration and build the rest lists."""
        self.rest = RestConfiguration(self.objects, self.fixed_boxes, self.max_neighbors,
                                      self.rest_volume, self.rest_support)
        self.rest.build(state)
        self.work = work_arrays(self.rest.n)
        rest = self.rest
        off, idx = rest.lists.offsets, rest.lists.indices
        # capped lists (max_neighbors, e.g. SPlisHSPlasH's Beam.json: 15) leave the quadratic
        # fit barely determined: there it needs twice as many neighbours as monomials, or the
        # particle keeps the linear weights (with kugelstadt2021, Beam.json's quadratic
        # weights on lists of 15 made the beam noisy within 25 steps: 33 MPa, 8 cm sideways)
        face = self.clamp == "face" and rest.fixed.size > 0
        samples = rest.clamp_vectors(state.dim) if face else None
        self.G = gradient_weights(rest.x0, rest.V0, off, idx, rest.h, state.kid, state.dim,
                                  self.gradient_correction,
                                  2.0 if self.max_neighbors > 0 else 1.0,
                                  samples, rest.pinned if face else None)
        self.C = clamp_shifts(rest.x0, off, idx, self.G, state.dim, samples)
        self.rev = reverse_pairs(off, idx)
        if self.plastic:
            for name, kind in PLASTIC_FIELDS.items():
                state.fluid.register(name, kind)

    @property
    def plastic(self) -> bool:
        """Whether the material yields (a yield stress > 0)."""
        return self.yield_stress > 0.0

    def plastic_state(self, state: SimState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The per-particle plastic strain fields (``solid_plastic``, ``solid_plastic_shear``,
        ``solid_plastic_alpha``; :mod:`sphkit.solids.plasticity`), or empty arrays when the
        material is purely elastic."""
        if not self.plastic:
            return _NO_PLASTIC
        f = state.fluid
        return f["solid_plastic"], f["solid_plastic_shear"], f["solid_plastic_alpha"]

    def _rotations(self, state: SimState, pos: np.ndarray, qw: np.ndarray, qv: np.ndarray,
                   R: np.ndarray) -> None:
        """The corotated frames ``R`` of the current positions (:attr:`rotation`), warm-started
        from and written back to the quaternions ``qw``, ``qv``."""
        rest = self.rest
        off, idx = rest.lists.offsets, rest.lists.indices
        if self.rotation == "gradient":
            gradient_rotations(state.fluid["x"], pos, off, idx, self.G, self.C, state.dim, qw,
                               qv, R, GRADIENT_ROTATION_ITERATIONS,
                               GRADIENT_ROTATION_TOLERANCE)
        else:
            rotations(state.fluid["x"], pos, rest.x0, rest.m, off, idx, rest.h, state.kid,
                      state.dim, qw, qv, R, ROTATION_ITERATIONS)

    def strain_energy(self, state: SimState) -> float:
        """The elastic strain energy ``U = sum_i V0_i (mu |eps_e,i|^2 + lambda/2 tr(eps_e,i)^2)``
        [J; J/m in 2D] of the current positions, ``eps_e`` the corotated small strain (the
        rotations of the moment matrices, as :meth:`apply` measures them, without changing the
        stored ones) less the plastic strain. The elastic force of :meth:`apply` is ``-dU/dx``
        with the rotations held (:mod:`sphkit.solids.corotation`), so kinetic energy plus U is
        kept by the elastic force alone (not by the zero-energy-mode control, ``alpha``, which
        has no energy of this form); exactly (to the time integration) with
        ``rotation="gradient"``, to second order in the strain with ``"moment"``.
        kugelstadt2021 takes its rotations from F instead; its energy is the same to first
        order in the strain."""
        rest = self.rest
        if rest is None or rest.n == 0:
            return 0.0
        f = state.fluid
        pos = rest.update(state)
        off, idx = rest.lists.offsets, rest.lists.indices
        qw, qv = f["solid_qw"].copy(), f["solid_q"].copy()
        w = {k: np.zeros_like(v) for k, v in self.work.items()}
        self._rotations(state, pos, qw, qv, w["R"])
        stresses(f["x"], pos, rest.x0, off, idx, self.G, self.C, state.dim, self.mu, self.lam,
                 w["R"], w["F"], w["P"], w["M"], np.zeros(f.n), *_NO_PLASTIC, 0.0, 0.0, False)
        return energy(w["F"], pos, rest.V0, self.mu, self.lam, *self.plastic_state(state),
                      self.plastic)

    def max_time_step(self, state: SimState) -> float:
        """``0.4 * 2r / c``, c the P-wave speed ``sqrt((lambda + 2 mu) / rho0)`` [s]."""
        if self.rest is None or self.rest.n == 0:
            return math.inf
        rho0 = float(np.min(state.fluid["rho0"][self.rest.update(state)]))
        c = math.sqrt((self.lam + 2.0 * self.mu) / rho0)
        return 0.4 * 2.0 * state.r / c

    def apply(self, state: SimState, dt: float) -> None:
        """Rotations, stresses, then the elastic and hourglass accelerations."""
        rest = self.rest
        if rest is None or rest.n == 0:
            return
        f = state.fluid
        pos = rest.update(state)
        off, idx = rest.lists.offsets, rest.lists.indices
        w = self.work
        self._rotations(state, pos, f["solid_qw"], f["solid_q"], w["R"])
        stresses(f["x"], pos, rest.x0, off, idx, self.G, self.C, state.dim, self.mu, self.lam,
                 w["R"], w["F"], w["P"], w["M"], f["solid_stress"],
                 *self.plastic_state(state), self.yield_stress, self.hardening, self.plastic)
        forces(f["x"], pos, rest.x0, rest.V0, rest.m, off, idx, self.G, self.rev, rest.h,
               state.kid, state.dim, w["P"], w["M"], self.alpha * self.youngs_modulus, f["a"])

    def constrain(self, state: SimState) -> None:
        """Pinned particles back at rest."""
        if self.rest is not None:
            self.rest.constrain(state)


class ImplicitCorotatedSolid(CorotatedSolid):
    """A corotated solid with an iterative solve in its step (:mod:`sphkit.solids.peer2018`'s
    CG, :mod:`sphkit.solids.kugelstadt2021`'s volume CG): the solve's iteration limit and
    tolerance besides the parameters of :class:`CorotatedSolid`."""

    @classmethod
    def from_config(cls, config: Any) -> ImplicitCorotatedSolid:
        """From a material's ``elasticity`` (as :class:`CorotatedSolid`, plus ``max_iterations``
        and ``max_error`` of the solve)."""
        out = super().from_config(config)
        out.max_iterations = int(config.max_iterations)
        out.max_error = float(config.max_error)
        return out

    def __init__(self, *args: Any, max_iterations: int = 100, max_error: float = 1e-4,
                 **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.max_iterations = max_iterations
        self.max_error = max_error
