"""The ``Materials`` of a SPlisHSPlasH scene: density, viscosity, vorticity, surface tension, drag.

Each material's non-pressure methods are chosen by number (``viscosityMethod``,
``vorticityMethod``, ``surfaceTensionMethod``, ``dragMethod``, ``elasticityMethod``)
and take their parameters from the block named after the method (``"Weiler et al. 2018":
{"viscosity": ...}``) or, in scenes before 2.16, flat from the material; the XSPH filter is the
per-material block ``"XSPH"``. Defaults and numbers: :mod:`sphkit.scene.splishsplash`; the method
tables: :mod:`sphkit.scene.splishsplash.methods`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sphkit.scene.splishsplash import legacy
from sphkit.scene.splishsplash.methods import (
    BOUNDARY_VISCOSITY,
    DRAG_SUPPORTED,
    ELASTICITY_KEYS,
    ELASTICITY_SUPPORTED,
    FACTOR_VISCOSITY,
    IMPLICIT_VISCOSITY,
    JESKE2023_FIELDS,
    KEE2023_FIELDS,
    KEE2023_MATERIALS,
    KEE2023_SOLVERS,
    MATERIAL_NAMESPACES,
    OMEGA_VISCOSITY,
    OTHER_METHODS,
    STANDARD_VISCOSITY,
    STRAIN_RATE_ERROR_VISCOSITY,
    SUPPORTED_OTHER_METHODS,
    SURFACE_TENSION_SUPPORTED,
    VISCOSITY_METHODS,
    VORTICITY_METHODS,
    VORTICITY_SUPPORTED,
    supported_list,
)
from sphkit.scene.splishsplash.reader import Reader

_MATERIAL_QUIET = {
    "colorField", "colorMapType", "renderMinValue", "renderMaxValue", "visible",
    # emitter settings (read with the emitters; the box only matters with reuse, see notes)
    "maxEmitterParticles", "emitterReuseParticles", "emitterBoxMin", "emitterBoxMax",
}


def materials(rd: Reader) -> list[dict[str, Any]]:
    """``Materials`` -> ``materials``: density, viscosity (a ``viscosityMethod`` or the XSPH
    block), vorticity, surface tension and drag of each fluid."""
    out = []
    rd.array("Materials")  # checked: an array of objects
    modern = legacy.since_2_16(rd.data)
    for k, (w, m) in enumerate(legacy.material_entries(rd.data)):
        m = legacy.renumber(m, w, rd.notes, modern)
        known = {
            "id", "density0", "viscosityMethod", "vorticityMethod", "surfaceTensionMethod",
            "dragMethod", "elasticityMethod", "Standard viscosity", "XSPH", "viscosity",
            "viscosityBoundary", "xsph", "xsphBoundary", "vorticity", "viscosityOmega",
            "inertiaInverse", "viscoMaxIter", "viscoMaxError", "viscoMaxIterOmega",
            "viscoMaxErrorOmega", "surfaceTension", "surfaceTensionBoundary", "drag",
        }
        if _flat_elasticity(m):
            known |= _FLAT_ELASTICITY
        if legacy.flat(m):  # a scene before 2.16: its surface tension's keys are flat too
            sm = m.get("surfaceTensionMethod")
            known |= {4: legacy.JESKE_KEYS,
                      5: {"surfTZRtemporalSmooth", *_ZR2020_NUMBERS, *_ZR2020_INTEGERS,
                          *_ZR2020_ENUMS}}.get(sm, set()) if isinstance(sm, int) else set()
        rd.collect_unknown(m, w, known, _MATERIAL_QUIET | MATERIAL_NAMESPACES)
        mid = rd.text(m, "id", w, "Fluid")
        density0 = rd.num(m, "density0", w, 1000.0, positive=True)
        for key, names in OTHER_METHODS.items():
            if key in SUPPORTED_OTHER_METHODS:  # read by surface_tension() and drag()
                continue
            v = rd.integer(m, key, w, 0)
            if v != 0:
                raise rd.unsupported(
                    f"{w}.{key}",
                    f"{v} ({names.get(v, 'unknown method')}) is not supported yet; "
                    "supported: 0 (none)",
                )
        vm = rd.integer(m, "viscosityMethod", w, 0)
        viscosity: dict[str, Any] = {"method": "none"}
        if vm in STANDARD_VISCOSITY:
            method, ns_key = STANDARD_VISCOSITY[vm]
            ns = rd.obj(m, ns_key, f"{w}.{ns_key}")
            nsw = f"{w}.{ns_key}"
            rd.collect_unknown(ns, nsw, {"viscosity", "viscosityBoundary"}, set())
            nu = rd.num(m, "viscosity", w, 0.01, nonneg=True)
            nub = rd.num(m, "viscosityBoundary", w, 0.0, nonneg=True)
            nu = rd.num(ns, "viscosity", nsw, nu, nonneg=True)
            nub = rd.num(ns, "viscosityBoundary", nsw, nub, nonneg=True)
            viscosity = {"method": method, "coefficient": nu, "boundary_coefficient": nub}
            src = nsw if ns else w
            rd.origin[f"materials[{k}].viscosity.coefficient"] = f"{src}.viscosity"
            rd.origin[f"materials[{k}].viscosity.boundary_coefficient"] = (
                f"{src}.viscosityBoundary"
            )
        elif vm in IMPLICIT_VISCOSITY:
            viscosity = implicit_viscosity(rd, m, w, k, vm)
        elif vm != 0:
            raise rd.unsupported(
                f"{w}.viscosityMethod",
                f"{vm} ({VISCOSITY_METHODS.get(vm, 'unknown method')}) is not supported "
                "yet; supported: 0 (none), "
                + supported_list(VISCOSITY_METHODS, [*STANDARD_VISCOSITY, *IMPLICIT_VISCOSITY])
                + " and the XSPH block",
            )
        xs = rd.obj(m, "XSPH", f"{w}.XSPH")
        rd.collect_unknown(xs, f"{w}.XSPH", {"xsph", "xsphBoundary"}, set())
        c = rd.num(m, "xsph", w, 0.0, nonneg=True)
        cb = rd.num(m, "xsphBoundary", w, 0.0, nonneg=True)
        c = rd.num(xs, "xsph", f"{w}.XSPH", c, nonneg=True)
        cb = rd.num(xs, "xsphBoundary", f"{w}.XSPH", cb, nonneg=True)
        if (c > 0 or cb > 0) and vm != 0:  # SPlisHSPlasH applies its XSPH on top
            src = f"{w}.XSPH" if xs else w
            viscosity.update(xsph=c, xsph_boundary=cb)
            rd.origin[f"materials[{k}].viscosity.xsph"] = f"{src}.xsph"
            rd.origin[f"materials[{k}].viscosity.xsph_boundary"] = f"{src}.xsphBoundary"
        elif c > 0 or cb > 0:
            viscosity = {"method": "xsph", "coefficient": c, "boundary_coefficient": cb}
            src = f"{w}.XSPH" if xs else w
            rd.origin[f"materials[{k}].viscosity.coefficient"] = f"{src}.xsph"
            rd.origin[f"materials[{k}].viscosity.boundary_coefficient"] = (
                f"{src}.xsphBoundary"
            )
        vort = vorticity(rd, m, w, k)
        rd.origin[f"materials[{k}]"] = w
        rd.origin[f"materials[{k}].density0"] = f"{w}.density0"
        out.append({"id": mid, "density0": density0, "viscosity": viscosity,
                    "vorticity": vort, "surface_tension": surface_tension(rd, m, w, k),
                    "drag": drag(rd, m, w, k), "elasticity": elasticity(rd, m, w, k)})
    rd.origin["materials"] = "Materials"
    return out


def implicit_viscosity(rd: Reader, m: Mapping[str, Any], w: str, k: int,
                       vm: int) -> dict[str, Any]:
    """An implicit viscosity model's block (``viscosity``, ``viscoMaxIter``,
    ``viscoMaxError``; Weiler et al. 2018 also ``viscosityBoundary``, Peer et al. 2016 also
    ``viscoMaxIterOmega``, ``viscoMaxErrorOmega``; flat keys of scenes before 2.16 are read
    too)."""
    method, ns_key, max_iter = IMPLICIT_VISCOSITY[vm]
    nsw = f"{w}.{ns_key}"
    ns = rd.obj(m, ns_key, nsw)
    keys = {"viscosity", "viscoMaxIter", "viscoMaxError"}
    if vm in BOUNDARY_VISCOSITY:
        keys.add("viscosityBoundary")
    if vm in OMEGA_VISCOSITY:
        keys |= {"viscoMaxIterOmega", "viscoMaxErrorOmega"}
    rd.collect_unknown(ns, nsw, keys, set())
    src = nsw if ns else w
    nu = rd.num(ns, "viscosity", nsw, rd.num(m, "viscosity", w, 0.01, nonneg=True),
                nonneg=True)
    if vm in FACTOR_VISCOSITY and not nu <= 1.0:
        raise rd.error(f"{src}.viscosity", nu,
                       f"a dimensionless factor in [0, 1] ({VISCOSITY_METHODS[vm]})")
    out: dict[str, Any] = {"method": method, "coefficient": nu}
    fields = [("coefficient", "viscosity"), ("max_iterations", "viscoMaxIter"),
              ("max_error", "viscoMaxError")]
    if vm in BOUNDARY_VISCOSITY:
        out["boundary_coefficient"] = rd.num(
            ns, "viscosityBoundary", nsw,
            rd.num(m, "viscosityBoundary", w, 0.0, nonneg=True), nonneg=True)
        fields.append(("boundary_coefficient", "viscosityBoundary"))
    # bender2017's maxError is an absolute strain rate [1/s]; the CG solvers' a relative
    # residual below 1
    below_one = vm not in STRAIN_RATE_ERROR_VISCOSITY
    for suffix, ours in (("", ""), ("Omega", "_omega")) if vm in OMEGA_VISCOSITY else (("", ""),):
        its = rd.integer(ns, f"viscoMaxIter{suffix}", nsw,
                         rd.integer(m, f"viscoMaxIter{suffix}", w, max_iter))
        if its < 1:
            raise rd.error(f"{src}.viscoMaxIter{suffix}", its, "an integer >= 1")
        err = rd.num(ns, f"viscoMaxError{suffix}", nsw,
                     rd.num(m, f"viscoMaxError{suffix}", w, 0.01, positive=True),
                     positive=True)
        if below_one and not err < 1:
            raise rd.error(f"{src}.viscoMaxError{suffix}", err,
                           "a relative residual in (0, 1)")
        out[f"max_iterations{ours}"] = its
        out[f"max_error{ours}"] = err
        if ours:
            fields += [(f"max_iterations{ours}", f"viscoMaxIter{suffix}"),
                       (f"max_error{ours}", f"viscoMaxError{suffix}")]
    for ours, theirs in fields:
        rd.origin[f"materials[{k}].viscosity.{ours}"] = f"{src}.{theirs}"
    return out


def vorticity(rd: Reader, m: Mapping[str, Any], w: str, k: int) -> dict[str, Any]:
    """The material's vorticity model (``vorticityMethod``; 1: "Bender et al. 2017" block,
    2: "Vorticity confinement" block, or the flat keys of scenes before 2.16)."""
    vm = rd.integer(m, "vorticityMethod", w, 0)
    if vm == 0:
        return {"method": "none"}
    if vm not in VORTICITY_SUPPORTED:
        raise rd.unsupported(
            f"{w}.vorticityMethod",
            f"{vm} ({VORTICITY_METHODS.get(vm, 'unknown method')}) is not supported yet; "
            "supported: 0 (none), " + supported_list(VORTICITY_METHODS, VORTICITY_SUPPORTED),
        )
    method, ns_key = VORTICITY_SUPPORTED[vm]
    if method == "confinement":
        eps = _namespaced(rd, m, w, ns_key, {"vorticity": 0.01})
        _origin_of_block(rd, m, w, k, "vorticity", ns_key, {"coefficient": "vorticity"})
        return {"method": method, "coefficient": eps["vorticity"]}
    nsw = f"{w}.{ns_key}"
    ns = rd.obj(m, ns_key, nsw)
    keys = {"vorticity": 0.01, "viscosityOmega": 0.1, "inertiaInverse": 0.5}
    rd.collect_unknown(ns, nsw, set(keys), set())
    values = {}
    for key, default in keys.items():
        val = rd.num(m, key, w, default, nonneg=True)
        values[key] = rd.num(ns, key, nsw, val, nonneg=True)
    src = nsw if ns else w
    for ours, theirs in (("coefficient", "vorticity"), ("viscosity_omega", "viscosityOmega"),
                         ("inertia_inverse", "inertiaInverse")):
        rd.origin[f"materials[{k}].vorticity.{ours}"] = f"{src}.{theirs}"
    return {"method": method, "coefficient": values["vorticity"],
            "viscosity_omega": values["viscosityOmega"],
            "inertia_inverse": values["inertiaInverse"]}


def _namespaced(rd: Reader, m: Mapping[str, Any], w: str, ns_key: str,
                keys: dict[str, float], extra: set[str] | None = None) -> dict[str, float]:
    """Non-negative numbers ``keys`` (name -> SPlisHSPlasH default) of a method, read from its
    namespace block ``ns_key`` or, for scenes before 2.16, flat from the material; ``extra``:
    further keys of the block that the caller reads itself."""
    nsw = f"{w}.{ns_key}"
    ns = rd.obj(m, ns_key, nsw)
    rd.collect_unknown(ns, nsw, set(keys) | (extra or set()), set())
    values = {}
    for key, default in keys.items():
        val = rd.num(m, key, w, default, nonneg=True)
        values[key] = rd.num(ns, key, nsw, val, nonneg=True)
    return values


def _origin_of_block(rd: Reader, m: Mapping[str, Any], w: str, k: int, model: str, ns_key: str,
                     fields: dict[str, str]) -> None:
    """Record where the fields of ``materials[k].<model>`` came from: the block ``ns_key``, or
    the material itself (scenes before 2.16)."""
    src = f"{w}.{ns_key}" if m.get(ns_key) else w
    for ours, theirs in fields.items():
        rd.origin[f"materials[{k}].{model}.{ours}"] = f"{src}.{theirs}"


def surface_tension(rd: Reader, m: Mapping[str, Any], w: str, k: int) -> dict[str, Any]:
    """The material's surface tension model (``surfaceTensionMethod`` 1-3 with the
    ``surfaceTension``/``surfaceTensionBoundary`` numbers of the method's block; 4 with
    :func:`jeske2023`, 5 with :func:`zorilla2020`)."""
    sm = rd.integer(m, "surfaceTensionMethod", w, 0)
    if sm == 0:
        return {"method": "none"}
    if sm not in SURFACE_TENSION_SUPPORTED:
        names = OTHER_METHODS["surfaceTensionMethod"]
        raise rd.unsupported(
            f"{w}.surfaceTensionMethod",
            f"{sm} ({names.get(sm, 'unknown method')}) is not supported yet; supported: 0 "
            "(none), " + supported_list(names, SURFACE_TENSION_SUPPORTED),
        )
    method, ns_key = SURFACE_TENSION_SUPPORTED[sm]
    if method == "zorilla2020":
        return zorilla2020(rd, m, w, k, ns_key)
    if method == "jeske2023":
        return jeske2023(rd, m, w, k, ns_key)
    v = _namespaced(rd, m, w, ns_key, {"surfaceTension": 0.05,
                                       "surfaceTensionBoundary": 0.01})
    _origin_of_block(rd, m, w, k, "surface_tension", ns_key,
                     {"coefficient": "surfaceTension",
                      "boundary_coefficient": "surfaceTensionBoundary"})
    return {"method": method, "coefficient": v["surfaceTension"],
            "boundary_coefficient": v["surfaceTensionBoundary"]}


#: Zorilla, Ritter et al. 2020: SPlisHSPlasH key -> (sphkit field, default); enums by number
_ZR2020_NUMBERS = {
    "surfTZRCsd": ("samples_per_second", 10000.0), "surfTZRr-ratio": ("r_ratio", 0.8),
    "surfTZRtau": ("tau", 0.5), "surfTZRd": ("classifier_d", 12.0),
    "surfTZRd-offset": ("d_offset", 2.0), "surfTZRPcaMixNrm": ("pca_mix_normal", 0.75),
    "surfTZRPcaMixCur": ("pca_mix_curvature", 0.5),
}
_ZR2020_INTEGERS = {
    "surfTZRMCSamples": ("samples", -1), "surfTZRNeighLimit": ("neighbour_limit", 13),
    "surfTZRsmoothPasses": ("smooth_passes", 0),
}
_ZR2020_ENUMS = {
    "surfTZRversion": ("version", 1, ("v2019", "v2020")),
    "surfTZRsampling": ("sampling", 0, ("halton", "random")),
    "surfTZRnormal-mode": ("normal_mode", 1, ("pca", "mc", "mix")),
}


def zorilla2020(rd: Reader, m: Mapping[str, Any], w: str, k: int,
                ns_key: str) -> dict[str, Any]:
    """Zorilla, Ritter et al. 2020 (``surfaceTensionMethod`` 5): ``surfaceTension`` and the
    ``surfTZR*`` parameters of its block (defaults: ``reference/methods.md`` K4)."""
    nsw = f"{w}.{ns_key}"
    ns = rd.obj(m, ns_key, nsw)
    known = {"surfaceTension", "surfaceTensionBoundary", "surfTZRtemporalSmooth",
             *_ZR2020_NUMBERS, *_ZR2020_INTEGERS, *_ZR2020_ENUMS}
    rd.collect_unknown(ns, nsw, known, set())
    src = nsw if ns else w
    if legacy.flat(m):  # a scene before 2.16: the surfTZR* keys are the material's
        ns, nsw = {key: m[key] for key in known if key in m}, w
    coef = rd.num(ns, "surfaceTension", nsw, rd.num(m, "surfaceTension", w, 0.05, nonneg=True),
                  nonneg=True)
    rd.origin[f"materials[{k}].surface_tension.coefficient"] = f"{src}.surfaceTension"
    zr: dict[str, Any] = {}
    for key, (ours, default) in _ZR2020_NUMBERS.items():
        zr[ours] = rd.num(ns, key, nsw, default)
    for key, (ours, default) in _ZR2020_INTEGERS.items():
        zr[ours] = rd.integer(ns, key, nsw, default)
    for key, (ours, default, names) in _ZR2020_ENUMS.items():
        v = rd.integer(ns, key, nsw, default)
        if not 0 <= v < len(names):
            raise rd.error(f"{nsw}.{key}", v, "one of " + ", ".join(
                f"{n} ({nm})" for n, nm in enumerate(names)))
        zr[ours] = names[v]
    zr["temporal_smoothing"] = rd.flag(ns, "surfTZRtemporalSmooth", nsw, False)
    for key, (ours, _) in {**_ZR2020_NUMBERS, **_ZR2020_INTEGERS}.items():
        rd.origin[f"materials[{k}].surface_tension.zorilla2020.{ours}"] = f"{nsw}.{key}"
    for key, (ours, _, _) in _ZR2020_ENUMS.items():
        rd.origin[f"materials[{k}].surface_tension.zorilla2020.{ours}"] = f"{nsw}.{key}"
    rd.origin[f"materials[{k}].surface_tension.zorilla2020.temporal_smoothing"] = (
        f"{nsw}.surfTZRtemporalSmooth")
    return {"method": "zorilla2020", "coefficient": coef, "boundary_coefficient": 0.0,
            "zorilla2020": zr}


def jeske2023(rd: Reader, m: Mapping[str, Any], w: str, k: int,
              ns_key: str) -> dict[str, Any]:
    """Jeske et al. 2023 (``surfaceTensionMethod`` 4): ``surfaceTension``,
    ``surfaceTensionBoundary`` and the solver keys of its block (defaults:
    ``reference/methods.md`` K5)."""
    v = _namespaced(rd, m, w, ns_key, {"surfaceTension": 0.05, "surfaceTensionBoundary": 0.01,
                                       **{key: d for key, (_, d) in JESKE2023_FIELDS.items()}},
                    extra={"surfaceTensionMaxIter"})
    nsw = f"{w}.{ns_key}"
    ns = rd.obj(m, ns_key, nsw)
    it = rd.integer(ns, "surfaceTensionMaxIter", nsw, rd.integer(m, "surfaceTensionMaxIter", w,
                                                                 100))
    _origin_of_block(rd, m, w, k, "surface_tension", ns_key,
                     {"coefficient": "surfaceTension",
                      "boundary_coefficient": "surfaceTensionBoundary",
                      "jeske2023.max_iterations": "surfaceTensionMaxIter",
                      **{f"jeske2023.{ours}": key for key, (ours, _) in JESKE2023_FIELDS.items()}})
    return {"method": "jeske2023", "coefficient": v["surfaceTension"],
            "boundary_coefficient": v["surfaceTensionBoundary"],
            "jeske2023": {"max_iterations": it,
                          **{ours: v[key] for key, (ours, _) in JESKE2023_FIELDS.items()}}}


def drag(rd: Reader, m: Mapping[str, Any], w: str, k: int) -> dict[str, Any]:
    """The material's drag model (``dragMethod`` 1-2 with the ``drag`` number of the
    method's block)."""
    dm = rd.integer(m, "dragMethod", w, 0)
    if dm == 0:
        return {"method": "none"}
    if dm not in DRAG_SUPPORTED:
        raise rd.unsupported(
            f"{w}.dragMethod",
            f"{dm} (unknown method) is not supported; supported: 0 (none), "
            + supported_list(OTHER_METHODS["dragMethod"], DRAG_SUPPORTED),
        )
    method, ns_key = DRAG_SUPPORTED[dm]
    v = _namespaced(rd, m, w, ns_key, {"drag": 0.01})
    _origin_of_block(rd, m, w, k, "drag", ns_key, {"coefficient": "drag"})
    return {"method": method, "coefficient": v["drag"]}



