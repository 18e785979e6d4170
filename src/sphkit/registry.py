"""Every method of sphkit, by role, scene name, paper, SPlisHSPlasH number and capabilities.

This is the one place a method is named (DESIGN.md, "Methods: roles, not types"). The scene
schema's choices (:mod:`sphkit.scene.schema`), the SPlisHSPlasH translator
(:mod:`sphkit.scene.splishsplash`), the capability checks (:mod:`sphkit.scene.checks`), the world
builder (:mod:`sphkit.world`) and ``sphkit methods`` all read it.

An entry names its class by import path (``"sphkit.viscosity.weiler2018:Weiler2018"``) and is
imported only when a world is built with it, so reading the registry (the schema does at import
time) imports no compiled code. The class implements its role's Protocol of
:mod:`sphkit.core.methods` and builds itself from its part of the scene with
``from_config``.

Adding a method: write its module (one paper per file), register it here with one
:func:`register` call, add its tests and its README row.

Capabilities (keyword flags of :func:`register`):

* ``periodic``: its pair loops take minimum-image distances (``configuration.periodic_x``);
* ``periodic_y``: also along a periodic y (``configuration.periodic_y``): its pair loops are
  passed the state's ``pair_period`` (validation/taylor_green.py);
* ``dynamic_bodies``: a pressure solver whose pressure moves dynamic rigid bodies;
* ``multiphase``: a pressure solver or boundary model that reads each particle's own rest
  density (several fluid materials in one scene, :mod:`sphkit.multiphase`); the non-pressure
  forces of each material act within its phase whatever their flags;
* ``solved_walls``: a pressure solver that solves the static wall particles' own pressures
  with the fluid's (``configuration.boundary.solved``; the others then use the symmetric wall
  term); scenes whose fluids' rest densities differ by more than a factor 4 get it by
  default (the scene schema's ``Scene._several_densities_walls``);
* ``stratified_walls``: a ``solved_walls`` solver whose default solved walls are
  ``"stratified"`` (rows only where a lighter fluid lies below a heavier one at a wall, MLS
  elsewhere) up to the schema's ``STRATIFIED_WALLS_RATIO``; the others solve every static wall
  particle (PCISPH: with the stratified rows its heavy-over-light column blew up at 1:20 and,
  at r = 2 cm and 0.01 %, at 1:10 at 0.27 s; validation/README.md, "Solved walls where the
  fluid is stratified");
* ``gpu``: its part of the time step runs on ``--device cuda`` with the fields resident on the
  device (DFSPH, IISPH, WCSPH, Akinci boundary particles with mirrored boundary pressure, the
  standard, XSPH and Weiler 2018 viscosities, Akinci 2013 surface tension and micropolar
  vorticity so far; the scene features the device step lacks are refused by
  :func:`sphkit.scene.checks.check_device`);
* ``boundary`` (boundary-pressure models): the boundary kinds it acts on (``particles`` or
  ``maps``, the ``kind`` of the boundary model).

A boundary model also names its default boundary pressure (``boundary_pressure``): the one a
scene gets when ``configuration.boundary.pressure`` is left out, resolved once, when the scene
is validated (:func:`default_boundary_pressure`), so the validated scene -- and the run
manifest that records it -- says which one ran. The defaults are the more accurate pressure
of each model, measured in ``validation/hydrostatic.py`` (``validation/README.md``, "Boundary
pressure defaults"): MLS extrapolation (Band et al. 2018) for boundary particles, the
hydrostatic wall pressure for density and volume maps; ``mirror`` stays selectable. A model
may name another default for scenes with moving (dynamic or kinematic) bodies
(``boundary_pressure_moving``): density maps mirror there, because their hydrostatic wall
pressure threw fluid squeezed between a turning paddle and a wall at 48 m/s.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Any

#: the roles, in the order of a time step (DESIGN.md, "One time step")
ROLES: tuple[str, ...] = ("boundary", "boundary_pressure", "viscosity", "vorticity",
                          "surface_tension", "drag", "interface_viscosity", "interface_tension",
                          "elasticity", "transport", "pressure")

#: the roles a material may leave out (scene value ``"none"``)
OPTIONAL_ROLES: tuple[str, ...] = ("viscosity", "vorticity", "surface_tension", "drag")

#: the roles set once for the whole fluid in ``configuration`` (scene value ``"none"``: off):
#: the transport velocity (``configuration.transport``, package :mod:`sphkit.transport`)
CONFIGURATION_ROLES: tuple[str, ...] = ("transport",)

#: the roles of an interface between two fluid materials (``interfaces[]``, scene value
#: ``"none"``: off); package :mod:`sphkit.multiphase`
INTERFACE_ROLES: tuple[str, ...] = ("interface_viscosity", "interface_tension")

#: the roles of a solid material (scene value ``"none"``: the material is a fluid); a solid's
#: elasticity is built and stepped apart from the fluid forces (``World.solids``)
SOLID_ROLES: tuple[str, ...] = ("elasticity",)
#: the capability flags a method may have
CAPABILITIES: tuple[str, ...] = ("periodic", "periodic_y", "dynamic_bodies", "multiphase",
                                  "gpu", "solved_walls", "stratified_walls")
#: the devices a simulation runs on (``Simulation(device=...)``, ``sphkit run --device``):
#: ``auto`` takes the GPU when one is found and every method of the scene has ``gpu``
DEVICE_CHOICES: tuple[str, ...] = ("auto", "cpu", "cuda")


@dataclass(frozen=True)
class Method:
    """One registered method."""

    role: str  #: one of :data:`ROLES`
    name: str  #: the scene name (``materials[].viscosity.method: weiler2018``)
    target: str | None  #: ``"module:Class"`` of its implementation; None: built into the core
    paper: str  #: the paper it implements
    summary: str  #: one line: what it is
    splishsplash: int | None = None  #: SPlisHSPlasH's number of the method (None: none)
    capabilities: frozenset[str] = field(default_factory=frozenset)
    #: boundary-pressure models: the boundary kinds (``particles``, ``maps``) they act on
    boundary: tuple[str, ...] = ()
    #: boundary models: ``particles`` (boundary particles) or ``maps`` (density/volume maps)
    kind: str = ""
    #: boundary models: the boundary pressure a scene that names none gets
    boundary_pressure: str = ""
    #: boundary models: the default in scenes with moving bodies (empty: the same)
    boundary_pressure_moving: str = ""

    def has(self, capability: str) -> bool:
        """Whether the method has ``capability`` (one of :data:`CAPABILITIES`)."""
        return capability in self.capabilities

    def load(self) -> type:
        """The implementing class (imported now)."""
        if self.target is None:
            raise LookupError(f"{self.role} method {self.name!r} has no class of its own")
        module, _, cls = self.target.partition(":")
        return getattr(importlib.import_module(module), cls)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form (``sphkit methods --json``)."""
        return {"role": self.role, "name": self.name, "paper": self.paper,
                "summary": self.summary, "splishsplash": self.splishsplash,
                "capabilities": sorted(self.capabilities), "boundary": list(self.boundary),
                "kind": self.kind, "default_boundary_pressure": self.boundary_pressure or None,
                "default_boundary_pressure_moving_bodies":
                    self.boundary_pressure_moving or self.boundary_pressure or None,
                "implementation": self.target}


