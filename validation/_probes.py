"""What the validation scripts share for their pressure probes."""

from __future__ import annotations

import math

import numpy as np

from sphkit.core.kernels import Kernel
from sphkit.simulation import Simulation

WET = 0.1  # least sum_j V_j W at a probe for it to read the fluid


class Probe:
    """Shepard-averaged fluid pressure at fixed points: at each point x_s,
    ``p_s = sum_j p_j V_j W(x_s - x_j) / sum_j V_j W(x_s - x_j)`` over the fluid particles
    (V_j = m_j / rho_j, the simulation's kernel and support), 0 (dry) while
    ``sum_j V_j W`` < ``wet`` (a full neighbourhood gives 1, a point on a wall about 0.5):
    the probe of DualSPHysics' MeasureTool and TrixiParticles' interpolated pressure."""

    def __init__(self, points: np.ndarray, sim: Simulation, wet: float = WET) -> None:
        self.points = np.asarray(points, dtype=np.float64)  # (S, dim)
        st = sim.state
        self.kernel = Kernel(st.kid, st.h, self.points.shape[1])
        self.h = st.h
        self.wet = wet
        self.x_lo, self.x_hi = self.points[:, 0].min(), self.points[:, 0].max()

    def __call__(self, sim: Simulation) -> np.ndarray:
        """Pressure [Pa] at each point (0 where dry)."""
        f = sim.fluid
        x = np.asarray(f["x"])  # (dim, N)
        # only the particles within one support of the points' x range can reach them
        near = (x[0] - self.x_hi < self.h) & (self.x_lo - x[0] < self.h)
        x = x[:, near]
        V = np.asarray(f["m"])[near] / np.asarray(f["rho"])[near]
        p = np.asarray(f["p"])[near]
        d = self.points[:, :, None] - x[None]  # (S, dim, n)
        w = self.kernel.w(np.sqrt((d * d).sum(axis=1))) * V  # (S, n)
        s = w.sum(axis=1)
        return np.where(s >= self.wet, (w * p).sum(axis=1) / np.maximum(s, 1e-300), 0.0)


def window_mean(T: np.ndarray, p: np.ndarray, a: float, b: float) -> float:
    """Mean of the piecewise-linear interpolant of p over a <= T <= b (irregular samples
    weighted by the time they cover); NaN when the series does not span the window."""
    if T[0] > a or T[-1] < b:
        return math.nan
    t = np.concatenate([[a], T[(T > a) & (T < b)], [b]])
    q = np.interp(t, T, p)
    return float(np.sum(0.5 * (q[1:] + q[:-1]) * np.diff(t)) / (b - a))