#: the elasticity keys that scenes before 2.16 write flat in the material (methods 1-3; Kee et
#: al. 2023 came with the namespaces)
_FLAT_ELASTICITY = {"youngsModulus", "poissonsRatio", "alpha", "fixedBoxMin", "fixedBoxMax",
                    *(key for em in (1, 2, 3) for key in ELASTICITY_KEYS[em])}


def _flat_elasticity(m: Mapping[str, Any]) -> bool:
    """Whether the material is an elastic solid of a scene before 2.16: a supported
    ``elasticityMethod`` and its parameters flat in the material, no block of the method."""
    em = m.get("elasticityMethod")
    if isinstance(em, bool) or em not in (1, 2, 3) or em not in ELASTICITY_SUPPORTED:
        return False
    return ELASTICITY_SUPPORTED[em][1] not in m and any(key in m for key in _FLAT_ELASTICITY)


def elasticity(rd: Reader, m: Mapping[str, Any], w: str, k: int) -> dict[str, Any]:
    """The material's elasticity (``elasticityMethod``; its block, e.g. ``"Becker et al.
    2009"``: ``youngsModulus``, ``poissonsRatio``, ``alpha``, ``fixedBoxMin``/``fixedBoxMax``,
    the implicit models' ``maxNeighbors`` and iteration control; in scenes before 2.16 the same
    keys flat in the material)."""
    em = rd.integer(m, "elasticityMethod", w, 0)
    if em == 0:
        return {"method": "none"}
    names = OTHER_METHODS["elasticityMethod"]
    if em not in ELASTICITY_SUPPORTED:
        raise rd.unsupported(
            f"{w}.elasticityMethod",
            f"{em} ({names.get(em, 'unknown method')}) is not supported yet; supported: 0 "
            "(none), " + supported_list(names, ELASTICITY_SUPPORTED),
        )
    method, ns_key = ELASTICITY_SUPPORTED[em]
    nsw = f"{w}.{ns_key}"
    ns = rd.obj(m, ns_key, nsw)
    if _flat_elasticity(m):  # a scene before 2.16: the block's keys are the material's
        ns, nsw = {key: m[key] for key in _FLAT_ELASTICITY if key in m}, w
    extra = ELASTICITY_KEYS[em]
    rd.collect_unknown(ns, nsw, {"youngsModulus", "poissonsRatio", "alpha", "fixedBoxMin",
                                 "fixedBoxMax", *extra}, set())
    out: dict[str, Any] = {"method": method}
    # Kugelstadt 2021's and Kee 2023's constructors override the base's default E 1e5 with 5e6
    # (Kee 2023: and nu 0.3 with 0.45)
    e_default = 5e6 if em in (3, 4) else 1e5
    fields = {"youngs_modulus": ("youngsModulus", e_default),
              "poisson_ratio": ("poissonsRatio", 0.45 if em == 4 else 0.3),
              "alpha": ("alpha", 0.0)}
    if "elasticityMaxIter" in extra:
        fields["max_error"] = ("elasticityMaxError", 1e-4)
    if "volumeMaxError" in extra:
        fields["max_error"] = ("volumeMaxError", 1e-4)
    for ours, (theirs, default) in fields.items():
        out[ours] = rd.num(ns, theirs, nsw, default)
        rd.origin[f"materials[{k}].elasticity.{ours}"] = f"{nsw}.{theirs}"
    for ours, theirs, default in (("max_neighbors", "maxNeighbors", -1),
                                  ("max_iterations", "elasticityMaxIter", 100),
                                  ("max_iterations", "volumeMaxIter", 100)):
        if theirs in extra:
            out[ours] = rd.integer(ns, theirs, nsw, default)
            rd.origin[f"materials[{k}].elasticity.{ours}"] = f"{nsw}.{theirs}"
    boxes = []
    pairs = [("fixedBoxMin", "fixedBoxMax")] + ([("fixedBox2Min", "fixedBox2Max")] if em == 4
                                                  else [])
    for lo, hi in pairs:
        if (lo in ns) != (hi in ns):
            given = lo if lo in ns else hi
            raise rd.error(f"{nsw}.{given}", ns[given], f"{lo} and {hi} together")
        if lo in ns:
            box = {"min": rd.vec3(ns, lo, nsw, [0.0] * 3), "max": rd.vec3(ns, hi, nsw, [0.0] * 3)}
            # Kee 2023: an all-zero box is no box (its second box is optional)
            if em != 4 or any(box["min"]) or any(box["max"]):
                boxes.append(box)
    if boxes:
        out["fixed_boxes"] = boxes
        rd.origin[f"materials[{k}].elasticity.fixed_boxes"] = f"{nsw}.fixedBoxMin"
    if em == 4:
        out.update(_kee2023(rd, ns, nsw, k))
    rd.origin[f"materials[{k}].elasticity"] = nsw
    return out


