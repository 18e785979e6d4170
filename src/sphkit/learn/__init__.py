"""Learned simulators and their data (the optional extra ``sphkit[learn]``: PyTorch, h5py).

* :mod:`sphkit.learn.data` -- the HDF5 dataset layout (LagrangeBench's: ``train.h5``,
  ``valid.h5``, ``test.h5`` and ``metadata.json``), a PyTorch ``Dataset`` of training windows and
  the normalisation statistics;
* :mod:`sphkit.learn.graph` -- the radius graph, built with sphkit's neighbour search
  (:mod:`sphkit.core.neighbors`);
* :mod:`sphkit.learn.sanchez_gonzalez2020` -- the graph network simulator (GNS) of
  Sanchez-Gonzalez et al. 2020;
* :mod:`sphkit.learn.train` -- training (noise injection, checkpoints, resume);
* :mod:`sphkit.learn.rollout` -- autoregressive rollouts written as frames, like ``sphkit run``;
* :mod:`sphkit.learn.walls` -- the rollout's collisions of the fluid with the wall particles;
* :mod:`sphkit.learn.evaluate` -- rollout errors against the solver and a constant-velocity
  baseline, kinetic energy and density error over time.

Importing this package imports nothing heavy; sphkit itself never imports it (DESIGN.md:
``learn -> simulation, io, core``), so sphkit runs without PyTorch.
"""

from __future__ import annotations

import importlib.util

__all__ = ["MISSING_MESSAGE", "missing"]

#: what ``sphkit learn`` says when PyTorch (or h5py) is not installed
MISSING_MESSAGE = "install sphkit[learn] (PyTorch) to use the learned simulators: " \
                  "pip install 'sphkit[learn]'"


def missing() -> list[str]:
    """The packages of the ``learn`` extra that are not installed (empty when all are)."""
    return [name for name in ("torch", "h5py") if importlib.util.find_spec(name) is None]
