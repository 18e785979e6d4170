"""Forces between phases (scene ``interfaces[]``): inter-phase viscosity (Morris et al. 1997,
``sphkit.multiphase.morris1997``) and interface tension (Hu & Adams 2006,
``sphkit.multiphase.hu2006``).

    python validation/interfaces.py [--study shear laplace ellipse drop] [--solver dfsph]
        [--shear-solver wcsph] [--radius 0.005] [--until 1.0] [--background 0 50 200]

``drop`` (not in the default list): a disc of b (R = 0.075 m) in a free square of a reaching
0.1 m beyond it (sigma = 1 N, nu = 0.005), its jump ``(p_b - p_a) / (sigma / R)`` and the
lowest density of b at 0.1 ... 1 s, for each ``--background`` pressure p_b of hu2006's band
(``interfaces[].tension.background_pressure``).

Three 2D studies, no gravity, time step at most :data:`DT_MAX` (0.5 ms), two fluid materials
of equal rest density 1000 kg/m^3 unless said otherwise:

* ``shear``: two layers 0.2 m thick between walls at y = -0.2 and 0.2 m (free slip: no wall
  viscosity; without walls the free slab flew apart), periodic in x (0.1 m), phase a at +U = 0.1
#: the largest step [s]: below the explicit viscosity's bound 0.125 (2r)^2 / nu = 1.25 ms at
#: r = 5 mm, nu = 0.01 m^2/s (Morris 1997; at 2 ms two materials with that viscosity grew
#: velocities of 2 m/s from rest within 0.1 s)
DT_MAX = 0.0005
  m/s below y = 0, phase b at -U above; each material has the standard viscosity nu = 0.01 m^2/s
  within its phase. With the inter-phase viscosity nu_ab = nu the two phases are one fluid of
  viscosity nu, and the profile must follow the impulsively started shear layer ``u(y, t) = -U
  erf(y / (2 sqrt(nu t)))``; the table gives the RMS deviation from it over the particles within
  0.1 m of the interface at t = 0.25 s (in units of U), and the velocity jump across the
  interface (mean u of the particles within 2r below minus within 2r above, in U; erf gives 0 +
  O(r/sqrt(nu t))), for the interface viscosity on (nu), off (the phases slip: SPlisHSPlasH's
  convention), and one material (the reference); also rho_b = 500 with nu_ab = nu (a different
  fluid: the jump must stay small, the profile is not erf). Solver ``--shear-solver`` (WCSPH).
* ``laplace``: a disc of phase b (radius R) in a square of phase a reaching 0.1 m beyond it,
  closed by walls (with a free outer surface the pressure inside reached sigma / R after 0.1 s
  and then decayed to 0.18 sigma / R by 1 s: the outer phase expanded, DFSPH, R = 0.075 m),
  interface tension sigma = 1 N (per unit depth), nu = 0.005 m^2/s in each phase and between
  them, run to ``--until`` (1 s) with ``--solver``: the mean pressure of b deeper than 2h inside
  the disc minus the mean pressure of a more than 2h from the disc and from the walls, averaged
  over the last third, against sigma / R (Laplace, 2D; R the disc's volume radius).
* ``ellipse``: an ellipse of b with semi-axes sqrt(2) R and R / sqrt(2) (aspect 2), R = 0.06 m,
  in a square of a reaching 0.05 m beyond it (free outer surface; in a closed box it relaxed
  more slowly: aspect 1.52 instead of 1.24 after 1 s with DFSPH), sigma = 1 N, nu =
  ``--ellipse-nu`` (0.01 m^2/s) in and between the phases: its aspect ``sqrt(<x^2> / <y^2>)``
  (about its centre) over time; it must relax towards 1 (a circle).
"""

from __future__ import annotations

import argparse
import logging
import math
import time
import warnings

import numpy as np

from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

U = 0.1
#: the largest step [s]: below the explicit viscosity's bound 0.125 (2r)^2 / nu = 1.25 ms at
#: r = 5 mm, nu = 0.01 m^2/s (Morris 1997; at 2 ms two materials with that viscosity grew
#: velocities of 2 m/s from rest within 0.1 s)
DT_MAX = 0.0005


def _sim(scene: Scene) -> Simulation:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Simulation(scene)


