"""The translator's state and field readers: one SPlisHSPlasH scene being read.

:class:`Reader` holds the scene's top-level object, the labels of its messages, the fields it
did not know (reported in one ``UserWarning`` by
:func:`~sphkit.scene.splishsplash.from_splishsplash`), the notes (one warning each) and the map
from sphkit's field paths to SPlisHSPlasH's, by which a validation error of the translated scene
names the field the user wrote. Its value readers (:meth:`Reader.num`, :meth:`Reader.vec3`,
:meth:`Reader.flag`, ...) take absent fields as the given SPlisHSPlasH default and raise a
:class:`~sphkit.scene.schema.SceneError` naming the field path, the value and what was expected.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from sphkit.scene.schema import SceneError, clip


def _finite(v: Any) -> float | None:
    """``v`` as a finite float, or None (not a number, a boolean, NaN, +-Infinity, or an
    integer too large for a float)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    try:
        x = float(v)
    except OverflowError:
        return None
    return x if math.isfinite(x) else None


class Reader:
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
        """The error for ``value`` at field path ``where``, which should be ``expected``."""
        return SceneError(f"{self.label}: {where}: got {clip(value)}: expected {expected}")

    def unsupported(self, where: str, message: str) -> SceneError:
        """The error for a feature sphkit does not have (``message`` names it)."""
        return SceneError(f"{self.label}: {where}: {message}")

    def obj(self, parent: Mapping[str, Any], key: str, where: str) -> dict[str, Any]:
        """The object ``parent[key]`` (``{}`` when absent)."""
        v = parent.get(key)
        if v is None:
            return {}
        if not isinstance(v, Mapping):
            raise self.error(where, v, "an object {...}")
        return dict(v)

    def array(self, key: str) -> list[dict[str, Any]]:
        """The top-level array ``key`` of objects (``[]`` when absent)."""
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
        """The finite number ``obj[key]`` (``default`` when absent), optionally > 0 or >= 0."""
        v = obj.get(key)
        if v is None:
            return default
        x = _finite(v)
        if x is None:
            raise self.error(f"{where}.{key}", v, "a finite number")
        if positive and not x > 0:
            raise self.error(f"{where}.{key}", v, "a number > 0")
        if nonneg and not x >= 0:
            raise self.error(f"{where}.{key}", v, "a number >= 0")
        return x

    def integer(self, obj: Mapping[str, Any], key: str, where: str, default: int) -> int:
        """The integer ``obj[key]`` (``default`` when absent; 2.0 is read as 2)."""
        v = obj.get(key)
        if v is None:
            return default
        x = _finite(v)
        if x is None or x != int(x) or abs(x) > 2**53:
            raise self.error(f"{where}.{key}", v, "an integer")
        return int(x)

    def flag(self, obj: Mapping[str, Any], key: str, where: str, default: bool) -> bool:
        """The boolean ``obj[key]`` (``default`` when absent; non-zero integers are true)."""
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
        """The list of 3 finite numbers ``obj[key]`` (a copy of ``default`` when absent)."""
        v = obj.get(key)
        if v is None:
            return list(default)
        xs = [_finite(c) for c in v] if isinstance(v, (list, tuple)) and len(v) == 3 else None
        if xs is None or any(c is None for c in xs):
            raise self.error(f"{where}.{key}", v, "a list of 3 finite numbers")
        return [float(c) for c in xs]

    def text(self, obj: Mapping[str, Any], key: str, where: str, default: str) -> str:
        """The string ``obj[key]`` (``default`` when absent)."""
        v = obj.get(key)
        if v is None:
            return default
        if not isinstance(v, str):
            raise self.error(f"{where}.{key}", v, "a string")
        return v

    def collect_unknown(
        self, obj: Mapping[str, Any], where: str, known: set[str], quiet: set[str]
    ) -> None:
        """Record the keys of ``obj`` (at field path ``where``) in neither ``known`` nor
        ``quiet`` as unknown fields."""
        for key in obj:
            if key not in known and key not in quiet:
                name = str(key) if len(str(key)) <= 60 else clip(str(key), 60)
                self.unknown.append(f"{where}.{name}" if where else name)

    # -- field paths ---------------------------------------------------------------------------
    def origin_of(self, path: str) -> str | None:
        """The SPlisHSPlasH field path a sphkit field path was translated from, if known."""
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
