"""Method numbers of SPlisHSPlasH scene files written before 2.16 (flat material parameters).

SPlisHSPlasH renumbered two of a material's method enums before 2.16 moved every method's
parameters into a block named after the method (``"Weiler et al. 2018": {...}``; its
Changelog.txt):

* **2.12.0** took XSPH out of ``viscosityMethod`` (it became the separate ``xsph`` /
  ``xsphBoundary`` keys): before, 2 was XSPH, 3 Bender and Koschier 2017, 4 Peer et al. 2015,
  5 Peer et al. 2016, 6 Takahashi et al. 2015, 7 Weiler et al. 2018; from 2.12 each of 3-7 is
  one lower (``NonPressureForceRegistration.cpp`` before and after).
* **2.13.0** inserted Jeske et al. 2023 as ``surfaceTensionMethod`` 4; Zorilla, Ritter et al.
  2020 moved from 4 to 5.

A scene file carries no version. The translator reads numbers as 2.13-2.16 number them
(:mod:`sphkit.scene.splishsplash.methods`); :func:`renumber` maps a material written in the
flat form (no method block) to that numbering where the file itself shows that it is older,
and notes the number otherwise when it meant another method before: ``viscosityMethod`` 7
exists only before 2.12 (Weiler et al. 2018); a key that only one of a number's two methods
reads tells which (the implicit solvers' ``viscoMaxIter``: 2 is Bender and Koschier 2017, not
XSPH; ``viscoMaxIterOmega``: 4 is Peer et al. 2016 in 2.12's numbering, 5 in the older one;
``viscosityBoundary``: 6 is Weiler et al. 2018, not Takahashi et al. 2015); flat ``xsph`` keys
show 2.12 or later; ``surfaceTensionMethod`` 4 with Zorilla and Ritter's ``surfTZR*`` keys is
their method as 2.12 and earlier numbered it. Materials with a method block are 2.16's and are
left alone.

Before the ``Materials`` array (SPlisHSPlasH's scenes until 2020, e.g. its repository at
ffe47dc), each fluid's parameters were a top-level object named by the fluid's id (``"Fluid":
{"viscosity": 0.01, ...}``, read by ``readParameterObject(model->getId(), model)``):
:func:`material_entries` reads those as materials; before that (2018, SPlisHSPlasH at
09c39a4: one fluid) its parameters sat in ``Configuration`` (:data:`CONFIG_MATERIAL_KEYS`).
Emitters of 2019 (0d1656a) had a ``direction``, a velocity vector and ``emitsPerSecond`` instead
of a rotation and a speed: :func:`emitter` rewrites them. Before October 2019 (ee26ef3)
boundary particles were the only boundary method and ``boundaryHandlingMethod`` did not exist
(since, its default is volume maps): :func:`particle_walls` tells such a scene.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from sphkit.scene.splishsplash.methods import (
    JESKE2023_FIELDS,
    MATERIAL_NAMESPACES,
    SIMULATION_METHODS,
    VISCOSITY_METHODS,
)
from sphkit.scene.splishsplash.reader import Reader

#: ``viscosityMethod`` before 2.12 -> its number in 2.12 and later (2, XSPH, has none: later
#: files give its coefficient as ``xsph``)
VISCOSITY_BEFORE_2_12 = {3: 2, 4: 3, 5: 4, 6: 5, 7: 6}
#: the names of the numbers before 2.12
VISCOSITY_NAMES_BEFORE_2_12 = {2: "XSPH", **{old: VISCOSITY_METHODS[new]
                                              for old, new in VISCOSITY_BEFORE_2_12.items()}}
#: flat keys that only the method of a number in 2.12's numbering reads, not the older method of
#: the same number
_SIGNS_2_12 = {2: {"viscoMaxIter", "viscoMaxError"},
               4: {"viscoMaxIterOmega", "viscoMaxErrorOmega"}, 6: {"viscosityBoundary"}}
#: flat keys that only the method of a number before 2.12 reads (5: Peer et al. 2016, not
#: Takahashi et al. 2015)
_SIGNS_BEFORE = {5: {"viscoMaxIterOmega", "viscoMaxErrorOmega"}}
#: ``surfaceTensionMethod`` of Zorilla, Ritter et al. 2020 before 2.13, and since
ZORILLA_BEFORE_2_13, ZORILLA = 4, 5
#: Jeske et al. 2023's own flat keys (beside surfaceTension and surfaceTensionBoundary)
JESKE_KEYS = {"surfaceTensionMaxIter", *JESKE2023_FIELDS}
#: blocks of 2.16's form a material may hold (a material with one is 2.16's)
_BLOCKS = MATERIAL_NAMESPACES | {"Standard viscosity", "XSPH"}


def flat(m: Mapping[str, Any]) -> bool:
    """Whether the material is written in the form before 2.16: no method block."""
    return not any(key in m for key in _BLOCKS)


def since_2_16(data: Mapping[str, Any]) -> bool:
    """Whether the scene shows 2.16's form anywhere: a solver block in ``Configuration``
    (``"DFSPH": {...}``) or a method block in a material; then a material without a block (its
    methods at their defaults) is 2.16's too and its numbers are read as they are."""
    cfg = data.get("Configuration")
    mats = data.get("Materials")
    return ((isinstance(cfg, Mapping) and any(key in cfg for key in SIMULATION_METHODS.values()))
            or (isinstance(mats, list)
                and any(isinstance(m, Mapping) and not flat(m) for m in mats)))


