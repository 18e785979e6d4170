"""Issue 15's eight hostile inputs, run as a user runs them: ``sphkit`` in a subprocess.

    python validation/hostile.py [--markdown]

Each probe writes its scene (or damages a run folder) in a temporary folder, starts
``python -m sphkit ...`` (the ``sphkit`` script's ``main``, from this checkout's ``src``) and,
where the probe is a signal, sends it after a delay. The table gives the exit code, the wall
time, the child's own peak resident memory (``os.wait4``: ``ru_maxrss`` of that process, not
the maximum over all children), whether stderr holds a traceback, and the first line of the
message (an error's lines joined while one ends with ':', a heading). A probe passes when
its exit code is the expected one, it ended within 10 s, its peak RSS is under 1 GB, nothing
printed ``Traceback`` and the message names the field (or flag, or file) listed for it.

A Ctrl-C that lands before the first line of the ``sphkit`` script runs (the interpreter's own
start-up: before it installs its SIGINT handler, or while it imports ``site`` and its ``.pth``
files) is CPython's, out of sphkit's reach: such a probe is shown as void, not counted.

The runs that simulate compile with Numba on the first use of a checkout (minutes): run this
twice, or after the tests, to time them warm. Exit code 0 when every probe passes, 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
#: the issue's bounds: seconds and bytes of resident memory per probe
SECONDS = 10.0
MEMORY = 2**30
#: a probe that has not ended after this long is killed (and fails)
KILL_AFTER = 60.0

#: 2D, 5 x 5 = 25 fluid particles in a box
TINY = {
    "name": "tiny",
    "configuration": {"dim": 2, "particle_radius": 0.02, "time": {"until": 0.01}},
    "fluid_blocks": [{"start": [0.1, 0.1], "end": [0.3, 0.3]}],
    "boxes": [{"min": [0.0, 0.0], "max": [0.6, 0.5]}],
    "output": {"fps": 40},
}


@dataclass
class Probe:
    """One hostile input: the issue's item, a label, what to run and what must hold."""

    item: int
    label: str
    #: (folder) -> the command's arguments after ``sphkit``
    setup: Callable[[Path], list[str]]
    expect: int
    #: words stderr must contain (the field, flag or file)
    named: tuple[str, ...] = ()
    #: a signal sent this many seconds after the start (None: none) ...
    signal_after: float | None = None
    #: ... and once this many files match this pattern (in the probe's folder)
    signal_once: tuple[str, int] | None = None
    signum: int = signal.SIGINT
    #: a further check of the folder after the run: (folder, stderr) -> problem or ""
    after: Callable[[Path, str], str] | None = None


@dataclass
class Result:
    probe: Probe
    code: int | None
    seconds: float
    rss: int
    stderr: str
    problems: list[str] = field(default_factory=list)
    #: why the probe does not count (a signal that landed in Python's own start-up)
    void: str = ""


def _scene(folder: Path, data: dict | str, name: str = "scene.json") -> str:
    """Write the scene into the probe's folder; its name as the command gets it (the command
    runs in that folder)."""
    (folder / name).write_text(data if isinstance(data, str) else json.dumps(data))
    return name


def _with(changes: dict) -> dict:
    """TINY with top-level sections updated (one level deep)."""
    scene = json.loads(json.dumps(TINY))
    for key, value in changes.items():
        if isinstance(value, dict) and isinstance(scene.get(key), dict):
            scene[key].update(value)
        else:
            scene[key] = value
    return scene


def laughs(levels: int) -> str:
    """A YAML file of ``levels`` nested aliases, each nine times the one before (a "billion
    laughs" document; also the input of tests/test_hostile.py)."""
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for k in range(1, levels + 1):
        lines.append(f"a{k}: &a{k} [" + ", ".join([f"*a{k - 1}"] * 9) + "]")
    lines.append(f"name: *a{levels}")
    return "\n".join(lines) + "\n"


