"""The check of the methods' numeric parameters: one place that refuses a NaN, an infinity, a
string or a number out of range given to a method's constructor through the API, with a message
that names the parameter (scene files are checked earlier, by the scene schema)."""

from __future__ import annotations

import math
from typing import Any


def checked_number(what: str, value: Any, lo: float = 0.0, hi: float = math.inf,
                   expected: str = "a finite number >= 0") -> float:
    """``value`` as a float when it is a finite number in ``[lo, hi]``; otherwise a
    ``ValueError`` that names the parameter ``what`` (e.g. ``"surface tension (he2014):
    coefficient"``), the value and ``expected``. The one check of the methods' numeric
    parameters (a NaN, an infinity, a string or a negative coefficient given through the API)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{what}: {value!r}; expected {expected}")
    return v
