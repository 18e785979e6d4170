"""``sphkit scenes``: list the built-in scenes (name and one-line description) on stdout.

The built-in scenes are the scene files shipped in ``sphkit/scenes``
(:func:`sphkit.scene.files.builtin_scenes`); ``sphkit run NAME`` runs one.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from sphkit.cli.common import EXIT_OK


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``sphkit scenes`` to the ``sphkit`` command's subcommands."""
    p = sub.add_parser("scenes", help="list the built-in scenes",
                       description="List the built-in scenes with their descriptions.")
    p.set_defaults(handler=cmd_scenes)


def cmd_scenes(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """``sphkit scenes``: list the built-in scenes on stdout."""
    from sphkit.scene.files import builtin_scenes

    scenes = builtin_scenes()
    width = max((len(n) for n in scenes), default=0)
    for name, description in sorted(scenes.items()):
        print(f"{name:<{width}}  {description}")
    return EXIT_OK
