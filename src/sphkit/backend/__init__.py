"""Compute backend: :func:`launch` runs a per-particle kernel body as a CPU ``prange`` loop or as
a CUDA kernel (:mod:`sphkit.backend.launch`; the CUDA side, :mod:`sphkit.backend.cuda`, is
imported only when a launch asks for it)."""

from sphkit.backend.launch import (
    DEVICES,
    cuda_available,
    device_of,
    empty,
    exclusive_scan,
    histogram,
    launch,
    launch_reduce,
    launch_sum,
    on_device,
    register_typed,
    specialize,
    to_device,
    to_host,
)

__all__ = ["DEVICES", "cuda_available", "device_of", "empty", "exclusive_scan", "histogram",
           "launch", "launch_reduce", "launch_sum", "on_device", "register_typed", "specialize",
           "to_device", "to_host"]
