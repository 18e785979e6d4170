"""DFSPH and IISPH: hydrostatic columns in 2D and 3D (PCISPH too: the same columns), a 2D dam
break, iteration control.

Columns start one particle diameter off the walls (as SPlisHSPlasH samples fluid blocks): an
incompressible solver removes any initial density error within one step, so fluid sampled
against Akinci walls (whose first fluid layer sees a few percent too much boundary density)
would be shot off the walls.
"""

from __future__ import annotations

import json
import logging
import warnings
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

G = 9.81
ETA = 0.05  # target average density error [%] (SPlisHSPlasH's shipped scenes use 0.05 %)


def _column_scene(method: str, dim: int, eta: float = ETA, max_iterations: int = 200,
                  w: float = 0.6, bp: str = "mirror", lattice: str = "square") -> Scene:
    r = 0.01 if dim == 2 else 0.02
    hgt = 0.5 if dim == 2 else 0.4
    gap = 2 * r
    start = [gap, 0.0] if dim == 2 else [gap, 0.0, gap]
    end = [w - gap, hgt] if dim == 2 else [w - gap, hgt, w - gap]
    box_max = [w, hgt + 0.1] if dim == 2 else [w, hgt + 0.1, w]
    return Scene.model_validate({
        "configuration": {
            "dim": dim, "particle_radius": r, "gravity": [0.0, -G, 0.0][:dim],
            "pressure": {"method": method, "max_error": eta, "max_iterations": max_iterations},
            # dt_max bounds the step at rest, where the CFL step would grow to its maximum
            "time": {"dt_max": 0.002},
            "boundary": {"pressure": bp},
        },
        "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": start, "end": end, "lattice": lattice}],
        "boxes": [{"min": [0.0] * dim, "max": box_max, "layers": 2}],
    })


def _settled(method: str, dim: int, w: float = 0.6, bp: str = "mls") -> dict:
    """:func:`_settled_run`, with the defaults filled in so that ``_settled(m, d)`` and
    ``_settled(m, d, 0.6)`` share one cached run (the cache keys on the arguments as passed:
    the 0.6 m column used to run twice in test_hydrostatic_column)."""
    return _settled_run(method, dim, w, bp)


