"""The validated scene model (pydantic), in SI units.

A scene is what a simulation is built from; both front ends (sphkit's own JSON/YAML,
:mod:`sphkit.scene.files`, and SPlisHSPlasH's JSON scene format,
:mod:`sphkit.scene.splishsplash`) produce a :class:`Scene`.
Every parameter documents its unit. Validation errors name the field path, the bad value and
what was expected (see :func:`format_validation_error`).
"""

from __future__ import annotations

import math
import re
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    field_validator,
    model_validator,
)

from sphkit import registry
from sphkit.scene.expressions import ExpressionError, compile_expression
from sphkit.scene.limits import CLIP, MAX_FPS, MAX_PARTICLES

Vec = list[float]


def _three_components(v: Vec) -> Vec:
    if len(v) != 3:
        raise ValueError(f"{v} must have 3 components")
    return v


#: a vector of exactly 3 components, also in 2D (an angular velocity, a file's placement)
Vec3 = Annotated[Vec, AfterValidator(_three_components)]
#: the ratio of the largest to the smallest rest density of a scene's fluids above which the
#: static walls are solved by default (``Scene._several_densities_walls``): with the MLS wall
#: term every heavy-over-light column ran up to 1:4, and PCISPH blew up from 1:6 on (2D),
#: IISPH and DFSPH from 1:8; below it, MLS keeps the Rayleigh-Taylor growth (1:2) that the
#: solved walls changed (validation/README.md, "Several rest densities: the solved walls by
#: default")
SOLVED_WALLS_RATIO = 4.0
#: up to this ratio the default solved walls are ``"stratified"`` (rows only where a lighter
#: fluid lies below a heavier one at a wall, MLS elsewhere: the resting columns' accuracy),
#: above it ``"density"`` (every static wall particle: 2D heavy-over-light overturns ran at 1:50
#: with PCISPH, IISPH and DFSPH, where the stratified rows ran PCISPH to 1:10, DFSPH to 1:20
#: and IISPH to 1:30; validation/README.md, "Solved walls where the fluid is stratified")
STRATIFIED_WALLS_RATIO = 10.0
#: WCSPH's walls take the symmetric term by default (``Scene._inviscid_wcsph_walls``) where the
#: smallest kinematic viscosity of a scene's fluids is below this rate times (2r)^2 [1/s]: the
#: mirrored and MLS wall terms are not the derivative of the elastic energy and pump energy
#: into the flow, which only a viscosity of about that size takes out again (an inviscid 2D
#: dam break in a closed box doubled its energy every 0.5 s and leaked at 2 s; stable from
#: nu = 1e-3 at r = 1 cm, 3e-4 at r = 5 mm, unstable at 1e-4 and 3e-4 at r = 1 and 2 cm;
#: validation/README.md, "WCSPH's walls by default: the energy they pump")
WCSPH_WALL_DAMPING = 1.0
#: the viscosity methods whose coefficient is a kinematic viscosity [m^2/s]
KINEMATIC_VISCOSITY = ("standard", "weiler2018", "takahashi2015")


def _choices(role: str) -> Any:
    """The scene names of a role's methods (:mod:`sphkit.registry`) as a ``Literal``, with
    ``"none"`` first for the optional non-pressure forces."""
    names = registry.names(role)
    if (role in registry.OPTIONAL_ROLES or role in registry.SOLID_ROLES
            or role in registry.INTERFACE_ROLES or role in registry.CONFIGURATION_ROLES):
        names = ("none", *names)
    return Literal[names]  # type: ignore[valid-type]


#: a field path at the start of a message (``meshes[0].scale: ...``)
_FIELD = re.compile(r"^([a-z_]+(?:\[\d+\])?(?:\.[a-z_]+(?:\[\d+\])?)*)(?=[:, ])")

#: the methods a scene may name, read from the registry (one place names them)
PressureMethod = _choices("pressure")
ViscosityMethod = _choices("viscosity")
VorticityMethod = _choices("vorticity")
SurfaceTensionMethod = _choices("surface_tension")
DragMethod = _choices("drag")
InterfaceViscosityMethod = _choices("interface_viscosity")
InterfaceTensionMethod = _choices("interface_tension")
ElasticityMethod = _choices("elasticity")
BoundaryMethod = _choices("boundary")
BoundaryPressureMethod = _choices("boundary_pressure")
TransportMethod = _choices("transport")


class _Model(BaseModel):
    # every number of every scene field is finite: NaN and Infinity are refused naming the field
    model_config = ConfigDict(extra="forbid", validate_assignment=True, allow_inf_nan=False)


class TimeConfig(_Model):
    """Time stepping."""

    until: float = Field(1.0, gt=0, description="simulated end time [s]")
    dt: float = Field(0.001, gt=0, description="initial (or fixed, without CFL) time step [s]")
    cfl: bool = Field(True, description="adapt the time step to the CFL condition")
    cfl_factor: float = Field(
        1.0, gt=0, le=2.0,
        description="scale of the CFL step dt = cfl_factor * 0.4 * 2r / max|v| (dimensionless)",
    )
    dt_min: float = Field(1e-5, gt=0, description="lower bound of the CFL time step [s]")
    dt_max: float = Field(0.005, gt=0, description="upper bound of the CFL time step [s]")
    iteration_control: bool = Field(
        False,
        description="with cfl: also adapt the step to the pressure solver's iterations, as "
        "SPlisHSPlasH's cflMethod 2: the last step times 0.9 after a solve of more than 10 "
        "iterations, times 1.1 after one of fewer than 5, else kept, and never above the CFL "
        "step (nor below dt_min); from the first step's CFL step, not from dt",
    )
    retries: int = Field(
        4, ge=0, le=20,
        description="times a step whose pressure solve failed (PCISPH: stopped at its iteration "
        "limit with an average error above twice its tolerance) is computed again with half "
        "the step, each logged; where every non-pressure force of the scene allows it and "
        "there are no moving bodies, elastic solids or solved walls; 0: off",
    )

    @model_validator(mode="after")
    def _bounds(self) -> TimeConfig:
        if self.dt_min > self.dt_max:
            raise ValueError(f"dt_min ({self.dt_min}) must not exceed dt_max ({self.dt_max})")
        if self.iteration_control and not self.cfl:
            raise ValueError("iteration_control: true adapts the CFL step; expected cfl: true "
                             "with it (cfl: false is the fixed step time.dt)")
        return self


class PressureConfig(_Model):
    """Pressure solver and its parameters.

    ``method``: ``wcsph`` (state equation), ``pcisph`` (Solenthaler & Pajarola 2009), ``pbf``
    (Macklin & Mueller 2013), ``iisph`` (Ihmsen et al. 2014), ``dfsph`` (Bender & Koschier 2015,
    2017), ``pf`` (projective fluids, Weiler et al. 2016), ``icsph`` (Gissler et al. 2020). The
    iterative solvers share one iteration control: they stop when the average density error is
    at most ``max_error`` percent of rho0 after at least ``min_iterations`` (icsph: the error of
    its compressible equation; pf: when its global step's relative residual is at most
    ``pf_tolerance``, its density error set by ``pf_stiffness``); fields left at None take the
    solver's SPlisHSPlasH default.
    """

    method: PressureMethod = "wcsph"
    equation: Literal["tait", "linear"] = Field(
        "tait", description="wcsph: tait: p = B((rho/rho0)^gamma - 1); linear: p = k (rho - rho0)"
    )
    stiffness: float = Field(
        50000.0, ge=0,
        description="wcsph: B [Pa] of the Tait equation, or k [m^2/s^2] of the linear equation "
        "(0, no pressure, only when every material is an elastic solid)",
    )
    exponent: float = Field(7.0, ge=1.0, description="gamma of the Tait equation (dimensionless)")
    background_pressure: float = Field(
        0.0, ge=0, description="wcsph: background pressure p_b [Pa]; 0: densities are clamped to "
        "rho >= rho0 (free surfaces); > 0: p = p_b + the unclamped state equation, for flows "
        "without a free surface (doubly periodic flows: vortex cores keep a pressure)",
    )
    acoustic_cfl: bool = Field(
        True,
        description="wcsph: also bound dt by 0.4 h / c with the speed of sound c of the state "
        "equation (Becker & Teschner 2007) and by 0.8 / omega with each particle's own pressure "
        "stiffness omega (sphkit.pressure.wcsph); switch off only to reproduce a peer's fixed step",
    )
    max_error: float = Field(
        0.01, gt=0, le=100,
        description="iterative solvers: target average density error [% of rho0] (SPlisHSPlasH "
        "maxError, default 0.01 %); several rest densities: each one's own average (pcisph: "
        "over all particles)",
    )
    min_iterations: int | None = Field(
        None, ge=0, description="iterative solvers: minimum iterations (default per solver)"
    )
    max_iterations: int = Field(100, ge=1, description="iterative solvers: maximum iterations")
    max_error_v: float = Field(
        0.1, gt=0, le=100,
        description="dfsph: target average divergence error: |D rho/Dt| dt at most this "
        "[% of rho0] (SPlisHSPlasH maxErrorV, default 0.1 %)",
    )
    max_iterations_v: int = Field(100, ge=1, description="dfsph: maximum divergence iterations")
    divergence_solver: bool = Field(True, description="dfsph: run the divergence-free solver")
    free_surface: bool | None = Field(
        None,
        description="dfsph, iisph: false: the fluid fills a domain periodic along every axis, "
        "without walls (a doubly periodic flow): both solves take their sources relative to the "
        "fluid's mean (predicted density, velocity divergence) and the pressures may be "
        "negative (a clamped solve cannot lower the mean summed density of a disordered "
        "particle set above rho0 and pushes without end); true: SPlisHSPlasH's clamped solves; "
        "null (default): false where every axis is periodic, there are no walls and the fluid "
        "fills the period, else true (sphkit.pressure.dfsph, 'Closed domains')",
    )
    pbf_epsilon: float = Field(
        1e-6, gt=0,
        description="pbf: constraint-force-mixing relaxation epsilon of lambda [1/m^2], added "
        "to sum |grad C|^2 (Macklin & Mueller 2013, Eq. 11; SPlisHSPlasH 1e-6)",
    )
    pbf_s_corr: bool = Field(
        False, description="pbf: artificial pressure s_corr against tensile instability (Eq. 13)"
    )
    pbf_s_corr_k: float = Field(0.1, ge=0, description="pbf: s_corr strength k (dimensionless)")
    pbf_s_corr_n: float = Field(4.0, gt=0, description="pbf: s_corr exponent n")
    pbf_s_corr_dq: float = Field(
        0.2, gt=0, lt=1, description="pbf: s_corr reference distance |dq| as a fraction of h"
    )
    pbf_velocity_update: Literal["first_order", "second_order"] = Field(
        "first_order", description="pbf: v = (x - x_old)/dt, or the 2nd-order BDF form"
    )
    icsph_lambda: float = Field(
        200000.0, gt=0,
        description="icsph: Lame parameter lambda [Pa] of the compressible pressure equation, "
        "rho = rho0 (1 + p / lambda) at rest (SPlisHSPlasH lambda, default 200000)",
    )
    icsph_clamping: bool = Field(
        True, description="icsph: clamp the pressure to p >= 0 (SPlisHSPlasH pressureClamping)"
    )
    icsph_psi: float = Field(
        1.0, gt=0,
        description="icsph: boundary factor psi of the pressure gradient, in the solve and the "
        "acceleration (dimensionless; 1: the boundary model's own term; SPlisHSPlasH uses 1.5 "
        "with boundary particles in the solve only, see sphkit.pressure.icsph)",
    )
    pf_stiffness: float = Field(
        50000.0, gt=0,
        description="pf: stiffness k [N/m] of the density constraints (SPlisHSPlasH stiffness, "
        "default 50000); larger k, smaller compression",
    )
    pf_tolerance: float = Field(
        1e-10, gt=0, lt=1,
        description="pf: relative residual |b - A x| / |b| of the global step that ends the "
        "local/global iterations (SPlisHSPlasH 1e-10)",
    )


