"""Generated hostile scenes for the fuzz test (``tests/test_fuzz.py``, 300 examples) and its long
run (``python validation/fuzz.py --examples 10000``).

A tiny valid scene (sphkit's format: 2D, 25 particles in a box; SPlisHSPlasH's: 2D, 25 particles
in a box mesh) gets one to three mutations: a field set to a value of a random type (NaN,
Infinity, huge, tiny, negative, zero, strings, lists, objects, ...), a field deleted, an unknown
field added, or an optional field added (methods, emitters, periodic domains, ...) with a
plausible or a hostile value. :func:`run_example` runs ``sphkit run`` on it in-process with its
output captured, a few steps at most, with a particle budget of 100,000, and :func:`check`
states what must hold: exit code 0 (ran), 3 (the stability guard stopped it), 130 (stopped by
the harness after a few steps: time steps too small to reach ``--until``) or 2 with a message
naming one of the mutated fields, and never an exception out of the command.
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import math
import shutil
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from unittest import mock

from hypothesis import strategies as st

#: steps an example may take before the harness stops it (as Ctrl-C would: exit 130)
MAX_STEPS = 4
#: simulated time an example runs (``--until``) [s]
UNTIL = "0.003"
#: the particle budget of an example (``--max-particles``): the base scenes have about 100
#: particles; a hostile value that needs more than this is refused (exit 2, naming the part).
#: The default budget (20 million) let a fluid block reaching down to y = -128768 m (3.2
#: million rows of 5) be sampled: 16 million particles, over 5 GB before the harness was
#: stopped
MAX_PARTICLES = 100_000

OWN = {
    "name": "fuzz",
    "configuration": {
        "dim": 2, "particle_radius": 0.02, "gravity": [0.0, -9.81],
        "time": {"until": 0.01, "dt": 0.001, "cfl": True, "dt_max": 0.005},
        "pressure": {"method": "dfsph", "max_error": 0.1, "max_iterations": 20},
        "boundary": {"method": "akinci2012", "map_cache": False},
    },
    "materials": [{"id": "water", "density0": 1000.0,
                   "viscosity": {"method": "standard", "coefficient": 0.01}}],
    "fluid_blocks": [{"start": [0.1, 0.1], "end": [0.3, 0.3], "material": "water"}],
    "boxes": [{"min": [0.0, 0.0], "max": [0.6, 0.5], "layers": 2}],
    "output": {"fps": 40, "formats": ["vtk"]},
}

SPH = {
    "Configuration": {
        "sim2D": True, "particleRadius": 0.02, "simulationMethod": 4,
        "boundaryHandlingMethod": 0, "timeStepSize": 0.001, "stopAt": 0.01,
        "gravitation": [0.0, -9.81, 0.0], "cflMethod": 1, "dataExportFPS": 40,
        "maxIterations": 20, "maxError": 0.1,
    },
    "Materials": [{"id": "Fluid", "density0": 1000.0, "viscosityMethod": 1, "viscosity": 0.01}],
    "FluidBlocks": [{"start": [0.1, 0.1, -0.5], "end": [0.3, 0.3, 0.5]}],
    "RigidBodies": [{"geometryFile": "box.obj", "translation": [0.3, 0.25, 0.0],
                     "scale": [0.6, 0.5, 1.0], "isDynamic": False, "isWall": True,
                     "mapInvert": True}],
}

#: a unit cube centred on the origin, faces outward (the SPlisHSPlasH scene's wall, scaled)
BOX_OBJ = "\n".join(
    [f"v {x} {y} {z}" for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
    + ["f 2 4 3 1", "f 7 8 6 5", "f 5 6 2 1", "f 4 8 7 3", "f 3 7 5 1", "f 6 8 4 2"]) + "\n"

_NASTY = [math.nan, math.inf, -math.inf, 1e300, -1e300, 1e-300, -1e-300, 0, 0.0, -1, -0.5,
          1e-9, 1e9, 10 ** 30, 2 ** 63, True, False, None, "x", "", "nan", [], {}, [1, 2],
          [math.nan] * 3, [math.inf, 0.0, 0.0], [1e300, 1e300, 1e300], {"a": 1}]

#: any value: the hostile ones above, and random numbers, strings and short lists
VALUES = st.one_of(
    st.sampled_from(_NASTY),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-10 ** 6, 10 ** 6),
    st.text(max_size=4),
    st.lists(st.one_of(st.floats(-2.0, 2.0), st.sampled_from(_NASTY[:8])), max_size=4),
)


def _names(role: str) -> list[str]:
    from sphkit import registry

    return [*registry.names(role), "none", "nope"]


def _own_extras() -> list[tuple[tuple, st.SearchStrategy]]:
    """Optional fields of sphkit's format, with plausible values (or any value)."""
    def vec(n: int) -> st.SearchStrategy:
        return st.lists(st.floats(-1.0, 1.0), min_size=n, max_size=n)

    extras = [
        (("configuration", "pressure", "method"), st.sampled_from(_names("pressure"))),
        (("configuration", "boundary", "method"), st.sampled_from(_names("boundary"))),
        (("configuration", "boundary", "pressure"),
         st.sampled_from(_names("boundary_pressure"))),
        (("configuration", "kernel"),
         st.sampled_from(["cubic", "wendland", "poly6", "spiky", "quintic", "gauss"])),
        (("configuration", "precision"), st.sampled_from(["float64", "float32", "float16"])),
        (("configuration", "pressure", "stiffness"), VALUES),
        (("configuration", "pressure", "equation"), st.sampled_from(["tait", "linear", "x"])),
        (("configuration", "max_cfl"), VALUES),
        (("configuration", "domain_margin"), VALUES),
        (("configuration", "max_particles"), VALUES),
        (("configuration", "contact_tolerance"), VALUES),
        (("configuration", "start", "hydrostatic"), VALUES),
        (("configuration", "start", "relax"), VALUES),
        (("configuration", "start", "relax_iterations"), VALUES),
        (("configuration", "start", "settle"),
         st.one_of(st.sampled_from(["auto", True, False, "maybe"]), VALUES)),
        (("configuration", "start", "settle_speed"), VALUES),
        (("configuration", "start", "settle_min_periods"), VALUES),
        (("configuration", "max_velocity"), VALUES),
        (("configuration", "zsort_every"), VALUES),
        (("configuration", "periodic_x"), st.one_of(st.just([-0.1, 0.7]), VALUES)),
        (("configuration", "time", "cfl"), st.booleans()),
        (("configuration", "time", "dt_min"), VALUES),
        (("configuration", "time", "cfl_factor"), VALUES),
        (("materials", 0, "viscosity", "method"), st.sampled_from(_names("viscosity"))),
        (("materials", 0, "vorticity"),
         st.fixed_dictionaries({"method": st.sampled_from(_names("vorticity"))})),
        (("materials", 0, "surface_tension"),
         st.fixed_dictionaries({"method": st.sampled_from(_names("surface_tension")),
                                "coefficient": st.one_of(st.floats(0, 1), VALUES)})),
        (("materials", 0, "drag"),
         st.fixed_dictionaries({"method": st.sampled_from(_names("drag"))})),
        (("fluid_blocks", 0, "velocity"), st.one_of(vec(2), VALUES)),
        (("fluid_blocks", 0, "lattice"),
         st.sampled_from(["square", "hexagonal", "layered", "close_packed", "x"])),
        (("fluid_blocks", 1), st.fixed_dictionaries({"start": vec(2), "end": vec(2)})),
        (("boxes", 0, "open_top"), st.booleans()),
        (("emitters",), st.just([{"position": [0.1, 0.4], "width": 0.1, "velocity": 1.0,
                                  "end_time": 0.002, "material": "water"}])),
        (("emitters", 0, "width"), VALUES),
        (("emitters", 0, "velocity"), VALUES),
        (("animation_fields",), st.just([{"translation": [0.1, 0.1, 0.0],
                                           "scale": [0.1, 0.1, 1.0],
                                           "expression": ["0.1*cos(2*t)", "", ""]}])),
        (("animation_fields", 0, "expression", 0),
         st.one_of(st.sampled_from(["sin(t", "__import__('os')", "x.y", "1e999", "vx^2"]),
                   VALUES)),
        (("animation_fields", 0, "scale"), VALUES),
        (("animation_fields", 0, "shape"), st.sampled_from(["box", "sphere", "cylinder", "x"])),
        (("output", "fps"), VALUES),
        (("output", "formats"), st.lists(st.sampled_from(["vtk", "ply", "bgeo", "obj"]),
                                         max_size=3)),
        (("output", "attributes"), st.lists(st.sampled_from(["velocity", "density", "x"]),
                                            max_size=3)),
        (("output", "checkpoint_every"), st.one_of(st.floats(0.0, 0.01), VALUES)),
        (("output", "body_formats"), st.lists(st.sampled_from(["vtk", "obj", "ply", "stl"]),
                                              max_size=3)),
        (("configuration", "time", "iteration_control"),
         st.one_of(st.booleans(), st.just("often"), VALUES)),
        (("configuration", "boundary", "symmetric"), st.one_of(st.booleans(), VALUES)),
        (("configuration", "boundary", "solved"),
         st.one_of(st.sampled_from([True, False, "velocity", "density", "x"]), VALUES)),
        (("boxes", 0, "viscosity_factors"),
         st.one_of(st.lists(st.floats(0.0, 3.0), min_size=4, max_size=4), VALUES)),
        (("emitters", 0, "reuse_box"),
         st.one_of(st.fixed_dictionaries({"min": vec(2), "max": vec(2)}), VALUES)),
        # several fluids: a second material, a block of it and the forces between the phases
        (("materials", 1), st.fixed_dictionaries(
            {"id": st.just("oil"), "density0": st.one_of(st.floats(50.0, 2000.0), VALUES)})),
        (("fluid_blocks", 1), st.fixed_dictionaries(
            {"start": st.just([0.35, 0.1]), "end": st.just([0.5, 0.3]),
             "material": st.sampled_from(["oil", "water", "nope"])})),
        (("interfaces",), st.fixed_dictionaries(
            {"materials": st.one_of(st.just(["water", "oil"]), VALUES),
             "viscosity": st.fixed_dictionaries(
                 {"method": st.sampled_from(_names("interface_viscosity")),
                  "coefficient": st.one_of(st.floats(0.0, 0.1), VALUES)}),
             "tension": st.fixed_dictionaries(
                 {"method": st.sampled_from(_names("interface_tension")),
                  "coefficient": st.one_of(st.floats(0.0, 1.0), VALUES)})}).map(
                      lambda d: [d])),
        # an elastic solid
        (("materials", 0, "elasticity"), st.fixed_dictionaries(
            {"method": st.sampled_from(_names("elasticity")),
             "youngs_modulus": st.one_of(st.floats(1e3, 1e6), VALUES),
             "poisson_ratio": st.one_of(st.floats(0.0, 0.45), VALUES)})),
        (("materials", 0, "elasticity", "fixed_boxes"),
         st.one_of(st.just([{"min": [0.0, 0.0], "max": [0.2, 0.2]}]), VALUES)),
        # a dynamic rigid body (the folder's box.obj, scaled into the tank)
        (("meshes",), st.just([{"geometry_file": "box.obj", "translation": [0.45, 0.3, 0.0],
                                "scale": [0.08, 0.08, 1.0], "dynamic": True,
                                "density": 500.0}])),
        (("meshes", 0, "velocity"), st.one_of(vec(2), VALUES)),
        (("meshes", 0, "angular_velocity"), VALUES),
        (("meshes", 0, "density"), VALUES),
        (("meshes", 0, "friction"), VALUES),
        (("meshes", 0, "restitution"), st.one_of(st.floats(0.0, 1.0), VALUES)),
    ]
    return extras


