"""The objects of a SPlisHSPlasH scene: fluid blocks, fluid models, emitters and rigid bodies.

``FluidBlocks`` become lattice blocks at SPlisHSPlasH's particle positions, ``FluidModels``
particle files (BGEO, PLY, VTK) or closed meshes to fill with fluid, ``Emitters`` sphkit's
emitters (:mod:`sphkit.world.emitters`), ``RigidBodies`` static walls or dynamic bodies given by
a mesh
(:class:`~sphkit.scene.schema.MeshBoundary`). Paths are relative to the scene file. The
placement rules (SPlisHSPlasH's ``createFluidBlocks``, ``initFluidData``, ``createEmitters``,
``StaticBoundarySimulator``) are described in :mod:`sphkit.scene.splishsplash`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from sphkit.scene.paths import check_particle_file
from sphkit.scene.splishsplash import legacy
from sphkit.scene.splishsplash.reader import Reader

#: a FluidModels particleFile with these suffixes is a mesh to fill (``.ply`` is a particle file)
_FILL_SUFFIXES = (".obj", ".stl", ".off")
#: sphkit's lattices (scene ``fluid_blocks[].lattice``) of SPlisHSPlasH's denseMode 1 and 2
_DENSE_MODES = {1: "layered", 2: "close_packed"}
_RIGID_QUIET = {
    "color", "isWall", "samplingMode", "tubeMapOrder",
    # PositionBasedDynamics settings, only used by dynamic bodies
    "density", "friction", "restitution", "collisionObjectType", "collisionObjectScale",
    "invertSDF", "id",
}
_BLOCK_QUIET = {"visMesh"}


def fluid_blocks(rd: Reader, dim: int, r: float) -> list[dict[str, Any]]:
    """``FluidBlocks`` -> ``fluid_blocks`` holding SPlisHSPlasH's particle positions (a block
    with no particle on an axis is left out with a note)."""
    out = []
    for k, b in enumerate(rd.array("FluidBlocks")):
        w = f"FluidBlocks[{k}]"
        known = {
            "id", "start", "end", "translation", "scale", "denseMode", "initialVelocity",
            "initialAngularVelocity",
        }
        rd.collect_unknown(b, w, known, _BLOCK_QUIET)
        for key in ("start", "end"):
            if b.get(key) is None:
                raise rd.error(f"{w}.{key}", None, "a list of 3 finite numbers")
        start = rd.vec3(b, "start", w, [0.0, 0.0, 0.0])
        end = rd.vec3(b, "end", w, [0.0, 0.0, 0.0])
        translation = rd.vec3(b, "translation", w, [0.0, 0.0, 0.0])
        scale = rd.vec3(b, "scale", w, [1.0, 1.0, 1.0])
        mode = rd.integer(b, "denseMode", w, 0)
        if mode not in (0, 1, 2):
            raise rd.error(f"{w}.denseMode", mode,
                           "0 (regular lattice), 1 (layered) or 2 (close packed)")
        velocity = rd.vec3(b, "initialVelocity", w, [0.0, 0.0, 0.0])
        omega = rd.vec3(b, "initialAngularVelocity", w, [0.0, 0.0, 0.0])
        lo = [s * a + t for s, a, t in zip(scale, start, translation, strict=True)][:dim]
        hi = [s * a + t for s, a, t in zip(scale, end, translation, strict=True)][:dim]
        if not all(h > l for l, h in zip(lo, hi, strict=True)):
            raise rd.error(
                f"{w}.end", end,
                f"to exceed start {start} on every axis after scale and translation "
                f"(block {lo} .. {hi})",
            )
        if not all(math.isfinite((h - l) / (2.0 * r)) for l, h in zip(lo, hi, strict=True)):
            raise rd.error(
                f"{w}.start", start,
                f"a block whose extent in particle diameters is a finite number (block {lo} .. "
                f"{hi} with end {end}, Configuration.particleRadius {r} m)",
            )
        n = len(out)
        block: dict[str, Any] = {"start": [l + r for l in lo]}
        if mode:  # SPlisHSPlasH's denser lattices, sampled for its box [lo, hi]
            block.update(end=[h - r for h in hi], lattice=_DENSE_MODES[mode])
            rd.origin[f"fluid_blocks[{n}].lattice"] = f"{w}.denseMode"
        else:
            # SPlisHSPlasH: round((hi - lo) / 2r) - 1 particles per axis, the first at lo + 2r
            counts = [
                math.floor((h - l) / (2.0 * r) + 0.5) - 1 for l, h in zip(lo, hi, strict=True)
            ]
            if min(counts) < 1:
                rd.notes.append(
                    f"{w}: the block {lo} .. {hi} holds no particle of radius {r} in "
                    "SPlisHSPlasH (less than 2 particle diameters on an axis); it is left out"
                )
                continue
            block["end"] = [l + r + 2.0 * r * c for l, c in zip(lo, counts, strict=True)]
        block["material"] = rd.text(b, "id", w, "Fluid")
        rd.origin[f"fluid_blocks[{n}]"] = w
        rd.origin[f"fluid_blocks[{n}].material"] = f"{w}.id"
        rd.origin[f"fluid_blocks[{n}].velocity"] = f"{w}.initialVelocity"
        rd.origin[f"fluid_blocks[{n}].angular_velocity"] = f"{w}.initialAngularVelocity"
        if any(velocity[:dim]):
            block["velocity"] = velocity[:dim]
        if any(omega):
            block["angular_velocity"] = omega
        out.append(block)
    rd.origin["fluid_blocks"] = "FluidBlocks"
    return out


def fluid_models(rd: Reader) -> list[dict[str, Any]]:
    """``FluidModels`` with a particle file -> ``fluid_files`` (placement and velocity as in
    ``SimulatorBase::initFluidData``: only ``scale[0]`` scales a particle file; the file's
    velocities are replaced by ``initialVelocity`` and ``initialAngularVelocity``)."""
    out = []
    base = rd.path.parent if rd.path is not None else Path.cwd()
    for k, fm in enumerate(rd.array("FluidModels")):
        w = f"FluidModels[{k}]"
        known = {"particleFile", "translation", "scale", "rotationAxis", "rotationAngle", "id",
                 "initialVelocity", "initialAngularVelocity"}
        name = rd.text(fm, "particleFile", w, "")
        if not name:
            raise rd.error(f"{w}.particleFile", fm.get("particleFile"),
                           "a particle file (BGEO, PLY, VTK) or a closed mesh (OBJ, STL) "
                           "relative to the scene file")
        if name.lower().endswith(_FILL_SUFFIXES):
            continue  # a mesh to fill with fluid: fluid_mesh_models
        rd.collect_unknown(fm, w, known, {"visMesh"})
        p = Path(name).expanduser()
        f = p if p.is_absolute() else base / p
        check_particle_file(f, name, f"{rd.label}: {w}.particleFile")
        if isinstance(fm.get("scale"), (int, float)) and not isinstance(fm["scale"], bool):
            scale = [rd.num(fm, "scale", w, 1.0)] * 3  # one number before 2020 (0d1656a)
        else:
            scale = rd.vec3(fm, "scale", w, [1.0, 1.0, 1.0])
        if not scale[0] > 0:
            raise rd.error(f"{w}.scale", scale, "a positive first component (SPlisHSPlasH "
                           "scales particle files by scale[0])")
        if scale[1:] != [scale[0], scale[0]]:
            rd.notes.append(
                f"{w}.scale: {scale}: SPlisHSPlasH scales particle files uniformly by the "
                f"first component, as sphkit does ({scale[0]})"
            )
        axis = rd.vec3(fm, "rotationAxis", w, [1.0, 0.0, 0.0])
        angle = rd.num(fm, "rotationAngle", w, 0.0)
        if angle != 0.0 and not any(axis):
            raise rd.error(f"{w}.rotationAxis", axis, "a non-zero axis")
        n = len(out)
        rd.origin[f"fluid_files[{n}]"] = w
        rd.origin[f"fluid_files[{n}].material"] = f"{w}.id"
        entry: dict[str, Any] = {
            "file": name,
            "translation": rd.vec3(fm, "translation", w, [0.0, 0.0, 0.0]),
            "scale": scale[0],
            "rotation_axis": axis,
            "rotation_angle": angle,
            "material": rd.text(fm, "id", w, "Fluid"),
        }
        velocity = rd.vec3(fm, "initialVelocity", w, [0.0, 0.0, 0.0])
        omega = rd.vec3(fm, "initialAngularVelocity", w, [0.0, 0.0, 0.0])
        if any(velocity):
            entry["velocity"] = velocity
        if any(omega):
            entry["angular_velocity"] = omega
        out.append(entry)
    rd.origin["fluid_files"] = "FluidModels"
    return out


def emitters(rd: Reader, dim: int, r: float) -> list[dict[str, Any]]:
    """``Emitters`` -> ``emitters`` (``SimulatorBase::createEmitters``, ``Emitter.cpp``):
    widths in particles become metres (``n 2r``); in 2D every emitter is a box of width 1,
    its line ``height`` (box) or ``width`` (circle) particles long, rotating about z; the
    material's ``maxEmitterParticles`` (10,000) becomes ``max_particles``."""
    caps, reuse = {}, {}
    for w, m in legacy.material_entries(rd.data):
        mid = rd.text(m, "id", w, "Fluid")
        caps[mid] = rd.integer(m, "maxEmitterParticles", w, 10000)
        if rd.flag(m, "emitterReuseParticles", w, False):  # SPlisHSPlasH's default box
            lo = rd.vec3(m, "emitterBoxMin", w, [-1.0, -1.0, -1.0])
            hi = rd.vec3(m, "emitterBoxMax", w, [1.0, 1.0, 1.0])
            if any(b < a for a, b in zip(lo, hi, strict=True)):
                raise rd.error(f"{w}.emitterBoxMax", hi, f"a corner above emitterBoxMin {lo}")
            reuse[mid] = {"min": lo[:dim], "max": hi[:dim]}
    out = []
    for k, e in enumerate(rd.array("Emitters")):
        w = f"Emitters[{k}]"
        e = legacy.emitter(rd, e, w, r)  # noqa: PLW2901 -- the later form of it
        known = {"type", "width", "height", "translation", "rotationAxis", "rotationAngle",
                 "velocity", "id", "emitStartTime", "emitEndTime"}
        rd.collect_unknown(e, w, known, set())
        kind = rd.integer(e, "type", w, 0)
        if kind not in (0, 1):
            raise rd.error(f"{w}.type", kind, "0 (box) or 1 (circle)")
        # SPlisHSPlasH reads width/height into unsigned ints, so a fractional count (the
        # JWL+23 CoveredSphere scene has width 6.2575) is truncated; sphkit does the same and
        # says so
        size = {}
        for key in ("width", "height"):
            val = rd.num(e, key, w, 5.0)
            size[key] = int(val)
            if val != int(val):
                rd.notes.append(f"{w}.{key}: {val!r} truncated to {int(val)} particles, as "
                                "SPlisHSPlasH reads it into an integer")
        width, height = size["width"], size["height"]
        for key, v in (("width", width), ("height", height)):
            if v < 1:
                raise rd.error(f"{w}.{key}", v, "a number of particles >= 1")
        velocity = rd.num(e, "velocity", w, 1.0, positive=True)
        start = rd.num(e, "emitStartTime", w, 0.0, nonneg=True)
        end = None if e.get("emitEndTime") is None else rd.num(e, "emitEndTime", w, 0.0)
        if end is not None and end < start:
            raise rd.error(f"{w}.emitEndTime", end, f"a time >= emitStartTime {start}")
        axis = rd.vec3(e, "rotationAxis", w, [0.0, 0.0, 1.0])
        angle = rd.num(e, "rotationAngle", w, 0.0)
        diam = 2.0 * r
        entry: dict[str, Any] = {
            "shape": "circle" if kind == 1 else "box",
            "position": rd.vec3(e, "translation", w, [0.0, 0.0, 0.0]),
            "velocity": velocity, "start_time": start, "end_time": end,
            "material": rd.text(e, "id", w, "Fluid"),
        }
        if dim == 2:  # SPlisHSPlasH: a box of width 1, rotated about z
            entry.update(shape="box", width=(width if kind == 1 else height) * diam,
                         rotation_axis=[0.0, 0.0, 1.0], rotation_angle=angle)
        else:
            if angle != 0.0 and not any(axis):
                raise rd.error(f"{w}.rotationAxis", axis, "a non-zero axis")
            entry.update(width=width * diam, height=height * diam, rotation_axis=axis,
                         rotation_angle=angle)
        entry["max_particles"] = caps.get(entry["material"], 10000)
        n = len(out)
        if entry["material"] in reuse:
            entry["reuse_box"] = reuse[entry["material"]]
            rd.origin[f"emitters[{n}].reuse_box"] = "Materials[].emitterBoxMin/emitterBoxMax"
        rd.origin[f"emitters[{n}]"] = w
        rd.origin[f"emitters[{n}].position"] = f"{w}.translation"
        out.append(entry)
    rd.origin["emitters"] = "Emitters"
    return out


