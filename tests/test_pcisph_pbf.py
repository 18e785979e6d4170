"""PCISPH and PBF: template factor and constraint passes, hydrostatic columns, 2D dam breaks,
PBF's velocity updates and the shared iteration control.

The columns start 0.2 r off the walls (box ``[0, W + 2m]``, fluid ``[m, m + W]`` with m = 0.2 r).
Sampled 2r from the Akinci walls, as in tests/test_wcsph.py's column, the wall-adjacent particles
start 3 % (4.5 % in the corners) compressed, because the wall volumes over-count the missing
fluid; PCISPH cannot remove that in one step (its pressure iteration diverges, see
:mod:`sphkit.pressure.pcisph`). With the 0.2 r margin no particle starts compressed and the
fluid can only settle by 0.2 r, far below the one-diameter height check.
"""

from __future__ import annotations

import logging
import warnings
from pathlib import Path

import numpy as np
import pytest
from _validation import load_validation

from sphkit import registry
from sphkit.core.ppe import density_at
from sphkit.core.projection import constraint_lambda
from sphkit.core.solver import PairGradients
from sphkit.pressure import pcisph as pcisph_module
from sphkit.pressure.pbf import PBF
from sphkit.pressure.pcisph import PCISPH, REJECT
from sphkit.scene.schema import PressureConfig, Scene
from sphkit.scene.splishsplash import from_splishsplash
from sphkit.simulation import Simulation

G = 9.81
RHO0 = 1000.0


def _column(method: str, dim: int = 2, width: float = 0.3, height: float = 0.5,
            r: float = 0.01, max_error: float = 0.05, nu: float = 0.01, margin: float = 0.2,
            bp: str = "mirror", lattice: str = "square", **pressure) -> Scene:
    m = margin * r
    up = [m + height + 0.1] if dim == 2 else [m + height + 0.1, width + 2 * m]
    grav = [0.0, -G] + [0.0] * (dim - 2)
    return Scene.model_validate({
        "name": "column",
        "configuration": {
            "dim": dim, "particle_radius": r, "gravity": grav,
            "pressure": {"method": method, "max_error": max_error, **pressure},
            "time": {"dt_max": 0.002},
            "boundary": {"pressure": bp},
        },
        "materials": [{"id": "fluid", "density0": RHO0,
                       "viscosity": {"method": "standard", "coefficient": nu,
                                     "boundary_coefficient": nu}}],
        "fluid_blocks": [{"start": [m] * dim,
                          "end": [m + width, m + height, m + width][:dim], "lattice": lattice}],
        "boxes": [{"min": [0.0] * dim, "max": [width + 2 * m] + up, "layers": 2}],
    })


def _settle(sim: Simulation, until: float, window: float) -> dict:
    """Run to ``until``; average pressure and positions (by particle id) over the last
    ``window`` seconds; iterations per step."""
    acc = {"p": 0.0, "x": 0.0, "k": 0, "its": []}

    def on_step(s: Simulation, st) -> None:
        acc["its"].append(st.iterations)
        if s.time > until - window:
            o = s.fluid.order_by_id()
            acc["p"] = acc["p"] + s.pressures[o]
            acc["x"] = acc["x"] + s.positions[o]
            acc["k"] += 1

    sim.run(until=until, on_step=on_step)
    return {"p": acc["p"] / acc["k"], "x": acc["x"] / acc["k"], "its": np.array(acc["its"])}


def _slope_error(x: np.ndarray, p: np.ndarray, r: float, box_width: float,
                 inner: bool = True) -> float:
    """Least-squares slope of p over height, relative to rho0 g, minus 1: middle 80% of the
    column, particles at least 3r from the side walls (all with ``inner=False``)."""
    y = x[:, 1]
    top = y.max()
    side = np.delete(x, 1, axis=1)
    keep = np.all((side > 3 * r) & (side < box_width - 3 * r), axis=1) if inner else True
    sel = keep & (y > 0.1 * top) & (y < 0.9 * top)
    assert sel.sum() > 20
    return float(-np.polyfit(y[sel], p[sel], 1)[0] / (RHO0 * G) - 1.0)


def _compression(sim: Simulation) -> float:
    return float(np.maximum(sim.densities - RHO0, 0.0).mean() / RHO0)


# -- building blocks ---------------------------------------------------------------------------

@pytest.mark.parametrize("dim", [2, 3])
def test_pcisph_delta_is_half_the_inverse_diagonal_of_a_filled_neighbourhood(dim: int) -> None:
    """delta = 1 / (2 V^2 (|S1|^2 + S2)) of the template equals 1 / (2 D_i) for an interior
    particle of a sampled block, D_i = |sum_j V_j grad W_ij|^2 + sum_j V_j^2 |grad W_ij|^2 (the
    PPE diagonal of :func:`sphkit.core.ppe.diagonal_cached`): PCISPH is Jacobi with omega = 0.5."""
    r = 0.02
    sc = Scene.model_validate({"configuration": {"dim": dim, "particle_radius": r,
                                                 "gravity": [0.0] * dim,
                                                 "pressure": {"method": "pcisph"}},
                               "fluid_blocks": [{"start": [0.0] * dim, "end": [0.4] * dim}]})
    sim = Simulation(sc)
    sim.run(until=1e-9, fps=1.0)
    st = sim.state
    D = PairGradients(st).diagonal()
    centre = np.argmin(np.linalg.norm(sim.positions - 0.2, axis=1))
    assert sim.pressure.delta == pytest.approx(1.0 / (2.0 * D[centre]), rel=1e-6)