def shear_scene(r: float, nu: float, nu_ab: float | None, rho_b: float = 1000.0,
                solver: str = "dfsph", one: bool = False) -> Scene:
    """The sheared layers of the module docstring (``nu_ab`` None: no interface; ``one``: a
    single material)."""
    visc = {"method": "standard", "coefficient": nu}
    mats = [{"id": "a", "density0": 1000.0, "viscosity": visc}]
    if not one:
        mats.append({"id": "b", "density0": rho_b, "viscosity": visc})
    itf = ([] if nu_ab is None or one else
           [{"materials": ["a", "b"], "viscosity": {"method": "morris1997",
                                                     "coefficient": nu_ab}}])
    return Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, 0.0],
                          "periodic_x": [0.0, 0.1], "pressure": {"method": solver},
                          "time": {"dt_max": DT_MAX}},
        "materials": mats,
        "fluid_blocks": [{"start": [0.0, -0.2], "end": [0.1, 0.0], "material": "a",
                          "velocity": [U, 0.0]},
                         {"start": [0.0, 0.0], "end": [0.1, 0.2], "material": "a" if one else "b",
                          "velocity": [-U, 0.0]}],
        "boxes": [{"min": [0.0, -0.2], "max": [0.1, 0.2]}],
        "interfaces": itf,
    })


def shear(r: float, solver: str, until: float = 0.25, nu: float = 0.01) -> None:
    print(f"\nsheared layers, 2D periodic, r = {r} m, nu = {nu} m^2/s, U = {U} m/s, {solver}, "
          f"t = {until} s: RMS deviation from -U erf(y / 2 sqrt(nu t)) within 0.1 m, and the "
          "jump across the interface, in U")
    print(f"{'case':28s} {'n':>5s} {'rms/U':>7s} {'jump/U':>7s} {'ms/step':>8s}")
    cases = [("interface viscosity nu", nu, 1000.0, False),
             ("no interface viscosity", None, 1000.0, False),
             ("one material", None, 1000.0, True),
             ("rho_b 500, interface nu", nu, 500.0, False)]
    for name, nu_ab, rho_b, one in cases:
        sim = _sim(shear_scene(r, nu, nu_ab, rho_b, solver, one))
        t0, steps = time.perf_counter(), 0
        while sim.time < until - 1e-9:
            sim.step()
            steps += 1
        wall = (time.perf_counter() - t0) / steps * 1e3
        f = sim.fluid
        y = f.view("x")[:, 1]
        u = f.view("v")[:, 0]
        y0 = float(np.median(y))  # the interface stays at the middle (equal layers)
        yy = y - y0
        near = np.abs(yy) < 0.1
        exact = -U * np.array([math.erf(t / (2.0 * math.sqrt(nu * sim.time))) for t in yy])
        rms = float(np.sqrt(np.mean((u[near] - exact[near]) ** 2))) / U
        below = (yy < 0) & (yy > -2 * r)
        above = (yy > 0) & (yy < 2 * r)
        jump = float(u[below].mean() - u[above].mean()) / U
        print(f"{name:28s} {f.n:5d} {rms:7.4f} {jump:7.4f} {wall:8.1f}", flush=True)


def drop_scene(r: float, R: float, sigma: float, nu: float, solver: str,
               aspect: float = 1.0, margin: float = 0.05,
               walls: bool = False, background: float = 0.0) -> tuple[Scene, float]:
    """A square of phase a around the origin, large enough for the ellipse (semi-axes R aspect,
    R / aspect) plus ``margin`` [m]; returns the scene and its half width."""
    half = R * aspect + margin
    visc = {"method": "standard", "coefficient": nu}
    return Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, 0.0],
                          "pressure": {"method": solver}, "time": {"dt_max": DT_MAX}},
        "materials": [{"id": "a", "density0": 1000.0, "viscosity": visc},
                      {"id": "b", "density0": 1000.0, "viscosity": visc}],
        "fluid_blocks": [{"start": [-half, -half], "end": [half, 0.0], "material": "a"},
                         {"start": [-half, 0.0], "end": [half, half], "material": "b"}],
        "boxes": [{"min": [-half, -half], "max": [half, half]}] if walls else [],
        "interfaces": [{"materials": ["a", "b"],
                        "viscosity": {"method": "morris1997", "coefficient": nu},
                        "tension": {"method": "hu2006", "coefficient": sigma,
                                    "background_pressure": background}}],
    }), half


