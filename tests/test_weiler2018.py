"""Implicit viscosity of Weiler et al. 2018: the backward-Euler system, conservation,
unconditional stability, the high-viscosity regime where explicit viscosity fails, SPlisHSPlasH
scene mapping, and a fast Poiseuille start-up (the long study is validation/poiseuille.py)."""

from __future__ import annotations

import numpy as np
import pytest
from _validation import load_validation

from sphkit.scene.files import scene_from_dict
from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation
from sphkit.viscosity.standard import StandardViscosity


def _sim(method: str, nu: float, nub: float, periodic: bool, **vis) -> Simulation:
    if periodic:
        cfg = {"dim": 2, "particle_radius": 0.01, "gravity": [0.0, 0.0], "periodic_x": [0, 0.2]}
        blocks = [{"start": [0.0, 0.0], "end": [0.2, 0.16]}]
        boxes = [{"min": [0.0, 0.0], "max": [0.2, 0.16], "layers": 2}]
    else:
        cfg = {"dim": 3, "particle_radius": 0.02, "gravity": [0.0, 0.0, 0.0]}
        blocks = [{"start": [0.0, 0.0, 0.0], "end": [0.24, 0.24, 0.24]}]
        boxes = [{"min": [0.0, 0.0, 0.0], "max": [0.24, 0.32, 0.24], "layers": 2}]
    sc = {"configuration": cfg, "fluid_blocks": blocks, "boxes": boxes,
          "materials": [{"viscosity": {"method": method, "coefficient": nu,
                                       "boundary_coefficient": nub, **vis}}]}
    sim = Simulation(Scene.model_validate(sc))
    sim._neighbors()
    sim.compute_density()
    return sim


@pytest.mark.parametrize("periodic", [False, True])
def test_solution_satisfies_backward_euler_with_the_explicit_operator(periodic: bool) -> None:
    """With densities set to rho0 the Weiler operator and the standard (explicit) viscosity are
    the same Laplacian (including the wall term), written independently. The implicit velocity
    must then satisfy backward Euler, ``v_new - dt a_std(v_new) = v``, to the CG tolerance
    (1e-10 relative, so 1e-8 of |v| leaves room for round-off). Stiff case: nu dt / (2r)^2 = 25
    (the explicit limit is about 0.1). Runs in 3D with walls and in 2D periodic in x with walls
    across y (the seam pairs take the minimum image in both operators)."""
    nu, dt = (0.04, 0.4) if not periodic else (0.01, 1.0)
    sim = _sim("weiler2018", nu, 0.5 * nu, periodic, max_error=1e-10, max_iterations=2000)
    f = sim.fluid
    f["rho"][:] = sim.state.rho0
    v0 = np.random.default_rng(5).normal(0.0, 0.1, f["v"].shape)
    f["v"][...] = v0
    f["a"][...] = 0.0
    force = sim.forces[0]
    force.apply(sim.state, dt)
    assert force.stats.converged and force.stats.iterations > 5
    vnew = v0 + dt * f["a"]
    f["v"][...] = vnew
    f["a"][...] = 0.0
    StandardViscosity(nu, 0.5 * nu, substeps=1).apply(sim.state, dt)  # one explicit step
    resid = vnew - dt * f["a"] - v0
    assert np.linalg.norm(resid) < 1e-8 * np.linalg.norm(v0)


