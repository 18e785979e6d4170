"""``sphkit methods``: every method sphkit implements, read from the registry.

One row per method (:mod:`sphkit.registry`): its role, its scene name, SPlisHSPlasH's number of
it, what it can do (capabilities: ``periodic``, ``dynamic_bodies``, ``multiphase``, ``gpu``; a
boundary model's kind, ``particles`` or ``maps``; the boundary kinds a boundary pressure acts
on) and the paper it implements. ``--json`` prints the same as a JSON list, one object per
method; ``--role`` lists one role.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

from sphkit import registry
from sphkit.cli.common import EXIT_OK


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``sphkit methods`` to the ``sphkit`` command's subcommands."""
    p = sub.add_parser(
        "methods", help="list every method: paper, SPlisHSPlasH number, capabilities",
        description="Every method of sphkit by role: scene name, SPlisHSPlasH's number, "
        "capabilities and the paper it implements.")
    p.add_argument("--role", choices=registry.ROLES, help="list the methods of one role only")
    p.add_argument("--json", action="store_true", help="print the list as JSON")
    p.set_defaults(handler=cmd_methods)


def capabilities(m: registry.Method) -> str:
    """What a method can do, as one comma-separated cell ("-" for nothing)."""
    caps = sorted(m.capabilities)
    if m.kind:
        caps.insert(0, m.kind)
    if m.boundary:
        caps.insert(0, "on " + "/".join(m.boundary))
    return ", ".join(caps) or "-"


def cmd_methods(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """``sphkit methods``: the registry as a table (or JSON) on stdout."""
    rows = registry.methods(args.role)
    if args.json:
        print(json.dumps([m.as_dict() for m in rows], indent=2, ensure_ascii=False))
        return EXIT_OK
    table = [("role", "method", "SPlisHSPlasH", "capabilities", "paper")]
    table += [(m.role, m.name, "-" if m.splishsplash is None else str(m.splishsplash),
               capabilities(m), m.paper) for m in rows]
    widths = [max(len(r[c]) for r in table) for c in range(4)]
    for r in table:
        sys.stdout.write("  ".join(v.ljust(w) for v, w in zip(r[:4], widths, strict=True))
                         + "  " + r[4] + "\n")
    return EXIT_OK
