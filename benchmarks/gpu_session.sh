#!/usr/bin/env bash
# Issue 18's checks on a lent GPU machine, as one prepared run (the lease is minutes):
#
#   OUT=/some/folder bash benchmarks/gpu_session.sh
#
# 1. the machine (nvidia-smi, the CPU, the Python packages);
# 2. in the background, pinned to two other cores: the CPU rows of benchmarks/gpu.py at
#    CPU_SIZE particles with two threads (passes and whole DFSPH steps: the ratio's denominator);
# 3. whole DFSPH steps on the GPU at SIZES particles (benchmarks/gpu.py --no-passes);
# 4. validation/device_agreement.py (every solver, GPU float32 against CPU float64; the walls'
#    default MLS boundary pressure: the mirrored one was checked on an H200 on 2026-12-04);
# 5. the per-pass timings on the GPU at SIZES (benchmarks/gpu.py);
# 6. the real-GPU test of tests/test_cuda_simulator.py.
# Every part writes its JSON and log under $OUT as it goes and has its own time limit, so a run
# cut short keeps what finished. Python wheels the image lacks (or must have in another version:
# numpy < 2.5) are installed from .whl/ when that folder exists (see benchmarks/README.md).
# Under NUMBA_ENABLE_CUDASIM=1 with small sizes it checks itself:
#   NUMBA_ENABLE_CUDASIM=1 TMUL=5 SIZES=60 CPU_SIZE=300 STEPS=2 AGREE="--radius 0.05 --steps 3" \
#     WHEELS=0 OUT=/tmp/gs bash benchmarks/gpu_session.sh
set -u -o pipefail
OUT=${OUT:-/tmp/gpu_session}
SIZES=${SIZES:-1e6 4e6 16e6}
CPU_SIZE=${CPU_SIZE:-1e6}
STEPS=${STEPS:-10}
AGREE=${AGREE:-}
# options of the whole steps (GPU and CPU rows), e.g. "--depth 0.4 --warmup 20": a column of one
# depth at every size, timed after the start's saturated steps (benchmarks/README.md)
STEPS_ARGS=${STEPS_ARGS:-}
PY=${PY:-python3}
TMUL=${TMUL:-1}  # a multiplier of every time limit (the simulator is slow)
t() { echo $(( $1 * TMUL )); }
mkdir -p "$OUT"
export PYTHONUNBUFFERED=1 NUMBA_CUDA_LOW_OCCUPANCY_WARNINGS=0
if [ "${WHEELS:-1}" = 1 ] && [ -d .whl ] && ls .whl/*.whl > /dev/null 2>&1; then
  "$PY" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl || exit 1
  export PYTHONPATH=/tmp/site:$PWD/src
else
  export PYTHONPATH=$PWD/src${PYTHONPATH:+:$PYTHONPATH}
fi
ncpu=$(nproc)
pin() {  # pin <cores> <command...>: taskset where it exists
  local cores=$1; shift
  if command -v taskset > /dev/null && [ "$ncpu" -ge 10 ]; then taskset -c "$cores" "$@"; else "$@"; fi
}
{
  date -u
  nvidia-smi --query-gpu=name,memory.total,driver_version,clocks.max.sm,clocks.max.mem \
    --format=csv 2> /dev/null || echo "no nvidia-smi"
  grep -m1 "model name" /proc/cpuinfo; echo "cores: $ncpu"
  "$PY" -c "import sys, numpy, numba; print(sys.version.split()[0], 'numpy', numpy.__version__, 'numba', numba.__version__)"
  "$PY" -c "import importlib.metadata as m; print('numba-cuda', m.version('numba-cuda'))" 2> /dev/null
  "$PY" -c "from sphkit.backend import cuda_available; print('cuda_available', cuda_available())"
} 2>&1 | tee "$OUT/machine.txt"

# the CPU rows beside the GPU's, on cores 8-9 (the GPU's process keeps to cores 0-7)
( NUMBA_NUM_THREADS=2 pin 8,9 timeout $(t 400) "$PY" benchmarks/gpu.py --only cpu \
    --cpu-size "$CPU_SIZE" --steps "$STEPS" $STEPS_ARGS --repeat 3 --json "$OUT/cpu.json" \
    > "$OUT/cpu.log" 2>&1; echo "rc $?" >> "$OUT/cpu.log" ) &

gpu() { NUMBA_NUM_THREADS=8 pin 0-7 "$@"; }
echo "== whole steps"
# shellcheck disable=SC2086
gpu timeout $(t 200) "$PY" benchmarks/gpu.py --only cuda --no-passes --sizes $SIZES --steps "$STEPS" $STEPS_ARGS \
  --json "$OUT/steps.json" 2>&1 | tee -a "$OUT/session.log"; echo "rc $?"
echo "== agreement"
# shellcheck disable=SC2086
gpu timeout $(t 130) "$PY" validation/device_agreement.py --boundary-pressure mls $AGREE \
  --json "$OUT/agree.json" 2>&1 \
  | tee -a "$OUT/session.log"; echo "rc $?"
echo "== passes"
# shellcheck disable=SC2086
gpu timeout $(t 50) "$PY" benchmarks/gpu.py --only cuda --sizes $SIZES --json "$OUT/passes.json" 2>&1 \
  | tee -a "$OUT/session.log"; echo "rc $?"
echo "== real-GPU test"
gpu timeout $(t 100) "$PY" -m pytest -q -n 0 -p no:cacheprovider tests/test_cuda_simulator.py \
  -k on_gpu 2>&1 | tail -5 | tee -a "$OUT/session.log"; echo "rc $?"
wait
echo "== CPU rows"
cat "$OUT/cpu.log"
