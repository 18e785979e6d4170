"""Scene front ends: sphkit's own JSON/YAML, built-in scenes, and SPlisHSPlasH JSON scenes.

:func:`load_scene` is the one entry point; every front end produces a validated
:class:`~sphkit.scene.schema.Scene`. Every error is a :class:`~sphkit.scene.schema.SceneError`
whose message names the field path, the value and what was expected.

SPlisHSPlasH translation
------------------------
:func:`from_splishsplash` reads SPlisHSPlasH's scene format (field names as SPlisHSPlasH spells
them, methods chosen by its numbers; see ``reference/splishsplash_scene_format.md``). A field
that is absent takes SPlisHSPlasH's default. Checked against SPlisHSPlasH's sources
(``SPlisHSPlasH/Simulation.cpp``, ``TimeManager``/``SceneLoader.cpp``, ``TimeStep.cpp``,
``WCSPH/TimeStepWCSPH.cpp``, ``PCISPH/TimeStepPCISPH.cpp``, ``PBF/TimeStepPBF.cpp``,
``IISPH/TimeStepIISPH.cpp``, ``DFSPH/TimeStepDFSPH.cpp``, ``Viscosity/ViscosityBase.cpp``,
``Viscosity/Viscosity_Standard.cpp``, ``XSPH.cpp``, ``Vorticity/VorticityBase.cpp``,
``Vorticity/MicropolarModel_Bender2017.cpp``, ``Simulator/SimulatorBase.cpp``,
``Simulator/StaticBoundarySimulator.cpp``, ``NonPressureForceRegistration.cpp``) and the scenes
shipped with pysplishsplash 2.19 (the solver defaults were also read back from its time-step
objects):

==========================  ===============================================================
``simulationMethod``        4 (DFSPH); 0 WCSPH, 1 PCISPH, 2 PBF, 3 IISPH and 4 DFSPH map to
                            ``pressure.method`` wcsph/pcisph/pbf/iisph/dfsph; 5 (Projective
                            Fluids) and 6 (ICSPH) are not supported
``PCISPH``, ``PBF``,        the selected solver's block: ``minIterations`` (PCISPH 3, the
``IISPH``, ``DFSPH``        others 2), ``maxIterations`` 100, ``maxError`` 0.01 (% of rho0);
                            DFSPH also ``maxIterationsV`` 100, ``maxErrorV`` 0.1 (%),
                            ``enableDivergenceSolver`` true; PBF ``velocityUpdateMethod`` 0
                            (0 first order, 1 second order). The blocks of solvers the scene
                            does not select are ignored quietly.
``boundaryHandlingMethod``  2 (Bender et al. 2019 volume maps); 0 Akinci et al. 2012
                            particles, 1 Koschier & Bender 2017 density maps and 2 map to
                            ``boundary.method`` akinci2012/koschier2017/bender2019; 3 (Nogina
                            and Sellan 2026) is not supported (checked only when the scene has
                            rigid bodies)
``particleRadius``          0.025 m
``gravitation``             (0, -9.81, 0) m/s^2
``timeStepSize``            0.001 s (initial step; the fixed step when ``cflMethod`` is 0)
``cflMethod``               1 (0: fixed step, 1: CFL, 2: CFL with iteration control, read
                            as 1 with a warning for the iterative solvers: SPlisHSPlasH also
                            shrinks the step by 10 % above 10 iterations and grows it by 10 %
                            below 5, which sphkit does not do)
``cflFactor``               0.5
``cflMinTimeStepSize``      1e-4 s (hard-coded in older versions)
``cflMaxTimeStepSize``      0.005 s
``WCSPH.stiffness``         50 Pa (shipped scenes use 25,000 to 50,000); ``exponent`` 7
``kernel``, ``gradKernel``  WCSPH selects the cubic spline; 0 cubic, 1 Wendland quintic C2,
                            2 poly6, 3 spiky, 4 precomputed cubic (read as cubic). In 2D
                            SPlisHSPlasH knows only 0 (cubic) and 1 (Wendland) and falls back
                            to the cubic spline for any other number, as done here.
``density0``                1000 kg/m^3
``viscosityMethod``         0 (none); 1 Standard (``"Standard viscosity": {"viscosity": nu,
                            "viscosityBoundary": nu_b}``, nu default 0.01 m^2/s, kinematic),
                            the implicit models, each with its block of ``"viscosity"``,
                            ``"viscoMaxIter"``, ``"viscoMaxError"`` (default 0.01):
                            2 Bender and Koschier 2017 (``"Bender and Koschier 2017"``,
                            viscosity a factor in [0, 1], default 0.01, viscoMaxIter 50),
                            3 Peer et al. 2015 (``"Peer et al. 2015"``, factor, 50),
                            4 Peer et al. 2016 (``"Peer et al. 2016"``, factor, 50, also
                            ``"viscoMaxIterOmega"`` 50, ``"viscoMaxErrorOmega"`` 0.01),
                            5 Takahashi et al. 2015 (``"Takahashi et al. 2015 (improved)"``,
                            kinematic, 100), 6 Weiler et al. 2018 (``"Weiler et al. 2018"``,
                            kinematic, 100, also ``"viscosityBoundary"`` 0) (numbering of 2.16+;
                            the XSPH filter is no longer a viscosity method but the per-material
                            block ``"XSPH": {"xsph": c, "xsphBoundary": c_b}``, default 0)
``vorticityMethod``         0 (none); 1 micropolar model of Bender et al. 2017 (``"Bender et al.
                            2017": {"vorticity": nu_t, "viscosityOmega": zeta, "inertiaInverse":
                            1/Theta}``, defaults 0.01 m^2/s, 0.1 m^2, 0.5 1/m^2); 2 vorticity
                            confinement (``"Vorticity confinement": {"vorticity": epsilon}``,
                            default 0.01 m/s); 3 Liu et al. 2021 is not supported (numbering of
                            ``NonPressureForceRegistration.cpp``)
``surfaceTensionMethod``    0 (none); 1 Becker & Teschner 2007, 2 Akinci et al. 2013, 3 He et
                            al. 2014, each with its block ``{"surfaceTension": c,
                            "surfaceTensionBoundary": c_b}`` (defaults 0.05, 0.01; units in
                            :mod:`sphkit.surface_tension`); 4 Jeske et al. 2023 and 5 Zorilla,
                            Ritter et al. 2020 are not supported
``dragMethod``              0 (none); 1 Macklin et al. 2014, 2 Gissler et al. 2017, with the
                            block ``{"drag": c}`` (default 0.01)
``stopAt``                  -1 (no end); mapped to ``time.until`` when > 0
``dataExportFPS``           25; mapped to ``output.fps``
``enablePartioExport``,     false; mapped to ``output.formats`` bgeo and vtk (neither set:
``enableVTKExport``         sphkit's default, vtk)
``particleAttributes``      ``"velocity;density"`` -> ``output.attributes`` (absent: sphkit's
                            default velocity, density, pressure)
``FluidModels``             ``particleFile`` (BGEO, PLY, VTK/VTU; relative to the scene file)
                            -> ``fluid_files``: ``translation``, ``scale`` (only the first
                            component, as SPlisHSPlasH), ``rotationAxis``/``rotationAngle``,
                            ``id``, ``initialVelocity``, ``initialAngularVelocity`` (these
                            replace the file's velocities, as in SPlisHSPlasH); OBJ meshes to
                            fill are not supported
``Emitters``                ``type`` 0 (box) / 1 (circle), ``width``/``height`` 5 (particles,
                            become ``width``/``height`` = n 2r), ``translation``,
                            ``rotationAxis``/``rotationAngle`` (forced about z in 2D, where every
                            emitter is a box of width 1 as in ``createEmitters``), ``velocity``
                            1, ``id``, ``emitStartTime`` 0, ``emitEndTime`` (none) ->
                            ``emitters`` (:mod:`sphkit.emitters`); the material's
                            ``maxEmitterParticles`` (10,000) -> ``max_particles``;
                            ``emitterReuseParticles`` is not supported (a warning)
==========================  ===============================================================

Older scenes (before 2.16) write solver and method parameters flat (``"stiffness"`` or
``"maxError"`` in ``Configuration``, ``"viscosity"`` in a material); those are read when the
namespaced block does not set them (pysplishsplash 2.19 itself reads the iterative solvers'
parameters only from their block). Fields that only matter to SPlisHSPlasH's GUI, exporters or
to methods the scene does not select are ignored quietly; any other field sphkit does not know
is reported in one ``UserWarning`` listing the field paths.

Fluid blocks. SPlisHSPlasH (``SimulatorBase::createFluidBlocks``, ``denseMode`` 0) turns a block
into the box ``lo = scale * start + translation``, ``hi = scale * end + translation`` and places
``n = round((hi - lo) / 2r) - 1`` particles per axis at ``lo + 2r + 2r j`` (j = 0 .. n-1), i.e.
one particle diameter inside the box on both sides (in 2D only x and y, at z = 0). sphkit's
lattice (first particle at ``start + r``, last at or below ``end - r``) reproduces exactly these
positions with the block ``start' = lo + r``, ``end' = lo + r + 2r n``. A block with n < 1 on an
axis holds no particle in SPlisHSPlasH either; it is left out with a warning.

Rigid bodies. Static walls become :class:`~sphkit.scene.schema.MeshBoundary` entries; the mesh
is scaled, then rotated (``rotationAngle`` in radians about ``rotationAxis``), then translated,
as in ``StaticBoundarySimulator``. ``geometryFile`` stays relative to the scene file
(``scene.source``). In 2D SPlisHSPlasH samples the mesh's section with the plane z = 0 before the
(in-plane) rotation and translation; sphkit intersects the placed mesh, which is the same for
rotations about z and translations in the xy-plane.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from sphkit.scene.schema import Scene, SceneError, format_validation_error

__all__ = [
    "builtin_scenes",
    "builtin_scene_path",
    "from_splishsplash",
    "is_splishsplash",
    "load_scene",
    "load_scene_file",
    "resolve_scene_path",
    "scene_from_dict",
]

SCENE_SUFFIXES = (".json", ".yaml", ".yml")
_SCENES_DIR = Path(__file__).resolve().parent.parent / "scenes"


# ----------------------------------------------------------------------------------------------
# built-in scenes
# ----------------------------------------------------------------------------------------------


def _builtin_files() -> dict[str, Path]:
    if not _SCENES_DIR.is_dir():
        return {}
    return {
        p.stem: p
        for p in sorted(_SCENES_DIR.iterdir())
        if p.is_file() and p.suffix.lower() in SCENE_SUFFIXES
    }


def builtin_scenes() -> dict[str, str]:
    """The built-in scenes: name -> one-line description (sorted by name)."""
    out = {}
    for name, path in _builtin_files().items():
        try:
            data = _read_mapping(path)
            out[name] = str(data.get("description", "")).strip()
        except SceneError as err:
            out[name] = f"(unreadable: {err})"
    return out


def builtin_scene_path(name: str) -> Path:
    """Path of the built-in scene ``name``; SceneError listing the known names otherwise."""
    files = _builtin_files()
    if name not in files:
        raise SceneError(
            f"unknown built-in scene {name!r}; built-in scenes: {', '.join(files) or '(none)'}"
        )
    return files[name]


# ----------------------------------------------------------------------------------------------
# files
# ----------------------------------------------------------------------------------------------


def _parse_json(text: str, path: Path) -> Any:
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise SceneError(
            f"scene file {str(path)!r}: invalid JSON at line {err.lineno}, column {err.colno}: "
            f"{err.msg}"
        ) from None


def _parse_yaml(text: str, path: Path) -> Any:
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None) or getattr(err, "context_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(err, "problem", None) or str(err)
        raise SceneError(f"scene file {str(path)!r}: invalid YAML{where}: {problem}") from None


def _read_mapping(path: Path) -> dict[str, Any]:
    """Read a JSON or YAML file whose top level is a mapping."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError(f"scene file {str(path)!r}: not found") from None
    except IsADirectoryError:
        raise SceneError(f"scene file {str(path)!r}: is a directory, expected a file") from None
    except UnicodeDecodeError:
        raise SceneError(f"scene file {str(path)!r}: not a UTF-8 text file") from None
    except OSError as err:
        raise SceneError(f"scene file {str(path)!r}: cannot be read ({err.strerror})") from None
    suffix = path.suffix.lower()
    if suffix == ".json" or (suffix not in (".yaml", ".yml") and text.lstrip().startswith("{")):
        data = _parse_json(text, path)
    else:
        data = _parse_yaml(text, path)
    if not isinstance(data, dict):
        raise SceneError(
            f"scene file {str(path)!r}: got {type(data).__name__} at the top level; "
            "expected a mapping of scene fields"
        )
    return data


