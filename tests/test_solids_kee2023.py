"""Kee et al. 2023 (elasticityMethod 4): hyperelastic SPH solid, backward Euler as a
minimisation. Conservation (forces and a spinning bar), the release wave of a stretched bar, a
cantilever's static sag against Euler-Bernoulli, kinematic pinned particles and the
SPlisHSPlasH translation of ``Beam_Kee23_validation.json``."""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest
from _restart import continued_from_checkpoint

from sphkit.scene.schema import Scene, SceneError
from sphkit.simulation import Simulation

E, NU, RHO = 1e5, 0.3, 1000.0


def _solid(end: list[float], r: float = 0.01, dt: float = 1e-3, gravity: float = 0.0,
           fixed: list | None = None, **el: object) -> Simulation:
    """A block of one kee2023 material from the origin to ``end``, no pressure (WCSPH with
    stiffness 0, as SPlisHSPlasH's Beam scenes), fixed time step."""
    dim = len(end)
    g = [0.0] * dim
    g[1] = -gravity
    elasticity = {"method": "kee2023", "youngs_modulus": E, "poisson_ratio": NU,
                  "fixed_boxes": fixed or [], **el}
    return Simulation(Scene.model_validate({
        "configuration": {"dim": dim, "particle_radius": r, "gravity": g,
                          "pressure": {"method": "wcsph", "stiffness": 0.0},
                          "time": {"cfl": False, "dt": dt}},
        "materials": [{"density0": RHO, "elasticity": elasticity}],
        "fluid_blocks": [{"start": [0.0] * dim, "end": end}]}))