def test_pbf_lambda_pass_matches_density_at_and_a_numpy_reference() -> None:
    """The fused PBF pass computes the density of :func:`density_at` at displaced positions and
    lambda_i = -C_i / (sum_k |grad_k C_i|^2 + eps) (checked for one compressed particle)."""
    sim = Simulation(_column("pbf", width=0.1, height=0.1))
    sim.run(until=1e-9, fps=1.0)
    st = sim.state
    f, b = st.fluid, st.boundary
    nl, nb = st.nl_ff, st.nl_fb
    rng = np.random.default_rng(1)
    dx = rng.uniform(-0.1, 0.1, f["x"].shape) * st.r
    ref = np.empty(f.n)
    density_at(f["x"] + dx, f["m"], nl.offsets, nl.indices, b["x"], np.zeros((st.dim, 0)),
               b["V"], nb.offsets, nb.indices, st.rho0, st.h, st.kid, st.dim, ref)
    lam = np.empty(f.n)
    rho = np.empty(f.n)
    eps = 1e-6
    avg, mx = constraint_lambda(f["x"] + dx, f["V0"], np.ones(f.n), nl.offsets, nl.indices,
                                b["x"], b["V"], nb.offsets, nb.indices, st.h, st.kid, st.dim,
                                0.0, eps, 0.0, lam, rho)
    assert np.allclose(rho, ref, rtol=1e-12)
    # one mass (the block's, as sampled): the pass compiled without the mass gather agrees
    assert st.rest().one_mass
    one = np.empty(f.n)
    density_at(f["x"] + dx, f["m"], nl.offsets, nl.indices, b["x"], np.zeros((st.dim, 0)),
               b["V"], nb.offsets, nb.indices, st.rho0, st.h, st.kid, st.dim, one, True)
    assert np.allclose(one, ref, rtol=1e-14, atol=0.0)
    f["m"][0] *= 1.5  # a mass of its own: no longer one value
    assert not st.rest().one_mass
    f["m"][0] /= 1.5
    c = np.maximum(ref - 1.0, 0.0)
    assert avg == pytest.approx(c.mean()) and mx == pytest.approx(c.max())
    i = int(np.argmax(c))
    assert c[i] > 0
    from sphkit.core.kernels import Kernel

    k = Kernel(st.kid, st.h, st.dim)
    xs = f["x"] + dx
    fj = nl.neighbors(i)
    gj = f["V0"][fj][:, None] * k.grad((xs[:, [i]] - xs[:, fj]).T)
    gb = b["V"][nb.neighbors(i)][:, None] * k.grad((xs[:, [i]] - b["x"][:, nb.neighbors(i)]).T)
    gi = gj.sum(axis=0) + gb.sum(axis=0)
    assert lam[i] == pytest.approx(-c[i] / ((gj * gj).sum() + gi @ gi + eps), rel=1e-10)
    assert np.all(lam[c == 0] == 0)


def test_registry_and_parameters() -> None:
    """SPlisHSPlasH numbers 1 and 2, and the scene's PBF parameters reach the solver."""
    assert registry.by_number("pressure", 1).name == "pcisph"
    assert registry.by_number("pressure", 2).name == "pbf"

    def build_pressure_solver(p: PressureConfig):
        return registry.get("pressure", p.method).load().from_config(p)

    ps = build_pressure_solver(PressureConfig(method="pcisph", max_error=0.1, max_iterations=7))
    assert isinstance(ps, PCISPH)
    assert (ps.control.min_iterations, ps.control.max_iterations) == (3, 7)
    assert ps.control.tolerance == pytest.approx(0.001)
    pb = build_pressure_solver(PressureConfig(
        method="pbf", pbf_epsilon=1e-4, pbf_s_corr=True, pbf_s_corr_k=0.05, pbf_s_corr_n=3,
        pbf_s_corr_dq=0.3, pbf_velocity_update="second_order", min_iterations=4))
    assert isinstance(pb, PBF)
    assert (pb.epsilon, pb.s_corr, pb.s_corr_k, pb.s_corr_n, pb.s_corr_dq, pb.second_order) == (
        1e-4, True, 0.05, 3.0, 0.3, True)
    assert pb.control.min_iterations == 4


# -- hydrostatic columns -----------------------------------------------------------------------

