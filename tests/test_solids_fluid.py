"""An elastic solid in a fluid: a light elastic block dropped into water floats (the solid
goes through the fluid's pressure solve, which pushes it and keeps the two apart)."""

from __future__ import annotations

import warnings

import numpy as np

from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

R = 0.0125
WIDTH, DEPTH = 0.4, 0.2  # the tank's width and the water's depth [m]
BW, BH = 0.15, 0.1  # the block's width and height [m]


def float_scene(method: str = "peer2018", rho: float = 500.0, until: float = 0.8) -> Scene:
    """2D: water (DFSPH, 16 x 8 particles) in a box, an elastic block (6 x 4 particles, E 5e5
    Pa, density ``rho``) released 5 cm above it."""
    return Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": R, "gravity": [0.0, -9.81],
                          "pressure": {"method": "dfsph"},
                          "time": {"until": until, "dt_max": 0.002}},
        "materials": [{"id": "water", "density0": 1000.0},
                      {"id": "block", "density0": rho,
                       "elasticity": {"method": method, "youngs_modulus": 5e5,
                                      "poisson_ratio": 0.3, "alpha": 0.1}}],
        "fluid_blocks": [
            {"start": [0.0, 0.0], "end": [WIDTH, DEPTH], "material": "water"},
            {"start": [(WIDTH - BW) / 2, DEPTH + 0.05], "end": [(WIDTH + BW) / 2,
                                                                DEPTH + 0.05 + BH],
             "material": "block"}],
        "boxes": [{"min": [0.0, 0.0], "max": [WIDTH, 0.6]}]})


def test_light_elastic_block_floats_in_water() -> None:
    """peer2018 block of density 500 dropped into water of density 1000 (DFSPH): after 0.8 s
    it is whole and afloat: no NaN, well above the tank's bottom, its top out of the water
    and its bottom in it; the submerged fraction of its height, averaged over the last 0.3 s
    (it bobs), lies within 0.3-0.7 (Archimedes: rho / rho_water = 0.5; 0.45 measured; at 4
    particles across, the block's faces and the water's surface are known to about r, so
    this is a test that it floats, not of the depth: validation/solids.py --case float)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # DFSPH's convergence warnings of the first steps
        sim = Simulation(float_scene())
        f = sim.fluid
        fractions = []
        while sim.time < 0.8 - 1e-9:
            sim.step()
            if sim.time > 0.5:
                block = f["solid_slot"] >= 0
                y, x = f["x"][1], f["x"][0]
                bottom, top = y[block].min() - R, y[block].max() + R
                far = ~block & ((x < 0.1) | (x > WIDTH - 0.1))  # water away from the block
                surface = y[far].max() + R
                fractions.append((surface - bottom) / (top - bottom))
    assert np.isfinite(f["x"]).all() and np.isfinite(f["v"]).all()
    assert bottom > 0.5 * DEPTH
    assert bottom < surface < top
    frac = float(np.mean(fractions))
    assert 0.3 < frac < 0.7, frac
    # the block keeps its shape (elastic, not dissolved into the water)
    rest = f["solid_x0"][:, block]
    span = np.ptp(f["x"][:, block], axis=1) / np.ptp(rest, axis=1)
    assert np.all(np.abs(span - 1.0) < 0.1), span
