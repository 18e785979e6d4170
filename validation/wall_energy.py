"""Mechanical energy of fluid at rest in a small closed box, per wall pressure term.

    python validation/wall_energy.py [--dim 3] [--n 5] [--solver iisph] [--until 0.01]
        [--dt 0.0005] [--walls mls mirror symmetric solved density] [--akinci-box-volumes]
    python validation/wall_energy.py --column [dfsph iisph pcisph pbf] [--until 0.5]
        [--akinci-box-volumes]

A cube (square in 2D) of ``n`` particles per side, r = 2 cm, fills a closed ``boxes`` container
of the same width and twice its height (one wall layer, the fluid's lattice volume, sphkit's
start-up: hydrostatic start, relaxation, consistent masses), gravity 9.81 m/s^2, no viscosity,
time step ``--dt``. Nothing should move: the start is hydrostatic and the box is closed, so the
kinetic energy KE and the change of the mechanical energy ``E = KE + sum m g y`` should stay
near zero.

For each wall term of the PPE solvers (``configuration.boundary``; ``core.ppe.
kappa_accel_cached``: ``a_i = ... - sum_b V_b ((1 + m_b) k_i + k_b) grad W_ib``):

* ``mls``: the default of ``boxes`` (Band et al. 2018's extrapolated ``k_b``, ``m_b = 0``);
* ``mirror``: ``p_b = p_i`` mirrored fully (``m_b = 1``, ``k_b = 0``);
* ``symmetric``: ``V_b k_i`` alone (``boundary.symmetric``), SPlisHSPlasH's term: the only one
  that is the transpose of the density constraint's wall part (the force of a Lagrange
  multiplier), so the only one that does no work on a flow that keeps the constraint;
* ``solved``: the static walls' own pressures solved in the PPE (``boundary.solved: true``,
  the fluid's density rate at each wall particle held); ``density``: the same with the
  density itself held at its start value (``boundary.solved: "density"``).

``--akinci-box-volumes`` gives the box walls Akinci's volumes ``1 / sum_k W_bk`` again (before
2026-12-05; since, they keep the fluid's lattice volume). ``--column [SOLVER ...]``: instead, a
column 0.4 x 0.6 (x 0.2) m filling a box of its width (and depth), 2D and 3D, without and with
viscosity, to ``--until`` (0.5 s): the largest speed of any particle and the mean speed at the
end.

the table gives, at ``--until``: the largest speed, KE, the change of E, and the work done by
the wall term's share beyond the symmetric one (``-sum_b V_b (m_b k_i + k_b) grad W_ib`` times
``m_i v_i``, summed over the steps with the end-of-step velocity), split by where the wall
particle sits: on the floor, on a side wall, on an edge of the box, in a corner. The share is
read from the solver's last call of ``kappa_accel_cached`` in each step (instrumentation of
this script only; it wraps the Jacobi loop's pass, ``sphkit.core.solver``, so the work columns
are those of IISPH and DFSPH: PCISPH's own loop shows zeros there, its energies are right).
"""

from __future__ import annotations

import argparse
import logging
import warnings

import numpy as np

import sphkit.core.solver as solver_module
from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

G = 9.81
R = 0.02
KINDS = ("floor", "side", "edge", "corner")


def scene(dim: int, n: int, solver: str, walls: str, dt: float) -> Scene:
    """The closed box of the module docstring."""
    L = 2 * R * n
    z, zl = ([0.0], [L]) if dim == 3 else ([], [])
    boundary: dict = {"symmetric": walls == "symmetric",
                      "solved": "density" if walls == "density" else walls == "solved"}
    if walls == "mirror":
        boundary["pressure"] = "mirror"
    return Scene.model_validate({
        "configuration": {"dim": dim, "particle_radius": R, "gravity": [0.0, -G, *z],
                          "pressure": {"method": solver, "max_error": 0.05},
                          "time": {"dt_max": dt}, "boundary": boundary},
        "materials": [{"id": "fluid", "density0": 1000.0}],
        "fluid_blocks": [{"start": [0.0, 0.0, *z], "end": [L, L, *zl], "material": "fluid"}],
        "boxes": [{"min": [0.0, 0.0, *z], "max": [L, 2 * L, *zl], "layers": 1}],
    })


