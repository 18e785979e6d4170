"""Where the pysplishsplash wheel keeps SPlisHSPlasH's scene files (tests skip without it)."""

from __future__ import annotations

from pathlib import Path

import pytest

from sphkit.scene.splishsplash import wheel


def wheel_scene(name: str) -> Path:
    """Path of ``data/Scenes/<name>`` in the installed pysplishsplash wheel, or skip the test."""
    if wheel.version() is None:
        pytest.skip("pysplishsplash is not installed: its scene files are not available")
    path = wheel.scene_file(name)
    if path is None:
        pytest.skip(f"the pysplishsplash wheel ships no data/Scenes/{name}")
    return path