class TransportConfig(_Model):
    """Transport velocity (``method``: ``none`` or ``adami2013``, Adami, Hu & Adams 2013,
    :mod:`sphkit.transport.adami2013`): the particles move with their velocity plus the
    acceleration of a background pressure times the step, which keeps them evenly spaced in
    flows that stretch the particle lattice (Taylor-Green vortex, lid-driven cavity); the
    momentum equation gains the stress term ``A = rho v (v~ - v)``. WCSPH only; no free
    surfaces (the background pressure pulls a surface particle into the fluid)."""

    method: TransportMethod = "none"
    background_pressure: float | None = Field(
        None, gt=0, description="adami2013: background pressure p_b [Pa] of the transport "
        "velocity; unset: rho0 c^2 with the speed of sound c of the WCSPH state equation (PySPH's "
        "choice in its implementation of Adami et al. 2013)",
    )


class ViscosityConfig(_Model):
    """Non-pressure viscosity (one model per material; SPlisHSPlasH's ``viscosityMethod`` number):

    * ``standard``: explicit Morris/Monaghan Laplacian (1); ``xsph``: XSPH smoothing (SPlisHSPlasH's
      separate XSPH block);
    * implicit: ``bender2017`` (Bender & Koschier 2017, strain-rate constraints, 2),
      ``peer2015`` (Peer et al. 2015, 3), ``peer2016`` (Peer & Teschner 2016, 4),
      ``takahashi2015`` (Takahashi et al. 2015, SPlisHSPlasH's improved form, 5),
      ``weiler2018`` (Weiler et al. 2018, 6).

    ``coefficient`` is a kinematic viscosity for standard, takahashi2015 and weiler2018, but a
    dimensionless per-step factor in [0, 1] for bender2017, peer2015 and peer2016 (the fraction of
    strain rate or shear the step removes); ``boundary_coefficient`` exists for standard, xsph and
    weiler2018 only (the other models have SPlisHSPlasH's fixed wall terms).
    """

    method: ViscosityMethod = "none"
    coefficient: float = Field(
        0.0, ge=0,
        description="standard, weiler2018, takahashi2015: kinematic viscosity nu [m^2/s] (dynamic "
        "viscosity mu = nu * density0 [Pa s]); xsph: smoothing factor c in [0, 1]; bender2017, "
        "peer2015, peer2016: dimensionless factor in [0, 1] (bender2017: target strain rate "
        "(1 - c) times the current one; peer: shear scaled by 1 - c)",
    )
    boundary_coefficient: float = Field(
        0.0, ge=0,
        description="standard, xsph, weiler2018: same meaning as coefficient, for fluid-boundary "
        "pairs (must stay 0 for the other implicit models)",
    )
    boundary_velocity: Literal["zero", "morris1997"] = Field(
        "zero",
        description="standard, weiler2018: the wall velocity in the boundary viscosity term; "
        "'zero' uses the wall particle's own velocity (SPlisHSPlasH; the fluid slips by a few "
        "particle spacings), 'morris1997' the fluid velocity extrapolated antisymmetrically "
        "across the wall surface (Morris, Fox & Zhu 1997 no-slip walls; needs the walls' "
        "distance to their surface, known for boxes; other walls keep their own velocity)",
    )
    morris_beta_max: float = Field(
        1.5, ge=1,
        description="boundary_velocity 'morris1997': upper bound beta_max of the factor "
        "beta = 1 + d_b / d_i on the relative velocity (Morris et al.: 1.5), dimensionless",
    )
    laplacian_eps: float = Field(
        0.01, gt=0,
        description="standard, weiler2018: regularisation eps of the Laplacian's "
        "1 / (|x_ij|^2 + eps h^2), a fraction of the support radius h squared, dimensionless "
        "(SPlisHSPlasH: 0.01, which weakens the cubic spline's shear Laplacian by 4.9 %; Morris "
        "et al. 1997 and Monaghan use 0.01 of the smoothing length squared, 0.0025 for the "
        "cubic spline)",
    )
    substeps: int = Field(
        8, ge=1,
        description="standard: the largest number of explicit sub-steps, each at most half the "
        "diffusion condition 0.125 (2r)^2 / nu (Morris et al. 1997), a time step longer than "
        "the condition is split into; the step is bound by substeps times half the condition; "
        "1: the step stays within the condition",
    )
    max_iterations: int | None = Field(
        None, ge=1,
        description="implicit solvers: maximum iterations (SPlisHSPlasH viscoMaxIter; default "
        "per method: weiler2018 and takahashi2015 100, bender2017, peer2015, peer2016 50)",
    )
    max_error: float = Field(
        0.01, gt=0,
        description="implicit solvers (SPlisHSPlasH viscoMaxError, default 0.01): the tolerance "
        "on the relative residual |b - A v| / |b| of the linear solve, dimensionless, below 1; "
        "bender2017: the average strain-rate error [1/s]",
    )
    max_iterations_omega: int | None = Field(
        None, ge=1,
        description="peer2016: maximum iterations of the vorticity diffusion solve "
        "(SPlisHSPlasH viscoMaxIterOmega, default 50)",
    )
    max_error_omega: float = Field(
        0.01, gt=0, lt=1,
        description="peer2016: relative-residual tolerance of the vorticity diffusion solve "
        "(SPlisHSPlasH viscoMaxErrorOmega)",
    )
    xsph: float = Field(
        0.0, ge=0, le=1,
        description="XSPH smoothing factor c in [0, 1] applied beside the viscosity method "
        "(SPlisHSPlasH's XSPH block, which it applies on top of its viscosityMethod); 0: none. "
        "For XSPH alone use method 'xsph' and coefficient",
    )
    xsph_boundary: float = Field(
        0.0, ge=0, le=1,
        description="XSPH smoothing factor for fluid-boundary pairs beside the viscosity "
        "method (SPlisHSPlasH's xsphBoundary)",
    )

    @model_validator(mode="after")
    def _ranges(self) -> ViscosityConfig:
        m = self.method
        if (self.xsph or self.xsph_boundary) and m in ("none", "xsph"):
            raise ValueError(
                f"xsph {self.xsph} / xsph_boundary {self.xsph_boundary}: the smoothing beside "
                f"a viscosity method, but method is {m!r}; expected method 'xsph' with "
                "coefficient and boundary_coefficient for XSPH alone")
        if m in ("bender2017", "peer2015", "peer2016") and not self.coefficient <= 1.0:
            raise ValueError(
                f"coefficient {self.coefficient}: {m}'s viscosity is a dimensionless factor; "
                "expected a value in [0, 1]"
            )
        if m in ("bender2017", "takahashi2015", "peer2015", "peer2016"):
            if self.boundary_coefficient != 0.0:
                raise ValueError(
                    f"boundary_coefficient {self.boundary_coefficient}: {m} has no separate "
                    "boundary viscosity (SPlisHSPlasH's fixed wall term is used); expected 0"
                )
        if self.boundary_velocity != "zero" and m not in ("standard", "weiler2018"):
            raise ValueError(
                f"boundary_velocity {self.boundary_velocity!r}: only the standard and weiler2018 "
                f"viscosities have a wall velocity in their boundary term, not {m!r}; expected "
                "'zero'"
            )
        if self.laplacian_eps != 0.01 and m not in ("standard", "weiler2018"):
            raise ValueError(
                f"laplacian_eps {self.laplacian_eps}: only the standard and weiler2018 "
                f"viscosities have this Laplacian, not {m!r}; expected the default 0.01"
            )
        if self.substeps != 8 and m != "standard":
            raise ValueError(
                f"substeps {self.substeps}: only the standard viscosity is explicit in sub-steps, "
                f"not {m!r}; expected the default 8"
            )
        if m in ("weiler2018", "takahashi2015", "peer2015", "peer2016") and not self.max_error < 1:
            raise ValueError(
                f"max_error {self.max_error}: {m} stops on the relative residual of its linear "
                "solve; expected a value in (0, 1)"
            )
        return self


class VorticityConfig(_Model):
    """Vorticity model: ``micropolar`` is Bender et al. 2017 (SPlisHSPlasH's vorticityMethod 1,
    :mod:`sphkit.vorticity.micropolar_bender2017`), ``confinement`` is vorticity confinement
    (Macklin & Mueller 2013, vorticityMethod 2, :mod:`sphkit.vorticity.confinement`); defaults
    are SPlisHSPlasH's."""

    method: VorticityMethod = "none"
    coefficient: float = Field(
        0.01, ge=0, allow_inf_nan=False,
        description="micropolar: vortex viscosity (transfer coefficient) nu_t [m^2/s], a kinematic "
        "viscosity: a += nu_t curl(omega), domega/dt += nu_t/Theta (curl(v) - 2 omega); "
        "confinement: epsilon [m/s] of a += epsilon N x omega",
    )
    viscosity_omega: float = Field(
        0.1, ge=0, allow_inf_nan=False,
        description="micropolar: angular viscosity zeta [m^2]; zeta * inertia_inverse is the "
        "dimensionless XSPH weight that smooths omega each time step (keep it below 1)",
    )
    inertia_inverse: float = Field(
        0.5, ge=0, allow_inf_nan=False,
        description="micropolar: inverse microinertia 1/Theta [1/m^2] (Theta: moment of inertia "
        "per unit mass); omega relaxes towards curl(v)/2 at the rate 2 nu_t/Theta [1/s]",
    )


