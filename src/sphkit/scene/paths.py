"""Files a scene names: paths resolved against the scene file's folder, particle files checked.

Both front ends (sphkit's own format, :mod:`sphkit.scene.files`, and SPlisHSPlasH's,
:mod:`sphkit.scene.splishsplash`) and the world builder resolve the files of a scene the same
way, here.
"""

from __future__ import annotations

from pathlib import Path

from sphkit.scene.schema import Scene, SceneError


def resolve_scene_path(scene: Scene, path: str | Path) -> Path:
    """Resolve a path written in a scene (e.g. a mesh file) against the scene file's folder."""
    p = Path(path).expanduser()
    if p.is_absolute() or not scene.source:
        return p
    return Path(scene.source).parent / p


def check_particle_file(f: Path, given: str, where: str) -> None:
    """SceneError naming ``where`` unless ``f`` is an existing particle file of a known format.

    Args:
        f: the file, resolved against the scene file's folder.
        given: the path as the scene wrote it (quoted in the message).
        where: the message's prefix: the scene and the field path.
    """
    from sphkit.io.particle_files import PARTICLE_FILE_SUFFIXES, particle_file_kind

    if particle_file_kind(f) is None:
        raise SceneError(
            f"{where}: got {given!r}: expected a particle file ending in "
            f"{', '.join(PARTICLE_FILE_SUFFIXES)}"
        )
    if not f.is_file():
        raise SceneError(
            f"{where}: got {given!r}: expected an existing particle file (looked for {str(f)!r})"
        )