def _sphkit(args: list[str], cwd: Path, timeout: float) -> subprocess.CompletedProcess:
    """A helper run (no measurement), e.g. to make checkpoints."""
    return subprocess.run(
        [sys.executable, "-m", "sphkit", *args],
        capture_output=True,
        text=True,
        env=_env(),
        timeout=timeout,
        cwd=cwd,
    )


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")])
    env.setdefault("NUMBA_NUM_THREADS", "1")
    return env


# -- 4. and 8.: run folders with checkpoints ----------------------------------------------------
_CHECKPOINTED: Path | None = None


def _checkpointed(base: Path) -> Path:
    """A tiny run with two checkpoints (made once, copied by each probe)."""
    global _CHECKPOINTED
    if _CHECKPOINTED is None:
        out = base / "checkpointed"
        res = _sphkit(
            [
                "run",
                _scene(base, TINY, "ck.json"),
                "--out",
                str(out),
                "--checkpoint-every",
                "0.005",
                "--until",
                "0.008",
                "--quiet",
            ],
            base,
            timeout=900,
        )
        found = sorted((out / "checkpoints").glob("checkpoint_*.npz"))
        if res.returncode != 0 or len(found) != 2:
            raise SystemExit(f"could not make the checkpointed run:\n{res.stderr}")
        _CHECKPOINTED = out
    return _CHECKPOINTED


