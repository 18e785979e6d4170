"""The ``Configuration`` block of a SPlisHSPlasH scene: pressure solver, boundary, time, export.

``simulationMethod`` chooses the pressure solver (WCSPH's ``stiffness``/``exponent``, the
iterative solvers' ``minIterations``/``maxIterations``/``maxError`` and DFSPH's and PBF's own
settings, read from the block named as the method or flat from ``Configuration`` in scenes
before 2.16), ``boundaryHandlingMethod`` the boundary model; the time step (``timeStepSize``,
``cflMethod``, ``cflFactor``, ``cflMinTimeStepSize``, ``cflMaxTimeStepSize``, ``stopAt``), the
kernel (``kernel``, ``gradKernel``), gravity, the particle radius, z-sorting and the export
settings (``dataExportFPS``, ``enablePartioExport``, ``enableVTKExport``,
``particleAttributes``, ``enableStateExport`` with ``stateExportFPS`` as checkpoints) map to
sphkit's ``configuration`` and ``output``. Defaults and numbers:
:mod:`sphkit.scene.splishsplash`; the method tables: :mod:`sphkit.scene.splishsplash.methods`.
"""

from __future__ import annotations

from typing import Any

from sphkit.scene.splishsplash import legacy
from sphkit.scene.splishsplash.methods import (
    BOUNDARY_METHODS,
    BOUNDARY_MODELS,
    DEFAULT_BOUNDARY_METHOD,
    DEFAULT_SIMULATION_METHOD,
    FALLBACK_BOUNDARY_MODEL,
    ICSPH_CLAMPING,
    ICSPH_LAMBDA,
    PF_STIFFNESS,
    PRESSURE_METHODS,
    SIMULATION_METHODS,
    SOLVER_KEYS,
    SOLVER_MIN_ITERATIONS,
    supported_list,
)
from sphkit.scene.splishsplash.reader import Reader

_PBF_VELOCITY_UPDATES = {0: "first_order", 1: "second_order"}
_KERNELS_3D = {0: "cubic", 1: "wendland", 2: "poly6", 3: "spiky", 4: "cubic"}
_KERNELS_2D = {0: "cubic", 1: "wendland", 2: "cubic", 3: "cubic", 4: "cubic"}

# Configuration fields that only matter to the GUI, the exporters, or to solvers the scene does
# not select: ignored without a warning.
_CONFIG_QUIET = {
    "pause", "pauseAt", "cameraPosition", "cameraLookat", "numberOfStepsPerRenderUpdate",
    "renderWalls", "colorMapType", "colorField", "renderMinValue", "renderMaxValue",
    "renderMaxVelocity", "enablePartioExport", "enableVTKExport", "enableRigidBodyExport",
    "enableRigidBodyOBJExport", "enableRigidBodyPLYExport", "enableRigidBodyVTKExport",
    "particleAttributes", "enableAsyncExport",
    "enableObjectSplitting",
    # the pressure solvers' blocks (the selected one is read; WCSPH's is a known field) and
    # their flat (pre-2.16) parameters
    *SIMULATION_METHODS.values(), "minIterations", "maxIterations", "maxError",
    "maxIterationsV", "maxErrorV", "enableDivergenceSolver", "velocityUpdateMethod", "lambda",
    "pressureClamping",
}


