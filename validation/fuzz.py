"""The long run of the scene fuzz test: many generated hostile scenes through ``sphkit run``.

    python validation/fuzz.py --examples 10000 [--seed 1] [--show 5] [--minutes M]

Each example is a tiny scene (sphkit's or SPlisHSPlasH's format) with one to three hostile
mutations (``tests/_fuzz.py``: NaN, Infinity, huge, tiny, negative values, wrong types, missing
and unknown fields, optional methods and objects). It runs in-process, a few steps at most, and
must exit 0 (ran), 3 (stopped by the stability guard), 130 (stopped by the harness after a few
steps) or 2 with a message naming a mutated field, without an exception escaping the command.
Unlike the test (300 fixed examples, stops at the first failure and shrinks it), this draws
random examples, runs all of them and prints a table of exit codes and the failures it found
(each failure also on stderr when it is found, with a progress line every 250 examples).
``--minutes M`` stops running examples after M minutes (the rest are drawn but not run; the
table counts those that ran), for a long run in chunks with different seeds.
"""

from __future__ import annotations

import argparse
import collections
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from _fuzz import check, examples, run_example  # noqa: E402
from hypothesis import HealthCheck, given, seed, settings  # noqa: E402


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--examples", type=int, default=10000, help="number of generated scenes")
    p.add_argument("--seed", type=int, default=1, help="random seed of the generator")
    p.add_argument("--show", type=int, default=5, help="failures to print in full")
    p.add_argument(
        "--minutes", type=float, default=None, help="stop running examples after this many minutes"
    )
    args = p.parse_args()

    codes: collections.Counter[str] = collections.Counter()
    failures: list[str] = []
    folder = Path(tempfile.mkdtemp(prefix="sphkit-fuzz-"))
    t0 = time.perf_counter()

    @seed(args.seed)
    @settings(
        max_examples=args.examples,
        deadline=None,
        database=None,
        derandomize=False,
        phases=["generate"],
        suppress_health_check=list(HealthCheck),
    )
    @given(ex=examples())
    def one(ex) -> None:
        if args.minutes is not None and time.perf_counter() - t0 > 60 * args.minutes:
            return  # over the time budget: drawn, not run
        code, text, escaped = run_example(ex, folder / "example")
        codes[f"{ex.kind} {code if escaped is None else type(escaped).__name__}"] += 1
        try:
            check(ex, code, text, escaped)
        except AssertionError as e:
            failures.append(str(e))
            print(f"--- failure {len(failures)} ---\n{e}", file=sys.stderr, flush=True)
        total = sum(codes.values())
        if total % 250 == 0:
            print(
                f"{total} examples, {len(failures)} failure(s), {time.perf_counter() - t0:.0f} s",
                file=sys.stderr,
                flush=True,
            )

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the scenes' own warnings (unknown fields, ...)
            one()
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    wall = time.perf_counter() - t0
    total = sum(codes.values())
    print(
        f"{total} examples in {wall:.0f} s ({1e3 * wall / max(total, 1):.0f} ms each), "
        f"{len(failures)} failure(s)"
        + (
            f"; the time budget stopped it after {total} of {args.examples}"
            if total < args.examples
            else ""
        )
        + "\n"
    )
    print("| format | exit code | examples |\n|---|---|---|")
    for key in sorted(codes):
        kind, code = key.split(" ", 1)
        print(f"| {kind} | {code} | {codes[key]} |")
    for text in failures[: args.show]:
        print("\n--- failure ---\n" + text)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