class Zorilla2020Config(_Model):
    """The Monte Carlo parameters of ``zorilla2020`` (Zorilla, Ritter et al. 2020; SPlisHSPlasH's
    ``surfTZR*`` names in brackets, defaults SPlisHSPlasH's); see
    :mod:`sphkit.surface_tension.zorilla2020`."""

    version: Literal["v2019", "v2020"] = Field(
        "v2020", description="v2019: Monte Carlo only, random samples (surfTZRversion 0); "
        "v2020: classification, Halton samples, optional PCA (surfTZRversion 1)")
    samples_per_second: float = Field(
        10000.0, ge=0, le=1e9, description="Monte Carlo samples per particle per second of "
        "simulated time, used as int(value * dt) per step when samples is -1 (surfTZRCsd) "
        "[1/s]")
    samples: int = Field(
        -1, ge=-1, le=100000, description="fixed Monte Carlo samples per particle and step; -1: "
        "samples_per_second * dt (surfTZRMCSamples; v2020 only)")
    r_ratio: float = Field(0.8, gt=0, lt=1, description="r2 / r1: radius of the neighbours' "
                           "covering spheres over the sampled sphere's h (surfTZRr-ratio)")
    tau: float = Field(0.5, ge=0, lt=1, description="weight of the neighbours in the smoothed "
                       "normal and curvature (surfTZRtau)")
    classifier_d: float = Field(12.0, ge=-1e6, le=1e6, description="constant d of the linear "
                                "surface classifier n <= 74.69 c + d (surfTZRd)")
    d_offset: float = Field(2.0, ge=-1e6, le=1e6, description="added to d when neighbours are "
                            "chosen for the PCA (surfTZRd-offset)")
    sampling: Literal["halton", "random"] = Field(
        "halton", description="v2020 sample directions (surfTZRsampling 0, 1)")
    normal_mode: Literal["pca", "mc", "mix"] = Field(
        "mc", description="v2020 normal and curvature: PCA, Monte Carlo or their mix "
        "(surfTZRnormal-mode 0, 1, 2)")
    pca_mix_normal: float = Field(0.75, ge=0, le=1, description="mix: weight of the PCA normal "
                                  "(surfTZRPcaMixNrm)")
    pca_mix_curvature: float = Field(0.5, ge=0, le=1, description="mix: weight of the PCA "
                                     "curvature (surfTZRPcaMixCur)")
    neighbour_limit: int = Field(13, ge=1, le=10000, description="nearest neighbours in the "
                                 "PCA (surfTZRNeighLimit)")
    smooth_passes: int = Field(0, ge=0, le=100, description="averaging passes of the PCA "
                               "curvature; 0 runs one (surfTZRsmoothPasses)")
    temporal_smoothing: bool = Field(False, description="v2020: blend the curvature with 0.95 of "
                                     "the previous step's (surfTZRtemporalSmooth)")


class Jeske2023Config(_Model):
    """The solver parameters of ``jeske2023`` (Jeske et al. 2023; SPlisHSPlasH's names in
    brackets, defaults SPlisHSPlasH's); see :mod:`sphkit.surface_tension.jeske2023`."""

    viscosity: float = Field(0.0, ge=0, le=1e6, description="kinematic viscosity nu of the "
                             "implicit solve [m^2/s] (surfaceTensionViscosity)")
    boundary_viscosity: float = Field(0.0, ge=0, le=1e6, description="wall viscosity nu_b "
                                      "[m^2/s] (surfaceTensionViscosityBoundary)")
    xsph: float = Field(0.0, ge=0, le=1, description="XSPH factor of the implicit solve "
                        "(surfaceTensionXSPH)")
    max_iterations: int = Field(100, ge=1, le=100000, description="CG iterations at most "
                                "(surfaceTensionMaxIter)")
    max_error: float = Field(1e-3, gt=0, le=1, description="CG tolerance on the relative "
                             "residual (surfaceTensionMaxError)")


class SurfaceTensionConfig(_Model):
    """Surface tension and adhesion: ``becker2007`` (Becker & Teschner 2007, SPlisHSPlasH
    surfaceTensionMethod 1), ``akinci2013`` (Akinci et al. 2013, 2), ``he2014`` (He et al. 2014,
    3); see :mod:`sphkit.surface_tension`. The coefficients are the models' own, not the physical
    surface tension sigma [N/m] (validation/surface_tension.py measures what they give);
    defaults are SPlisHSPlasH's. ``mueller2003`` (Müller et al. 2003 continuum surface force, no
    SPlisHSPlasH number): ``coefficient`` is the physical sigma, no adhesion. ``zorilla2020``
    (Zorilla, Ritter et al. 2020, 5): Monte Carlo normals and curvature, parameters in the
    ``zorilla2020`` block. ``jeske2023`` (Jeske et al. 2023, 4): implicit cohesion, adhesion
    and viscosity, solver parameters in the ``jeske2023`` block."""

    method: SurfaceTensionMethod = "none"
    coefficient: float = Field(
        0.05, ge=0, le=1e6, allow_inf_nan=False,
        description="becker2007: cohesion kappa [m^d/s^2]; akinci2013: gamma (cohesion "
        "m^4/(kg s^2), curvature m/s^2: one number for both, as in the paper); he2014: surface "
        "energy kappa [N in 3D, J in 2D] (SPlisHSPlasH surfaceTension, default 0.05); "
        "mueller2003: the surface tension sigma [N/m in 3D, N in 2D]; zorilla2020: gamma "
        "[N m in 3D, N in 2D], the force per curvature of one surface particle "
        "(SPlisHSPlasH surfaceTension, default 0.05); jeske2023: cohesion gamma [N/m in 3D] "
        "(surfaceTension, default 0.05)",
    )
    boundary_coefficient: float = Field(
        0.01, ge=0, le=1e6, allow_inf_nan=False,
        description="fluid-boundary term, same units as coefficient: becker2007 and he2014 "
        "adhesion kappa_b, akinci2013 adhesion beta (SPlisHSPlasH surfaceTensionBoundary, "
        "default 0.01); mueller2003: none (0, its default); zorilla2020: none (unused)",
    )
    zorilla2020: Zorilla2020Config = Field(
        default_factory=Zorilla2020Config,
        description="zorilla2020 only: the Monte Carlo / PCA parameters")
    jeske2023: Jeske2023Config = Field(
        default_factory=Jeske2023Config,
        description="jeske2023 only: viscosity and solver parameters of the implicit solve")

    @model_validator(mode="after")
    def _mueller_no_adhesion(self) -> SurfaceTensionConfig:
        # a block equal to its defaults is what a dumped scene carries for every method: accepted
        if self.method != "zorilla2020" and self.zorilla2020 != Zorilla2020Config():
            raise ValueError(f"zorilla2020: parameters given for method {self.method!r}; "
                             "expected them only with method zorilla2020")
        if self.method != "jeske2023" and self.jeske2023 != Jeske2023Config():
            raise ValueError(f"jeske2023: parameters given for method {self.method!r}; "
                             "expected them only with method jeske2023")
        if self.method == "zorilla2020" and "boundary_coefficient" not in self.model_fields_set:
            self.boundary_coefficient = 0.0
        if self.method == "mueller2003":
            if "boundary_coefficient" not in self.model_fields_set:
                self.boundary_coefficient = 0.0
            elif self.boundary_coefficient != 0.0:
                raise ValueError(
                    f"boundary_coefficient {self.boundary_coefficient}: mueller2003 has no "
                    "adhesion term; expected 0")
        return self


class DragConfig(_Model):
    """Air drag on surface particles: ``macklin2014`` (Macklin et al. 2014, SPlisHSPlasH
    dragMethod 1) or ``gissler2017`` (Gissler et al. 2017, dragMethod 2); see
    :mod:`sphkit.drag`."""

    method: DragMethod = "none"
    coefficient: float = Field(
        0.01, ge=0, le=1e6, allow_inf_nan=False,
        description="macklin2014: k [kg/s] of a = -(k/m)(v - v_air) max(0, 1 - rho/rho0); "
        "gissler2017: dimensionless scale of the droplet drag (SPlisHSPlasH drag, default 0.01)",
    )
    air_velocity: Vec | None = Field(
        None, description="velocity of the surrounding air [m/s] (default: at rest)"
    )


class FixedBox(_Model):
    """An axis-aligned box whose solid particles are pinned: particles whose rest position lies
    inside ``[min, max]`` keep that position and zero velocity (SPlisHSPlasH ``fixedBoxMin``,
    ``fixedBoxMax``)."""

    min: Vec = Field(description="lower corner [m]")
    max: Vec = Field(description="upper corner [m]")

    @model_validator(mode="after")
    def _ordered(self) -> FixedBox:
        if len(self.min) != len(self.max) or len(self.min) not in (1, 2, 3):
            raise ValueError(f"min {self.min} and max {self.max}: expected two vectors of the "
                             "same length (1 to 3)")
        for a, b in zip(self.min, self.max, strict=True):
            if not b >= a:
                raise ValueError(f"max {self.max} must not be below min {self.min} on any axis")
        return self


class ReuseBox(FixedBox):
    """An axis-aligned box ``[min, max]`` [m] of an emitter: fluid particles of its material
    found outside it are moved back into the emitter as its next layers (keeping their ids)
    before new particles are added, and slowed by 5 % a step while they wait (SPlisHSPlasH's
    ``emitterReuseParticles`` with ``emitterBoxMin``/``emitterBoxMax``)."""