class _Opens:
    """Unpickling this opens (creates) ``path``: the trace a loaded pickle would leave."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self) -> tuple:
        return open, (str(self.path), "w")


def _damaged(folder: Path, how: str) -> list[str]:
    out = folder / "run"
    shutil.copytree(_checkpointed(folder.parent), out)
    found = sorted(
        (out / "checkpoints").glob("checkpoint_*.npz"), key=lambda p: int(p.stem.split("_")[1])
    )
    targets = found[-1:] if how in ("truncated", "empty") else found
    for path in targets:
        data = path.read_bytes()
        if how == "truncated":
            path.write_bytes(data[: len(data) // 2])
        elif how == "empty":
            path.write_bytes(b"")
        elif how == "random":
            path.write_bytes(np.random.default_rng(1).bytes(4000))
        elif how in ("nan", "pickled"):
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
            if how == "nan":
                arrays["fluid/x"] = np.full_like(arrays["fluid/x"], np.nan)
            else:  # an object array, stored pickled
                arrays["fluid/v"] = np.array([_Opens(folder / "unpickled")], dtype=object)
            with open(path, "wb") as f:
                np.savez(f, **arrays)
    (folder / "names.txt").write_text("\n".join(p.name for p in found))
    return ["run", "--resume", "run", "--until", "0.012"]


def _newest_named(folder: Path, err: str) -> str:
    newest = (folder / "names.txt").read_text().split()[-1]
    problems = [] if newest in err else [f"{newest} not named"]
    if "allow_pickle" in err:
        problems.append("repeats numpy's allow_pickle advice")
    return "; ".join(problems)


def _not_unpickled(folder: Path, err: str) -> str:
    problem = _newest_named(folder, err)
    if (folder / "unpickled").exists():
        problem += "; the pickle was loaded"
    return problem.lstrip("; ")


def _fell_back(folder: Path, err: str) -> str:
    names = (folder / "names.txt").read_text().split()
    resumed = json.loads((folder / "run" / "manifest.json").read_text()).get("resumed", [{}])
    problems = []
    if names[-1] not in err or "skipped" not in err:
        problems.append("no warning naming the skipped checkpoint")
    if not str(resumed[-1].get("checkpoint", "")).endswith(names[0]):
        problems.append("did not resume from the older checkpoint")
    return "; ".join(problems)


def _frames_per_step(folder: Path, err: str) -> str:
    m = json.loads((folder / "o" / "manifest.json").read_text())
    times = [f["time"] for f in m["frames"]]
    if len(set(times)) != len(times):
        return "two frames of one step"
    if m.get("status") != "interrupted":
        return f"manifest status {m.get('status')!r}"
    return ""


# -- the probes ----------------------------------------------------------------------------------
def _stiffness_1() -> dict:
    return {
        "name": "wcsph-k1",
        "configuration": {
            "dim": 2,
            "particle_radius": 0.02,
            "time": {"until": 2.0, "dt": 0.02, "cfl": False},
            "pressure": {"method": "wcsph", "stiffness": 1.0, "acoustic_cfl": False},
        },
        "fluid_blocks": [{"start": [0.04, 0.04], "end": [0.44, 0.44]}],
        "boxes": [{"min": [0.0, 0.0], "max": [1.0, 1.0]}],
        "output": {"fps": 25},
    }


def _run_scene(
    data: dict | str, name: str = "scene.json", extra: tuple[str, ...] = ()
) -> Callable[[Path], list[str]]:
    def setup(folder: Path) -> list[str]:
        return ["run", _scene(folder, data, name), "--out", "o", *extra]

    return setup


def _junk_stl(folder: Path) -> list[str]:
    (folder / "junk.stl").write_bytes(np.random.default_rng(2).bytes(2000))
    return _run_scene(_with({"meshes": [{"geometry_file": "junk.stl"}]}))(folder)


def _out_is_a_file(folder: Path) -> list[str]:
    (folder / "o").write_text("a file where the output folder should be\n")
    return ["run", _scene(folder, TINY), "--out", "o", "--quiet"]


def probes() -> list[Probe]:
    inf, nan = float("inf"), float("nan")
    return [
        Probe(
            1,
            "YAML billion laughs, 9 levels (700 bytes)",
            _run_scene(laughs(9), "laughs.yaml"),
            2,
            ("laughs.yaml", "aliases"),
        ),
        Probe(
            1,
            "YAML billion laughs, 7 levels (the 39 MB error)",
            _run_scene(laughs(7), "laughs.yaml"),
            2,
            ("laughs.yaml", "aliases"),
        ),
        Probe(
            2,
            "output.fps: Infinity",
            _run_scene(_with({"output": {"fps": inf}})),
            2,
            ("output.fps",),
        ),
        Probe(2, "--fps 1e12", _run_scene(TINY, extra=("--fps", "1e12")), 2, ("--fps",)),
        Probe(
            2,
            "--fps 1e5 (accepted), SIGTERM once 20 frames are written",
            _run_scene(
                _with({"configuration": {"time": {"until": 100.0}}}), extra=("--fps", "1e5")
            ),
            143,
            ("terminated",),
            signal_after=0.0,
            signal_once=("o/frame_*.vtu", 20),
            signum=signal.SIGTERM,
            after=_frames_per_step,
        ),
        Probe(
            3,
            "particle_radius 1e-9 in a 1 m box",
            _run_scene(
                _with(
                    {
                        "configuration": {"particle_radius": 1e-9},
                        "fluid_blocks": [{"start": [0, 0], "end": [1, 1]}],
                        "boxes": [{"min": [0, 0], "max": [1, 1]}],
                    }
                )
            ),
            2,
            ("fluid_blocks[0]", "1e-09", "max-particles"),
        ),
        Probe(
            3,
            "--max-particles 20 (budget below the scene)",
            _run_scene(TINY, extra=("--max-particles", "20")),
            2,
            ("particle_radius",),
        ),
        Probe(
            4,
            "--resume, newest checkpoint truncated (falls back)",
            lambda f: _damaged(f, "truncated"),
            0,
            ("skipped",),
            after=_fell_back,
        ),
        Probe(
            4,
            "--resume, newest checkpoint empty (falls back)",
            lambda f: _damaged(f, "empty"),
            0,
            ("skipped",),
            after=_fell_back,
        ),
        Probe(
            4,
            "--resume, every checkpoint NaN positions",
            lambda f: _damaged(f, "nan"),
            2,
            ("NaN",),
            after=_newest_named,
        ),
        Probe(
            5,
            "WCSPH stiffness 1, fixed dt 0.02 s, CFL off",
            _run_scene(_stiffness_1()),
            3,
            ("CFL number", "configuration.max_cfl"),
        ),
        Probe(
            6,
            "particle_radius Infinity",
            _run_scene(_with({"configuration": {"particle_radius": inf}})),
            2,
            ("configuration.particle_radius",),
        ),
        Probe(
            6,
            "fluid block end [Infinity, 0.3]",
            _run_scene(_with({"fluid_blocks": [{"start": [0.1, 0.1], "end": [inf, 0.3]}]})),
            2,
            ("fluid_blocks[0].end[0]",),
        ),
        Probe(
            6,
            "gravity [NaN, -9.81]",
            _run_scene(_with({"configuration": {"gravity": [nan, -9.81]}})),
            2,
            ("configuration.gravity[0]",),
        ),
        Probe(
            6,
            "fluid block velocity [NaN, 0]",
            _run_scene(
                _with(
                    {
                        "fluid_blocks": [
                            {"start": [0.1, 0.1], "end": [0.3, 0.3], "velocity": [nan, 0.0]}
                        ]
                    }
                )
            ),
            2,
            ("fluid_blocks[0].velocity[0]",),
        ),
        Probe(
            6,
            "pressure.stiffness Infinity",
            _run_scene(
                _with({"configuration": {"pressure": {"method": "wcsph", "stiffness": inf}}})
            ),
            2,
            ("configuration.pressure.stiffness",),
        ),
        Probe(
            6,
            "SPlisHSPlasH particleRadius Infinity",
            _run_scene(
                {
                    "Configuration": {"particleRadius": inf, "simulationMethod": 0},
                    "FluidBlocks": [{"start": [0, 0, 0], "end": [0.2, 0.2, 0.2]}],
                }
            ),
            2,
            ("particleRadius",),
        ),
        *[
            Probe(
                7,
                f"Ctrl-C {t:g} s after start",
                _run_scene(_with({"configuration": {"time": {"until": 100.0}}})),
                130,
                ("interrupted",),
                signal_after=t,
            )
            for t in (0.02, 0.1, 0.2, 0.35, 0.5, 0.8, 1.5, 3.0)
        ],
        Probe(8, "random-bytes STL", _junk_stl, 2, ("junk.stl",)),
        Probe(
            8,
            "--resume, every checkpoint holds a pickled object array",
            lambda f: _damaged(f, "pickled"),
            2,
            ("pickled data",),
            after=_not_unpickled,
        ),
        Probe(
            8,
            "--resume, every checkpoint random bytes",
            lambda f: _damaged(f, "random"),
            2,
            (),
            after=_newest_named,
        ),
        Probe(
            8,
            "fluid block outside every box (warns, runs)",
            _run_scene(_with({"fluid_blocks": [{"start": [0.8, 0.1], "end": [0.9, 0.2]}]})),
            0,
            ("fluid_blocks[0]", "not inside any"),
        ),
        Probe(
            8,
            "two overlapping fluid blocks (warns, runs)",
            _run_scene(
                _with(
                    {
                        "fluid_blocks": [
                            {"start": [0.1, 0.1], "end": [0.3, 0.3]},
                            {"start": [0.2, 0.2], "end": [0.4, 0.4]},
                        ]
                    }
                )
            ),
            0,
            ("fluid_blocks[0] and fluid_blocks[1] overlap",),
        ),
        Probe(8, "--out is a file (output folder error)", _out_is_a_file, 1, ("output folder",)),
    ]


# -- running -------------------------------------------------------------------------------------
def measure(probe: Probe, folder: Path) -> Result:
    """Run the probe's command in a subprocess; exit code, wall time, peak RSS, stderr."""
    folder.mkdir(parents=True)
    args = probe.setup(folder)
    with open(folder / "stdout", "wb") as out, open(folder / "stderr", "wb") as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(
            [sys.executable, "-m", "sphkit", *args],
            stdout=out,
            stderr=err,
            env=_env(),
            cwd=folder,
            # as from a terminal: SIGINT not ignored (it is in background
            # jobs, which a script run with & would hand on)
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        )
        sent = probe.signal_after is None
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            elapsed = time.perf_counter() - t0
            if pid:
                break
            if (
                not sent
                and elapsed >= probe.signal_after
                and (
                    probe.signal_once is None
                    or len(list(folder.glob(probe.signal_once[0]))) >= probe.signal_once[1]
                )
            ):
                proc.send_signal(probe.signum)
                sent = True
            if elapsed > KILL_AFTER:
                proc.kill()
            time.sleep(0.005)
        proc.returncode = os.waitstatus_to_exitcode(status)
    text = (folder / "stderr").read_text(errors="replace")
    res = Result(probe, proc.returncode, elapsed, usage.ru_maxrss * 1024, text)
    if res.code != probe.expect:
        res.problems.append(f"exit {res.code}, expected {probe.expect}")
    if res.seconds >= SECONDS:
        res.problems.append(f"{res.seconds:.1f} s")
    if res.rss >= MEMORY:
        res.problems.append(f"{res.rss / 2**20:.0f} MB")
    if "Traceback" in text:
        res.problems.append("traceback")
    res.problems += [f"{w!r} not named" for w in probe.named if w not in text]
    if probe.signum == signal.SIGINT and "init_import_site" in text:
        # the signal landed while the interpreter imported ``site`` (its .pth files), before
        # the first line of sphkit's code or of the sphkit script: CPython's own start-up
        res.void = "landed in CPython's start-up (import of site), before sphkit's code"
        return res
    if probe.signum == signal.SIGINT and res.code == -signal.SIGINT and not text:
        # killed by the signal's default action: before the interpreter installed its own
        # handler (which it does before any Python code runs)
        res.void = "landed before the interpreter installed its SIGINT handler"
        return res
    if probe.after is not None:
        try:
            problem = probe.after(folder, text)
        except (OSError, ValueError, KeyError, IndexError) as e:
            problem = f"{type(e).__name__}: {e}"
        if problem:
            res.problems.append(problem)
    return res