def _block(vm: int) -> str:
    return "Standard viscosity" if vm == 1 else VISCOSITY_METHODS[vm]


def _viscosity(m: Mapping[str, Any], out: dict[str, Any], w: str, notes: list[str]) -> None:
    vm = m.get("viscosityMethod")
    if isinstance(vm, bool) or not isinstance(vm, int) or vm not in VISCOSITY_NAMES_BEFORE_2_12:
        return
    keys = set(m)
    later = bool(keys & ({"xsph", "xsphBoundary"} | _SIGNS_2_12.get(vm, set())))
    if vm == 7 or (not later and keys & _SIGNS_BEFORE.get(vm, set())):
        out["viscosityMethod"] = VISCOSITY_BEFORE_2_12[vm]
        notes.append(f"{w}.viscosityMethod: {vm} read as SPlisHSPlasH numbered it before 2.12 "
                     f"({VISCOSITY_NAMES_BEFORE_2_12[vm]}; 2.12 and later: "
                     f"{VISCOSITY_BEFORE_2_12[vm]})")
    elif not later:
        now = f"now {VISCOSITY_BEFORE_2_12[vm]}" if vm in VISCOSITY_BEFORE_2_12 else "now xsph"
        notes.append(f"{w}.viscosityMethod: {vm} read as {VISCOSITY_METHODS[vm]}, as "
                     f"SPlisHSPlasH 2.12 and later number it; before 2.12, {vm} was "
                     f"{VISCOSITY_NAMES_BEFORE_2_12[vm]} ({now}). Parameters in the method's "
                     f"block (\"{_block(vm)}\", 2.16's form) silence this note")


#: 2.12's numbers of the two models whose ``viscosity`` was a dynamic viscosity [Pa s] before
#: 2.10 (Viscosity_Takahashi2015.cpp, Viscosity_Weiler2018.cpp at cb45119: ``mu = viscosity``,
#: since ``viscosity * density0``)
_DYNAMIC_BEFORE_2_10 = {5: "Takahashi et al. 2015", 6: "Weiler et al. 2018"}
#: a kinematic viscosity above this [m^2/s] in such a model is noted as likely dynamic
_LIKELY_DYNAMIC = 100.0


def _dynamic_note(m: Mapping[str, Any], vm: Any, w: str, notes: list[str]) -> None:
    name = _DYNAMIC_BEFORE_2_10.get(vm) if isinstance(vm, int) else None
    nu = m.get("viscosity")
    if (name and isinstance(nu, (int, float)) and not isinstance(nu, bool)
            and nu > _LIKELY_DYNAMIC):
        notes.append(f"{w}.viscosity: {nu:g} read as a kinematic viscosity [m^2/s] ({name}, "
                     "as SPlisHSPlasH 2.10 and later read it); before 2.10 it was the dynamic "
                     f"viscosity [Pa s], i.e. {nu:g} / density0 m^2/s (SPlisHSPlasH's own scenes "
                     "went from 5000 to 5): divide it by the rest density if the file is older")