class ElasticityConfig(_Model):
    """Elasticity of a solid material (SPlisHSPlasH ``elasticityMethod``): ``becker2009``
    (Becker et al. 2009 corotated SPH, explicit, 1; :mod:`sphkit.solids.becker2009`),
    ``peer2018`` (Peer et al. 2018, implicit, 2; :mod:`sphkit.solids.peer2018`),
    ``kugelstadt2021`` (Kugelstadt et al. 2021, implicit, pre-factorised, 3;
    :mod:`sphkit.solids.kugelstadt2021`; its ``max_iterations``/``max_error`` are those of the
    volume solve, volumeMaxIter/volumeMaxError), ``kee2023`` (Kee et al. 2023, hyperelastic,
    backward Euler as a minimisation by Newton or L-BFGS, 4; :mod:`sphkit.solids.kee2023`; its
    ``max_iterations`` are the minimisation's, maxIterations, and its own fields below). A
    material with an elasticity is an elastic solid: its particles keep their rest
    neighbourhoods, feel the elastic force in the non-pressure stage and still go through the
    pressure solver (volume, contact). Defaults are SPlisHSPlasH's."""

    method: ElasticityMethod = "none"
    youngs_modulus: float = Field(
        1e5, gt=0, description="Young's modulus E [Pa] (SPlisHSPlasH youngsModulus)")
    poisson_ratio: float = Field(
        0.3, gt=-1, lt=0.5,
        description="Poisson's ratio nu, dimensionless, in (-1, 0.5) (poissonsRatio); Lame "
        "mu = E / (2 (1 + nu)), lambda = E nu / ((1 + nu)(1 - 2 nu)); in 2D plane strain")
    alpha: float = Field(
        0.0, ge=0,
        description="zero-energy-mode (hourglass) control factor alpha, dimensionless "
        "(Ganzenmüller 2015; 0: off; SPlisHSPlasH's scenes use 0.1)")
    max_neighbors: int = Field(
        -1, ge=-1,
        description="cap on the rest neighbours of a particle (the nearest ones; pairs are kept "
        "only when each is among the other's nearest, so the lists stay symmetric); -1: all "
        "(SPlisHSPlasH maxNeighbors)")
    max_iterations: int = Field(
        100, ge=1, description="implicit models: maximum solver iterations (elasticityMaxIter)")
    max_error: float = Field(
        1e-4, gt=0, lt=1,
        description="implicit models: relative residual tolerance of the linear solve "
        "(elasticityMaxError), dimensionless")
    gradient_correction: Literal["none", "linear", "quadratic"] = Field(
        "quadratic",
        description="the displacement gradient's weights (sphkit.solids.gradients): "
        "'none', SPlisHSPlasH's plain SPH gradient; 'linear', corrected kernel gradients "
        "(Bonet & Lok 1999), exact for linear displacements; 'quadratic', a second-order "
        "least-squares gradient, exact for the quadratic displacement of a bent beam (the "
        "others make thin beams tens of percent too soft in bending)")
    rest_support: float = Field(
        1.5, ge=1, le=2,
        description="radius of the rest neighbourhoods as a multiple of the support "
        "radius h (1: SPlisHSPlasH's); the quadratic gradient needs more neighbours than a "
        "surface particle has within h (it falls back to the linear one there); 1.5 gives "
        "them, at about 3 times the pairs in 3D")
    rest_volume: Literal["particle", "kernel_sum"] = Field(
        "particle",
        description="the rest volume V0 of a particle in the elastic sums: "
        "'particle', its own V0 = m / density0 (the volume of its sampling lattice); "
        "'kernel_sum', SPlisHSPlasH's m / sum_j m_j W(x0_ij), up to 1.65 times larger at the "
        "surface (a stiffer surface layer)")
    fixed_boxes: list[FixedBox] = Field(
        default_factory=list,
        description="boxes whose particles (by rest position) are pinned (fixedBoxMin/Max; "
        "kee2023 also fixedBox2Min/Max); kee2023's pinned particles move with their velocity "
        "(zero unless an animation field sets it), the others' stay at rest")
    solver: Literal["newton", "lbfgs"] = Field(
        "lbfgs", description="kee2023: the minimiser, projected Newton with block-Jacobi CG or "
        "L-BFGS on a pre-factorised initial Hessian (solverType 0, 1)")
    material_model: Literal["corotated", "stable_neo_hookean"] = Field(
        "corotated", description="kee2023: the energy density, corotated or stable "
        "neo-Hookean (Smith et al. 2018, Lamé parameters remapped so E and nu keep their "
        "small-strain meaning) (materialType 1, 0)")
    max_position_change: float = Field(
        1e-6, gt=0, description="kee2023: the minimisation stops when no particle moves by "
        "more than this in an iteration [m] (maxError)")
    cg_max_iterations: int = Field(
        100, ge=1, description="kee2023 Newton: CG iterations per Newton step "
        "(maxIterationsCG)")
    cg_tolerance: float = Field(
        1e-4, gt=0, lt=1, description="kee2023 Newton: relative residual of the CG, "
        "dimensionless (tolCG)")
    lbfgs_window: int = Field(
        5, ge=0, description="kee2023 L-BFGS: secant pairs kept (lbfgsWindowSize)")
    line_search: bool = Field(
        True, description="kee2023: backtracking Armijo line search (useLineSearch)")
    line_search_iterations: int = Field(
        20, ge=1, description="kee2023: line-search trials per iteration (maxLSIterations)")
    armijo: float = Field(
        1e-4, gt=0, lt=0.5, description="kee2023: Armijo's sufficient-decrease factor c1, "
        "dimensionless (lsArmijoParam)")
    line_search_beta: float = Field(
        0.5, gt=0, lt=1, description="kee2023: step factor per line-search trial, "
        "dimensionless (lsBeta)")
    rotation: Literal["moment", "gradient"] = Field(
        "moment",
        description="becker2009, peer2018: the corotated frame of a particle: 'moment', the "
        "rotation of its moment matrix sum_j m_j W x_ji x0_ji^T (Becker et al. 2009, "
        "SPlisHSPlasH); 'gradient', the polar rotation of its deformation gradient (then the "
        "force is the gradient of a rotation-invariant energy: angular momentum is kept to "
        "round-off with the 'linear' or 'quadratic' gradient_correction)")
    clamp: Literal["particles", "face"] = Field(
        "particles",
        description="the pinned particles (fixed_boxes) in the elastic sums: 'particles' "
        "(SPlisHSPlasH's), pinned particles are particles of the solid, with their own strain "
        "and stress, and the free particles' gradient fits sample them where they are; "
        "'face', pinned particles are rigid (no strain) and a free particle's fit samples "
        "their zero displacement where the pair's segment enters the fixed box, on the "
        "clamp's face (assumes the pinned particles at rest)")
    yield_stress: float | None = Field(
        None, ge=0,
        description="sphkit's own: von Mises yield stress sigma_y [Pa] of the corotated strain "
        "(J2 plasticity with radial return, sphkit.solids.plasticity); absent, null or 0: "
        "purely elastic (the default)")
    hardening: float = Field(
        0.0, ge=0,
        description="sphkit's own: linear isotropic hardening modulus H [Pa], the growth of "
        "the yield stress per unit equivalent plastic strain (0: perfectly plastic)")

    @model_validator(mode="after")
    def _cap(self) -> ElasticityConfig:
        if self.max_neighbors == 0:
            raise ValueError("max_neighbors 0: expected -1 (no cap) or a count >= 1")
        return self


class Material(_Model):
    """A fluid material, or an elastic solid when ``elasticity.method`` is not none."""

    id: str = "fluid"
    density0: float = Field(1000.0, gt=0, description="rest density [kg/m^3]")
    viscosity: ViscosityConfig = ViscosityConfig()
    vorticity: VorticityConfig = VorticityConfig()
    surface_tension: SurfaceTensionConfig = SurfaceTensionConfig()
    drag: DragConfig = DragConfig()
    elasticity: ElasticityConfig = ElasticityConfig()

    @property
    def elastic(self) -> bool:
        """Whether the material is an elastic solid."""
        return self.elasticity.method != "none"


class InterfaceViscosityConfig(_Model):
    """Viscosity between the two materials of an interface (``morris1997``: Morris et al.
    1997's Laplacian over the pairs of unlike phases, :mod:`sphkit.multiphase.morris1997`)."""

    method: InterfaceViscosityMethod = "none"
    coefficient: float = Field(
        0.0, ge=0, le=1e6, description="kinematic viscosity nu [m^2/s] between the two "
        "phases; the pair's dynamic viscosity is the harmonic mean of rho0_a nu and rho0_b nu "
        "(= rho0 nu for equal rest densities)",
    )
    laplacian_eps: float = Field(
        0.01, gt=0, le=1, description="regularisation eps of |x_ij|^2 + eps h^2 "
        "(dimensionless; Morris 1997's 0.01)",
    )


class InterfaceTensionConfig(_Model):
    """Tension of the interface between two fluid materials (``hu2006``: the surface stress of
    Hu & Adams 2006, :mod:`sphkit.multiphase.hu2006`)."""

    method: InterfaceTensionMethod = "none"
    coefficient: float = Field(
        0.0, ge=0, le=1e6, description="interface tension sigma [N/m] (2D: N, per unit "
        "depth): the pressure jump across the interface is sigma kappa (sigma / R for a 2D "
        "drop, 2 sigma / R in 3D)",
    )
    background_pressure: float = Field(
        0.0, ge=0, le=1e9, description="hu2006: a background pressure p_b [Pa] added to the "
        "surface stress of the particles in the interface band (Pi - p_b I; Hu & Adams 2006 "
        "run with a background pressure): a repulsion among the band's particles that "
        "closes the gap the tangential tension opens at the interface; 0: none",
    )


class Interface(_Model):
    """Forces between two fluid materials (phases) of a scene with several fluids. Without an
    entry, the materials meet as SPlisHSPlasH's phases do: through the pressure alone (each
    material's viscosity and surface tension act within its own phase)."""

    materials: list[str] = Field(description="the ids of the two fluid materials")
    viscosity: InterfaceViscosityConfig = InterfaceViscosityConfig()
    tension: InterfaceTensionConfig = InterfaceTensionConfig()

    @field_validator("materials")
    @classmethod
    def _two(cls, v: list[str]) -> list[str]:
        if len(v) != 2 or v[0] == v[1]:
            raise ValueError(f"materials {v}: expected the ids of two different materials")
        return v


class FluidBlock(_Model):
    """An axis-aligned block of fluid, sampled on a lattice of spacing 2r (square, or hexagonal
    in 2D)."""

    start: Vec = Field(description="lower corner [m]")
    end: Vec = Field(description="upper corner [m]")
    material: str = "fluid"
    velocity: Vec | None = Field(None, description="initial velocity [m/s]")
    angular_velocity: Vec3 | None = Field(
        None, description="initial angular velocity [rad/s] (3 components; in 2D only z "
        "acts): the block starts with ``velocity + angular_velocity x (x - centre)`` about "
        "the centre of its particles (SPlisHSPlasH's initialAngularVelocity)")
    lattice: Literal["square", "hexagonal", "layered", "close_packed"] = Field(
        "square", description="'square': spacing 2r (SPlisHSPlasH's denseMode 0); 'hexagonal' "
        "(2D only): touching discs (spacing 2r, rows along x), the packing a 2D fluid at rest "
        "settles into; 'layered' and 'close_packed': SPlisHSPlasH's denseMode 1 and 2 "
        "(sphkit.geometry.sampling.dense_block); particle volume 1 / sum_k W over the lattice")

    @model_validator(mode="after")
    def _ordered(self) -> FluidBlock:
        if len(self.start) != len(self.end):
            raise ValueError(f"start {self.start} and end {self.end} differ in length")
        for a, b in zip(self.start, self.end, strict=True):
            if not b > a:
                raise ValueError(f"end {self.end} must exceed start {self.start} on every axis")
        return self


class FluidFile(_Model):
    """Fluid read from a particle file (BGEO, PLY, VTK/VTU; SPlisHSPlasH's ``FluidModels``).

    Placed as SPlisHSPlasH does: ``x = R(rotation_axis, rotation_angle) (scale x_file) +
    translation``; initial velocity ``velocity + angular_velocity x (x - centre)`` (see
    :mod:`sphkit.io.particle_files`). The particles get the mass of the scene's lattice (spacing
    2r), so the file should be sampled at that spacing.
    """

    file: str = Field(description="particle file, relative to the scene file")
    translation: Vec3 = Field([0.0, 0.0, 0.0], description="offset [m] (3 components)")
    scale: float = Field(1.0, gt=0, description="uniform scale factor of the file's positions")
    rotation_axis: Vec3 = Field([1.0, 0.0, 0.0], description="rotation axis (3 components)")
    rotation_angle: float = Field(0.0, description="rotation about rotation_axis [rad]")
    material: str = "fluid"
    velocity: Vec3 | None = Field(None, description="initial velocity [m/s] (3 components)")
    angular_velocity: Vec3 | None = Field(
        None, description="initial angular velocity [rad/s] about the particles' centre (3)"
    )
    use_file_velocity: bool = Field(
        False, description="start from the file's velocity attribute (plus velocity and "
        "angular_velocity); SPlisHSPlasH ignores it"
    )


