"""Every kernel the GPU path launches, compiled for a real GPU on a machine without one.

    python validation/cuda_compile.py --site DIR [--cc 9.0] [--quick] [--records FILE]

The CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, the CI's GPU check) runs device functions as
Python: it does not type them, so code that Numba compiles on the CPU but numba-cuda cannot type
passes there and fails on the first real GPU (on an H200 on 2026-12-04: numba-cuda 0.30 does not
prune an ``isinstance`` branch, and every pair body failed with ``getitem(float64, 0)``). This
script closes that gap before a GPU is lent:

1. under the simulator, it runs the device-agreement check (every solver, 27 particles, one
   step), ``benchmarks/gpu.py`` (60 particles, one whole step) and, unless ``--quick``, the
   script of ``tests/test_cuda_simulator.py`` (maps, Weiler 2018, surface tension, vorticity,
   emitters), and records each launch's body and argument types (``sphkit.backend.cuda``'s
   ``launch`` and ``launch_reduce``);
2. in a second process without the simulator, with numba-cuda from ``--site`` (a folder that
   ``pip install --target`` filled: numba-cuda of the GPU machine's version, cuda-bindings,
   cuda-core, cuda-pathfinder, nvidia-nvvm and nvidia-cuda-nvrtc; see benchmarks/README.md,
   "gpu_session.sh"), it builds each kernel as :func:`sphkit.backend.cuda.kernel_for` does and
   compiles it to PTX for compute capability ``--cc`` (no driver needed: the device's compute
   capability is given).

It prints one line per distinct launch and exits 1 when any fails to compile.
"""

from __future__ import annotations

import argparse
import os
import pickle
import runpy
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def record(out: str, target: list[str]) -> None:
    """Run ``target`` (a script and its arguments, or ``-c CODE``) under the simulator and append
    each distinct launch (module, qualified name, reduce, argument types) to ``out``."""
    import numba

    import sphkit.backend.cuda as bc

    seen: set = set()

    def note(body, args, reduce: bool) -> None:  # noqa: ANN001
        types = tuple(numba.typeof(getattr(a, "_ary", a)) for a in args)
        key = (body.py_func.__module__, body.py_func.__qualname__, reduce, types)
        if key not in seen:
            seen.add(key)
            with open(out, "ab") as fh:
                pickle.dump(key, fh)

    launch, launch_reduce = bc.launch, bc.launch_reduce

    def each(body, n, args):  # noqa: ANN001, ANN202
        note(body, args, False)
        return launch(body, n, args)

    def reduced(body, n, args):  # noqa: ANN001, ANN202
        note(body, args, True)
        return launch_reduce(body, n, args)

    bc.launch, bc.launch_reduce = each, reduced
    if target[0] == "-c":
        sys.argv = ["-c", *target[2:]]
        exec(compile(target[1], "<script>", "exec"), {"__name__": "__main__"})  # noqa: S102
    else:
        sys.argv = list(target)
        try:
            runpy.run_path(target[0], run_name="__main__")
        except SystemExit:
            pass


def compile_all(records: str, site: str, cc: tuple[int, int]) -> int:
    """Compile every recorded launch to PTX with the numba-cuda of ``site``; the failures."""
    import importlib
    import site as site_mod
    import types as pytypes

    site_mod.addsitedir(site)
    import numba
    import numba.cuda.dispatcher as disp
    from numba.cuda import compile_ptx

    import sphkit.backend.cuda as bc

    # device functions ask the current device for its compute capability: there is none here
    disp.get_current_device = lambda: pytypes.SimpleNamespace(compute_capability=cc)
    recs = []
    with open(records, "rb") as fh:
        while True:
            try:
                recs.append(pickle.load(fh))
            except EOFError:
                break
    recs = list(dict.fromkeys(recs))
    bad = 0
    for mod, qual, reduce, types in recs:
        body = importlib.import_module(mod)
        for part in qual.split("."):
            body = getattr(body, part)
        kern = bc.kernel_for(body, len(types), reduce)
        sig = (numba.int64,) + ((numba.float64[::1],) if reduce else ()) + tuple(types)
        try:
            compile_ptx(kern.py_func, sig, cc=cc)
        except Exception as e:  # noqa: BLE001 - report every failure, then go on
            bad += 1
            msg = " | ".join(ln.strip() for ln in str(e).splitlines() if ln.strip())
            print(f"FAIL {mod}.{qual}{' (reduce)' if reduce else ''}: {msg[:800]}")
        else:
            print(f"ok   {mod}.{qual}{' (reduce)' if reduce else ''}")
    print(f"{len(recs)} distinct launches compiled for sm_{cc[0]}{cc[1]} with numba-cuda "
          f"from {site}: {bad} failed")
    return bad