def first_line(text: str) -> str:
    """The message's first line: an error's (with the next while one ends with ':'), else
    a warning's, else stderr's first line; cut to 150 characters."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    pick = next(
        (i for i, ln in enumerate(lines) if ln.startswith("sphkit") and ": error:" in ln), None
    )
    if pick is None:
        pick = next((i for i, ln in enumerate(lines) if "warning" in ln.lower()), 0)
    if not lines:
        return ""
    line = lines[pick]
    while line.endswith(":") and pick + 1 < len(lines):
        pick += 1
        line += " " + lines[pick]
    line = line.replace("|", "/")
    return line if len(line) <= 150 else line[:147] + "..."


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", type=int, help="run only the probes of this item (1-8)")
    p.add_argument("--show", action="store_true", help="print each probe's stderr")
    args = p.parse_args()
    base = Path(tempfile.mkdtemp(prefix="sphkit-hostile-"))
    results = []
    try:
        for k, probe in enumerate(probes()):
            if args.only is not None and probe.item != args.only:
                continue
            results.append(measure(probe, base / f"p{k:02d}"))
    finally:
        shutil.rmtree(base, ignore_errors=True)
    print("| # | input | exit (expected) | wall s | peak RSS MB | traceback | message | ok |")
    print("|---|---|---|---|---|---|---|---|")
    for r in results:
        ok = (
            "n/a: " + r.void
            if r.void
            else "yes"
            if not r.problems
            else "NO: " + "; ".join(r.problems)
        )
        print(
            f"| {r.probe.item} | {r.probe.label} | {r.code} ({r.probe.expect}) | "
            f"{r.seconds:.2f} | {r.rss / 2**20:.0f} | "
            f"{'yes' if 'Traceback' in r.stderr else 'no'} | `{first_line(r.stderr)}` | {ok} |"
        )
    failed = [r for r in results if r.problems and not r.void]
    void = sum(1 for r in results if r.void)
    print(
        f"\n{len(results) - len(failed) - void} of {len(results) - void} probes pass"
        + (f" ({void} void: the signal landed before sphkit's code)" if void else "")
    )
    if args.show:
        for r in results:
            print(f"\n--- {r.probe.label}: exit {r.code}\n{r.stderr[-3000:]}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