def resolve_scene_path(scene: Scene, path: str | Path) -> Path:
    """Resolve a path written in a scene (e.g. a mesh file) against the scene file's folder."""
    p = Path(path).expanduser()
    if p.is_absolute() or not scene.source:
        return p
    return Path(scene.source).parent / p


def load_scene_file(path: str | Path) -> Scene:
    """Load a scene file: sphkit's JSON/YAML, or a SPlisHSPlasH JSON scene."""
    p = Path(path).expanduser()
    return scene_from_dict(_read_mapping(p), p)


def load_scene(src: str | os.PathLike[str] | Mapping[str, Any] | Scene) -> Scene:
    """Load a scene from a built-in name, a file, a dict, or return a Scene as it is.

    Args:
        src: a :class:`Scene`; a dict (sphkit's fields, or SPlisHSPlasH's when it has a
            ``Configuration`` block); a path to a sphkit JSON/YAML or SPlisHSPlasH JSON file
            (``scene.source`` becomes the file path, ``scene.name`` its stem unless the file
            names the scene); or a built-in scene name (see :func:`builtin_scenes`).

    Raises:
        SceneError: the file is missing or malformed (with the line), the name is unknown (the
            message lists the built-in scenes), or a field is invalid (path, value, expectation).
    """
    if isinstance(src, Scene):
        return src
    if isinstance(src, Mapping):
        return scene_from_dict(src)
    if isinstance(src, (str, os.PathLike)):
        name = os.fspath(src)
        path = Path(name).expanduser()
        if path.is_file():
            return load_scene_file(path)
        files = _builtin_files()
        if name in files:
            return load_scene_file(files[name])
        if path.is_dir():
            raise SceneError(f"scene {name!r}: is a directory, expected a scene file")
        if path.suffix.lower() in SCENE_SUFFIXES or "/" in name or os.sep in name:
            raise SceneError(f"scene file {name!r}: not found")
        raise SceneError(
            f"unknown scene {name!r}: neither a scene file nor a built-in scene; "
            f"built-in scenes: {', '.join(files) or '(none)'}"
        )
    raise SceneError(
        f"cannot load a scene from a {type(src).__name__}; expected a built-in scene name, "
        "a file path, a dict or a Scene"
    )


def is_splishsplash(data: Mapping[str, Any]) -> bool:
    """Whether a scene dict is in SPlisHSPlasH's format (capitalized top-level blocks)."""
    return any(k in data for k in ("Configuration", *_SPH_ARRAYS, *_SPH_UNSUPPORTED_ARRAYS))


def scene_from_dict(data: Mapping[str, Any], path: str | Path | None = None) -> Scene:
    """Validate a scene dict (sphkit's or SPlisHSPlasH's format) read from ``path`` (optional)."""
    if not isinstance(data, Mapping):
        raise SceneError(f"got {type(data).__name__}; expected a mapping of scene fields")
    if is_splishsplash(data):
        return from_splishsplash(data, path)
    d = dict(data)
    where = "scene"
    if path is not None:
        p = Path(path)
        where = f"scene file {str(p)!r}"
        d["source"] = str(p.resolve())
        if not d.get("name"):
            d["name"] = p.stem
    try:
        scene = Scene.model_validate(d)
    except ValidationError as err:
        raise SceneError(f"{where}: invalid scene:\n{format_validation_error(err)}") from None
    for k, m in enumerate(scene.meshes):
        f = resolve_scene_path(scene, m.geometry_file)
        if not f.is_file():
            raise SceneError(
                f"{where}: meshes[{k}].geometry_file: got {m.geometry_file!r}: expected an "
                f"existing mesh file (looked for {str(f)!r})"
            )
    for k, ff in enumerate(scene.fluid_files):
        _check_particle_file(resolve_scene_path(scene, ff.file), ff.file,
                             f"{where}: fluid_files[{k}].file")
    return scene


def _check_particle_file(f: Path, given: str, where: str) -> None:
    """SceneError naming ``where`` unless ``f`` is an existing particle file of a known format."""
    from sphkit.io.particle_files import PARTICLE_FILE_SUFFIXES, particle_file_kind

    if particle_file_kind(f) is None:
        raise SceneError(
            f"{where}: got {given!r}: expected a particle file ending in "
            f"{', '.join(PARTICLE_FILE_SUFFIXES)}"
        )
    if not f.is_file():
        raise SceneError(
            f"{where}: got {given!r}: expected an existing particle file (looked for {str(f)!r})"
        )


# ----------------------------------------------------------------------------------------------
# SPlisHSPlasH
# ----------------------------------------------------------------------------------------------

_SPH_ARRAYS = ("Materials", "FluidBlocks", "RigidBodies", "FluidModels", "Emitters")
_SPH_UNSUPPORTED_ARRAYS = {
    "AnimationFields": "animation fields",
    # joints of PositionBasedDynamics, which only connect dynamic rigid bodies
    "BallJoints": "joints between dynamic rigid bodies",
    "BallOnLineJoints": "joints between dynamic rigid bodies",
    "HingeJoints": "joints between dynamic rigid bodies",
    "UniversalJoints": "joints between dynamic rigid bodies",
    "SliderJoints": "joints between dynamic rigid bodies",
    "TargetAngleMotorHingeJoints": "motors on dynamic rigid bodies",
    "TargetVelocityMotorHingeJoints": "motors on dynamic rigid bodies",
    "TargetPositionMotorSliderJoints": "motors on dynamic rigid bodies",
    "TargetVelocityMotorSliderJoints": "motors on dynamic rigid bodies",
    "DamperJoints": "joints between dynamic rigid bodies",
    "RigidBodyParticleBallJoints": "joints between dynamic rigid bodies",
    "RigidBodySprings": "springs between dynamic rigid bodies",
    "DistanceJoints": "joints between dynamic rigid bodies",
}
_SPH_TOP_QUIET = {"Simulation"}  # PositionBasedDynamics settings, only used by dynamic bodies

