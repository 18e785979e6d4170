"""Non-pressure forces (standard viscosity, XSPH) and the linear state equation."""

from __future__ import annotations

import numpy as np
import pytest

from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

G = 9.81


def _block(method: str, coeff: float, boundary: float = 0.0, box: bool = False,
           pressure: str | None = None, **extra: float) -> Simulation:
    sc = {
        "configuration": {"dim": 3, "particle_radius": 0.02, "gravity": [0.0, 0.0, 0.0]},
        "materials": [{"viscosity": {"method": method, "coefficient": coeff,
                                     "boundary_coefficient": boundary, **extra}}],
        "fluid_blocks": [{"start": [0.0, 0.0, 0.0], "end": [0.4, 0.4, 0.4]}],
    }
    if pressure:
        sc["configuration"]["pressure"] = {"method": pressure}
    if box:
        sc["boxes"] = [{"min": [0.0, 0.0, 0.0], "max": [0.4, 0.5, 0.4], "layers": 2}]
    sim = Simulation(Scene.model_validate(sc))
    sim._neighbors()
    sim.compute_density()
    return sim


def _viscous_accel(sim: Simulation, v: np.ndarray, dt: float = 1e-3) -> np.ndarray:
    sim.fluid["v"][...] = v
    sim.fluid["a"][...] = 0.0
    for force in sim.forces:
        force.apply(sim.state, dt)
    return sim.fluid["a"].copy()


@pytest.mark.parametrize("method,coeff", [("standard", 0.01), ("xsph", 0.1)])
def test_uniform_motion_feels_no_viscosity(method: str, coeff: float) -> None:
    """Galilean invariance: both models act on velocity differences only, so a uniform velocity
    gives zero acceleration (to round-off, 1e-12 relative to |v|/dt)."""
    sim = _block(method, coeff)
    a = _viscous_accel(sim, np.array([[0.3], [-0.2], [0.1]]) * np.ones((3, sim.fluid.n)))
    assert np.abs(a).max() < 1e-12 * 0.3 / 1e-3


def test_standard_viscosity_vanishes_for_rigid_rotation() -> None:
    """(v_ij . x_ij) = 0 for v = omega x x, so the Monaghan form gives exactly no force."""
    sim = _block("standard", 0.01)
    x = sim.fluid["x"] - sim.fluid["x"].mean(axis=1, keepdims=True)
    v = np.cross(np.array([0.2, -0.5, 0.3])[:, None], x, axis=0)
    assert np.abs(_viscous_accel(sim, v)).max() < 1e-12


@pytest.mark.parametrize("several", [False, True])
def test_standard_viscosity_from_the_cached_pair_gradients(several: bool) -> None:
    """Where the step caches ``V_j grad W_ij`` (DFSPH here) the standard viscosity takes its
    fluid pairs' kernel derivative from the cache: the same accelerations as the kernel's
    evaluation (1e-12 relative: round-off of the two products), with one fluid and with two
    rest densities (the cache's V_j = m_j / rho0_j), walls with their own coefficient too."""
    sim = _block("standard", 0.01, boundary=0.01, box=True, pressure="dfsph")
    f = sim.fluid
    if several:  # a lighter half: rest density and mass halved (the same rest volumes)
        light = np.arange(f.n) % 2 == 0
        f["rho0"][light] *= 0.5
        f["m"][light] *= 0.5
        sim.compute_density()
    assert sim.state.pair_grads is not None
    v = np.random.default_rng(1).normal(0.0, 0.1, (3, f.n))
    cached = _viscous_accel(sim, v)
    sim.state.pair_grads = None
    direct = _viscous_accel(sim, v)
    assert np.abs(cached - direct).max() <= 1e-12 * np.abs(direct).max()


