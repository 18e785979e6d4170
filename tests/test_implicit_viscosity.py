"""Implicit viscosity models of Bender & Koschier 2017, Takahashi et al. 2015, Peer et al. 2015 and
Peer & Teschner 2016: Galilean invariance, momentum, rigid rotation, the decay of shear flows
against what each model prescribes, stability of a very viscous 3D block at the CFL step, and the
SPlisHSPlasH scene mapping. (Weiler et al. 2018 has its own tests/test_weiler2018.py.)"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from sphkit.core.kernels import Kernel
from sphkit.scene.files import scene_from_dict
from sphkit.scene.schema import Scene, SceneError
from sphkit.simulation import Simulation

#: each model with a strong coefficient: kinematic [m^2/s] for takahashi2015, a dimensionless
#: factor for the others
MODELS = {"bender2017": 0.5, "takahashi2015": 0.05, "peer2015": 0.5, "peer2016": 0.5}


def _block(method: str, coeff: float, dim: int = 2, periodic: bool = False, n: int = 0,
           **vis) -> Simulation:
    """A free block (no walls, no gravity): 20 x 20 particles of r = 1 cm in 2D (periodic in x
    with period 0.4 m if asked), 10^3 of r = 2 cm in 3D (or n per side); neighbours and
    densities computed."""
    r, n = (0.01, n or 20) if dim == 2 else (0.02, n or 10)
    side = 2 * r * n
    cfg = {"dim": dim, "particle_radius": r, "gravity": [0.0] * dim}
    if periodic:
        cfg["periodic_x"] = [0.0, side]
    sc = {"configuration": cfg, "fluid_blocks": [{"start": [0.0] * dim, "end": [side] * dim}],
          "materials": [{"viscosity": {"method": method, "coefficient": coeff, **vis}}]}
    sim = Simulation(Scene.model_validate(sc))
    sim._neighbors()
    sim.compute_density()
    return sim


def _step(sim: Simulation, v: np.ndarray, dt: float) -> np.ndarray:
    """The velocities after the viscosity model alone: v + dt a_visc."""
    f = sim.fluid
    f["v"][...] = v
    f["a"][...] = 0.0
    sim.forces[0].apply(sim.state, dt)
    return v + dt * f["a"]


def _kinetic(sim: Simulation, v: np.ndarray) -> float:
    """Kinetic energy of the motion relative to the centre of mass (times 2)."""
    m = sim.fluid["m"]
    w = v - (m * v).sum(axis=1, keepdims=True) / m.sum()
    return float((m * (w * w).sum(axis=0)).sum())


@pytest.mark.parametrize("method", list(MODELS))
@pytest.mark.parametrize("dim", [2, 3])
def test_uniform_velocity_is_unchanged(method: str, dim: int) -> None:
    """Galilean invariance: every model acts on velocity differences (strain rate, stress,
    gradient targets), so a uniform velocity gets exactly zero change (to round-off: 1e-12 of
    |v|/dt). For the Peer models the right-hand side vanishes and the solve keeps its start."""
    sim = _block(method, MODELS[method], dim)
    u = np.array([0.3, -0.2, 0.1][:dim])[:, None] * np.ones((dim, sim.fluid.n))
    dt = 0.01
    assert np.abs(_step(sim, u, dt) - u).max() < 1e-12 * 0.3


@pytest.mark.parametrize("method", ["bender2017", "takahashi2015"])
def test_pairwise_models_conserve_momentum(method: str) -> None:
    """Random velocities on a free 2D block. Bender 2017's impulses are pairwise opposite (equal
    masses), so momentum is kept to round-off after any number of iterations (1e-12 of
    sum m |v|). Takahashi's pair forces m_i m_j (S_i/rho_i^2 + S_j/rho_j^2) grad W_ij are
    antisymmetric: the momentum error is the solver's residual, 1e-8 of sum m |v| at a
    tolerance of 1e-10."""
    vis = {} if method == "bender2017" else {"max_error": 1e-10, "max_iterations": 2000}
    sim = _block(method, MODELS[method], **vis)
    m = sim.fluid["m"]
    v0 = np.random.default_rng(1).normal(0.0, 0.5, sim.fluid["v"].shape)
    v1 = _step(sim, v0, 0.01)
    scale = float((m * np.abs(v0).sum(axis=0)).sum())
    tol = 1e-12 if method == "bender2017" else 1e-8
    assert np.abs((m * (v1 - v0)).sum(axis=1)).max() < tol * scale
    assert _kinetic(sim, v1) < _kinetic(sim, v0)


@pytest.mark.parametrize("method", ["peer2015", "peer2016"])
def test_peer_reconstruction_keeps_the_density_weighted_mean(method: str) -> None:
    """Peer's reconstruction system fixes the velocities only up to a constant per component
    (without walls the kernel-sum matrix annihilates constants), and Jacobi-preconditioned CG
    keeps sum_i d_i v_i of its start, d_i = rho_i - m_i W(0) the density without the self term
    (here from the simulation's density pass, 1e-9 of sum d |v| at a tolerance of 1e-12). So
    momentum is kept only where d_i is uniform: with the free surface of this block the
    momentum changes by about 0.1 % of sum m |v| for random velocities (measured 0.05 % and
    0.13 %; bound 0.5 %), a property of the method, not a solver error."""
    vis = {"max_error": 1e-12, "max_iterations": 2000}
    if method == "peer2016":
        vis.update(max_error_omega=1e-12, max_iterations_omega=2000)
    sim = _block(method, MODELS[method], **vis)
    f = sim.fluid
    m = f["m"]
    d = f["rho"] - m * Kernel("cubic", sim.state.h, 2).w(np.zeros(1))[0]
    v0 = np.random.default_rng(1).normal(0.0, 0.5, f["v"].shape)
    v1 = _step(sim, v0, 0.01)
    assert sim.forces[0].stats.converged
    assert np.abs((d * (v1 - v0)).sum(axis=1)).max() < 1e-9 * float((d * np.abs(v0)).sum())
    scale = float((m * np.abs(v0).sum(axis=0)).sum())
    assert np.abs((m * (v1 - v0)).sum(axis=1)).max() < 0.005 * scale
    assert _kinetic(sim, v1) < _kinetic(sim, v0)


@pytest.mark.parametrize("method", list(MODELS))
def test_rigid_rotation_is_hardly_damped(method: str) -> None:
    """All four models claim to leave rigid rotation alone: its strain rate and stress vanish
    (Bender, Takahashi), its spin is kept (Peer 2015) or its uniform vorticity is a fixed point
    of the diffusion (Peer 2016). In SPH this holds where the neighbourhood is full; at the free
    surface the kernel sums are one-sided and the rotation shows a spurious strain rate. So one
    step removes at most 5 % of the energy that the same step removes from a simple shear flow
    of equal kinetic energy (measured: Bender 0.04 %, Takahashi 1.9 %, Peer 2015 and 2016
    0.8 %)."""
    sim = _block(method, MODELS[method])
    x = sim.fluid["x"]
    xc = x - x.mean(axis=1, keepdims=True)
    rot = np.vstack([-xc[1], xc[0]])
    shear = np.vstack([xc[1], np.zeros_like(xc[1])])
    shear *= np.sqrt(_kinetic(sim, rot) / _kinetic(sim, shear))
    dt = 0.005
    lost_rot = _kinetic(sim, rot) - _kinetic(sim, _step(sim, rot, dt))
    lost_shear = _kinetic(sim, shear) - _kinetic(sim, _step(sim, shear, dt))
    assert lost_shear > 0.0
    assert lost_rot < 0.05 * lost_shear


def _wave(method: str, coeff: float, transverse: bool, dt: float, **vis) -> tuple[float, float]:
    """One step of a sine wave along the periodic x axis (k = 2 pi / 0.4 m) on the 2D block:
    transverse u_y = sin(k x) (a shear wave) or longitudinal u_x = sin(k x). Returns the
    amplitude of the wave in the rows farther than 1.5 h from the free surfaces (least squares
    on sin(k x)) and the kinetic-energy ratio after/before."""
    sim = _block(method, coeff, periodic=True, **vis)
    x = sim.fluid["x"]
    k = 2.0 * np.pi / 0.4
    c = 1 if transverse else 0
    v = np.zeros_like(x)
    v[c] = np.sin(k * x[0])
    v1 = _step(sim, v, dt)
    h = sim.state.h
    mid = (x[1] > 1.5 * h) & (x[1] < 0.4 - 1.5 * h)
    s = np.sin(k * x[0, mid])
    return float((v1[c, mid] * s).sum() / (s * s).sum()), _kinetic(sim, v1) / _kinetic(sim, v)


def test_takahashi_waves_decay_like_backward_euler() -> None:
    """Takahashi's operator is div(mu (grad v + grad v^T)) / rho: a shear wave u_y = sin(k x)
    decays by 1 / (1 + nu k^2 dt) per backward-Euler step, a longitudinal wave u_x = sin(k x) by
    1 / (1 + 2 nu k^2 dt). The longitudinal wave is traction free at the free surfaces and
    matches to 1 % (measured 0.3 % at nu k^2 dt = 1); the shear wave is not (its stress pulls at
    the surfaces), and the SPH gradient at k h = 0.63 is smoothed, so it matches to 3 % at
    nu k^2 dt = 0.25 (measured 1.3 %)."""
    nu, k2 = 0.01, (2.0 * np.pi / 0.4) ** 2
    vis = {"max_error": 1e-10, "max_iterations": 2000}
    amp, ke = _wave("takahashi2015", nu, True, 0.25 / (nu * k2), **vis)
    assert amp == pytest.approx(1.0 / 1.25, rel=0.03)
    assert ke < 1.0
    amp, ke = _wave("takahashi2015", nu, False, 1.0 / (nu * k2), **vis)
    assert amp == pytest.approx(1.0 / 3.0, rel=0.01)
    assert ke < 1.0


def test_bender_shear_wave_reaches_its_target_strain_rate() -> None:
    """Bender 2017 prescribes the strain rate (1 - nu) E(v*). Iterated to convergence, the shear
    wave's amplitude is exactly 1 - nu = 0.5 (1e-6; measured 4e-14: the plane shear wave lies in
    the range of the constraints). With SPlisHSPlasH's defaults (50 iterations, 0.01 1/s) the
    Jacobi iteration, relaxed by the particle mass (capped at 0.2), gets part of the way:
    the amplitude lies between 0.5 and 0.9 (measured 0.61) and the energy drops."""
    amp, ke = _wave("bender2017", 0.5, True, 0.01, max_error=1e-12, max_iterations=3000)
    assert amp == pytest.approx(0.5, abs=1e-6)
    amp, ke = _wave("bender2017", 0.5, True, 0.01)
    assert 0.5 < amp < 0.9 and ke < 1.0


@pytest.mark.parametrize("method", ["peer2015", "peer2016"])
def test_peer_shear_wave_loses_its_prescribed_share(method: str) -> None:
    """A shear wave u_y = sin(k x) has the gradient du_y/dx = k cos(k x), half spin and half
    shear. Peer 2015 keeps the spin and scales the shear by xi = 1 - nu, so the reconstructed
    wave has the amplitude (1 + xi) / 2 = 0.75; Peer 2016 also relaxes the vorticity (of zero
    mean) by xi, so the amplitude is xi = 0.5, within 3 % (measured 1.3 %: the reconstruction
    averages the Taylor expansion over the kernel support, and the interior rows see the
    surfaces' one-sided sums). Nothing in the models depends on dt (the survey: they damp per
    step), so 1 ms and 10 ms steps give the same amplitude (1e-9)."""
    vis = {"max_error": 1e-10, "max_iterations": 500}
    if method == "peer2016":
        vis.update(max_error_omega=1e-10, max_iterations_omega=500)
    expected = 0.75 if method == "peer2015" else 0.5
    amps = []
    for dt in (0.001, 0.01):
        amp, ke = _wave(method, 0.5, True, dt, **vis)
        assert amp == pytest.approx(expected, rel=0.03)
        assert ke < 1.0
        amps.append(amp)
    assert amps[0] == pytest.approx(amps[1], abs=1e-9)


def test_takahashi_preconditioner_blocks_are_the_matrix_diagonal() -> None:
    """The block-Jacobi preconditioner's dim x dim blocks, derived by hand in the module, equal
    the diagonal blocks of the matrix-free operator I - dt a, read column by column from
    matvecs on unit vectors (uniform density, where the matrix is symmetric: 1e-12). The matrix
    is symmetric positive definite there, its smallest eigenvalue 1 (the rigid motions).
    A 2D block of 8 x 8 particles (interior, edge and corner neighbourhoods)."""
    sim = _block("takahashi2015", 0.05, n=8)
    st = sim.state
    sim.fluid["rho"][:] = st.rho0
    force = sim.forces[0]
    n, dim, dt = sim.fluid.n, 2, 0.01
    matvec = force.operator(st, dt)
    blocks = force.diagonal_blocks(st, dt)
    e, out = np.zeros(dim * n), np.zeros(dim * n)
    A = np.zeros((dim * n, dim * n))
    for c in range(dim * n):
        e[:] = 0.0
        e[c] = 1.0
        matvec(e, out)
        A[:, c] = out
    for i in range(n):
        diag = A[i::n, i::n]  # rows and columns (d * n + i) of particle i
        assert np.abs(diag - blocks[:, :, i]).max() < 1e-12
    assert np.abs(A - A.T).max() < 1e-12
    assert np.linalg.eigvalsh(A).min() > 1.0 - 1e-9


def _viscous_block(method: str, coeff: float) -> Simulation:
    """tests/test_weiler2018.py's 3D block dropped 2 cm onto the floor of a box, DFSPH, CFL step
    capped at 5 ms, where the explicit standard viscosity at nu = 0.1 m^2/s (100 Pa s) raises
    InstabilityError (its stability limit is about 0.5 ms; that test shows it)."""
    sc = {"configuration": {"dim": 3, "particle_radius": 0.01,
                            "pressure": {"method": "dfsph", "max_error": 0.05},
                            "time": {"dt_max": 0.005}, "max_velocity": 10.0},
          "fluid_blocks": [{"start": [0.04, 0.02, 0.04], "end": [0.16, 0.14, 0.16]}],
          "boxes": [{"min": [0.0, 0.0, 0.0], "max": [0.2, 0.3, 0.2], "layers": 2}],
          "materials": [{"viscosity": {"method": method, "coefficient": coeff}}]}
    return Simulation(Scene.model_validate(sc))


@pytest.mark.parametrize("method,coeff", [("takahashi2015", 0.1), ("bender2017", 1.0),
                                          ("peer2015", 1.0), ("peer2016", 1.0)])
def test_very_viscous_block_is_stable_at_the_cfl_step(method: str, coeff: float,
                                                      caplog: pytest.LogCaptureFixture) -> None:
    """Takahashi at 100 Pa s (nu = 0.1 m^2/s) and the factor models at their strongest setting
    (1: remove all strain rate / shear each step) run 0.2 s at the 5 ms steps that blow the
    explicit viscosity up: the speed stays below 1 m/s (free fall from 2 cm reaches 0.63 m/s),
    no particle gets through the floor (its first wall layer lies at y = -r = -1 cm; Bender's
    weak relaxation at these 8 g particles lets a corner particle splash to y = -0.6 mm), and
    each step after the first reports its viscosity iterations."""
    sim = _viscous_block(method, coeff)
    vmax, its = 0.0, []
    with caplog.at_level(logging.WARNING, logger="sphkit"):
        while sim.time < 0.2:
            s = sim.step()
            vmax = max(vmax, s.max_velocity)
            its.append(s.viscosity_iterations)
    assert s.dt == pytest.approx(0.005)
    assert min(its[1:]) >= 1  # the first step starts at rest: nothing to solve
    assert vmax < 1.0
    assert sim.fluid["x"][1].min() > -0.01


def test_splishsplash_materials_map_to_the_implicit_models() -> None:
    """viscosityMethod 2-5 with their blocks (values of the shipped BucklingModel_* and
    CoilingModel_* scenes) map field by field; absent keys take the defaults read back from
    pysplishsplash 2.19 (viscosity 0.01, viscoMaxIter 50 for 2-4 and 100 for 5, viscoMaxError
    0.01, Peer 2016's omega solve 50 / 0.01); bad values name their SPlisHSPlasH field."""
    base = {"Configuration": {"particleRadius": 0.025, "simulationMethod": 4},
            "FluidBlocks": [{"start": [0, 0, 0], "end": [0.5, 0.5, 0.5]}]}

    def vis(vm: int, block: dict | None):
        mat = {"id": "Fluid", "viscosityMethod": vm}
        if block is not None:
            mat.update(block)
        return scene_from_dict(dict(base, Materials=[mat])).materials[0].viscosity

    v = vis(2, {"Bender and Koschier 2017": {"viscosity": 0.6, "viscoMaxIter": 200,
                                             "viscoMaxError": 0.05}})
    assert (v.method, v.coefficient, v.max_iterations, v.max_error) == ("bender2017", 0.6, 200,
                                                                        0.05)
    v = vis(3, {"Peer et al. 2015": {"viscosity": 0.05, "viscoMaxIter": 200,
                                     "viscoMaxError": 0.08}})
    assert (v.method, v.coefficient, v.max_iterations, v.max_error) == ("peer2015", 0.05, 200,
                                                                        0.08)
    v = vis(4, {"Peer et al. 2016": {"viscosity": 0.05, "viscoMaxIter": 200,
                                     "viscoMaxError": 0.08, "viscoMaxIterOmega": 150,
                                     "viscoMaxErrorOmega": 0.02}})
    assert (v.method, v.coefficient, v.max_iterations, v.max_error, v.max_iterations_omega,
            v.max_error_omega) == ("peer2016", 0.05, 200, 0.08, 150, 0.02)
    v = vis(5, {"Takahashi et al. 2015 (improved)": {"viscosity": 20, "viscoMaxIter": 200,
                                                     "viscoMaxError": 0.05}})
    assert (v.method, v.coefficient, v.max_iterations, v.max_error) == ("takahashi2015", 20.0,
                                                                        200, 0.05)
    for vm, its in ((2, 50), (3, 50), (4, 50), (5, 100)):
        v = vis(vm, None)
        assert (v.coefficient, v.max_iterations, v.max_error) == (0.01, its, 0.01)
    assert (v.boundary_coefficient, vis(4, None).max_iterations_omega) == (0.0, 50)
    sim = Simulation(scene_from_dict(dict(base, Materials=[{"viscosityMethod": 4}])))
    force = sim.forces[0]
    assert (force.nu, force.max_iterations, force.max_iterations_omega) == (0.01, 50, 50)
    # Bender's maxError is a strain rate [1/s] and may exceed 1; the CG tolerances may not
    assert vis(2, {"Bender and Koschier 2017": {"viscoMaxError": 2.0}}).max_error == 2.0
    with pytest.raises(SceneError, match=r"Takahashi et al\. 2015 \(improved\)\.viscoMaxError"):
        vis(5, {"Takahashi et al. 2015 (improved)": {"viscoMaxError": 2.0}})
    with pytest.raises(SceneError, match=r"Bender and Koschier 2017\.viscosity: got 1\.5: "
                                         r"expected a dimensionless factor in \[0, 1\]"):
        vis(2, {"Bender and Koschier 2017": {"viscosity": 1.5}})
    with pytest.raises(SceneError, match=r"Peer et al\. 2016\.viscoMaxIterOmega: got 0"):
        vis(4, {"Peer et al. 2016": {"viscoMaxIterOmega": 0}})
    with pytest.warns(UserWarning, match=r"Peer et al\. 2015\.viscosityBoundary"):
        vis(3, {"Peer et al. 2015": {"viscosityBoundary": 1.0}})


@pytest.mark.parametrize("vis,expected", [
    ({"method": "peer2015", "coefficient": 1.5}, r"dimensionless factor; expected a value in"),
    ({"method": "takahashi2015", "coefficient": 0.1, "boundary_coefficient": 0.1},
     r"takahashi2015 has no separate boundary viscosity"),
    ({"method": "takahashi2015", "coefficient": 0.1, "max_error": 1.5},
     r"relative residual of its linear solve; expected a value in \(0, 1\)"),
])
def test_scene_rejects_bad_viscosity_values(vis: dict, expected: str) -> None:
    """sphkit's own scene format: a factor above 1, a wall coefficient for a model without one,
    a relative tolerance of 1 or more are refused with the field and the expectation."""
    with pytest.raises(ValueError, match=expected):
        Scene.model_validate({"materials": [{"viscosity": vis}]})