class Box(_Model):
    """A box container of boundary particles: the fluid lives inside [min, max]."""

    min: Vec = Field(description="inner lower corner [m]")
    max: Vec = Field(description="inner upper corner [m]")
    layers: int = Field(
        2, ge=1, le=4, description="number of particle layers of the walls (each particle has "
        "the fluid's lattice volume; two span the kernel's support h = 4r, so that fluid pushed "
        "nearer than 2r to the wall still sees a complete wall: with one, a 2D dam break's "
        "particles came within 0.56-0.80 r of a wall particle, with two 0.83-0.96 r)")
    open_top: bool = Field(False, description="leave out the wall at max along the gravity axis")
    viscosity_factors: list[float] | None = Field(
        None,
        description="per face, a factor on the material viscosity's boundary_coefficient at "
        "this box's walls (standard viscosity only), in the order -x, +x, -y, +y (, -z, +z): "
        "2 dim values >= 0; a particle beyond several faces (an edge or corner) takes the "
        "largest of theirs; default 1 on every face. E.g. 2D [0, 0, 1, 0] with y up: the "
        "wall term acts on the floor only (free-slip side walls, a rough floor)",
    )

    @model_validator(mode="after")
    def _ordered(self) -> Box:
        if len(self.min) != len(self.max):
            raise ValueError(f"min {self.min} and max {self.max} differ in length")
        for a, b in zip(self.min, self.max, strict=True):
            if not b > a:
                raise ValueError(f"max {self.max} must exceed min {self.min} on every axis")
        f = self.viscosity_factors
        if f is not None:
            if len(f) != 2 * len(self.min):
                raise ValueError(
                    f"viscosity_factors {f}: {len(f)} values; expected {2 * len(self.min)}, "
                    "one per face (-x, +x, -y, +y" + (", -z, +z)" if len(self.min) == 3
                                                      else ")"))
            if not all(math.isfinite(v) and v >= 0.0 for v in f):
                raise ValueError(f"viscosity_factors {f}: expected finite values >= 0")
        return self


class MeshBoundary(_Model):
    """A static wall from a triangle mesh (OBJ/PLY/STL): its surface sampled into particles
    (akinci2012), or its signed distance turned into a density or volume map (koschier2017,
    bender2019). In 2D the mesh's section with the plane z = 0 is used."""

    geometry_file: str = Field(description="mesh file, relative to the scene file")
    translation: Vec = [0.0, 0.0, 0.0]
    rotation_axis: Vec = [1.0, 0.0, 0.0]
    rotation_angle: float = Field(0.0, description="rotation about rotation_axis [rad]")
    scale: Vec = [1.0, 1.0, 1.0]
    invert: bool = Field(False, description="the fluid is inside the mesh (a container)")
    map_thickness: float = Field(
        0.0, allow_inf_nan=False,
        description="maps: the wall surface is moved this far into the fluid [m] "
        "(SPlisHSPlasH mapThickness)",
    )
    map_resolution: list[int] | None = Field(
        None, description="maps: grid cells per axis (SPlisHSPlasH mapResolution); default "
        "configuration.boundary.map_resolution",
    )

    # rigid bodies (every boundary.method, 2D and 3D; see sphkit.boundary.rigid)
    dynamic: bool = Field(False, description="a dynamic rigid body moved by fluid forces, "
                          "gravity and contacts (SPlisHSPlasH isDynamic)")
    density: float = Field(1000.0, gt=0.0, allow_inf_nan=False,
                           description="dynamic bodies: density of the closed mesh [kg/m^3]")
    velocity: Vec | None = Field(
        None, description="kinematic bodies: prescribed velocity [m/s]; dynamic: initial one")
    angular_velocity: Vec | None = Field(
        None, description="kinematic bodies: prescribed angular velocity vector [rad/s] about "
        "rotation_center; dynamic: the initial one (about the centre of mass)")
    rotation_center: Vec | None = Field(
        None, description="kinematic bodies: point the rotation turns about at t = 0 [m]; "
        "default the mesh's centre of mass")
    friction: float = Field(0.5, ge=0.0, allow_inf_nan=False,
                            description="dynamic bodies: Coulomb friction coefficient of "
                            "contacts with static walls")
    restitution: float = Field(
        0.0, ge=0.0, le=1.0, allow_inf_nan=False,
        description="dynamic bodies: coefficient of restitution of their contacts with walls "
        "and bodies (SPlisHSPlasH's PositionBasedDynamics restitution): a contact met at a "
        "normal speed above 2 |g| dt leaves at that speed times it; between two bodies the "
        "geometric mean; 0: inelastic")

    @field_validator("map_resolution")
    @classmethod
    def _cells(cls, v: list[int] | None) -> list[int] | None:
        if v is not None and (len(v) not in (2, 3) or min(v) < 1):
            raise ValueError(f"map_resolution {v}: expected 2 or 3 positive cell counts")
        return v

    @field_validator("velocity", "angular_velocity", "rotation_center")
    @classmethod
    def _vec3(cls, v: Vec | None) -> Vec | None:
        if v is not None and len(v) != 3:
            raise ValueError(f"{v}: expected 3 components")
        return v

    @property
    def kinematic(self) -> bool:
        """A prescribed motion (velocity or angular velocity given, not dynamic)."""
        return not self.dynamic and (any(self.velocity or []) or any(self.angular_velocity or []))

    @property
    def moving(self) -> bool:
        """A rigid body that moves (dynamic or kinematic), not a static wall."""
        return self.dynamic or self.kinematic


class FluidMesh(_Model):
    """Fluid filling a closed triangle mesh (OBJ/PLY/STL; 2D: its section with z = 0), sampled on
    the lattice ``bbox_min + r + 2r k`` keeping points with negative signed distance (inside), as
    SPlisHSPlasH samples its FluidModels."""

    geometry_file: str = Field(description="mesh file, relative to the scene file")
    translation: Vec = [0.0, 0.0, 0.0]
    rotation_axis: Vec = [1.0, 0.0, 0.0]
    rotation_angle: float = Field(0.0, description="rotation about rotation_axis [rad]")
    scale: Vec = [1.0, 1.0, 1.0]
    invert: bool = Field(
        False, description="fill the mesh's bounding box outside the mesh instead of inside"
    )
    material: str = "fluid"
    velocity: Vec | None = Field(None, description="initial velocity [m/s]")
    angular_velocity: Vec3 | None = Field(
        None, description="initial angular velocity [rad/s] (3 components; in 2D only z "
        "acts) about the centre of the mesh's particles, added to velocity")
    lattice: Literal["square", "layered", "close_packed"] = Field(
        "square", description="the sampling lattice (SPlisHSPlasH's FluidModels mode 0, 1, 2: "
        "VolumeSampling's lattices, sphkit.geometry.mesh_sampling.volume_lattices): "
        "'square' spacing 2r; 'layered' rows sqrt(3) r apart, alternate rows shifted by r; "
        "'close_packed' x spacing sqrt(3) r, rows 2 sqrt(6) r / 3 apart, shifted as "
        "SPlisHSPlasH shifts them. Particle volume 1 / sum_k W over the lattice")


class Emitter(_Model):
    """A fluid emitter (SPlisHSPlasH's ``Emitters``; :mod:`sphkit.world.emitters`).

    Every ``2r / velocity`` seconds from ``start_time`` to ``end_time`` it adds a layer of
    particles (spacing 2r) at ``position``, moving with ``velocity`` along the emit direction
    ``R e_x`` (R: ``rotation_angle`` about ``rotation_axis``). Box: ``round(width / 2r)`` particles
    along ``R e_z`` times ``round(height / 2r)`` along ``R e_y``; circle: the lattice points of
    that grid (``width`` by ``width``) within the disc of diameter ``width``. In 2D a layer is a
    line of ``round(width / 2r)`` particles along ``R e_y`` (rotations about z only).
    """

    shape: Literal["box", "circle"] = "box"
    position: Vec = Field(description="centre of the emitted layer [m] (dim or 3 components)")
    width: float = Field(gt=0, description="box: extent along R e_z; circle: diameter; 2D: "
                         "length of the emitted line [m]")
    height: float | None = Field(None, gt=0, description="box in 3D: extent along R e_y [m] "
                                 "(default: width)")
    velocity: float = Field(1.0, gt=0, description="emission speed along R e_x [m/s]")
    rotation_axis: Vec = Field([0.0, 0.0, 1.0], description="rotation axis (3 components)")
    rotation_angle: float = Field(0.0, description="rotation about rotation_axis [rad]")
    start_time: float = Field(0.0, ge=0, description="first emission [s]")
    end_time: float | None = Field(None, description="last emission [s] (None: never stops)")
    material: str = "fluid"
    max_particles: int | None = Field(
        None, ge=0, description="stop emitting after this many particles (SPlisHSPlasH's "
        "maxEmitterParticles: the emitters of one material share the smallest limit among them)")
    housing: bool = Field(
        True, description="surround the emitter with boundary particles, a box (cylinder) open "
        "towards the emit direction, as SPlisHSPlasH does")
    reuse_box: ReuseBox | None = Field(
        None, description="particles of the emitter's material outside this box {min, max} "
        "[m] are emitted again (same ids) before new ones are added (SPlisHSPlasH "
        "emitterReuseParticles, emitterBoxMin/Max); the emitters of one material share them")

    @model_validator(mode="after")
    def _valid(self) -> Emitter:
        if len(self.rotation_axis) != 3:
            raise ValueError(f"rotation_axis {self.rotation_axis} must have 3 components")
        if self.end_time is not None and not self.end_time >= self.start_time:
            raise ValueError(f"end_time {self.end_time} must not precede start_time "
                             f"{self.start_time}")
        return self