def test_pcisph_hydrostatic_column_2d() -> None:
    """2D column 0.3 x 0.5 m, r = 0.01, max_error 0.05 %, dt <= 2 ms, run for 1.5 s, sampled on
    the hexagonal lattice (``fluid_blocks[].lattice``; the packing a 2D fluid at rest settles
    into, see tests/test_dfsph_iisph.py::test_hydrostatic_column and validation/README.md).

    * mean compression <= 0.06 %: the solver stops at an average *predicted* compression <= 0.05 %
      and the last pressure increment only lowers it (measured 0.050 %);
    * the top stays within 1.5 diameters of its start (measured 1.9 cm lower: the block's odd
      rows hold one particle less, a gap the fluid fills when it spreads to the walls);
    * pressure slope (least squares, middle 80 %), with the boundary pressure extrapolated by MLS
      (Band et al. 2018, ``boundary.pressure: mls``): PCISPH rebuilds the pressure from 0 every
      step and stops at the tolerance, so the slope of a single step scatters (standard deviation
      2.2 % over the last 0.5 s); the pressure averaged over the last 0.5 s is tested against the
      issue's 2 %, for particles >= 3r from the walls (measured -0.5 %) and for the full width
      (-0.2 %); the last step alone (measured -6.0 %, the extreme of the last 0.5 s, range -6.0
      .. +4.2 %) against 8 %. Those numbers are for a 2 s run; the 1.5 s run (2026-12-03): -0.73
      and -0.28 % averaged over 1.0-1.5 s (0.5-1.0 s: -2.0 %, not settled), single steps -6.3 ..
      +4.0 % (standard deviation 2.1 %), the last one -3.5 %, max speed 0.007 m/s. Sampled on
      the square lattice the same column gave +0.7 % (>= 3r)
      and +1.5 % (full width); 11 widths 0.5-0.7 m (validation/hydrostatic.py's column):
      square +0.8 .. +2.0 %, hexagonal -0.4 .. +0.1 %;
    * about 34 iterations per step at rest (g H dt^2 / (2 delta eta), see the module doc; 48 on
      the square lattice); some steps hit the 100-iteration limit when the column lands after
      its 0.2 r drop (t = 0.03 s).
    """
    r = 0.01
    sim = Simulation(_column("pcisph", bp="mls", lattice="hexagonal"))
    top0 = sim.positions[:, 1].max()
    res = _settle(sim, until=1.5, window=0.5)
    assert _compression(sim) <= 0.0006
    assert sim.positions[:, 1].max() >= top0 - 3 * r
    box = 0.3 + 0.4 * r
    assert abs(_slope_error(res["x"], res["p"], r, box)) < 0.02
    assert abs(_slope_error(res["x"], res["p"], r, box, inner=False)) < 0.02
    assert abs(_slope_error(sim.positions, sim.pressures, r, box)) < 0.08
    assert 20 <= res["its"][-100:].mean() <= 80
    assert sim.last.max_velocity < 0.1
    assert np.all(sim.pressures >= 0)


def test_pcisph_hydrostatic_column_3d() -> None:
    """3D column 0.24 x 0.4 x 0.24 m at r = 0.02 (360 particles), settled for 1 s: compression
    <= 0.06 % (measured 0.049 %), top within one diameter (measured 2.5 cm lower, 2r = 4 cm),
    about 8 iterations per step at rest. The slope is coarse here -- six particles across,
    h = 0.08 m is a fifth of the height, only the middle three columns are >= 3r from the walls
    -- with the MLS-extrapolated boundary pressure (time-averaged over 0.3 s): the whole
    column's slope within 2 % (measured -0.7 %), the inner columns' within 8 % (measured -6.8 %:
    they carry less than the columns at the walls; -2.4 % while the box walls had Akinci's
    volumes, 1.02 / 1.42 lattice volumes in their two layers, whose wall term did work on the
    resting fluid; +1.0 % with full mirroring). The issue's 2 % is tested on the wider columns
    of test_dfsph_iisph.py::test_hydrostatic_column, PCISPH included. The column still sways:
    max speed 0.023 m/s at the end (the free-fall speed of the column is sqrt(2 g H) = 2.8
    m/s), tested against 0.25 m/s."""
    r = 0.02
    sim = Simulation(_column("pcisph", dim=3, width=0.24, height=0.4, r=r, bp="mls"))
    top0 = sim.positions[:, 1].max()
    res = _settle(sim, until=1.0, window=0.3)
    assert _compression(sim) <= 0.0006
    assert sim.positions[:, 1].max() >= top0 - 2 * r
    assert abs(_slope_error(res["x"], res["p"], r, 0.24 + 0.4 * r, inner=False)) < 0.02
    assert abs(_slope_error(res["x"], res["p"], r, 0.24 + 0.4 * r)) < 0.08
    assert sim.last.max_velocity < 0.25


@pytest.mark.parametrize("order", ["first_order", "second_order"])
def test_pbf_hydrostatic_column_2d(order: str) -> None:
    """PBF (min 2 iterations) on the 2D column for 2 s: compression <= 0.06 % (measured 0.049 %),
    top within one diameter (measured 0.8 / 0.7 cm lower), about 23 iterations per step at rest.
    The equivalent pressure -rho0 sum(lambda) / dt^2, averaged over the last 0.5 s, has the
    hydrostatic slope within 5 % (measured +1.8 % first order, +2.3 % second order; other widths
    and end times -1.5 to +3.4 %; a single step scatters much more, -3 % and -15 % here)."""
    r = 0.01
    sim = Simulation(_column("pbf", pbf_velocity_update=order))
    top0 = sim.positions[:, 1].max()
    res = _settle(sim, until=2.0, window=0.5)
    assert _compression(sim) <= 0.0006
    assert sim.positions[:, 1].max() >= top0 - 2 * r
    assert abs(_slope_error(res["x"], res["p"], r, 0.3 + 0.4 * r)) < 0.05
    assert res["its"][-100:].mean() <= 40
    assert sim.last.max_velocity < 0.1


