"""One PCISPH solve of validation/hydrostatic.py's column, traced sweep by sweep.

    python validation/pcisph_trace.py [--dim 2] [--radius R] [--width 0.6] [--step 519]
        [--boundary bender2019] [--sweeps 0 5 10 20 30 50 99] [--cluster 2.5]

Runs the ``splishsplash`` column of ``hydrostatic.py`` (PCISPH, the boundary model's default
boundary pressure) to the step before ``--step`` exactly as ``hydrostatic.py`` does, then
repeats that step's solve outside :class:`sphkit.pressure.pcisph.PCISPH` with the same
prediction, update and stopping rule, and prints:

* the particle with the largest predicted compression at sweep 0 ("the particle"): its distance
  to the side walls and the floor, velocity, fluid neighbours, its volume-map quantities where
  the boundary is a map (distance phi and abs(grad phi) of the map at it, V_B; its virtual
  particle: distance, V_b, mirrored share), its PPE diagonal against the template's and its
  capped factor;
* per sweep in ``--sweeps``: average and largest compression, the particle's compression,
  pressure ``p~`` and the response ``d rho*_i / d p~_i`` of its predicted density to its own
  pressure (finite difference with the other pressures as they are; linear: ``-dt^2 D_i``), its
  predicted displacement, and its neighbours' pressures;
* at sweeps 0, 5, 10 and 15 the extreme eigenvalues of ``M = -f_i d rho*_i / d p~_j`` over the
  particles within ``--cluster`` h of it (the sweep is ``p~ <- p~ + f (rho* - 1)``, linearly an
  iteration with ``I - M``: it converges while M's eigenvalues lie in (0, 2)) and the largest
  entries of the lowest mode.

The solve is traced, not continued: the script stops after it. Single fluid only. Results:
validation/README.md, "2D PCISPH with volume maps: what diverges at step 519".
"""

from __future__ import annotations

import argparse
import logging
import tempfile
from pathlib import Path

import numpy as np

from sphkit.core.ppe import density_at, diagonal_cached, kappa_accel_cached
from sphkit.core.solver import PairGradients
from sphkit.core.state import SimState
from sphkit.pressure import pcisph
from sphkit.simulation import Simulation

ROOT = Path(__file__).resolve().parent


class _Traced(Exception):
    """Raised once the traced solve is printed (ends the run)."""


def _map_point(sim: Simulation, x: np.ndarray) -> str:
    """The first volume or density map's phi, abs(grad phi) and V_B at x (dim,), in r and V0."""
    maps = getattr(sim.boundary_model, "maps", [])
    if not maps:
        return "no map"
    bm = maps[0]
    r, dim = sim.state.r, sim.state.dim
    e = 1e-6
    pts = np.repeat(x[:, None], 2 * dim + 1, axis=1)
    for d in range(dim):
        pts[d, 1 + 2 * d] += e
        pts[d, 2 + 2 * d] -= e
    phi = bm.eval_phi(pts)
    grad = np.array([(phi[1 + 2 * d] - phi[2 + 2 * d]) / (2 * e) for d in range(dim)])
    V = bm.eval_values(pts[:, :1])[0]
    V0 = float(sim.fluid["V0"][0])
    return (f"map phi {phi[0] / r:.3f} r, abs(grad phi) {np.linalg.norm(grad):.3f}, "
            f"V_B {V / V0:.2f} V0")