@cache
def _settled_run(method: str, dim: int, w: float, bp: str) -> dict:
    """Let the column settle, then average pressure and height per particle: 2D 0.5 s, then
    0.25 s; 3D 1 s, then 0.5 s.

    2D columns start on the hexagonal lattice (``fluid_blocks[].lattice``), the packing a 2D
    fluid at rest settles into (see test_hydrostatic_column); their slope is within 0.5 % of its
    final value after 0.25 s and within 0.2 % after 0.75 s (DFSPH 0.6 m, IISPH 0.7 m, 0.25 s
    averages up to 2.5 s). Averaged over 0.5-0.75 s instead of 1.0-1.5 s (2026-12-03, widths
    0.5 / 0.6 / 0.7 m): DFSPH -0.65 / -0.19 / -0.13 %, IISPH -0.37 / -0.20 / -0.12 %, PCISPH
    -0.56 / -0.31 / -0.61 % (over 0.5-1.0 s: -0.50 / -0.13 / -0.08, -0.29 / -0.15 / -0.05, -0.52 /
    -0.30 / -0.57 %), mean speed at 0.75 s 0.014-0.016 m/s, compression 0.050 %, 21 (DFSPH,
    IISPH) and 32 (PCISPH) iterations per step: half the simulated time of the 1.5 s run. The
    0.25 s window still averages 125 steps of the per-step pressure split (about 2 % per step).
    3D columns averaged over 1.0-1.5 s and over 1.5-2.0 s (2026-12-03,
    three widths, every solver): each slope within 1.4 % of its other, the mean over the widths
    within 0.9 % (DFSPH -1.74 / -1.72 %), so the 3D columns settle 1 s too (1.5 s before). They
    do not settle sooner: PCISPH 0.56 m over 0.5-1.0 s -0.2 %, over 1.0-1.5 s -1.3 %, mean speed
    0.054 m/s at 0.75 s (2026-12-03)."""
    lattice = "hexagonal" if dim == 2 else "square"
    settle, window = (0.5, 0.25) if dim == 2 else (1.0, 0.5)
    sim = Simulation(_column_scene(method, dim, w=w, bp=bp, lattice=lattice))
    sim.run(until=settle)
    n = sim.fluid.n
    p_sum, y_sum, its = np.zeros(n), np.zeros(n), []

    def accumulate(s: Simulation, st) -> None:
        order = s.fluid.order_by_id()
        p_sum[:] += s.pressures[order]
        y_sum[:] += s.positions[order, 1]
        its.append(st.iterations)

    sim.run(until=settle + window, on_step=accumulate)
    k = len(its)
    order = sim.fluid.order_by_id()
    return {"p": p_sum / k, "y": y_sum / k, "x": sim.positions[order], "rho": sim.densities,
            "iterations": np.array(its), "r": sim.state.r, "n": n,
            "vmean": float(np.linalg.norm(sim.velocities, axis=1).mean())}


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("method", ["dfsph", "iisph", "pcisph"])
def test_hydrostatic_column(method: str, dim: int) -> None:
    res = _settled(method, dim)
    # compression: the solver stops at an average predicted error <= ETA; the real density
    # after the position update may exceed it slightly (the prediction is linear in dt):
    # allow 0.02 % on top
    compression = np.maximum(res["rho"] - 1000.0, 0.0).mean() / 1000.0
    assert compression <= (ETA + 0.02) / 100.0, compression
    # at rest: the mean speed is below 3 % of the free-fall speed sqrt(2 g H) ~ 3 m/s (measured
    # 0.006-0.052 m/s: the column still sways a little after spreading over the floor; the 3D
    # column is only 10 particles high)
    assert res["vmean"] < 0.08
    # pressure slope over the middle 80% of the column, pressures and heights averaged over
    # the last 0.25 s (2D) / 0.5 s (3D; see _settled) (the per-step split of the pressure
    # between iterations fluctuates by about 2 %), with the boundary pressure extrapolated by
    # MLS (Band et al. 2018; configuration.boundary.pressure 'mls'): with mirroring (p_b = p_i)
    # a side wall cannot carry the vertical pressure gradient and the slope was 2D +2.5 %
    # (DFSPH, mean of widths 0.5-0.7 m), 3D +4.5 % (DFSPH) / +8.4 % (IISPH). The 2 %
    # is tested for every column.
    # 2D: the column starts on the hexagonal lattice (touching discs, V = 1 / sum_k W over it;
    # fluid_blocks[].lattice), the packing a 2D fluid at rest settles into. Sampled on the square
    # lattice it shears into hexagonal grains with frozen-in defects, where sum_j V_j grad W_ij
    # does not vanish (0.7-0.8 /m rms against 0.35 /m from a hexagonal start) and the symmetric
    # force's zeroth-order error 2 p_i sum_j V_j grad W_ij, large at the large absolute pressure
    # of a deep column, needs a steeper mean pressure field: square start +0.5 .. +2.2 % (DFSPH,
    # 21 widths 0.50-0.70 m, mean +1.4 %), hexagonal start -0.3 .. +0.3 % (mean +0.07 %, std
    # 0.14 %); IISPH +0.7 .. +1.9 % / -0.2 .. +0.5 % (validation/README.md, "2D hydrostatic
    # columns"). Measured
    # here 2026-11-26 (1.0-1.5 s): DFSPH -0.2 / 0.0 / +0.3 %, IISPH -0.2 / +0.1 / +0.1 % (1 and
    # 2 threads), PCISPH -0.6 / -0.1 / -0.4 % (1 thread; about 31 iterations per step at rest);
    # 2026-12-03 (0.5-0.75 s): DFSPH -0.65 / -0.19 / -0.13 %, IISPH -0.37 / -0.20 / -0.12 %,
    # PCISPH -0.56 / -0.31 / -0.61 %.
    # 3D (square lattice, 10 particles high), measured 2026-12-03 (widths 0.56 / 0.6 / 0.64 m):
    # DFSPH -2.4 / -1.1 / -1.7 % (mean -1.7 %), IISPH -2.3 / -0.5 / 0.0 % (mean -0.9 %), PCISPH
    # -1.4 / -1.0 / +0.3 % (mean -0.7 %); the mean is tested against 2 %, each column against
    # 3 %. (PCISPH's own 3D test in test_pcisph_pbf.py uses a column only 0.24 m wide, six
    # particles across, where the slope is coarse: -2.4 %, tested there against 5 %.)
    widths = (0.5, 0.6, 0.7) if dim == 2 else (0.56, 0.6, 0.64)  # 3D: multiples of 2r
    slopes = []
    for w in widths:
        r = _settled(method, dim, w)
        y, p = r["y"], r["p"]
        top = y.max()
        sel = (y > 0.1 * top) & (y < 0.9 * top)
        slopes.append(-np.polyfit(y[sel], p[sel], 1)[0] / (1000.0 * G))
    err = np.array(slopes) - 1.0
    mean_bound, each_bound = (0.02, 0.02) if dim == 2 else (0.02, 0.03)
    assert abs(err.mean()) < mean_bound, slopes
    assert np.all(np.abs(err) < each_bound), slopes