_METHODS: dict[str, dict[str, Method]] = {role: {} for role in ROLES}


def register(role: str, name: str, target: str | None, *, paper: str, summary: str,
             splishsplash: int | None = None, periodic: bool = False, periodic_y: bool = False,
             dynamic_bodies: bool = False, multiphase: bool = False, gpu: bool = False,
             solved_walls: bool = False, stratified_walls: bool = False,
             boundary: tuple[str, ...] = (), kind: str = "",
             boundary_pressure: str = "", boundary_pressure_moving: str = "") -> Method:
    """Register a method (see the module docstring); returns its entry."""
    if role not in _METHODS:
        raise ValueError(f"registry: role {role!r}; expected one of {list(ROLES)}")
    if name in _METHODS[role] or name == "none":
        raise ValueError(f"registry: {role} method {name!r} registered twice (or reserved)")
    if splishsplash is not None and any(m.splishsplash == splishsplash
                                        for m in _METHODS[role].values()):
        raise ValueError(f"registry: {role} number {splishsplash} registered twice")
    caps = frozenset(c for c, on in (("periodic", periodic), ("periodic_y", periodic_y),
                                     ("dynamic_bodies", dynamic_bodies),
                                     ("multiphase", multiphase), ("gpu", gpu),
                                     ("solved_walls", solved_walls),
                                     ("stratified_walls", stratified_walls)) if on)
    if role == "boundary" and not boundary_pressure:
        raise ValueError(f"registry: boundary model {name!r} names no default boundary_pressure")
    m = Method(role, name, target, paper, summary, splishsplash, caps, tuple(boundary), kind,
               boundary_pressure, boundary_pressure_moving)
    _METHODS[role][name] = m
    return m