def test_xsph_beside_a_viscosity_adds_its_smoothing() -> None:
    """SPlisHSPlasH applies its XSPH on top of the material's viscosity method
    (``Simulation::computeNonPressureForces``): ``viscosity.xsph`` beside the standard
    viscosity gives the standard model's accelerations plus XSPH's alone, walls included
    (to round-off), and the sum still only dissipates a random field's energy."""
    v = np.random.default_rng(2).normal(0.0, 0.1, (3, 1000))
    both = _block("standard", 0.01, 0.01, box=True, xsph=0.1, xsph_boundary=0.05)
    assert len(both.forces) == 2
    a = _viscous_accel(both, v[:, :both.fluid.n])
    parts = (_viscous_accel(_block("standard", 0.01, 0.01, box=True), v[:, :both.fluid.n])
             + _viscous_accel(_block("xsph", 0.1, 0.05, box=True), v[:, :both.fluid.n]))
    assert np.abs(a - parts).max() <= 1e-12 * np.abs(parts).max()
    assert float(np.sum(both.fluid["m"] * np.sum(a * both.fluid["v"], axis=0))) < 0.0


@pytest.mark.parametrize("method,coeff", [("standard", 0.01), ("xsph", 0.1)])
def test_viscosity_dissipates_relative_motion(method: str, coeff: float) -> None:
    """A random velocity field: the viscous accelerations do negative work (power
    sum m v . a < 0), i.e. they remove kinetic energy of the relative motion."""
    sim = _block(method, coeff)
    v = np.random.default_rng(0).normal(0.0, 0.1, (3, sim.fluid.n))
    a = _viscous_accel(sim, v)
    power = float((sim.fluid["m"] * (v * a).sum(axis=0)).sum())
    assert power < 0.0


@pytest.mark.parametrize("method,coeff", [("standard", 0.01), ("xsph", 0.1)])
def test_boundary_viscosity_drags_along_static_walls(method: str, coeff: float) -> None:
    """Fluid sliding along static walls: with the boundary coefficient > 0 the wall term opposes
    the motion (mean acceleration against v); with 0 the uniform slide feels no force at all."""
    v = np.array([[0.2], [0.0], [0.0]])
    free = _block(method, coeff, boundary=0.0, box=True)
    a0 = _viscous_accel(free, v * np.ones((3, free.fluid.n)))
    assert np.abs(a0).max() < 1e-9
    sticky = _block(method, coeff, boundary=coeff, box=True)
    a1 = _viscous_accel(sticky, v * np.ones((3, sticky.fluid.n)))
    assert a1[0].mean() < 0.0
    assert np.abs(a1[1:]).max() < 1e-9 + 0.5 * np.abs(a1[0]).max()


def test_linear_state_equation_hydrostatic_column() -> None:
    """SESPH with p = k (rho - rho0), k = 1000 m^2/s^2 (c = 31.6 m/s). The soft column is
    settled before t = 0 (``start.settle`` "auto"), but its slope still breathes from step to
    step, so pressure and height are averaged per particle over t = 0.25..0.75 s (about 2,000
    steps; the means over each 0.05 s from 0 to 2 s measured 0.98-1.03 rho0 g): that mean slope
    over the middle 80 % of the column is within 5 % of rho0 g (measured 1.003; over 1..2 s,
    the earlier window, 1.011) and the compression about g H / (2 k) = 0.25 % (measured
    0.249 %, bound 1 %)."""
    sc = Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": 0.01, "gravity": [0.0, -G],
                          "pressure": {"method": "wcsph", "equation": "linear",
                                       "stiffness": 1000.0}},
        "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [0.2, 0.5]}],
        "boxes": [{"min": [0.0, 0.0], "max": [0.2, 0.6], "layers": 2}],
    })
    sim = Simulation(sc)
    sim.run(until=0.25)
    n = sim.fluid.n
    p_sum, y_sum, comp, steps = np.zeros(n), np.zeros(n), [], [0]

    def accumulate(s: Simulation, st) -> None:
        order = s.fluid.order_by_id()
        p_sum[:] += s.pressures[order]
        y_sum[:] += s.positions[order, 1]
        comp.append(np.maximum(s.densities - 1000.0, 0.0).mean() / 1000.0)
        steps[0] += 1

    sim.run(until=0.75, on_step=accumulate)
    y, p = y_sum / steps[0], p_sum / steps[0]
    top = y.max()
    sel = (y > 0.1 * top) & (y < 0.9 * top)
    slope = -np.polyfit(y[sel], p[sel], 1)[0]
    assert abs(slope / (1000.0 * G) - 1.0) < 0.05, slope / (1000.0 * G)
    assert np.mean(comp) < 0.01