def test_implicit_solve_conserves_momentum_and_is_unconditionally_stable() -> None:
    """A periodic 2D block without walls, random velocities, nu dt / (2r)^2 = 250: the solve
    damps the relative motion (kinetic energy in the centre-of-mass frame drops by more than
    90 %) without any growth, and keeps the total momentum (antisymmetric pair forces) to the
    CG tolerance (1e-8 relative to sum m |v|, with max_error 1e-10)."""
    sc = {"configuration": {"dim": 2, "particle_radius": 0.01, "gravity": [0.0, 0.0],
                            "periodic_x": [0.0, 0.2]},
          "fluid_blocks": [{"start": [0.0, 0.0], "end": [0.2, 0.2]}],
          "materials": [{"viscosity": {"method": "weiler2018", "coefficient": 0.1,
                                       "max_error": 1e-10, "max_iterations": 3000}}]}
    sim = Simulation(Scene.model_validate(sc))
    sim._neighbors()
    sim.compute_density()
    f = sim.fluid
    v0 = np.random.default_rng(1).normal(0.0, 0.5, f["v"].shape)
    f["v"][...] = v0
    f["a"][...] = 0.0
    dt = 1.0
    sim.forces[0].apply(sim.state, dt)
    vnew = v0 + dt * f["a"]
    m = f["m"]
    p0, p1 = (m * v0).sum(axis=1), (m * vnew).sum(axis=1)
    assert np.abs(p1 - p0).max() < 1e-8 * (m * np.abs(v0).sum(axis=0)).sum()

    def rel_energy(v: np.ndarray) -> float:
        w = v - (m * v).sum(axis=1, keepdims=True) / m.sum()
        return float((m * (w * w).sum(axis=0)).sum())

    assert rel_energy(vnew) < 0.1 * rel_energy(v0)
    assert np.abs(vnew).max() <= np.abs(v0).max()


def _viscous_block(method: str, substeps: int = 8) -> Simulation:
    """A 3D block of 100 Pa s fluid (nu = 0.1 m^2/s) dropped 2 cm onto the floor of a box,
    DFSPH with the CFL step (5 ms at these speeds). The explicit stability limit of the standard
    viscosity is about 0.125 (2r)^2 / nu = 0.5 ms, ten times smaller."""
    vis = {"method": method, "coefficient": 0.1, "boundary_coefficient": 0.1}
    if method == "standard":
        vis["substeps"] = substeps
    sc = {"configuration": {"dim": 3, "particle_radius": 0.01,
                            "pressure": {"method": "dfsph", "max_error": 0.05},
                            "time": {"dt_max": 0.005}, "max_velocity": 10.0},
          "fluid_blocks": [{"start": [0.04, 0.02, 0.04], "end": [0.16, 0.14, 0.16]}],
          "boxes": [{"min": [0.0, 0.0, 0.0], "max": [0.2, 0.3, 0.2], "layers": 2}],
          "materials": [{"viscosity": vis}]}
    return Simulation(Scene.model_validate(sc))


def test_high_viscosity_block_explicit_at_its_bound_implicit_at_the_cfl_step() -> None:
    """Explicit standard viscosity is stable only within its diffusion limit 0.125 (2r)^2 / nu =
    0.5 ms (without the bound it raised InstabilityError, speed above 10 m/s or NaN, within 40
    steps of 5 ms): with ``substeps`` 1 the step is the limit, and 40 steps at 0.5 ms stay below
    1 m/s; with the default sub-steps the block falls and rests in 2 ms steps below 1 m/s for
    0.2 s. Weiler 2018 at the CFL step of 5 ms, ten times longer, stays below 1 m/s (free fall
    from 2 cm reaches 0.63 m/s) for 0.2 s with every solve converged."""
    explicit = _viscous_block("standard", substeps=1)
    for _ in range(40):
        s = explicit.step()
        assert s.dt == pytest.approx(0.125 * 0.02 ** 2 / 0.1)
        assert s.max_velocity < 1.0
    # the default 8 sub-steps of at most half the condition: steps of 2 ms, calm to the end
    # (with sub-steps at the full condition the block threw particles at 2.5 m/s, and with
    # substeps 1 beyond 40 steps at 5.6 m/s: validation/README.md)
    sub = _viscous_block("standard")
    vmax = 0.0
    while sub.time < 0.2:
        s = sub.step()
        vmax = max(vmax, s.max_velocity)
    assert s.dt == pytest.approx(8 * 0.5 * 0.125 * 0.02 ** 2 / 0.1)
    assert vmax < 1.0, vmax
    implicit = _viscous_block("weiler2018")
    vmax = 0.0
    while implicit.time < 0.2:
        s = implicit.step()
        vmax = max(vmax, s.max_velocity)
        assert implicit.forces[0].stats.converged
    assert s.dt == pytest.approx(0.005)
    assert vmax < 1.0
    # the block has settled on the floor, its bottom near the wall (y = 0), not sunk through
    assert implicit.fluid["x"][1].min() > 0.0