def test_pbf_hydrostatic_column_3d() -> None:
    """PBF on the 3D column (r = 0.02) for 1 s: compression <= 0.06 % (measured 0.045 %), the
    fluid stays in the box, about 4 iterations per step at rest. PBF has no boundary pressure:
    the walls push only through the density constraint, and since the box walls keep the
    fluid's lattice volume the fluid next to them settles closer (its lowest particle 0.22 r
    above the floor, 0.53 r with Akinci's volumes) and the top 2.2 r lower after 1 s (1.4 r
    before; the block starts 0.2 r off the walls): tested against 2.5 r. On the walls' lattice
    (no margin) the top sinks 0.5 r (validation/README.md, "Box walls: the lattice's
    volume")."""
    r = 0.02
    sim = Simulation(_column("pbf", dim=3, width=0.24, height=0.4, r=r))
    top0 = sim.positions[:, 1].max()
    sim.run(until=1.0)
    assert _compression(sim) <= 0.0006
    x = sim.positions
    assert x.min() > 0.0 and x[:, 0].max() < 0.24 + 0.4 * r
    assert x[:, 1].max() >= top0 - 2.5 * r
    assert sim.last.max_velocity < 0.1


def test_pbf_artificial_pressure_keeps_particles_apart() -> None:
    """s_corr (Eq. 13, k = 0.1, n = 4, dq = 0.2 h) is repulsive: a small column settled for 0.5 s
    stands higher and has a lower mean density than without it (measured: top 0.195 vs 0.185 m,
    mean rho 969 vs 989 kg/m^3) and still meets the compression tolerance."""
    res = {}
    for on in (False, True):
        sim = Simulation(_column("pbf", width=0.1, height=0.2, pbf_s_corr=on))
        sim.run(until=0.5)
        assert _compression(sim) <= 0.0006
        assert np.all(np.isfinite(sim.positions))
        res[on] = (sim.positions[:, 1].max(), sim.densities.mean())
    assert res[True][0] > res[False][0] + 0.005
    assert res[True][1] < res[False][1] - 10.0


def test_pbf_velocity_updates_land_on_the_predicted_positions() -> None:
    """After each step, x is the constraint-projected x* and v is PBF's velocity update:
    first order v dt = x_new - x_old; second order (from the second step on)
    v dt = 1.5 (x_new - x_old) - 0.5 (x_old - x_oldold), with x_new - x_old = x* - x_old."""
    for order in ("first_order", "second_order"):
        sim = Simulation(_column("pbf", width=0.1, height=0.2, pbf_velocity_update=order))
        hist = []
        for _ in range(6):
            o = sim.fluid.order_by_id()
            hist.append(sim.positions[o].copy())
            sim.step()
        o = sim.fluid.order_by_id()
        x_new, v_new, dt = sim.positions[o], sim.velocities[o], sim.dt
        x_old, x_oo = hist[-1], hist[-2]
        if order == "first_order":
            expect = x_new - x_old
        else:
            expect = 1.5 * (x_new - x_old) - 0.5 * (x_old - x_oo)
        assert np.abs(v_new * dt - expect).max() < 1e-12
        assert np.abs(sim.fluid["a"]).max() < 1e3  # an acceleration, not a position jump


# -- dam breaks and iteration control ----------------------------------------------------------

@pytest.mark.parametrize("method", ["pcisph", "pbf"])
def test_dambreak_2d_stays_in_tank(method: str) -> None:
    """0.5 x 1.0 m block (one diameter off the walls, as the built-in dam break) in a 2 x 1.2 m
    tank, r = 0.01 (1250 particles), max_error 0.05 %, to t = 1.2 s: every centre stays inside
    the tank up to r/2 at 25 frames/s, no NaN, the wave reaches the far wall. Measured (to 2 s):
    PCISPH 30 iterations per step on average (max 70), PBF 14 (max 35); no step hits the limit.
    The surge hits the far wall at 0.56 s, runs up to the lid (PCISPH 0.8-1.05 s) and falls
    back. Runs to 2 s (2026-12-03) came closest to a wall during the impact, before 1 s:
    PCISPH 0.30 r, PBF 0.38 r short of the r/2 limit (0.56 s); over 1.2-2.0 s no frame came
    closer than 0.62 r (PCISPH) and 0.47 r (PBF). 1.2 s instead of 2 s: 61-71 % of the time."""
    r = 0.01
    sc = Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -G],
                          "pressure": {"method": method, "max_error": 0.05},
                          "time": {"dt_max": 0.002}},
        "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01,
                                     "boundary_coefficient": 0.01}}],
        "fluid_blocks": [{"start": [2 * r, 2 * r], "end": [2 * r + 0.5, 2 * r + 1.0]}],
        "boxes": [{"min": [0.0, 0.0], "max": [2.0, 1.2], "layers": 2}],
    })
    sim = Simulation(sc)
    lo, hi = np.array([0.0, 0.0]), np.array([2.0, 1.2])
    bad: list[float] = []
    conv: list[bool] = []

    def check(s: Simulation, k: int) -> None:
        x = s.positions
        if not (np.all(x >= lo - 0.5 * r) and np.all(x <= hi + 0.5 * r)):
            bad.append(s.time)

    sim.run(until=1.2, fps=25, on_frame=check,
            on_step=lambda s, st: conv.append(s.last_solver.converged))
    assert sim.time >= 1.2
    assert not bad, f"particles left the tank at t = {bad}"
    assert np.all(np.isfinite(sim.positions)) and np.all(np.isfinite(sim.velocities))
    assert sim.positions[:, 0].max() > 1.5
    assert all(conv)


