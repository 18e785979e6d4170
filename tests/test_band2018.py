"""MLS pressure extrapolation to boundary particles (Band et al. 2018): the fit reproduces linear
pressure fields, the scene option is validated. The hydrostatic slopes it gives are tested in
test_dfsph_iisph.py and test_pcisph_pbf.py."""

from __future__ import annotations

import numpy as np
import pytest

from sphkit.boundary.band2018 import (
    RIDGE,
    MLSPressureExtrapolation,
    mls_coefficients,
    mls_extrapolate,
)
from sphkit.scene.schema import Scene, SceneError
from sphkit.simulation import Simulation

L = 0.32  # tank width [m], a multiple of the spacing 2r: the walls continue the fluid lattice


def _tank(dim: int, bp: str = "mls", method: str = "akinci2012") -> Scene:
    r = 0.02
    return Scene.model_validate({
        "configuration": {"dim": dim, "particle_radius": r,
                          "pressure": {"method": "dfsph"},
                          "boundary": {"method": method, "pressure": bp}},
        "fluid_blocks": [{"start": [0.0] * dim, "end": [L] * dim}],
        "boxes": [{"min": [0.0] * dim, "max": [L] * dim, "layers": 2}],
    })


def _jittered(dim: int) -> Simulation:
    sim = Simulation(_tank(dim))
    st = sim.state
    rng = np.random.default_rng(3)
    st.fluid["x"][:] += rng.uniform(-0.3, 0.3, st.fluid["x"].shape) * st.r
    sim._neighbors()
    sim.compute_density()
    return sim


def _extrapolate(sim: Simulation, grad: np.ndarray, ridge: float) -> tuple:
    """Extrapolated and exact ``p_b / rho0`` of ``p = 3e4 Pa + grad . x`` (positive in the
    tank, so the clamp at 0 does not act), and the fluid neighbour counts of the samples."""
    st = sim.state
    p = 3e4 + grad @ st.fluid["x"]
    k = p / st.rho0 / (st.fluid["rho"] / st.rho0) ** 2  # the solvers' variable
    ext = MLSPressureExtrapolation(st.coupling.pressure.use, ridge=ridge)
    ext.init(st)
    ext.prepare(st)
    out = np.zeros(st.boundary.n)
    ext.extrapolate(k, out)
    exact = (3e4 + grad @ st.boundary["x"]) / st.rho0
    assert np.all(exact > 0)
    return out, exact, np.diff(ext.toff)


@pytest.mark.parametrize("dim", [2, 3])
def test_mls_reproduces_linear_pressure_at_the_walls(dim: int) -> None:
    """Moving least squares with a linear basis reproduces linear fields: without the Tikhonov
    term a linear pressure is extrapolated exactly (relative error 1e-6: round-off of the nearly
    collinear neighbourhoods) at every wall sample with enough fluid neighbours (jittered
    fluid; neighbours at distance ~h have weight ~0 and do not count, hence 2 dim; with fewer
    the fit falls back to the Shepard average, as it should)."""
    sim = _jittered(dim)
    grad = np.array([3.0, -5.0, 2.0][:dim]) * 1e4  # [Pa/m]
    out, exact, counts = _extrapolate(sim, grad, 0.0)
    sel = counts >= 2 * dim
    assert sel.sum() >= 5
    assert np.abs(out[sel] - exact[sel]).max() < 1e-6 * np.abs(exact).max()


@pytest.mark.parametrize("dim", [2, 3])
def test_mls_with_ridge_keeps_the_gradient_along_the_wall(dim: int) -> None:
    """With the default Tikhonov weight, the pressure gradient *along* a wall (what a side wall
    must carry in a hydrostatic column) is still extrapolated: error below 10 % of the pressure
    change over one support radius h at the floor samples (measured 2D 4.9 %, 3D 5.2 %: the ridge
    shortens the fitted gradient by about RIDGE over the neighbours' second moment in units of
    h^2, ~0.1 for a single row). The
    gradient *normal* to the wall is not determined by the single fluid row that a wall sample
    sees at h = 4r; the ridge takes it as 0 there instead of fitting particle noise."""
    sim = _jittered(dim)
    st = sim.state
    grad = np.zeros(dim)
    grad[0] = 4e4  # [Pa/m], along the floor
    out, exact, counts = _extrapolate(sim, grad, RIDGE)
    bx = st.boundary["x"]
    # floor samples at least h from the side walls (full neighbourhoods along the floor)
    side = np.delete(bx, 1, axis=0)
    floor = (bx[1] < 0.0) & np.all((side > st.h) & (side < L - st.h), axis=0)
    sel = floor & (counts >= dim + 1)
    assert sel.sum() >= 3
    err = np.abs(out[sel] - exact[sel]).max()
    assert err < 0.10 * grad[0] * st.h / st.rho0, err / (grad[0] * st.h / st.rho0)


def test_mls_option_is_validated() -> None:
    with pytest.raises(
            ValueError, match=r"configuration.boundary.pressure\n.*'mirror', 'mls' or 'hydro"):
        Scene.model_validate({"configuration": {"dim": 2,
                                                "boundary": {"pressure": "extrapolate"}}})
    with pytest.raises(SceneError, match="configuration.boundary.pressure: 'mls'"):
        Simulation(_tank(2, method="bender2019"))


