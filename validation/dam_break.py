"""2D dam break: surge front and residual column against Martin & Moyce 1952 and Koshizuka &
Oka 1996.

A water column of width a and height n^2 a (rho0 = 1000 kg/m^3, nu = 1e-6 m^2/s, g = 9.81
m/s^2) stands at rest against the left wall of a tank 4a long and collapses at t = 0.

References (``validation/data/``, each file names the source of its numbers and their
precision):

* Martin & Moyce 1952 (Phil. Trans. R. Soc. Lond. A 244, 312-324), n^2 = 2, a = 2.25 in: the
  surge front Z = x / a against **T = n t sqrt(g / a)** and the height of the residual column
  at the back wall H = h / (n^2 a) against **tau = t sqrt(g / a)**. Martin & Moyce scale the
  front's time with n so that shallow-water (Ritter) fronts, x - a = 2 sqrt(g n^2 a) t, i.e.
  Z = 1 + 2T, coincide for every n; ``T = t sqrt(2 g / a)``, the form usually quoted, is the
  same thing for n^2 = 2 only (for the square column, n^2 = 1, T = t sqrt(g / a)). The
  smaller column (a = 1.125 in, digitised from their figure) shows the experiments' spread.
* Koshizuka & Oka 1996 (Nucl. Sci. Eng. 123, 421-434): their experiment, L = 0.146 m wide,
  2L high (n^2 = 2), tank 4L: leading edge Z = z / L against T = t sqrt(2 g / L).

Both references are n^2 = 2 columns: inviscid and without surface tension the flow depends on
a only through the scales sqrt(g a) and a, so one simulation (a = 0.146 m, Koshizuka & Oka's
size) is compared with both. ``--columns 1`` runs the square column in the same 4a tank and
compares it, on Martin & Moyce's scaled time, with the n^2 = 2 table (their scaling makes
Ritter's fronts equal, not the early collapse: the square column runs well ahead,
validation/README.md) and on T = t sqrt(2 g / a) (column 'MM 2g/a').

* ``--square``: Martin & Moyce's square column (n^2 = 1, a = 2.25 in) against its own table:
  front Z = 6-13 and residual column against T = t sqrt(g / a), as plotted in Xie 2021
  (arXiv:2108.08769, Fig. 7) and digitised from that figure by a third party (third hand; the
  data files say so), in a tank 15 a long to T = 9.8 (:data:`SQUARE`); ``--floor-viscosity``
  adds DFSPH runs with that floor friction at the middle resolution.

Measures: the front ``max_i x_i + r`` (the leading particle's edge; Z = 1 at t = 0), the
fronts of the water at least 0.02, 0.05, 0.1 a deep (the depth of each 2r-wide column of
particles; printed under each row), the residual column ``max y_i + r`` over the particles
within 4r of the back wall. Errors:
``(Z_sim(T) - Z_exp) / Z_exp`` at every experimental point with T > 0 and Z_exp < 3.9 (the
front is still inside the 4a tank), the mean (signed) and the largest absolute; height: the
mean |H_sim - H_exp| at the tabulated tau within the run. Observed order of convergence from
the mean |Z_N - Z_2N| over 0.5 <= T <= 3 between successive resolutions.

Explanations of a lead over Martin & Moyce (``--gate``):

* Time shift: the T0 that minimises the RMS relative error of ``Z_sim(T - T0)`` (the
  experiment's clock started before the column was free; Lethe's dam-break example adds
  0.175 to its simulation times for this).
* A gate lifted at a finite speed V: a kinematic rigid body (a thin box mesh across the
  column's face from the floor up) that moves up at V from t = 0, DFSPH; the column runs out
  under it as it opens.

Solvers: WCSPH (Tait, B = rho0 c^2 / 7 with c = 10 sqrt(2 g n^2 a), Mach 0.1 against
Ritter's largest front speed), PCISPH, PBF, IISPH, DFSPH (SPlisHSPlasH's default tolerances).
Walls: box walls of Akinci boundary particles (MLS boundary pressure); ``free-slip``: no
viscous wall term; ``no-slip``: the standard viscosity's wall term with nu_b = nu and Morris et
al. 1997's velocity extrapolated across the wall (``boundary_velocity: morris1997``). Cubic
spline, h = 4r, CFL step 0.4 * 2r / max|v|; hydrostatic start.

Run ``python validation/dam_break.py`` (``--per-a 10 20 40`` particles across a,
``--solvers ...``, ``--walls free-slip no-slip``, ``--columns 2 1``, ``--gate`` adds the
gate-speed runs, ``--wall-viscosity NU_B ...`` the runs with no-slip walls whose viscous term
has the coefficient NU_B (wall friction as an eddy viscosity; DFSPH, the middle resolution),
``--floor-viscosity NU_B ...`` the same on the floor only (``boxes[].viscosity_factors``: the
side walls free-slip), ``--surface-tension SIGMA ...`` free-slip runs with Mueller et al.
2003's surface tension (no adhesion), ``--front-thickness D ...`` adds the fronts of water at
least D thick (``2L``: two particle layers; ``5mm``; ``0.05``: a fraction of a; the water per
width in 4r-wide windows of x), ``--quick``: DFSPH, free-slip, 10 and 20; ``--dim 3``: the
column in a channel 0.5 a wide between side walls, y up, z across; ``--solved-walls``:
``configuration.boundary.solved``, wall pressures solved in the PPE, which the 3D runs need;
``--solved-walls density``: at density level).
It prints the tables and saves ``validation/dam_break.png`` (``dam_break_3d.png``) when
matplotlib is installed. No settling before t = 0 (``start.settle: false``).
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from _plotting import pyplot

from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

G = 9.81  # [m/s^2]
RHO0 = 1000.0  # [kg/m^3]
NU = 1e-6  # kinematic viscosity of water [m^2/s]
A = 0.146  # column width a [m] (Koshizuka & Oka's L)
TANK = 4.0  # tank length [a]
T_END = 3.2  # end of the run, Martin & Moyce's T
Z_MAX = 3.9  # compare while the experimental front is inside the tank [a]
WIDTH_3D = 0.5  # the 3D channel's width [a]
SOLVERS = ("wcsph", "pcisph", "pbf", "iisph", "dfsph")
WALLS = ("free-slip", "no-slip")
DATA = Path(__file__).resolve().parent / "data"
REFERENCES = {  # name: (file, column n^2)
    "MM a=2.25in": ("martin_moyce_1952_n2_2_front.csv", 2),
    "MM a=1.125in": ("martin_moyce_1952_n2_2_a1125_front.csv", 2),
    "K&O": ("koshizuka_oka_1996_front.csv", 2),
}
HEIGHT = "martin_moyce_1952_n2_2_height.csv"
#: ``--square``: Martin & Moyce's square column (n^2 = 1) in a tank long enough for its table
SQUARE = {"front": "martin_moyce_1952_n2_1_front.csv",
          "height": "martin_moyce_1952_n2_1_height.csv",
          "tank": 15.0, "t_end": 9.8, "z_max": 13.5, "shift_max": 3.0}
#: the front of the water at least this deep [a] (``Z<d>``): how much of the lead is a thin
#: tongue
DEPTHS = (0.02, 0.05, 0.1)


def reference(file: str) -> tuple[np.ndarray, np.ndarray]:
    """The two columns of a ``validation/data`` table (its ``#`` lines name its source, the
    first other line is the header)."""
    rows = [s for s in (DATA / file).read_text().splitlines() if s and not s.startswith("#")]
    d = np.array([[float(v) for v in s.split(",")] for s in rows[1:]])
    return d[:, 0], d[:, 1]


def _gate_obj(folder: Path, a: float, n2: float, width: float) -> Path:
    """A box mesh across the column's face, x in [a, a + width], y from the floor to above
    the column (2D: its section z = 0 is the gate)."""
    import trimesh

    box = trimesh.creation.box(bounds=[[a, 0.0, -0.5], [a + width, (n2 + 0.5) * a, 0.5]])
    path = folder / "gate.obj"
    box.export(path)
    return path


def scene(solver: str, per_a: int, wall: str = "free-slip", n2: float = 2.0, a: float = A,
          gate_speed: float | None = None, gate_dir: Path | None = None, dim: int = 2,
          solved_walls: bool | str = False, tank: float = TANK) -> Scene:
    """The dam break of the module docstring: ``per_a`` particles across the column; ``dim``
    3: the same in a channel WIDTH_3D a wide (y up, z across; walls on both sides);
    ``solved_walls``: ``configuration.boundary.solved`` (walls that do no work). ``wall``:
    ``free-slip``, ``no-slip`` (nu_b = nu), ``no-slip:<nu_b>`` (every wall), ``floor:<nu_b>``
    (the no-slip term on the floor only, ``boxes[].viscosity_factors``; the other walls
    free-slip), ``sigma:<N/m>`` (free-slip walls, Mueller et al. 2003's surface tension);
    ``tank``: the tank's length [a]."""
    r = a / (2 * per_a)
    height = n2 * a
    pressure: dict = {"method": solver}
    if solver == "wcsph":
        c = 10.0 * math.sqrt(2.0 * G * height)
        pressure.update(equation="tait", exponent=7.0, stiffness=RHO0 * c * c / 7.0)
    visc: dict = {"method": "standard", "coefficient": NU}
    if wall.startswith(("no-slip", "floor")):  # "<kind>:<nu_b>": the wall term's coefficient
        nu_b = float(wall.split(":")[1]) if ":" in wall else NU
        visc.update(boundary_coefficient=nu_b, boundary_velocity="morris1997")
    lo, hi, start, end = [0.0, 0.0], [tank * a, height + a], [0.0, 0.0], [a, height]
    if dim == 3:
        lo, hi = lo + [0.0], hi + [WIDTH_3D * a]
        start, end = start + [0.0], end + [WIDTH_3D * a]
    data: dict = {
        "name": f"dam-break-{solver}",
        "configuration": {
            "dim": dim, "particle_radius": r, "gravity": [0.0, -G] + [0.0] * (dim - 2),
            "pressure": pressure,
            "time": {"dt": 1e-4, "dt_min": 1e-7, "dt_max": 1e-3},
            "boundary": {"solved": solved_walls},
            # no settling before t = 0: the column is not at rest ("auto" settled the 3D
            # column of a narrow channel, i.e. let it collapse, damped, before the clock)
            "start": {"settle": False},
        },
        "materials": [{"density0": RHO0, "viscosity": visc}],
        "fluid_blocks": [{"start": start, "end": end}],
        "boxes": [{"min": lo, "max": hi, "layers": 2, "open_top": True}],
    }
    if wall.startswith("floor"):  # the wall term on the floor (-y) only
        data["boxes"][0]["viscosity_factors"] = [0.0, 0.0, 1.0, 0.0] + [0.0, 0.0] * (dim - 2)
    if wall.startswith("sigma"):  # "sigma:<N/m>": CSF surface tension, no adhesion
        data["materials"][0]["surface_tension"] = {
            "method": "mueller2003", "coefficient": float(wall.split(":")[1])}
    if gate_speed is not None:
        path = _gate_obj(gate_dir, a, n2, 8.0 * r)
        data["meshes"] = [{"geometry_file": str(path), "velocity": [0.0, gate_speed, 0.0]}]
    return Scene.model_validate(data)


def thickness_thresholds(labels: list[str], r: float) -> list[tuple[str, float]]:
    """``--front-thickness`` labels as thicknesses [m]: ``<k>L`` k particle layers (k 2r),
    ``<d>mm`` d millimetres at the simulation's scale (a = 0.146 m, Koshizuka & Oka's; times
    25.4 * 2.25 / 146 = 0.39 at Martin & Moyce's a = 2.25 in), a plain number a fraction of a."""
    out = []
    for lab in labels:
        if lab.endswith("L"):
            out.append((lab, float(lab[:-1]) * 2.0 * r))
        elif lab.endswith("mm"):
            out.append((lab, float(lab[:-2]) * 1e-3))
        else:
            out.append((lab, float(lab) * A))
    return out


def parse_thickness(labels: list[str]) -> str | None:
    """Why ``--front-thickness`` labels are malformed, or None."""
    for lab in labels:
        num = lab[:-1] if lab.endswith("L") else lab[:-2] if lab.endswith("mm") else lab
        try:
            v = float(num)
        except ValueError:
            return f"{lab!r}: expected <k>L (particle layers), <d>mm or a fraction of a"
        if not (math.isfinite(v) and v > 0):
            return f"{lab!r}: expected a positive finite thickness"
    return None


def run(sim: Simulation, n2: float, a: float = A, t_end: float = T_END,
        thick: list[tuple[str, float]] = (), tank: float = TANK) -> dict:
    """Step to Martin & Moyce's T = t_end (or until the front reaches the far wall): per step
    T, Z (front), tau, H (residual column); ``Z<d>``: the fronts of water at least d a deep
    (DEPTHS: the top of each 2r-wide column of particles); ``Zt<label>`` for each (label,
    thickness) of ``thick``: the front of the water at least that thick, the thickness of a
    4r-wide window of x being the water it holds per width, N (2r)^dim / (4r w^(dim - 2))
    (w the 3D channel's width; spray above the tongue adds to it, gaps do not)."""
    n = math.sqrt(n2)
    f = sim.fluid
    r = sim.state.r
    dim = sim.state.dim
    s = math.sqrt(G / a)
    ts, zs, hs = [0.0], [float(f["x"][0].max() + r) / a], [float(f["x"][1].max() + r) / (n2 * a)]
    zd = [[1.0] for _ in DEPTHS]
    zt = [[1.0] for _ in thick]
    per_window = (2.0 * r) ** dim / (4.0 * r * (WIDTH_3D * a) ** (dim - 2))
    while n * sim.time * s < t_end and zs[-1] < tank - 0.05:
        sim.step()
        x = f["x"]
        ts.append(sim.time)
        zs.append(float(x[0].max() + r) / a)
        back = x[0] < 4.0 * r
        hs.append(float(x[1][back].max() + r) / (n2 * a) if back.any() else 0.0)
        # fronts of the water at least d deep: the depth of each 2r-wide column of particles
        cell = np.floor(x[0] / (2.0 * r)).astype(np.int64)
        depth = np.zeros(cell.max() + 1)
        np.maximum.at(depth, cell, x[1] + r)
        for k, d in enumerate(DEPTHS):
            deep = depth[cell] >= d * a
            zd[k].append(float(x[0][deep].max() + r) / a if deep.any() else 0.0)
        if thick:  # the water per width in 4r-wide windows
            win = np.floor(np.maximum(x[0], 0.0) / (4.0 * r)).astype(np.int64)
            th = np.bincount(win) * per_window
            for k, (_lab, d) in enumerate(thick):
                deep = th[win] >= d
                zt[k].append(float(x[0][deep].max() + r) / a if deep.any() else 0.0)
    t = np.array(ts)
    out = {"T": n * s * t, "tau": s * t, "Z": np.array(zs), "H": np.array(hs),
           "steps": sim.step_count, "n": f.n}
    for k, d in enumerate(DEPTHS):
        out[f"Z{d:g}"] = np.array(zd[k])
    for k, (lab, _d) in enumerate(thick):
        out[f"Zt{lab}"] = np.array(zt[k])
    return out


def front_error(T: np.ndarray, Z: np.ndarray, ref: str, shift: float = 0.0,
                z_max: float = Z_MAX) -> tuple[float, float, int]:
    """Mean signed and largest absolute relative front error against ``ref`` (a name of
    REFERENCES or a ``validation/data`` file) at its points with T > 0, Z < z_max and within
    the run (the run's times shifted by ``shift``)."""
    tr, zr = reference(REFERENCES[ref][0] if ref in REFERENCES else ref)
    keep = (tr > 0) & (zr < z_max) & (tr <= T[-1] + shift)
    if not keep.any():
        return math.nan, math.nan, 0
    e = np.interp(tr[keep], T + shift, Z) / zr[keep] - 1.0
    return float(e.mean()), float(np.abs(e).max()), int(keep.sum())


def fit_shift(T: np.ndarray, Z: np.ndarray, ref: str, z_max: float = Z_MAX,
              shift_max: float = 0.8) -> tuple[float, float, float]:
    """The time shift T0 minimising the RMS relative error of Z_sim(T - T0) (grid search
    from -0.3 to ``shift_max``, 0.005 apart); returns T0 and the mean and largest errors
    after it."""
    tr, zr = reference(REFERENCES[ref][0] if ref in REFERENCES else ref)
    keep = (tr > 0) & (zr < z_max)
    best = (math.inf, 0.0)
    for t0 in np.arange(-0.3, shift_max, 0.005):
        k = keep & (tr <= T[-1] + t0)
        if k.sum() < min(5, keep.sum()):
            continue
        e = np.interp(tr[k], T + t0, Z) / zr[k] - 1.0
        best = min(best, (float(np.sqrt((e * e).mean())), float(t0)))
    t0 = best[1]
    mean, mx, _ = front_error(T, Z, ref, t0, z_max)
    return t0, mean, mx


def height_error(tau: np.ndarray, H: np.ndarray, table: str = HEIGHT) -> float:
    """Mean |H_sim - H_exp| over Martin & Moyce's tabulated tau > 0 within the run."""
    tr, hr = reference(table)
    keep = (tr > 0) & (tr <= tau[-1])
    return float(np.abs(np.interp(tr[keep], tau, H) - hr[keep]).mean()) if keep.any() else math.nan


def order(runs: dict[int, dict]) -> list[tuple[int, int, float, float]]:
    """Self-convergence of Z(T) over 0.5 <= T <= 3: (N, 2N, mean |Z_N - Z_2N|, order)."""
    ns = sorted(runs)
    grid = np.linspace(0.5, 3.0, 51)
    z = {}
    for n in ns:
        ok = grid <= runs[n]["T"][-1]
        z[n] = np.where(ok, np.interp(grid, runs[n]["T"], runs[n]["Z"]), np.nan)
    d = [(a, b, float(np.nanmean(np.abs(z[a] - z[b])))) for a, b in zip(ns, ns[1:], strict=False)]
    out = []
    for k, (a, b, e) in enumerate(d):
        p = math.log(d[k - 1][2] / e) / math.log(b / a) if k and e > 0 else math.nan
        out.append((a, b, e, p))
    return out


def print_convergence(label: str, runs: dict[int, dict]) -> None:
    """The self-convergence line of one solver and wall model (:func:`order`) where it has
    more than one resolution."""
    if len(runs) > 1:
        print(f"self-convergence {label}: " + "; ".join(
            f"{a}->{b}: {e:.4f}" + (f" (order {p:.2f})" if p == p else "")
            for a, b, e, p in order(runs)))


def simulate(solver: str, per_a: int, wall: str, n2: float, gate: float | None = None,
             folder: Path | None = None, dim: int = 2, solved: bool | str = False,
             thickness: list[str] = (), square: bool = False) -> dict | str:
    """One run; an error message if it blew up. ``thickness``: ``--front-thickness`` labels
    (:func:`thickness_thresholds`); ``square``: the square column in SQUARE's long tank."""
    tank, t_end = (SQUARE["tank"], SQUARE["t_end"]) if square else (TANK, T_END)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(scene(solver, per_a, wall, 1.0 if square else n2, gate_speed=gate,
                               gate_dir=folder, dim=dim, solved_walls=solved, tank=tank))
    t0 = time.perf_counter()
    try:
        out = run(sim, 1.0 if square else n2, t_end=t_end,
                  thick=thickness_thresholds(list(thickness), sim.state.r), tank=tank)
    except InstabilityError as e:
        return f"unstable at t = {sim.time:.3f} s: {str(e).splitlines()[0]}"
    out["wall"] = time.perf_counter() - t0
    return out


def save(path: Path, results: dict) -> None:
    """The runs' curves in one .npz (``--load`` prints and plots them again)."""
    arrays = {}
    for key, o in results.items():
        tag = "|".join(str(k) for k in key)
        for f in o:
            if f in ("T", "tau", "H") or f.startswith("Z"):
                arrays[f"{tag}|{f}"] = o[f]
        arrays[f"{tag}|info"] = np.array([o["steps"], o["n"], o["wall"]])
    np.savez_compressed(path, **arrays)


def load(path: Path) -> dict:
    """The runs saved by :func:`save`."""
    out: dict = {}
    with np.load(path) as d:
        for name in d.files:
            *tag, f = name.split("|")
            n2, solver, wall, per_a, gate = tag
            key = (float(n2), solver, wall, int(per_a), None if gate == "None" else float(gate))
            o = out.setdefault(key, {})
            if f == "info":
                o["steps"], o["n"], o["wall"] = int(d[name][0]), int(d[name][1]), float(d[name][2])
            else:
                o[f] = d[name]
    return out


def row(key: tuple, o: dict | str) -> str:
    """One line of the table."""
    n2, solver, wall, per_a, gate = key
    head = f"{solver:7s}{wall:>10s}{n2:4g}{per_a:5d}{'-' if gate is None else gate:>6}"
    if isinstance(o, str):
        return f"{head}  {o}"
    refs = list(REFERENCES)
    errs = [front_error(o["T"], o["Z"], r) for r in refs]
    alt = front_error(o["T"] * math.sqrt(2.0 / n2), o["Z"], refs[0])  # T = t sqrt(2g/a)
    s_mm = fit_shift(o["T"], o["Z"], refs[0])
    s_ko = fit_shift(o["T"], o["Z"], refs[2])
    return (f"{head}{o['n']:6d}{o['steps']:6d}"
            + "".join(f"{e[0]:+8.1%}/{e[1]:6.1%} " for e in errs)
            + f"{alt[0]:+8.1%}/{alt[1]:6.1%} "
            + f"{s_mm[0]:8.3f}{s_mm[1]:+7.1%}/{s_mm[2]:5.1%}"
            + f"{s_ko[0]:9.3f}{s_ko[1]:+7.1%}/{s_ko[2]:5.1%}"
            + f"{height_error(o['tau'], o['H']):7.3f}"
            + f"{np.interp(1.0, o['T'], o['Z']):7.3f}{o['wall']:7.1f}")


def square_row(key: tuple, o: dict | str) -> str:
    """One line of the ``--square`` table: the front against Martin & Moyce's square column
    (mean signed / largest |.|), the fitted time shift and the errors after it, the residual
    column's mean |H - H_exp|, Z at the table's first point (T = 3.9), steps and wall time."""
    solver, wall, per_a = key
    head = f"{solver:7s}{wall:>10s}{per_a:5d}"
    if isinstance(o, str):
        return f"{head}  {o}"
    z_max = SQUARE["z_max"]
    mean, mx, _ = front_error(o["T"], o["Z"], SQUARE["front"], z_max=z_max)
    t0, m0, x0 = fit_shift(o["T"], o["Z"], SQUARE["front"], z_max, SQUARE["shift_max"])
    return (f"{head}{o['n']:6d}{o['steps']:6d}{mean:+8.1%}/{mx:6.1%} "
            f"{t0:8.3f}{m0:+7.1%}/{x0:5.1%}"
            f"{height_error(o['tau'], o['H'], SQUARE['height']):7.3f}"
            f"{np.interp(3.9, o['T'], o['Z']):7.3f}{o['wall']:7.1f}")


def depth_row(o: dict) -> str:
    """The fronts of water at least d deep (``Z<d>``) and at least as thick as each
    ``--front-thickness`` label (``Zt<label>``) against Martin & Moyce (2.25 in) and K&O."""
    out, thick = [], []
    for d in DEPTHS:
        if f"Z{d:g}" in o:
            mm = front_error(o["T"], o[f"Z{d:g}"], "MM a=2.25in")
            ko = front_error(o["T"], o[f"Z{d:g}"], "K&O")
            out.append(f"depth >= {d:g} a: MM {mm[0]:+.1%}/{mm[1]:.1%}, K&O {ko[0]:+.1%}/"
                       f"{ko[1]:.1%}")
    for f in sorted(k for k in o if k.startswith("Zt")):
        mm = front_error(o["T"], o[f], "MM a=2.25in")
        ko = front_error(o["T"], o[f], "K&O")
        thick.append(f"thickness >= {f[2:]}: MM {mm[0]:+.1%}/{mm[1]:.1%}, K&O {ko[0]:+.1%}/"
                     f"{ko[1]:.1%}")
    lines = ["    fronts of deeper water: " + "; ".join(out)] if out else []
    if thick:
        lines.append("    fronts of thicker water: " + "; ".join(thick))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--per-a", type=int, nargs="+", default=[10, 20, 40],
                    help="particles across the column width a (default 10 20 40)")
    ap.add_argument("--solvers", nargs="+", default=list(SOLVERS))
    ap.add_argument("--walls", nargs="+", default=list(WALLS), choices=WALLS)
    ap.add_argument("--columns", type=float, nargs="*", default=[2.0],
                    help="column height over width n^2 (default 2; 1: the square column)")
    ap.add_argument("--gate", type=float, nargs="*", default=None,
                    help="gate speeds V [m/s] (DFSPH, free-slip, n^2 = 2, the middle "
                    "resolution); without values 0.6 1.2 2.4")
    ap.add_argument("--wall-viscosity", type=float, nargs="+", default=None, metavar="NU_B",
                    help="no-slip walls whose viscous term has the coefficient NU_B [m^2/s] "
                    "instead of nu (a rough, turbulent floor's friction as an eddy viscosity; "
                    "DFSPH, n^2 = 2, the middle resolution)")
    ap.add_argument("--floor-viscosity", type=float, nargs="+", default=None, metavar="NU_B",
                    help="as --wall-viscosity, on the floor only (boxes[].viscosity_factors); "
                    "the side walls free-slip")
    ap.add_argument("--surface-tension", type=float, nargs="+", default=None, metavar="SIGMA",
                    help="free-slip runs with Mueller et al. 2003's surface tension SIGMA [N/m] "
                    "(no adhesion) at the simulation's a = 0.146 m; water's 0.0728 N/m at "
                    "Martin & Moyce's a = 2.25 in has the same Bond number as 0.475 N/m here "
                    "(DFSPH, n^2 = 2, the middle resolution)")
    ap.add_argument("--front-thickness", nargs="+", default=[], metavar="D",
                    help="also the fronts of the water at least D thick (per width, 4r-wide "
                    "windows): <k>L k particle layers, <d>mm millimetres at the simulation's "
                    "(Koshizuka & Oka's) scale, or a fraction of a; e.g. 2L 3L 5mm")
    ap.add_argument("--quick", action="store_true", help="DFSPH, free-slip, 10 and 20 across")
    ap.add_argument("--square", action="store_true",
                    help="only the square column (n^2 = 1) in a tank 15 a long to T = 9.8, "
                    "against Martin & Moyce's square-column table (the --solvers, --walls, "
                    "--per-a given, and with --floor-viscosity DFSPH at the middle resolution "
                    "with that floor friction; plot dam_break_square.png)")
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3),
                    help="3: the column in a channel 0.5 a wide between side walls (no gate)")
    ap.add_argument("--solved-walls", nargs="?", const=True, default=False,
                    choices=["velocity", "density"],
                    help="configuration.boundary.solved: wall pressures solved in the PPE "
                         "(alone or 'velocity': the rate held; 'density': the density held)")
    ap.add_argument("--save", type=Path, help="write the runs' curves to this .npz")
    ap.add_argument("--load", type=Path, nargs="*", default=[],
                    help="print and plot runs saved with --save (runs nothing but --gate)")
    args = ap.parse_args(argv)
    if args.quick:
        args.solvers, args.walls, args.per_a = ["dfsph"], ["free-slip"], [10, 20]
    bad = parse_thickness(args.front_thickness)
    if bad:
        ap.error(f"--front-thickness {bad}")
    for opt, vals in (("--floor-viscosity", args.floor_viscosity),
                      ("--surface-tension", args.surface_tension)):
        if vals and not all(math.isfinite(v) and v >= 0 for v in vals):
            ap.error(f"{opt} {vals}: expected finite values >= 0")
    logging.getLogger("sphkit").setLevel(logging.ERROR)
    if args.square:
        return square(args)
    walls = ("solved (density level)" if args.solved_walls == "density"
             else "solved" if args.solved_walls else "MLS")
    print(f"{args.dim}D dam break ({walls} walls), a = {A} m, tank {TANK} a, nu = {NU} m^2/s; "
          "front Z = x/a "
          "against T = n t sqrt(g/a); errors (Z_sim/Z_exp - 1): mean (signed) / max |.|; "
          "'MM 2g/a': against MM a = 2.25 in on T = t sqrt(2g/a); T0: fitted time shift and the "
          "errors after it; dH: mean |H - H_exp| (MM a = 2.25 in); gate: its speed [m/s]")
    print(f"{'solver':7s}{'walls':>10s}{'n2':>4s}{'a/2r':>5s}{'gate':>6s}{'N':>6s}{'steps':>6s}"
          + "".join(f"{r:>16s}" for r in REFERENCES) + f"{'MM 2g/a':>16s}{'T0 (MM)':>8s}"
          + f"{'after':>14s}{'T0 (K&O)':>9s}{'after':>14s}{'dH':>7s}{'Z(T=1)':>7s}{'wall':>7s}")
    results: dict = {}
    for path in args.load:
        for key, o in load(path).items():
            results[key] = o
            print(row(key, o), flush=True)
            if depth_row(o):
                print(depth_row(o), flush=True)
    cases = [] if args.load else [
        (n2, solver, wall, per_a, None) for n2 in args.columns for solver in args.solvers
        for wall in args.walls for per_a in args.per_a]
    if args.gate is not None:
        per_a = sorted(args.per_a)[len(args.per_a) // 2]
        cases += [(2.0, "dfsph", "free-slip", per_a, v) for v in (args.gate or [0.6, 1.2, 2.4])]
    if args.wall_viscosity:
        if not all(v >= 0 for v in args.wall_viscosity):
            ap.error(f"--wall-viscosity {args.wall_viscosity}: expected coefficients >= 0")
        per_a = sorted(args.per_a)[len(args.per_a) // 2]
        cases += [(2.0, "dfsph", f"no-slip:{v:g}", per_a, None) for v in args.wall_viscosity]
    per_a = sorted(args.per_a)[len(args.per_a) // 2]
    cases += [(2.0, "dfsph", f"floor:{v:g}", per_a, None) for v in args.floor_viscosity or []]
    cases += [(2.0, "dfsph", f"sigma:{v:g}", per_a, None) for v in args.surface_tension or []]
    with tempfile.TemporaryDirectory() as tmp:
        for key in cases:
            n2, solver, wall, per_a, gate = key
            o = simulate(solver, per_a, wall, n2, gate, Path(tmp), args.dim, args.solved_walls,
                         args.front_thickness)
            print(row(key, o), flush=True)
            if not isinstance(o, str):
                print(depth_row(o), flush=True)
                results[key] = o
                if args.save:
                    save(args.save, results)
    groups = sorted({k[:3] + (k[4],) for k in results}, key=str)
    for n2, solver, wall, gate in groups:
        runs = {k[3]: o for k, o in results.items() if k[:3] == (n2, solver, wall) and k[4] == gate}
        print_convergence(f"{solver} {wall} n2 = {n2:g}", runs)
    _plot(results, args.dim)
    return 0


def _label(ax: object, x: str, y: str, title: str) -> None:
    """Axis labels, a small title and the legend of one plot panel."""
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=6)


def square(args: argparse.Namespace) -> int:
    """``--square``: the square column against Martin & Moyce's n^2 = 1 table."""
    print(f"2D square column (n^2 = 1), a = {A} m, tank {SQUARE['tank']:g} a, nu = {NU} m^2/s; "
          "front Z = x/a against T = t sqrt(g/a), Martin & Moyce's square column (a = 2.25 in; "
          "validation/data/martin_moyce_1952_n2_1_front.csv, Z = 6-13); errors (Z_sim/Z_exp - "
          "1): mean (signed) / max |.|; T0: fitted time shift and the errors after it; dH: mean "
          "|H - H_exp|; Z(3.9): the front at the table's first point (6.00)")
    print(f"{'solver':7s}{'walls':>10s}{'a/2r':>5s}{'N':>6s}{'steps':>6s}{'MM n2=1':>16s}"
          f"{'T0':>8s}{'after':>14s}{'dH':>7s}{'Z(3.9)':>7s}{'wall':>7s}")
    results: dict = {}
    cases = [(solver, wall, per_a) for solver in args.solvers for wall in args.walls
             for per_a in args.per_a]
    per_a = sorted(args.per_a)[len(args.per_a) // 2]  # --floor-viscosity: DFSPH, the middle
    cases += [("dfsph", f"floor:{v:g}", per_a) for v in args.floor_viscosity or []]
    for solver, wall, per_a in cases:
        o = simulate(solver, per_a, wall, 1.0, square=True)
        print(square_row((solver, wall, per_a), o), flush=True)
        if not isinstance(o, str):
            results[(solver, wall, per_a)] = o
    for solver, wall in sorted({k[:2] for k in results}):
        runs = {k[2]: o for k, o in results.items() if k[:2] == (solver, wall)}
        print_convergence(f"{solver} {wall} n2 = 1", runs)
    plt = pyplot()
    if plt is None or not results:
        return 0
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4))
    t, z = reference(SQUARE["front"])
    ax.plot(t[1:], z[1:], "ko", ms=4, mfc="none", label="Martin & Moyce, n2 = 1")
    tau, h = reference(SQUARE["height"])
    bx.plot(tau, h, "ko", ms=4, mfc="none", label="Martin & Moyce, n2 = 1")
    top = max(k[2] for k in results)
    for (solver, wall, per_a), o in sorted(results.items()):
        # the free-slip runs at the finest resolution, DFSPH's no-slip one and the floor's
        if wall.startswith("floor") or (per_a == top and (
                wall == "free-slip" or solver == "dfsph")):
            ls = "-" if wall == "free-slip" else ":" if wall == "no-slip" else "--"
            ax.plot(o["T"], o["Z"], ls, lw=1, label=f"{solver} {wall} a/2r={per_a}")
            bx.plot(o["tau"], o["H"], ls, lw=1, label=f"{solver} {wall} a/2r={per_a}")
    _label(ax, "T = t sqrt(g/a)", "Z = x/a", "Square column: surge front")
    bx.set_xlim(0, 7)
    _label(bx, "tau = t sqrt(g/a)", "H = h/a", "Square column: residual column at the back wall")
    path = Path(__file__).with_name("dam_break_square.png")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    print(f"plot: {path}")
    return 0


def _plot(results: dict, dim: int = 2) -> None:
    plt = pyplot()
    if plt is None:
        return
    if not results:
        return
    fig, (ax, bx, cx) = plt.subplots(1, 3, figsize=(15, 4))
    for ref, mk in zip(REFERENCES, ("ko", "k^", "ks"), strict=True):
        t, z = reference(REFERENCES[ref][0])
        ax.plot(t, z, mk, ms=4, mfc="none", label=ref)
    tau, h = reference(HEIGHT)
    bx.plot(tau, h, "ko", ms=4, mfc="none", label="MM a=2.25in")
    tt = np.linspace(0, 1.5, 10)
    ax.plot(tt, 1 + 2 * tt, "k:", lw=0.8, label="Ritter 1 + 2T")
    top = max(k[3] for k in results)
    for (n2, solver, wall, per_a, gate), o in sorted(results.items(), key=str):
        if gate is not None:
            ax.plot(o["T"], o["Z"], "--", lw=0.8, label=f"dfsph n2=2 gate {gate:g} m/s")
            bx.plot(o["tau"], o["H"], "--", lw=0.8, label=f"gate {gate:g} m/s")
        elif (per_a == top or n2 != 2.0) and wall == "free-slip":
            ax.plot(o["T"], o["Z"], lw=1, label=f"{solver} n2={n2:g} a/2r={per_a}")
            if n2 == 2.0:
                bx.plot(o["tau"], o["H"], lw=1, label=f"{solver} a/2r={per_a}")
            if n2 == 2.0 and solver == "dfsph":
                t0 = fit_shift(o["T"], o["Z"], "MM a=2.25in")[0]
                ax.plot(o["T"] + t0, o["Z"], "k-.", lw=0.8, label=f"dfsph shifted by T0 = {t0:.3f}")
    for (solver, wall), mk in zip(sorted({(k[1], k[2]) for k in results if k[0] == 2.0
                                           and k[4] is None}), "ov^sdxP+*<>", strict=False):
        keys = sorted(k for k in results if k[:3] == (2.0, solver, wall) and k[4] is None)
        if len(keys) > 1:
            cx.plot([k[3] for k in keys],
                    [front_error(results[k]["T"], results[k]["Z"], "K&O")[0] for k in keys],
                    marker=mk, ls="-" if wall == "free-slip" else ":", label=f"{solver} {wall}")
    ax.set_xlim(0, 3.4)
    ax.set_ylim(1, 4.2)
    _label(ax, "T = n t sqrt(g/a)", "Z = x/a", "Surge front (free-slip walls, finest)")
    bx.set_xlim(0, 3.0)
    _label(bx, "tau = t sqrt(g/a)", "H = h/(n^2 a)", "Residual column at the back wall (n2 = 2)")
    cx.set_xscale("log")
    _label(cx, "particles across a", "mean (Z_sim / Z_exp - 1) against K&O",
           "Front error against resolution (n2 = 2)")
    path = Path(__file__).with_name(f"dam_break{'_3d' if dim == 3 else ''}.png")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    print(f"plot: {path}")


if __name__ == "__main__":
    sys.exit(main())