class BoundaryConfig(_Model):
    """Boundary model: ``akinci2012`` boundary particles (Akinci et al. 2012), ``koschier2017``
    density maps (Koschier & Bender 2017) or ``bender2019`` volume maps (Bender et al. 2019).

    ``pressure`` left out (or null) takes the boundary model's default from the registry
    (:func:`sphkit.registry.default_boundary_pressure`: ``mls`` for akinci2012,
    ``hydrostatic`` for the maps), resolved here, so the validated scene names the pressure
    that runs."""

    method: BoundaryMethod = "akinci2012"
    pressure: BoundaryPressureMethod = Field(
        None,  # type: ignore[assignment]  # None: the model's default (_default_pressure)
        description="akinci2012: pressure of the static boundary particles in the "
        "pressure force: 'mls' (moving least squares extrapolation from the fluid, Band et al. "
        "2018; the default) or 'mirror' (p_b = p_i, Akinci et al. 2012); koschier2017 / "
        "bender2019: 'hydrostatic' (the default: adds the static walls' share of the "
        "tangential pressure gradient for p_b = p_i + rho_i g . (x_b - x_i), Adami et al. 2012) "
        "or 'mirror' (SPlisHSPlasH's boundary term); null or absent: the model's default",
    )
    symmetric: bool = Field(
        False, description="the PPE solvers (DFSPH, IISPH, PCISPH) use SPlisHSPlasH's "
        "boundary term V_b k_i alone (no mirrored share, no extrapolated boundary pressure): "
        "the only form that keeps their operator symmetric positive; needed for a light fluid "
        "under a heavy one between walls (density ratio 1:10), where the other forms make it "
        "indefinite and the Jacobi iterations diverge (validation/README.md, 'Several fluids'); "
        "WCSPH then uses the same term, which does no work on the fluid (the mirrored one "
        "pumped energy into water at rest, validation/README.md, 'WCSPH in the tank at rest'). "
        "Left out: false, but true for WCSPH where a fluid's kinematic viscosity is below "
        "(2r)^2 times 1/s (none, or water's: the other wall terms pump energy into the flow "
        "until it leaks; validation/README.md, \"WCSPH's walls by default: the energy they "
        "pump\")",
    )
    solved: bool | Literal["velocity", "density", "stratified"] = Field(
        False, description="the static wall particles (boxes, static meshes) get a pressure of "
        "their own that IISPH and DFSPH solve for in the same Jacobi iteration as the fluid's "
        "and PCISPH in the same predict-correct sweep, so that the fluid's density at each wall "
        "particle does not change in a step (after Band et al. 2018, 'Pressure boundaries for "
        "IISPH'): a wall force that does no work on the flow, where the mirrored or MLS "
        "boundary pressure (the default) pumped energy into a closed box of fluid at rest "
        "(validation/wall_energy.py); akinci2012 only; ICSPH and WCSPH then use the symmetric "
        "term V_b k_i. true or 'velocity': the walls' constraint holds the rate of that density "
        "(velocity level); 'density': the density solves hold the density itself at its start "
        "value at every wall particle whose fluid neighbours all had full kernels at the start "
        "(the others, and DFSPH's divergence solve, keep the rate); validation/README.md, "
        "'Solved walls at density level'. 'stratified': as 'density', but only the wall "
        "particles among whose fluid neighbours a lighter fluid lies below the heaviest one "
        "(each step); the others take the boundary pressure model's value (MLS per phase): "
        "in 2D the rows of every wall particle hold the fluid column beside a side wall and "
        "steepen a resting column by 3-8 %, where they are needed only to keep a heavy-over-"
        "light overturn stable (validation/README.md, 'Solved walls where the fluid is "
        "stratified'). Left out: 'stratified' with iisph and dfsph in a scene whose fluids' "
        "rest densities differ by more than a factor 4 and at most 10, 'density' beyond 10 "
        "and with pcisph (every wall row keeps overturns stable to 1:50, the stratified rows "
        "to 1:10-1:30, PCISPH's less far), with akinci2012 (validation/README.md, 'Several "
        "rest densities: the solved walls by default'), else false",
    )
    map_resolution: list[int] | None = Field(
        None, description="maps: default grid cells per axis; None: cells of about one support "
        "radius (at most 8 million grid points); 2D density maps are built on cells of at most "
        "half a support radius whatever this says (koschier2017.MAX_CELL_2D)",
    )
    map_cache: bool = Field(True, description="maps: keep computed maps in the cache folder")
    map_cache_dir: str | None = Field(
        None, description="maps: cache folder (default $SPHKIT_CACHE_DIR or ~/.cache/sphkit)"
    )

    @field_validator("map_resolution")
    @classmethod
    def _cells(cls, v: list[int] | None) -> list[int] | None:
        if v is not None and (len(v) not in (2, 3) or min(v) < 1):
            raise ValueError(f"map_resolution {v}: expected 2 or 3 positive cell counts")
        return v

    @model_validator(mode="after")
    def _one_wall_term(self) -> BoundaryConfig:
        solved = "true" if self.solved is True else repr(self.solved)
        if self.symmetric and self.solved:
            raise ValueError(f"symmetric true and solved {solved}: expected at most one of them "
                             "(two different wall terms of the PPE solvers)")
        if self.solved and self.method != "akinci2012":
            raise ValueError(f"solved {solved} with method {self.method!r}: expected method "
                             "'akinci2012' (the solved wall pressures belong to boundary "
                             "particles)")
        return self

    #: ``pressure`` was left out and is the model's default (the scene may change it to the
    #: default for moving bodies, :meth:`Scene._moving_bodies_pressure`)
    _pressure_default: bool = PrivateAttr(False)
    #: ``solved`` was left out (the scene may solve the walls where its fluids differ in rest
    #: density, :meth:`Scene._several_densities_walls`)
    _solved_default: bool = PrivateAttr(False)
    #: ``symmetric`` was left out (WCSPH takes it for nearly inviscid fluids,
    #: :meth:`Scene._inviscid_wcsph_walls`)
    _symmetric_default: bool = PrivateAttr(False)

    @model_validator(mode="wrap")
    @classmethod
    def _default_pressure(cls, data: Any, handler: Any) -> Any:
        """``pressure`` absent or null: the boundary model's default (registry); ``solved``
        absent: false until the scene decides (:attr:`_solved_default`)."""
        defaulted = solved_default = False
        if isinstance(data, dict) and data.get("pressure") is None:
            method = data.get("method", cls.model_fields["method"].default)
            if isinstance(method, str) and method in registry.names("boundary"):
                data = {**data, "pressure": registry.default_boundary_pressure(method)}
                defaulted = True
        if isinstance(data, dict) and "solved" not in data:
            solved_default = True
        symmetric_default = isinstance(data, dict) and "symmetric" not in data
        out = handler(data)
        if isinstance(out, BoundaryConfig):
            out._pressure_default = out._pressure_default or defaulted
            out._solved_default = solved_default
            out._symmetric_default = symmetric_default
        return out


class StartConfig(_Model):
    """How the fluid starts (:mod:`sphkit.world.startup`). Fluid particles that start inside a
    wall or body are always removed, with a warning naming the block and the count."""

    hydrostatic: bool = Field(
        True, description="start every fluid object with the density and pressure of its "
        "hydrostatic column: p = rho0 |g| depth below the top of the connected column of fluid "
        "along gravity (plus r), the density through the state equation (WCSPH) or rho0 (the "
        "incompressible solvers; IISPH warm-starts from p); false: at rest density, p = 0")
    relax: bool = Field(
        True, description="move fluid sampled too close to walls and bodies out of the boundary "
        "model's range (a density relaxation before t = 0, without gravity or time) and set "
        "each particle's mass so that its summation density is its start density; false: the "
        "particles and lattice masses as sampled")
    relax_iterations: int = Field(
        100, ge=0, le=10000, description="largest number of relaxation sweeps (it stops once "
        "no particle is more than 1 % too dense)")
    settle: Literal["auto"] | bool = Field(
        "auto", description="before t = 0, let fluid at rest in its container settle into its "
        "solver's own equilibrium: the simulation's step with gravity and a velocity damping at "
        "the critical rate of the deepest column's first acoustic mode (dynamic relaxation; "
        "state-equation solvers only: WCSPH), until the fluid's root mean square speed is below "
        "settle_speed; "
        "the clock then starts at 0 with the fluid at rest. \"auto\": when the solver has a "
        "speed of sound, gravity acts, and every resting fluid particle deeper than h below its "
        "free surface has a full neighbourhood or a wall beside it (a container, not a dam "
        "break's free face), with no moving body, emitter, elastic solid or animation field, "
        "and one fluid")
    settle_speed: float = Field(
        0.005, gt=0, description="the settling stops once the root mean square speed of the "
        "fluid is below this [m/s]")
    settle_periods: float = Field(
        30.0, gt=0, le=1000, description="longest settling, in periods 4 H / c of the deepest "
        "column's first acoustic mode (H its depth, c the speed of sound)")
    settle_min_periods: float = Field(
        20.0, ge=0, le=1000, description="shortest settling, in the same periods, whatever the "
        "speed: a block sampled on a 2D square lattice keeps rearranging into hexagonal grains "
        "for 1-2 s after its speed is below settle_speed; at most settle_periods")


class OutputConfig(_Model):
    """Frame output."""

    fps: float = Field(25.0, gt=0, le=MAX_FPS, description="frames per simulated second [1/s] "
                       "(at most one frame is written per time step)")
    formats: list[Literal["vtk", "ply", "bgeo", "bgeo.gz"]] = ["vtk"]
    attributes: list[str] | None = Field(
        None, description="particle attributes written besides position and id, e.g. "
        "[velocity, density, pressure] (SPlisHSPlasH's particleAttributes); None: velocity, "
        "density and pressure"
    )
    directory: str | None = Field(None, description="output folder (default: out/<scene name>)")
    body_formats: list[Literal["vtk", "obj", "ply"]] | None = Field(
        None, description="formats of the moving rigid bodies' meshes at each frame "
        "(bodies_00042.vtu/.obj/.ply, sphkit.io.bodies); None: vtk beside vtk frames, ply "
        "beside ply, obj beside bgeo; []: none (SPlisHSPlasH's enableRigidBodyExport)")
    checkpoint_every: float | None = Field(
        None, gt=0, allow_inf_nan=False,
        description="simulated seconds between checkpoints of sphkit run (SPlisHSPlasH's "
        "enableStateExport with 1 / stateExportFPS); None: none unless --checkpoint-every")


