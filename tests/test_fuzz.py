"""Property-based fuzzing of scenes as users might write them (hypothesis; ``tests/_fuzz.py``):
300 generated scenes, sphkit's and SPlisHSPlasH's format, each with hostile values (NaN,
Infinity, huge, tiny, negative, wrong types), missing or unknown fields. Every one either runs
a few steps (exit 0; 3 when the stability guard stops it; 130 when the harness stops a run of
tiny time steps) or exits 2 with a message naming a mutated field, and none lets an exception
out of the command. The examples are the same on every run (``derandomize``); the long run with
random ones is ``python validation/fuzz.py --examples 10000``."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("hypothesis")

import copy  # noqa: E402
import tracemalloc  # noqa: E402

from _fuzz import OWN, Example, check, examples, run_example  # noqa: E402
from hypothesis import HealthCheck, given, settings  # noqa: E402


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


@settings(max_examples=300, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                 HealthCheck.function_scoped_fixture])
@given(ex=examples())
def test_generated_scenes_run_or_name_a_field(folder: Path, ex) -> None:
    code, text, escaped = run_example(ex, folder / "example")
    check(ex, code, text, escaped)


def test_a_block_of_millions_is_refused_by_the_budget(folder: Path) -> None:
    # found by the long run: a fluid block from y = -128768 m to 0.3 m needs 16 million
    # particles, under the default budget of 20 million; the harness's budget (100,000) refuses
    # it before anything is allocated (it had grown past 5 GB)
    import sphkit.simulation  # noqa: F401 -- imported before tracing (tracemalloc slows it)

    scene = copy.deepcopy(OWN)
    scene["fluid_blocks"][0]["start"][1] = -128768
    ex = Example("own", scene, ["fluid_blocks", "start"], ["set fluid_blocks.0.start.1"])
    tracemalloc.start()
    try:
        code, text, escaped = run_example(ex, folder / "budget")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    check(ex, code, text, escaped)
    assert code == 2 and "fluid_blocks[0]: needs about 1.61e+07" in text, text
    assert peak < 100 * 2**20  # bytes: nothing was sampled