def configuration(
    rd: Reader, cfg: dict[str, Any], has_rigid: bool, fluid_keys: set[str] | None = None
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The ``Configuration`` block -> sphkit's ``configuration`` and ``output`` (the pressure
    solver, the boundary model, the time step, the kernel, gravity, the export settings);
    ``has_rigid``: the scene has rigid bodies or emitters, so its boundary method matters;
    ``fluid_keys``: keys that are the fluid's in a scene of 2018 (read with the materials)."""
    w = "Configuration"
    known = {
        "particleRadius", "sim2D", "simulationMethod", "boundaryHandlingMethod",
        "gravitation", "timeStepSize", "cflMethod", "cflFactor", "cflMinTimeStepSize",
        "cflMaxTimeStepSize", "stopAt", "kernel", "gradKernel", "WCSPH", "stiffness",
        "stiffnessPF",
        "exponent", "enableZSort", "stepsPerZSort", "dataExportFPS", "enableStateExport",
        "stateExportFPS",
    }
    rd.collect_unknown(cfg, w, known | (fluid_keys or set()), _CONFIG_QUIET)

    method = rd.integer(cfg, "simulationMethod", w, DEFAULT_SIMULATION_METHOD)
    if method not in PRESSURE_METHODS:
        name = SIMULATION_METHODS.get(method, "unknown method")
        default = "" if "simulationMethod" in cfg else ", SPlisHSPlasH's default"
        supported = supported_list(SIMULATION_METHODS, PRESSURE_METHODS)
        raise rd.unsupported(
            f"{w}.simulationMethod",
            f"{method} ({name}{default}) is not supported yet; supported: {supported}",
        )
    rd.origin["configuration.pressure.method"] = f"{w}.simulationMethod"
    bhm = rd.integer(cfg, "boundaryHandlingMethod", w, DEFAULT_BOUNDARY_METHOD)
    if legacy.particle_walls(rd.data):
        bhm = 0
        rd.notes.append(f"{w}.boundaryHandlingMethod: not given, walls (isWall) without map keys: "
                        "read as a scene from before October 2019, when boundary particles "
                        "were the only method (0; since, the default is 2, volume maps); write "
                        "boundaryHandlingMethod to choose")
    if has_rigid and bhm not in BOUNDARY_MODELS:
        name = BOUNDARY_METHODS.get(bhm, "unknown method")
        default = "" if "boundaryHandlingMethod" in cfg else ", SPlisHSPlasH's default"
        supported = supported_list(BOUNDARY_METHODS, BOUNDARY_MODELS)
        raise rd.unsupported(
            f"{w}.boundaryHandlingMethod",
            f"{bhm} ({name}{default}) is not supported yet; supported: {supported}",
        )
    rd.origin["configuration.boundary.method"] = f"{w}.boundaryHandlingMethod"

    dim = 2 if rd.flag(cfg, "sim2D", w, False) else 3
    r = rd.num(cfg, "particleRadius", w, 0.025, positive=True)
    gravity = rd.vec3(cfg, "gravitation", w, [0.0, -9.81, 0.0])[:dim]
    dt = rd.num(cfg, "timeStepSize", w, 0.001, positive=True)
    cfl_method = rd.integer(cfg, "cflMethod", w, 1)
    if cfl_method not in (0, 1, 2):
        raise rd.error(f"{w}.cflMethod", cfl_method,
                       "0 (fixed step), 1 (CFL) or 2 (CFL with iteration control)")
    time = {
        "dt": dt,
        "cfl": cfl_method != 0,
        "cfl_factor": rd.num(cfg, "cflFactor", w, 0.5, positive=True),
        "dt_min": rd.num(cfg, "cflMinTimeStepSize", w, 1e-4, positive=True),
        "dt_max": rd.num(cfg, "cflMaxTimeStepSize", w, 0.005, positive=True),
        "iteration_control": cfl_method == 2,
    }
    rd.origin.update({
        "configuration.time.dt": f"{w}.timeStepSize",
        "configuration.time.cfl_factor": f"{w}.cflFactor",
        "configuration.time.dt_min": f"{w}.cflMinTimeStepSize",
        "configuration.time.dt_max": f"{w}.cflMaxTimeStepSize",
        "configuration.time.iteration_control": f"{w}.cflMethod",
        "configuration.time.cfl": f"{w}.cflMethod",
        "configuration.time.until": f"{w}.stopAt",
        "configuration.time": f"{w}.cflMinTimeStepSize/cflMaxTimeStepSize",
        "configuration.particle_radius": f"{w}.particleRadius",
        "configuration.kernel": f"{w}.kernel",
        "configuration.gravity": f"{w}.gravitation",
    })
    stop_at = rd.num(cfg, "stopAt", w, -1.0)
    if stop_at > 0:
        time["until"] = stop_at

    kernels = _KERNELS_2D if dim == 2 else _KERNELS_3D
    kid = rd.integer(cfg, "kernel", w, 0)
    gid = rd.integer(cfg, "gradKernel", w, kid if "kernel" in cfg else 0)
    for key, value in (("kernel", kid), ("gradKernel", gid)):
        if value not in kernels:
            raise rd.error(
                f"{w}.{key}", value,
                "0 (cubic), 1 (Wendland quintic C2), 2 (poly6), 3 (spiky) or 4 (precomputed "
                "cubic)",
            )
    if kernels[kid] != kernels[gid]:
        raise rd.unsupported(
            f"{w}.gradKernel",
            f"{gid} ({kernels[gid]}) differs from kernel {kid} ({kernels[kid]}); sphkit uses "
            "one kernel for W and its gradient, expected the same kernel",
        )

    if PRESSURE_METHODS[method] == "wcsph":
        pressure = wcsph(rd, cfg, cfl_method)
    else:
        pressure = iterative_solver(rd, cfg, method)

    configuration: dict[str, Any] = {
        "dim": dim,
        "particle_radius": r,
        "kernel": kernels[kid],
        "gravity": gravity,
        "time": time,
        "pressure": pressure,
        "boundary": {"method": BOUNDARY_MODELS.get(bhm, FALLBACK_BOUNDARY_MODEL)},
    }
    if not rd.flag(cfg, "enableZSort", w, True):
        configuration["zsort_every"] = 0
    elif "stepsPerZSort" in cfg:
        configuration["zsort_every"] = rd.integer(cfg, "stepsPerZSort", w, 500)
        rd.origin["configuration.zsort_every"] = f"{w}.stepsPerZSort"

    output: dict[str, Any] = {}
    if cfg.get("dataExportFPS") is not None:
        output["fps"] = rd.num(cfg, "dataExportFPS", w, 25.0, positive=True)
        rd.origin["output.fps"] = f"{w}.dataExportFPS"
    if rd.flag(cfg, "enableStateExport", w, False):  # SPlisHSPlasH's state files: checkpoints
        fps = rd.num(cfg, "stateExportFPS", w, 1.0, positive=True)
        output["checkpoint_every"] = 1.0 / fps
        rd.origin["output.checkpoint_every"] = f"{w}.stateExportFPS"
    output.update(export(rd, cfg))
    return configuration, output


