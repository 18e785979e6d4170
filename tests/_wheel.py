"""Where the pysplishsplash wheel keeps SPlisHSPlasH's scene files (tests skip without it)."""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import pytest


def wheel_scene(name: str) -> Path:
    """Path of ``data/Scenes/<name>`` in the installed pysplishsplash wheel, or skip the test."""
    try:
        dist = importlib.metadata.distribution("pysplishsplash")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("pysplishsplash is not installed: its scene files are not available")
    for f in dist.files or []:
        if str(f).replace("\\", "/").endswith(f"data/Scenes/{name}"):
            return Path(dist.locate_file(f)).resolve()
    pytest.skip(f"the pysplishsplash wheel ships no data/Scenes/{name}")