class Configuration(_Model):
    """Global simulation settings."""

    dim: Literal[2, 3] = 3
    particle_radius: float = Field(0.025, gt=0, le=1e6, description="particle radius r [m] "
                                   "(at most 1e6 m: the kernel support 4r stays finite)")
    kernel: Literal["cubic", "wendland", "poly6", "spiky", "quintic"] = "cubic"
    gravity: Vec = Field([0.0, -9.81, 0.0], description="gravitational acceleration [m/s^2]")
    precision: Literal["float64", "float32"] = Field(
        "float64", description="floating-point type of the particle fields and of the cached "
        "pair values (MLS coefficients; the pair gradients: pair_cache), float32 halves their "
        "memory (sphkit run --precision); unset, float32 on the GPU and float64 on the CPU; "
        "the accuracy of each is in validation/README.md, 'float32'")
    pair_cache: Literal["auto", "float64", "float32"] = Field(
        "auto", description="floating-point type of the pair gradients V_j grad W_ij that the "
        "pressure solvers cache for a step (on the CPU): auto is float32 where they would not "
        "fit in the machine's last-level cache in float64 (there the passes over them move "
        "memory at its bandwidth, and half the bytes makes a DFSPH step about 10 % faster; "
        "within the cache float64 is faster), else the precision's type; float64 or float32 "
        "fix it (float64 only with precision float64)")
    time: TimeConfig = TimeConfig()
    pressure: PressureConfig = PressureConfig()
    transport: TransportConfig = TransportConfig()
    boundary: BoundaryConfig = BoundaryConfig()
    start: StartConfig = StartConfig()
    neighbor_skin: float = Field(
        0.0, ge=0, le=1, description="Verlet neighbour lists: the fluid's lists are searched "
        "with the radius h (1 + neighbor_skin) and reused until a particle has moved half the "
        "skin, each step cut to the pairs closer than h (the same pairs, summed in another "
        "order: results agree to round-off); 0: a search every step (default)")
    zsort_every: int = Field(
        50, ge=0, description="reorder particles along a z-curve every this many steps (0: never)"
    )
    max_velocity: float = Field(
        100.0, gt=0,
        description="a particle faster than this [m/s] stops the run as unstable",
    )
    max_cfl: float = Field(
        1.0, gt=0,
        description="with time.cfl off: a CFL number max|v| dt / (2r) of the fluid with a "
        "boundary neighbour above this (dimensionless) in 5 steps in a row, or of any fluid "
        "above twice this, stops the run as unstable (the fixed time.dt is too large)",
    )
    domain_margin: float | None = Field(
        10.0, ge=0,
        description="fluid farther than this many kernel supports h outside the bounding box of "
        "the static boundaries (boxes, meshes, map geometries, emitter housings) stops the run "
        "as unstable (it leaked through a wall); not checked above the walls (against gravity) "
        "unless closed boxes shut the fluid in, nor in a scene without a container (a box or a "
        "static mesh with invert: solid obstacles alone, the fluid may fall off them); null: "
        "never checked",
    )
    contact_tolerance: float = Field(
        0.0, ge=0, le=1e6, allow_inf_nan=False,
        description="dynamic bodies: the gap [m] their contacts keep from the walls and from "
        "other bodies (a skin around each mesh: contacts start within it and push back to it; "
        "SPlisHSPlasH's PositionBasedDynamics contactTolerance, read from a SPlisHSPlasH "
        "scene's Simulation block with its default 0.01 m there); 0: the meshes touch",
    )
    max_particles: int = Field(
        MAX_PARTICLES, ge=1,
        description="particle budget: a scene whose fluid, walls and emitters would need more "
        "particles is refused before anything is allocated (sphkit run --max-particles)",
    )
    periodic_x: list[float] | None = Field(
        None,
        description="[xmin, xmax] [m]: the domain is periodic along x with period xmax - xmin "
        "(more than 2h = 8 particle radii); particles sampled outside [xmin, xmax) are left out, "
        "so a box spanning [xmin, xmax] in x keeps only its walls across the other axes. "
        "Supported with the wcsph, dfsph and iisph pressure solvers",
    )
    periodic_y: list[float] | None = Field(
        None,
        description="[ymin, ymax] [m]: periodic along y as periodic_x along x (2D and 3D; with "
        "periodic_x too, a doubly periodic domain). Supported with the wcsph, dfsph and iisph "
        "pressure solvers and the standard and weiler2018 viscosities",
    )

    @model_validator(mode="after")
    def _pair_cache(self) -> Configuration:
        if self.pair_cache == "float64" and self.precision == "float32":
            raise ValueError("pair_cache 'float64' with precision 'float32': expected 'auto' or "
                             "'float32' (a cache in float64 over float32 fields gains nothing)")
        return self

    @model_validator(mode="after")
    def _periodic(self) -> Configuration:
        for axis in ("x", "y"):
            p = getattr(self, f"periodic_{axis}")
            if p is None:
                continue
            name = f"periodic_{axis}"
            if len(p) != 2:
                raise ValueError(f"{name} {p}: expected two numbers [{axis}min, {axis}max]")
            lo, hi = p
            if not (abs(lo) < float("inf") and abs(hi) < float("inf")) or not hi > lo:
                raise ValueError(f"{name} {p}: expected finite {axis}min < {axis}max")
            h = 4.0 * self.particle_radius
            if not hi - lo > 2.0 * h:
                raise ValueError(
                    f"{name} {p}: the period {hi - lo:g} m must exceed twice the kernel support "
                    f"2h = 8 * particle_radius = {2.0 * h:g} m"
                )
        return self


class AnimationFieldConfig(_Model):
    """A region that imposes a particle field on the fluid inside it (SPlisHSPlasH's
    ``AnimationFields``; :mod:`sphkit.world.animation`), after every step from ``start_time``
    to ``end_time``."""

    field: Literal["velocity", "angular_velocity", "position"] = Field(
        "velocity", description="the particle field it sets: velocity [m/s], angular velocity "
        "[1/s] (micropolar vorticity's field; without it the region does nothing) or position [m]")
    shape: Literal["box", "sphere", "cylinder"] = Field(
        "box", description="box: scale = side lengths; sphere: scale[0] = radius; cylinder "
        "along its local x: scale[0] = length, scale[1] = radius [m]")
    translation: Vec = Field([0.0, 0.0, 0.0], description="centre [m]")
    rotation_axis: Vec = Field([0.0, 0.0, 1.0], description="rotation axis (3 components)")
    rotation_angle: float = Field(0.0, description="rotation about rotation_axis [rad]")
    scale: Vec = Field([1.0, 1.0, 1.0], description="size, see shape [m] (3 components)")
    expression: list[str] = Field(
        ["", "", ""], description="the x, y, z components as expressions over t, dt, x, y, z, "
        "vx, vy, vz, valuex, valuey, valuez (sphkit.scene.expressions); '' leaves a component")
    start_time: float = Field(0.0, description="first time it acts [s]")
    end_time: float | None = Field(None, description="last time it acts [s] (None: never stops)")

    @field_validator("expression")
    @classmethod
    def _expressions(cls, v: list[str]) -> list[str]:
        if len(v) != 3:
            raise ValueError("expected 3 entries (x, y, z)")
        for k, e in enumerate(v):
            if e.strip():
                try:
                    compile_expression(e)
                except ExpressionError as err:
                    raise ValueError(f"entry {k} ({'xyz'[k]}) {e[:200]!r}: {err}") from None
        return v

    @model_validator(mode="after")
    def _valid(self) -> AnimationFieldConfig:
        if len(self.rotation_axis) != 3 or len(self.scale) != 3:
            raise ValueError("rotation_axis and scale must have 3 components")
        if self.end_time is not None and not self.end_time >= self.start_time:
            raise ValueError(f"end_time {self.end_time} must not precede start_time "
                             f"{self.start_time}")
        return self


class MotorConfig(_Model):
    """A target-velocity motor of a hinge: it drives the relative angular velocity of the
    joint's first body to its second about the axis, ``(w_A - w_B) . axis``, to the target
    (:mod:`sphkit.boundary.rigid.joints_catto2005`). Give ``target_velocity`` or
    ``target_sequence``."""

    target_velocity: float | None = Field(
        None, description="constant target of (w_A - w_B) . axis [rad/s]")
    target_sequence: list[float] | None = Field(
        None, description="time / target pairs [t0, v0, t1, v1, ...] ([s], [rad/s]), times "
        "increasing: linear between the times, the first value before t0, the last after the "
        "last time (SPlisHSPlasH targetSequence)")
    repeat: bool = Field(False, description="target_sequence: repeat it with period "
                         "t_last - t0 (SPlisHSPlasH repeatSequence)")

    @model_validator(mode="after")
    def _one_target(self) -> MotorConfig:
        if (self.target_velocity is None) == (self.target_sequence is None):
            raise ValueError("expected exactly one of target_velocity and target_sequence")
        seq = self.target_sequence
        if seq is not None:
            if len(seq) < 2 or len(seq) % 2:
                raise ValueError(f"target_sequence {clip(seq)}: expected time / value pairs "
                                 "(an even number >= 2 of numbers)")
            ts = seq[0::2]
            if any(b <= a for a, b in zip(ts, ts[1:], strict=False)):
                raise ValueError(f"target_sequence {clip(seq)}: expected increasing times "
                                 f"(got {ts})")
        return self


class JointConfig(_Model):
    """A joint between two of the scene's meshes (``bodies``: indices into ``meshes``; a
    static mesh is fixed in space, a kinematic one moves as prescribed, at least one must be
    dynamic): ``hinge``, the bodies turn about the axis through ``position`` relative to each
    other, with an optional target-velocity ``motor`` (sequential impulses,
    :mod:`sphkit.boundary.rigid.joints_catto2005`). Placement at t = 0."""

    type: Literal["hinge"] = Field("hinge", description="joint type")
    bodies: list[int] = Field(description="the two joined bodies A, B: indices into meshes")
    position: Vec = Field(description="a point on the hinge axis at t = 0 [m] (3 components; 2D: "
                          "z is taken as 0, the plane of the bodies)")
    axis: Vec = Field(description="hinge axis at t = 0 (3 components, non-zero; 2D: z)")
    motor: MotorConfig | None = Field(None, description="target-velocity motor")

    @field_validator("bodies")
    @classmethod
    def _two(cls, v: list[int]) -> list[int]:
        if len(v) != 2 or v[0] == v[1] or min(v) < 0:
            raise ValueError(f"{v}: expected two different mesh indices >= 0")
        return v

    @field_validator("position", "axis")
    @classmethod
    def _vec3(cls, v: Vec) -> Vec:
        if len(v) != 3:
            raise ValueError(f"{v}: expected 3 components")
        return v

    @field_validator("axis")
    @classmethod
    def _nonzero(cls, v: Vec) -> Vec:
        if not sum(c * c for c in v) > 0.0:
            raise ValueError(f"{v}: expected a non-zero axis")
        return v


