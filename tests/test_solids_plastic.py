"""Plasticity of the corotated solids (von Mises yield, linear isotropic hardening, radial
return; :mod:`sphkit.solids.plasticity`): the return mapping itself, a 2D cantilever that keeps
a permanent bend after its load is removed while the elastic one springs back, checkpoints of
the plastic state, and the scene fields' validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _restart import continued_from_checkpoint

from sphkit.scene.files import scene_from_dict
from sphkit.scene.schema import Scene, SceneError
from sphkit.simulation import Simulation
from sphkit.solids.corotation import lame
from sphkit.solids.plasticity import return_mapping, von_mises

E, NU, R, RHO = 1e6, 0.3, 0.01, 1000.0
LENGTH, THICK = 0.34, 0.06  # the bar from x = -0.04 (clamped: x <= 0) to 0.3, 3 particles thick


def _dt_explicit() -> float:
    mu, lam = lame(E, NU)
    return 0.4 * 2 * R / math.sqrt((lam + 2 * mu) / RHO)


def _bar(method: str = "becker2009", dt_factor: float = 1.0, **plastic: float) -> Simulation:
    """A 2D cantilever (17 x 3 particles) clamped at its left end, under gravity."""
    el = {"method": method, "youngs_modulus": E, "poisson_ratio": NU, "alpha": 0.1,
          "fixed_boxes": [{"min": [-1, -1], "max": [0.0, 1]}], **plastic}
    return Simulation(Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": R, "gravity": [0.0, -9.81],
                          "pressure": {"method": "wcsph", "stiffness": 0.0},
                          "time": {"cfl": False, "dt": dt_factor * _dt_explicit()}},
        "materials": [{"density0": RHO, "elasticity": el}],
        "fluid_blocks": [{"start": [-0.04, 0.0], "end": [LENGTH - 0.04, THICK]}]}))


def _load_and_unload(sim: Simulation) -> tuple[float, float]:
    """Gravity for 0.4 s, then none for 0.4 s, with the velocities damped at about twice the
    first-mode angular frequency (21 rad/s) after every step (near-critical damping: the bar
    settles within each phase; damping does not change a static state). The tip's mean
    deflection at the end of each phase [m]."""
    f = sim.fluid
    tip = f["solid_x0"][0] > f["solid_x0"][0].max() - 1e-9
    dt = sim.scene.configuration.time.dt
    out = []
    for phase in range(2):
        if phase:
            sim.state.gravity[:] = 0.0
        for _ in range(round(0.4 / dt)):
            sim.step()
            f["v"] *= math.exp(-43.0 * dt)
        assert np.isfinite(f["x"]).all()
        out.append(float(np.mean(f["solid_x0"][1, tip] - f["x"][1, tip])))
    return out[0], out[1]


def test_return_mapping_lands_on_the_hardened_yield_surface() -> None:
    """Random strains (3D, plane-strain-like and volumetric parts mixed) of a material with
    sigma_y = 1e4 Pa and H = 1e5 Pa, part of them below yield: below, nothing changes (plastic
    state and Hooke's stress); above, the von Mises stress after the return equals the grown
    yield stress ``sigma_y + H alpha`` to round-off (1e-9 relative), the plastic strain is
    deviatoric, its increment is parallel to the trial deviatoric stress (radial return), and
    a second return of the same strain changes nothing (the returned state is admissible)."""
    rng = np.random.default_rng(3)
    mu, lam = lame(E, NU)
    ys, hard = 1e4, 1e5
    n = 400
    eps = rng.normal(scale=1e-2, size=(6, n)) * rng.uniform(0.0, 1.0, n)
    ep = np.zeros((3, n))
    ep_s = np.zeros((3, n))
    alpha = np.zeros(n)
    sigma = np.zeros((6, n))
    # the elastic (trial) stresses
    tr = eps[:3].sum(axis=0)
    trial = np.concatenate([2 * mu * eps[:3] + lam * tr, 2 * mu * eps[3:]])
    return_mapping(eps, ep, ep_s, alpha, mu, lam, ys, hard, sigma)
    below = von_mises(trial) <= ys
    assert 20 < below.sum() < n - 20
    np.testing.assert_array_equal(alpha[below], 0.0)
    np.testing.assert_array_equal(ep[:, below], 0.0)
    np.testing.assert_allclose(sigma[:, below], trial[:, below], rtol=1e-12, atol=1e-9)
    above = ~below
    np.testing.assert_allclose(von_mises(sigma[:, above]), ys + hard * alpha[above], rtol=1e-9)
    assert (alpha[above] > 0).all()
    np.testing.assert_allclose(ep.sum(axis=0), 0.0, atol=1e-15)
    # radial: eps_p parallel to the trial deviator
    dev = trial.copy()
    dev[:3] -= trial[:3].mean(axis=0)
    cos = ((ep * dev[:3]).sum(axis=0) + 2 * (ep_s * dev[3:]).sum(axis=0))[above] / (
        np.sqrt((ep ** 2).sum(axis=0) + 2 * (ep_s ** 2).sum(axis=0))
        * np.sqrt((dev[:3] ** 2).sum(axis=0) + 2 * (dev[3:] ** 2).sum(axis=0)))[above]
    np.testing.assert_allclose(cos, 1.0, rtol=1e-9)
    state = (ep.copy(), ep_s.copy(), alpha.copy())
    again = np.zeros_like(sigma)
    return_mapping(eps, ep, ep_s, alpha, mu, lam, ys, hard, again)
    for a, b in zip((ep, ep_s, alpha), state, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(again, sigma, rtol=1e-9, atol=1e-6)


def test_plastic_bar_stays_bent_and_elastic_bar_springs_back() -> None:
    """becker2009 cantilever (17 x 3 particles, E 1 MPa): under its weight it sags 4.1 cm
    elastic (root von Mises stress 31 kPa); with sigma_y = 20 kPa, H = 100 kPa the root
    yields and it sags further; once gravity is off, the elastic bar springs back to within
    1 % of its length (0.3 % measured: the residual is the damped settling, not a set), the
    plastic one keeps a permanent deflection of more than 2 % of its length (3.5 % measured:
    11.9 mm of 46.6 mm loaded) and a fifth of its loaded sag."""
    loaded_e, left_e = _load_and_unload(_bar())
    loaded_p, left_p = _load_and_unload(_bar(yield_stress=2e4, hardening=1e5))
    assert loaded_e > 0.03
    assert abs(left_e) < 0.01 * LENGTH, left_e
    assert loaded_p > loaded_e
    assert left_p > 0.02 * LENGTH and left_p > 0.2 * loaded_p, (loaded_p, left_p)


@pytest.mark.parametrize("method", ["peer2018", "kugelstadt2021"])
def test_implicit_plastic_bar_stays_bent(method: str) -> None:
    """The implicit models (8 times the explicit step) hold the plastic strain of the return
    at the step's start in their solve: the same plastic cantilever keeps a permanent
    deflection of more than 2 % of its length (peer2018: 3.5 %, kugelstadt2021: 6.9 % measured,
    its split solve being softer; the elastic bar of each springs back to 0.25 % and 0.54 %)."""
    loaded, left = _load_and_unload(_bar(method, 8.0, yield_stress=2e4, hardening=1e5))
    assert loaded > 0.03
    assert left > 0.02 * LENGTH, (loaded, left)


def test_checkpoint_restores_the_plastic_strain(tmp_path) -> None:
    """The plastic strain lives in registered particle fields: a plastic run (a yield stress
    of 300 Pa, so it flows from the first steps) continued from a checkpoint repeats the
    uninterrupted one bit for bit, across z-order reorderings; frames carry the equivalent
    plastic strain."""
    from sphkit.io.frames import frame_arrays

    sc = _bar(yield_stress=300.0).scene.model_copy(deep=True)
    sc.configuration.zsort_every = 5
    sim = Simulation(sc)
    for _ in range(12):
        sim.step()
    assert sim.fluid["solid_plastic_alpha"].max() > 0
    assert frame_arrays(sim.fluid)["plastic_strain"].max() > 0
    continued_from_checkpoint(sim, tmp_path, 12, ("x", "solid_plastic", "solid_plastic_shear",
                                                  "solid_plastic_alpha"))


def test_elastic_solid_has_no_plastic_fields() -> None:
    """Without a yield stress (absent, null or 0) the solid is purely elastic: no plastic
    fields, the same numbers as before plasticity existed."""
    for extra in ({}, {"yield_stress": None}, {"yield_stress": 0.0, "hardening": 1e5}):
        sim = _bar(**extra)
        assert not sim.solids[0].plastic
        assert "solid_plastic" not in sim.fluid.specs


@pytest.mark.parametrize("field,value", [("yield_stress", -1.0), ("hardening", -5.0),
                                         ("yield_stress", float("nan")),
                                         ("hardening", float("inf")),
                                         ("yield_stress", "soft")])
def test_bad_plastic_parameters_are_refused_by_name(field: str, value: object) -> None:
    """A negative, non-finite or non-numeric yield stress or hardening modulus is a scene
    error naming ``materials[0].elasticity.<field>``."""
    with pytest.raises(SceneError, match=rf"materials\[0\]\.elasticity\.{field}"):
        scene_from_dict({"configuration": {"dim": 2},
                         "materials": [{"elasticity": {"method": "becker2009", field: value}}],
                         "fluid_blocks": [{"start": [0, 0], "end": [0.1, 0.1]}]})
