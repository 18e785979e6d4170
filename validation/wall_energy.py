"""Mechanical energy of fluid at rest in a small closed box, per wall pressure term.

    python validation/wall_energy.py [--dim 3] [--n 5] [--solver iisph] [--until 0.01]
        [--dt 0.0005] [--walls mls mirror symmetric solved density]

A cube (square in 2D) of ``n`` particles per side, r = 2 cm, fills a closed ``boxes`` container
of the same width and twice its height (one wall layer, Akinci volumes, sphkit's start-up:
hydrostatic start, relaxation, consistent masses), gravity 9.81 m/s^2, no viscosity, time step
``--dt``. Nothing should move: the start is hydrostatic and the box is closed, so the kinetic
energy KE and the change of the mechanical energy ``E = KE + sum m g y`` should stay near zero.

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
        "boxes": [{"min": [0.0, 0.0, *z], "max": [L, 2 * L, *zl]}],
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dim", type=int, default=3, choices=[2, 3])
    ap.add_argument("--n", type=int, default=5, help="particles per side of the fluid block")
    ap.add_argument("--solver", default="iisph")
    ap.add_argument("--until", type=float, default=0.01)
    ap.add_argument("--dt", type=float, default=0.0005)
    ap.add_argument("--walls", nargs="+", default=["mls", "mirror", "symmetric", "solved"],
                    choices=["mls", "mirror", "symmetric", "solved", "density"])
    args = ap.parse_args()
    logging.getLogger("sphkit").setLevel(logging.ERROR)
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