def _surface_tension(m: Mapping[str, Any], out: dict[str, Any], w: str,
                     notes: list[str]) -> None:
    sm = m.get("surfaceTensionMethod")
    if isinstance(sm, bool) or sm != ZORILLA_BEFORE_2_13:
        return
    if any(isinstance(key, str) and key.startswith("surfTZR") for key in m):
        out["surfaceTensionMethod"] = ZORILLA
        notes.append(f"{w}.surfaceTensionMethod: 4 with surfTZR* parameters read as "
                     "SPlisHSPlasH numbered it before 2.13 (Zorilla, Ritter et al. 2020; 2.13 "
                     "and later: 5)")
    elif not set(m) & JESKE_KEYS:
        notes.append(f"{w}.surfaceTensionMethod: 4 read as Jeske et al. 2023, as SPlisHSPlasH "
                     "2.13 and later number it; before 2.13, 4 was Zorilla, Ritter et al. 2020 "
                     "(now 5). Parameters in the method's block (\"Jeske et al. 2023\", 2.16's "
                     "form) silence this note")


def renumber(m: Mapping[str, Any], w: str, notes: list[str],
             modern: bool = False) -> dict[str, Any]:
    """The material ``m`` (field path ``w``) with its method numbers in the numbering of 2.13
    and later: a copy, changed only for a flat material whose file shows an older numbering
    (module docstring); a note in ``notes`` for each number changed, and for each number read
    in the later numbering that meant another method before, where nothing in the file says
    which."""
    out = dict(m)
    if flat(m) and not modern:  # (modern: the scene is 2.16's, :func:`since_2_16`)
        _viscosity(m, out, w, notes)
        _dynamic_note(m, out.get("viscosityMethod"), w, notes)
        _surface_tension(m, out, w, notes)
    return out


#: a fluid's keys that scenes of 2018 (one fluid) kept in ``Configuration``
CONFIG_MATERIAL_KEYS = {
    "density0", "viscosityMethod", "viscosity", "viscosityBoundary", "viscoMaxIter",
    "viscoMaxError", "viscoMaxIterOmega", "viscoMaxErrorOmega", "surfaceTensionMethod",
    "surfaceTension", "surfaceTensionBoundary", "vorticityMethod", "vorticity",
    "viscosityOmega", "inertiaInverse", "dragMethod", "drag", "maxEmitterParticles",
    "emitterReuseParticles", "emitterBoxMin", "emitterBoxMax",
}
#: top-level keys that are never a fluid's parameter object
_RESERVED = {"Configuration", "Simulation", "Materials", "FluidBlocks", "FluidModels",
             "RigidBodies", "Emitters", "AnimationFields"}


def fluid_ids(data: Mapping[str, Any]) -> list[str]:
    """The fluid ids a scene's ``FluidBlocks``, ``FluidModels`` and ``Emitters`` name (default
    ``"Fluid"``), in order of first use."""
    ids: list[str] = []
    for key in ("FluidBlocks", "FluidModels", "Emitters"):
        entries = data.get(key)
        for e in entries if isinstance(entries, list) else []:
            fid = e.get("id", "Fluid") if isinstance(e, Mapping) else None
            if isinstance(fid, str) and fid not in ids:
                ids.append(fid)
    return ids


def material_keys(data: Mapping[str, Any]) -> list[str]:
    """The top-level keys that are materials in a scene written before the ``Materials`` array:
    fluid ids (:func:`fluid_ids`) with an object of their own; none when the scene has the
    array."""
    if "Materials" in data:
        return []
    return [fid for fid in fluid_ids(data)
            if fid not in _RESERVED and isinstance(data.get(fid), Mapping)]


def configuration_material_keys(data: Mapping[str, Any]) -> set[str]:
    """The keys of ``Configuration`` that are the fluid's in a scene of 2018 (no ``Materials``
    array, no top-level fluid objects): :data:`CONFIG_MATERIAL_KEYS` present there."""
    cfg = data.get("Configuration")
    if "Materials" in data or material_keys(data) or not isinstance(cfg, Mapping):
        return set()
    return {key for key in CONFIG_MATERIAL_KEYS if key in cfg}