class _LastCall:
    """Wraps the solvers' ``kappa_accel_cached`` and keeps the arguments of its last call
    (the converged field of the step: the solvers call it once more after their loop)."""

    def __init__(self) -> None:
        self.original = solver_module.kappa_accel_cached
        self.args: dict = {}

    def __call__(self, k, kb, off, idx, boff, bidx, mirror, gw, gwb, dim, a, inv_c=None):  # noqa: ANN001, ANN204
        self.args = {"k": k.copy(), "kb": kb.copy(), "boff": boff, "bidx": bidx,
                     "mirror": mirror.copy(), "gwb": gwb.copy(), "inv_c": inv_c}
        return self.original(k, kb, off, idx, boff, bidx, mirror, gw, gwb, dim, a, inv_c)


def wall_kind(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """floor / side / edge / corner for wall particles x (dim, M) of the box [lo, hi]."""
    outside = ((x.T < lo) | (x.T > hi)).sum(axis=1)
    kind = np.array(["", "face", "edge", "corner"])[outside]
    return np.where(kind == "face", np.where(x[1] < lo[1], "floor", "side"), kind)


def run(dim: int, n: int, solver: str, walls: str, dt: float, until: float) -> dict:
    """One row of the table."""
    spy = _LastCall()
    solver_module.kappa_accel_cached = spy
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sim = Simulation(scene(dim, n, solver, walls, dt))
        f, b = sim.fluid, sim.state.boundary
        L = 2 * R * n
        kind = wall_kind(b["x"], np.zeros(dim), np.array([L, 2 * L, L][:dim]))
        work = dict.fromkeys(KINDS, 0.0)

        def energy() -> float:
            return float(0.5 * (f["m"] * (f["v"] ** 2).sum(axis=0)).sum()
                         + G * (f["m"] * f["x"][1]).sum())

        e0, note = energy(), ""
        try:
            while sim.time < until - 1e-12:
                st = sim.step()
                c = spy.args
                if not c:
                    continue
                rows = np.repeat(np.arange(f.n), np.diff(c["boff"]))
                bb = c["bidx"]
                inv_c = np.ones(f.n) if c["inv_c"] is None else c["inv_c"]
                extra = c["mirror"][bb] * c["k"][rows] + (c["kb"][bb] if len(c["kb"]) else 0.0)
                power = -f["m"][rows] * inv_c[rows] * extra * (c["gwb"] * f["v"][:, rows]).sum(0)
                for k in KINDS:
                    work[k] += float(power[kind[bb] == k].sum()) * st.dt
        except InstabilityError as e:
            note = f"unstable at {e.stats.time:.4f} s"
        speed = np.sqrt((f["v"] ** 2).sum(axis=0))
        return {"n": f.n, "vmax": float(speed.max()),
                "ke": float(0.5 * (f["m"] * speed ** 2).sum()), "de": energy() - e0,
                "work": work, "note": note}
    finally:
        solver_module.kappa_accel_cached = spy.original


def akinci_box_volumes() -> None:
    """Give the box walls Akinci's volumes ``1 / sum_k W_bk`` again, as before 2026-12-05
    (their lattice cells set to 0, :func:`sphkit.boundary.akinci2012.static_volumes`)."""
    import sphkit.world.walls as walls_module

    shell = walls_module.box_shell

    def no_cells(*args, **kw):  # noqa: ANN002, ANN003, ANN202 (box_shell's signature)
        pts, cells = shell(*args, **kw)
        return pts, np.zeros_like(cells)

    walls_module.box_shell = no_cells


def column_scene(dim: int, solver: str, viscosity: float) -> Scene:
    """A column filling a box of its width (and depth): 0.4 x 0.6 (x 0.2) m of fluid in a box
    0.8 m high, r = 2 cm, one wall layer, SPlisHSPlasH's tolerance 0.05 %, dt at most 2 ms."""
    z, zl = ([0.0], [0.2]) if dim == 3 else ([], [])
    return Scene.model_validate({
        "configuration": {"dim": dim, "particle_radius": R, "gravity": [0.0, -G, *z],
                          "pressure": {"method": solver, "max_error": 0.05},
                          "time": {"dt_max": 0.002}},
        "materials": [{"id": "fluid", "viscosity": {"method": "standard",
                                                    "coefficient": viscosity}
                       if viscosity else {"method": "none"}}],
        "fluid_blocks": [{"start": [0.0, 0.0, *z], "end": [0.4, 0.6, *zl], "material": "fluid"}],
        "boxes": [{"min": [0.0, 0.0, *z], "max": [0.4, 0.8, *zl], "layers": 1}],
    })


def column(solvers: list[str], until: float) -> None:
    """The ``--column`` table: fastest particle over the run and mean speed at its end."""
    print(f"column filling its box at rest, r = {R} m, until {until} s: largest speed of any "
          "particle at any step, mean speed at the end [m/s]")
    print(f"{'dim':>3s} {'solver':8s} {'nu':>5s} {'n':>5s} {'vmax':>8s} {'at step':>7s} "
          f"{'mean':>8s}  note")
    for dim in (2, 3):
        for solver in solvers:
            for nu in (0.0, 0.01):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    sim = Simulation(column_scene(dim, solver, nu))
                speeds, note = [], ""
                try:
                    while sim.time < until - 1e-12:
                        speeds.append(sim.step().max_velocity)
                except InstabilityError as e:
                    note = f"unstable at step {e.stats.step}, {e.stats.time:.4f} s"
                mean = float(np.sqrt((sim.fluid["v"] ** 2).sum(axis=0)).mean())
                k = int(np.argmax(speeds)) if speeds else -1
                print(f"{dim:3d} {solver:8s} {nu:5.2f} {sim.fluid.n:5d} "
                      f"{max(speeds, default=0.0):8.3f} {k + 1:7d} {mean:8.4f}  {note}",
                      flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dim", type=int, default=3, choices=[2, 3])
    ap.add_argument("--n", type=int, default=5, help="particles per side of the fluid block")
    ap.add_argument("--solver", default="iisph")
    ap.add_argument("--until", type=float, default=0.01)
    ap.add_argument("--dt", type=float, default=0.0005)
    ap.add_argument("--walls", nargs="+", default=["mls", "mirror", "symmetric", "solved"],
                    choices=["mls", "mirror", "symmetric", "solved", "density"])
    ap.add_argument("--akinci-box-volumes", action="store_true",
                    help="box walls with Akinci's volumes 1 / sum W, as before 2026-12-05")
    ap.add_argument("--column", nargs="*", default=None, metavar="SOLVER",
                    help="instead: a column filling its box at rest, per solver (default "
                    "dfsph iisph pcisph pbf), 2D and 3D, without and with viscosity 0.01")
    args = ap.parse_args()
    logging.getLogger("sphkit").setLevel(logging.ERROR)
    if args.akinci_box_volumes:
        akinci_box_volumes()
    if args.column is not None:
        column(args.column or ["dfsph", "iisph", "pcisph", "pbf"],
               args.until if args.until != 0.01 else 0.5)
        return
    print(f"closed box, {args.dim}D, {args.n} particles per side, r = {R} m, {args.solver}, "
          f"dt {args.dt} s, until {args.until} s; energies in J (per m in 2D)")
    print(f"{'walls':10s} {'n':>5s} {'vmax':>7s} {'KE':>9s} {'dE':>10s} "
          + " ".join(f"{'W ' + k:>10s}" for k in KINDS) + "  note")
    for walls in args.walls:
        o = run(args.dim, args.n, args.solver, walls, args.dt, args.until)
        print(f"{walls:10s} {o['n']:5d} {o['vmax']:7.3f} {o['ke']:9.2e} {o['de']:10.2e} "
              + " ".join(f"{o['work'][k]:10.2e}" for k in KINDS) + f"  {o['note']}", flush=True)


if __name__ == "__main__":
    main()
