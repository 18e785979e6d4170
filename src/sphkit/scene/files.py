"""Scene files: sphkit's own JSON/YAML, built-in scenes, and the entry point :func:`load_scene`.

:func:`load_scene` is the one entry point; every front end produces a validated
:class:`~sphkit.scene.schema.Scene`: sphkit's own format (:func:`scene_from_dict`) and
SPlisHSPlasH's JSON scenes (:func:`~sphkit.scene.splishsplash.from_splishsplash`, chosen by
:func:`~sphkit.scene.splishsplash.is_splishsplash`). Every error is a
:class:`~sphkit.scene.schema.SceneError` whose message names the field path, the value and what
was expected. Files are read as UTF-8 JSON or YAML (PyYAML's safe loader: no tags that run
code; anchors and aliases are allowed as long as the document they expand to has at most
:data:`~sphkit.scene.limits.MAX_YAML_NODES` nodes, so a "billion laughs" file is refused before
it is expanded); files larger than :data:`~sphkit.scene.limits.MAX_SCENE_BYTES` are refused
unread; a malformed file is reported with
its line and column. Paths written in a scene (meshes,
particle files) are relative to the scene file's folder
(:func:`sphkit.scene.paths.resolve_scene_path`).
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from sphkit.scene.limits import MAX_SCENE_BYTES, MAX_YAML_NODES
from sphkit.scene.paths import check_particle_file, resolve_scene_path
from sphkit.scene.schema import Scene, SceneError, clip, format_validation_error
from sphkit.scene.splishsplash import from_splishsplash, is_splishsplash

__all__ = [
    "builtin_scenes",
    "builtin_scene_path",
    "load_scene",
    "load_scene_file",
    "read_scene_mapping",
    "scene_from_dict",
]

SCENE_SUFFIXES = (".json", ".yaml", ".yml")

_SCENES_DIR = Path(__file__).resolve().parent.parent / "scenes"


# ----------------------------------------------------------------------------------------------
# built-in scenes
# ----------------------------------------------------------------------------------------------


def _builtin_files() -> dict[str, Path]:
    if not _SCENES_DIR.is_dir():
        return {}
    return {
        p.stem: p
        for p in sorted(_SCENES_DIR.iterdir())
        if p.is_file() and p.suffix.lower() in SCENE_SUFFIXES
    }


def builtin_scenes() -> dict[str, str]:
    """The built-in scenes: name -> one-line description (sorted by name)."""
    out = {}
    for name, path in _builtin_files().items():
        try:
            data = _read_mapping(path)
            out[name] = str(data.get("description", "")).strip()
        except SceneError as err:
            out[name] = f"(unreadable: {err})"
    return out


def builtin_scene_path(name: str) -> Path:
    """Path of the built-in scene ``name``; SceneError listing the known names otherwise."""
    files = _builtin_files()
    if name not in files:
        raise SceneError(
            f"unknown built-in scene {name!r}; built-in scenes: {', '.join(files) or '(none)'}"
        )
    return files[name]


# ----------------------------------------------------------------------------------------------
# files
# ----------------------------------------------------------------------------------------------


def _parse_json(text: str, path: Path) -> Any:
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise SceneError(
            f"scene file {str(path)!r}: invalid JSON at line {err.lineno}, column {err.colno}: "
            f"{err.msg}"
        ) from None
    except RecursionError:
        raise SceneError(f"scene file {str(path)!r}: JSON nested too deeply; expected a scene "
                         "of a few levels of fields") from None
    except ValueError as err:  # e.g. an integer of more digits than Python converts
        raise SceneError(f"scene file {str(path)!r}: invalid JSON: {clip(str(err), 200)}"
                         ) from None


def _expanded_size(node: yaml.Node, path: Path) -> int:
    """The number of nodes of a composed YAML document with every alias expanded; refuses
    more than :data:`MAX_YAML_NODES` and recursive aliases (a node containing itself)."""
    sizes: dict[int, int] = {}
    busy: set[int] = set()

    def size(n: yaml.Node) -> int:
        key = id(n)
        if key in sizes:
            return sizes[key]
        if key in busy:
            raise SceneError(f"scene file {str(path)!r}: a YAML alias refers to a node that "
                             "contains it (a recursive structure); expected a tree of fields")
        busy.add(key)
        total = 1
        if isinstance(n, yaml.SequenceNode):
            for child in n.value:
                total += size(child)
                if total > MAX_YAML_NODES:
                    break
        elif isinstance(n, yaml.MappingNode):
            for k, v in n.value:
                total += size(k) + size(v)
                if total > MAX_YAML_NODES:
                    break
        busy.discard(key)
        if total > MAX_YAML_NODES:
            raise SceneError(
                f"scene file {str(path)!r}: its YAML anchors and aliases expand to more than "
                f"{MAX_YAML_NODES:,} fields and values (nested aliases, a 'billion laughs' "
                "file); expected a scene without deeply nested aliases")
        sizes[key] = total
        return total

    size(node)
    return sizes[id(node)]


def _parse_yaml(text: str, path: Path) -> Any:
    try:
        loader = yaml.SafeLoader(text)
        try:
            node = loader.get_single_node()  # the document's nodes, aliases not expanded
            if node is None:
                return None
            _expanded_size(node, path)
            return loader.construct_document(node)
        finally:
            loader.dispose()
    except RecursionError:
        raise SceneError(f"scene file {str(path)!r}: YAML nested too deeply; expected a scene "
                         "of a few levels of fields") from None
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None) or getattr(err, "context_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(err, "problem", None) or str(err)
        raise SceneError(f"scene file {str(path)!r}: invalid YAML{where}: {problem}") from None


def _read_mapping(path: Path) -> dict[str, Any]:
    """Read a JSON or YAML file whose top level is a mapping."""
    try:
        size = path.stat().st_size
        if size > MAX_SCENE_BYTES:
            raise SceneError(f"scene file {str(path)!r}: {size:,} bytes; expected a scene file "
                             f"of at most {MAX_SCENE_BYTES:,} bytes (particles belong in "
                             "particle files, fluid_files)")
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError(f"scene file {str(path)!r}: not found") from None
    except IsADirectoryError:
        raise SceneError(f"scene file {str(path)!r}: is a directory, expected a file") from None
    except UnicodeDecodeError:
        raise SceneError(f"scene file {str(path)!r}: not a UTF-8 text file") from None
    except OSError as err:
        raise SceneError(f"scene file {str(path)!r}: cannot be read ({err.strerror})") from None
    suffix = path.suffix.lower()
    if suffix == ".json" or (suffix not in (".yaml", ".yml") and text.lstrip().startswith("{")):
        data = _parse_json(text, path)
    else:
        data = _parse_yaml(text, path)
    if not isinstance(data, dict):
        raise SceneError(
            f"scene file {str(path)!r}: got {type(data).__name__} at the top level; "
            "expected a mapping of scene fields"
        )
    return data


def read_scene_mapping(src: str | os.PathLike[str]) -> tuple[dict[str, Any], Path] | None:
    """The parsed top-level mapping of a scene file or built-in scene name, and its path, before
    validation (``--vary`` paths in SPlisHSPlasH's own field names,
    :mod:`sphkit.scene.variants`); None where ``src`` names neither."""
    path = Path(os.fspath(src)).expanduser()
    if not path.is_file():
        path = _builtin_files().get(os.fspath(src), path)
    return (_read_mapping(path), path) if path.is_file() else None


def load_scene_file(path: str | Path) -> Scene:
    """Load a scene file: sphkit's JSON/YAML, or a SPlisHSPlasH JSON scene."""
    p = Path(path).expanduser()
    return scene_from_dict(_read_mapping(p), p)