@pytest.mark.parametrize("method", ["dfsph", "iisph"])
def test_iterations_at_rest_are_few(method: str) -> None:
    """Measured at rest (2D column, 23 rows deep, eta 0.05 %, dt 2 ms): DFSPH 21, IISPH 21
    iterations per step on average (both warm starts keep only half the pressure; SPlisHSPlasH's
    DFSPH takes 21 on the same column, 2.19 wheel; sphkit's DFSPH took 10 with the one-sided
    update it used until 2026-11-26, see sphkit.pressure.dfsph); bound: 30 (DFSPH) and 50
    (IISPH) on average."""
    its = _settled(method, 2)["iterations"]
    bound = 30 if method == "dfsph" else 50
    assert its.mean() <= bound, its.mean()


@pytest.mark.parametrize("method", ["dfsph", "iisph"])
def test_dam_break_2d_stays_in_tank(method: str) -> None:
    """0.5 x 1.0 m block in a 2 x 1.2 m tank, r = 0.01, to t = 1.2 s: every centre inside the
    tank up to r/2 at 25 frames/s, no NaN, the wave reaches the far wall. The surge hits the far
    wall at 0.48 s, runs up to the lid (0.6-1.0 s) and falls back from 1.05 s. Runs to 2 s
    (2026-12-03) came closest to a wall before 1 s (the front's run over the floor, the impact,
    the run-up): DFSPH 0.34 r (0.44 s), IISPH 0.24 r (0.80 s) short of the r/2 limit; over
    1.2-2.0 s no frame came closer than 0.39 r (DFSPH, the jet's plunge onto the floor at
    1.4 s) and 0.46 r (IISPH). 1.2 s instead of 2 s: 62 % of the steps' time."""
    r = 0.01
    sc = Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -G],
                          "pressure": {"method": method, "max_error": ETA},
                          "time": {"dt_max": 0.004}},
        "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": [0.02, 0.02], "end": [0.52, 1.02]}],
        "boxes": [{"min": [0.0, 0.0], "max": [2.0, 1.2], "layers": 2}],
    })
    sim = Simulation(sc)
    bad: list[float] = []

    def check(s: Simulation, k: int) -> None:
        x = s.positions
        if not (np.all(np.isfinite(x)) and np.all(x >= -0.5 * r)
                and np.all(x <= np.array([2.0, 1.2]) + 0.5 * r)):
            bad.append(s.time)

    sim.run(until=1.2, fps=25, on_frame=check)
    assert sim.time >= 1.2
    assert not bad, f"particles left the tank at t = {bad}"
    assert sim.positions[:, 0].max() > 1.5  # the wave reached the far side


def test_iteration_limit_is_a_logged_warning(caplog: pytest.LogCaptureFixture) -> None:
    sim = Simulation(_column_scene("dfsph", 2, eta=1e-6, max_iterations=1))
    with caplog.at_level(logging.WARNING, logger="sphkit"):
        for _ in range(5):
            sim.step()
    msgs = [r.getMessage() for r in caplog.records]
    assert any("no convergence in 1 iterations at step" in m for m in msgs), msgs
    assert not sim.last_solver.converged
    # DFSPH's step bound (its module docstring, "Time step"; the rule itself is tested with
    # IISPH below): the failed solve (far above its 1e-6 % tolerance) set it to 0.8 of its
    # step, and it goes through a checkpoint (exact: a float product and a JSON round trip)
    from sphkit.core.solver import JACOBI_STEP_BOUND
    from sphkit.pressure.dfsph import DFSPH

    bound = sim.pressure.step_bound.value
    assert bound == max(0.8 * sim.dt, JACOBI_STEP_BOUND["floor"]), (bound, sim.dt)
    t = DFSPH()
    t.restore_checkpoint_state(json.loads(json.dumps(sim.pressure.checkpoint_state())))
    assert t.step_bound.value == bound


