"""A sinking rigid body's landing, tracked step by step (shared by the 2D and 3D rigid tests)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Landing:
    """``lowest``: the lowest corner height ever [m]; ``landed``: the time it first came within
    ``0.1 r`` of the floor (None if never); ``vmax``: the fastest fluid particle after that;
    ``final``: the lowest corner height at the end; ``rest_speed``: the median of the body's
    speed |v| over the steps of the last ``window`` seconds, and ``drift``: how far its centre
    moved over them (0 where no window was asked for); ``vmax_all``: the fastest fluid particle
    of the whole run."""

    lowest: float
    landed: float | None
    vmax: float
    final: float
    rest_speed: float = 0.0
    drift: float = 0.0
    vmax_all: float = 0.0


def track_landing(sim, body, corners: np.ndarray, until: float, r: float,
                  window: float = 0.0) -> Landing:
    """Step ``sim`` to ``until``, following the body's ``corners`` (3, K) in its body frame (and
    its speed and centre over the last ``window`` seconds)."""
    lowest, landed, vmax, low, vall = np.inf, None, 0.0, np.inf, 0.0
    speeds, c0 = [], None
    while sim.time < until:
        st = sim.step()
        vall = max(vall, st.max_velocity)
        if window > 0.0 and sim.time >= until - window:
            c0 = body.c.copy() if c0 is None else c0
            speeds.append(float(np.linalg.norm(body.v)))
        low = float((body.c[:, None] + body.R @ corners)[1].min())
        lowest = min(lowest, low)
        if landed is None and low < 0.1 * r:
            landed = sim.time
        if landed is not None:
            vmax = max(vmax, st.max_velocity)
    rest = float(np.median(speeds)) if speeds else 0.0
    drift = float(np.linalg.norm(body.c - c0)) if c0 is not None else 0.0
    return Landing(lowest, landed, vmax, low, rest, drift, vall)