def test_mls_leaves_moving_bodies_and_mirror_alone() -> None:
    """'mirror' builds no extrapolation; with 'mls' (akinci2012's default) the extrapolated
    samples stop mirroring."""
    sim = Simulation(_tank(2, bp="mirror"))
    assert sim.state.coupling.pressure is None
    sim = Simulation(_tank(2))
    bp = sim.state.coupling.pressure
    assert bp.use.all()
    assert np.all(sim.state.boundary["pressure_mirror"] == 0.0)


def test_boundary_values_kept_between_solves_read_as_fresh_ones() -> None:
    """The coupling keeps one array for the extrapolated ``k_b`` of every solve (each solve's
    values overwrite the last ones only at the samples fitted now): after a few steps, the
    samples the pressure terms read (the fluid's boundary neighbours) hold exactly the values
    an extrapolation into a fresh array of zeros gives."""
    sim = _jittered(2)
    for _ in range(3):
        sim.step()
    st = sim.state
    sim._neighbors()
    sim.compute_density()
    k = np.random.default_rng(4).uniform(0.0, 50.0, st.fluid.n)
    kb = st.coupling.boundary_kappa(st)
    assert kb.kb is st.coupling.boundary_kappa(st).kb
    got = kb(k)
    fresh = np.zeros(st.boundary.n)
    st.coupling.pressure.extrapolate(k, fresh)
    read = np.unique(st.nl_fb.indices)
    assert read.size >= 40  # the 2D tank: 50 wall samples with fluid neighbours
    assert np.array_equal(got[read], fresh[read])


@pytest.mark.parametrize("dim", [2, 3])
def test_mls_fits_each_phase_on_its_own(dim: int) -> None:
    """Two fluids of rest density 1000 and 100, heavy below: the hydrostatic pressure is
    continuous across the interface but its gradient jumps tenfold there, so a linear fit over
    both phases cannot reproduce either. With several rest densities each phase's fluid
    neighbours are fitted on their own (one boundary value per phase): a pressure field that is
    linear *within each phase* (different gradients) is then extrapolated exactly for each phase
    at every wall sample with enough fluid neighbours of that phase (relative error 1e-6,
    round-off as in the single-fluid test), while the mixed fit of the same samples misses by
    more than 1 % where it sees both phases."""
    r = 0.02
    z = [0.0] * (dim - 2)
    top = [L] * (dim - 2)
    sc = Scene.model_validate({
        "configuration": {"dim": dim, "particle_radius": r, "pressure": {"method": "dfsph"},
                          "boundary": {"method": "akinci2012", "pressure": "mls",
                                       "solved": False}},
        "materials": [{"id": "heavy", "density0": 1000.0}, {"id": "light", "density0": 100.0}],
        "fluid_blocks": [{"start": [0.0, 0.0, *z], "end": [L, L / 2, *top],
                          "material": "heavy"},
                         {"start": [0.0, L / 2, *z], "end": [L, L, *top], "material": "light"}],
        "boxes": [{"min": [0.0] * dim, "max": [L] * dim, "layers": 2}],
    })
    sim = Simulation(sc)
    st = sim.state
    rng = np.random.default_rng(5)
    st.fluid["x"][:] += rng.uniform(-0.3, 0.3, st.fluid["x"].shape) * r
    sim._neighbors()
    sim.compute_density()
    phase = st.fluid["phase"]
    grads = [np.array([3.0, -5.0, 2.0][:dim]) * 1e4, np.array([-1.0, 2.0, -4.0][:dim]) * 1e4]
    p = np.where(phase == 0, 3e4 + grads[0] @ st.fluid["x"], 3e4 + grads[1] @ st.fluid["x"])
    k = p / st.rho0 / (st.fluid["rho"] / st.fluid["rho0"]) ** 2
    ext = MLSPressureExtrapolation(st.coupling.pressure.use, ridge=0.0)
    ext.init(st)
    ext.prepare(st)
    assert ext.phases == 2 and ext.phase is not None
    out = np.zeros((2, st.boundary.n))
    ext.extrapolate(k, out)
    tfl = ext.tfluid
    count = np.array([[np.sum(phase[tfl[ext.toff[b]:ext.toff[b + 1]]] == q)
                       for b in range(st.boundary.n)] for q in range(2)])
    exact = [(3e4 + g @ st.boundary["x"]) / st.rho0 for g in grads]
    for q in range(2):
        assert np.all(exact[q] > 0)
        sel = count[q] >= 2 * dim
        assert sel.sum() >= 5
        assert np.abs(out[q, sel] - exact[q][sel]).max() < 1e-6 * np.abs(exact[q]).max()
    # the mixed fit (one value per sample, the phases together) of the same field, where a
    # sample sees both phases: off both phases' values
    mixed_coef = np.empty(tfl.shape[0])
    mls_coefficients(st.fluid["x"], st.fluid["rho"] / st.fluid["rho0"], st.boundary["x"],
                     ext.toff, tfl, ext.rows, st.h, st.kid, dim, st.pair_period, 0.0,
                     mixed_coef, np.zeros(st.fluid.n, np.int64), 1)
    mixed = np.zeros(st.boundary.n)
    mls_extrapolate(k, ext.toff, tfl, ext.rows, mixed_coef, mixed)
    both = (count[0] >= 1) & (count[1] >= 1) & (count.sum(axis=0) >= 2 * dim)
    assert both.sum() >= 2
    off = [np.abs(mixed[both] - exact[q][both]) / exact[q][both] for q in range(2)]
    assert np.minimum(off[0], off[1]).max() > 0.01
