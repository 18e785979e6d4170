"""Elliptical drop (Monaghan 1994, "Simulating free surface flows with SPH", J. Comput. Phys.
110, 399-406, Sec. 5).

A 2D circular drop of radius ``R = 1 m`` (``rho0 = 1000 kg/m^3``), no gravity, no walls, no
viscosity, starts with the velocity field ``u = -A0 x``, ``v = A0 y`` (``A0 = 100 1/s``): it
stretches along y into an ellipse of semi-axes a (along x) and b (along y), compared over
``0 <= t <= 0.0076 s`` (Monaghan's end time).

Analytic solution (incompressible, inviscid; Monaghan 1994). Try the linear velocity field
``u = -A(t) x``, ``v = A(t) y`` (divergence-free) and the pressure
``p = P0(t) (1 - x^2/a^2 - y^2/b^2)``, zero on the ellipse ``x^2/a^2 + y^2/b^2 = 1``. A
linear field maps the ellipse onto an ellipse with ``da/dt = -A a``, ``db/dt = A b``, so
``d(ab)/dt = 0``: ``a b = R^2`` (area conserved). Euler's equations:

    Du/Dt = -A' x - A (dx/dt) = (A^2 - A') x = -(1/rho) dp/dx = 2 P0 x / (rho a^2)
    Dv/Dt =  A' y + A (dy/dt) = (A^2 + A') y = -(1/rho) dp/dy = 2 P0 y / (rho b^2)

hold at every point when ``(A^2 - A') a^2 = (A^2 + A') b^2 = 2 P0 / rho``, i.e.

    dA/dt = A^2 (a^2 - b^2) / (a^2 + b^2),    P0 = rho (A^2 + A') b^2 / 2,

integrated here with scipy's ``solve_ivp`` (RK45, rtol 1e-10) from A = A0, a = b = R. At
t = 0: P0 = rho A0^2 R^2 / 2 = 5 MPa at the centre.

Measured semi-axis: the flow of the exact solution is linear, so every particle moves as
``y_i(t) = y_i(0) b(t) / R`` whatever the sampling; the second-moment estimate
``b_mom = R sqrt(<(y - <y>)^2>(t) / <(y - <y>)^2>(0))`` (and a_mom likewise along x) is thus
exact for the analytic flow, with no bias from the lattice's ragged rim. (For a uniformly
filled ellipse b = 2 sqrt(<y^2>); the ratio form removes the difference between the sampled
disc and the continuum one.) ``b_max = R max|y - <y>|(t) / max|y - <y>|(0)`` is Monaghan's
measure (the outermost particle); ``b_in``: the second-moment estimate over the particles that
start within R/2 of the centre (by id), which the rim's particles do not enter. Errors: the
largest ``|b/b_exact - 1|`` over every step in [0, 0.0076 s] and the signed error at
0.0076 s; ``ab/R^2 - 1`` at the end from the second moments (area: compression, and the
particles of the rim that leave the ellipse).

Sampling: a square ``[-R, R]^2`` block (``fluid_blocks``, lattice spacing 2r; ``--lattice
hexagonal`` for the hexagonal one) of which the particles with centres at most R from the
centre are kept through the Python API (:meth:`sphkit.core.particles.ParticleSet.compact`)
before the first step, then the solver's and forces' ``init`` rerun on the disc; the
start-up's relaxation, settling and hydrostatic start are off (the particles keep the lattice
mass, so an interior particle has summation density rho0); ``sim.fluid["v"]`` is then set to
the initial field. (The scene format has no disc of fluid; a fluid mesh would do the same.)

Solvers:

* WCSPH: Tait equation, ``B = rho0 c^2 / 7`` with ``c = 1400 m/s`` (Monaghan's sound speed,
  14 times the largest initial speed): the centre's 5 MPa compresses the fluid by
  ``P0 / (rho0 c^2) = 0.26 %``. Densities are clamped to rho0 before the state equation
  (sphkit), so the rim (summation density below rho0) has p = 0: the free surface. Time step:
  CFL 0.4 * 2r / max|v| and the acoustic bound 0.4 * 2r / c (about 3-6 us at r = 0.01 m).
* DFSPH: ``max_error`` 0.01 %, ``max_error_v`` 0.1 % (SPlisHSPlasH's defaults), CFL step
  ``0.4 * 2r / max|v|`` (``--cfl-factor``).

No viscosity (the exact solution is inviscid), cubic spline, h = 4r.

Run ``python validation/elliptical_drop.py`` (``--radii 0.04 0.02 0.01`` particle radii [m],
``--solvers wcsph dfsph``). It prints the table and saves ``validation/elliptical_drop.png``
when matplotlib is installed.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from _plotting import pyplot
from scipy.integrate import solve_ivp

from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

RADIUS = 1.0  # R [m]
A0 = 100.0  # initial strain rate [1/s]
RHO0 = 1000.0
SOUND = 1400.0  # WCSPH speed of sound [m/s] (Monaghan 1994)
T_END = 0.0076  # [s]


def analytic(t_end: float = T_END):
    """The dense solution of (A, a, b)(t) of the module docstring (scipy OdeSolution)."""

    def rhs(_t: float, s: np.ndarray) -> list[float]:
        a_, a, b = s
        return [a_ * a_ * (a * a - b * b) / (a * a + b * b), -a_ * a, a_ * b]

    sol = solve_ivp(rhs, (0.0, t_end), [A0, RADIUS, RADIUS], rtol=1e-10, atol=1e-12,
                    dense_output=True)
    return sol.sol


def scene(solver: str, r: float, lattice: str = "square", cfl_factor: float = 1.0) -> Scene:
    """The square block the disc is cut from (module docstring)."""
    pressure: dict = {"method": solver}
    if solver == "wcsph":
        pressure.update(equation="tait", exponent=7.0, stiffness=RHO0 * SOUND**2 / 7.0)
    return Scene.model_validate({
        "name": f"elliptical-drop-{solver}",
        "configuration": {
            "dim": 2, "particle_radius": r, "gravity": [0.0, 0.0],
            "pressure": pressure,
            "time": {"dt": 1e-6, "dt_min": 1e-8, "dt_max": 1e-3, "cfl_factor": cfl_factor},
            "max_velocity": 1000.0,
            "start": {"relax": False, "hydrostatic": False, "settle": False},
        },
        "materials": [{"density0": RHO0, "viscosity": {"method": "none"}}],
        "fluid_blocks": [{"start": [-RADIUS, -RADIUS], "end": [RADIUS, RADIUS],
                          "lattice": lattice}],
    })


def _square_disc(sim: Simulation, spacing: float) -> None:
    """Replace the fluid by the square lattice of ``spacing`` within the disc (nodes at
    ``(k + 1/2) spacing``), rest volume 1 / (kernel sum over the infinite lattice)."""
    from sphkit.core.kernels import Kernel

    st = sim.state
    k = np.arange(-math.ceil(RADIUS / spacing) - 1, math.ceil(RADIUS / spacing) + 1) + 0.5
    gx, gy = np.meshgrid(k * spacing, k * spacing, indexing="ij")
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    pts = pts[(pts * pts).sum(axis=1) <= RADIUS**2]
    j = np.arange(-12, 13)
    lx, ly = np.meshgrid(j * spacing, j * spacing, indexing="ij")
    vol = 1.0 / Kernel(sim.scene.configuration.kernel, st.h, 2).w(np.hypot(lx, ly)).sum()
    fluid = st.fluid.empty_like()
    fluid.add(pts, name="drop", m=RHO0 * vol, V0=vol, rho=RHO0, rho0=RHO0)
    st.fluid = fluid


def drop(solver: str, r: float, lattice: str = "square", cfl_factor: float = 1.0,
         support: float = 2.0) -> Simulation:
    """The drop at t = 0: the block cut to the disc, the initial velocity set. ``support``:
    the kernel support h in particle spacings 2r (sphkit: h = 4r = 2); otherwise the particle
    radius of the scene is ``support / 2 * r`` (so h = support * 2r) and the disc is a square
    lattice of spacing 2r built here (module docstring)."""
    scale = support / 2.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(scene(solver, r * scale, lattice, cfl_factor / scale))
    st = sim.state
    f = st.fluid
    if support == 2.0:
        x = f["x"]
        f.compact((x * x).sum(axis=0) <= RADIUS**2)
    else:
        _square_disc(sim, 2.0 * r)
        f = st.fluid
    sim.pressure.init(st)
    for force in sim.forces:
        force.init(st)
    x = f["x"]
    f["v"][0] = -A0 * x[0]
    f["v"][1] = A0 * x[1]
    return sim


def _moments(x: np.ndarray) -> tuple[float, float, float, float]:
    c = x - x.mean(axis=1, keepdims=True)
    return (float((c[0] ** 2).mean()), float((c[1] ** 2).mean()), float(np.abs(c[0]).max()),
            float(np.abs(c[1]).max()))


def run(sim: Simulation, t_end: float = T_END) -> dict:
    """Step to t_end; the semi-axes at every step against the exact ones (module docstring)."""
    sol = analytic(t_end)
    f = sim.fluid
    x0 = _moments(f["x"])
    o = f.order_by_id()
    start = f["x"][:, o]
    inner = np.flatnonzero((start * start).sum(axis=0) <= (0.5 * RADIUS) ** 2)  # by id
    y0_in = float(((start[1, inner] - start[1, inner].mean()) ** 2).mean())
    ts, bm, bx, am, bi = [0.0], [RADIUS], [RADIUS], [RADIUS], [RADIUS]
    iters = []
    max_it = sim.scene.configuration.pressure.max_iterations
    while sim.time < t_end - 1e-12:
        s = sim.step(land_at=t_end)
        iters.append(s.iterations)
        m = _moments(f["x"])
        ts.append(sim.time)
        am.append(RADIUS * math.sqrt(m[0] / x0[0]))
        bm.append(RADIUS * math.sqrt(m[1] / x0[1]))
        bx.append(RADIUS * m[3] / x0[3])
        y_in = f["x"][1, f.order_by_id()[inner]]
        bi.append(RADIUS * math.sqrt(((y_in - y_in.mean()) ** 2).mean() / y0_in))
    t = np.array(ts)
    exact = sol(t)
    b_ex, a_ex = exact[2], exact[1]
    e_mom = np.array(bm) / b_ex - 1.0
    e_max = np.array(bx) / b_ex - 1.0
    e_a = np.array(am) / a_ex - 1.0
    e_in = np.array(bi) / b_ex - 1.0
    return {"n": sim.fluid.n, "steps": sim.step_count, "t": t, "b_mom": np.array(bm),
            "b_max": np.array(bx), "a_mom": np.array(am), "b_exact": b_ex, "a_exact": a_ex,
            "err_mom": float(np.abs(e_mom).max()), "end_mom": float(e_mom[-1]),
            "err_max": float(np.abs(e_max).max()), "end_max": float(e_max[-1]),
            "err_a": float(np.abs(e_a).max()), "err_in": float(np.abs(e_in).max()),
            "end_in": float(e_in[-1]),
            "unconverged": int(sum(k >= max_it for k in iters)) if sim.pressure.name != "wcsph"
            else 0,
            "area": am[-1] * bm[-1] / RADIUS**2 - 1.0,
            "rho_max": float(sim.fluid["rho"].max() / RHO0 - 1.0),
            "iterations": float(np.mean(iters)) if iters else 0.0}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--radii", type=float, nargs="+", default=[0.04, 0.02, 0.01],
                    help="particle radii r [m] (default 0.04 0.02 0.01)")
    ap.add_argument("--solvers", nargs="+", default=["wcsph", "dfsph"])
    ap.add_argument("--lattice", choices=("square", "hexagonal"), default="square")
    ap.add_argument("--cfl-factor", type=float, default=1.0)
    ap.add_argument("--support", type=float, default=2.0,
                    help="kernel support h in particle spacings (sphkit: 2)")
    ap.add_argument("--until", type=float, default=T_END, help="end time [s] (0.0076)")
    args = ap.parse_args(argv)
    logging.getLogger("sphkit").setLevel(logging.ERROR)  # DFSPH's non-convergence: counted
    sol = analytic(args.until)
    ex = sol(args.until)
    print(f"Elliptical drop (Monaghan 1994), R = {RADIUS} m, A0 = {A0} 1/s, {args.lattice} "
          f"lattice, support {args.support} spacings, to t = {args.until} s: exact "
          f"a = {ex[1]:.4f} m, b = {ex[2]:.4f} m, A = {ex[0]:.3f} 1/s; WCSPH c = {SOUND} m/s")
    print("b_mom: second-moment semi-axis, b_max: outermost particle; errors relative to the "
          "exact b: largest over the run / at the end")
    print(f"{'solver':7s}{'r [m]':>7s}{'R/2r':>6s}{'N':>7s}{'steps':>6s}{'iter':>6s}"
          f"{'unconv':>7s}{'b_mom max':>10s}{'end':>8s}{'b_max max':>10s}{'end':>8s}"
          f"{'b_in max':>9s}{'end':>8s}{'a_mom max':>10s}{'ab/R2-1':>9s}{'rho_max':>8s}"
          f"{'wall':>7s}")
    results = {}
    for solver in args.solvers:
        for r in args.radii:
            t0 = time.perf_counter()
            try:
                o = run(drop(solver, r, args.lattice, args.cfl_factor, args.support),
                        args.until)
            except InstabilityError as e:
                print(f"{solver:7s}{r:7.4f}{RADIUS / (2 * r):6.1f}  unstable: "
                      f"{str(e).splitlines()[0]}", flush=True)
                continue
            wall = time.perf_counter() - t0
            results[(solver, r)] = o
            print(f"{solver:7s}{r:7.4f}{RADIUS / (2 * r):6.1f}{o['n']:7d}{o['steps']:6d}"
                  f"{o['iterations']:6.1f}{o['unconverged']:7d}{o['err_mom']:10.2%}"
                  f"{o['end_mom']:+8.2%}{o['err_max']:10.2%}{o['end_max']:+8.2%}"
                  f"{o['err_in']:9.2%}{o['end_in']:+8.2%}{o['err_a']:10.2%}"
                  f"{o['area']:+9.2%}{o['rho_max']:+8.2%}{wall:7.1f}", flush=True)
    plt = pyplot()
    if plt is None:
        return 0
    fig, ax = plt.subplots(figsize=(6, 4))
    tt = np.linspace(0.0, args.until, 200)
    ax.plot(tt * 1e3, sol(tt)[2], "k-", lw=1, label="exact b")
    ax.plot(tt * 1e3, sol(tt)[1], "k--", lw=1, label="exact a")
    for (solver, r), o in results.items():
        ax.plot(o["t"] * 1e3, o["b_mom"], lw=0.8, label=f"{solver} r = {r:g} b_mom")
    ax.set_xlabel("t [ms]")
    ax.set_ylabel("semi-axis [m]")
    ax.set_title("Elliptical drop (Monaghan 1994)")
    ax.legend(fontsize=7)
    path = Path(__file__).with_suffix(".png")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    print(f"plot: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
