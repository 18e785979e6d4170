"""``sphkit compat`` over the pysplishsplash wheel's scenes (skipped without the wheel).

Speed: the scenes are coarsened (``particleRadius`` x 2, 8x fewer particles in 3D) and only
those with at most 30,000 particles after that are run, 5 steps each; the others must still load
or name their missing feature.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from sphkit.cli import main
from sphkit.cli.compat import check_folder, wheel_scene_folder

DOC = Path(__file__).resolve().parent.parent / "docs" / "compatibility.md"


@pytest.fixture(scope="module")
def folder() -> Path:
    f = wheel_scene_folder()
    if f is None:
        pytest.skip("pysplishsplash is not installed: its scene files are not available")
    return f


def test_every_scene_loads_and_runs_or_names_the_missing_feature(folder: Path) -> None:
    results = check_folder(folder, steps=5, radius_scale=2.0, max_particles=30_000)
    assert len(results) == len(list(folder.glob("*.json"))) > 40
    for r in results:
        if r.status == "does not load":
            # the loader's message names the field (path with a dot or a block name)
            assert r.detail and ("not supported" in r.detail or "expected" in r.detail), r
        else:  # every scene whose features exist runs 5 steps (or is over the size limit)
            assert r.status in ("runs", "loads, not run"), r
            if r.status == "runs":
                assert "5 steps" in r.detail
    assert any(r.status == "runs" for r in results)


def test_compat_markdown_lists_every_scene(folder: Path, tmp_path: Path) -> None:
    out = tmp_path / "compat.md"
    assert main(["compat", "--only", "GridModel_Akinci2012.json", "Empty.json", "--steps", "1",
                 "--radius-scale", "1", "--markdown", str(out)]) == 0
    text = out.read_text()
    assert "| GridModel_Akinci2012.json | runs |" in text
    # SPlisHSPlasH opens its empty scene; sphkit runs it with 0 particles and a warning
    assert "| Empty.json | runs | 0 (3D) |" in text and "runs with 0 particles" in text
    # the committed page covers the whole corpus
    committed = DOC.read_text()
    for scene in folder.glob("*.json"):
        assert f"| {scene.name} |" in committed, scene.name
