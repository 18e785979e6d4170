"""A sinking rigid body's landing, tracked step by step (shared by the 2D and 3D rigid tests)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Landing:
    """``lowest``: the lowest corner height ever [m]; ``landed``: the time it first came within
    ``0.1 r`` of the floor (None if never); ``vmax``: the fastest fluid particle after that;
    ``final``: the lowest corner height at the end."""

    lowest: float
    landed: float | None
    vmax: float
    final: float


def track_landing(sim, body, corners: np.ndarray, until: float, r: float) -> Landing:
    """Step ``sim`` to ``until``, following the body's ``corners`` (3, K) in its body frame."""
    lowest, landed, vmax, low = np.inf, None, 0.0, np.inf
    while sim.time < until:
        st = sim.step()
        low = float((body.c[:, None] + body.R @ corners)[1].min())
        lowest = min(lowest, low)
        if landed is None and low < 0.1 * r:
            landed = sim.time
        if landed is not None:
            vmax = max(vmax, st.max_velocity)
    return Landing(lowest, landed, vmax, low)