def trace(sim: Simulation, state: SimState, dt: float, sweeps: list[int],
          cluster: float, width: float) -> None:
    """The traced PCISPH solve of this step (see the module docstring)."""
    solver = sim.pressure
    f, b = state.fluid, state.boundary
    nl, nb = state.nl_ff, state.nl_fb
    x, v, a = f["x"], f["v"], f["a"]
    n, r, dim = f.n, state.r, state.dim
    coupling = state.coupling
    mirror = coupling.mirror(state)
    kb = coupling.boundary_kappa(state)
    g = PairGradients.of(state)
    rest = state.rest()
    factor = solver.delta / (dt * dt)
    scale = pcisph.diagonal_cap(state, g, solver.d0)
    factors = np.full(n, factor) if scale is None else np.asarray(scale) * factor
    D = np.empty(n)
    diagonal_cached(nl.offsets, nb.offsets, nb.indices, coupling.mirror(state, diagonal=True),
                    g.gw, g.gwb, dim, D)
    still = np.empty((dim, 0))

    def predicted(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ap = np.zeros(x.shape)
        kappa_accel_cached(p, kb(p), nl.offsets, nl.indices, nb.offsets, nb.indices, mirror,
                           g.gw, g.gwb, dim, ap, rest.inv_c, kb.phase)
        dx = dt * (v + dt * (a + ap))
        bx, bV, nbp, _ = coupling.boundary_at(state, dx)
        rho = np.empty(n)
        density_at(x + dx, rest.mu, nl.offsets, nl.indices, bx, still, bV, nbp.offsets,
                   nbp.indices, state.rho0, state.h, state.kid, dim, rho)
        return rho, dx

    print(f"step {state.step}, dt {dt:.4g} s; PPE diagonal D_i / d0 in [{D.min() / solver.d0:.3f}, "
          f"{D.max() / solver.d0:.3f}], capped (CAP {pcisph.CAP}): "
          f"{int(np.sum(D > pcisph.CAP * solver.d0))}")
    p = np.zeros(n)
    i = -1
    control = solver.control
    for k in range(control.max_iterations):
        rho, dx = predicted(p)
        e = np.maximum(rho - 1.0, 0.0)
        if k == 0:
            i = int(np.argmax(e))
            xi = x[:, i]
            js = nl.indices[nl.offsets[i]:nl.offsets[i + 1]]
            dist = np.linalg.norm(x[:, js] - xi[:, None], axis=0) / r
            print(f"the particle: index {i}, id {int(f['id'][i])}, x {xi} m, v {v[:, i]} m/s; "
                  f"{len(js)} fluid neighbours at {np.round(dist, 2)} r")
            left, right = (xi[0] + width / 2) / r, (width / 2 - xi[0]) / r
            print(f"  {left:.2f} r off the left wall, {right:.2f} r off the right, "
                  f"{xi[1] / r:.2f} r above the floor; {_map_point(sim, xi)}")
            for kk in range(nb.offsets[i], nb.offsets[i + 1]):
                bb = nb.indices[kk]
                share = b["pressure_mirror"][bb] if "pressure_mirror" in b.fields else 0.0
                print(f"  boundary neighbour {bb}: x_b - x_i {(b['x'][:, bb] - xi) / r} r, V_b "
                      f"{b['V'][bb] / f['V0'][i]:.2f} V0, mirrored share {share}")
            print(f"  D_i / d0 {D[i] / solver.d0:.3f}, factor / template's "
                  f"{factors[i] / factor:.3f}")
        if k in sweeps:
            eps = 1e-4 * max(p[i], 1.0)
            pp = p.copy()
            pp[i] += eps
            J = (predicted(pp)[0][i] - rho[i]) / eps
            js = nl.indices[nl.offsets[i]:nl.offsets[i + 1]]
            step = np.linalg.norm(dx[:, i]) / r
            print(f"sweep {k:3d}: avg / max compression {100 * e.mean():.4f} / "
                  f"{100 * e.max():.3f} %; the particle {100 * (rho[i] - 1):+.3f} %, p~ "
                  f"{p[i]:.4g} m^2/s^2, d rho*/d p~ {J:+.4g} (linear {-dt * dt * D[i]:+.4g}), "
                  f"|dx| {step:.3f} r; neighbours' p~ {np.round(p[js], 1)}")
        if k in (0, 5, 10, 15):
            cl = np.where(np.linalg.norm(x - x[:, i:i + 1], axis=0) < cluster * state.h)[0]
            M = np.zeros((len(cl), len(cl)))
            for c, j in enumerate(cl):
                pp = p.copy()
                pp[j] += 1e-3
                M[:, c] = -(predicted(pp)[0][cl] - rho[cl]) / 1e-3 * factors[cl]
            w, vec = np.linalg.eig(M)
            o = np.argsort(w.real)
            top = np.argsort(-np.abs(vec[:, o[0]]))[:5]
            print(f"  sweep {k}: {len(cl)} particles within {cluster} h; eigenvalues of M: lowest "
                  f"{np.round(w[o[:3]].real, 4)}, highest {np.round(w[o[-2:]].real, 4)}; lowest "
                  f"mode's largest entries at indices {[int(cl[t]) for t in top]}")
        p = p + factors * e
        if k + 1 >= control.min_iterations and e.mean() <= control.tolerance:
            print(f"converged after {k + 1} sweeps")
            break
    raise _Traced


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=2, choices=[2, 3])
    ap.add_argument("--radius", type=float, default=None, help="hydrostatic.py's default")
    ap.add_argument("--width", type=float, default=0.6)
    ap.add_argument("--step", type=int, default=519, help="the step whose solve is traced")
    ap.add_argument("--boundary", default="bender2019",
                    choices=["akinci2012", "koschier2017", "bender2019"])
    ap.add_argument("--sweeps", type=int, nargs="+", default=[0, 1, 2, 5, 10, 20, 30, 50, 99])
    ap.add_argument("--cluster", type=float, default=2.5, help="cluster radius in h")
    args = ap.parse_args()
    if args.step < 1:
        raise SystemExit("--step: a step number from 1")
    import sys

    sys.path.insert(0, str(ROOT))
    import hydrostatic

    logging.disable(logging.WARNING)
    with tempfile.TemporaryDirectory() as cache:
        scene = hydrostatic.column("splishsplash", "pcisph", args.boundary, "default", args.dim,
                                   args.width, cache, radius=args.radius)
        sim = Simulation(scene)
        plain = pcisph.PCISPH.solve

        def solve(self: pcisph.PCISPH, state: SimState, dt: float) -> object:
            if state.step == args.step:
                trace(sim, state, dt, args.sweeps, args.cluster, args.width)
            return plain(self, state, dt)

        pcisph.PCISPH.solve = solve
        try:
            sim.run(until=1e9, fps=25.0)
        except _Traced:
            pass
        finally:
            pcisph.PCISPH.solve = plain


if __name__ == "__main__":
    main()
