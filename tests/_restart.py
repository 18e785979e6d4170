"""Shared by the checkpoint tests of the solids: a run and its continuation from a checkpoint."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sphkit.simulation import Simulation


def continued_from_checkpoint(sim: Simulation, folder: Path, steps: int,
                              fields: tuple[str, ...] = ("x", "v")) -> Simulation:
    """Write a checkpoint of ``sim`` (after its steps so far), run ``steps`` more, continue a
    second simulation from the checkpoint for the same ``steps``, and assert that ``fields``
    agree bit for bit (by particle id); returns the continued simulation."""
    path = sim.save_checkpoint(folder / "ck.npz")
    for _ in range(steps):
        sim.step()
    again = Simulation.from_checkpoint(path)
    for _ in range(steps):
        again.step()
    a, b = sim.fluid, again.fluid
    for name in fields:
        np.testing.assert_array_equal(a[name][..., a.order_by_id()],
                                      b[name][..., b.order_by_id()], err_msg=name)
    return again
