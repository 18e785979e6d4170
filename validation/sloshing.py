"""2D sloshing in a swaying or rolling rectangular tank against linear potential flow
(Faltinsen 1978; Faltinsen & Timokha 2009, "Sloshing", Ch. 5: the modal solution of forced sway
and roll).

A tank of inner length L = 1 m, filled to depth h = 0.5 m with water at rest (rho0 = 1000
kg/m^3, nu = 1e-6 m^2/s, g = 9.81 m/s^2), moves horizontally from rest with the displacement

    eta(t) = A (1 - cos(omega t)),  eta' = A omega sin(omega t),  eta'' = A omega^2 cos(omega t)

(it starts at rest with a finite acceleration: no impulsive start). The measure is the
free-surface elevation at the left wall.

Linear theory (incompressible, inviscid, irrotational, small amplitude; tank frame, s = x - the
left wall in [0, L], k_n = n pi / L). The surface ``zeta(s, t) = sum_n beta_n(t) cos(k_n s)``;
the frame's acceleration enters the dynamic free-surface condition as ``s eta''(t)``, whose
cosine series on [0, L] has the coefficients ``-4 / (L k_n^2)`` (odd n; 0 for even n), so each
odd mode is a forced oscillator

    beta_n'' + omega_n^2 beta_n = (omega_n^2 / g) (4 / (L k_n^2)) eta''(t),
    omega_n^2 = g k_n tanh(k_n h),

and from rest, with eta'' = A omega^2 cos(omega t),

    beta_n(t) = F_n / (omega_n^2 - omega^2) (cos(omega t) - cos(omega_n t)),
    F_n = (omega_n^2 / g) (4 / (L k_n^2)) A omega^2:

a forced part at the tank's frequency and a free part at each natural frequency, as large as
the forced one in mode 1 (no damping in the theory). Quasi-static check: sum_n 4 / (L k_n^2)
over odd n is L / 2, the wall rises by eta'' L / (2 g), the tilted plane's. The measured
elevation is a weighted mean over a strip at the wall (below), so the theory is averaged with
the same weight (each mode by its weighted mean of cos(k_n s), :func:`strip_factor`); 200 odd
modes.

SPH measure: the strip s < W2 at the wall weighted by phi(s) (1 to W1 = 0.05 m, a cos^2 ramp
to 0 at W2 = 0.15 m, in the tank's frame), ``Z(t) = sum_i V0_i phi(s_i) / int phi ds``: the
weighted mean height of the fluid over the strip from the particles in it (their rest volumes;
no surface detection; the ramp keeps a column of particles crossing the strip's edge from
jumping the sum). The elevation is its change since t = 0, antisymmetric part:
``zeta_w = ((Z_left(t) - Z_left(0)) - (Z_right(t) - Z_right(0))) / 2`` (the right wall's strip
mirrored). Sway excites only the odd modes, antisymmetric about the centre, so the theory's
zeta_w is the left wall's; the symmetric part that this removes is the even modes of second
order and the drift of the strips' packing at both walls alike: with the default (MLS) walls
the tank at rest is stirred (``--at-rest``) and the particles next to each wall thin out, so
the strips' rest volume falls by 1.5 particles' volume at 30 along L while the water does not
fall (validation/README.md, "The strips' drift at 30 along L"); what the two walls do
differently stays in zeta_w as noise. Column ``top``: the
highest particle's top within 2 spacings of the left wall against the theory at s = 0 (a
wave-probe measure; run-up along the wall and splashes spike it).
Peak: the largest |zeta_w| of the run against the theory's.

Amplitude and phase: a least-squares fit of zeta_w(t) over the run to ``c0 + a cos(omega t) + b
sin(omega t) + e^(-gamma t) (p cos(W t) + q sin(W t))`` (W and gamma by a grid search, W in
steps of 0.2 % of omega_1, gamma of 0.025 1/s; the rest linear): the forced response's amplitude
sqrt(a^2 + b^2) against the theory's ``sum_n F_n s_n / (omega_n^2 - omega^2)`` (s_n the strip
factor), its phase atan2(b, a) (theory 0: in phase with the acceleration below resonance), the
first mode's frequency W against omega_1, its amplitude sqrt(p^2 + q^2) against the theory's
free part (mostly mode 1) and its decay rate gamma (theory 0; with free-slip walls the fluid's
viscosity damps mode 1 at 2 nu k_1^2 = 2e-5 1/s, so what the fit finds is numerical dissipation;
the fit's grid is 0.025 1/s). Also the RMS of zeta_sim - zeta_theory over the run, over the
theory's largest |zeta|.

Setup: a box of boundary particles (``boxes``, 2 layers, open top, walls to h + 0.3 m),
Akinci walls, free-slip (the standard viscosity without its wall term), cubic spline, h = 4r.
The tank moves through the API, as the upper plate of ``validation/couette.py``: after every
step the wall particles are placed at x0 + eta(t) with velocity eta'(t) (``state.boundary``,
``x`` and ``v``; the solvers' divergence and density terms read the wall velocity) and the
boundary grid is rebuilt. sphkit has no scene-level way to prescribe a time-varying wall
motion: a kinematic rigid body moves with a constant velocity and angular velocity, animation
fields set fluid particles only. ``--frame tank``: the same problem in the tank's frame (walls
at rest, gravity (-eta''(t), -g)), exactly equivalent for a rigid translation; a cross-check of
the moving walls.

Solvers: DFSPH and IISPH (SPlisHSPlasH's tolerances, CFL step clamped to dt_max = 2 ms), WCSPH
(Tait, c = 10 sqrt(g h), 1 % compression at the floor; ``boundary.symmetric``: the wall term
V_b k_i, which does no work; with the default mirrored wall term it was unstable in this tank,
also at rest, see validation/README.md). Start: sphkit's default (hydrostatic,
relaxed; WCSPH settles before t = 0).

Cases (``--cases``): ``off`` omega = 0.7 omega_1, A = 0.02 m (forced response 2.4 cm in the
strip, crests to 4.7 cm with the free part, k_1 zeta 0.07-0.15: linear to 0.5-2 % in the
first harmonic); ``near`` omega = 0.9
omega_1, A = 0.005 m (forced 2.5 cm, the free and forced parts beat with period
2 pi / (omega_1 - omega) = 10 T_1: linear theory's limit is amplitude growth at resonance,
which damping and nonlinearity cap in a real tank).

Roll (``--motion roll``). The tank turns rigidly, counter-clockwise (the right wall rises),
about the axis point O above the floor's centre at the height ``--roll-axis-height`` (default
0: the floor's centre) by theta(t) = Theta (1 - cos(omega t)) (from rest, no impulsive start).
Tank coordinates: x in [-L/2, L/2] from the centre (s = x + L/2), z up from the still-water
level (floor z = -h), O at (0, d), d = the axis height - h. A tank point moves with
theta' (-(z - d), x). The absolute velocity potential Phi, written in tank coordinates, is
harmonic with Phi_x = -theta' (z - d) on the walls x = +-L/2 and Phi_z = theta' x on the floor;
on the free surface, linearised about z = 0 with zeta the elevation relative to the tank, the
kinematic condition zeta_t = Phi_z - theta' x and the dynamic one Phi_t + g (zeta + x theta) =
0 (the surface's height in the inertial frame is zeta + x theta to first order; the frame's
convective term is of second order). Write Phi = theta' Omega + sum_n R_n(t) cos(k_n s)
cosh(k_n (z + h)) / cosh(k_n h) with Omega the Stokes-Joukowski potential, harmonic with the
rigid normal velocity on the walls, the floor and the lid z = 0:

    Omega = -x (z - d) + sum_(odd n) 2 P_n sinh(k_n (z + h/2)) / (k_n cosh(k_n h/2)) cos(k_n s),
    P_n = (2/L) int x cos(k_n s) dx = -4 / (L k_n^2) (odd n; 0 for even n)

(Omega_x = -(z - d) on the walls, where sin(k_n s) = 0; Omega_z = -x + 2x = x at z = 0 and
z = -h). The natural modes carry zeta: zeta = sum_n beta_n cos(k_n s), beta_n' = k_n tanh(k_n
h) R_n. The dynamic condition projected on cos(k_n s) is R_n' + g beta_n + g P_n theta + Q_n
theta'' = 0, Q_n = (2/L) int Omega(x, 0) cos(k_n s) dx = P_n lambda_n, so

    beta_n'' + omega_n^2 beta_n = -(omega_n^2 / g) P_n (g theta + lambda_n theta''),
    lambda_n = d + (2 / k_n) tanh(k_n h / 2):

the sway equation with eta'' replaced by g theta (gravity's component along the tilted floor)
plus lambda_n theta'' (the axis's arm to the still-water level, d theta'', and the water's
rotational inertia, the Stokes-Joukowski share; the structure of the linear modal
equations of roll in Faltinsen et al. 2000 and Faltinsen & Timokha 2009, the coefficients
derived here, not copied). From rest, with p_n = -P_n = 4 / (L k_n^2),

    beta_n(t) = p_n Theta (1 - cos(omega_n t)) + C_n (cos(omega t) - cos(omega_n t)),
    C_n = (omega_n^2 / g) p_n Theta (lambda_n omega^2 - g) / (omega_n^2 - omega^2):

a mean tilt (sum p_n Theta = Theta L / 2 at the wall), a forced part (below resonance and with
lambda_n omega^2 < g, in antiphase with theta'': the water rises at the low wall) and free
parts. Roll, like sway, excites only the odd (antisymmetric) modes, so the antisymmetric strip
measure is the whole linear answer; it is taken in tank coordinates (the fluid's positions
turned back by -theta about O). Limits (:func:`theory_checks`, printed with ``--motion roll``
and asserted in tests/test_dambreak.py): (a) a slow roll, omega = 0.01 omega_1: the free
surface stays horizontal in the inertial frame, so the wall's elevation in tank coordinates is
(L/2) tan(theta) ~ (L/2) theta (the series: to 1.2e-3, its truncation at 200 odd modes, 1.0e-3
of the plain tilt; the free part is of order (omega / omega_n)^2), and the strip's mean is
theta (L/2 - <s>) (to 1.2e-4); (b) an axis far above the tank, d -> infinity with d Theta = A:
the tilt g theta = g A / d and the rotational inertia vanish and the roll is the sway eta = d
theta (at d = 1e4 m within 8e-5 of the sway series' largest value). No finite axis height makes
roll a sway for every mode (lambda_n depends on n); at d = -(2 / k_1) tanh(k_1 h / 2) (0.08 m
above the floor here) mode 1 is driven by the tilt alone, as by a sway with eta'' = g theta.
Case ``off`` (roll): omega = 0.7 omega_1, Theta = 0.02 rad about the floor's centre: forced
amplitude 19.08 mm in the strip (20.90 mm at the wall), mode-1 free 9.46 mm, mean tilt 8.95
mm, crests to 37.9 mm (k_1 zeta 0.12). The phase is the lag behind the theory's forced part.
``--frame tank`` with roll: walls at rest, gravity turned by -theta, (-g sin theta, -g cos
theta), set on ``state.gravity`` after every step, and the frame's Euler, centrifugal and
Coriolis accelerations added to the fluid by a non-pressure force appended to the
simulation's forces (:class:`RollFrame`, r from the axis, the rate and angular acceleration of
the step's start); exactly equivalent to the rotating walls for the continuum, a cross-check.

Run ``python validation/sloshing.py`` (``--per-l 30 60 120`` particles along L, ``--solvers
dfsph iisph wcsph``, ``--periods`` of the forcing (4), ``--quick``: DFSPH at 30 and 60,
``--save DIR`` / ``--load FILES`` the runs' time series; ``--motion roll``,
``--roll-axis-height``; ``--walls solved`` or ``symmetric``: the wall pressure
``boundary.solved`` / ``boundary.symmetric`` instead of the default; ``--at-rest``: the tank at
rest for the same time, its kinetic energy, centre of mass and the strips' drift). It prints
the table and saves ``validation/sloshing.png`` (sway) and
``validation/sloshing_roll.png`` (roll) when matplotlib is installed.
"""