@pytest.mark.parametrize("model", ["corotated", "stable_neo_hookean"])
@pytest.mark.parametrize("dim", [2, 3])
def test_kee2023_forces_are_free_of_net_force_and_torque(model: str, dim: int) -> None:
    """At a deformed state (stretched, noisy, turned by 0.7 rad about an oblique axis) the
    elastic and zero-energy-mode forces sum to zero and have no torque, to round-off (1e-12 of
    ``sum |f|`` and ``max|x| sum |f|``): the energy depends on the positions only through
    ``F_i`` (which turns with the body, the gradient weights being exact for linear fields)
    and the rotation-invariant zero-energy term, and the force is its gradient on symmetric
    rest lists -- the conservation Kee et al. 2023 claim for their discretisation."""
    end = [0.08, 0.05, 0.04][:dim]
    sim = _solid(end, material_model=model, alpha=0.5)
    sim.step()
    s = sim.solids[0]
    rest = s.rest
    rng = np.random.default_rng(1)
    x = rest.x0.copy()
    x[:dim] *= np.array([1.03, 0.98, 0.99])[:dim, None]
    x[:dim] += 2e-4 * rng.standard_normal((dim, rest.n))
    axis = np.array([1.0, 2.0, 3.0]) / math.sqrt(14.0) if dim == 3 else np.array([0, 0, 1.0])
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    Q = np.eye(3) + math.sin(0.7) * K + (1 - math.cos(0.7)) * K @ K
    x = Q @ x + 0.3
    _, g = s._energy(x, x, 1.0, False, True)  # grad E at dt = 1, x~ = x: -f + Z x
    scale = np.abs(g).sum()
    assert scale > 0
    assert np.abs(g.sum(axis=1)).max() < 1e-12 * scale
    torque = np.cross(x.T, g.T).sum(axis=0)
    assert np.abs(torque).max() < 1e-12 * np.abs(x).max() * scale, torque


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The z-component of ``a x b`` for (2, n) arrays."""
    return a[0] * b[1] - a[1] * b[0]


@pytest.mark.parametrize("solver", ["lbfgs", "newton"])
def test_kee2023_spinning_bar_keeps_momentum(solver: str) -> None:
    """A 2D bar (40 x 8 particles, alpha 0.1) stretched by 2 %, turned by 0.7 rad, spinning at
    2 rad/s and drifting, in zero gravity, 15 steps of 1 ms:

    * linear momentum stays to 1e-12 of ``sum m |v|`` (measured 1e-14): the elastic forces sum
      to zero at any state (previous test), and each iterate keeps ``sum m (x - x~) = 0``
      (L-BFGS: its initial Hessian's columns and the secant pairs conserve it; Newton: the
      block-Jacobi CG is not bound to it, and keeps it to round-off here);
    * angular momentum changes each step by backward Euler's own ``dt sum m v' x v`` and by
      nothing else, to 1e-6 of L: at the minimiser ``m (x' - x~) = dt^2 f(x')`` with
      torque-free forces gives ``L' - L = dt sum m v' x v`` exactly (backward Euler is not
      angular-momentum preserving; the forces are); the minimisation stops when no particle
      moves by more than 1e-10 m, which leaves an error of about
      ``1e-10 m / (dt |v|) = 1e-6`` relative."""
    sim = _solid([0.4, 0.08], solver=solver, alpha=0.1, max_position_change=1e-10)
    f = sim.fluid
    x, m = f["x"], f["m"]
    c = x.mean(axis=1, keepdims=True)
    th = 0.7
    R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    x[...] = R @ ((x - c) * np.array([[1.02], [0.99]])) + c
    f["v"][0] = -2.0 * (x[1] - c[1]) + 0.1
    f["v"][1] = 2.0 * (x[0] - c[0]) + 0.05

    def state() -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        o = np.argsort(f["id"])  # the set is reordered with the neighbour search
        xs, vs, ms = f["x"][:, o], f["v"][:, o], f["m"][o]
        return vs.copy(), ms, (ms * vs).sum(axis=1), float((ms * _cross(xs, vs)).sum())

    v0, _, p_start, l_start = state()
    scale = (m * np.linalg.norm(f["v"], axis=0)).sum()
    for _ in range(15):
        v_old, _, _, l_old = state()
        sim.step()
        v_new, ms, p, ang = state()
        euler = sim.dt * float((ms * _cross(v_new, v_old)).sum())
        assert abs(ang - l_old - euler) < 1e-6 * abs(l_start), (ang - l_old, euler)
    assert np.abs(p - p_start).max() < 1e-12 * scale
    assert f["solid_stress"].max() > 0.0


@pytest.mark.parametrize("model", ["corotated", "stable_neo_hookean"])
def test_kee2023_stretched_bar_springs_back_at_the_bar_wave_speed(model: str) -> None:
    """A free 2D bar (L = 0.4 m, 4 particles thick, zero gravity) released from a uniform 1 %
    stretch: the release waves from both ends meet in the middle at ``t = L / (2 c)``, ``c =
    sqrt(E / (rho (1 - nu^2)))`` (a thin plane-strain strip), where the length passes its rest
    value; it then overshoots into compression (an elastic spring-back, not a creep). The
    crossing must be within 10 % of ``L / (2 c)`` = 19.1 ms (measured: 0.995 of it): backward
    Euler's period error at ``omega dt = 0.08`` is 0.3 %, the time is read at 1 ms steps
    (5 %), and the discretisation's stiffness error at 4 layers is a few percent. The stable
    neo-Hookean energy must give the same speed: with Smith et al.'s remapped Lamé parameters
    its small-strain moduli are E and nu's (without the remap, as in SPlisHSPlasH, the strip's
    modulus is 0.72 of ``E / (1 - nu^2)`` and the crossing 18 % late)."""
    L, eps = 0.4, 0.01
    sim = _solid([L, 0.04], dt=1e-3, material_model=model)
    f = sim.fluid
    x0 = f["solid_x0"]
    c0 = x0.mean(axis=1, keepdims=True)
    f["x"][0] = c0[0] + (1 + eps) * (x0[0] - c0[0])
    left, right = x0[0] < 0.02, x0[0] > L - 0.02

    def strain() -> float:
        xs, x0s = f["x"][0], f["solid_x0"][0]
        lo, hi = x0s < 0.02, x0s > L - 0.02
        return (xs[hi].mean() - xs[lo].mean()) / (x0s[hi].mean() - x0s[lo].mean()) - 1.0

    assert left.any() and right.any()
    ts, es = [0.0], [strain()]
    for _ in range(40):
        sim.step()
        ts.append(sim.time)
        es.append(strain())
    es_a = np.array(es)
    k = int(np.flatnonzero(es_a <= 0.0)[0])
    t_cross = ts[k - 1] + es_a[k - 1] / (es_a[k - 1] - es_a[k]) * (ts[k] - ts[k - 1])
    c = math.sqrt(E / (RHO * (1 - NU * NU)))
    assert abs(t_cross / (L / (2 * c)) - 1.0) < 0.1, t_cross / (L / (2 * c))
    assert es_a.min() < -0.5 * eps
    assert es_a.max() <= eps * (1 + 1e-9)


def test_kee2023_cantilever_sags_like_euler_bernoulli() -> None:
    """A 2D plate (L = 0.2 m free, H = 0.02 m, 4 particles thick, E 2e7 Pa, nu 0.3) clamped
    by a fixed box over the particles behind x = 0, under gravity, stepped with 50 ms
    (backward Euler damps the first mode, omega_1 = 76 rad/s, by a factor 0.25 a step: six
    steps reach the static state to 1e-3; L-BFGS, whose initial Hessian is far from a bent
    beam's, takes its 100 iterations a step): the tip sags downwards by Euler-Bernoulli's
    ``w = 1.5 rho g L^4 / (E' H^2)`` (plane strain: ``E' = E / (1 - nu^2)``; 2.6 mm) within
    [-5 %, +35 %]: at 4 layers the known, all positive parts are the clamp (an effective
    clamp about 2.3 r behind x = 0: +11.5 %), the midpoint rule's second moment (+6.7 %) and
    shear (Timoshenko +1 %) -- validation/README.md, "Elastic cantilevers", where becker2009
    sags +18 % in 3D at 4 layers; measured here +19.3 %."""
    L, H, r = 0.2, 0.02, 0.0025
    e_mod = 2e7
    sim = Simulation(Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -9.81],
                          "pressure": {"method": "wcsph", "stiffness": 0.0},
                          "time": {"cfl": False, "dt": 0.05}},
        "materials": [{"density0": RHO, "elasticity": {
            "method": "kee2023", "youngs_modulus": e_mod, "poisson_ratio": NU,
            "fixed_boxes": [{"min": [-1, -1], "max": [0.0, 1]}]}}],
        "fluid_blocks": [{"start": [-6 * r, -H / 2], "end": [L, H / 2]}]}))
    f = sim.fluid
    for _ in range(6):
        sim.step()
    x0 = f["solid_x0"]
    tip = x0[0] > L - 2 * r
    w = float(np.mean(x0[1, tip] - f["x"][1, tip]))
    w_eb = 1.5 * RHO * 9.81 * L ** 4 * (1 - NU * NU) / (e_mod * H * H)
    assert -0.05 < w / w_eb - 1.0 < 0.35, w / w_eb
    assert np.abs(f["v"]).max() < 1e-4  # static (1e-2 of the sag per step)


def test_kee2023_pinned_particles_move_with_their_velocity() -> None:
    """Pinned particles are kinematic (as SPlisHSPlasH's Fixed particles, which its twisted
    beam turns with an animation field): at rest they stay exactly at rest; given a velocity
    (what an animation field writes) they move by ``dt v`` a step, keep it, and drag the free
    particles along."""
    sim = _solid([0.2, 0.04], fixed=[{"min": [-1, -1], "max": [0.03, 1]}])
    f = sim.fluid
    pinned = f["solid_fixed"] == 1
    assert pinned.sum() > 0
    for _ in range(3):
        sim.step()
    pinned = f["solid_fixed"] == 1
    np.testing.assert_array_equal(f["x"][:, pinned], f["solid_x0"][:, pinned])
    assert not f["v"][:, pinned].any()
    f["v"][1, pinned] = 0.1
    for _ in range(5):
        sim.step()
    pinned = f["solid_fixed"] == 1
    np.testing.assert_allclose(f["x"][1, pinned] - f["solid_x0"][1, pinned], 5e-4, atol=1e-15)
    np.testing.assert_allclose(f["v"][1, pinned], 0.1)
    assert f["x"][1, ~pinned].mean() > f["solid_x0"][1, ~pinned].mean()


def test_kee2023_splishsplash_scene_translates(tmp_path) -> None:
    """``Beam_Kee23_validation.json`` loads unchanged: the "Kee et al. 2023" block becomes
    kee2023 with its E, nu, alpha, maxNeighbors, both fixed boxes, solverType 0 (Newton),
    materialType 0 (stable neo-Hookean), maxError (a position change [m]), CG limits and no
    line search; an absent block takes SPlisHSPlasH's defaults (E 5e6, nu 0.45, L-BFGS,
    corotated, 1e-6 m, line search on), an all-zero second box is no box, and an unknown
    solverType is an error naming the field."""
    from sphkit.cli.compat import wheel_scene_folder
    from sphkit.scene.files import load_scene

    folder = wheel_scene_folder()
    if folder is None:
        pytest.skip("no pysplishsplash wheel")
    el = load_scene(os.path.join(folder, "Beam_Kee23_validation.json")).materials[0].elasticity
    assert (el.method, el.youngs_modulus, el.poisson_ratio, el.alpha, el.max_neighbors,
            el.solver, el.material_model, el.max_position_change, el.max_iterations,
            el.cg_max_iterations, el.cg_tolerance, el.line_search, el.lbfgs_window) == (
        "kee2023", 5e6, 0.45, 1.0, 15, "newton", "stable_neo_hookean", 1e-4, 100, 100, 1e-4,
        False, 5)
    assert [b.max[0] for b in el.fixed_boxes] == [-1.9, 10.0]
    scene = {"Configuration": {"particleRadius": 0.025},
             "Materials": [{"id": "Fluid", "elasticityMethod": 4, "Kee et al. 2023": {
                 "fixedBoxMin": [-1, -1, -1], "fixedBoxMax": [0, 1, 1],
                 "fixedBox2Min": [0, 0, 0], "fixedBox2Max": [0, 0, 0]}}],
             "FluidBlocks": [{"denseMode": 0, "start": [0, 0, 0], "end": [0.2, 0.1, 0.1]}]}
    path = tmp_path / "kee.json"
    path.write_text(json.dumps(scene))
    el = load_scene(str(path)).materials[0].elasticity
    assert (el.youngs_modulus, el.poisson_ratio, el.solver, el.material_model,
            el.max_position_change, el.line_search, len(el.fixed_boxes)) == (
        5e6, 0.45, "lbfgs", "corotated", 1e-6, True, 1)
    scene["Materials"][0]["Kee et al. 2023"]["solverType"] = 2
    path.write_text(json.dumps(scene))
    with pytest.raises(SceneError, match=r"Kee et al. 2023.solverType: got 2: expected 0 "
                                         r"\(newton\) or 1 \(lbfgs\)"):
        load_scene(str(path))


def test_kee2023_checkpoint_restores_bit_for_bit(tmp_path) -> None:
    """Everything kee2023 carries from step to step lives in particle fields (rest positions,
    slots, pinned flags, the pinned particles' velocities; the L-BFGS history starts afresh each
    step and the factorisation is rebuilt), so a run continued from a checkpoint repeats the
    uninterrupted one bit for bit, across z-order reorderings, with moving pinned particles."""
    sc = _solid([0.2, 0.04], gravity=9.81, fixed=[{"min": [-1, -1], "max": [0.03, 1]}],
                alpha=0.1).scene.model_copy(deep=True)
    sc.configuration.zsort_every = 3
    sim = Simulation(sc)
    f = sim.fluid
    f["v"][1, f["solid_fixed"] == 1] = 0.1
    for _ in range(4):
        sim.step()
    continued_from_checkpoint(sim, tmp_path, 4)
    a = sim.fluid
    pinned = a["solid_fixed"] == 1
    np.testing.assert_allclose(a["v"][1, pinned], 0.1)