def _kee2023(rd: Reader, ns: Mapping[str, Any], nsw: str, k: int) -> dict[str, Any]:
    """Kee et al. 2023's solver parameters (``Elasticity_Kee2023.cpp``'s names and defaults)."""
    out: dict[str, Any] = {}
    for theirs, (ours, default, kind) in KEE2023_FIELDS.items():
        out[ours] = (rd.integer(ns, theirs, nsw, default) if kind == "int"
                     else rd.num(ns, theirs, nsw, default))
        rd.origin[f"materials[{k}].elasticity.{ours}"] = f"{nsw}.{theirs}"
    for theirs, ours, names, default in (("solverType", "solver", KEE2023_SOLVERS, 1),
                                         ("materialType", "material_model", KEE2023_MATERIALS,
                                          1)):
        v = rd.integer(ns, theirs, nsw, default)
        if v not in names:
            raise rd.error(f"{nsw}.{theirs}", ns[theirs],
                           " or ".join(f"{n} ({name})" for n, name in names.items()))
        out[ours] = names[v]
        rd.origin[f"materials[{k}].elasticity.{ours}"] = f"{nsw}.{theirs}"
    out["line_search"] = rd.flag(ns, "useLineSearch", nsw, True)
    rd.origin[f"materials[{k}].elasticity.line_search"] = f"{nsw}.useLineSearch"
    return out