def names(role: str) -> tuple[str, ...]:
    """The scene names of a role's methods, in registration order."""
    return tuple(_METHODS[role])


def get(role: str, name: str) -> Method:
    """The entry of a role's method; KeyError naming the choices when there is none."""
    try:
        return _METHODS[role][name]
    except KeyError:
        raise KeyError(f"{role} method {name!r}; expected one of {list(_METHODS[role])}") from None


def by_number(role: str, number: int) -> Method | None:
    """The method SPlisHSPlasH numbers ``number`` in this role, or None."""
    for m in _METHODS[role].values():
        if m.splishsplash == number:
            return m
    return None


def methods(role: str | None = None) -> list[Method]:
    """Every registered method (of one role), roles in :data:`ROLES` order."""
    roles = ROLES if role is None else (role,)
    return [m for r in roles for m in _METHODS[r].values()]


def default_boundary_pressure(boundary: str, moving_bodies: bool = False) -> str:
    """The boundary pressure (a ``boundary_pressure`` method) that the boundary model
    ``boundary`` uses when the scene names none (``moving_bodies``: the scene has dynamic or
    kinematic bodies); KeyError naming the choices for an unknown model."""
    m = get("boundary", boundary)
    return (m.boundary_pressure_moving if moving_bodies else "") or m.boundary_pressure


def with_capability(role: str, capability: str) -> tuple[str, ...]:
    """The names of a role's methods that have ``capability``."""
    return tuple(m.name for m in _METHODS[role].values() if m.has(capability))


# ---------------------------------------------------------------------------------------------
# the methods (registration order is the order of the schema's choices and error messages)

# pressure solvers: SPlisHSPlasH simulationMethod
register("pressure", "wcsph", "sphkit.pressure.wcsph:WCSPH", splishsplash=0,
         paper="Becker & Teschner 2007, Weakly compressible SPH for free surface flows",
         summary="state equation (Tait or linear), symmetric pressure force",
         periodic=True, periodic_y=True, dynamic_bodies=True, multiphase=True, gpu=True)
register("pressure", "pcisph", "sphkit.pressure.pcisph:PCISPH", splishsplash=1,
         paper="Solenthaler & Pajarola 2009, Predictive-corrective incompressible SPH",
         summary="predict-correct loop with a template scaling factor", dynamic_bodies=True,
         multiphase=True, gpu=True, solved_walls=True)
register("pressure", "pbf", "sphkit.pressure.pbf:PBF", splishsplash=2,
         paper="Macklin & Müller 2013, Position based fluids",
         summary="density constraints solved on positions", dynamic_bodies=True,
         multiphase=True, gpu=True)