@pytest.mark.parametrize("method", ["pcisph", "pbf"])
def test_max_iterations_warning(method: str, caplog: pytest.LogCaptureFixture,
                                monkeypatch: pytest.MonkeyPatch) -> None:
    """With max_iterations 1 and a tolerance (0.001 %) one sweep cannot reach -- the column is
    sampled 2r from the walls, so it starts up to 4.5 % compressed there -- every step logs the
    shared iteration control's warning and reports converged = False after 1 iteration.
    (PCISPH's load bound is lifted: it would shrink the step until one sweep holds the
    column, and this test is of the warning.)"""
    monkeypatch.setattr(pcisph_module, "LOAD", float("inf"))
    sim = Simulation(_column(method, width=0.1, height=0.2, max_error=0.001, max_iterations=1,
                             margin=0.0))
    with caplog.at_level(logging.WARNING, logger="sphkit"):
        for _ in range(3):
            sim.step()
    name = "PCISPH" if method == "pcisph" else "PBF"
    msgs = [rec.getMessage() for rec in caplog.records if rec.levelno == logging.WARNING]
    assert sum(m.startswith(f"{name}: no convergence in 1 iterations") for m in msgs) >= 2
    assert sim.last_solver.iterations == 1 and not sim.last_solver.converged


@pytest.mark.parametrize("dim", [2, 3])
def test_fused_density_and_pair_gradients_equal_the_separate_passes(dim: int) -> None:
    """The simulation computes the densities and the cached ``V_j grad W_ij`` of DFSPH, IISPH
    and PCISPH in one pass (:func:`sphkit.core.ppe.density_pair_gradients`); it must give the
    densities of :func:`sphkit.core.operators.density_cpu` and the gradients of
    :func:`sphkit.core.ppe.pair_gradients` (same sums, so equal to rounding: 1e-12 relative)."""
    from sphkit.core.operators import density_cpu

    sim = Simulation(_column("dfsph", dim=dim, width=0.06, height=0.06))
    sim.run(until=0.01, fps=1000.0)  # a few steps: moved, disordered positions
    sim._neighbors()
    sim.compute_density()
    st = sim.state
    fused = st.pair_grads
    assert fused is not None and fused.gwb.shape[1] > 0  # walls are in the pairs
    f, b = st.fluid, st.boundary
    rho = np.empty(f.n)
    density_cpu(f["x"], f["m"], st.nl_ff.offsets, st.nl_ff.indices, b["x"], b["V"],
                st.nl_fb.offsets, st.nl_fb.indices, st.rho0, st.h, st.kid, st.dim, rho)
    np.testing.assert_allclose(f["rho"], rho, rtol=1e-12)
    st.pair_grads = None
    sep = PairGradients.of(st)
    assert sep is not fused
    scale = np.abs(sep.gw).max()
    np.testing.assert_allclose(fused.gw, sep.gw, rtol=1e-12, atol=1e-12 * scale)
    np.testing.assert_allclose(fused.gwb, sep.gwb, rtol=1e-12, atol=1e-12 * scale)