def _sph_extras() -> list[tuple[tuple, st.SearchStrategy]]:
    """Optional fields of SPlisHSPlasH's format, with plausible values (or any value)."""
    c = "Configuration"
    return [
        ((c, "simulationMethod"), st.one_of(st.integers(-1, 7), VALUES)),
        ((c, "boundaryHandlingMethod"), st.one_of(st.integers(-1, 3), VALUES)),
        ((c, "kernel"), st.one_of(st.integers(-1, 5), VALUES)),
        ((c, "stiffness"), VALUES),
        ((c, "exponent"), VALUES),
        ((c, "cflFactor"), VALUES),
        ((c, "cflMinTimeStepSize"), VALUES),
        ((c, "cflMaxTimeStepSize"), VALUES),
        ((c, "enableVTKExport"), st.one_of(st.booleans(), VALUES)),
        ((c, "particleAttributes"), st.one_of(st.just("velocity;density"), VALUES)),
        (("Materials", 0, "viscosityMethod"), st.one_of(st.integers(-1, 7), VALUES)),
        (("Materials", 0, "vorticityMethod"), st.one_of(st.integers(-1, 3), VALUES)),
        (("Materials", 0, "surfaceTensionMethod"), st.one_of(st.integers(-1, 6), VALUES)),
        (("Materials", 0, "dragMethod"), st.one_of(st.integers(-1, 3), VALUES)),
        (("Materials", 0, "maxEmitterParticles"), VALUES),
        (("FluidBlocks", 0, "initialVelocity"), VALUES),
        (("FluidBlocks", 0, "denseMode"), st.one_of(st.integers(-1, 3), VALUES)),
        (("FluidBlocks", 0, "initialAngularVelocity"), VALUES),
        (("Materials", 0, "XSPH"), st.one_of(st.just({"xsph": 0.1}), VALUES)),
        (("FluidBlocks", 0, "translation"), VALUES),
        (("RigidBodies", 0, "isDynamic"), st.one_of(st.booleans(), VALUES)),
        (("RigidBodies", 0, "mapResolution"), VALUES),
        (("Emitters",), st.just([{"width": 3, "height": 3, "translation": [0.1, 0.4, 0.0],
                                  "velocity": 1.0, "emitEndTime": 0.002}])),
        (("Emitters", 0, "width"), VALUES),
        (("Emitters", 0, "velocity"), VALUES),
        (("AnimationFields",), st.just([{"particleField": "velocity", "scale": [0.1, 0.1, 1.0],
                                         "expression_x": "0.1*cos(2*t)"}])),
        (("AnimationFields", 0, "expression_y"),
         st.one_of(st.sampled_from(["sin(t", "__import__('os')", "valuex*2"]), VALUES)),
        (("AnimationFields", 0, "particleField"),
         st.one_of(st.sampled_from(["velocity", "angular velocity", "density"]), VALUES)),
        (("AnimationFields", 0, "shapeType"), st.one_of(st.integers(-1, 3), VALUES)),
        (("AnimationFields", 0, "translation"), VALUES),
        (("RigidBodies", 0, "isAnimated"), st.one_of(st.booleans(), VALUES)),
        (("RigidBodies", 0, "velocity"), VALUES),
        (("RigidBodies", 0, "angularVelocity"), VALUES),
        (("RigidBodies", 0, "restitution"), VALUES),
        (("Simulation", "contactTolerance"), VALUES),
        ((c, "cflMethod"), st.one_of(st.integers(-1, 3), VALUES)),
        ((c, "enableStateExport"), st.one_of(st.booleans(), VALUES)),
        ((c, "stateExportFPS"), VALUES),
        (("Emitters", 0, "emitterReuseParticles"), st.one_of(st.booleans(), VALUES)),
        (("Emitters", 0, "emitterBoxMin"), VALUES),
        (("Emitters", 0, "emitterBoxMax"), VALUES),
        # several fluids: a second material and a block of it
        (("Materials", 1), st.fixed_dictionaries(
            {"id": st.just("Fluid2"), "density0": st.one_of(st.floats(50.0, 2000.0), VALUES)})),
        (("FluidBlocks", 1), st.fixed_dictionaries(
            {"start": st.just([0.35, 0.1, -0.5]), "end": st.just([0.5, 0.3, 0.5]),
             "id": st.sampled_from(["Fluid2", "Fluid", "nope"])})),
        # the forms before 2.16 and before the Materials array (SPlisHSPlasH 2018-2020)
        (("Fluid",), st.fixed_dictionaries(
            {"viscosity": st.one_of(st.floats(0.0, 0.1), VALUES),
             "viscosityMethod": st.one_of(st.integers(-1, 8), VALUES)})),
        ((c, "viscosityMethod"), st.one_of(st.integers(-1, 8), VALUES)),
        ((c, "density0"), VALUES),
        (("Emitters", 0, "direction"), st.one_of(st.sampled_from([[1, 0, 0], [0, -1, 0]]),
                                                 VALUES)),
        (("Emitters", 0, "emitsPerSecond"), VALUES),
        (("Materials", 0, "surfTZRd"), VALUES),
        # an elastic solid
        (("Materials", 0, "elasticityMethod"), st.one_of(st.integers(-1, 5), VALUES)),
        (("Materials", 0, "youngsModulus"), VALUES),
        (("Materials", 0, "poissonsRatio"), VALUES),
    ]