def test_splishsplash_material_maps_to_weiler2018() -> None:
    """viscosityMethod 6 with the "Weiler et al. 2018" block maps field by field; absent keys
    take SPlisHSPlasH's defaults (viscosityBoundary 0, viscoMaxIter 100, viscoMaxError 0.01);
    a bad value names its field."""
    base = {"Configuration": {"particleRadius": 0.025, "simulationMethod": 4},
            "FluidBlocks": [{"start": [0, 0, 0], "end": [0.5, 0.5, 0.5]}]}
    data = dict(base, Materials=[{"id": "Fluid", "viscosityMethod": 6, "Weiler et al. 2018": {
        "viscosity": 5.0, "viscosityBoundary": 4.0, "viscoMaxIter": 200,
        "viscoMaxError": 0.05}}])
    vis = scene_from_dict(data).materials[0].viscosity
    assert (vis.method, vis.coefficient, vis.boundary_coefficient, vis.max_iterations,
            vis.max_error) == ("weiler2018", 5.0, 4.0, 200, 0.05)
    data = dict(base, Materials=[{"id": "Fluid", "viscosityMethod": 6,
                                  "Weiler et al. 2018": {"viscosity": 0.5}}])
    vis = scene_from_dict(data).materials[0].viscosity
    assert (vis.boundary_coefficient, vis.max_iterations, vis.max_error) == (0.0, 100, 0.01)
    data = dict(base, Materials=[{"id": "Fluid", "viscosityMethod": 6,
                                  "Weiler et al. 2018": {"viscoMaxError": -1}}])
    with pytest.raises(Exception, match="viscoMaxError"):
        scene_from_dict(data)


def _poiseuille():
    return load_validation("poiseuille.py")


def test_poiseuille_start_up_implicit_matches_explicit_and_interior_curvature() -> None:
    """Fast Poiseuille start-up (validation/poiseuille.py, 10 rows across, hexagonal lattice,
    walls of resting lattice fluid): (1) Weiler 2018 and the explicit standard viscosity
    discretize the same Laplacian, so at the explicit step their profiles agree to 3 % of u_max
    at 0.2, 0.5 and 1.0 t_s (backward vs forward Euler differ by O(dt)); (2) in steady state the
    rows farther than h from the walls follow u'' = -F / nu to 6 % (the hexagonal lattice sum
    of the Laplacian is 1.9 % weak, the fit and the slightly compressed rows add the rest;
    measured 4.5 %). The walls' slip, which keeps the full profile about 28 % above Morris' peak
    at this resolution, is reported by the validation script, not asserted here."""
    P = _poiseuille()
    res = {}
    for method in ("standard", "weiler2018"):
        sim = P.hex_channel(method, 10, walls="lattice")
        res[method] = P.run(sim)
        h = sim.state.h
    for frac in P.FRACTIONS:
        _e, ys, us = res["standard"][frac]
        _e, yw, uw = res["weiler2018"][frac]
        os_, ow = np.argsort(ys, kind="stable"), np.argsort(yw, kind="stable")
        # compare row means (particles of a row are equivalent)
        rs = us[os_].reshape(10, -1).mean(axis=1)
        rw = uw[ow].reshape(10, -1).mean(axis=1)
        assert np.abs(rs - rw).max() < 0.03 * P.U_MAX
    for method in ("standard", "weiler2018"):
        _e, y, u = res[method][P.STEADY]
        k = P.curvature(y, u, h) / (-P.FORCE / P.NU)
        assert abs(k - 1.0) < 0.06


