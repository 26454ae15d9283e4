#!/usr/bin/env bash
# The device checks of a session lent a GPU, as ONE prepared command (the `device` tool's
# `run`, timeout_s 590; the machine has JAX with CUDA and jaxga's dependencies):
#
#   mkdir -p .carry && cp ../shared/tools/gpu_bisect.py .carry/   # here, once; .carry is
#   echo /.carry/ >> .git/info/exclude                             # ignored by git
#   run: bash benchmarks/gpu_session.sh          carry: [".carry"]
#   (tried on a CPU: DEVICE_CHECK_ARGS=--small OUT=/tmp/o bash benchmarks/gpu_session.sh)
#
# In order, each bounded so that the later phases still run:
#   1. jaxga doctor --json: the exact probes (random bits; sga's and the field walk's walks,
#      2048 runs in one call) and whole runs of every preset against the CPU (docs/devices.md);
#   2. the bisection (gpu_bisect.py, when carried): each walk against the CPU's at 10, 256
#      and 2048 runs per call, one suspect switched off at a time;
#   3. the device check (benchmarks/device_check.py): the README's job, the agreement, the
#      sweep and the throughput table.
# Everything lands in $OUT (doctor.json, bisect.json, device_check.json, session.log); record
# them here with `python benchmarks/doctor.py`-style sections or
# `python benchmarks/device_check.py --from-json device_check.json`.
set -uo pipefail
export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
OUT="${OUT:-$(mktemp -d)}"
PY="${PYTHON:-python3}"
exec > >(tee "$OUT/session.log") 2>&1
phase() { echo "=== $1 ($(date -u +%H:%M:%S))"; }
phase "devices"
"$PY" -c "import jax, jaxlib; print(jax.__version__, jaxlib.__version__, jax.devices())"
phase "jaxga doctor"
JAXGA_CACHE_DIR=/tmp/jaxga-cache timeout 200 "$PY" -m jaxga.cli doctor \
    --json "$OUT/doctor.json"
echo "doctor exit status $?"
if [ -f .carry/gpu_bisect.py ]; then
    phase "bisection"
    timeout 170 "$PY" .carry/gpu_bisect.py --runs 10 256 2048 --json "$OUT/bisect.json"
    echo "bisection exit status $?"
fi
phase "device check"
timeout 200 "$PY" benchmarks/device_check.py --json "$OUT/device_check.json" --no-write \
    --budget-s 180 ${DEVICE_CHECK_ARGS:-}
echo "device check exit status $?"
phase "done"