def _paths(node: Any, prefix: tuple = ()) -> Iterator[tuple]:
    """Every field path of a scene dict (objects' keys and lists' indices), parents first."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield (*prefix, k)
            yield from _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield (*prefix, i)
            yield from _paths(v, (*prefix, i))


def _parent(scene: Any, path: tuple) -> tuple[Any, Any] | None:
    """The container of ``path``'s last key, created along the way where possible."""
    node = scene
    for k in path[:-1]:
        if isinstance(node, dict):
            if not isinstance(node.get(k), (dict, list)):
                node[k] = {}
            node = node[k]
        elif isinstance(node, list) and isinstance(k, int):
            while len(node) <= k:
                node.append({})
            if not isinstance(node[k], (dict, list)):
                node[k] = {}
            node = node[k]
        else:
            return None
    return node, path[-1]


def _set(scene: Any, path: tuple, value: Any) -> None:
    value = copy.deepcopy(value)  # the strategies hand out shared objects: never mutate them
    found = _parent(scene, path)
    if found is None:
        return
    node, k = found
    if isinstance(node, dict):
        node[k] = value
    elif isinstance(node, list) and isinstance(k, int):
        while len(node) <= k:
            node.append({})
        node[k] = value


def _delete(scene: Any, path: tuple) -> None:
    found = _parent(scene, path)
    if found is None:
        return
    node, k = found
    if isinstance(node, dict):
        node.pop(k, None)
    elif isinstance(node, list) and isinstance(k, int) and k < len(node):
        del node[k]