from __future__ import annotations

import argparse
import functools
import logging
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from _plotting import pyplot

from sphkit.core.methods import NonPressureForce
from sphkit.core.state import SimState
from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

G = 9.81  # [m/s^2]
RHO0 = 1000.0  # [kg/m^3]
NU = 1e-6  # kinematic viscosity of water [m^2/s]
LENGTH = 1.0  # tank's inner length L [m]
DEPTH = 0.5  # still-water depth h [m]
W1, W2 = 0.05, 0.15  # the strip at the wall: weight 1 to W1, ramp to 0 at W2 [m]
AREA = 0.5 * (W1 + W2)  # int phi ds [m]
MODES = 200  # odd modes of the theory
SOLVERS = ("dfsph", "iisph", "wcsph")
#: case: (omega / omega_1, amplitude A [m])
CASES = {"off": (0.7, 0.02), "near": (0.9, 0.005)}
#: roll case: (omega / omega_1, Theta [rad]); run as ``--motion roll --cases off`` ("roll-off")
ROLL_CASES = {"off": (0.7, 0.02)}
ROLL_AXIS = 0.0  # default roll axis: the floor's centre (its height above the floor [m])
WALLS = ("default", "solved", "symmetric")  # --walls: the wall pressure (scene())


def natural(n: np.ndarray | int) -> np.ndarray:
    """omega_n [rad/s] of the tank: omega_n^2 = g k_n tanh(k_n h), k_n = n pi / L."""
    k = np.asarray(n, float) * math.pi / LENGTH
    return np.sqrt(G * k * np.tanh(k * DEPTH))


