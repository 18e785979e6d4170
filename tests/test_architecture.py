"""The package keeps the architecture of DESIGN.md: who may import whom, one registry that the
scene schema agrees with, every registered method implementing its role, no oversized files."""

from __future__ import annotations

import ast
import json
import typing
from pathlib import Path

import pytest

from sphkit import registry
from sphkit.core.methods import BoundaryModel, Elasticity, NonPressureForce, PressureSolver
from sphkit.scene import schema

SRC = Path(__file__).resolve().parent.parent / "src" / "sphkit"

#: the method packages (one paper per file); they import only core and geometry
METHODS = {"pressure", "viscosity", "vorticity", "surface_tension", "drag", "boundary",
           "solids", "multiphase", "transport"}

#: top-level package -> the other top-level packages it may import (DESIGN.md, "Who may import
#: whom"; see docs/architecture.md for the two additions: the simulation builds its world from
#: a scene, and the world reads the scene model and particle files)
ALLOWED: dict[str, set[str]] = {
    "core": {"backend"},
    "backend": set(),
    "geometry": set(),
    **{m: {"core", "geometry", "backend"} for m in METHODS},
    "registry": set(),
    "scene": {"registry", "io"},
    "io": {"geometry"},
    "world": {"registry", "core", "geometry", "scene", "io", "backend"} | METHODS,
    "simulation": {"core", "registry", "io", "world", "scene"},
    "cli": {"scene", "world", "simulation", "io", "learn", "registry", "core"},
    "learn": {"simulation", "io", "core"},
    "__init__": {"simulation"},
    "__main__": {"cli"},
}


def _imports(path: Path) -> set[str]:
    """The top-level sphkit packages a file imports (also inside functions)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            parts = node.module.split(".")
            if parts[0] != "sphkit":
                continue
            if len(parts) > 1:
                out.add(parts[1])
            else:  # from sphkit import x
                out.update(a.name for a in node.names if a.name != "__version__")
        elif isinstance(node, ast.Import):
            out.update(a.name.split(".")[1] for a in node.names if a.name.startswith("sphkit."))
    return out


def _files() -> list[tuple[str, Path]]:
    return [(p.relative_to(SRC).parts[0].removesuffix(".py"), p) for p in SRC.rglob("*.py")]


def test_imports_follow_the_design() -> None:
    """Every import of src/sphkit goes where DESIGN.md allows: methods never import each other
    (nor the registry), core imports no method, geometry holds no SPH."""
    bad = []
    for top, path in _files():
        assert top in ALLOWED, f"{path}: package {top!r} is not in the design's layout"
        for target in _imports(path) - {top}:
            if target not in ALLOWED[top]:
                bad.append(f"{path.relative_to(SRC)} imports sphkit.{target}")
    assert not bad, "\n".join(bad)


def test_no_oversized_files() -> None:
    """No file over 600 lines but the scene schema (a file that long holds two concerns)."""
    long = [f"{p.relative_to(SRC)}: {n}" for _t, p in _files()
            if (n := len(p.read_text().splitlines())) > 600 and p.name != "schema.py"]
    assert not long, long


def test_minimum_image_only_in_pairs() -> None:
    """The pair-loop preamble's minimum image is written once, in core/pairs.py."""
    hits = [str(p.relative_to(SRC)) for _t, p in _files()
            if "/ L + 0.5)" in p.read_text() and p.name != "pairs.py"]
    assert not hits, hits


BASES = {"pressure": PressureSolver, "boundary": BoundaryModel, "viscosity": NonPressureForce,
         "vorticity": NonPressureForce, "surface_tension": NonPressureForce,
         "drag": NonPressureForce, "interface_viscosity": NonPressureForce,
         "interface_tension": NonPressureForce, "elasticity": Elasticity,
         "transport": NonPressureForce}
#: the package of a role's methods, where it is not named as the role
PACKAGES = {"elasticity": "solids", "interface_viscosity": "multiphase",
            "interface_tension": "multiphase"}


@pytest.mark.parametrize("method", [m for m in registry.methods() if m.target],
                         ids=lambda m: f"{m.role}-{m.name}")
def test_registered_methods_implement_their_role(method: registry.Method) -> None:
    """Each entry's class imports, lives in its role's package and inherits its Protocol."""
    cls = method.load()
    base = BASES.get(method.role)
    if base is not None:
        assert base in cls.__mro__, (cls, base)  # nominal: it inherits the defaults
        assert cls.name == method.name
    package = method.target.split(".")[1]
    expected = "boundary" if method.role.startswith("boundary") else method.role
    assert package == PACKAGES.get(method.role, expected)


def test_schema_choices_are_the_registry() -> None:
    """The scene schema offers exactly the registered methods of each role (plus "none" for
    the optional forces), in registration order."""
    fields = {"pressure": (schema.PressureConfig, "method"),
              "boundary": (schema.BoundaryConfig, "method"),
              "boundary_pressure": (schema.BoundaryConfig, "pressure"),
              "viscosity": (schema.ViscosityConfig, "method"),
              "vorticity": (schema.VorticityConfig, "method"),
              "surface_tension": (schema.SurfaceTensionConfig, "method"),
              "drag": (schema.DragConfig, "method"),
              "interface_viscosity": (schema.InterfaceViscosityConfig, "method"),
              "interface_tension": (schema.InterfaceTensionConfig, "method"),
              "elasticity": (schema.ElasticityConfig, "method"),
              "transport": (schema.TransportConfig, "method")}
    assert set(fields) == set(registry.ROLES)
    for role, (model, name) in fields.items():
        choices = typing.get_args(model.model_fields[name].annotation)
        expected = registry.names(role)
        if (role in registry.OPTIONAL_ROLES or role in registry.SOLID_ROLES
                or role in registry.INTERFACE_ROLES or role in registry.CONFIGURATION_ROLES):
            expected = ("none", *expected)
        assert choices == expected, (role, choices, expected)


def test_splishsplash_numbers_are_unique_and_known() -> None:
    """SPlisHSPlasH's method numbers resolve to one method each."""
    for role in registry.ROLES:
        numbered = [m for m in registry.methods(role) if m.splishsplash is not None]
        for m in numbered:
            assert registry.by_number(role, m.splishsplash) is m
    assert registry.by_number("pressure", 4).name == "dfsph"
    assert registry.by_number("viscosity", 6).name == "weiler2018"
    assert registry.by_number("boundary", 2).name == "bender2019"


def test_methods_command(capsys: pytest.CaptureFixture[str]) -> None:
    """``sphkit methods`` lists every registered method (table and JSON, by role); a bad role
    is a usage error (exit 2) naming the choices."""
    from sphkit.cli import main

    assert main(["methods"]) == 0
    out = capsys.readouterr().out
    for m in registry.methods():
        assert any(line.split()[:2] == [m.role, m.name] for line in out.splitlines()), m.name
    assert main(["methods", "--json", "--role", "viscosity"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["name"] for r in rows] == list(registry.names("viscosity"))
    weiler = next(r for r in rows if r["name"] == "weiler2018")
    assert weiler["splishsplash"] == 6 and "periodic" in weiler["capabilities"]
    assert main(["methods", "--role", "plasticity"]) == 2
    assert "invalid choice: 'plasticity'" in capsys.readouterr().err