def material_entries(data: Mapping[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """The scene's materials as (field path, object with ``id``): ``Materials[k]``; in a scene
    before that array the top-level object of each fluid id (:func:`material_keys`); before
    those, the fluid keys of ``Configuration`` as the material ``Fluid``."""
    if "Materials" in data:
        entries = data["Materials"] or []
        return [(f"Materials[{k}]", dict(m)) for k, m in enumerate(entries)]
    keys = material_keys(data)
    if keys:
        return [(fid, {"id": fid, **data[fid]}) for fid in keys]
    own = configuration_material_keys(data)
    if own:
        cfg = data["Configuration"]
        return [("Configuration", {"id": "Fluid", **{key: cfg[key] for key in sorted(own)}})]
    return []


def emitter(rd: Reader, e: Mapping[str, Any], w: str, r: float) -> dict[str, Any]:
    """An emitter of a scene before 2020 (``direction``, ``velocity`` as a vector,
    ``emitsPerSecond``; ``Emitter.cpp`` at 0d1656a) in the later form: a rotation taking e_x to
    the direction with the layer's width along R e_z and its height along R e_y (the older
    emitter's ``dir x v0`` and ``dir x (dir x v0)``, v0 = e_x, or e_y for a direction along
    x), and the speed along it. The emission rate follows the speed (a layer each 2r, as since
    2020); a differing ``emitsPerSecond`` is noted (``rd.notes``). Other emitters are returned
    unchanged. Bad values raise the reader's errors naming the field; so do a direction of zero
    length and a velocity that is not along the direction (the later emitters have none)."""
    old = "direction" in e or "emitsPerSecond" in e or isinstance(e.get("velocity"), list)
    if not old:
        return dict(e)
    out = {k: v for k, v in e.items() if k not in ("direction", "velocity", "emitsPerSecond")}
    d = np.asarray(rd.vec3(e, "direction", w, [1.0, 0.0, 0.0]))
    if not np.linalg.norm(d) > 0.0:
        raise rd.error(f"{w}.direction", d.tolist(), "a direction of non-zero length")
    d /= np.linalg.norm(d)
    v = (np.asarray(rd.vec3(e, "velocity", w, [1.0, 0.0, 0.0]))
         if isinstance(e.get("velocity"), list) else rd.num(e, "velocity", w, 1.0) * d)
    speed = float(v @ d)
    if not speed > 0.0 or np.linalg.norm(v - speed * d) > 1e-9 * max(1.0, abs(speed)):
        raise rd.error(f"{w}.velocity", e.get("velocity"), f"a velocity along the direction "
                       f"{d.tolist()} (an emitter emits along its direction since 2020)")
    v0 = np.array([0.0, 1.0, 0.0]) if abs(d[0]) > 0.999 else np.array([1.0, 0.0, 0.0])
    a1 = np.cross(d, v0)
    a1 /= np.linalg.norm(a1)
    a2 = np.cross(d, a1)
    rot = np.column_stack([d, -a2, a1])  # R e_x = d, R e_y = -a2, R e_z = a1 (proper)
    from scipy.spatial.transform import Rotation

    rotvec = Rotation.from_matrix(rot).as_rotvec()
    angle = float(np.linalg.norm(rotvec))
    out.update(velocity=speed, rotationAngle=angle,
               rotationAxis=(rotvec / angle).tolist() if angle > 0.0 else [0.0, 0.0, 1.0])
    rate = rd.num(e, "emitsPerSecond", w, 0.0, nonneg=True)
    if rate > 0 and abs(rate - speed / (2.0 * r)) > 1e-6 * rate:
        rd.notes.append(f"{w}.emitsPerSecond: {rate:g} layers per second; sphkit emits a layer "
                        f"each time the last one has moved 2r, {speed / (2.0 * r):.4g} per "
                        f"second at velocity {speed:g} m/s (as SPlisHSPlasH since 2020)")
    return out


#: RigidBodies keys that only maps read (absent from scenes written for boundary particles)
_MAP_KEYS = ("mapInvert", "mapThickness", "mapResolution", "mapFile")


def particle_walls(data: Mapping[str, Any]) -> bool:
    """Whether a scene without ``boundaryHandlingMethod`` was written before October 2019, when
    boundary particles were the only method: a wall (``isWall``) among its rigid bodies and no
    map key (``mapInvert``, ...) in any of them. Its walls are then boundary particles, a wall
    holding the fluid inside it, as SPlisHSPlasH then ran it (since, a missing
    ``boundaryHandlingMethod`` means volume maps, and a wall without ``mapInvert`` is solid)."""
    cfg = data.get("Configuration")
    bodies = data.get("RigidBodies")
    if not isinstance(bodies, list) or (isinstance(cfg, Mapping)
                                        and "boundaryHandlingMethod" in cfg):
        return False
    bodies = [b for b in bodies if isinstance(b, Mapping)]
    return (any(b.get("isWall") is True for b in bodies)
            and not any(key in b for b in bodies for key in _MAP_KEYS))