OMEGA1 = float(natural(1))


def motion(t: float, omega: float, amp: float) -> tuple[float, float, float]:
    """The tank's displacement, velocity and acceleration at t (module docstring)."""
    return (amp * (1.0 - math.cos(omega * t)), amp * omega * math.sin(omega * t),
            amp * omega**2 * math.cos(omega * t))


def window(s: np.ndarray) -> np.ndarray:
    """The strip's weight phi(s): 1 for s <= W1, a cos^2 ramp to 0 at s = W2, 0 beyond."""
    u = np.clip((np.asarray(s, float) - W1) / (W2 - W1), 0.0, 1.0)
    return np.cos(0.5 * math.pi * u) ** 2


def strip_factor(k: np.ndarray) -> np.ndarray:
    """The weighted mean of cos(k s) over the strip, int phi cos(k s) ds / int phi ds (trapezoid
    rule on 4001 points)."""
    s = np.linspace(0.0, W2, 4001)
    phi = window(s)
    return np.trapezoid(phi[None, :] * np.cos(np.outer(k, s)), s, axis=1) / np.trapezoid(phi, s)


@functools.cache
def _odd_strip_factors() -> np.ndarray:
    """:func:`strip_factor` of the theory's odd modes (computed once)."""
    return strip_factor(np.arange(1, 2 * MODES, 2) * math.pi / LENGTH)


