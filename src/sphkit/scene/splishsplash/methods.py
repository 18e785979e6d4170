"""SPlisHSPlasH's method numbers and the sphkit methods they map to: every such table in one place.

A SPlisHSPlasH scene chooses its methods by number (``simulationMethod``,
``boundaryHandlingMethod``, a material's ``viscosityMethod``, ``vorticityMethod``,
``surfaceTensionMethod``, ``dragMethod``, ``elasticityMethod``) and writes each method's
parameters in a block named after the method (``"DFSPH": {...}``, ``"Weiler et al. 2018":
{...}``). This module holds all the tables of the translator that name methods: SPlisHSPlasH's
names of its numbers, the numbers sphkit implements with the ``method`` names of sphkit's scene
schema, the per-method defaults and parameter blocks. The rest of the translator
(:mod:`sphkit.scene.splishsplash.configuration`, :mod:`sphkit.scene.splishsplash.materials`)
reads them only through this module. Which numbers sphkit implements, and under which scene
name, comes from the method registry (:mod:`sphkit.registry`); what is left here is
SPlisHSPlasH's own naming: its names of its numbers, its parameter blocks and defaults.
Numbering as in SPlisHSPlasH 2.16+ (``NonPressureForceRegistration.cpp``; the defaults were read
back from pysplishsplash 2.19).
"""

from __future__ import annotations

from collections.abc import Iterable

from sphkit import registry


def implemented(role: str) -> dict[int, str]:
    """SPlisHSPlasH's numbers of the methods sphkit implements in a role -> their scene names
    (read from :mod:`sphkit.registry`, the one place methods are named)."""
    return {m.splishsplash: m.name for m in registry.methods(role) if m.splishsplash is not None}


def _with_blocks(role: str, blocks: dict[int, str]) -> dict[int, tuple[str, str]]:
    """number -> (scene name, SPlisHSPlasH parameter block) of the implemented methods."""
    names = implemented(role)
    missing = sorted(set(names) - set(blocks))
    if missing:  # a registered number the translator cannot read the parameters of
        raise LookupError(f"SPlisHSPlasH translator: no parameter block for {role} {missing}")
    return {n: (names[n], blocks[n]) for n in sorted(names)}

# -- pressure solvers (Configuration.simulationMethod) ------------------------------------------

#: SPlisHSPlasH's ``simulationMethod`` numbers -> its names (also the names of the solvers'
#: parameter blocks in ``Configuration``)
SIMULATION_METHODS = {
    0: "WCSPH", 1: "PCISPH", 2: "PBF", 3: "IISPH", 4: "DFSPH", 5: "Projective Fluids", 6: "ICSPH",
}
#: SPlisHSPlasH's default ``simulationMethod`` (DFSPH)
DEFAULT_SIMULATION_METHOD = 4
#: SPlisHSPlasH ``simulationMethod`` numbers sphkit has -> ``pressure.method``
PRESSURE_METHODS = implemented("pressure")
#: SPlisHSPlasH's default ``minIterations`` per iterative solver: 2 from ``TimeStep``'s
#: constructor, raised to 3 by ``TimeStepPCISPH``'s
SOLVER_MIN_ITERATIONS = {1: 3, 2: 2, 3: 2, 4: 2, 5: 2, 6: 2}
#: the parameters of each iterative solver's block (the block is named as the method)
SOLVER_KEYS = {
    1: ("minIterations", "maxIterations", "maxError"),
    2: ("minIterations", "maxIterations", "maxError", "velocityUpdateMethod"),
    3: ("minIterations", "maxIterations", "maxError"),
    4: ("minIterations", "maxIterations", "maxError", "maxIterationsV", "maxErrorV",
        "enableDivergenceSolver"),
    # projective fluids: "stiffness" in 2.x scenes, "stiffnessPF" in SPlisHSPlasH's newer source
    5: ("minIterations", "maxIterations", "maxError", "stiffness", "stiffnessPF"),
    6: ("minIterations", "maxIterations", "maxError", "lambda", "pressureClamping"),
}
#: SPlisHSPlasH's defaults of projective fluids' stiffness [N/m] (``TimeStepPF``'s constructor)
#: and ICSPH's lambda [Pa] and pressure clamping (``TimeStepICSPH``'s)
PF_STIFFNESS = 50000.0
ICSPH_LAMBDA = 200000.0
ICSPH_CLAMPING = True

# -- boundary handling (Configuration.boundaryHandlingMethod) -----------------------------------