class Scene(_Model):
    """A whole scene."""

    name: str = "scene"
    description: str = Field("", description="one line describing the scene (listings)")
    configuration: Configuration = Configuration()
    materials: list[Material] = [Material()]
    fluid_blocks: list[FluidBlock] = Field(default_factory=list)
    fluid_files: list[FluidFile] = Field(default_factory=list)
    boxes: list[Box] = Field(default_factory=list)
    meshes: list[MeshBoundary] = Field(default_factory=list)
    fluid_meshes: list[FluidMesh] = Field(default_factory=list)
    emitters: list[Emitter] = Field(default_factory=list)
    animation_fields: list[AnimationFieldConfig] = Field(default_factory=list)
    joints: list[JointConfig] = Field(default_factory=list)
    interfaces: list[Interface] = Field(
        default_factory=list, description="viscosity and tension between pairs of fluid "
        "materials (several fluids, sphkit.multiphase); none: the phases meet through the "
        "pressure alone")
    output: OutputConfig = OutputConfig()
    source: str | None = Field(None, description="path of the file the scene was read from")
    #: a translated scene's field paths -> the paths the user wrote (SPlisHSPlasH's), for
    #: messages about the scene after validation (:meth:`field`)
    _origins: dict[str, str] = PrivateAttr(default_factory=dict)

    def field(self, path: str) -> str:
        """A field path as messages name it: sphkit's, with the translated scene's own
        (``RigidBodies[0] (sphkit meshes[0])``) when the scene was translated."""
        p = path
        while p:
            if p in self._origins:
                tail = path[len(p):]
                return f"{self._origins[p]}{tail} (sphkit {path})"
            cut = max(p.rfind("."), p.rfind("["))
            if cut <= 0:
                break
            p = p[:cut]
        return path

    def as_written(self, message: str) -> str:
        """A message that starts with a field path, with the path the user wrote in front (a
        translated scene's, :meth:`field`)."""
        m = _FIELD.match(message)
        if m is None or self.field(m.group(1)) == m.group(1):
            return message
        return self.field(m.group(1)) + message[m.end():]

    @field_validator("materials")
    @classmethod
    def _unique_ids(cls, v: list[Material]) -> list[Material]:
        ids = [m.id for m in v]
        if len(set(ids)) != len(ids):
            raise ValueError(f"material ids {ids} are not unique")
        if not v:
            raise ValueError("at least one material is needed")
        return v

    @model_validator(mode="after")
    def _moving_bodies_pressure(self) -> Scene:
        """A boundary pressure left out, in a scene with moving (dynamic or kinematic) bodies:
        the boundary model's default for moving bodies (registry)."""
        b = self.configuration.boundary
        if b._pressure_default and any(m.moving for m in self.meshes):
            b.pressure = registry.default_boundary_pressure(b.method, moving_bodies=True)
        return self

    @model_validator(mode="after")
    def _several_densities_walls(self) -> Scene:
        """``boundary.solved`` left out, in a scene whose fluids' rest densities differ by more than
        :data:`SOLVED_WALLS_RATIO`, with boundary particles and a pressure solver that
        solves the walls: ``"stratified"`` up to :data:`STRATIFIED_WALLS_RATIO` with the
        solvers of registry capability ``stratified_walls``, ``"density"`` beyond and with PCISPH
        (the MLS wall term made a light fluid under a heavy one blow up from 1:6 on with
        PCISPH, from 1:8 with IISPH and DFSPH; measured in validation/README.md, "Several
        rest densities: the solved walls by default"; the rows only where the fluid beside a
        wall is stratified the unstable way, and every wall row beyond 1:10: "Solved walls
        where the fluid is stratified")."""
        cfg = self.configuration
        b = cfg.boundary
        used = self.fluid_material_ids()
        rest = [m.density0 for m in self.materials if m.id in used]
        if (b._solved_default and not b.symmetric and b.method == "akinci2012" and rest
                and max(rest) > SOLVED_WALLS_RATIO * min(rest)
                and cfg.pressure.method in registry.with_capability("pressure", "solved_walls")):
            b.solved = ("stratified" if max(rest) <= STRATIFIED_WALLS_RATIO * min(rest)
                        and cfg.pressure.method
                        in registry.with_capability("pressure", "stratified_walls")
                        else "density")
        return self

    @model_validator(mode="after")
    def _inviscid_wcsph_walls(self) -> Scene:
        """``boundary.symmetric`` left out, WCSPH, and a fluid whose kinematic viscosity (0
        without one; the methods of :data:`KINEMATIC_VISCOSITY`, the others count as
        viscous) is below :data:`WCSPH_WALL_DAMPING` (2r)^2: the symmetric wall term, the
        only one that does no work on the flow (measured in validation/README.md, "WCSPH's
        walls by default: the energy they pump")."""
        cfg = self.configuration
        b = cfg.boundary
        if not b._symmetric_default or b.symmetric or b.solved or cfg.pressure.method != "wcsph":
            return self
        used = self.fluid_material_ids()
        nus = [0.0 if m.viscosity.method == "none" else m.viscosity.coefficient
               for m in self.materials if m.id in used
               and (m.viscosity.method == "none" or m.viscosity.method in KINEMATIC_VISCOSITY)]
        if nus and min(nus) < WCSPH_WALL_DAMPING * (2.0 * cfg.particle_radius) ** 2:
            b.symmetric = True
        return self

    @model_validator(mode="after")
    def _consistent(self) -> Scene:
        dim = self.configuration.dim
        dims = f"{dim} components (configuration.dim = {dim})"
        ids = {m.id for m in self.materials}
        if len(self.configuration.gravity) not in (dim, 3):
            raise ValueError(
                f"configuration.gravity {self.configuration.gravity} must have {dims}"
            )
        for k, b in enumerate(self.fluid_blocks):
            if len(b.start) != dim:
                raise ValueError(f"fluid_blocks[{k}].start {b.start} must have {dims}")
            if b.material not in ids:
                raise ValueError(
                    f"fluid_blocks[{k}].material {b.material!r} is not one of the "
                    f"ids of materials {sorted(ids)}"
                )
            if b.velocity is not None and len(b.velocity) != dim:
                raise ValueError(
                    f"fluid_blocks[{k}].velocity {b.velocity} must have {dims}"
                )
        for k, f in enumerate(self.fluid_files):
            if f.material not in ids:
                raise ValueError(
                    f"fluid_files[{k}].material {f.material!r} is not one of the "
                    f"ids of materials {sorted(ids)}"
                )
        for k, b in enumerate(self.fluid_meshes):
            if b.material not in ids:
                raise ValueError(
                    f"fluid_meshes[{k}].material {b.material!r} is not one of the "
                    f"ids of materials {sorted(ids)}"
                )
            if b.velocity is not None and len(b.velocity) != dim:
                raise ValueError(
                    f"fluid_meshes[{k}].velocity {b.velocity} must have {dims}"
                )
        for k, m in enumerate(self.materials):
            va = m.drag.air_velocity
            if va is not None and len(va) != dim:
                raise ValueError(
                    f"materials[{k}].drag.air_velocity {va} must have {dims}")
        for k, e in enumerate(self.emitters):
            if len(e.position) not in (dim, 3):
                raise ValueError(f"emitters[{k}].position {e.position} must have {dims}")
            if e.material not in ids:
                raise ValueError(
                    f"emitters[{k}].material {e.material!r} is not one of the "
                    f"ids of materials {sorted(ids)}"
                )
            if dim == 2 and e.rotation_angle != 0.0 and (e.rotation_axis[0] != 0.0
                                                         or e.rotation_axis[1] != 0.0):
                raise ValueError(f"emitters[{k}].rotation_axis {e.rotation_axis}: in 2D "
                                 "emitters rotate about z; expected [0, 0, 1]")
        for k, b in enumerate(self.boxes):
            if len(b.min) != dim:
                raise ValueError(f"boxes[{k}].min {b.min} must have {dims}")
            if b.viscosity_factors is not None:
                for j, m in enumerate(self.materials):
                    if m.viscosity.method != "standard":
                        raise ValueError(
                            f"boxes[{k}].viscosity_factors {b.viscosity_factors}: only the "
                            "standard viscosity scales its wall term per face; "
                            f"materials[{j}].viscosity.method is {m.viscosity.method!r}; "
                            "expected 'standard' (or leave viscosity_factors out)")
                bm = self.configuration.boundary.method
                if registry.get("boundary", bm).kind == "maps":
                    raise ValueError(
                        f"boxes[{k}].viscosity_factors {b.viscosity_factors}: the boundary "
                        f"method {bm!r} makes the box a map, which has no wall particles to "
                        "scale; expected a particle boundary (e.g. 'akinci2012') or no "
                        "viscosity_factors")
        pairs: set[frozenset[str]] = set()
        for k, itf in enumerate(self.interfaces):
            for mid in itf.materials:
                if mid not in ids:
                    raise ValueError(f"interfaces[{k}].materials {itf.materials}: {mid!r} is "
                                     f"not one of the ids of materials {sorted(ids)}")
                if self.material(mid).elastic:
                    raise ValueError(f"interfaces[{k}].materials {itf.materials}: {mid!r} is "
                                     "an elastic solid; expected fluid materials")
            pair = frozenset(itf.materials)
            if pair in pairs:
                raise ValueError(f"interfaces[{k}].materials {itf.materials}: the pair is "
                                 "named twice; expected one entry per pair of materials")
            pairs.add(pair)
        for k, j in enumerate(self.joints):
            if max(j.bodies) >= len(self.meshes):
                raise ValueError(f"joints[{k}].bodies {j.bodies}: expected indices into meshes "
                                 f"(0 .. {len(self.meshes) - 1})")
            if not any(self.meshes[i].dynamic for i in j.bodies):
                raise ValueError(f"joints[{k}].bodies {j.bodies}: expected at least one "
                                 "dynamic mesh (meshes[].dynamic)")
            if dim == 2 and (j.axis[0] != 0.0 or j.axis[1] != 0.0):
                raise ValueError(f"joints[{k}].axis {j.axis}: in 2D bodies turn about z; "
                                 "expected [0, 0, 1]")
        return self

    def material(self, mid: str) -> Material:
        """The material with id ``mid``."""
        for m in self.materials:
            if m.id == mid:
                return m
        raise KeyError(mid)

    def fluid_material_ids(self) -> set[str]:
        """The ids of the materials the scene's fluid uses (blocks, files, meshes, emitters);
        empty when the scene has no fluid."""
        return {src.material for src in (*self.fluid_blocks, *self.fluid_files,
                                         *self.fluid_meshes, *self.emitters)}


class SceneError(ValueError):
    """A scene that cannot be read or is invalid; the message names field, value and expectation."""


def clip(value: Any, limit: int = CLIP) -> str:
    """``repr(value)``, cut to about ``limit`` characters (error messages never echo much of
    the input)."""
    if isinstance(value, (dict, list, tuple)) and len(value) > limit:
        text = f"<{type(value).__name__} of {len(value)} items>"
        return text
    try:
        text = repr(value)
    except Exception:  # a value whose repr fails (an int of more digits than Python prints)
        text = f"<{type(value).__name__}>"
    if len(text) > limit:
        text = f"{text[:limit]}... ({len(text)} characters)"
    return text


#: how many problems of one validation error are listed
MAX_ERRORS = 12


def format_validation_error(err: ValidationError, prefix: str = "") -> str:
    """Render a pydantic error as lines 'path: got value: problem' (values clipped, at most
    :data:`MAX_ERRORS` lines)."""
    lines = []
    errors = err.errors(include_url=False, include_context=False)
    for e in errors[:MAX_ERRORS]:
        parts = []
        for p in e["loc"]:
            if isinstance(p, int):
                parts.append(f"[{p}]")
            else:
                parts.append(("." if parts else "") + str(p)[:40])
        path = prefix + "".join(parts)
        val = e.get("input")
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            msg = "unknown field"
        got = "{...}" if isinstance(val, dict) else clip(val)
        if len(msg) > 4 * CLIP:
            msg = msg[:4 * CLIP] + "..."
        lines.append(f"{path or '<scene>'}: got {got}: {msg}")
    if len(errors) > MAX_ERRORS:
        lines.append(f"... and {len(errors) - MAX_ERRORS} more problem(s)")
    return "\n".join(lines)