def main(argv: list[str] | None = None) -> int:
    """Record under the simulator, then compile; exit 1 on a failure, 2 on a bad ``--site``."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--site", required=True, help="folder with numba-cuda and NVVM/NVRTC wheels "
                    "installed (pip install --target)")
    ap.add_argument("--cc", default="9.0", help="compute capability (9.0: H100/H200)")
    ap.add_argument("--quick", action="store_true",
                    help="skip the simulator test's script (5 minutes on two cores)")
    ap.add_argument("--records", help="keep the records in this file (default: a temporary one)")
    ap.add_argument("--_record", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    ap.add_argument("--_compile", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    try:
        cc = tuple(int(v) for v in args.cc.split("."))
        assert len(cc) == 2
    except (ValueError, AssertionError):
        print(f"--cc: {args.cc!r}; expected MAJOR.MINOR, e.g. 9.0")
        return 2
    if args._record:
        record(args.records, args._record)
        return 0
    if args._compile:
        return 1 if compile_all(args._compile, args.site, cc) else 0
    if not (Path(args.site) / "numba_cuda").is_dir():
        print(f"--site: {args.site!r} holds no numba_cuda; expected a folder filled by "
              "pip install --target (benchmarks/README.md, gpu_session.sh)")
        return 2
    records = args.records or tempfile.mktemp(suffix=".pkl")
    Path(records).unlink(missing_ok=True)
    sim = dict(os.environ, NUMBA_ENABLE_CUDASIM="1",
               PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    me = [sys.executable, __file__, "--site", args.site, "--records", records, "--_record"]
    runs = [[str(ROOT / "validation" / "device_agreement.py"), "--radius", "0.05", "--steps", "1"],
            [str(ROOT / "benchmarks" / "gpu.py"), "--sizes", "60", "--cpu-size", "0",
             "--repeat", "1", "--steps", "1"]]
    if not args.quick:
        sys.path.insert(0, str(ROOT / "tests"))
        from test_cuda_simulator import SCRIPT

        # the script checks that the CPU path alone does not import numba.cuda: here it is
        code = SCRIPT.replace('assert "numba.cuda" not in sys.modules', 'assert True or sys')
        runs.append(["-c", code])
    for run in runs:
        res = subprocess.run(me + run, env=sim, capture_output=True, text=True)
        if res.returncode != 0:
            print(f"recording {run[0]} failed:\n{res.stdout[-2000:]}{res.stderr[-2000:]}")
            return 1
        print(f"recorded {Path(run[0]).name if run[0] != '-c' else 'the simulator test'}")
    real = {k: v for k, v in sim.items() if k != "NUMBA_ENABLE_CUDASIM"}
    lib = Path(args.site) / "nvidia" / "cu13" / "lib"
    if lib.is_dir():  # NVVM and NVRTC of the pip wheels
        real["LD_LIBRARY_PATH"] = os.pathsep.join([str(lib), real.get("LD_LIBRARY_PATH", "")])
    res = subprocess.run([sys.executable, __file__, "--site", args.site, "--cc", args.cc,
                          "--_compile", records], env=real, text=True)
    return res.returncode


if __name__ == "__main__":
    sys.exit(main())
