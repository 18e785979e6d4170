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

A SPlisHSPlasH scene (:class:`NativeScene`) may also be varied in its own field names, as its
users write them: ``Fluid.viscosity``, ``Configuration.particleRadius``,
``RigidBodies.0.translation.1``, ``FluidBlocks.0.end.1``. Such a path (its first part one of
the file's top-level blocks) is set in the file's JSON, which is then translated as
``sphkit run`` translates it; the translated scene's own paths can be varied beside it. A
field the file does not write (left to SPlisHSPlasH's default) can be varied in a block it
writes. Such a field is an integer one where the translation accepts whole numbers only
(``Configuration.DFSPH.maxIterations``), else a float one, however the file writes its value
(SPlisHSPlasH's files write 2 for 2.0). A SPlisHSPlasH path whose two ends of the range give
the same translated scene (a field sphkit ignores for this scene, e.g.
``Configuration.stiffness`` of a DFSPH scene, or a misspelt one) is refused.
"""

from __future__ import annotations

import copy
import math
import os
import re
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sphkit.scene.files import read_scene_mapping, scene_from_dict
from sphkit.scene.schema import Scene, SceneError, clip
from sphkit.scene.splishsplash import is_splishsplash

__all__ = ["NativeScene", "VarySpec", "default_specs", "parse_vary", "sample_values",
           "variant_scene"]

_BRACKET = re.compile(r"\[(\d+)\]")


@dataclass(frozen=True)
class VarySpec:
    """One varied number: its ``path`` (dot form), and ``low``/``high`` or ``choices``."""

    path: str
    low: float | None = None
    high: float | None = None
    choices: tuple[float, ...] | None = None
    integer: bool = False
    #: the path names a field of the SPlisHSPlasH file (:class:`NativeScene`), not of sphkit's
    #: scene model
    native: bool = False

    def text(self) -> str:
        """The spec as it is written on the command line."""
        if self.choices is not None:
            return f"{self.path}=" + ",".join(f"{v:g}" for v in self.choices)
        return f"{self.path}={self.low:g}:{self.high:g}"

    def as_dict(self) -> dict[str, Any]:
        """JSON form (provenance)."""
        d: dict[str, Any] = {"path": self.path, "integer": self.integer}
        if self.native:
            d["format"] = "splishsplash"
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


@dataclass(frozen=True)
class NativeScene:
    """A SPlisHSPlasH scene file as written (its parsed JSON and its path), for ``--vary`` paths
    in its own field names (module docstring)."""

    data: Mapping[str, Any]
    path: Path

    @staticmethod
    def of(src: str | os.PathLike[str]) -> NativeScene | None:
        """The scene file or built-in scene ``src`` if it is in SPlisHSPlasH's format, else
        None."""
        found = read_scene_mapping(src)
        return NativeScene(*found) if found is not None and is_splishsplash(found[0]) else None

    def names(self, parts: Sequence[str]) -> bool:
        """Whether the path ``parts`` starts with one of the file's top-level blocks."""
        return bool(parts) and parts[0] in self.data

    def scene(self, values: Mapping[str, float | int]) -> Scene:
        """The file with ``values`` (its own paths -> numbers) set, translated (the file's
        warnings were shown when it was loaded and are not repeated for every variant)."""
        data = copy.deepcopy(dict(self.data))
        _assign(data, values)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return scene_from_dict(data, self.path)


def _assign(data: Any, values: Mapping[str, float | int]) -> None:
    """Set each path of ``values`` in the dict ``data`` (paths checked by :func:`parse_vary`)."""
    for path, value in values.items():
        parts = _parts(path)
        parent = _lookup(data, parts[:-1], path) if len(parts) > 1 else data
        key: Any = int(parts[-1]) if isinstance(parent, list) else parts[-1]
        parent[key] = value


def parse_vary(spec: str, base: Scene | Mapping[str, Any],
               native: NativeScene | None = None) -> VarySpec:
    """Parse ``PATH=LO:HI`` or ``PATH=V1,V2,...`` against the scene ``base`` (or, for a path
    that starts with one of its blocks, against the SPlisHSPlasH file ``native``); SceneError
    naming the path, the value and what was expected."""
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
    own = native is not None and native.names(parts)
    if native is not None and not own and parts[0] not in data:
        raise SceneError(
            f"--vary {clip(spec)}: path {parts[0]!r}: no field {parts[0]!r}; expected one of "
            f"the SPlisHSPlasH file's blocks ({', '.join(sorted(map(str, native.data)))}) or "
            f"of sphkit's scene ({', '.join(sorted(map(str, data)))})")
    if not (own and _unwritten(native, parts, spec)):  # a field the file leaves to its default
        current = _lookup(native.data if own else data, parts, spec)
        if isinstance(current, bool) or not isinstance(current, (int, float)):
            raise SceneError(f"--vary {clip(spec)}: {path} is {clip(current)}; expected a path "
                             "to a number of the scene")
        integer = isinstance(current, int)
    if ":" in values:
        lo_text, _, hi_text = values.partition(":")
        lo, hi = _number(lo_text, spec, path), _number(hi_text, spec, path)
        if hi < lo:
            raise SceneError(f"--vary {clip(spec)}: {path}: the range {lo:g}:{hi:g} is "
                             "reversed; expected LO <= HI")
        ends: tuple[float, ...] = (lo, hi)
    else:
        items = [s for s in values.split(",") if s.strip()]
        if not items:
            raise SceneError(f"--vary {clip(spec)}: {path}: no values; expected LO:HI or "
                             "V1,V2,...")
        ends = tuple(_number(s, spec, path) for s in items)
    if own:  # SPlisHSPlasH's JSON writes 2 for 2.0: its fields' type is the translation's
        assert native is not None
        integer = _integer_field(native, path, ends[0])
    if integer and any(v != int(v) for v in ends):
        raise SceneError(f"--vary {clip(spec)}: {path} is an integer field; expected integer "
                         "values")
    vs = (VarySpec(path, low=ends[0], high=ends[1], integer=integer, native=own)
          if ":" in values else VarySpec(path, choices=ends, integer=integer, native=own))
    return _effective(vs, native, spec)


def _integer_field(native: NativeScene, path: str, value: float) -> bool:
    """Whether the SPlisHSPlasH field ``path`` takes integers only: the file translates with
    ``floor(value)`` but not with ``floor(value) + 0.5``."""
    whole = math.floor(value)
    try:
        native.scene({path: whole + 0.5})
    except SceneError:
        try:
            native.scene({path: int(whole)})
        except SceneError:
            return False
        return True
    return False


def _unwritten(native: NativeScene | None, parts: Sequence[str], spec: str) -> bool:
    """Whether ``parts`` names a field that the SPlisHSPlasH file does not write, in a block it
    does write (``Configuration.stiffness`` of a file without it)."""
    if native is None or len(parts) < 2:
        return False
    parent = _lookup(native.data, parts[:-1], spec)
    return isinstance(parent, Mapping) and parts[-1] not in parent


def _effective(vs: VarySpec, native: NativeScene | None, spec: str) -> VarySpec:
    """``vs``, after checking that a SPlisHSPlasH path changes the translated scene: the
    smallest and largest value it can draw must give different scenes (SceneError naming the
    path otherwise: sphkit ignores that field for this scene)."""
    ends = (vs.low, vs.high) if vs.choices is None else (min(vs.choices), max(vs.choices))
    if not vs.native or native is None or ends[0] == ends[1]:
        return vs
    cast = int if vs.integer else float
    try:
        a, b = (native.scene({vs.path: cast(v)}).model_dump(mode="json") for v in ends)
    except SceneError as e:
        raise SceneError(f"--vary {clip(spec)}: {e}") from None
    if a == b:
        raise SceneError(f"--vary {clip(spec)}: {vs.path}: {ends[0]:g} and {ends[1]:g} give the "
                         "same scene; sphkit does not use this SPlisHSPlasH field for this "
                         "scene (its methods or blocks do not read it); expected a field that "
                         "changes the simulation")
    return vs


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


def variant_scene(base: Scene, values: Mapping[str, float | int],
                  native: NativeScene | None = None,
                  adjust: Callable[[Scene], None] | None = None) -> Scene:
    """``base`` with ``values`` (path -> number) set, validated like a scene file. Paths of the
    SPlisHSPlasH file ``native`` are set in it first and the file translated anew, then
    ``adjust`` (the command's end time and frame rate, which ``base`` has already) applied to
    it, then sphkit's paths set."""
    theirs = {p: v for p, v in values.items() if native is not None and native.names(_parts(p))}
    shown = ", ".join(f"{p}={v:.6g}" for p, v in values.items())
    if theirs:
        assert native is not None
        try:
            start = native.scene(theirs)
        except SceneError as e:
            raise SceneError(f"variant ({shown}): {e}") from None
        if adjust is not None:
            adjust(start)
    else:
        start = base
    data = start.model_dump(mode="json")  # a new dict: setting paths leaves base as it is
    _assign(data, {p: v for p, v in values.items() if p not in theirs})
    try:
        return scene_from_dict(data)
    except SceneError as e:
        raise SceneError(f"variant ({shown}): {e}") from None