#: SPlisHSPlasH's ``boundaryHandlingMethod`` numbers -> its names
BOUNDARY_METHODS = {
    0: "Akinci et al. 2012 boundary particles",
    1: "Koschier and Bender 2017 density maps",
    2: "Bender et al. 2019 volume maps",
    3: "Nogina and Sellan 2026",
}
#: SPlisHSPlasH's default ``boundaryHandlingMethod`` (Bender et al. 2019 volume maps)
DEFAULT_BOUNDARY_METHOD = 2
#: SPlisHSPlasH ``boundaryHandlingMethod`` numbers sphkit has -> ``boundary.method``
BOUNDARY_MODELS = implemented("boundary")
#: ``boundary.method`` of a scene without rigid bodies whose ``boundaryHandlingMethod`` sphkit
#: does not have (the number is checked only when the scene has rigid bodies)
FALLBACK_BOUNDARY_MODEL = "akinci2012"

# -- viscosity (Materials[].viscosityMethod) ----------------------------------------------------

#: SPlisHSPlasH's ``viscosityMethod`` numbers -> its names
VISCOSITY_METHODS = {
    0: "none", 1: "Standard", 2: "Bender and Koschier 2017", 3: "Peer et al. 2015",
    4: "Peer et al. 2016", 5: "Takahashi et al. 2015 (improved)", 6: "Weiler et al. 2018",
}
#: SPlisHSPlasH's parameter block of each ``viscosityMethod``
VISCOSITY_BLOCKS = {
    1: "Standard viscosity", 2: "Bender and Koschier 2017", 3: "Peer et al. 2015",
    4: "Peer et al. 2016", 5: "Takahashi et al. 2015 (improved)", 6: "Weiler et al. 2018",
}
#: SPlisHSPlasH's ``viscoMaxIter`` default of its implicit viscosity models (their
#: viscoMaxError default is 0.01; read back from pysplishsplash 2.19)
VISCOSITY_MAX_ITER = {2: 50, 3: 50, 4: 50, 5: 100, 6: 100}
_VISCOSITY = _with_blocks("viscosity", VISCOSITY_BLOCKS)
#: explicit viscosity sphkit supports: number -> (scene method, SPlisHSPlasH block)
STANDARD_VISCOSITY = {n: v for n, v in _VISCOSITY.items() if n not in VISCOSITY_MAX_ITER}
#: implicit viscosity models sphkit supports: number -> (scene method, SPlisHSPlasH block,
#: viscoMaxIter default)
IMPLICIT_VISCOSITY = {n: (*v, VISCOSITY_MAX_ITER[n]) for n, v in _VISCOSITY.items()
                      if n in VISCOSITY_MAX_ITER}
#: models whose "viscosity" is a dimensionless factor in [0, 1]
FACTOR_VISCOSITY = {2, 3, 4}
#: models with a "viscosityBoundary"
BOUNDARY_VISCOSITY = {6}
#: models with a second solve for the angular velocity ("viscoMaxIterOmega",
#: "viscoMaxErrorOmega")
OMEGA_VISCOSITY = {4}
#: models whose "viscoMaxError" is an absolute strain rate [1/s] (the CG solvers' is a relative
#: residual below 1)
STRAIN_RATE_ERROR_VISCOSITY = {2}

# -- vorticity (Materials[].vorticityMethod) ----------------------------------------------------

#: SPlisHSPlasH's ``vorticityMethod`` numbers -> its names
VORTICITY_METHODS = {
    0: "none", 1: "Bender et al. 2017 micropolar model", 2: "vorticity confinement",
    3: "Liu et al. 2021 vorticity refinement",
}
#: vorticity models sphkit supports: number -> (scene method, SPlisHSPlasH block)
VORTICITY_SUPPORTED = _with_blocks(
    "vorticity", {1: "Bender et al. 2017", 2: "Vorticity confinement", 3: "Liu et al. 2021"})

# -- surface tension, drag, elasticity (Materials[]) --------------------------------------------