_SIMULATION_METHODS = {
    0: "WCSPH", 1: "PCISPH", 2: "PBF", 3: "IISPH", 4: "DFSPH", 5: "Projective Fluids", 6: "ICSPH",
}
#: SPlisHSPlasH ``simulationMethod`` numbers sphkit has -> ``pressure.method``
_PRESSURE_METHODS = {0: "wcsph", 1: "pcisph", 2: "pbf", 3: "iisph", 4: "dfsph"}
#: SPlisHSPlasH's default ``minIterations`` per iterative solver: 2 from ``TimeStep``'s
#: constructor, raised to 3 by ``TimeStepPCISPH``'s
_SOLVER_MIN_ITERATIONS = {1: 3, 2: 2, 3: 2, 4: 2}
#: the parameters of each iterative solver's block (the block is named as the method)
_SOLVER_KEYS = {
    1: ("minIterations", "maxIterations", "maxError"),
    2: ("minIterations", "maxIterations", "maxError", "velocityUpdateMethod"),
    3: ("minIterations", "maxIterations", "maxError"),
    4: ("minIterations", "maxIterations", "maxError", "maxIterationsV", "maxErrorV",
        "enableDivergenceSolver"),
}
_PBF_VELOCITY_UPDATES = {0: "first_order", 1: "second_order"}
_BOUNDARY_METHODS = {
    0: "Akinci et al. 2012 boundary particles",
    1: "Koschier and Bender 2017 density maps",
    2: "Bender et al. 2019 volume maps",
    3: "Nogina and Sellan 2026",
}
#: SPlisHSPlasH ``boundaryHandlingMethod`` numbers sphkit has -> ``boundary.method``
_BOUNDARY_MODELS = {0: "akinci2012", 1: "koschier2017", 2: "bender2019"}
#: mesh formats a FluidModels particleFile may name (sampled through the mesh's signed distance)
_MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off")
#: a FluidModels particleFile with these suffixes is a mesh to fill (``.ply`` is a particle file)
_FILL_SUFFIXES = (".obj", ".stl", ".off")
_VISCOSITY_METHODS = {
    0: "none", 1: "Standard", 2: "Bender and Koschier 2017", 3: "Peer et al. 2015",
    4: "Peer et al. 2016", 5: "Takahashi et al. 2015 (improved)", 6: "Weiler et al. 2018",
}
# implicit viscosity models sphkit supports: number -> (scene method, SPlisHSPlasH namespace,
# viscoMaxIter default); their viscoMaxError default is 0.01 (read back from pysplishsplash 2.19)
_IMPLICIT_VISCOSITY = {
    2: ("bender2017", "Bender and Koschier 2017", 50),
    3: ("peer2015", "Peer et al. 2015", 50),
    4: ("peer2016", "Peer et al. 2016", 50),
    5: ("takahashi2015", "Takahashi et al. 2015 (improved)", 100),
    6: ("weiler2018", "Weiler et al. 2018", 100),
}
# models whose "viscosity" is a dimensionless factor in [0, 1]; models with a viscosityBoundary
_FACTOR_VISCOSITY = {2, 3, 4}
_BOUNDARY_VISCOSITY = {6}
_VORTICITY_METHODS = {
    0: "none", 1: "Bender et al. 2017 micropolar model", 2: "vorticity confinement",
    3: "Liu et al. 2021 vorticity refinement",
}
_OTHER_METHODS = {
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
# surface tension and drag methods sphkit implements: number -> (scene name, SPlisHSPlasH block)
_SURFACE_TENSION_SUPPORTED = {
    1: ("becker2007", "Becker & Teschner 2007"), 2: ("akinci2013", "Akinci et al. 2013"),
    3: ("he2014", "He et al. 2014"),
}
_DRAG_SUPPORTED = {1: ("macklin2014", "Macklin et al. 2014"),
                   2: ("gissler2017", "Gissler et al. 2017")}
_SUPPORTED_OTHER_METHODS = {"surfaceTensionMethod", "dragMethod"}
_KERNELS_3D = {0: "cubic", 1: "wendland", 2: "poly6", 3: "spiky", 4: "cubic"}
_KERNELS_2D = {0: "cubic", 1: "wendland", 2: "cubic", 3: "cubic", 4: "cubic"}
_DENSE_MODES = {1: "more dense (hexagonal layers)", 2: "dense (hexagonal close packing)"}

# Configuration fields that only matter to the GUI, the exporters, or to solvers the scene does
# not select: ignored without a warning.
_CONFIG_QUIET = {
    "pause", "pauseAt", "cameraPosition", "cameraLookat", "numberOfStepsPerRenderUpdate",
    "renderWalls", "colorMapType", "colorField", "renderMinValue", "renderMaxValue",
    "renderMaxVelocity", "enablePartioExport", "enableVTKExport", "enableRigidBodyExport",
    "enableRigidBodyOBJExport", "enableRigidBodyPLYExport", "enableRigidBodyVTKExport",
    "particleAttributes", "enableStateExport", "stateExportFPS", "enableAsyncExport",
    "enableObjectSplitting",
    # other pressure solvers' namespaces and their flat (pre-2.16) parameters
    "PCISPH", "PBF", "IISPH", "DFSPH", "Projective Fluids", "ICSPH", "minIterations",
    "maxIterations", "maxError", "maxIterationsV", "maxErrorV", "enableDivergenceSolver",
    "velocityUpdateMethod", "lambda", "pressureClamping",
}
_MATERIAL_QUIET = {
    "colorField", "colorMapType", "renderMinValue", "renderMaxValue", "visible",
    # emitter settings (read with the emitters; the box only matters with reuse, see notes)
    "maxEmitterParticles", "emitterReuseParticles", "emitterBoxMin", "emitterBoxMax",
}
# namespaces of non-pressure methods; ignored when the material does not select the method
_MATERIAL_NAMESPACES = {
    "Bender and Koschier 2017", "Peer et al. 2015", "Peer et al. 2016",
    "Takahashi et al. 2015 (improved)", "Weiler et al. 2018", "Bender et al. 2017",
    "Vorticity confinement", "Liu et al. 2021", "Macklin et al. 2014", "Gissler et al. 2017",
    "Becker & Teschner 2007", "Akinci et al. 2013", "He et al. 2014", "Jeske et al. 2023",
    "Zorilla, Ritter, et al. 2020", "Becker et al. 2009", "Peer et al. 2018",
    "Kugelstadt et al. 2021", "Kee et al. 2023",
}
_RIGID_QUIET = {
    "color", "isWall", "samplingMode", "tubeMapOrder",
    # PositionBasedDynamics settings, only used by dynamic bodies
    "density", "friction", "restitution", "collisionObjectType", "collisionObjectScale",
    "invertSDF", "id",
}
_BLOCK_QUIET = {"visMesh"}


class _Translator:
    """One SPlisHSPlasH scene -> sphkit scene dict, collecting unknown fields."""

    def __init__(self, data: Mapping[str, Any], path: str | Path | None) -> None:
        self.data = data
        self.path = None if path is None else Path(path)
        self.label = (
            f"SPlisHSPlasH scene {str(self.path)!r}" if self.path else "SPlisHSPlasH scene"
        )
        self.unknown: list[str] = []
        self.notes: list[str] = []
        self.origin: dict[str, str] = {}  # sphkit field path -> SPlisHSPlasH field path

    # -- errors and value readers --------------------------------------------------------------
    def error(self, where: str, value: Any, expected: str) -> SceneError:
        return SceneError(f"{self.label}: {where}: got {value!r}: expected {expected}")

    def unsupported(self, where: str, message: str) -> SceneError:
        return SceneError(f"{self.label}: {where}: {message}")

    def obj(self, parent: Mapping[str, Any], key: str, where: str) -> dict[str, Any]:
        v = parent.get(key)
        if v is None:
            return {}
        if not isinstance(v, Mapping):
            raise self.error(where, v, "an object {...}")
        return dict(v)

    def array(self, key: str) -> list[dict[str, Any]]:
        v = self.data.get(key)
        if v is None:
            return []
        if not isinstance(v, list):
            raise self.error(key, v, "an array [...]")
        for k, item in enumerate(v):
            if not isinstance(item, Mapping):
                raise self.error(f"{key}[{k}]", item, "an object {...}")
        return [dict(item) for item in v]

    def num(
        self,
        obj: Mapping[str, Any],
        key: str,
        where: str,
        default: float,
        *,
        positive: bool = False,
        nonneg: bool = False,
    ) -> float:
        v = obj.get(key)
        if v is None:
            return default
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise self.error(f"{where}.{key}", v, "a finite number")
        if positive and not v > 0:
            raise self.error(f"{where}.{key}", v, "a number > 0")
        if nonneg and not v >= 0:
            raise self.error(f"{where}.{key}", v, "a number >= 0")
        return float(v)

    def integer(self, obj: Mapping[str, Any], key: str, where: str, default: int) -> int:
        v = obj.get(key)
        if v is None:
            return default
        if isinstance(v, bool) or not isinstance(v, (int, float)) or v != int(v):
            raise self.error(f"{where}.{key}", v, "an integer")
        return int(v)

    def flag(self, obj: Mapping[str, Any], key: str, where: str, default: bool) -> bool:
        v = obj.get(key)
        if v is None:
            return default
        if isinstance(v, bool):
            return v
        if isinstance(v, int):  # SPlisHSPlasH reads integers as booleans (non-zero is true)
            return v != 0
        raise self.error(f"{where}.{key}", v, "true or false")

    def vec3(
        self, obj: Mapping[str, Any], key: str, where: str, default: list[float]
    ) -> list[float]:
        v = obj.get(key)
        if v is None:
            return list(default)
        if (
            not isinstance(v, (list, tuple))
            or len(v) != 3
            or any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in v)
            or not all(math.isfinite(c) for c in v)
        ):
            raise self.error(f"{where}.{key}", v, "a list of 3 finite numbers")
        return [float(c) for c in v]

    def text(self, obj: Mapping[str, Any], key: str, where: str, default: str) -> str:
        v = obj.get(key)
        if v is None:
            return default
        if not isinstance(v, str):
            raise self.error(f"{where}.{key}", v, "a string")
        return v

    def collect_unknown(
        self, obj: Mapping[str, Any], where: str, known: set[str], quiet: set[str]
    ) -> None:
        for key in obj:
            if key not in known and key not in quiet:
                self.unknown.append(f"{where}.{key}" if where else key)

    # -- translation ---------------------------------------------------------------------------
    def translate(self) -> dict[str, Any]:
        data = self.data
        for key, what in _SPH_UNSUPPORTED_ARRAYS.items():
            v = data.get(key)
            if v:
                n = len(v) if isinstance(v, list) else 1
                raise self.unsupported(
                    key, f"{n} {'entry' if n == 1 else 'entries'}; {what} are not supported yet"
                )
        self.collect_unknown(
            data, "", {"Configuration", *_SPH_ARRAYS, *_SPH_UNSUPPORTED_ARRAYS}, _SPH_TOP_QUIET
        )

        cfg = self.obj(data, "Configuration", "Configuration")
        rigid = self.array("RigidBodies")
        # emitters come with a housing of boundary particles: the boundary method matters
        configuration, output = self.configuration(cfg, bool(rigid) or bool(self.array("Emitters")))
        dim = configuration["dim"]
        r = configuration["particle_radius"]
        materials = self.materials()
        blocks = self.fluid_blocks(dim, r)
        fluid_files = self.fluid_models()
        ids = [m["id"] for m in materials]
        for b in [*blocks, *fluid_files]:  # a fluid without a material entry gets the defaults
            if b["material"] not in ids:
                ids.append(b["material"])
                materials.append({"id": b["material"]})
        fluid_meshes = self.fluid_mesh_models(dim)
        for b in fluid_meshes:
            if b["material"] not in ids:
                ids.append(b["material"])
                materials.append({"id": b["material"]})
        if not materials:
            materials.append({"id": "Fluid"})
        meshes = self.rigid_bodies(rigid)
        emitters = self.emitters(dim, r)
        for e in emitters:
            if e["material"] not in [m["id"] for m in materials]:
                materials.append({"id": e["material"]})

        scene: dict[str, Any] = {
            "name": self.path.stem if self.path else "splishsplash",
            "description": "translated from the SPlisHSPlasH scene "
            + (self.path.name if self.path else "(dict)"),
            "configuration": configuration,
            "materials": materials,
            "fluid_blocks": blocks,
            "meshes": meshes,
        }
        if fluid_files:
            scene["fluid_files"] = fluid_files
        if fluid_meshes:
            scene["fluid_meshes"] = fluid_meshes
        if emitters:
            scene["emitters"] = emitters
        if output:
            scene["output"] = output
        if self.path is not None:
            scene["source"] = str(self.path.resolve())
        return scene

    def configuration(
        self, cfg: dict[str, Any], has_rigid: bool
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        w = "Configuration"
        known = {
            "particleRadius", "sim2D", "simulationMethod", "boundaryHandlingMethod",
            "gravitation", "timeStepSize", "cflMethod", "cflFactor", "cflMinTimeStepSize",
            "cflMaxTimeStepSize", "stopAt", "kernel", "gradKernel", "WCSPH", "stiffness",
            "exponent", "enableZSort", "stepsPerZSort", "dataExportFPS",
        }
        self.collect_unknown(cfg, w, known, _CONFIG_QUIET)

        method = self.integer(cfg, "simulationMethod", w, 4)
        if method not in _PRESSURE_METHODS:
            name = _SIMULATION_METHODS.get(method, "unknown method")
            default = "" if "simulationMethod" in cfg else ", SPlisHSPlasH's default"
            supported = ", ".join(f"{k} ({_SIMULATION_METHODS[k]})" for k in _PRESSURE_METHODS)
            raise self.unsupported(
                f"{w}.simulationMethod",
                f"{method} ({name}{default}) is not supported yet; supported: {supported}",
            )
        self.origin["configuration.pressure.method"] = f"{w}.simulationMethod"
        bhm = self.integer(cfg, "boundaryHandlingMethod", w, 2)
        if has_rigid and bhm not in _BOUNDARY_MODELS:
            name = _BOUNDARY_METHODS.get(bhm, "unknown method")
            default = "" if "boundaryHandlingMethod" in cfg else ", SPlisHSPlasH's default"
            supported = ", ".join(f"{k} ({_BOUNDARY_METHODS[k]})" for k in _BOUNDARY_MODELS)
            raise self.unsupported(
                f"{w}.boundaryHandlingMethod",
                f"{bhm} ({name}{default}) is not supported yet; supported: {supported}",
            )
        self.origin["configuration.boundary.method"] = f"{w}.boundaryHandlingMethod"

        dim = 2 if self.flag(cfg, "sim2D", w, False) else 3
        r = self.num(cfg, "particleRadius", w, 0.025, positive=True)
        gravity = self.vec3(cfg, "gravitation", w, [0.0, -9.81, 0.0])[:dim]
        dt = self.num(cfg, "timeStepSize", w, 0.001, positive=True)
        cfl_method = self.integer(cfg, "cflMethod", w, 1)
        if cfl_method not in (0, 1, 2):
            raise self.error(f"{w}.cflMethod", cfl_method,
                             "0 (fixed step), 1 (CFL) or 2 (CFL with iteration control)")
        time = {
            "dt": dt,
            "cfl": cfl_method != 0,
            "cfl_factor": self.num(cfg, "cflFactor", w, 0.5, positive=True),
            "dt_min": self.num(cfg, "cflMinTimeStepSize", w, 1e-4, positive=True),
            "dt_max": self.num(cfg, "cflMaxTimeStepSize", w, 0.005, positive=True),
        }
        self.origin.update({
            "configuration.time.dt": f"{w}.timeStepSize",
            "configuration.time.cfl_factor": f"{w}.cflFactor",
            "configuration.time.dt_min": f"{w}.cflMinTimeStepSize",
            "configuration.time.dt_max": f"{w}.cflMaxTimeStepSize",
            "configuration.time.until": f"{w}.stopAt",
            "configuration.time": f"{w}.cflMinTimeStepSize/cflMaxTimeStepSize",
            "configuration.particle_radius": f"{w}.particleRadius",
            "configuration.gravity": f"{w}.gravitation",
        })
        stop_at = self.num(cfg, "stopAt", w, -1.0)
        if stop_at > 0:
            time["until"] = stop_at

        kernels = _KERNELS_2D if dim == 2 else _KERNELS_3D
        kid = self.integer(cfg, "kernel", w, 0)
        gid = self.integer(cfg, "gradKernel", w, kid if "kernel" in cfg else 0)
        for key, value in (("kernel", kid), ("gradKernel", gid)):
            if value not in kernels:
                raise self.error(
                    f"{w}.{key}", value,
                    "0 (cubic), 1 (Wendland quintic C2), 2 (poly6), 3 (spiky) or 4 (precomputed "
                    "cubic)",
                )
        if kernels[kid] != kernels[gid]:
            raise self.unsupported(
                f"{w}.gradKernel",
                f"{gid} ({kernels[gid]}) differs from kernel {kid} ({kernels[kid]}); sphkit uses "
                "one kernel for W and its gradient, expected the same kernel",
            )

        if method == 0:
            pressure = self.wcsph(cfg, cfl_method)
        else:
            pressure = self.iterative_solver(cfg, method)
            if cfl_method == 2:
                self.notes.append(
                    f"{w}.cflMethod: 2 (CFL with iteration control) is read as 1 (CFL): sphkit "
                    "does not shrink or grow the step with the pressure solver's iteration count"
                )

        configuration: dict[str, Any] = {
            "dim": dim,
            "particle_radius": r,
            "kernel": kernels[kid],
            "gravity": gravity,
            "time": time,
            "pressure": pressure,
            "boundary": {"method": _BOUNDARY_MODELS.get(bhm, "akinci2012")},
        }
        if not self.flag(cfg, "enableZSort", w, True):
            configuration["zsort_every"] = 0
        elif "stepsPerZSort" in cfg:
            configuration["zsort_every"] = self.integer(cfg, "stepsPerZSort", w, 500)
            self.origin["configuration.zsort_every"] = f"{w}.stepsPerZSort"

        output: dict[str, Any] = {}
        if cfg.get("dataExportFPS") is not None:
            output["fps"] = self.num(cfg, "dataExportFPS", w, 25.0, positive=True)
            self.origin["output.fps"] = f"{w}.dataExportFPS"
        output.update(self.export(cfg))
        return configuration, output

    def export(self, cfg: dict[str, Any]) -> dict[str, Any]:
        """``enablePartioExport`` -> format bgeo, ``enableVTKExport`` -> vtk (neither: sphkit's
        default, vtk); ``particleAttributes`` ("velocity;density") -> ``output.attributes``."""
        w = "Configuration"
        out: dict[str, Any] = {}
        formats = [f for key, f in (("enableVTKExport", "vtk"), ("enablePartioExport", "bgeo"))
                   if self.flag(cfg, key, w, False)]
        if formats:
            out["formats"] = formats
        attrs = cfg.get("particleAttributes")
        if attrs is not None:
            if not isinstance(attrs, str):
                raise self.error(f"{w}.particleAttributes", attrs,
                                 'a ";"-separated list of field names, e.g. "velocity;density"')
            names = [a.strip() for a in attrs.split(";") if a.strip()]
            out["attributes"] = [a for a in names if a not in ("position", "id")]
            self.origin["output.attributes"] = f"{w}.particleAttributes"
        return out

    def wcsph(self, cfg: dict[str, Any], cfl_method: int) -> dict[str, Any]:
        """WCSPH's parameters (``"WCSPH"`` block, or the flat keys of scenes before 2.16)."""
        w = "Configuration"
        wc = self.obj(cfg, "WCSPH", f"{w}.WCSPH")
        self.collect_unknown(wc, f"{w}.WCSPH", {"stiffness", "exponent"}, set())
        stiffness = self.num(cfg, "stiffness", w, 50.0, positive=True)
        exponent = self.num(cfg, "exponent", w, 7.0, positive=True)
        stiffness = self.num(wc, "stiffness", f"{w}.WCSPH", stiffness, positive=True)
        exponent = self.num(wc, "exponent", f"{w}.WCSPH", exponent, positive=True)
        src = f"{w}.WCSPH" if wc else w
        self.origin["configuration.pressure.stiffness"] = f"{src}.stiffness"
        self.origin["configuration.pressure.exponent"] = f"{src}.exponent"
        return {
            "method": "wcsph",
            "equation": "tait",
            "stiffness": stiffness,
            "exponent": exponent,
            # SPlisHSPlasH bounds its step by the CFL condition only; with a fixed step
            # (cflMethod 0) reproduce that step exactly
            "acoustic_cfl": cfl_method != 0,
        }

    def iterative_solver(self, cfg: dict[str, Any], method: int) -> dict[str, Any]:
        """PCISPH/PBF/IISPH/DFSPH: the iteration control from the block named as the method
        (``"DFSPH": {"maxError": ...}``), or from the flat keys of scenes before 2.16; absent
        keys take SPlisHSPlasH's defaults, ``minIterations`` per solver."""
        w = "Configuration"
        name = _SIMULATION_METHODS[method]
        nsw = f"{w}.{name}"
        ns = self.obj(cfg, name, nsw)
        keys = _SOLVER_KEYS[method]
        self.collect_unknown(ns, nsw, set(keys), set())

        def where(key: str) -> str:
            return nsw if key in ns or key not in cfg else w

        def integer(key: str, default: int) -> int:
            return self.integer(ns, key, nsw, self.integer(cfg, key, w, default))

        def num(key: str, default: float) -> float:
            return self.num(ns, key, nsw, self.num(cfg, key, w, default, positive=True),
                            positive=True)

        pressure: dict[str, Any] = {
            "method": _PRESSURE_METHODS[method],
            "min_iterations": integer("minIterations", _SOLVER_MIN_ITERATIONS[method]),
            "max_iterations": integer("maxIterations", 100),
            "max_error": num("maxError", 0.01),
        }
        ours = {"minIterations": "min_iterations", "maxIterations": "max_iterations",
                "maxError": "max_error", "maxIterationsV": "max_iterations_v",
                "maxErrorV": "max_error_v", "enableDivergenceSolver": "divergence_solver",
                "velocityUpdateMethod": "pbf_velocity_update"}
        for key in keys:
            self.origin[f"configuration.pressure.{ours[key]}"] = f"{where(key)}.{key}"
        if method == 4:
            pressure["max_iterations_v"] = integer("maxIterationsV", 100)
            pressure["max_error_v"] = num("maxErrorV", 0.1)
            pressure["divergence_solver"] = self.flag(
                ns, "enableDivergenceSolver", nsw,
                self.flag(cfg, "enableDivergenceSolver", w, True))
        elif method == 2:
            vum = integer("velocityUpdateMethod", 0)
            if vum not in _PBF_VELOCITY_UPDATES:
                raise self.error(f"{where('velocityUpdateMethod')}.velocityUpdateMethod", vum,
                                 "0 (first order) or 1 (second order)")
            pressure["pbf_velocity_update"] = _PBF_VELOCITY_UPDATES[vum]
        return pressure

    def materials(self) -> list[dict[str, Any]]:
        out = []
        for k, m in enumerate(self.array("Materials")):
            w = f"Materials[{k}]"
            known = {
                "id", "density0", "viscosityMethod", "vorticityMethod", "surfaceTensionMethod",
                "dragMethod", "elasticityMethod", "Standard viscosity", "XSPH", "viscosity",
                "viscosityBoundary", "xsph", "xsphBoundary", "vorticity", "viscosityOmega",
                "inertiaInverse", "viscoMaxIter", "viscoMaxError", "viscoMaxIterOmega",
                "viscoMaxErrorOmega", "surfaceTension", "surfaceTensionBoundary", "drag",
            }
            self.collect_unknown(m, w, known, _MATERIAL_QUIET | _MATERIAL_NAMESPACES)
            mid = self.text(m, "id", w, "Fluid")
            density0 = self.num(m, "density0", w, 1000.0, positive=True)
            for key, names in _OTHER_METHODS.items():
                if key in _SUPPORTED_OTHER_METHODS:  # read by surface_tension() and drag()
                    continue
                v = self.integer(m, key, w, 0)
                if v != 0:
                    raise self.unsupported(
                        f"{w}.{key}",
                        f"{v} ({names.get(v, 'unknown method')}) is not supported yet; "
                        "supported: 0 (none)",
                    )
            vm = self.integer(m, "viscosityMethod", w, 0)
            viscosity: dict[str, Any] = {"method": "none"}
            if vm == 1:
                ns = self.obj(m, "Standard viscosity", f"{w}.Standard viscosity")
                nsw = f"{w}.Standard viscosity"
                self.collect_unknown(ns, nsw, {"viscosity", "viscosityBoundary"}, set())
                nu = self.num(m, "viscosity", w, 0.01, nonneg=True)
                nub = self.num(m, "viscosityBoundary", w, 0.0, nonneg=True)
                nu = self.num(ns, "viscosity", nsw, nu, nonneg=True)
                nub = self.num(ns, "viscosityBoundary", nsw, nub, nonneg=True)
                viscosity = {"method": "standard", "coefficient": nu, "boundary_coefficient": nub}
                src = nsw if ns else w
                self.origin[f"materials[{k}].viscosity.coefficient"] = f"{src}.viscosity"
                self.origin[f"materials[{k}].viscosity.boundary_coefficient"] = (
                    f"{src}.viscosityBoundary"
                )
            elif vm in _IMPLICIT_VISCOSITY:
                viscosity = self.implicit_viscosity(m, w, k, vm)
            elif vm != 0:
                raise self.unsupported(
                    f"{w}.viscosityMethod",
                    f"{vm} ({_VISCOSITY_METHODS.get(vm, 'unknown method')}) is not supported "
                    "yet; supported: 0 (none), 1 (Standard), "
                    + ", ".join(f"{n} ({_VISCOSITY_METHODS[n]})" for n in _IMPLICIT_VISCOSITY)
                    + " and the XSPH block",
                )
            xs = self.obj(m, "XSPH", f"{w}.XSPH")
            self.collect_unknown(xs, f"{w}.XSPH", {"xsph", "xsphBoundary"}, set())
            c = self.num(m, "xsph", w, 0.0, nonneg=True)
            cb = self.num(m, "xsphBoundary", w, 0.0, nonneg=True)
            c = self.num(xs, "xsph", f"{w}.XSPH", c, nonneg=True)
            cb = self.num(xs, "xsphBoundary", f"{w}.XSPH", cb, nonneg=True)
            if c > 0 or cb > 0:
                if vm != 0:
                    raise self.unsupported(
                        f"{w}.XSPH",
                        f"xsph {c} together with viscosityMethod {vm} "
                        f"({_VISCOSITY_METHODS[vm]}) is not supported yet; sphkit applies one "
                        "viscosity model per material, expected one of them",
                    )
                viscosity = {"method": "xsph", "coefficient": c, "boundary_coefficient": cb}
                src = f"{w}.XSPH" if xs else w
                self.origin[f"materials[{k}].viscosity.coefficient"] = f"{src}.xsph"
                self.origin[f"materials[{k}].viscosity.boundary_coefficient"] = (
                    f"{src}.xsphBoundary"
                )
            vorticity = self.vorticity(m, w, k)
            self.origin[f"materials[{k}]"] = w
            self.origin[f"materials[{k}].density0"] = f"{w}.density0"
            out.append({"id": mid, "density0": density0, "viscosity": viscosity,
                        "vorticity": vorticity, "surface_tension": self.surface_tension(m, w, k),
                        "drag": self.drag(m, w, k)})
        self.origin["materials"] = "Materials"
        return out

    def implicit_viscosity(self, m: Mapping[str, Any], w: str, k: int,
                           vm: int) -> dict[str, Any]:
        """An implicit viscosity model's block (``viscosity``, ``viscoMaxIter``,
        ``viscoMaxError``; Weiler et al. 2018 also ``viscosityBoundary``, Peer et al. 2016 also
        ``viscoMaxIterOmega``, ``viscoMaxErrorOmega``; flat keys of scenes before 2.16 are read
        too)."""
        method, ns_key, max_iter = _IMPLICIT_VISCOSITY[vm]
        nsw = f"{w}.{ns_key}"
        ns = self.obj(m, ns_key, nsw)
        keys = {"viscosity", "viscoMaxIter", "viscoMaxError"}
        if vm in _BOUNDARY_VISCOSITY:
            keys.add("viscosityBoundary")
        if vm == 4:
            keys |= {"viscoMaxIterOmega", "viscoMaxErrorOmega"}
        self.collect_unknown(ns, nsw, keys, set())
        src = nsw if ns else w
        nu = self.num(ns, "viscosity", nsw, self.num(m, "viscosity", w, 0.01, nonneg=True),
                      nonneg=True)
        if vm in _FACTOR_VISCOSITY and not nu <= 1.0:
            raise self.error(f"{src}.viscosity", nu,
                             f"a dimensionless factor in [0, 1] ({_VISCOSITY_METHODS[vm]})")
        out: dict[str, Any] = {"method": method, "coefficient": nu}
        fields = [("coefficient", "viscosity"), ("max_iterations", "viscoMaxIter"),
                  ("max_error", "viscoMaxError")]
        if vm in _BOUNDARY_VISCOSITY:
            out["boundary_coefficient"] = self.num(
                ns, "viscosityBoundary", nsw,
                self.num(m, "viscosityBoundary", w, 0.0, nonneg=True), nonneg=True)
            fields.append(("boundary_coefficient", "viscosityBoundary"))
        # bender2017's maxError is an absolute strain rate [1/s]; the CG solvers' a relative
        # residual below 1
        below_one = vm != 2
        for suffix, ours in (("", ""), ("Omega", "_omega")) if vm == 4 else (("", ""),):
            its = self.integer(ns, f"viscoMaxIter{suffix}", nsw,
                               self.integer(m, f"viscoMaxIter{suffix}", w, max_iter))
            if its < 1:
                raise self.error(f"{src}.viscoMaxIter{suffix}", its, "an integer >= 1")
            err = self.num(ns, f"viscoMaxError{suffix}", nsw,
                           self.num(m, f"viscoMaxError{suffix}", w, 0.01, positive=True),
                           positive=True)
            if below_one and not err < 1:
                raise self.error(f"{src}.viscoMaxError{suffix}", err,
                                 "a relative residual in (0, 1)")
            out[f"max_iterations{ours}"] = its
            out[f"max_error{ours}"] = err
            if ours:
                fields += [(f"max_iterations{ours}", f"viscoMaxIter{suffix}"),
                           (f"max_error{ours}", f"viscoMaxError{suffix}")]
        for ours, theirs in fields:
            self.origin[f"materials[{k}].viscosity.{ours}"] = f"{src}.{theirs}"
        return out

    def vorticity(self, m: Mapping[str, Any], w: str, k: int) -> dict[str, Any]:
        """The material's vorticity model (``vorticityMethod``; 1: "Bender et al. 2017" block,
        or the flat keys of scenes before 2.16)."""
        vm = self.integer(m, "vorticityMethod", w, 0)
        if vm == 0:
            return {"method": "none"}
        if vm == 2:
            eps = self._namespaced(m, w, "Vorticity confinement", {"vorticity": 0.01})
            self._origin_of_block(m, w, k, "vorticity", "Vorticity confinement",
                                  {"coefficient": "vorticity"})
            return {"method": "confinement", "coefficient": eps["vorticity"]}
        if vm != 1:
            raise self.unsupported(
                f"{w}.vorticityMethod",
                f"{vm} ({_VORTICITY_METHODS.get(vm, 'unknown method')}) is not supported yet; "
                "supported: 0 (none), 1 (Bender et al. 2017 micropolar model), 2 (vorticity "
                "confinement)",
            )
        ns_key = "Bender et al. 2017"
        nsw = f"{w}.{ns_key}"
        ns = self.obj(m, ns_key, nsw)
        keys = {"vorticity": 0.01, "viscosityOmega": 0.1, "inertiaInverse": 0.5}
        self.collect_unknown(ns, nsw, set(keys), set())
        values = {}
        for key, default in keys.items():
            val = self.num(m, key, w, default, nonneg=True)
            values[key] = self.num(ns, key, nsw, val, nonneg=True)
        src = nsw if ns else w
        for ours, theirs in (("coefficient", "vorticity"), ("viscosity_omega", "viscosityOmega"),
                             ("inertia_inverse", "inertiaInverse")):
            self.origin[f"materials[{k}].vorticity.{ours}"] = f"{src}.{theirs}"
        return {"method": "micropolar", "coefficient": values["vorticity"],
                "viscosity_omega": values["viscosityOmega"],
                "inertia_inverse": values["inertiaInverse"]}

    def _namespaced(self, m: Mapping[str, Any], w: str, ns_key: str,
                    keys: dict[str, float]) -> dict[str, float]:
        """Non-negative numbers ``keys`` (name -> SPlisHSPlasH default) of a method, read from its
        namespace block ``ns_key`` or, for scenes before 2.16, flat from the material."""
        nsw = f"{w}.{ns_key}"
        ns = self.obj(m, ns_key, nsw)
        self.collect_unknown(ns, nsw, set(keys), set())
        values = {}
        for key, default in keys.items():
            val = self.num(m, key, w, default, nonneg=True)
            values[key] = self.num(ns, key, nsw, val, nonneg=True)
        return values

    def _origin_of_block(self, m: Mapping[str, Any], w: str, k: int, model: str, ns_key: str,
                         fields: dict[str, str]) -> None:
        src = f"{w}.{ns_key}" if m.get(ns_key) else w
        for ours, theirs in fields.items():
            self.origin[f"materials[{k}].{model}.{ours}"] = f"{src}.{theirs}"

    def surface_tension(self, m: Mapping[str, Any], w: str, k: int) -> dict[str, Any]:
        """The material's surface tension model (``surfaceTensionMethod`` 1-3 with the
        ``surfaceTension``/``surfaceTensionBoundary`` numbers of the method's block)."""
        sm = self.integer(m, "surfaceTensionMethod", w, 0)
        if sm == 0:
            return {"method": "none"}
        if sm not in _SURFACE_TENSION_SUPPORTED:
            names = _OTHER_METHODS["surfaceTensionMethod"]
            raise self.unsupported(
                f"{w}.surfaceTensionMethod",
                f"{sm} ({names.get(sm, 'unknown method')}) is not supported yet; supported: 0 "
                "(none), 1 (Becker & Teschner 2007), 2 (Akinci et al. 2013), 3 (He et al. 2014)",
            )
        method, ns_key = _SURFACE_TENSION_SUPPORTED[sm]
        v = self._namespaced(m, w, ns_key, {"surfaceTension": 0.05,
                                            "surfaceTensionBoundary": 0.01})
        self._origin_of_block(m, w, k, "surface_tension", ns_key,
                              {"coefficient": "surfaceTension",
                               "boundary_coefficient": "surfaceTensionBoundary"})
        return {"method": method, "coefficient": v["surfaceTension"],
                "boundary_coefficient": v["surfaceTensionBoundary"]}

    def drag(self, m: Mapping[str, Any], w: str, k: int) -> dict[str, Any]:
        """The material's drag model (``dragMethod`` 1-2 with the ``drag`` number of the
        method's block)."""
        dm = self.integer(m, "dragMethod", w, 0)
        if dm == 0:
            return {"method": "none"}
        if dm not in _DRAG_SUPPORTED:
            raise self.unsupported(
                f"{w}.dragMethod",
                f"{dm} (unknown method) is not supported; supported: 0 (none), 1 (Macklin et al. "
                "2014), 2 (Gissler et al. 2017)",
            )
        method, ns_key = _DRAG_SUPPORTED[dm]
        v = self._namespaced(m, w, ns_key, {"drag": 0.01})
        self._origin_of_block(m, w, k, "drag", ns_key, {"coefficient": "drag"})
        return {"method": method, "coefficient": v["drag"]}

    def fluid_blocks(self, dim: int, r: float) -> list[dict[str, Any]]:
        out = []
        for k, b in enumerate(self.array("FluidBlocks")):
            w = f"FluidBlocks[{k}]"
            known = {
                "id", "start", "end", "translation", "scale", "denseMode", "initialVelocity",
                "initialAngularVelocity",
            }
            self.collect_unknown(b, w, known, _BLOCK_QUIET)
            for key in ("start", "end"):
                if b.get(key) is None:
                    raise self.error(f"{w}.{key}", None, "a list of 3 finite numbers")
            start = self.vec3(b, "start", w, [0.0, 0.0, 0.0])
            end = self.vec3(b, "end", w, [0.0, 0.0, 0.0])
            translation = self.vec3(b, "translation", w, [0.0, 0.0, 0.0])
            scale = self.vec3(b, "scale", w, [1.0, 1.0, 1.0])
            mode = self.integer(b, "denseMode", w, 0)
            if mode != 0:
                raise self.unsupported(
                    f"{w}.denseMode",
                    f"{mode} ({_DENSE_MODES.get(mode, 'unknown mode')}) is not supported yet; "
                    "supported: 0 (regular lattice)",
                )
            velocity = self.vec3(b, "initialVelocity", w, [0.0, 0.0, 0.0])
            omega = self.vec3(b, "initialAngularVelocity", w, [0.0, 0.0, 0.0])
            if any(omega):
                raise self.unsupported(
                    f"{w}.initialAngularVelocity",
                    f"{omega}: rotating initial velocity fields are not supported yet; "
                    "expected [0, 0, 0]",
                )
            lo = [s * a + t for s, a, t in zip(scale, start, translation, strict=True)][:dim]
            hi = [s * a + t for s, a, t in zip(scale, end, translation, strict=True)][:dim]
            if not all(h > l for l, h in zip(lo, hi, strict=True)):
                raise self.error(
                    f"{w}.end", end,
                    f"to exceed start {start} on every axis after scale and translation "
                    f"(block {lo} .. {hi})",
                )
            # SPlisHSPlasH: round((hi - lo) / 2r) - 1 particles per axis, the first at lo + 2r
            counts = [
                math.floor((h - l) / (2.0 * r) + 0.5) - 1 for l, h in zip(lo, hi, strict=True)
            ]
            if min(counts) < 1:
                self.notes.append(
                    f"{w}: the block {lo} .. {hi} holds no particle of radius {r} in SPlisHSPlasH "
                    "(less than 2 particle diameters on an axis); it is left out"
                )
                continue
            n = len(out)
            self.origin[f"fluid_blocks[{n}]"] = w
            self.origin[f"fluid_blocks[{n}].material"] = f"{w}.id"
            self.origin[f"fluid_blocks[{n}].velocity"] = f"{w}.initialVelocity"
            block: dict[str, Any] = {
                "start": [l + r for l in lo],
                "end": [l + r + 2.0 * r * c for l, c in zip(lo, counts, strict=True)],
                "material": self.text(b, "id", w, "Fluid"),
            }
            if any(velocity[:dim]):
                block["velocity"] = velocity[:dim]
            out.append(block)
        self.origin["fluid_blocks"] = "FluidBlocks"
        return out

    def fluid_models(self) -> list[dict[str, Any]]:
        """``FluidModels`` with a particle file -> ``fluid_files`` (placement and velocity as in
        ``SimulatorBase::initFluidData``: only ``scale[0]`` scales a particle file; the file's
        velocities are replaced by ``initialVelocity`` and ``initialAngularVelocity``)."""
        out = []
        base = self.path.parent if self.path is not None else Path.cwd()
        for k, fm in enumerate(self.array("FluidModels")):
            w = f"FluidModels[{k}]"
            known = {"particleFile", "translation", "scale", "rotationAxis", "rotationAngle", "id",
                     "initialVelocity", "initialAngularVelocity"}
            name = self.text(fm, "particleFile", w, "")
            if not name:
                raise self.error(f"{w}.particleFile", fm.get("particleFile"),
                                 "a particle file (BGEO, PLY, VTK) or a closed mesh (OBJ, STL) "
                                 "relative to the scene file")
            if name.lower().endswith(_FILL_SUFFIXES):
                continue  # a mesh to fill with fluid: fluid_mesh_models
            self.collect_unknown(fm, w, known, {"visMesh"})
            p = Path(name).expanduser()
            f = p if p.is_absolute() else base / p
            _check_particle_file(f, name, f"{self.label}: {w}.particleFile")
            scale = self.vec3(fm, "scale", w, [1.0, 1.0, 1.0])
            if not scale[0] > 0:
                raise self.error(f"{w}.scale", scale, "a positive first component (SPlisHSPlasH "
                                 "scales particle files by scale[0])")
            if scale[1:] != [scale[0], scale[0]]:
                self.notes.append(
                    f"{w}.scale: {scale}: SPlisHSPlasH scales particle files uniformly by the "
                    f"first component, as sphkit does ({scale[0]})"
                )
            axis = self.vec3(fm, "rotationAxis", w, [1.0, 0.0, 0.0])
            angle = self.num(fm, "rotationAngle", w, 0.0)
            if angle != 0.0 and not any(axis):
                raise self.error(f"{w}.rotationAxis", axis, "a non-zero axis")
            n = len(out)
            self.origin[f"fluid_files[{n}]"] = w
            self.origin[f"fluid_files[{n}].material"] = f"{w}.id"
            entry: dict[str, Any] = {
                "file": name,
                "translation": self.vec3(fm, "translation", w, [0.0, 0.0, 0.0]),
                "scale": scale[0],
                "rotation_axis": axis,
                "rotation_angle": angle,
                "material": self.text(fm, "id", w, "Fluid"),
            }
            velocity = self.vec3(fm, "initialVelocity", w, [0.0, 0.0, 0.0])
            omega = self.vec3(fm, "initialAngularVelocity", w, [0.0, 0.0, 0.0])
            if any(velocity):
                entry["velocity"] = velocity
            if any(omega):
                entry["angular_velocity"] = omega
            out.append(entry)
        self.origin["fluid_files"] = "FluidModels"
        return out

    def emitters(self, dim: int, r: float) -> list[dict[str, Any]]:
        """``Emitters`` -> ``emitters`` (``SimulatorBase::createEmitters``, ``Emitter.cpp``):
        widths in particles become metres (``n 2r``); in 2D every emitter is a box of width 1,
        its line ``height`` (box) or ``width`` (circle) particles long, rotating about z; the
        material's ``maxEmitterParticles`` (10,000) becomes ``max_particles``."""
        caps = {}
        for m in self.array("Materials"):
            cap = self.integer(m, "maxEmitterParticles", "Materials[]", 10000)
            caps[self.text(m, "id", "Materials[]", "Fluid")] = cap
            if self.flag(m, "emitterReuseParticles", "Materials[]", False):
                self.notes.append(
                    f"Materials[id={m.get('id', 'Fluid')!r}].emitterReuseParticles: true: "
                    "sphkit does not recycle particles that leave emitterBoxMin/emitterBoxMax; "
                    "they stay in the simulation")
        out = []
        for k, e in enumerate(self.array("Emitters")):
            w = f"Emitters[{k}]"
            known = {"type", "width", "height", "translation", "rotationAxis", "rotationAngle",
                     "velocity", "id", "emitStartTime", "emitEndTime"}
            self.collect_unknown(e, w, known, set())
            kind = self.integer(e, "type", w, 0)
            if kind not in (0, 1):
                raise self.error(f"{w}.type", kind, "0 (box) or 1 (circle)")
            width = self.integer(e, "width", w, 5)
            height = self.integer(e, "height", w, 5)
            for key, v in (("width", width), ("height", height)):
                if v < 1:
                    raise self.error(f"{w}.{key}", v, "a number of particles >= 1")
            velocity = self.num(e, "velocity", w, 1.0, positive=True)
            start = self.num(e, "emitStartTime", w, 0.0, nonneg=True)
            end = None if e.get("emitEndTime") is None else self.num(e, "emitEndTime", w, 0.0)
            if end is not None and end < start:
                raise self.error(f"{w}.emitEndTime", end, f"a time >= emitStartTime {start}")
            axis = self.vec3(e, "rotationAxis", w, [0.0, 0.0, 1.0])
            angle = self.num(e, "rotationAngle", w, 0.0)
            diam = 2.0 * r
            entry: dict[str, Any] = {
                "shape": "circle" if kind == 1 else "box",
                "position": self.vec3(e, "translation", w, [0.0, 0.0, 0.0]),
                "velocity": velocity, "start_time": start, "end_time": end,
                "material": self.text(e, "id", w, "Fluid"),
            }
            if dim == 2:  # SPlisHSPlasH: a box of width 1, rotated about z
                entry.update(shape="box", width=(width if kind == 1 else height) * diam,
                             rotation_axis=[0.0, 0.0, 1.0], rotation_angle=angle)
            else:
                if angle != 0.0 and not any(axis):
                    raise self.error(f"{w}.rotationAxis", axis, "a non-zero axis")
                entry.update(width=width * diam, height=height * diam, rotation_axis=axis,
                             rotation_angle=angle)
            entry["max_particles"] = caps.get(entry["material"], 10000)
            n = len(out)
            self.origin[f"emitters[{n}]"] = w
            out.append(entry)
        self.origin["emitters"] = "Emitters"
        return out

    def rigid_bodies(self, bodies: list[dict[str, Any]]) -> list[dict[str, Any]]:
        out = []
        base = self.path.parent if self.path is not None else Path.cwd()
        for k, rb in enumerate(bodies):
            w = f"RigidBodies[{k}]"
            known = {
                "geometryFile", "particleFile", "translation", "rotationAxis", "rotationAngle",
                "scale", "isDynamic", "isAnimated", "mapInvert", "mapThickness", "mapResolution",
                "mapFile",
            }
            self.collect_unknown(rb, w, known, _RIGID_QUIET)
            dynamic = self.flag(rb, "isDynamic", w, False)
            if self.flag(rb, "isAnimated", w, False):
                raise self.unsupported(
                    f"{w}.isAnimated", "true: animated rigid bodies are not supported yet"
                )
            geometry = self.text(rb, "geometryFile", w, "")
            if not geometry:
                if rb.get("particleFile"):
                    raise self.unsupported(
                        f"{w}.particleFile",
                        "pre-sampled boundary particles are not supported yet; expected a "
                        "geometryFile (OBJ/PLY mesh) to sample",
                    )
                raise self.error(f"{w}.geometryFile", rb.get("geometryFile"),
                                 "a mesh file (OBJ/PLY/STL) relative to the scene file")
            if rb.get("particleFile"):
                self.unknown.append(f"{w}.particleFile (sphkit samples geometryFile instead)")
            if rb.get("mapFile"):
                self.unknown.append(f"{w}.mapFile (sphkit computes the map from geometryFile)")
            res = rb.get("mapResolution", [20, 20, 20])
            if (not isinstance(res, list) or len(res) != 3
                    or not all(isinstance(c, int) and not isinstance(c, bool) and c >= 1
                               for c in res)):
                raise self.error(f"{w}.mapResolution", res, "a list of 3 positive integers")
            self.origin[f"meshes[{len(out)}].map_resolution"] = f"{w}.mapResolution"
            self.origin[f"meshes[{len(out)}].map_thickness"] = f"{w}.mapThickness"
            p = Path(geometry).expanduser()
            f = p if p.is_absolute() else base / p
            if not f.is_file():
                raise self.error(f"{w}.geometryFile", geometry,
                                 f"an existing mesh file (looked for {str(f)!r})")
            scale = self.vec3(rb, "scale", w, [1.0, 1.0, 1.0])
            if not all(scale):
                raise self.error(f"{w}.scale", scale, "non-zero scale factors")
            axis = self.vec3(rb, "rotationAxis", w, [1.0, 0.0, 0.0])
            angle = self.num(rb, "rotationAngle", w, 0.0)
            if angle != 0.0 and not any(axis):
                raise self.error(f"{w}.rotationAxis", axis, "a non-zero axis")
            n = len(out)
            self.origin[f"meshes[{n}]"] = w
            out.append({
                "geometry_file": geometry,
                "translation": self.vec3(rb, "translation", w, [0.0, 0.0, 0.0]),
                "rotation_axis": axis,
                "rotation_angle": angle,
                "scale": scale,
                "invert": self.flag(rb, "mapInvert", w, False),
                "map_thickness": self.num(rb, "mapThickness", w, 0.0),
                "map_resolution": res,
            })
            if dynamic:  # PositionBasedDynamics' density and friction apply to sphkit's bodies
                out[-1].update(dynamic=True,
                               density=self.num(rb, "density", w, 1000.0, positive=True),
                               friction=self.num(rb, "friction", w, 0.5, nonneg=True))
                self.origin[f"meshes[{n}].density"] = f"{w}.density"
                self.origin[f"meshes[{n}].friction"] = f"{w}.friction"
        self.origin["meshes"] = "RigidBodies"
        return out

    def fluid_mesh_models(self, dim: int) -> list[dict[str, Any]]:
        """FluidModels whose particleFile is a closed mesh: fluid filling it (sphkit samples the
        mesh through its exact signed distance at the lattice points, so ``resolutionSDF`` is
        not needed); particle files are :meth:`fluid_models`."""
        out = []
        base = self.path.parent if self.path is not None else Path.cwd()
        for k, fm in enumerate(self.array("FluidModels")):
            w = f"FluidModels[{k}]"
            known = {
                "particleFile", "id", "translation", "scale", "rotationAxis", "rotationAngle",
                "invert", "resolutionSDF", "denseMode", "initialVelocity",
                "initialAngularVelocity",
            }
            f = self.text(fm, "particleFile", w, "")
            if not f.lower().endswith(_FILL_SUFFIXES):
                continue  # a particle file (or missing: reported by fluid_models)
            self.collect_unknown(fm, w, known, _BLOCK_QUIET)
            p = Path(f).expanduser()
            if not (p if p.is_absolute() else base / p).is_file():
                raise self.error(f"{w}.particleFile", f,
                                 f"an existing mesh file (looked for {str(base / p)!r})")
            mode = self.integer(fm, "denseMode", w, 0)
            if mode != 0:
                raise self.unsupported(
                    f"{w}.denseMode",
                    f"{mode} ({_DENSE_MODES.get(mode, 'unknown mode')}) is not supported yet; "
                    "supported: 0 (regular lattice)",
                )
            omega = self.vec3(fm, "initialAngularVelocity", w, [0.0, 0.0, 0.0])
            if any(omega):
                raise self.unsupported(
                    f"{w}.initialAngularVelocity",
                    f"{omega}: rotating initial velocity fields are not supported yet; "
                    "expected [0, 0, 0]",
                )
            scale = self.vec3(fm, "scale", w, [1.0, 1.0, 1.0])
            if not all(scale):
                raise self.error(f"{w}.scale", scale, "non-zero scale factors")
            axis = self.vec3(fm, "rotationAxis", w, [1.0, 0.0, 0.0])
            angle = self.num(fm, "rotationAngle", w, 0.0)
            if angle != 0.0 and not any(axis):
                raise self.error(f"{w}.rotationAxis", axis, "a non-zero axis")
            velocity = self.vec3(fm, "initialVelocity", w, [0.0, 0.0, 0.0])
            n = len(out)
            self.origin[f"fluid_meshes[{n}]"] = w
            self.origin[f"fluid_meshes[{n}].material"] = f"{w}.id"
            entry: dict[str, Any] = {
                "geometry_file": f,
                "translation": self.vec3(fm, "translation", w, [0.0, 0.0, 0.0]),
                "rotation_axis": axis,
                "rotation_angle": angle,
                "scale": scale,
                "invert": self.flag(fm, "invert", w, False),
                "material": self.text(fm, "id", w, "Fluid"),
            }
            if any(velocity[:dim]):
                entry["velocity"] = velocity[:dim]
            out.append(entry)
        return out

    # -- validation ----------------------------------------------------------------------------
    def validate(self, scene: dict[str, Any]) -> Scene:
        try:
            return Scene.model_validate(scene)
        except ValidationError as err:
            lines = []
            for line in format_validation_error(err).splitlines():
                path, sep, rest = line.partition(": ")
                origin = self._origin_of(path)
                if origin:
                    lines.append(f"{origin} (sphkit {path}){sep}{rest}")
                else:
                    lines.append(line)
            raise SceneError(
                f"{self.label}: invalid after translation to sphkit:\n" + "\n".join(lines)
            ) from None

    def _origin_of(self, path: str) -> str | None:
        p = path
        while p:
            if p in self.origin:
                tail = path[len(p):]
                return self.origin[p] + (tail if p != path and tail.startswith("[") else "")
            cut = max(p.rfind("."), p.rfind("["))
            if cut <= 0:
                break
            p = p[:cut]
        return None


def from_splishsplash(data: Mapping[str, Any], path: str | Path | None = None) -> Scene:
    """Translate a SPlisHSPlasH JSON scene (already parsed) into a sphkit :class:`Scene`.

    Args:
        data: the scene's top-level object (``Configuration``, ``Materials``, ``FluidBlocks``,
            ``RigidBodies``, ...).
        path: the scene file, if any: relative mesh paths are checked against its folder, it
            becomes ``scene.source`` and its stem ``scene.name``.

    Returns:
        The validated scene. Fields sphkit does not support yet but that do not change the
        simulation's meaning for the supported subset are listed in one ``UserWarning``.

    Raises:
        SceneError: a method or feature sphkit does not have yet (named with SPlisHSPlasH's
            number and name), or an invalid value (field path, value, expectation).
    """
    if not isinstance(data, Mapping):
        raise SceneError(f"SPlisHSPlasH scene: got {type(data).__name__}; expected an object")
    tr = _Translator(data, path)
    scene = tr.validate(tr.translate())
    if tr.unknown:
        warnings.warn(
            f"{tr.label}: ignored {len(tr.unknown)} field(s) that sphkit does not know or "
            f"support yet: {', '.join(tr.unknown)}",
            UserWarning,
            stacklevel=2,
        )
    for note in tr.notes:
        warnings.warn(f"{tr.label}: {note}", UserWarning, stacklevel=2)
    return scene