def modes(omega: float, amp: float, at_wall: bool = False, roll_axis: float | None = None
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Linear theory's odd modes at the left wall (module docstring): omega_n, the constant
    part m_n (roll: the mean tilt's), the forced part's coefficient c_n of cos(omega t) and the
    free part's of -cos(omega_n t), each times the mode's strip factor (``at_wall``: at s = 0).
    Sway (``roll_axis`` None): eta = amp (1 - cos omega t) [m]; roll: theta = amp (1 - cos
    omega t) [rad] about the axis ``roll_axis`` [m] above the floor's centre."""
    n = np.arange(1, 2 * MODES, 2)
    k = n * math.pi / LENGTH
    wn = natural(n)
    s = np.ones_like(k) if at_wall else _odd_strip_factors()
    p = 4.0 / (LENGTH * k**2)  # -P_n, the cosine coefficient of -(s - L/2)
    if roll_axis is None:
        m = np.zeros_like(k)
        c = (wn**2 / G) * p * amp * omega**2 / (wn**2 - omega**2)
    else:
        lam = (roll_axis - DEPTH) + 2.0 * np.tanh(0.5 * k * DEPTH) / k
        m = p * amp
        c = (wn**2 / G) * p * amp * (lam * omega**2 - G) / (wn**2 - omega**2)
    return wn, m * s, c * s, (m + c) * s


def theory(t: np.ndarray, omega: float, amp: float, at_wall: bool = False,
           roll_axis: float | None = None) -> tuple[np.ndarray, float, float]:
    """Linear theory's elevation at the left wall, zeta_w(t) [m] (the strip's weighted mean;
    ``at_wall``: at s = 0), its forced amplitude (coefficient of cos(omega t)) and its mode-1
    free amplitude (coefficient of -cos(omega_1 t)) (module docstring; ``roll_axis``:
    :func:`modes`)."""
    wn, m, c, e = modes(omega, amp, at_wall, roll_axis)
    t = np.asarray(t, float)
    z = m.sum() + c.sum() * np.cos(omega * t) - (e[:, None] * np.cos(np.outer(wn, t))).sum(axis=0)
    return z, float(c.sum()), float(e[0])


def theory_checks() -> dict:
    """The roll series against its limits (module docstring), as relative errors: ``slow``,
    a slow roll (omega = 0.01 omega_1, theta up to 0.04 rad) at the wall against the tilted
    plane (L/2) theta(t) over the first half period (the free part is O((omega /
    omega_n)^2)); ``strip``, the same in the strip's mean against the plane's mean over the
    strip, theta (L/2 - <s>); ``sway``, roll about an axis 1e4 m above the floor with theta =
    A / 1e4 against sway with A = 2 cm at 0.7 omega_1 over 4 periods (the tilt g theta and the
    fluid's rotational inertia vanish as 1 / height); ``quasi``, the sway series' quasi-static
    tilt (sum over odd n of 4 / (L k_n^2) against L / 2)."""
    om = 0.01 * OMEGA1
    t = np.linspace(0.05, 0.5, 10) * 2.0 * math.pi / om
    th = 0.02 * (1.0 - np.cos(om * t))
    slow = theory(t, om, 0.02, at_wall=True, roll_axis=0.0)[0] / (0.5 * LENGTH * th) - 1.0
    u = np.linspace(0.0, W2, 4001)
    mean_s = np.trapezoid(window(u) * u, u) / np.trapezoid(window(u), u)
    strip = theory(t, om, 0.02, roll_axis=0.0)[0] / ((0.5 * LENGTH - mean_s) * th) - 1.0
    omega = 0.7 * OMEGA1
    tt = np.linspace(0.0, 8.0 * math.pi / omega, 801)
    zs = theory(tt, omega, 0.02)[0]
    zr = theory(tt, omega, 0.02 / 1e4, roll_axis=1e4)[0]
    k = np.arange(1, 2 * MODES, 2) * math.pi / LENGTH
    return {"slow": float(np.abs(slow).max()), "strip": float(np.abs(strip).max()),
            "sway": float(np.abs(zr - zs).max() / np.abs(zs).max()),
            "quasi": float((4.0 / (LENGTH * k**2)).sum() / (0.5 * LENGTH) - 1.0)}


def scene(solver: str, per_l: int, dt_max: float = 2e-3, nu: float = NU,
          walls: str = "default") -> Scene:
    """The tank of the module docstring: ``per_l`` particles along L; ``nu`` the kinematic
    viscosity [m^2/s]; ``walls`` the wall pressure: "default" (MLS; WCSPH symmetric),
    "solved" (``boundary.solved``) or "symmetric" (``boundary.symmetric``)."""
    if walls not in WALLS:
        raise ValueError(f"walls: {walls!r}; expected one of {list(WALLS)}")
    r = LENGTH / (2 * per_l)
    pressure: dict = {"method": solver}
    if solver == "wcsph":
        c = 10.0 * math.sqrt(G * DEPTH)
        pressure.update(equation="tait", exponent=7.0, stiffness=RHO0 * c * c / 7.0)
    data: dict = {
        "name": f"sloshing-{solver}",
        "configuration": {
            "dim": 2, "particle_radius": r, "gravity": [0.0, -G],
            "pressure": pressure,
            "time": {"dt": 1e-4, "dt_min": 1e-7, "dt_max": dt_max},
            # WCSPH: the energy-consistent wall term (the mirrored one pumped energy into the
            # tank at rest until it blew up, validation/README.md)
            "boundary": {"symmetric": solver == "wcsph" or walls == "symmetric",
                         "solved": walls == "solved"},
        },
        "materials": [{"density0": RHO0, "viscosity": {"method": "standard",
                                                       "coefficient": nu}}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [LENGTH, DEPTH]}],
        "boxes": [{"min": [0.0, 0.0], "max": [LENGTH, DEPTH + 0.3], "layers": 2,
                   "open_top": True}],
    }
    return Scene.model_validate(data)


class RollFrame(NonPressureForce):
    """The rolling tank's frame's inertial accelerations on the fluid (``--frame tank`` with
    roll; gravity turned by -theta is set on ``state.gravity``): Euler -theta'' z x r,
    centrifugal theta'^2 r and Coriolis -2 theta' z x v, r from the axis (ox, oz), with the
    rate and angular acceleration that :func:`run` sets for the step."""

    name = "roll-frame"

    def __init__(self, ox: float, oz: float) -> None:
        self.ox, self.oz = ox, oz
        self.rate = self.accel = 0.0

    def apply(self, state: SimState, dt: float) -> None:
        """Add the three accelerations to ``state.fluid['a']`` (whole arrays)."""
        f = state.fluid
        x, v, a = f["x"], f["v"], f["a"]
        rx, rz = x[0] - self.ox, x[1] - self.oz
        w, dw = self.rate, self.accel
        a[0] += dw * rz + w * w * rx + 2.0 * w * v[1]
        a[1] += -dw * rx + w * w * rz - 2.0 * w * v[0]


def run(sim: Simulation, omega: float, amp: float, t_end: float, frame: str = "moving",
        roll_axis: float | None = None) -> dict:
    """Step to t_end moving the tank (``frame`` 'moving': the wall particles through the API;
    'tank': walls at rest, gravity (-eta'', -g)); per step t, zeta_w (antisymmetric strip
    measure), the left strip's change alone, the highest particle's top next to the left wall
    and the tank's displacement. ``roll_axis``: roll instead of sway, theta = amp (1 - cos
    omega t) [rad] about the point (L/2, roll_axis) (the height above the floor [m]), the
    measures in the tank's coordinates (frame 'tank': gravity (-g sin theta, -g cos theta)
    and :class:`RollFrame`'s accelerations)."""
    st = sim.state
    f = sim.fluid
    b = st.boundary
    bx0 = b["x"].copy()
    bn0 = b["wall_normal"].copy() if "wall_normal" in b.fields else None
    ox, oz = 0.5 * LENGTH, 0.0 if roll_axis is None else float(roll_axis)
    inertial = None
    if roll_axis is not None and frame == "tank":  # the frame's accelerations on the fluid
        inertial = RollFrame(ox, oz)
        sim.forces.append(inertial)
        if len(sim.world.force_roles) < len(sim.forces):  # the same list as the world's
            sim.world.force_roles.append("frame")

    def strips(shift: float, angle: float = 0.0) -> tuple[float, float, float]:
        """Weighted rest volume in the strips at the left and right walls, and the top of
        the two columns of particles next to the left wall (tank coordinates: the fluid's
        positions shifted back by the sway ``shift`` or rotated back by the roll ``angle``
        about the axis)."""
        if angle == 0.0:
            s, z = f["x"][0] - shift, f["x"][1]
        else:
            c, sn = math.cos(angle), math.sin(angle)
            dx, dz = f["x"][0] - ox, f["x"][1] - oz
            s, z = ox + c * dx + sn * dz, oz - sn * dx + c * dz
        top = s < 4.0 * st.r
        return (float(np.dot(f["V0"], window(s))), float(np.dot(f["V0"], window(LENGTH - s))),
                float(z[top].max() + st.r) if top.any() else 0.0)

    left0, right0, top0 = strips(0.0)
    ts, zs, zl, tops, etas = [0.0], [0.0], [0.0], [0.0], [0.0]
    if frame == "tank" and inertial is None:
        st.gravity[0] = -motion(0.0, omega, amp)[2]
    elif inertial is not None:
        inertial.accel = motion(0.0, omega, amp)[2]
    while sim.time < t_end - 1e-12:
        sim.step()
        t = sim.time
        x, v, a = motion(t, omega, amp)
        shift = angle = 0.0
        if inertial is not None:  # the tank's frame of the roll
            st.gravity[0], st.gravity[1] = -G * math.sin(x), -G * math.cos(x)
            inertial.rate, inertial.accel = v, a
        elif roll_axis is not None:  # rigid rotation by x about (ox, oz), angular velocity v
            c, sn = math.cos(x), math.sin(x)
            dx, dz = bx0[0] - ox, bx0[1] - oz
            b["x"][0] = ox + c * dx - sn * dz
            b["x"][1] = oz + sn * dx + c * dz
            b["v"][0] = -v * (b["x"][1] - oz)
            b["v"][1] = v * (b["x"][0] - ox)
            if bn0 is not None:  # box walls' normals (the no-slip wall term reads them)
                b["wall_normal"][0] = c * bn0[0] - sn * bn0[1]
                b["wall_normal"][1] = sn * bn0[0] + c * bn0[1]
            sim.boundary_model.rebuild(st)
            angle = x
        elif frame == "moving":
            b["x"][0] = bx0[0] + x
            b["v"][0] = v
            sim.boundary_model.rebuild(st)
            shift = x
        else:
            st.gravity[0] = -a
        left, right, top = strips(shift, angle)
        ts.append(t)
        zs.append(0.5 * ((left - left0) - (right - right0)) / AREA)
        zl.append((left - left0) / AREA)
        tops.append(top - top0)
        etas.append(x)
    return {"t": np.array(ts), "zeta": np.array(zs), "left": np.array(zl),
            "top": np.array(tops),
            "eta": np.array(etas), "steps": sim.step_count, "n": f.n}


def at_rest(sim: Simulation, t_end: float) -> dict:
    """The tank at rest (``--at-rest``) to t_end: per step the fluid's kinetic energy [J/m],
    its centre of mass's height [m], the strip measure's change at the left and right walls
    (:func:`run`'s ``left``, [m]), the particles within 2r of each side wall and those outside
    the tank (behind a wall or below the floor)."""
    f, r = sim.fluid, sim.state.r
    v0 = f["V0"]

    def sample() -> list[float]:
        s, z = f["x"][0], f["x"][1]
        return [sim.time, 0.5 * float(np.dot(f["m"], (f["v"] ** 2).sum(axis=0))),
                float(np.dot(f["m"], z) / f["m"].sum()), float(np.dot(v0, window(s))) / AREA,
                float(np.dot(v0, window(LENGTH - s))) / AREA,
                0.5 * float((s < 2.0 * r).sum() + (LENGTH - s < 2.0 * r).sum()),
                float(((s < 0.0) | (s > LENGTH) | (z < 0.0)).sum())]

    rows = [sample()]
    while sim.time < t_end - 1e-12:
        sim.step()
        rows.append(sample())
    a = np.array(rows)
    return {k: a[:, i] for i, k in enumerate(("t", "ke", "zcm", "left", "right", "column",
                                               "outside"))}


def rest_row(solver: str, per_l: int, walls: str, o: dict) -> str:
    """One line of the at-rest table: means over t >= 1 s (the start-up's first second left
    out) of the kinetic energy [J/m] (and its largest), the centre of mass's rise [mm], the
    strips' symmetric change [mm] (what the antisymmetric measure removes) and the RMS and
    largest antisymmetric change [mm] (what it keeps: the sway measure's noise at rest), the
    particles within 2r of a side wall (at t = 0 and mean), and the most outside the tank."""
    late = o["t"] >= 1.0
    dl, dr = 1000.0 * (o["left"] - o["left"][0]), 1000.0 * (o["right"] - o["right"][0])
    anti = 0.5 * (dl - dr)[late]
    return (f"rest {solver:>6s}{per_l:5d} {walls:>9s}  KE {o['ke'][late].mean():7.3f} "
            f"(max {o['ke'].max():7.3f}) J/m  zcm "
            f"{1000 * (o['zcm'][late].mean() - o['zcm'][0]):+6.2f} mm  strips sym "
            f"{0.5 * (dl + dr)[late].mean():+7.2f} mm  anti rms "
            f"{np.sqrt(np.mean(anti**2)):5.2f} max {np.abs(anti).max():5.2f} mm  column "
            f"{o['column'][0]:.0f} -> {o['column'][late].mean():5.2f}  outside "
            f"{o['outside'].max():.0f}")


def fit(t: np.ndarray, z: np.ndarray, omega: float) -> dict:
    """Least-squares fit of zeta(t) (module docstring): forced amplitude and phase [rad],
    free frequency W [rad/s], its amplitude and decay rate gamma [1/s]."""
    tu = np.linspace(t[0], t[-1], 1200)  # uniform in time: adaptive steps weigh alike
    z = np.interp(tu, t, z)
    t = tu
    best = None
    for gamma in np.linspace(0.0, 1.0, 41):
        for w in np.linspace(0.85 * OMEGA1, 1.1 * OMEGA1, 126):
            e = np.exp(-gamma * t)
            M = np.stack([np.ones_like(t), np.cos(omega * t), np.sin(omega * t),
                          e * np.cos(w * t), e * np.sin(w * t)], axis=1)
            coef, *_ = np.linalg.lstsq(M, z, rcond=None)
            res = float(np.sum((M @ coef - z) ** 2))
            if best is None or res < best[0]:
                best = (res, gamma, w, coef)
    _, gamma, w, c = best
    return {"forced": math.hypot(c[1], c[2]), "phase": math.atan2(c[2], c[1]),
            "W": float(w), "free": math.hypot(c[3], c[4]), "gamma": float(gamma),
            "mean": float(c[0])}


def case_params(case: str) -> tuple[float, float, bool]:
    """omega / omega_1, the amplitude (sway [m], roll [rad]) and whether it is a roll case
    (named ``roll-<name>`` from :data:`ROLL_CASES`)."""
    if case.startswith("roll-"):
        ratio, amp = ROLL_CASES[case[5:]]
        return ratio, amp, True
    ratio, amp = CASES[case]
    return ratio, amp, False


def simulate(solver: str, per_l: int, case: str, periods: float, frame: str = "moving",
             nu: float = NU, roll_axis: float = ROLL_AXIS, walls: str = "default") -> dict | str:
    """One run; an error message if it blew up. A roll case (``roll-...``) turns about the
    point ``roll_axis`` [m] above the floor's centre; ``walls``: :func:`scene`."""
    ratio, amp, roll = case_params(case)
    omega = ratio * OMEGA1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(scene(solver, per_l, nu=nu, walls=walls))
    t0 = time.perf_counter()
    try:
        out = run(sim, omega, amp, periods * 2.0 * math.pi / omega, frame,
                  roll_axis if roll else None)
    except InstabilityError as e:
        return f"unstable at t = {sim.time:.3f} s: {str(e).splitlines()[0]}"
    out["wall"] = time.perf_counter() - t0
    if roll:
        out["axis"] = roll_axis
    return out


def measures(o: dict, case: str) -> dict:
    """Errors of one run against the theory (phase: the lag behind the theory's forced part,
    which is in antiphase with the acceleration in roll; ``mean``: the fit's constant against
    the theory's, the mean tilt's in roll, None in sway)."""
    ratio, amp, roll = case_params(case)
    axis = float(o["axis"]) if roll else None
    omega = ratio * OMEGA1
    zt, forced, free = theory(o["t"], omega, amp, roll_axis=axis)
    fs = fit(o["t"], o["zeta"], omega)
    lag = fs["phase"] - (0.0 if forced > 0 else math.pi)
    lag = (lag + math.pi) % (2.0 * math.pi) - math.pi
    mean = float(modes(omega, amp, roll_axis=axis)[1].sum()) if roll else 0.0
    return {"amp": fs["forced"] / abs(forced) - 1.0, "phase": math.degrees(lag),
            "W": fs["W"] / OMEGA1 - 1.0, "free": fs["free"] / abs(free) - 1.0,
            "gamma": fs["gamma"],
            "rms": float(np.sqrt(np.mean((o["zeta"] - zt) ** 2)) / np.abs(zt).max()),
            "top": fit(o["t"], o["top"], omega)["forced"]
            / abs(theory(o["t"][:1], omega, amp, at_wall=True, roll_axis=axis)[1]) - 1.0,
            "peak": float(np.abs(o["zeta"]).max() / np.abs(zt).max()) - 1.0,
            "mean": fs["mean"] / mean - 1.0 if roll else None,
            "forced_theory": forced, "forced_sim": fs["forced"]}


def row(key: tuple, o: dict | str) -> str:
    """One line of the table."""
    case, solver, per_l = key
    head = f"{case:8s} {solver:>6s}{per_l:5d}"
    if isinstance(o, str):
        return f"{head}  {o}"
    m = measures(o, case)
    return (f"{head}{o['n']:7d}{o['steps']:7d}{1000 * m['forced_sim']:7.2f}mm"
            f"{m['amp']:+9.1%}{m['phase']:+7.1f}d{m['W']:+8.1%}{m['free']:+9.1%}"
            f"{m['gamma']:7.2f}{m['rms']:8.1%}{m['peak']:+8.1%}{m['top']:+9.1%}{o['wall']:7.1f}"
            + (f"{m['mean']:+9.1%}" if m["mean"] is not None else ""))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--per-l", type=int, nargs="+", default=[30, 60, 120],
                    help="particles along the tank length L (default 30 60 120)")
    ap.add_argument("--solvers", nargs="+", default=list(SOLVERS))
    ap.add_argument("--cases", nargs="+", default=["off"], choices=list(CASES),
                    help="sway: off, near; roll: off")
    ap.add_argument("--motion", choices=("sway", "roll"), default="sway",
                    help="sway (default) or roll theta = Theta (1 - cos omega t) about the axis")
    ap.add_argument("--roll-axis-height", type=float, default=ROLL_AXIS,
                    help=f"roll axis above the floor's centre [m] (default {ROLL_AXIS:g})")
    ap.add_argument("--periods", type=float, default=4.0, help="forcing periods to run (default 4)")
    ap.add_argument("--frame", choices=("moving", "tank"), default="moving",
                    help="moving walls (default) or walls at rest under gravity (-eta'', -g) "
                    "(roll: gravity turned by -theta and the frame's inertial accelerations)")
    ap.add_argument("--nu", type=float, default=NU,
                    help=f"kinematic viscosity [m^2/s] (default {NU:g}, water)")
    ap.add_argument("--walls", choices=WALLS, default="default",
                    help="wall pressure: default (MLS; WCSPH symmetric), solved "
                    "(boundary.solved) or symmetric (boundary.symmetric)")
    ap.add_argument("--at-rest", action="store_true",
                    help="the tank at rest for --periods of case off: kinetic energy, centre "
                    "of mass, the strips' drift (runs nothing else)")
    ap.add_argument("--quick", action="store_true", help="DFSPH at 30 and 60 along L")
    ap.add_argument("--save", type=Path, help="folder to write each run's time series to (.npz)")
    ap.add_argument("--load", type=Path, nargs="*", default=[],
                    help="print and plot runs saved with --save (runs nothing)")
    args = ap.parse_args(argv)
    if args.motion == "roll":
        bad = [c for c in args.cases if c not in ROLL_CASES]
        if bad:
            ap.error(f"--cases: {bad} with --motion roll; expected one of {list(ROLL_CASES)}")
        args.cases = [f"roll-{c}" for c in args.cases]
    if args.quick:
        args.solvers, args.per_l = ["dfsph"], [30, 60]
    logging.getLogger("sphkit").setLevel(logging.ERROR)
    if args.at_rest:
        t_end = args.periods * 2.0 * math.pi / (CASES["off"][0] * OMEGA1)
        print(f"tank at rest to {t_end:.2f} s; means over t >= 1 s")
        for solver in args.solvers:
            for per_l in args.per_l:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    sim = Simulation(scene(solver, per_l, nu=args.nu, walls=args.walls))
                try:
                    print(rest_row(solver, per_l, args.walls, at_rest(sim, t_end)), flush=True)
                except InstabilityError as e:
                    print(f"rest {solver:>6s}{per_l:5d} {args.walls:>9s}  unstable at t = "
                          f"{sim.time:.3f} s: {str(e).splitlines()[0]}", flush=True)
        return 0
    print(f"2D sloshing, tank L = {LENGTH} m, depth h = {DEPTH} m, omega_1 = {OMEGA1:.4f} "
          f"rad/s (T_1 = {2 * math.pi / OMEGA1:.4f} s); sway eta = A (1 - cos omega t) or roll "
          f"theta = Theta (1 - cos omega t) about the axis {args.roll_axis_height:g} m above "
          "the floor's centre (roll: measures in the tank's coordinates), "
          f"{args.frame} walls (--load: the label says); elevation: weighted mean height over "
          f"the strip s < {W2} m (weight 1 to {W1} m), left minus right wall over 2; errors "
          "against linear theory: forced amplitude and phase, first mode's frequency W, "
          "free amplitude and decay gamma [1/s] (fit), rms/max, peak |zeta|, top particle's "
          "forced amplitude")
    print(f"{'case':8s}{'solver':>7s}{'L/2r':>5s}{'N':>7s}{'steps':>7s}{'forced':>9s}"
          f"{'amp err':>9s}{'phase':>8s}{'W/w1-1':>8s}{'free err':>9s}{'gamma':>7s}"
          f"{'rms/max':>8s}{'peak':>8s}{'top err':>9s}{'wall':>7s}"
          + (f"{'mean err':>9s}" if args.motion == "roll" else ""))
    results: dict = {}
    for path in args.load:
        with np.load(path) as d:
            o = {k: d[k] for k in d.files}
        key = (str(o.pop("case")), str(o.pop("solver")), int(o.pop("per_l")))
        o.update(steps=int(o["steps"]), n=int(o["n"]), wall=float(o["wall"]))
        if "axis" in o:
            o["axis"] = float(o["axis"])
        results[key] = o
    for key in sorted(results):
        print(row(key, results[key]), flush=True)
    cases = [] if args.load else [(case, solver, per_l) for case in args.cases
                                  for solver in args.solvers for per_l in args.per_l]
    for key in cases:
        case, solver, per_l = key
        o = simulate(solver, per_l, case, args.periods, args.frame, args.nu,
                     args.roll_axis_height, args.walls)
        if args.frame == "tank":  # the label of the runs in the tank's frame
            key = (case, f"{solver}/tank", per_l)
        if args.nu != NU:
            key = (key[0], f"{key[1]}/nu{args.nu:g}", per_l)
        if args.walls != "default":
            key = (key[0], f"{key[1]}/{args.walls}", per_l)
        print(row(key, o), flush=True)
        if isinstance(o, str):
            continue
        results[key] = o
        if args.save:
            args.save.mkdir(parents=True, exist_ok=True)
            np.savez_compressed(args.save / f"{case}_{key[1].replace('/', '_')}_{per_l}.npz",
                                case=case, solver=key[1], per_l=per_l, **o)
    for case in sorted({k[0] for k in results} | set(args.cases)):
        ratio, amp, roll = case_params(case)
        axes = sorted({float(o["axis"]) for k, o in results.items() if k[0] == case}
                      or {args.roll_axis_height}) if roll else [None]
        for axis in axes:
            _, forced, free = theory(np.zeros(1), ratio * OMEGA1, amp, roll_axis=axis)
            what = (f"Theta = {amp} rad about {axis:g} m above the floor" if roll
                    else f"A = {amp} m")
            mean = (f", mean tilt {1000 * modes(ratio * OMEGA1, amp, roll_axis=axis)[1].sum():.2f}"
                    " mm" if roll else "")
            print(f"case {case}: omega = {ratio} omega_1, {what}; theory: forced amplitude "
                  f"{1000 * forced:.2f} mm, mode-1 free {1000 * free:.2f} mm{mean}")
        for solver in sorted({k[1] for k in results if k[0] == case}):
            runs = sorted((k[2], results[k]) for k in results if k[:2] == (case, solver))
            if len(runs) > 1:
                for name in ("amp", "rms"):
                    e = [abs(measures(o, case)[name]) for _, o in runs]
                    orders = [math.log(e[i] / e[i + 1]) / math.log(runs[i + 1][0] / runs[i][0])
                              for i in range(len(e) - 1) if e[i + 1] > 0]
                    print(f"  observed order of |{name} err| {solver}: "
                          + ", ".join(f"{p:.2f}" for p in orders))
    if args.motion == "roll":
        print("roll series' limits (relative errors): " + ", ".join(
            f"{k} {v:.1e}" for k, v in theory_checks().items()))
    _plot({k: o for k, o in results.items() if not k[0].startswith("roll-")},
          Path(__file__).with_suffix(".png"))
    _plot({k: o for k, o in results.items() if k[0].startswith("roll-")},
          Path(__file__).with_name("sloshing_roll.png"), width=8.0, dpi=90)
    return 0


