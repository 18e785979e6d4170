"""Compute backends: the CPU drivers live next to the physics bodies (``prange`` loops);
:mod:`sphkit.backend.cuda` wraps the same bodies as CUDA device functions."""