def _drop(r: float, R: float, sigma: float, nu: float, solver: str,
          aspect: float = 1.0, margin: float = 0.05,
          walls: bool = False, background: float = 0.0) -> tuple[Simulation, float]:
    scene, half = drop_scene(r, R, sigma, nu, solver, aspect, margin, walls, background)
    sim = _sim(scene)
    x = sim.fluid["x"]
    inside = (x[0] / (R * aspect)) ** 2 + (x[1] * aspect / R) ** 2 < 1.0
    sim.fluid["phase"][:] = np.where(inside, 1, 0)
    return sim, half


def _jump(sim: Simulation, r: float, h: float, top: float) -> tuple[float, float]:
    """The drop's pressure jump ``p_b - p_a`` [Pa] and its volume radius ``Rv`` [m]: the mean
    pressure of the drop (phase 1) more than 2h inside Rv against that of the outer phase more
    than 2h outside it and more than 2h inside the square of half width ``top``."""
    f = sim.fluid
    x = f["x"]
    b = f["phase"] == 1
    c = x[:, b].mean(axis=1, keepdims=True)
    d = np.linalg.norm(x - c, axis=0)
    Rv = math.sqrt(b.sum() * (2 * r) ** 2 / math.pi)
    edge = top - np.abs(x).max(axis=0)  # distance to the square's sides
    pin = f["p"][b & (d < Rv - 2 * h)].mean()
    pout = f["p"][~b & (d > Rv + 2 * h) & (edge > 2 * h)].mean()
    return float(pin - pout), Rv


def laplace(r: float, solver: str, until: float = 1.0, sigma: float = 1.0,
            nu: float = 0.005) -> None:
    print(f"\n2D drop of b in a, r = {r} m, sigma = {sigma} N, nu = {nu} m^2/s, {solver}, "
          f"{until} s: pressure jump (last third) against sigma / R")
    print(f"{'R [m]':>6s} {'n':>5s} {'p_b - p_a [Pa]':>15s} {'sigma/R':>8s} {'ratio':>6s} "
          f"{'vmax':>6s} {'ms/step':>8s}  note")
    for R in (0.05, 0.075, 0.1):
        sim, half = _drop(r, R, sigma, nu, solver, margin=0.1, walls=True)
        h = sim.state.h
        jumps, steps, note = [], 0, ""
        t0 = time.perf_counter()
        try:
            while sim.time < until - 1e-9:
                sim.step()
                steps += 1
                if sim.time > 2.0 * until / 3.0:
                    jumps.append(_jump(sim, r, h, half))
        except InstabilityError as e:
            note = f"unstable at t = {e.stats.time:.3f} s"
        wall = (time.perf_counter() - t0) / max(steps, 1) * 1e3
        vmax = float(np.sqrt((sim.fluid["v"] ** 2).sum(axis=0)).max())
        if jumps:
            jump = float(np.mean([j for j, _ in jumps]))
            Rv = jumps[-1][1]
            print(f"{R:6.3f} {sim.fluid.n:5d} {jump:15.3f} {sigma / Rv:8.3f} "
                  f"{jump * Rv / sigma:6.3f} {vmax:6.3f} {wall:8.1f}  {note}", flush=True)
        else:
            print(f"{R:6.3f} {sim.fluid.n:5d} {'-':>15s} {'-':>8s} {'-':>6s} {vmax:6.3f} "
                  f"{wall:8.1f}  {note}", flush=True)