register("pressure", "iisph", "sphkit.pressure.iisph:IISPH", splishsplash=3,
         paper="Ihmsen et al. 2014, Implicit incompressible SPH",
         summary="relaxed Jacobi on the pressure Poisson equation", periodic=True,
         periodic_y=True, dynamic_bodies=True, multiphase=True, gpu=True, solved_walls=True,
         stratified_walls=True)
register("pressure", "dfsph", "sphkit.pressure.dfsph:DFSPH", splishsplash=4,
         paper="Bender & Koschier 2015/2017, Divergence-free SPH",
         summary="constant-density and divergence-free solvers with warm starts",
         periodic=True, periodic_y=True, dynamic_bodies=True, multiphase=True, gpu=True,
         solved_walls=True, stratified_walls=True)
register("pressure", "pf", "sphkit.pressure.pf:PF", splishsplash=5,
         paper="Weiler, Koschier & Bender 2016, Projective fluids",
         summary="projective dynamics: local density-constraint projections, global CG; "
         "no dynamic bodies (as SPlisHSPlasH)")
register("pressure", "icsph", "sphkit.pressure.icsph:ICSPH", splishsplash=6,
         paper="Gissler et al. 2020, An implicit compressible SPH solver for snow simulation",
         summary="compressible PPE with Lame lambda, current volumes, relaxed Jacobi")

# boundary models: SPlisHSPlasH boundaryHandlingMethod
register("boundary", "akinci2012", "sphkit.boundary.akinci2012:Akinci2012", splishsplash=0,
         paper="Akinci et al. 2012, Versatile rigid-fluid coupling for incompressible SPH",
         summary="boundary particles with volumes 1 / sum W", kind="particles",
         boundary_pressure="mls", multiphase=True, gpu=True)
register("boundary", "koschier2017", "sphkit.boundary.koschier2017:Koschier2017",
         splishsplash=1, paper="Koschier & Bender 2017, Density maps for improved SPH "
         "boundary handling", summary="density maps on signed distance fields", kind="maps",
         boundary_pressure="hydrostatic", boundary_pressure_moving="mirror", multiphase=True,
         gpu=True)
register("boundary", "bender2019", "sphkit.boundary.bender2019:Bender2019", splishsplash=2,
         paper="Bender et al. 2019, Volume maps: an implicit boundary representation for SPH",
         summary="volume maps on signed distance fields", kind="maps",
         boundary_pressure="hydrostatic", multiphase=True, gpu=True)

# boundary pressure: what p_b the pressure terms of the boundary use
register("boundary_pressure", "mirror", None,
         paper="Akinci et al. 2012 (p_b = p_i); SPlisHSPlasH's boundary term for maps",
         summary="the fluid particle's pressure mirrored to the boundary",
         boundary=("particles", "maps"), periodic=True, gpu=True)
register("boundary_pressure", "mls", "sphkit.boundary.band2018:MLSPressureExtrapolation",
         paper="Band et al. 2018, Pressure boundaries for implicit incompressible SPH",
         summary="moving-least-squares extrapolation of the fluid pressure to the boundary "
         "particles", boundary=("particles",), periodic=True, gpu=True)
register("boundary_pressure", "hydrostatic", None,
         paper="Adami et al. 2012, A generalized wall boundary condition for SPH",
         summary="maps: p_b = p_i + rho_i g . (x_b - x_i), the walls' tangential moment",
         boundary=("maps",), gpu=True)

# viscosity: SPlisHSPlasH viscosityMethod (XSPH is its separate per-material filter)
register("viscosity", "standard", "sphkit.viscosity.standard:StandardViscosity",
         splishsplash=1, paper="Morris et al. 1997; Monaghan 2005 (vector Laplacian)",
         summary="explicit Laplacian viscosity, kinematic nu", periodic=True, periodic_y=True,
         gpu=True)