_ANIMATED_FIELDS = {"velocity": "velocity", "angular velocity": "angular_velocity",
                    "position": "position"}


def animation_fields(rd: Reader) -> list[dict[str, Any]]:
    """``AnimationFields`` -> ``animation_fields`` (``SceneLoader``, ``AnimationField``):
    ``particleField`` velocity, angular velocity or position; ``shapeType`` 0 box, 1 sphere,
    2 cylinder; the expressions and the time window as they are."""
    out = []
    for k, a in enumerate(rd.array("AnimationFields")):
        w = f"AnimationFields[{k}]"
        known = {"particleField", "translation", "rotationAxis", "rotationAngle", "scale",
                 "shapeType", "expression_x", "expression_y", "expression_z", "startTime",
                 "endTime"}
        rd.collect_unknown(a, w, known, set())
        name = rd.text(a, "particleField", w, "velocity")
        if name not in _ANIMATED_FIELDS:
            raise rd.unsupported(f"{w}.particleField",
                                 f"{name!r} is not supported yet; supported: "
                                 f"{', '.join(map(repr, _ANIMATED_FIELDS))}")
        shape = rd.integer(a, "shapeType", w, 0)
        if shape not in (0, 1, 2):
            raise rd.error(f"{w}.shapeType", shape, "0 (box), 1 (sphere) or 2 (cylinder)")
        end = None if a.get("endTime") is None else rd.num(a, "endTime", w, 0.0)
        entry: dict[str, Any] = {
            "field": _ANIMATED_FIELDS[name],
            "shape": ("box", "sphere", "cylinder")[shape],
            "translation": rd.vec3(a, "translation", w, [0.0, 0.0, 0.0]),
            "rotation_axis": rd.vec3(a, "rotationAxis", w, [1.0, 0.0, 0.0]),
            "rotation_angle": rd.num(a, "rotationAngle", w, 0.0),
            "scale": rd.vec3(a, "scale", w, [1.0, 1.0, 1.0]),
            "expression": [rd.text(a, f"expression_{c}", w, "") for c in "xyz"],
            "start_time": rd.num(a, "startTime", w, 0.0),
            "end_time": end,
        }
        n = len(out)
        rd.origin[f"animation_fields[{n}]"] = w
        rd.origin[f"animation_fields[{n}].expression"] = f"{w}.expression_x/_y/_z"
        out.append(entry)
    rd.origin["animation_fields"] = "AnimationFields"
    return out


