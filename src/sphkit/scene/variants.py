"""Randomised variants of a scene: ``--vary PATH=LO:HI`` (or ``PATH=V1,V2,...``).

A *path* names one number of the scene in its dict form (:meth:`Scene.model_dump`), its parts
separated by dots, list entries by their index: ``fluid_blocks.0.end.1``,
``materials.0.viscosity.coefficient``, ``configuration.particle_radius``,
``meshes.0.translation.0``. The form the error messages use, ``fluid_blocks[0].end[1]``, is
accepted too. ``LO:HI`` draws uniformly from [LO, HI] (an integer field: an integer in [LO, HI]
inclusive); ``V1,V2,...`` picks one of the listed numbers with equal probability. NaN and
Infinity are refused.

Variant ``k`` of a seed draws from its own generator, ``numpy.random.default_rng([seed, k])``,
its specs in the order given: its values depend on the seed, ``k`` and the specs, never on how
many variants are drawn, so a rerun with a larger ``--count`` keeps the first variants. Every
variant passes the normal scene validation (:func:`sphkit.scene.files.scene_from_dict`); a bad
value is a :class:`~sphkit.scene.schema.SceneError` naming the path, the value and what was
expected.
"""

from __future__ import annotations

import copy
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sphkit.scene.files import scene_from_dict
from sphkit.scene.schema import Scene, SceneError, clip

__all__ = ["VarySpec", "default_specs", "parse_vary", "sample_values", "variant_scene"]

_BRACKET = re.compile(r"\[(\d+)\]")


@dataclass(frozen=True)
class VarySpec:
    """One varied number: its ``path`` (dot form), and ``low``/``high`` or ``choices``."""

    path: str
    low: float | None = None
    high: float | None = None
    choices: tuple[float, ...] | None = None
    integer: bool = False

    def text(self) -> str:
        """The spec as it is written on the command line."""
        if self.choices is not None:
            return f"{self.path}=" + ",".join(f"{v:g}" for v in self.choices)
        return f"{self.path}={self.low:g}:{self.high:g}"

    def as_dict(self) -> dict[str, Any]:
        """JSON form (provenance)."""
        d: dict[str, Any] = {"path": self.path, "integer": self.integer}
        if self.choices is not None:
            d["choices"] = list(self.choices)
        else:
            d["low"], d["high"] = self.low, self.high
        return d

    def draw(self, rng: np.random.Generator) -> float | int:
        """One value from ``rng``."""
        if self.choices is not None:
            v = self.choices[int(rng.integers(len(self.choices)))]
            return int(v) if self.integer else float(v)
        assert self.low is not None and self.high is not None
        if self.integer:
            return int(rng.integers(int(self.low), int(self.high) + 1))
        return float(self.low + (self.high - self.low) * rng.random())


def _number(text: str, spec: str, path: str) -> float:
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not math.isfinite(v):
        raise SceneError(f"--vary {clip(spec)}: {path}: got {clip(text.strip())}; expected a "
                         "finite number")
    return v


def _parts(path: str) -> list[str]:
    """``a[0].b`` and ``a.0.b`` -> ``["a", "0", "b"]``."""
    return [p for p in _BRACKET.sub(r".\1", path.strip()).split(".") if p != ""]


def _lookup(data: Any, parts: Sequence[str], spec: str) -> Any:
    """The value at ``parts`` in the scene dict; SceneError naming the first bad part."""
    node = data
    for i, part in enumerate(parts):
        where = ".".join(parts[: i + 1])
        if isinstance(node, Mapping):
            if part not in node:
                keys = ", ".join(sorted(str(k) for k in node)) or "(none)"
                raise SceneError(f"--vary {clip(spec)}: path {where!r}: no field {part!r}; "
                                 f"expected one of: {keys}")
            node = node[part]
        elif isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise SceneError(f"--vary {clip(spec)}: path {where!r}: got {part!r}; expected "
                                 f"a list index from 0 to {len(node) - 1}" if node else
                                 f"--vary {clip(spec)}: path {where!r}: the list is empty")
            node = node[int(part)]
        else:
            raise SceneError(f"--vary {clip(spec)}: path {where!r}: "
                             f"{'.'.join(parts[:i]) or 'the scene'} is {clip(node)}, not a "
                             "group of fields or a list")
    return node