def _plot(results: dict, path: Path, width: float = 11.0, dpi: int = 120) -> None:
    plt = pyplot()
    if plt is None:
        return
    if not results:
        return
    cases = sorted({k[0] for k in results})
    groups = {(k[0], k[1]) for k in results}
    conv = [g for g in sorted(groups) if sum(k[:2] == g for k in results) > 1]
    rows = len(cases) + bool(conv)
    fig, axes = plt.subplots(rows, 1, figsize=(width, 3.6 * width / 11.0 * rows), squeeze=False)
    for ax, case in zip(axes[:, 0], cases, strict=False):
        ratio, amp, roll = case_params(case)
        keys = sorted(k for k in results if k[0] == case)
        axis = float(results[keys[0]]["axis"]) if roll else None
        t_end = max(results[k]["t"][-1] for k in keys)
        tt = np.linspace(0.0, t_end, 2000)
        ax.plot(tt, 1000 * theory(tt, ratio * OMEGA1, amp, roll_axis=axis)[0], "k-", lw=1.5,
                label="linear theory (strip mean)")
        for k in keys:
            o = results[k]
            ax.plot(o["t"], 1000 * o["zeta"], lw=0.8, label=f"{k[1]} L/2r = {k[2]}")
        ax.set_xlabel("t [s]")
        ax.set_ylabel("elevation at the left wall [mm]")
        ax.set_title(f"roll omega = {ratio} omega_1, Theta = {amp:g} rad about {axis:g} m "
                     "above the floor's centre (tank coordinates)" if roll else
                     f"sway omega = {ratio} omega_1, A = {1000 * amp:g} mm", fontsize=9)
        ax.legend(fontsize=6, ncol=3)
    if conv:
        ax = axes[-1, 0]
        for (case, solver), mk in zip(conv, "ovs^dx", strict=False):
            keys = sorted(k for k in results if k[:2] == (case, solver))
            m = [measures(results[k], case) for k in keys]
            n = [k[2] for k in keys]
            ax.plot(n, [100 * abs(e["amp"]) for e in m], marker=mk, label=f"{case} {solver} "
                    "|forced amplitude error|")
            ax.plot(n, [100 * e["rms"] for e in m], marker=mk, ls=":",
                    label=f"{case} {solver} rms / max")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("particles along L")
        ax.set_ylabel("error [%]")
        ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    print(f"plot: {path}")


if __name__ == "__main__":
    sys.exit(main())