def rigid_bodies(rd: Reader, bodies: list[dict[str, Any]],
                 particles: bool = False) -> list[dict[str, Any]]:
    """``RigidBodies`` -> ``meshes``: static walls, or dynamic bodies (``isDynamic``) with
    PositionBasedDynamics' ``density`` and ``friction``.

    ``particles``: the scene samples boundary particles (``boundaryHandlingMethod`` 0). They
    cover only the mesh's surface, so SPlisHSPlasH keeps fluid on either side of it and a wall
    (``isWall``) without ``mapInvert`` holds its fluid inside (``Sampling_2D.json``); sphkit
    needs the side: such a static wall becomes a container (``invert``), with a note."""
    out = []
    base = rd.path.parent if rd.path is not None else Path.cwd()
    for k, rb in enumerate(bodies):
        w = f"RigidBodies[{k}]"
        known = {
            "geometryFile", "particleFile", "translation", "rotationAxis", "rotationAngle",
            "scale", "isDynamic", "isAnimated", "mapInvert", "mapThickness", "mapResolution",
            "mapFile", "velocity", "angularVelocity",
        }
        rd.collect_unknown(rb, w, known, _RIGID_QUIET)
        dynamic = rd.flag(rb, "isDynamic", w, False)
        if rd.flag(rb, "isAnimated", w, False):
            if dynamic:
                raise rd.error(f"{w}.isAnimated", True, "false for a dynamic body (isDynamic)")
            # SPlisHSPlasH moves an animated body only from a Python script (its scriptFile
            # calls setVelocity / animate); without the script it stays where it is
            rd.notes.append(
                f"{w}.isAnimated: true: the body moves only as the scene's "
                "Configuration.scriptFile (SPlisHSPlasH's Python API) animates it, which sphkit "
                "does not run; it stays in place (sphkit's format prescribes a motion with "
                "meshes[].velocity and angular_velocity)")
        geometry = rd.text(rb, "geometryFile", w, "")
        if not geometry:
            if rb.get("particleFile"):
                raise rd.unsupported(
                    f"{w}.particleFile",
                    "pre-sampled boundary particles are not supported yet; expected a "
                    "geometryFile (OBJ/PLY mesh) to sample",
                )
            raise rd.error(f"{w}.geometryFile", rb.get("geometryFile"),
                           "a mesh file (OBJ/PLY/STL) relative to the scene file")
        if rb.get("particleFile"):
            rd.unknown.append(f"{w}.particleFile (sphkit samples geometryFile instead)")
        if rb.get("mapFile"):
            rd.unknown.append(f"{w}.mapFile (sphkit computes the map from geometryFile)")
        res = rb.get("mapResolution", [20, 20, 20])
        if (not isinstance(res, list) or len(res) != 3
                or not all(isinstance(c, int) and not isinstance(c, bool) and c >= 1
                           for c in res)):
            raise rd.error(f"{w}.mapResolution", res, "a list of 3 positive integers")
        rd.origin[f"meshes[{len(out)}].map_resolution"] = f"{w}.mapResolution"
        rd.origin[f"meshes[{len(out)}].map_thickness"] = f"{w}.mapThickness"
        p = Path(geometry).expanduser()
        f = p if p.is_absolute() else base / p
        if not f.is_file():
            raise rd.error(f"{w}.geometryFile", geometry,
                           f"an existing mesh file (looked for {str(f)!r})")
        scale = rd.vec3(rb, "scale", w, [1.0, 1.0, 1.0])
        if not all(scale):
            raise rd.error(f"{w}.scale", scale, "non-zero scale factors")
        axis = rd.vec3(rb, "rotationAxis", w, [1.0, 0.0, 0.0])
        angle = rd.num(rb, "rotationAngle", w, 0.0)
        if angle != 0.0 and not any(axis):
            raise rd.error(f"{w}.rotationAxis", axis, "a non-zero axis")
        n = len(out)
        rd.origin[f"meshes[{n}]"] = w
        rd.origin[f"meshes[{n}].invert"] = f"{w}.mapInvert"
        wall_container = (particles and not dynamic and "mapInvert" not in rb
                          and rd.flag(rb, "isWall", w, False))
        if wall_container:
            rd.notes.append(
                f"{w}: a wall (isWall) without mapInvert, with boundary particles "
                "(boundaryHandlingMethod 0), which sample only its surface: sphkit holds the "
                "fluid inside it (meshes[].invert true)")
        rd.origin[f"meshes[{n}].geometry_file"] = f"{w}.geometryFile"
        out.append({
            "geometry_file": geometry,
            "translation": rd.vec3(rb, "translation", w, [0.0, 0.0, 0.0]),
            "rotation_axis": axis,
            "rotation_angle": angle,
            "scale": scale,
            "invert": rd.flag(rb, "mapInvert", w, False) or wall_container,
            "map_thickness": rd.num(rb, "mapThickness", w, 0.0),
            "map_resolution": res,
        })
        # PositionBasedDynamics' initial velocity and angular velocity (its scene loader's
        # "velocity", "angularVelocity"; zero by default) move only dynamic bodies
        motion = {key: rd.vec3(rb, key, w, [0.0, 0.0, 0.0])
                  for key in ("velocity", "angularVelocity")}
        if dynamic:  # PositionBasedDynamics' density and friction apply to sphkit's bodies
            out[-1].update(dynamic=True,
                           density=rd.num(rb, "density", w, 1000.0, positive=True),
                           friction=rd.num(rb, "friction", w, 0.5, nonneg=True))
            rd.origin[f"meshes[{n}].density"] = f"{w}.density"
            rd.origin[f"meshes[{n}].friction"] = f"{w}.friction"
            if "restitution" in rb:
                out[-1]["restitution"] = rd.num(rb, "restitution", w, 0.0, nonneg=True)
                rd.origin[f"meshes[{n}].restitution"] = f"{w}.restitution"
            for key, field in (("velocity", "velocity"), ("angularVelocity", "angular_velocity")):
                if any(motion[key]):
                    out[-1][field] = motion[key]
                    rd.origin[f"meshes[{n}].{field}"] = f"{w}.{key}"
        elif any(any(u) for u in motion.values()):
            rd.notes.append(
                f"{w}.velocity/angularVelocity: a static body (isDynamic false) does not move, "
                "in SPlisHSPlasH either; ignored")
    rd.origin["meshes"] = "RigidBodies"
    return out