def _field_names(path: tuple) -> list[str]:
    """The names an error may mention for a mutated path: its keys (``configuration`` only when
    it is the whole path), cut to the 40 characters an error repeats of a key."""
    keys = [k[:40] for k in path if isinstance(k, str)]
    return [k for k in keys if k not in ("configuration", "Configuration")] or keys


@dataclass
class Example:
    """A generated scene: its format, the dict, and the names of the fields it mutated."""

    kind: str
    scene: dict
    names: list[str]
    ops: list[str]


@st.composite
def examples(draw: st.DrawFn, kind: str | None = None) -> Example:
    """A tiny scene of sphkit's (``"own"``) or SPlisHSPlasH's (``"sph"``) format with one to
    three hostile mutations."""
    kind = kind or draw(st.sampled_from(["own", "sph"]))
    base = OWN if kind == "own" else SPH
    extras = _own_extras() if kind == "own" else _sph_extras()
    scene = copy.deepcopy(base)
    names, ops = [], []
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["set", "set", "set", "delete", "unknown", "extra", "extra"]))
        if op == "extra":
            path, values = draw(st.sampled_from(extras))
            value = draw(st.one_of(values, VALUES) if draw(st.booleans()) else values)
        else:
            paths = list(_paths(scene))
            if not paths:
                continue
            path = draw(st.sampled_from(paths))
            value = draw(VALUES)
        if op == "delete":
            _delete(scene, path)
        elif op == "unknown":
            found = _parent(scene, path)
            if found is None or not isinstance(found[0], dict):
                continue
            key = draw(st.sampled_from(["frobnicate", "Particle_Radius", "x" * 300, "é"]))
            path = (*path[:-1], key)
            _set(scene, path, value)
        else:
            _set(scene, path, value)
        names.extend(_field_names(path))
        ops.append(f"{op} {'.'.join(map(str, path))[:80]}"
                   + ("" if op == "delete" else f" = {str(value)[:40]}"))
    return Example(kind, scene, [n for n in names if n], ops)


