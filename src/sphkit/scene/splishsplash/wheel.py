"""The installed pysplishsplash wheel: its scene files and how to run it in a subprocess.

SPlisHSPlasH's own scenes (``data/Scenes``) and models (``data/models``) ship inside the
pysplishsplash wheel; they are found through the installed distribution's file list, so
wherever pip put them. ``sphkit compat``, the tests that load SPlisHSPlasH's scenes, and the
validation and benchmark scripts that run SPlisHSPlasH side by side with sphkit use these
functions. Running the wheel needs, on Linux, ``libGLdispatch`` preloaded (its import links
against the GL dispatch library even without a GUI): :func:`subprocess_env` gives the
environment for a child process that imports it.
"""

from __future__ import annotations

import importlib.metadata
import os
import sys
from pathlib import Path

#: the distribution name of SPlisHSPlasH's Python wheel
WHEEL = "pysplishsplash"
#: the library that the wheel's import needs preloaded on Linux
GL_PRELOAD = "/lib/x86_64-linux-gnu/libGLdispatch.so.0"


def _files() -> list[tuple[str, Path]]:
    """Every file of the installed wheel: its ``/``-separated path in the distribution and where
    it lies; empty without the wheel."""
    try:
        dist = importlib.metadata.distribution(WHEEL)
    except importlib.metadata.PackageNotFoundError:
        return []
    return [(str(f).replace("\\", "/"), Path(dist.locate_file(f))) for f in dist.files or []]


def _data_file(suffix: str) -> Path | None:
    """The wheel's file whose path ends with ``suffix`` (``/``-separated), or None."""
    return next((where.resolve() for name, where in _files() if name.endswith(suffix)), None)


def scene_folder() -> Path | None:
    """``data/Scenes`` of the installed wheel, or None without the wheel."""
    for name, where in _files():
        parts = name.split("/")
        if len(parts) >= 3 and parts[-3:-1] == ["data", "Scenes"] and parts[-1].endswith(".json"):
            return where.resolve().parent
    return None


def scene_file(name: str) -> Path | None:
    """``data/Scenes/<name>`` of the installed wheel (``name`` with or without ``.json``), or
    None when the wheel is missing or ships no such scene."""
    if not name.endswith(".json"):
        name += ".json"
    return _data_file(f"data/Scenes/{name}")


def data_folder() -> Path | None:
    """The wheel's ``data`` folder (``Scenes``, ``models``, ...), or None."""
    box = _data_file("data/models/UnitBox.obj")
    return box.parent.parent if box is not None else None


def version() -> str | None:
    """The installed pysplishsplash version, or None."""
    try:
        return importlib.metadata.version(WHEEL)
    except importlib.metadata.PackageNotFoundError:
        return None


def subprocess_env(threads: int | str | None = None) -> dict[str, str]:
    """The environment of a child process that imports the wheel: this process's, with
    ``OMP_NUM_THREADS`` set to ``threads`` (unchanged when None) and, on Linux where the library
    exists, ``LD_PRELOAD`` set to :data:`GL_PRELOAD`."""
    env = dict(os.environ)
    if threads is not None:
        env["OMP_NUM_THREADS"] = str(threads)
    if sys.platform.startswith("linux") and Path(GL_PRELOAD).exists():
        env["LD_PRELOAD"] = GL_PRELOAD
    return env
