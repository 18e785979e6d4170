"""The world of a simulation, built once from a scene (:func:`build_world`)."""

from sphkit.world.build import World, build_world, resolve_device, scene_for_device

__all__ = ["World", "build_world", "resolve_device", "scene_for_device"]