def load_scene(src: str | os.PathLike[str] | Mapping[str, Any] | Scene) -> Scene:
    """Load a scene from a built-in name, a file, a dict, or return a Scene as it is.

    Args:
        src: a :class:`Scene`; a dict (sphkit's fields, or SPlisHSPlasH's when it has a
            ``Configuration`` block); a path to a sphkit JSON/YAML or SPlisHSPlasH JSON file
            (``scene.source`` becomes the file path, ``scene.name`` its stem unless the file
            names the scene); or a built-in scene name (see :func:`builtin_scenes`).

    Raises:
        SceneError: the file is missing or malformed (with the line), the name is unknown (the
            message lists the built-in scenes), or a field is invalid (path, value, expectation).
    """
    if isinstance(src, Scene):
        return src
    if isinstance(src, Mapping):
        return scene_from_dict(src)
    if isinstance(src, (str, os.PathLike)):
        name = os.fspath(src)
        path = Path(name).expanduser()
        if path.is_file():
            return load_scene_file(path)
        files = _builtin_files()
        if name in files:
            return load_scene_file(files[name])
        if path.is_dir():
            raise SceneError(f"scene {name!r}: is a directory, expected a scene file")
        if path.suffix.lower() in SCENE_SUFFIXES or "/" in name or os.sep in name:
            raise SceneError(f"scene file {name!r}: not found")
        raise SceneError(
            f"unknown scene {name!r}: neither a scene file nor a built-in scene; "
            f"built-in scenes: {', '.join(files) or '(none)'}"
        )
    raise SceneError(
        f"cannot load a scene from a {type(src).__name__}; expected a built-in scene name, "
        "a file path, a dict or a Scene"
    )


def scene_from_dict(data: Mapping[str, Any], path: str | Path | None = None) -> Scene:
    """Validate a scene dict (sphkit's or SPlisHSPlasH's format) read from ``path`` (optional)."""
    if not isinstance(data, Mapping):
        raise SceneError(f"got {type(data).__name__}; expected a mapping of scene fields")
    if is_splishsplash(data):
        return from_splishsplash(data, path)
    d = dict(data)
    where = "scene"
    if path is not None:
        p = Path(path)
        where = f"scene file {str(p)!r}"
        d["source"] = str(p.resolve())
        if not d.get("name"):
            d["name"] = p.stem
    try:
        scene = Scene.model_validate(d)
    except ValidationError as err:
        raise SceneError(f"{where}: invalid scene:\n{format_validation_error(err)}") from None
    for k, m in enumerate(scene.meshes):
        f = resolve_scene_path(scene, m.geometry_file)
        if not f.is_file():
            raise SceneError(
                f"{where}: meshes[{k}].geometry_file: got {m.geometry_file!r}: expected an "
                f"existing mesh file (looked for {str(f)!r})"
            )
    for k, ff in enumerate(scene.fluid_files):
        check_particle_file(resolve_scene_path(scene, ff.file), ff.file,
                             f"{where}: fluid_files[{k}].file")
    return scene
