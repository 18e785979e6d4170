"""sphkit: Smoothed Particle Hydrodynamics for computer graphics.

Quick start::

    import sphkit
    sim = sphkit.Simulation.from_scene("dambreak-2d")
    sim.run(until=0.5)
    print(sim.positions.shape)
"""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["Simulation", "InstabilityError", "__version__"]


def __getattr__(name: str):
    # lazy: importing sphkit must not compile anything
    if name in ("Simulation", "InstabilityError", "StepStats"):
        from sphkit import simulation

        return getattr(simulation, name)
    raise AttributeError(f"module 'sphkit' has no attribute {name!r}")