@pytest.mark.parametrize("substeps", [1, 8])
def test_explicit_viscosity_bounds_the_time_step(substeps: int) -> None:
    """The standard (explicit) viscosity is stable only within Morris et al. 1997's diffusion
    condition ``dt <= 0.125 (2r)^2 / nu`` (1.25 ms at r = 5 mm, nu = 0.01 m^2/s; at 2 ms a 2D
    column at 0.4 x 0.6 m grew 3.8 m/s from rest within 0.3 s, validation/README.md). With
    ``substeps`` 1 the step stays within it; with the default 8 the scene's 2 ms steps are
    taken in four viscous sub-steps each (at most half the condition each). Either way a small
    2D column at rest stays at rest (largest speed below 0.1 m/s over 0.1 s)."""
    r, nu = 0.005, 0.01
    sim = Simulation(Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -9.81],
                          "pressure": {"method": "dfsph"}, "time": {"dt_max": 0.002}},
        "materials": [{"viscosity": {"method": "standard", "coefficient": nu,
                                     "substeps": substeps}}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [0.1, 0.15]}],
        "boxes": [{"min": [0.0, 0.0], "max": [0.1, 0.2]}]}))
    bound = 0.125 * (2 * r) ** 2 / nu
    vmax, longest = 0.0, 0.0
    while sim.time < 0.1:
        s = sim.step()
        assert s.dt <= max(1, substeps // 2) * bound * (1 + 1e-12), s.dt
        vmax, longest = max(vmax, s.max_velocity), max(longest, s.dt)
    assert vmax < 0.1, vmax
    # the condition, resp. the scene's own cap above it, is reached
    assert longest == pytest.approx(bound if substeps == 1 else 0.002, rel=1e-9)


def test_viscous_substeps_damp_what_one_long_step_amplifies() -> None:
    """Sub-steps (``viscosity.substeps``): a step three times the diffusion condition is taken
    as six explicit sub-steps of half the condition, ``v_{k+1} = v_k + (dt / 6) a(v_k)``, and
    the step's acceleration is ``(v_6 - v_0) / dt``. On the lattice's shortest wave (x
    velocity alternating from particle to particle, the mode the condition is about) one
    explicit step of that length amplifies the
    velocity (explicit Euler's factor ``|1 - dt nu lambda| > 1``), the sub-steps damp it, as
    viscosity must; and within the condition the sub-stepped force is the single-step one, bit
    for bit."""
    r, nu = 0.02, 0.1
    bound = 0.125 * (2 * r) ** 2 / nu
    acc, sims = {}, {}
    for substeps in (1, 8):
        sim = Simulation(Scene.model_validate({
            "configuration": {"dim": 3, "particle_radius": r, "gravity": [0.0, 0.0, 0.0]},
            "materials": [{"viscosity": {"method": "standard", "coefficient": nu,
                                         "substeps": substeps}}],
            "fluid_blocks": [{"start": [0.0, 0.0, 0.0], "end": [0.4, 0.4, 0.4]}]}))
        sim._neighbors()
        sim.compute_density()
        sims[substeps] = sim
    x = sims[1].fluid["x"]
    cells = np.rint(x / (2 * r)).astype(np.int64).sum(axis=0)
    v = np.zeros_like(x)
    v[0] = 0.01 * (-1.0) ** cells
    force = sims[8].forces[0]
    assert force.substeps_of(sims[8].state, 3 * bound) == 6  # each half the condition
    assert force.substeps_of(sims[8].state, bound) == 1
    for substeps, sim in sims.items():
        acc[substeps] = _viscous_accel(sim, v, 3 * bound)
        acc[substeps, "within"] = _viscous_accel(sim, v, bound)
    assert np.array_equal(acc[1, "within"], acc[8, "within"])
    energy = float((v ** 2).sum())
    one = float(((v + 3 * bound * acc[1]) ** 2).sum())
    sub = float(((v + 3 * bound * acc[8]) ** 2).sum())
    # a dissipative force must not raise the kinetic energy: the long explicit step does (it
    # is 2.7 times what it was), its sub-steps do not
    assert one > energy, one / energy
    assert sub < energy, sub / energy
