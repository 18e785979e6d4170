"""A SPlisHSPlasH scene -> sphkit's scene model: the top level of the translation.

:func:`from_splishsplash` reads the top-level blocks (``Configuration``, ``Materials``,
``FluidBlocks``, ``FluidModels``, ``Emitters``, ``RigidBodies``, ``AnimationFields``, the hinge
joints) with :mod:`~sphkit.scene.splishsplash.configuration`,
:mod:`~sphkit.scene.splishsplash.materials`, :mod:`~sphkit.scene.splishsplash.objects` and
:mod:`~sphkit.scene.splishsplash.joints`, rejects the blocks sphkit does not have (the other
joints and motors), validates the result as a :class:`~sphkit.scene.schema.Scene` (an
error names SPlisHSPlasH's field next to sphkit's) and reports the ignored fields and notes as
``UserWarning``. The format and its defaults are described in :mod:`sphkit.scene.splishsplash`.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from sphkit.scene.schema import Scene, SceneError, format_validation_error
from sphkit.scene.splishsplash import legacy
from sphkit.scene.splishsplash.configuration import configuration
from sphkit.scene.splishsplash.joints import JOINT_ARRAYS, joints
from sphkit.scene.splishsplash.materials import materials
from sphkit.scene.splishsplash.objects import (
    animation_fields,
    emitters,
    fluid_blocks,
    fluid_mesh_models,
    fluid_models,
    rigid_bodies,
)
from sphkit.scene.splishsplash.reader import Reader

_SPH_ARRAYS = ("Materials", "FluidBlocks", "RigidBodies", "FluidModels", "Emitters",
               "AnimationFields", *JOINT_ARRAYS)
_SPH_UNSUPPORTED_ARRAYS = {
    # joints of PositionBasedDynamics; HingeJoints and TargetVelocityMotorHingeJoints are
    # translated (sphkit.scene.splishsplash.joints)
    "BallJoints": "joints between dynamic rigid bodies",
    "BallOnLineJoints": "joints between dynamic rigid bodies",
    "UniversalJoints": "joints between dynamic rigid bodies",
    "SliderJoints": "joints between dynamic rigid bodies",
    "TargetAngleMotorHingeJoints": "motors on dynamic rigid bodies",
    "TargetPositionMotorSliderJoints": "motors on dynamic rigid bodies",
    "TargetVelocityMotorSliderJoints": "motors on dynamic rigid bodies",
    "DamperJoints": "joints between dynamic rigid bodies",
    "RigidBodyParticleBallJoints": "joints between dynamic rigid bodies",
    "RigidBodySprings": "springs between dynamic rigid bodies",
    "DistanceJoints": "joints between dynamic rigid bodies",
}
_SPH_TOP_QUIET = {"Simulation"}  # PositionBasedDynamics settings, only used by dynamic bodies
#: PositionBasedDynamics' contactTolerance when the Simulation block leaves it out [m] (its
#: CollisionDetection's default): the gap its contacts keep between a dynamic body and a surface
PBD_TOLERANCE = 0.01


def is_splishsplash(data: Mapping[str, Any]) -> bool:
    """Whether a scene dict is in SPlisHSPlasH's format (capitalized top-level blocks)."""
    return any(k in data for k in ("Configuration", *_SPH_ARRAYS, *_SPH_UNSUPPORTED_ARRAYS))


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
    tr = Reader(data, path)
    scene = validate(tr, translate(tr))
    scene._origins = dict(tr.origin)
    if tr.unknown:
        names = ", ".join(tr.unknown[:20]) + (f", ... ({len(tr.unknown) - 20} more)"
                                              if len(tr.unknown) > 20 else "")
        warnings.warn(
            f"{tr.label}: ignored {len(tr.unknown)} field(s) that sphkit does not know or "
            f"support yet: {names}",
            UserWarning,
            stacklevel=2,
        )
    for note in tr.notes:
        warnings.warn(f"{tr.label}: {note}", UserWarning, stacklevel=2)
    return scene


