"""The MLS wall pressure with its transpose in the PPE rows (``configuration.boundary.
conservative``, :meth:`sphkit.core.methods.BoundaryCoupling.transposed_walls`).

The scene is ``tests/test_solved_walls.py``'s closed 2D box (5 x 5 particles, r = 2 cm, at rest,
20 steps of 0.5 ms), where the default MLS wall term gains 0.24 J/m.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pydantic import ValidationError

from sphkit.core.ppe import kappa_accel_cached, pair_divergence_cached, wall_sums, wall_transpose
from sphkit.core.solver import PairGradients
from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

R = 0.02
G = 9.81


def _box(solver: str) -> Scene:
    L = 10 * R
    return Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": R, "gravity": [0.0, -G],
                          "pressure": {"method": solver, "max_error": 0.05},
                          "time": {"dt_max": 0.0005}, "boundary": {"conservative": True}},
        "materials": [{"id": "fluid", "density0": 1000.0}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [L, L], "material": "fluid"}],
        "boxes": [{"min": [0.0, 0.0], "max": [L, 2 * L]}],
    })


def _sim(solver: str) -> Simulation:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Simulation(_box(solver))


@pytest.mark.parametrize("solver", ["iisph", "dfsph"])
def test_conservative_walls_do_not_pump_energy_into_a_closed_box(solver: str) -> None:
    """The mechanical energy does not grow (dE < 0.002 J/m, 5e-5 of the column's m g H / 2 =
    39 J/m; measured -4.1e-3 IISPH: the start's settling), and the speeds stay below the
    default's (< 0.15 m/s against its 0.19; measured 0.10: the fluid next to the walls
    settles)."""
    sim = _sim(solver)
    f = sim.fluid

    def energy() -> float:
        return float(0.5 * (f["m"] * (f["v"] ** 2).sum(axis=0)).sum()
                     + G * (f["m"] * f["x"][1]).sum())

    e0 = energy()
    for _ in range(20):
        sim.step()
    assert energy() - e0 < 0.002
    assert float(np.sqrt((f["v"] ** 2).sum(axis=0)).max()) < 0.15


def test_extended_rows_make_the_operator_symmetric() -> None:
    """With the walls' rows the PPE operator ``K -> J' a(K)`` is symmetric in the weights V_f
    (``<K2 V, A K1> = <K1 V, A K2>`` to round-off, measured 2e-16 relative), without them (the
    default MLS term) it is not (measured 15 % in 3D): the wall force is the transpose of the
    constraints the solve keeps. The MLS extrapolation is applied unclamped (its clamp at 0
    is the only nonlinearity)."""
    sim = _sim("iisph")
    sim.step()
    st = sim.state
    f, b, cp = st.fluid, st.boundary, st.coupling
    mls, g = cp.pressure, PairGradients(st)
    V = f["V0"]
    nl, nb = st.nl_ff, st.nl_fb
    use = cp.transposed_walls(st)
    rows = np.repeat(np.arange(b.n), np.diff(mls.toff))

    def op(k: np.ndarray, walls: bool) -> np.ndarray:
        kb = np.bincount(rows, weights=mls.coef * k[mls.tfluid], minlength=b.n)
        a = np.empty_like(f["x"])
        kappa_accel_cached(k, kb, nl.offsets, nl.indices, nb.offsets, nb.indices,
                           cp.mirror(st), g.gw, g.gwb, st.dim, a)
        div = np.empty(f.n)
        pair_divergence_cached(a, np.zeros_like(b["x"]), nl.offsets, nl.indices, nb.offsets,
                               nb.indices, g.gw, g.gwb, st.dim, div)
        if not walls:
            return div
        wap, out = np.empty(b.n), np.empty(f.n)
        wall_sums(a, V, b["V"], nb.offsets, nb.indices, g.gwb, st.dim, use, wap)
        wall_transpose(np.zeros(b.n), wap, -1.0, np.ones(b.n), b["V"], V, mls.toff,
                       mls.tfluid, mls.coef, div, out)
        return out

    rng = np.random.default_rng(0)
    k1, k2 = rng.random(f.n), rng.random(f.n)
    for walls, tol in ((True, 1e-12), (False, None)):
        x1, x2 = np.dot(k2 * V, op(k1, walls)), np.dot(k1 * V, op(k2, walls))
        if tol is None:
            assert abs(x1 - x2) > 1e-3 * abs(x1)
        else:
            assert abs(x1 - x2) < tol * abs(x1)


def test_conservative_walls_refuse_other_wall_terms() -> None:
    """Two wall terms at once, or the option without the MLS pressure, are refused."""
    with pytest.raises(ValidationError, match="conservative true with symmetric or solved"):
        Scene.model_validate({"configuration": {"dim": 2, "boundary": {
            "conservative": True, "solved": True}}, "materials": [{"id": "fluid"}]})
    with pytest.raises(ValidationError, match="conservative true with pressure 'mirror'"):
        Scene.model_validate({"configuration": {"dim": 2, "boundary": {
            "conservative": True, "pressure": "mirror"}}, "materials": [{"id": "fluid"}]})