def export(rd: Reader, cfg: dict[str, Any]) -> dict[str, Any]:
    """``enablePartioExport`` -> format bgeo, ``enableVTKExport`` -> vtk (neither: sphkit's
    default, vtk); ``enableRigidBodyVTKExport``/``OBJExport``/``PLYExport`` (and
    ``enableRigidBodyExport``, as OBJ) -> ``output.body_formats``; ``particleAttributes``
    ("velocity;density") -> ``output.attributes``."""
    w = "Configuration"
    out: dict[str, Any] = {}
    formats = [f for key, f in (("enableVTKExport", "vtk"), ("enablePartioExport", "bgeo"))
               if rd.flag(cfg, key, w, False)]
    if formats:
        out["formats"] = formats
    # the rigid bodies' meshes per frame (enableRigidBodyExport: SPlisHSPlasH's own binary
    # format, written here as OBJ); none set: sphkit's default beside the particle formats
    bodies = [f for key, f in (("enableRigidBodyVTKExport", "vtk"),
                               ("enableRigidBodyOBJExport", "obj"),
                               ("enableRigidBodyPLYExport", "ply"),
                               ("enableRigidBodyExport", "obj")) if rd.flag(cfg, key, w, False)]
    if bodies:
        out["body_formats"] = list(dict.fromkeys(bodies))
    attrs = cfg.get("particleAttributes")
    if attrs is not None:
        if not isinstance(attrs, str):
            raise rd.error(f"{w}.particleAttributes", attrs,
                           'a ";"-separated list of field names, e.g. "velocity;density"')
        names = [a.strip() for a in attrs.split(";") if a.strip()]
        out["attributes"] = [a for a in names if a not in ("position", "id")]
        rd.origin["output.attributes"] = f"{w}.particleAttributes"
    return out


def wcsph(rd: Reader, cfg: dict[str, Any], cfl_method: int) -> dict[str, Any]:
    """WCSPH's parameters (``"WCSPH"`` block, or the flat keys of scenes before 2.16)."""
    w = "Configuration"
    wc = rd.obj(cfg, "WCSPH", f"{w}.WCSPH")
    rd.collect_unknown(wc, f"{w}.WCSPH", {"stiffness", "exponent"}, set())
    # stiffness 0 (no pressure) is accepted here; the scene checks allow it only for elastic
    # solids (SPlisHSPlasH's Beam scenes)
    stiffness = rd.num(cfg, "stiffness", w, 50.0, nonneg=True)
    exponent = rd.num(cfg, "exponent", w, 7.0, positive=True)
    stiffness = rd.num(wc, "stiffness", f"{w}.WCSPH", stiffness, nonneg=True)
    exponent = rd.num(wc, "exponent", f"{w}.WCSPH", exponent, positive=True)
    src = f"{w}.WCSPH" if wc else w
    rd.origin["configuration.pressure.stiffness"] = f"{src}.stiffness"
    rd.origin["configuration.pressure.exponent"] = f"{src}.exponent"
    return {
        "method": "wcsph",
        "equation": "tait",
        "stiffness": stiffness,
        "exponent": exponent,
        # SPlisHSPlasH bounds its step by the CFL condition only; with a fixed step
        # (cflMethod 0) reproduce that step exactly
        "acoustic_cfl": cfl_method != 0,
    }