def translate(rd: Reader) -> dict[str, Any]:
    """The scene ``rd.data`` as a dict of sphkit's scene fields (not validated yet)."""
    data = rd.data
    for key, what in _SPH_UNSUPPORTED_ARRAYS.items():
        v = data.get(key)
        if v:
            n = len(v) if isinstance(v, list) else 1
            raise rd.unsupported(
                key, f"{n} {'entry' if n == 1 else 'entries'}; {what} are not supported yet"
            )
    rd.collect_unknown(
        data, "", {"Configuration", *_SPH_ARRAYS, *_SPH_UNSUPPORTED_ARRAYS,
                   *legacy.material_keys(data)}, _SPH_TOP_QUIET
    )

    cfg = rd.obj(data, "Configuration", "Configuration")
    rigid = rd.array("RigidBodies")
    # emitters come with a housing of boundary particles: the boundary method matters
    own = legacy.configuration_material_keys(data)  # a scene of 2018: the fluid's keys
    if own:
        rd.notes.append(f"Configuration.{', '.join(sorted(own))}: read as the parameters of the "
                        "fluid \"Fluid\" (SPlisHSPlasH's scenes of 2018 kept their one fluid's "
                        "parameters in Configuration)")
    config, output = configuration(rd, cfg, bool(rigid) or bool(rd.array("Emitters")), own)
    dim = config["dim"]
    r = config["particle_radius"]
    mats = materials(rd)
    blocks = fluid_blocks(rd, dim, r)
    fluid_files = fluid_models(rd)
    ids = [m["id"] for m in mats]
    for b in [*blocks, *fluid_files]:  # a fluid without a material entry gets the defaults
        if b["material"] not in ids:
            ids.append(b["material"])
            mats.append({"id": b["material"]})
    fluid_meshes = fluid_mesh_models(rd, dim)
    for b in fluid_meshes:
        if b["material"] not in ids:
            ids.append(b["material"])
            mats.append({"id": b["material"]})
    if not mats:
        mats.append({"id": "Fluid"})
    meshes = rigid_bodies(rd, rigid, config["boundary"]["method"] == "akinci2012")
    if any(m.get("dynamic") for m in meshes):  # PositionBasedDynamics' contacts: its skin
        sim = rd.obj(data, "Simulation", "Simulation")
        config["contact_tolerance"] = rd.num(sim, "contactTolerance",
                                             "Simulation", PBD_TOLERANCE,
                                             nonneg=True)
        rd.origin["configuration.contact_tolerance"] = "Simulation.contactTolerance"
    emits = emitters(rd, dim, r)
    for e in emits:
        if e["material"] not in [m["id"] for m in mats]:
            mats.append({"id": e["material"]})

    scene: dict[str, Any] = {
        "name": rd.path.stem if rd.path else "splishsplash",
        "description": "translated from the SPlisHSPlasH scene "
        + (rd.path.name if rd.path else "(dict)"),
        "configuration": config,
        "materials": mats,
        "fluid_blocks": blocks,
        "meshes": meshes,
    }
    if fluid_files:
        scene["fluid_files"] = fluid_files
    if fluid_meshes:
        scene["fluid_meshes"] = fluid_meshes
    if emits:
        scene["emitters"] = emits
    jts = joints(rd, rigid)
    if jts:
        scene["joints"] = jts
    anims = animation_fields(rd)
    if anims:
        scene["animation_fields"] = anims
    if output:
        scene["output"] = output
    if rd.path is not None:
        scene["source"] = str(rd.path.resolve())
    return scene


#: the field a check across the scene's fields names first ("Value error, joints[0].axis ...")
_CHECK = re.compile(r"Value error, ([A-Za-z_][\w\[\].]*)")


def validate(rd: Reader, scene: dict[str, Any]) -> Scene:
    """The translated ``scene`` validated; errors name SPlisHSPlasH's field paths too."""
    try:
        return Scene.model_validate(scene)
    except ValidationError as err:
        lines = []
        for line in format_validation_error(err).splitlines():
            path, sep, rest = line.partition(": ")
            origin = rd.origin_of(path)
            inner = _CHECK.search(rest) if not origin else None
            if inner and rd.origin_of(inner.group(1)):  # a check across fields names its own
                path, rest = inner.group(1), rest[inner.end(1):].lstrip(": ")
                origin = rd.origin_of(path)
            if origin:
                lines.append(f"{origin} (sphkit {path}): {rest}")
            else:
                lines.append(line)
        raise SceneError(
            f"{rd.label}: invalid after translation to sphkit:\n" + "\n".join(lines)
        ) from None