def drop_history(r: float, solver: str, backgrounds: list[float], until: float = 1.0,
                 sigma: float = 1.0, nu: float = 0.005, R: float = 0.075,
                 walls: bool = False) -> None:
    """A 2D drop in a free square (no walls, so the pressure level cannot drift) over time,
    for each background pressure: the jump ``p_b - p_a`` (drop interior more than 2h inside,
    the outer phase more than 2h outside the drop and 2h inside the free surface) over sigma /
    R, and the lowest density among the drop's particles (a gap at the interface)."""
    marks = [t for t in (0.1, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0) if t <= until + 1e-9]
    print(f"\n2D drop of b (R = {R} m) in a {'closed' if walls else 'free'} square of a, "
          f"r = {r} m, sigma = {sigma} N, "
          f"nu = {nu} m^2/s, {solver}: (p_b - p_a) / (sigma / R), lowest rho / rho0 of b")
    print(f"{'p_bg [Pa]':>9s} " + " ".join(f"{f'{t:g} s':>14s}" for t in marks)
          + "  ms/step  note")
    for bg in backgrounds:
        sim, half = _drop(r, R, sigma, nu, solver, margin=0.1, walls=walls, background=bg)
        h = sim.state.h
        row, k, steps, note = [], 0, 0, ""
        t0 = time.perf_counter()
        try:
            while k < len(marks):
                sim.step()
                steps += 1
                if sim.time >= marks[k] - 1e-9:
                    f = sim.fluid
                    b = f["phase"] == 1
                    # the square's half width: its walls, or the free fluid's extent
                    top = half if walls else float(np.abs(f["x"]).max())
                    jump, Rv = _jump(sim, r, h, top)
                    rmin = float((f["rho"][b] / f["rho0"][b]).min())
                    row.append(f"{jump * Rv / sigma:6.3f} / {rmin:5.3f}")
                    k += 1
        except InstabilityError as e:
            note = f"unstable at t = {e.stats.time:.3f} s"
        wall = (time.perf_counter() - t0) / max(steps, 1) * 1e3
        print(f"{bg:9g} " + " ".join(f"{c:>14s}" for c in row) + f"  {wall:7.1f}  {note}",
              flush=True)


def ellipse(r: float, solver: str, until: float = 2.0, sigma: float = 1.0,
            nu: float = 0.01) -> None:
    """The ellipse study of the module docstring (``nu`` [m^2/s] in and between the phases)."""
    print(f"\n2D ellipse of b in a (aspect 2, R = 0.06 m), r = {r} m, sigma = {sigma} N, "
          f"nu = {nu} m^2/s, {solver}: aspect sqrt(<x^2>/<y^2>) over time")
    sim, _ = _drop(r, 0.06, sigma, nu, solver, aspect=math.sqrt(2.0))
    marks = [0.0, 0.1, 0.25, 0.5, 1.0, 1.5, 2.0]
    marks = [t for t in marks if t <= until + 1e-9]
    row = []
    k = 0
    note = ""
    try:
        while True:
            if sim.time >= marks[k] - 1e-9:
                f = sim.fluid
                b = f["phase"] == 1
                x = f["x"][:, b]
                x = x - x.mean(axis=1, keepdims=True)
                row.append((sim.time, math.sqrt((x[0] ** 2).mean() / (x[1] ** 2).mean())))
                k += 1
                if k == len(marks):
                    break
            sim.step()
    except InstabilityError as e:
        note = f"unstable at t = {e.stats.time:.3f} s"
    print("  ".join(f"t={t:.2f}: {a:.3f}" for t, a in row), note)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--study", nargs="+", default=["shear", "laplace", "ellipse"],
                    choices=["shear", "laplace", "ellipse", "drop"])
    ap.add_argument("--solver", default="dfsph")
    ap.add_argument("--shear-solver", default="wcsph")
    ap.add_argument("--radius", type=float, default=0.005)
    ap.add_argument("--ellipse-nu", type=float, default=0.01, help="ellipse: nu [m^2/s]")
    ap.add_argument("--until", type=float, default=1.0, help="laplace: run time [s]")
    ap.add_argument("--drop-walls", action="store_true", help="drop: a closed square")
    ap.add_argument("--background", type=float, nargs="+", default=[0.0, 50.0, 200.0],
                    help="drop: background pressures p_b of the interface band [Pa]")
    args = ap.parse_args()
    logging.getLogger("sphkit").setLevel(logging.ERROR)
    if "shear" in args.study:
        shear(args.radius, args.shear_solver)
    if "laplace" in args.study:
        laplace(args.radius, args.solver, args.until)
    if "drop" in args.study:
        drop_history(args.radius, args.solver, args.background, args.until,
                     walls=args.drop_walls)
    if "ellipse" in args.study:
        ellipse(args.radius, args.solver, nu=args.ellipse_nu)


if __name__ == "__main__":
    main()