def iterative_solver(rd: Reader, cfg: dict[str, Any], method: int) -> dict[str, Any]:
    """PCISPH/PBF/IISPH/DFSPH: the iteration control from the block named as the method
    (``"DFSPH": {"maxError": ...}``), or from the flat keys of scenes before 2.16; absent
    keys take SPlisHSPlasH's defaults, ``minIterations`` per solver."""
    w = "Configuration"
    name = SIMULATION_METHODS[method]
    nsw = f"{w}.{name}"
    ns = rd.obj(cfg, name, nsw)
    keys = SOLVER_KEYS[method]
    rd.collect_unknown(ns, nsw, set(keys), set())

    def where(key: str) -> str:
        return nsw if key in ns or key not in cfg else w

    def integer(key: str, default: int) -> int:
        return rd.integer(ns, key, nsw, rd.integer(cfg, key, w, default))

    def num(key: str, default: float) -> float:
        return rd.num(ns, key, nsw, rd.num(cfg, key, w, default, positive=True),
                      positive=True)

    pressure: dict[str, Any] = {
        "method": PRESSURE_METHODS[method],
        "min_iterations": integer("minIterations", SOLVER_MIN_ITERATIONS[method]),
        "max_iterations": integer("maxIterations", 100),
        "max_error": num("maxError", 0.01),
    }
    ours = {"minIterations": "min_iterations", "maxIterations": "max_iterations",
            "maxError": "max_error", "maxIterationsV": "max_iterations_v",
            "maxErrorV": "max_error_v", "enableDivergenceSolver": "divergence_solver",
            "velocityUpdateMethod": "pbf_velocity_update", "stiffness": "pf_stiffness",
            "stiffnessPF": "pf_stiffness", "lambda": "icsph_lambda",
            "pressureClamping": "icsph_clamping"}
    for key in keys:
        rd.origin[f"configuration.pressure.{ours[key]}"] = f"{where(key)}.{key}"
        if key in ns and key in cfg and ns[key] != cfg[key]:
            rd.notes.append(
                f"{w}.{key}: {cfg[key]!r} is not used: {nsw}.{key} = {ns[key]!r} sets it (the "
                "method's own block wins, as SPlisHSPlasH since 2.16 reads only that block)")
    if pressure["method"] == "dfsph":
        pressure["max_iterations_v"] = integer("maxIterationsV", 100)
        pressure["max_error_v"] = num("maxErrorV", 0.1)
        pressure["divergence_solver"] = rd.flag(
            ns, "enableDivergenceSolver", nsw,
            rd.flag(cfg, "enableDivergenceSolver", w, True))
    elif pressure["method"] == "pbf":
        vum = integer("velocityUpdateMethod", 0)
        if vum not in _PBF_VELOCITY_UPDATES:
            raise rd.error(f"{where('velocityUpdateMethod')}.velocityUpdateMethod", vum,
                           "0 (first order) or 1 (second order)")
        pressure["pbf_velocity_update"] = _PBF_VELOCITY_UPDATES[vum]
    elif pressure["method"] == "pf":
        # scenes before 2.16 name it stiffnessPF, flat (a flat stiffness is WCSPH's)
        key = "stiffnessPF" if "stiffnessPF" in ns else "stiffness"
        flat = rd.num(cfg, "stiffnessPF", w, PF_STIFFNESS, positive=True)
        pressure["pf_stiffness"] = rd.num(ns, key, nsw, flat, positive=True)
        rd.origin["configuration.pressure.pf_stiffness"] = (
            f"{nsw}.{key}" if key in ns else f"{w}.stiffnessPF")
        if "maxError" in ns or "maxError" in cfg:
            rd.notes.append(
                f"{where('maxError')}.maxError: {pressure['max_error']} is not used by "
                "projective fluids (nor by SPlisHSPlasH's: its local/global iterations stop "
                "when the global step's relative residual is at most 1e-10, "
                "configuration.pressure.pf_tolerance; the density error follows from the "
                "stiffness)")
    elif pressure["method"] == "icsph":
        pressure["icsph_lambda"] = num("lambda", ICSPH_LAMBDA)
        pressure["icsph_clamping"] = rd.flag(
            ns, "pressureClamping", nsw, rd.flag(cfg, "pressureClamping", w, ICSPH_CLAMPING))
    return pressure

