"""Load a script of ``validation/`` as a module, for the tests that run its fast variants."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

VALIDATION = Path(__file__).resolve().parent.parent / "validation"


def load_validation(script: str, name: str | None = None) -> ModuleType:
    """A fresh module of ``validation/<script>`` (executed anew on every call, so a test that
    changes the module's settings changes no other test's), named ``name`` (default: the
    script's stem plus ``_validation``)."""
    path = VALIDATION / script
    if str(VALIDATION) not in sys.path:  # the scripts import their shared helpers (_plotting)
        sys.path.append(str(VALIDATION))
    spec = importlib.util.spec_from_file_location(name or f"{path.stem}_validation", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up there while it executes
    spec.loader.exec_module(mod)
    return mod
