"""``sphkit compat`` over the pysplishsplash wheel's scenes (skipped without the wheel).

Speed: building and stepping all 55 scenes compiles nearly every method of the library (about
9 CPU-minutes cold, most of it Numba compilation and the maps of the larger scenes), more than
the whole suite's budget allows. So CI reads every scene (the loader accepts it or names the
missing feature: 0.4 s for all of them) and builds and runs 5 steps of a sample that spans the
scene features without a test of their own here (rigid bodies, a motor joint, several fluids,
maps, dense sampling, a script, an emitter, ZR2020 surface tension, Weiler viscosity). The whole
corpus runs with ``sphkit compat --markdown docs/compatibility.md``, and the committed page, which
it regenerates, must cover every scene with none failing (last test).
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


#: run here (5 steps, particleRadius x 2): one scene per feature not run by another test file
SAMPLE = ["DamBreakModel.json", "DoubleDamBreakWithSphere.json", "MotorScene2.json",
          "MultiPhaseColoring.json", "Obstacle.json", "ReadWriteStateTest.json", "ScriptTest.json",
          "Emitter.json", "SurfaceTension_NoGravCube_ZR2020.json", "CoilingModel_Weiler2018.json"]


def test_every_scene_loads_or_names_the_missing_feature(folder: Path) -> None:
    import json
    import warnings

    from sphkit.scene.splishsplash import from_splishsplash

    scenes = sorted(folder.glob("*.json"))
    assert len(scenes) > 40
    refused = []
    for path in scenes:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # ignored fields are warnings, listed by compat
            try:
                from_splishsplash(json.loads(path.read_text(encoding="utf-8")), path)
            except Exception as e:  # noqa: BLE001 - the message is what is checked
                text = str(e)
                # the loader's message names the field (path with a dot) and what is supported
                assert "not supported" in text or "expected" in text, (path.name, text)
                refused.append(path.name)
    # only the Nogina & Sellan 2026 tube-map scenes are refused (issue 20's exception)
    assert refused and all("NoginaSellan2026" in name for name in refused), refused


def test_sample_scenes_build_and_run(folder: Path) -> None:
    results = check_folder(folder, steps=5, radius_scale=2.0, max_particles=30_000, only=SAMPLE)
    assert sorted(r.name for r in results) == sorted(SAMPLE)
    for r in results:
        assert r.status == "runs", r
        assert "5 steps" in r.detail, r


def test_compat_markdown_lists_every_scene(folder: Path, tmp_path: Path) -> None:
    out = tmp_path / "compat.md"
    assert main(["compat", "--only", "GridModel_Akinci2012.json", "Empty.json", "--steps", "1",
                 "--radius-scale", "1", "--markdown", str(out)]) == 0
    text = out.read_text()
    assert "| GridModel_Akinci2012.json | runs |" in text
    # SPlisHSPlasH opens its empty scene; sphkit runs it with 0 particles and a warning
    assert "| Empty.json | runs | 0 (3D) |" in text and "runs with 0 particles" in text
    # a folder of the user's scenes is named as the page's source, not the wheel
    import shutil

    mine = tmp_path / "mine"
    mine.mkdir()
    shutil.copy(folder / "Empty.json", mine / "Empty.json")
    assert main(["compat", "--scenes", str(mine), "--steps", "1", "--markdown", str(out)]) == 0
    assert f"from the 1 scenes in `{mine}`" in out.read_text()
    assert f"`sphkit compat --scenes {mine} --markdown {out}`" in out.read_text()
    # the committed page covers the whole corpus
    committed = DOC.read_text()
    for scene in folder.glob("*.json"):
        assert f"| {scene.name} |" in committed, scene.name
    # ... and its last full run found no scene that loads but fails to run
    assert "| fails to run |" not in committed