def test_cfl_with_iteration_control(tmp_path) -> None:
    """``time.iteration_control`` (SPlisHSPlasH's cflMethod 2): each step is the smaller of
    the CFL step of the velocities it starts from and the last step times 0.9 (more than 10
    iterations), 1.1 (fewer than 5) or 1; the rule is active (it, not the CFL step, sets the
    step) and goes through a checkpoint bit for bit. Exact comparisons up to one rounding of
    the float products (rtol 1e-15). The scene's first step (time.dt) equals dt_max, the CFL
    step at rest, so the rule's base after step 1 is that step (in general it is the first
    step's CFL step, not time.dt)."""
    from _restart import continued_from_checkpoint

    from sphkit.core.timestep import cfl_time_step

    # a tight tolerance (0.01 %, SPlisHSPlasH's default), so that solves take more than 10
    # iterations and the rule shrinks and regrows the step (at 0.05 % the column rests in 2
    # iterations a step and the rule sets the step only twice)
    sc = _column_scene("dfsph", 2, eta=0.01).model_copy(deep=True)
    tc = sc.configuration.time
    tc.iteration_control, tc.dt = True, 0.002
    sim = Simulation(sc)
    steps = [sim.step() for _ in range(12)]
    active = 0
    for a, b in zip(steps, steps[1:], strict=False):
        cfl = cfl_time_step(a.max_velocity, sc.configuration.particle_radius, tc.cfl_factor,
                            tc.dt_min, tc.dt_max)
        factor = 0.9 if a.iterations > 10 else 1.1 if a.iterations < 5 else 1.0
        rule = max(factor * a.dt, tc.dt_min)
        assert b.dt == pytest.approx(min(cfl, rule), rel=1e-15), (a, b)
        active += rule < cfl
    assert active >= 3, [(s.dt, s.iterations) for s in steps]
    continued_from_checkpoint(sim, tmp_path, 4)


def test_iisph_step_bound_rule_and_checkpoint() -> None:
    """IISPH's adaptive step bound (:class:`sphkit.core.solver.StepBound`, IISPH's constants),
    driven by hand, no simulation: absent while solves converge and after a solve that stopped
    at max_iterations within 1.5 tolerances (a near miss); 0.8 times the step after one that
    stopped above that (failed); unchanged by a near miss once set; +2 % per solve converged
    within half the limit, unchanged after a converged but hard one; never below the floor (the
    default dt_min); dropped above 1 s; the same through a JSON checkpoint round trip. Exact
    comparisons: the rule is a few float products."""
    from sphkit.core.solver import JACOBI_STEP_BOUND
    from sphkit.pressure.iisph import IISPH

    floor = JACOBI_STEP_BOUND["floor"]

    def restored(s: IISPH) -> IISPH:
        t = IISPH(max_iterations=100)
        t.restore_checkpoint_state(json.loads(json.dumps(s.checkpoint_state())))
        return t

    s = IISPH(max_iterations=100)
    b = s.step_bound
    b.update(0.005, 30, 100, True)
    assert b.value == float("inf")  # converged solves leave the run as it was
    assert restored(s).step_bound.value == float("inf")
    b.update(0.005, 100, 100, False, miss=1.4)
    assert b.value == float("inf")  # a near miss: the step is not shown too long
    b.update(0.005, 100, 100, False, miss=1.6)
    assert b.value == 0.8 * 0.005
    b.update(0.004, 100, 100, False, miss=1.2)
    assert b.value == 0.8 * 0.005  # a near miss leaves a bound as it is
    b.update(0.004, 50, 100, True)  # easy: within half the limit
    assert b.value == 0.8 * 0.005 * 1.02
    b.update(0.004, 80, 100, True)  # converged, not easy
    assert b.value == 0.8 * 0.005 * 1.02
    assert restored(s).step_bound.value == b.value
    b.update(1.1e-4, 100, 100, False)  # no error given: an unconverged solve fails
    assert b.value == floor  # 0.8 * 1.1e-4 is below the floor
    b.value = 0.99
    b.update(0.005, 10, 100, True)
    assert b.value == float("inf")  # above 1 s: no bound
    t = IISPH()
    t.restore_checkpoint_state({})  # a checkpoint written before the bound existed
    assert t.step_bound.value == float("inf")