def test_pcisph_splishsplash_column_lands_stably() -> None:
    """Issue 15: a 2D column 0.2 m wide and 0.5 m high in SPlisHSPlasH's format with its
    default settings (maxError 0.01 %, 100 iterations, CFL with steps up to 5 ms), Akinci walls
    from UnitBox.obj and the block r above the floor (as ``DamBreakModel_2D.json`` shifts it),
    falls r and lands. From p = 0 each step, the template-factor Jacobi sweeps cannot stop the
    50-layer column within 100 iterations at 5 ms; the residual compression piles up at the
    walls and the next solves diverge (before the adaptive step: unstable at step 18,
    0.085 s, 712 m/s; SPlisHSPlasH 2.19's PCISPH diverges on the 0.6 m column too). With the
    step halved after each unconverged solve the column runs 0.15 s with no speed above
    2 m/s (the landing speed is sqrt(2 g r) = 0.44 m/s; the blow-up reached hundreds of m/s),
    and the solves converge again once the step is small enough."""
    box = Path(__file__).resolve().parent.parent / "benchmarks" / "scenes" / "UnitBox.obj"
    r, w = 0.01, 0.2
    scene = {
        "Configuration": {"sim2D": True, "particleRadius": r, "simulationMethod": 1,
                          "boundaryHandlingMethod": 0, "gravitation": [0, -G, 0]},
        "Materials": [{"id": "Fluid", "density0": RHO0, "viscosityMethod": 1,
                       "Standard viscosity": {"viscosity": 0.01}}],
        "RigidBodies": [{"geometryFile": str(box), "translation": [0, 0.4, 0],
                         "scale": [w, 0.8, 1.0], "isWall": True, "mapInvert": True,
                         "mapThickness": 0.0}],
        "FluidBlocks": [{"denseMode": 0, "start": [-w / 2, 0.0, -0.5],
                         "end": [w / 2 - 2 * r, 0.5, 0.5], "translation": [r, r, 0.0]}],
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(from_splishsplash(scene))
    steps = []
    sim.run(until=0.15, on_step=lambda s, st: steps.append(st))
    assert max(st.max_velocity for st in steps) < 2.0
    assert min(st.dt for st in steps) < 0.005 * 0.5  # the bound acted
    assert all(st.iterations < 100 for st in steps[-5:])  # converged again
    assert sim.positions[:, 1].min() > 0.0


@pytest.mark.parametrize("boundary", [1, 2])
def test_pcisph_block_dropped_onto_a_map_floor_lands_stably(boundary: int) -> None:
    """A 2D block 1.6 m wide and 0.6 m high in SPlisHSPlasH's format (PCISPH's defaults: 0.01 %,
    100 sweeps, steps up to 5 ms), written 0.1 m above the floor of a density-map (1) or
    volume-map (2) tank, falls for 0.14 s. Its solves carry no pressure in the fall, so the
    adaptive bound grew by 10 % a step to 5 ms, and the landing -- the whole column's pressure
    from p = 0 in one step, which maps cannot compute again -- diverged (before the load
    bound: unstable at 0.144 s with density maps, 0.138 s with volume maps, at hundreds of
    m/s). The load bound keeps the step where 100 sweeps hold a column of the fluid's depth.
    Bound on the speed: three times the free-fall speed from the block's top, sqrt(2 g 0.7 m) =
    3.7 m/s; a landing splash stays within it, a diverged solve does not."""
    box = Path(__file__).resolve().parent.parent / "benchmarks" / "scenes" / "UnitBox.obj"
    scene = {
        "Configuration": {"sim2D": True, "particleRadius": 0.02, "simulationMethod": 1,
                          "boundaryHandlingMethod": boundary, "gravitation": [0, -G, 0],
                          "cflFactor": 0.5},
        "Materials": [{"id": "Fluid", "density0": RHO0, "viscosityMethod": 1,
                       "Standard viscosity": {"viscosity": 0.01}}],
        "RigidBodies": [{"geometryFile": str(box), "translation": [0, 1.0, 0],
                         "scale": [2.0, 2.0, 1.0], "isWall": True, "mapInvert": True}],
        "FluidBlocks": [{"denseMode": 0, "start": [-0.8, 0.1, -0.1], "end": [0.8, 0.7, 0.1]}],
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(from_splishsplash(scene))
    solver = sim.pressure
    bounds = []
    steps = []

    def record(s: Simulation, st) -> None:
        steps.append(st)
        bounds.append(solver.load_bound(s.state))

    sim.run(until=0.2, on_step=record)
    assert max(st.max_velocity for st in steps) < 3.0 * np.sqrt(2.0 * G * 0.7)
    x = sim.positions
    assert x[:, 1].min() > 0.0 and np.abs(x[:, 0]).max() < 1.0  # nothing left the tank
    # the landing (from 0.14 s) was taken at steps within the load bound, below the 5 ms cap
    landing = [st.dt for st in steps if st.time > 0.14]
    assert landing and max(landing) <= max(bounds) * (1 + 1e-9) < 0.005


def test_pcisph_checkpoint_keeps_the_step_bound(tmp_path: Path) -> None:
    """A PCISPH run continued from a checkpoint repeats the uninterrupted one bit for bit while
    the adaptive step bound acts (sampled 2r from the walls, the column starts compressed there
    and 5 sweeps cannot reach the tolerance: the solves halve the bound)."""
    def make() -> Simulation:
        return Simulation(_column("pcisph", width=0.06, height=0.1, max_error=0.001,
                                  max_iterations=5, margin=0.0))

    full = make()
    full.run(until=0.01)
    half = make()
    half.run(until=0.005)
    assert np.isfinite(half.pressure.step_bound.value)
    half.save_checkpoint(tmp_path / "checkpoints" / "checkpoint_000000001.npz")
    resumed = Simulation.from_checkpoint(tmp_path)
    assert resumed.pressure.step_bound.value == half.pressure.step_bound.value
    resumed.run(until=0.01)
    assert (full.time, full.step_count) == (resumed.time, resumed.step_count)
    np.testing.assert_array_equal(full.positions, resumed.positions)


def test_pcisph_lone_particle_is_not_thrown_off_a_volume_map_wall(tmp_path) -> None:
    """A lone particle thrown at 3 m/s against a volume-map wall (3D, a 0.3 m box, no gravity,
    r = 1.5 cm) is stopped, not thrown back. Its PPE diagonal next to the wall's one virtual
    particle (V_B of up to ~20 particle volumes) is many times the template's, so one sweep with
    the template's factor overshot the predicted density below rho0, where the clamped update
    stops: the solve converged with MPa pressures and threw the particle back (measured in
    this box: 12.6 m/s; in validation/startup.py's tank 69 m/s, and unstable at step 15 from
    6 m/s). With the factor capped where the particle's own diagonal exceeds three times the
    template's (omega <= 1.5) it comes back slower than it came (validation/startup.py's tank,
    CAP 2: 1.4 m/s; the solve removes the normal velocity, as an incompressible solver does).
    Bound: no faster than it came."""
    box = Path(__file__).resolve().parent.parent / "benchmarks" / "scenes" / "UnitBox.obj"
    r = 0.015
    scene = Scene.model_validate({
        "configuration": {
            "dim": 3, "particle_radius": r, "gravity": [0.0, 0.0, 0.0],
            "pressure": {"method": "pcisph"},
            "boundary": {"method": "bender2019", "map_cache_dir": str(tmp_path)},
        },
        "materials": [{"id": "fluid", "density0": 1000.0}],
        "fluid_blocks": [{"start": [-r, -r, -r], "end": [r, r, r],
                          "velocity": [0.0, 0.0, -3.0]}],
        "meshes": [{"geometry_file": str(box), "scale": [0.3, 0.3, 0.3], "invert": True,
                    "map_resolution": [8, 8, 8]}],
    })
    sim = Simulation(scene)
    assert sim.fluid.n == 1
    z0 = float(sim.fluid["x"][2, 0])
    for _ in range(400):  # to the wall (0.15 m away) and back, or stopped there
        sim.step()
        v, z = sim.fluid["v"][:, 0], float(sim.fluid["x"][2, 0])
        if v[2] > 0.0 and z >= z0:
            break
    speed = float(np.linalg.norm(v))
    assert speed <= 3.0, speed


@pytest.mark.parametrize(("speed", "nx", "ny", "gap"),
                         [(7.5, 2, 2, 4.0), (10.0, 2, 2, 3.3), (10.0, 3, 1, 4.0),
                          (15.0, 3, 1, 3.3)])
def test_pcisph_small_blocks_thrown_at_a_volume_map_wall_are_not_thrown_back(
        tmp_path, speed: float, nx: int, ny: int, gap: float) -> None:
    """Blocks of nx x ny particles (2D, r = 2.5 cm, a 1 m box of volume-map walls), their front
    gap r off the right wall, thrown at it at ``speed``, 0.15 s. Stopping such a particle takes
    a pressure that moves it more than THROW_PLAIN r within the step, so the impact rule's plain
    re-solve "throws" too; leaving those particles out of a third solve (the thrown-particle
    rule judged by the displacement) let them hit the wall unchecked and threw them back at
    19-42 m/s in these four cases. The rule leaves out only particles whose speed the pressure
    raises (:meth:`sphkit.core.impacts.Impacts.released`). Bound: nothing drives the flow, so no
    particle gets faster than the start speed plus a free fall through the block's 0.3 m
    height, ``sqrt(v0^2 + 2 g 0.3)``."""
    r = 0.025
    x0 = 1.0 - gap * r - nx * 2 * r
    scene = Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -9.81],
                          "pressure": {"method": "pcisph"},
                          "boundary": {"method": "bender2019", "map_cache_dir": str(tmp_path)}},
        "materials": [{}],
        "fluid_blocks": [{"start": [x0, 0.3], "end": [x0 + nx * 2 * r, 0.3 + ny * 2 * r],
                          "velocity": [speed, 0.0]}],
        "boxes": [{"min": [0.0, 0.0], "max": [1.0, 1.0]}],
    })
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the tiny block's start-up notes
        sim = Simulation(scene)
    fastest = 0.0
    while sim.time < 0.15:
        fastest = max(fastest, sim.step().max_velocity)
    assert fastest <= np.sqrt(speed**2 + 2 * 9.81 * 0.3), fastest