@pytest.mark.parametrize("dim", [2, 3])
def test_map_wall_samples_sum_to_the_closed_form_and_resist_sliding(dim: int) -> None:
    """On density and volume maps the wall term's volume sits at samples 0.5 h beside the
    virtual particle in the tangent plane (SPlisHSPlasH's m_tangentialDistanceFactor; four in
    3D, two in 2D): ``sphkit.core.viscous.wall_samples`` sums them in closed form. Checked
    against the explicit samples (any tangents; round-off only, so 1e-12), and what it is for:
    a fluid particle sliding along the wall feels a tangential drag (the single virtual
    particle along the normal gave none: SPlisHSPlasH's CoilingModel_Weiler2018 scene ran
    away to 40 m/s along its floor, 9.78 m/s now, SPlisHSPlasH 9.66)."""
    from sphkit.core.kernels import kernel_dw, kernel_id
    from sphkit.core.viscous import TANGENTIAL_DISTANCE, laplacian_diagonal_pair, wall_samples

    h, eps, c = 0.1, 0.01 * 0.1**2, 3.7
    kid = kernel_id("cubic")
    rng = np.random.default_rng(4)
    n = rng.normal(size=dim)
    n /= np.linalg.norm(n)
    d = -0.6 * h * n  # x_i - x_b: the virtual particle 0.6 h into the wall along n
    w = rng.normal(size=dim)
    spread = (TANGENTIAL_DISTANCE * h) ** 2
    g, cd, ct = wall_samples(c, float(d @ d), spread, eps, kid, h, dim)
    closed = g * (cd * (w @ d) * d + ct * w)
    # explicit samples x_k = d -+ 0.5 h t for an orthonormal tangent basis t of the plane
    basis = np.linalg.svd(np.eye(dim) - np.outer(n, n))[0][:, : dim - 1]
    basis = basis @ np.linalg.qr(rng.normal(size=(dim - 1, dim - 1)))[0]  # any tangents
    samples = [d + sgn * TANGENTIAL_DISTANCE * h * t for t in basis.T for sgn in (-1, 1)]
    share = 1.0 / len(samples)
    explicit = sum(laplacian_diagonal_pair(c * share, float(x @ x), eps, kid, h, dim)
                   * (w @ x) * x for x in samples)
    np.testing.assert_allclose(closed, explicit, rtol=1e-12, atol=1e-12 * abs(explicit).max())
    # sliding along the wall: no term from the normal pair, a drag from the samples
    t = basis[:, 0]
    single = laplacian_diagonal_pair(c, float(d @ d), eps, kid, h, dim) * (t @ d) * d
    drag = g * (cd * (t @ d) * d + ct * t)  # the acceleration's share: opposes the sliding
    assert drag @ t < 0.0 and kernel_dw(kid, float(np.sqrt(d @ d + spread)), h, dim) < 0.0
    assert np.abs(single).max() < 1e-9 * abs(drag @ t)  # t . d is round-off


@pytest.mark.parametrize("method", ["weiler2018", "takahashi2015"])
def test_a_particle_without_neighbours_keeps_no_stale_warm_start(method: str) -> None:
    """A particle with no neighbour feels no viscosity, whatever the last step's velocity change
    (the implicit solves' warm start) was. In a uniform flow (no viscous force anywhere) the
    warm start of the whole system passes the CG's test on the relative residual of all rows at
    once with no iteration (SPlisHSPlasH's loose 7.5 % and two iterations), so a stale change of
    one lone particle was applied again in every step: a constant acceleration, 400-500 m/s^2 in
    SPlisHSPlasH's ReadWriteStateTest with density maps. Exact: a zero acceleration there, and
    none in the uniform block (Weiler 2018 with no wall viscosity; Takahashi 2015 warm-starts
    the same way and has the same guard; here its walls' friction makes its CG iterate, so its
    case passed before the guard too.)"""
    sim = _sim(method, 0.01, 0.0, False, max_error=0.075, max_iterations=2)
    f = sim.fluid
    f["x"][:, 0] = [2.0, 2.0, 2.0]  # far from the block and the box
    sim._neighbors()  # (which may reorder the particles)
    sim.compute_density()
    lone = int(np.argmax(f["x"][0]))
    f["v"][...] = 0.0
    f["v"][0, :] = 0.1  # a uniform flow
    dv = f["weiler_dv" if method == "weiler2018" else "takahashi_dv"]
    dv[...] = 0.0
    dv[:, lone] = [0.05, 0.0, 0.0]  # the lone particle's stale change of a step with neighbours
    f["a"][...] = 0.0
    force = sim.forces[0]
    force.apply(sim.state, 1e-3)
    assert np.array_equal(f["a"][:, lone], np.zeros(3))
    if method == "weiler2018":  # (Takahashi's walls add their XSPH-type friction to the block)
        assert np.abs(f["a"]).max() < 1e-9  # the uniform block: no viscous force either