register("viscosity", "xsph", "sphkit.viscosity.xsph:XSPH",
         paper="Monaghan 1989/1992, XSPH", summary="velocity smoothing", gpu=True)
register("viscosity", "weiler2018", "sphkit.viscosity.weiler2018:Weiler2018", splishsplash=6,
         paper="Weiler et al. 2018, A physically consistent implicit viscosity solver for SPH",
         summary="implicit, block-Jacobi CG, kinematic nu", periodic=True, periodic_y=True,
         gpu=True)
register("viscosity", "bender2017", "sphkit.viscosity.bender2017:Bender2017", splishsplash=2,
         paper="Bender & Koschier 2017, Divergence-free SPH for incompressible and viscous "
         "fluids", summary="implicit strain-rate constraints (Jacobi), factor", periodic=True)
register("viscosity", "takahashi2015", "sphkit.viscosity.takahashi2015:Takahashi2015",
         splishsplash=5, paper="Takahashi et al. 2015, Implicit formulation for SPH-based "
         "viscous fluids", summary="implicit, two-pass operator, CG, kinematic nu", periodic=True)
register("viscosity", "peer2015", "sphkit.viscosity.peer2015:Peer2015", splishsplash=3,
         paper="Peer et al. 2015, An implicit viscosity formulation for SPH fluids",
         summary="implicit velocity-gradient reconstruction (CG), factor", periodic=True)
register("viscosity", "peer2016", "sphkit.viscosity.peer2016:Peer2016", splishsplash=4,
         paper="Peer & Teschner 2016, Prescribed velocity gradients for highly viscous SPH "
         "fluids with vorticity diffusion", summary="as peer2015 plus vorticity diffusion, "
         "factor", periodic=True)

# vorticity: SPlisHSPlasH vorticityMethod
register("vorticity", "micropolar", "sphkit.vorticity.micropolar_bender2017:"
         "MicropolarBender2017", splishsplash=1,
         paper="Bender et al. 2017, Turbulent micropolar SPH fluids with foam",
         summary="micropolar model: angular velocity field", gpu=True)
register("vorticity", "confinement", "sphkit.vorticity.confinement:VorticityConfinement",
         splishsplash=2, paper="Macklin & Müller 2013, Position based fluids (vorticity "
         "confinement)", summary="vorticity confinement force")

# surface tension: SPlisHSPlasH surfaceTensionMethod
register("surface_tension", "becker2007", "sphkit.surface_tension.becker2007:"
         "BeckerTeschner2007", splishsplash=1,
         paper="Becker & Teschner 2007, Weakly compressible SPH for free surface flows",
         summary="cohesion and adhesion forces", periodic=True)
register("surface_tension", "akinci2013", "sphkit.surface_tension.akinci2013:Akinci2013",
         splishsplash=2, paper="Akinci et al. 2013, Versatile surface tension and adhesion for "
         "SPH fluids", summary="cohesion, curvature and boundary adhesion", periodic=True,
         gpu=True)
register("surface_tension", "he2014", "sphkit.surface_tension.he2014:He2014", splishsplash=3,
         paper="He et al. 2014, Robust simulation of sparsely sampled thin features in SPH-based "
         "free surface flows", summary="surface energy of the colour field gradient",
         periodic=True)
register("surface_tension", "jeske2023", "sphkit.surface_tension.jeske2023:Jeske2023",
         splishsplash=4, paper="Jeske et al. 2023, Implicit surface tension for SPH fluid "
         "simulation", summary="implicit cohesion, adhesion and viscosity (one CG solve)",
         periodic=True)
register("surface_tension", "zorilla2020", "sphkit.surface_tension.zorilla2020:"
         "ZorillaRitter2020", splishsplash=5,
         paper="Zorilla, Ritter et al. 2020, Accelerating surface tension calculation in SPH "
         "via particle classification and Monte Carlo integration",
         summary="Monte Carlo (and PCA) normals and curvature, force on surface particles",
         periodic=True)