#: SPlisHSPlasH's numbers of the other non-pressure methods -> their names, per field
OTHER_METHODS = {
    "surfaceTensionMethod": {
        1: "Becker & Teschner 2007", 2: "Akinci et al. 2013", 3: "He et al. 2014",
        4: "Jeske et al. 2023", 5: "Zorilla, Ritter, et al. 2020",
    },
    "dragMethod": {1: "Macklin et al. 2014", 2: "Gissler et al. 2017"},
    "elasticityMethod": {
        1: "Becker et al. 2009", 2: "Peer et al. 2018", 3: "Kugelstadt et al. 2021",
        4: "Kee et al. 2023",
    },
}
#: surface tension methods sphkit implements: number -> (scene name, SPlisHSPlasH block)
SURFACE_TENSION_SUPPORTED = _with_blocks("surface_tension", OTHER_METHODS["surfaceTensionMethod"])
#: drag methods sphkit implements: number -> (scene name, SPlisHSPlasH block)
DRAG_SUPPORTED = _with_blocks("drag", OTHER_METHODS["dragMethod"])
#: elasticity methods sphkit implements: number -> (scene name, SPlisHSPlasH block)
ELASTICITY_SUPPORTED = _with_blocks("elasticity", OTHER_METHODS["elasticityMethod"])
#: the parameters of each elasticity block beyond ``youngsModulus``, ``poissonsRatio``,
#: ``alpha``, ``fixedBoxMin``, ``fixedBoxMax`` (implicit models: their iteration control and
#: the neighbour cap; defaults 100, 1e-4, -1)
ELASTICITY_KEYS = {
    1: (), 2: ("maxNeighbors", "elasticityMaxIter", "elasticityMaxError"),
    3: ("maxNeighbors", "volumeMaxIter", "volumeMaxError"),
    4: ("maxNeighbors", "fixedBox2Min", "fixedBox2Max", "solverType", "materialType",
        "maxIterations", "maxError", "maxIterationsCG", "tolCG", "maxLSIterations",
        "lsArmijoParam", "lsBeta", "useLineSearch", "lbfgsWindowSize"),
}
#: Jeske et al. 2023's parameters beside surfaceTension, surfaceTensionBoundary and
#: surfaceTensionMaxIter: SPlisHSPlasH name -> (sphkit field, default)
JESKE2023_FIELDS = {
    "surfaceTensionViscosity": ("viscosity", 0.0),
    "surfaceTensionViscosityBoundary": ("boundary_viscosity", 0.0),
    "surfaceTensionXSPH": ("xsph", 0.0), "surfaceTensionMaxError": ("max_error", 1e-3),
}
#: Kee et al. 2023's parameters (``Elasticity_Kee2023.cpp``): SPlisHSPlasH name -> (sphkit
#: field, default, kind); its enums: solverType 0 Newton, 1 L-BFGS; materialType 0 stable
#: neo-Hookean, 1 corotated
KEE2023_FIELDS = {
    "maxIterations": ("max_iterations", 100, "int"),
    "maxError": ("max_position_change", 1e-6, "num"),
    "maxIterationsCG": ("cg_max_iterations", 100, "int"),
    "tolCG": ("cg_tolerance", 1e-4, "num"),
    "maxLSIterations": ("line_search_iterations", 20, "int"),
    "lsArmijoParam": ("armijo", 1e-4, "num"),
    "lsBeta": ("line_search_beta", 0.5, "num"),
    "lbfgsWindowSize": ("lbfgs_window", 5, "int"),
}
KEE2023_SOLVERS = {0: "newton", 1: "lbfgs"}
KEE2023_MATERIALS = {0: "stable_neo_hookean", 1: "corotated"}
#: the fields of :data:`OTHER_METHODS` that sphkit reads (the others must be 0)
SUPPORTED_OTHER_METHODS = {"surfaceTensionMethod", "dragMethod", "elasticityMethod"}

#: the parameter blocks of SPlisHSPlasH's non-pressure methods in a material; ignored quietly
#: when the material does not select the method
MATERIAL_NAMESPACES = {
    "Bender and Koschier 2017", "Peer et al. 2015", "Peer et al. 2016",
    "Takahashi et al. 2015 (improved)", "Weiler et al. 2018", "Bender et al. 2017",
    "Vorticity confinement", "Liu et al. 2021", "Macklin et al. 2014", "Gissler et al. 2017",
    "Becker & Teschner 2007", "Akinci et al. 2013", "He et al. 2014", "Jeske et al. 2023",
    "Zorilla, Ritter, et al. 2020", "Becker et al. 2009", "Peer et al. 2018",
    "Kugelstadt et al. 2021", "Kee et al. 2023",
}


def supported_list(names: dict[int, str], numbers: Iterable[int]) -> str:
    """``"1 (name), 2 (name)"`` for the method ``numbers`` (keys of ``names``, SPlisHSPlasH's
    names of its numbers): the list of supported methods in the translator's error messages."""
    return ", ".join(f"{n} ({names[n]})" for n in numbers)