def test_pcisph_failed_solve_is_computed_again_with_half_the_step(
        caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    """A block falling at 3 m/s one radius above the floor, first step 5 ms (1.5 r of
    penetration predicted at the floor; CFL factor 2): PCISPH's solve stops at its 10
    iterations far above its tolerance (more than ``REJECT`` times), so with ``time.retries``
    the step is computed again with half the step, each time logged, until the solve no
    longer fails; with ``retries: 0`` the failed step is kept, as before. The step that was
    computed again is shorter and ends with a smaller density error than the kept failed one
    (the point of repeating it), and no particle crosses the floor. (PCISPH's load bound is
    lifted: with 10 sweeps it would take the first step below 5 ms, and this test is of the
    retry of a failed step.)"""
    monkeypatch.setattr(pcisph_module, "LOAD", float("inf"))
    r = 0.01

    def scene(retries: int) -> Scene:
        sc = _column("pcisph", width=0.2, height=0.1, r=r, margin=0.2, max_iterations=10)
        sc.fluid_blocks[0].start[1] += r
        sc.fluid_blocks[0].end[1] += r
        sc.fluid_blocks[0].velocity = [0.0, -3.0]
        tc = sc.configuration.time
        tc.dt = tc.dt_max = 0.005
        tc.cfl_factor = 2.0  # the CFL step 5.3 ms: the first step is the scene's 5 ms
        tc.retries = retries
        return sc

    kept = Simulation(scene(0))
    failed = kept.step()
    assert failed.rejected == 0 and failed.dt == pytest.approx(0.005)
    assert failed.density_error_avg > REJECT * 0.0005  # the solve failed by the rule
    sim = Simulation(scene(4))
    assert sim.state.retries == 4  # the column's standard viscosity only adds to a
    with caplog.at_level(logging.WARNING, logger="sphkit"):
        s = sim.step()
    msgs = [rec.getMessage() for rec in caplog.records if "time.retries" in rec.getMessage()]
    assert s.rejected >= 1 and len(msgs) == s.rejected
    assert s.dt == pytest.approx(0.005 * 0.5 ** s.rejected)
    assert s.density_error_avg < failed.density_error_avg
    assert sim.state.fluid["x"][1].min() > 0.0  # above the box's floor
    # solved walls keep their pressures as the next solve's warm start: no retries there
    walled = scene(4)
    walled.configuration.boundary.solved = True
    assert Simulation(walled).state.retries == 0


@pytest.mark.parametrize("materials", [
    {"viscosity": {"method": "standard", "coefficient": 0.01, "boundary_coefficient": 0.01},
     "surface_tension": {"method": "akinci2013", "coefficient": 0.5,
                         "boundary_coefficient": 0.5},
     "vorticity": {"method": "confinement", "coefficient": 0.1}},
    {"viscosity": {"method": "xsph", "coefficient": 0.05, "boundary_coefficient": 0.05},
     "drag": {"method": "macklin2014", "coefficient": 0.1, "air_velocity": [0.5, 0.0]}},
    {"surface_tension": {"method": "becker2007", "coefficient": 0.5,
                         "boundary_coefficient": 0.1},
     "drag": {"method": "gissler2017", "coefficient": 1.0}},
    {"surface_tension": {"method": "he2014", "coefficient": 0.5, "boundary_coefficient": 0.1}},
    {"surface_tension": {"method": "mueller2003", "coefficient": 0.5}},
])
def test_repeatable_forces_give_the_same_step_twice(materials: dict) -> None:
    """The forces marked ``repeatable`` (a rejected step, ``time.retries``, applies them again
    from the step's start) change nothing but what they derive from the state: applied a second
    time to the same state, every fluid field is the same bit for bit, the acceleration
    included (refilled with gravity first, as the step does)."""
    from sphkit.core import arrays

    sc = _column("pcisph", width=0.1, height=0.1)
    sc.materials[0] = sc.materials[0].model_validate({"id": "fluid", "density0": RHO0,
                                                      **materials})
    sim = Simulation(sc)
    for _ in range(3):
        sim.step()  # moving fluid, not the start's lattice
    assert sim.world.repeatable and sim.forces
    st = sim.state
    sim._neighbors()
    sim.compute_density()
    fields = []
    for _ in range(2):
        arrays.fill_rows(st.fluid["a"], st.gravity)
        for force in sim.forces:
            assert force.repeatable
            force.apply(st, 0.002)
        fields.append({k: np.array(st.fluid[k]) for k in st.fluid.fields})
    assert fields[0].keys() == fields[1].keys()
    for k in fields[0]:
        np.testing.assert_array_equal(fields[1][k], fields[0][k], err_msg=k)
    assert np.abs(fields[0]["a"] - np.array(st.gravity)[:, None]).max() > 0.0  # forces acted


def test_a_converged_pcisph_solve_that_throws_a_particle_is_computed_again(monkeypatch) -> None:
    """validation/energy.py's inviscid 2D dam break (100 particles, r = 1 cm, Akinci walls in a
    closed box), PCISPH, 0.5 s. A solve can converge on the average while one splash particle's
    prediction has left the linear range, and its pressure throws it: without the check the
    fluid's mechanical energy (kinetic + gravity) reached 2.07 times its start at 0.25 s. With
    it (a solve whose pressure moves a particle more than THROW = 0.5 r within the step is
    computed again with a shorter step) measured 1.035; bound 1.1 (symplectic Euler's exchange
    with the elastic energy; nothing drives the flow, so the energy can only fall)."""
    energy = load_validation("energy.py")
    top, retries, on = {}, {}, pcisph_module.THROW
    for throw in (on, float("inf")):
        monkeypatch.setattr(pcisph_module, "THROW", throw)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sim = Simulation(energy.scene(2, 0.01, "pcisph", "akinci2012", None))
        e0, top[throw], retries[throw] = energy.energy(sim), 1.0, 0
        while sim.time < 0.5:
            retries[throw] += sim.step().rejected
            top[throw] = max(top[throw], energy.energy(sim) / e0)
    assert top[on] < 1.1, top
    assert top[float("inf")] > 1.5, top  # the contrast: the throw
    assert retries[on] > retries[float("inf")], retries
