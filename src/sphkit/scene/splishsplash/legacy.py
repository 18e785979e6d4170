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
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sphkit.scene.splishsplash.methods import (
    JESKE2023_FIELDS,
    MATERIAL_NAMESPACES,
    VISCOSITY_METHODS,
)

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


def renumber(m: Mapping[str, Any], w: str, notes: list[str]) -> dict[str, Any]:
    """The material ``m`` (field path ``w``) with its method numbers in the numbering of 2.13
    and later: a copy, changed only for a flat material whose file shows an older numbering
    (module docstring); a note in ``notes`` for each number changed, and for each number read
    in the later numbering that meant another method before, where nothing in the file says
    which."""
    out = dict(m)
    if flat(m):
        _viscosity(m, out, w, notes)
        _surface_tension(m, out, w, notes)
    return out