def parse_vary(spec: str, base: Scene | Mapping[str, Any]) -> VarySpec:
    """Parse ``PATH=LO:HI`` or ``PATH=V1,V2,...`` against the scene ``base``; SceneError naming
    the path, the value and what was expected."""
    data = base.model_dump(mode="json") if isinstance(base, Scene) else base
    if "=" not in spec:
        raise SceneError(f"--vary {clip(spec)}: expected PATH=LO:HI or PATH=V1,V2,... , e.g. "
                         "fluid_blocks.0.end.1=0.6:1.0")
    path_text, _, values = spec.partition("=")
    parts = _parts(path_text)
    if not parts:
        raise SceneError(f"--vary {clip(spec)}: empty path; expected a field path like "
                         "materials.0.viscosity.coefficient")
    path = ".".join(parts)
    current = _lookup(data, parts, spec)
    if isinstance(current, bool) or not isinstance(current, (int, float)):
        raise SceneError(f"--vary {clip(spec)}: {path} is {clip(current)}; expected a path to "
                         "a number of the scene")
    integer = isinstance(current, int)
    if ":" in values:
        lo_text, _, hi_text = values.partition(":")
        lo, hi = _number(lo_text, spec, path), _number(hi_text, spec, path)
        if hi < lo:
            raise SceneError(f"--vary {clip(spec)}: {path}: the range {lo:g}:{hi:g} is "
                             "reversed; expected LO <= HI")
        if integer and (lo != int(lo) or hi != int(hi)):
            raise SceneError(f"--vary {clip(spec)}: {path} is an integer field; expected "
                             "integer bounds")
        return VarySpec(path, low=lo, high=hi, integer=integer)
    items = [s for s in values.split(",") if s.strip()]
    if not items:
        raise SceneError(f"--vary {clip(spec)}: {path}: no values; expected LO:HI or "
                         "V1,V2,...")
    choices = tuple(_number(s, spec, path) for s in items)
    if integer and any(v != int(v) for v in choices):
        raise SceneError(f"--vary {clip(spec)}: {path} is an integer field; expected integers")
    return VarySpec(path, choices=choices, integer=integer)


def default_specs(base: Scene) -> list[VarySpec]:
    """What ``sphkit dataset`` varies when no ``--vary`` is given: each component of the first
    fluid block's ``end`` uniformly between ``start + 0.5 (end - start)`` and ``end`` (the
    block keeps its corner at ``start`` and shrinks to at least half its size per axis)."""
    if not base.fluid_blocks:
        raise SceneError("the scene has no fluid_blocks, so there is no default variation; "
                         "expected --vary PATH=LO:HI (e.g. materials.0.viscosity.coefficient="
                         "0.001:0.05)")
    b = base.fluid_blocks[0]
    return [VarySpec(f"fluid_blocks.0.end.{i}", low=s + 0.5 * (e - s), high=e)
            for i, (s, e) in enumerate(zip(b.start, b.end, strict=True))]


def sample_values(specs: Sequence[VarySpec], seed: int, k: int) -> dict[str, float | int]:
    """The values of variant ``k``: path -> value, drawn from ``default_rng([seed, k])``."""
    rng = np.random.default_rng([int(seed), int(k)])
    return {s.path: s.draw(rng) for s in specs}


def variant_scene(base: Scene, values: Mapping[str, float | int]) -> Scene:
    """``base`` with ``values`` (path -> number) set, validated like a scene file."""
    data = copy.deepcopy(base.model_dump(mode="json"))
    for path, value in values.items():
        parts = _parts(path)
        parent = _lookup(data, parts[:-1], path) if len(parts) > 1 else data
        key: Any = int(parts[-1]) if isinstance(parent, list) else parts[-1]
        parent[key] = value
    shown = ", ".join(f"{p}={v:.6g}" for p, v in values.items())
    try:
        return scene_from_dict(data)
    except SceneError as e:
        raise SceneError(f"variant ({shown}): {e}") from None