def fluid_mesh_models(rd: Reader, dim: int) -> list[dict[str, Any]]:
    """FluidModels whose particleFile is a closed mesh: fluid filling it (sphkit samples the
    mesh through its exact signed distance at the lattice points, so ``resolutionSDF`` is
    not needed); particle files are :meth:`fluid_models`."""
    out = []
    base = rd.path.parent if rd.path is not None else Path.cwd()
    for k, fm in enumerate(rd.array("FluidModels")):
        w = f"FluidModels[{k}]"
        known = {
            "particleFile", "id", "translation", "scale", "rotationAxis", "rotationAngle",
            "invert", "resolutionSDF", "denseMode", "initialVelocity",
            "initialAngularVelocity",
        }
        f = rd.text(fm, "particleFile", w, "")
        if not f.lower().endswith(_FILL_SUFFIXES):
            continue  # a particle file (or missing: reported by fluid_models)
        rd.collect_unknown(fm, w, known, _BLOCK_QUIET)
        p = Path(f).expanduser()
        if not (p if p.is_absolute() else base / p).is_file():
            raise rd.error(f"{w}.particleFile", f,
                           f"an existing mesh file (looked for {str(base / p)!r})")
        mode = rd.integer(fm, "denseMode", w, 0)
        if mode not in (0, 1, 2):
            raise rd.error(f"{w}.denseMode", mode,
                           "0 (regular lattice), 1 (layered) or 2 (close packed)")
        omega = rd.vec3(fm, "initialAngularVelocity", w, [0.0, 0.0, 0.0])
        scale = rd.vec3(fm, "scale", w, [1.0, 1.0, 1.0])
        if not all(scale):
            raise rd.error(f"{w}.scale", scale, "non-zero scale factors")
        axis = rd.vec3(fm, "rotationAxis", w, [1.0, 0.0, 0.0])
        angle = rd.num(fm, "rotationAngle", w, 0.0)
        if angle != 0.0 and not any(axis):
            raise rd.error(f"{w}.rotationAxis", axis, "a non-zero axis")
        velocity = rd.vec3(fm, "initialVelocity", w, [0.0, 0.0, 0.0])
        n = len(out)
        rd.origin[f"fluid_meshes[{n}]"] = w
        rd.origin[f"fluid_meshes[{n}].material"] = f"{w}.id"
        entry: dict[str, Any] = {
            "geometry_file": f,
            "translation": rd.vec3(fm, "translation", w, [0.0, 0.0, 0.0]),
            "rotation_axis": axis,
            "rotation_angle": angle,
            "scale": scale,
            "invert": rd.flag(fm, "invert", w, False),
            "material": rd.text(fm, "id", w, "Fluid"),
        }
        if any(velocity[:dim]):
            entry["velocity"] = velocity[:dim]
        rd.origin[f"fluid_meshes[{n}].velocity"] = f"{w}.initialVelocity"
        if any(omega):
            entry["angular_velocity"] = omega
            rd.origin[f"fluid_meshes[{n}].angular_velocity"] = f"{w}.initialAngularVelocity"
        if mode:  # VolumeSampling's denser lattices
            entry["lattice"] = _DENSE_MODES[mode]
            rd.origin[f"fluid_meshes[{n}].lattice"] = f"{w}.denseMode"
        out.append(entry)
    return out

# -- validation ----------------------------------------------------------------------------