register("surface_tension", "mueller2003", "sphkit.surface_tension.mueller2003:Mueller2003",
         paper="Müller et al. 2003, Particle-based fluid simulation for interactive "
         "applications (CSF)", summary="continuum surface force, physical sigma",
         periodic=True)

# drag: SPlisHSPlasH dragMethod
register("drag", "macklin2014", "sphkit.drag.macklin2014:Macklin2014", splishsplash=1,
         paper="Macklin et al. 2014, Unified particle physics for real-time applications",
         summary="air drag on surface particles (no pair distances: periodic as it is)",
         periodic=True)
register("drag", "gissler2017", "sphkit.drag.gissler2017:Gissler2017", splishsplash=2,
         paper="Gissler et al. 2017, Generalized drag force for particle-based simulations",
         summary="droplet drag on surface particles")
# between two fluid materials (scene interfaces[]; not in SPlisHSPlasH, package multiphase/)
register("interface_viscosity", "morris1997", "sphkit.multiphase.morris1997:Morris1997",
         paper="Morris, Fox & Zhu 1997, Modeling low Reynolds number incompressible flows using "
         "SPH (pair viscosity: harmonic mean, Cleary 1998; Hu & Adams 2006)",
         summary="explicit Laplacian viscosity between unlike phases, kinematic nu",
         periodic=True, multiphase=True)
register("interface_tension", "hu2006", "sphkit.multiphase.hu2006:HuAdams2006",
         paper="Hu & Adams 2006, A multi-phase SPH method for macroscopic and mesoscopic flows",
         summary="surface stress of the colour gradient between unlike phases, sigma [N/m]",
         periodic=True, multiphase=True)
# elasticity of solid materials: SPlisHSPlasH elasticityMethod (package solids/)
register("elasticity", "becker2009", "sphkit.solids.becker2009:Becker2009", splishsplash=1,
         paper="Becker, Ihmsen & Teschner 2009, Corotated SPH for deformable solids; "
         "Ganzenmüller 2015, An hourglass control algorithm for Lagrangian SPH",
         summary="explicit corotated linear elasticity, zero-energy-mode control alpha")
register("elasticity", "peer2018", "sphkit.solids.peer2018:Peer2018", splishsplash=2,
         paper="Peer, Gissler, Band & Teschner 2018, An implicit SPH formulation for "
         "incompressible linearly elastic solids",
         summary="implicit corotated linear elasticity, backward Euler velocities, matrix-free CG")
register("elasticity", "kugelstadt2021", "sphkit.solids.kugelstadt2021:Kugelstadt2021",
         splishsplash=3,
         paper="Kugelstadt, Bender, Fernández-Fernández, Jeske, Löschner & Longva 2021, Fast "
         "corotated elastic SPH solids with implicit zero-energy mode control",
         summary="operator-split implicit corotated elasticity: pre-factorised constant "
         "stretch and zero-energy-mode matrix, CG volume solve")
register("elasticity", "kee2023", "sphkit.solids.kee2023:Kee2023", splishsplash=4,
         paper="Kee, Um, Kang & Han 2023, An optimization-based SPH solver for simulation of "
         "hyperelastic solids",
         summary="hyperelastic (corotated or stable neo-Hookean) backward Euler as a "
         "minimisation: projected Newton with CG, or L-BFGS on a pre-factorised Hessian")

# transport velocities: configuration.transport (no SPlisHSPlasH counterpart)
register("transport", "adami2013", "sphkit.transport.adami2013:Adami2013",
         paper="Adami, Hu & Adams 2013, A transport-velocity formulation for smoothed particle "
         "hydrodynamics", summary="particles advected with a background-pressure transport "
         "velocity, plus the stress term A = rho v (v~ - v); WCSPH only",
         periodic=True, periodic_y=True)