class _StepLimit:
    """Stops a run after MAX_STEPS steps as Ctrl-C would (tiny time steps would run long)."""

    def __init__(self) -> None:
        from sphkit.simulation import Simulation

        self.original = Simulation.step
        self.count = 0

    def __call__(self, sim: Any, *args: Any) -> Any:
        self.count += 1
        if self.count > MAX_STEPS:
            raise KeyboardInterrupt
        return self.original(sim, *args)


def run_example(ex: Example, folder: Path) -> tuple[int | None, str, BaseException | None]:
    """``sphkit run`` on the example in-process: exit code, what it printed, and the exception
    that escaped the command (None: it returned an exit code)."""
    from sphkit.cli import main
    from sphkit.simulation import Simulation

    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    (folder / "box.obj").write_text(BOX_OBJ)
    path = folder / "scene.json"
    try:
        path.write_text(json.dumps(ex.scene))
    except ValueError:  # an integer too long for json's str(): not a scene anyone can write
        return 2, "unwritable", None
    out = io.StringIO()
    limit = _StepLimit()
    code, escaped = None, None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out), \
            mock.patch.object(Simulation, "step", lambda sim, *a: limit(sim, *a)):
        try:
            code = main(["run", str(path), "--out", str(folder / "out"), "--until", UNTIL,
                         "--max-particles", str(MAX_PARTICLES), "--quiet"])
        except BaseException as e:  # noqa: B036 -- anything escaping is the failure we look for
            escaped = e
    return code, out.getvalue(), escaped


def check(ex: Example, code: int | None, text: str, escaped: BaseException | None) -> None:
    """What every example must satisfy (AssertionError naming the example otherwise)."""
    where = f"\n{ex.kind} example: {ex.ops}\n{json.dumps(ex.scene)[:1500]}\noutput:\n{text[-1500:]}"
    assert escaped is None, f"{type(escaped).__name__}: {escaped}{where}"
    assert "Traceback" not in text, where
    assert code in (0, 2, 3, 130), f"exit code {code}{where}"
    if code == 2 and text != "unwritable":
        assert any(n in text for n in ex.names), f"no mutated field {ex.names} named{where}"