def test_a_step_is_the_same_with_its_temporaries_in_the_kept_block() -> None:
    # The simulation keeps its neighbour search rows and pair-gradient cache in one block reused
    # across steps (core.arrays.Scratch); the same passes then run on the same values, so the
    # particles must move exactly as with fresh arrays (bit for bit: no tolerance).
    logging.disable(logging.WARNING)
    try:
        sims = [Simulation(_column_scene("dfsph", 2, w=0.2)) for _ in range(2)]
    finally:
        logging.disable(logging.NOTSET)
    assert sims[0].state.scratch is not None
    sims[1].state.scratch = None
    for sim in sims:
        for _ in range(8):
            sim.step()
    assert sims[0].state.scratch.nbytes > 0
    np.testing.assert_array_equal(sims[0].positions, sims[1].positions)
    np.testing.assert_array_equal(sims[0].pressures, sims[1].pressures)


def test_jacobi_sweep_with_the_boundary_sums() -> None:
    # A boundary that takes no pressure acceleration enters the sweep's Ap_i as a_i . B_i with
    # B_i = sum_b V_b grad W_ib made once a step (PairGradients.boundary_sums, by the
    # diagonal's pass): the same update as the pass over the boundary pairs with ab = 0, to
    # round-off (1e-12 relative: the boundary pairs' products summed in another order).
    from sphkit.core.ppe import jacobi_sweep

    sim = Simulation(_column_scene("dfsph", 2, w=0.2))
    sim._neighbors()
    sim.compute_density()
    st = sim.state
    g = st.pair_grads
    bsum = g.boundary_sums()
    # the sums against NumPy's over each particle's rows of the cached boundary gradients
    rows = np.repeat(np.arange(st.fluid.n), np.diff(st.nl_fb.offsets))
    ref = np.zeros_like(bsum)
    for d in range(2):
        np.add.at(ref[d], rows, g.gwb[d])
    np.testing.assert_allclose(bsum, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    rng = np.random.default_rng(3)
    n, nb = st.fluid.n, st.boundary.n
    a = rng.normal(0.0, 1.0, (2, n))
    s = rng.normal(0.0, 1e-3, n)
    outs = []
    for sums in (None, bsum):
        q = np.full(n, 1e-4)
        k = q.copy()
        err = jacobi_sweep(a, np.zeros((2, nb)), st.nl_ff.offsets, st.nl_ff.indices,
                           st.nl_fb.offsets, st.nl_fb.indices, g.gw, g.gwb, 2, q, s, 1e-4,
                           np.full(n, 0.5), 0.5, np.ones(n, np.bool_), np.ones(n), k, bsum=sums)
        outs.append((q, k, np.array(err)))
    assert np.abs(bsum).max() > 0.0 and (outs[0][0] > 0.0).any()
    for x, y in zip(outs[0], outs[1], strict=True):
        np.testing.assert_allclose(y, x, rtol=1e-12, atol=1e-12 * np.abs(x).max())
    # weight 1 and every particle active given as None (DFSPH): k is q itself, nothing else
    # written, and the same update and residuals bit for bit (w_i q_i = q_i exactly)
    q = np.full(n, 1e-4)
    err = jacobi_sweep(a, np.zeros((2, nb)), st.nl_ff.offsets, st.nl_ff.indices,
                       st.nl_fb.offsets, st.nl_fb.indices, g.gw, g.gwb, 2, q, s, 1e-4,
                       np.full(n, 0.5), 0.5, None, None, q, bsum=bsum)
    np.testing.assert_array_equal(q, outs[1][0])
    np.testing.assert_array_equal(q, outs[1][1])
    np.testing.assert_array_equal(np.array(err), outs[1][2])


def test_the_third_solve_leaves_out_only_held_particles_the_pressure_speeds_up() -> None:
    """PCISPH's third solve after a throw (:meth:`sphkit.core.impacts.Impacts.released`)
    keeps a held particle unless its pressure acceleration adds more than THROW_PLAIN r / dt =
    1.15 * 0.01 / 0.01 = 1.15 m/s to its speed within the step (r = 1 cm, dt = 10 ms): at rest,
    turned at a wall from +2 to -2 m/s (|dt^2 a_p| = 4 r, a large pressure but no gain) and
    sped up from 2 to 3 m/s (gain 1) it stays; sped up from 2 to 4 m/s (gain 2) it goes. A
    particle the solve does not hold (an emitter's) stays out and is not counted."""
    from types import SimpleNamespace

    from sphkit.core.impacts import Impacts

    class Fluid(dict):
        n = 5

    v = np.array([[0.0, 2.0, 2.0, 2.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0]])
    state = SimpleNamespace(fluid=Fluid(v=v), r=0.01, dim=2, step=7)
    ap = np.array([[0.0, -400.0, 100.0, 200.0, 900.0], [0.0, 0.0, 0.0, 0.0, 0.0]])
    a = np.zeros_like(ap)  # no non-pressure acceleration
    rule = Impacts("PCISPH")
    keep, count = rule.released(state, a, ap, 0.01, np.array([True, True, True, True, False]))
    np.testing.assert_array_equal(keep, [True, True, True, False, False])
    assert count == 1
    keep, count = rule.released(state, a, ap, 0.01, np.zeros(0, bool))  # every one held
    np.testing.assert_array_equal(keep, [True, True, True, False, False])
    assert count == 2


@pytest.mark.parametrize(("method", "raised", "until", "bound"),
                         [(3, 2.45, 0.76, 80.0), (4, 0.825, 0.5, 90.0), (1, 0.025, 0.3, 15.0)],
                         ids=["iisph", "dfsph", "pcisph"])
def test_a_block_dropped_onto_a_volume_map_floor_lands(method: int, raised: float, until: float,
                                                       bound: float) -> None:
    """``DamBreakModel_2D.json`` (volume maps, its viscosity; its vorticity left out, which the
    instability does not need) switched to IISPH with the block raised 2.45 m (it lands flat at
    6.9 m/s at 0.704 s), to DFSPH raised 0.825 m (4 m/s at 0.40 s), or to PCISPH as the file
    writes it (0.025 m above the floor). While the maps' surface stood 0.5 r into the fluid,
    the steps after the IISPH and DFSPH landings threw the fluid at the wall's corner until the
    guard stopped the run (over 100 m/s at 0.707 s and 0.418 s); with the surface on the mesh
    they land without the rule too (28 and 58 m/s within the windows), and PCISPH's dam break
    goes unstable at step 66 (0.11 s, 174 m/s). With the rule (a solve that would throw a
    particle more than 1.15 r is made again with the walls' plain term, kept for ten steps at
    half the step, :mod:`sphkit.core.impacts`) it acts in each, and all three land (measured
    IISPH 50, DFSPH 16, PCISPH 8.7 m/s). The bounds: SPlisHSPlasH 2.19 throws the drops' jets
    at up to 18-25 m/s on the scene's file raised 1-2.45 m; a run that blows up passes 100 m/s,
    the guard's limit; PCISPH's dam break has not reached the far wall by 0.3 s: twice its
    1.5 m column's front speed 2 sqrt(g H), 15 m/s."""
    from sphkit.scene.splishsplash import from_splishsplash

    box = Path(__file__).resolve().parent.parent / "benchmarks" / "scenes" / "UnitBox.obj"
    scene = from_splishsplash({
        "Configuration": {"sim2D": True, "particleRadius": 0.025,
                          "simulationMethod": method,
                          "cflMethod": 1, "cflFactor": 1, "cflMaxTimeStepSize": 0.005,
                          "boundaryHandlingMethod": 2,
                          "DFSPH": {"maxError": 0.1, "maxErrorV": 0.1}},
        "Materials": [{"id": "Fluid", "viscosityMethod": 1,
                       "Standard viscosity": {"viscosity": 0.01}}],
        "RigidBodies": [{"geometryFile": str(box), "translation": [0, 2.0, 0],
                         "scale": [4, 4, 1], "isWall": True, "mapInvert": True,
                         "mapResolution": [30, 30, 20]}],
        "FluidBlocks": [{"start": [-2.0, 0.0, -1], "end": [-0.5, 1.5, 1],
                         "translation": [0.025, raised, 0.0]}],
    })
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the scene's coarse map
        sim = Simulation(scene)
    acted, fastest = [], 0.0
    while sim.time < until:  # the landing and 20 steps after it
        fastest = max(fastest, sim.step().max_velocity)
        if sim.pressure.impacts.plain(sim.state):  # solved with the plain wall term
            acted.append(sim.time)
    assert acted
    assert 3.9 < fastest < bound
