#!/usr/bin/env bash
# The device checks of a session lent a GPU, as prepared commands (the `device` tool's
# `run`; the machine has JAX with CUDA and jaxga's dependencies). Prepare here, once:
#
#   mkdir -p .carry/old
#   git archive b365ff4 jaxga presets | tar -x -C .carry/old   # the code before decision 040
#   echo /.carry/ >> .git/info/exclude                         # .carry is ignored by git
#
# then   run: bash benchmarks/gpu_session.sh diagnose     carry: [".carry"]
# and    run: bash benchmarks/gpu_session.sh verify launches speed   (then: calls)
# (each phase's time limit is below; decision 048 says what one H200 session took)
# (tried on a CPU: BISECT_RUNS="4 16" DOCTOR_PRESETS=sga SPEED_ARGS=--small CALLS_ARGS=--small
#  OUT=/tmp/o ...)
#
# diagnose, three processes at once (the GPU's memory is not preallocated; they compile
# on the host's cores side by side; no timing of theirs is reported):
#   1. the bisection (benchmarks/gpu_bisect.py) against the code before decision 040 (.carry/old):
#      each walk against the CPU's at 10, 256 and 2048 runs per call, one suspect
#      switched off at a time: which construct the GPU mis-executed;
#   2. the same bisection against the code as it is: the walks at 256 and 2048 runs per
#      call and the whole initialisation of 256 runs in one call, against the CPU;
#   3. jaxga doctor --quick (the exact probes: the gate's verdict), then jaxga doctor
#      with whole runs of a few presets.
# verify, three processes at once: jaxga doctor --quick, jaxga doctor with whole runs of a
#   few presets, and the whole initialisation of 2048 runs in one call against the CPU's.
# launches, alone on the machine: benchmarks/launches.py for 1000 sga runs on the 20 x 20
#   map: the kernels a generation runs on the GPU and its time, in the CPU's layout of the
#   folded loops and in the accelerators' (decision 049).
# speed, alone on the machine: benchmarks/device_check.py without the main job, on the
#   20 x 20 and 64 x 64 maps, with jaxga's runs initialised INIT_BLOCK at a time (default:
#   2048 when this session's doctor --quick agreed, else the platform's 10): the sweep of
#   16 x 1000 sga runs and the throughput table (the agreement too unless SPEED_SKIP
#   names it).
# calls, alone on the machine, after speed: the same sweep with jaxga's calls holding up
#   to MAX_RUNS (default 16384) runs, so 16 x 1000 runs are one call instead of 8 of 2048
#   (device_check.py --max-runs-per-call): whether larger calls than ACCELERATOR_BUCKETS'
#   reach the throughput the table's 10k-run calls show. Record it as the device check.
# Everything lands in $OUT; record the device check with
# `python benchmarks/device_check.py --from-json device_check.json`, the launches with
# `python benchmarks/launches.py --from-json launches.json`.
set -uo pipefail
export PYTHONUNBUFFERED=1 XLA_PYTHON_CLIENT_PREALLOCATE=false
OUT="${OUT:-$(mktemp -d)}"
PY="${PYTHON:-python3}"
HERE="$PWD"
exec > >(tee "$OUT/session_${1:-diagnose}.log") 2>&1
LOGS=$(mktemp -d)  # the logs join the session log (at most 8 files come back)
phase() { echo "=== $1 ($(date -u +%H:%M:%S))"; }
phase "devices"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null
PYTHONPATH="$HERE" "$PY" -c "import jax, jaxlib; print(jax.__version__, jaxlib.__version__, jax.devices())"
for mode in "${@:-diagnose}"; do
case "$mode" in
diagnose)
    phase "diagnose: three processes"
    ( PYTHONPATH="$HERE/.carry/old" timeout "${BISECT_S:-220}" "$PY" benchmarks/gpu_bisect.py \
        --runs ${BISECT_RUNS:-2048 256 10} --json "$OUT/bisect_old.json"
      echo "bisection (old code) exit status $?" ) > "$LOGS/bisect_old.log" 2>&1 &
    pids=($!)
    ( export PYTHONPATH="$HERE"
      timeout "$(( ${BISECT_S:-220} / 2 ))" "$PY" benchmarks/gpu_bisect.py \
        --runs ${BISECT_NEW_RUNS:-2048 256} --variants as_is field no_compaction full_init \
        --json "$OUT/bisect_new.json"
      echo "bisection (code as it is) exit status $?"
      timeout "$(( ${BISECT_S:-220} / 2 ))" "$PY" benchmarks/gpu_bisect.py \
        --runs ${BISECT_INIT_RUNS:-2048} --variants full_init --json "$OUT/bisect_init.json"
      echo "bisection (code as it is, whole initialisation) exit status $?" \
    ) > "$LOGS/bisect_new.log" 2>&1 &
    pids+=($!)
    ( export PYTHONPATH="$HERE" JAXGA_CACHE_DIR=/tmp/jaxga-cache
      timeout 70 "$PY" -m jaxga.cli doctor --quick --json "$OUT/doctor_quick.json"
      echo "doctor --quick exit status $?"
      timeout 150 "$PY" -m jaxga.cli doctor --presets "${DOCTOR_PRESETS:-sga,hybrid,iga_zhu}" \
          --json "$OUT/doctor.json"
      echo "doctor exit status $?" ) > "$LOGS/doctor.log" 2>&1 &
    pids+=($!)
    wait "${pids[@]}"  # not a bare wait: that waits for the tee above too, for ever
    for f in doctor bisect_old bisect_new; do echo "--- $f"; cat "$LOGS/$f.log"; done
    ;;
verify)
    phase "verify: three processes"
    ( export PYTHONPATH="$HERE" JAXGA_CACHE_DIR=/tmp/jaxga-cache
      timeout 40 "$PY" -m jaxga.cli doctor --quick --json "$OUT/doctor_quick.json"
      echo "doctor --quick exit status $?" ) > "$LOGS/doctor_quick.log" 2>&1 &
    pids=($!)
    ( export PYTHONPATH="$HERE" JAXGA_CACHE_DIR=/tmp/jaxga-cache-2
      timeout 120 "$PY" -m jaxga.cli doctor --presets "${DOCTOR_PRESETS:-sga,hybrid,iga_zhu}" \
          --json "$OUT/doctor.json"
      echo "doctor exit status $?" ) > "$LOGS/doctor.log" 2>&1 &
    pids+=($!)
    ( PYTHONPATH="$HERE" timeout 120 "$PY" benchmarks/gpu_bisect.py --runs ${BISECT_INIT_RUNS:-2048} \
        --variants as_is field full_init --json "$OUT/bisect_init.json"
      echo "whole initialisation exit status $?" ) > "$LOGS/bisect_init.log" 2>&1 &
    pids+=($!)
    wait "${pids[@]}"
    for f in doctor_quick doctor bisect_init; do echo "--- $f"; cat "$LOGS/$f.log"; done
    ;;
launches)
    phase "kernels per generation in both layouts"
    PYTHONPATH="$HERE" JAXGA_TRUST_DEVICE=1 timeout "${LAUNCHES_S:-150}" \
        "$PY" benchmarks/launches.py --presets sga --maps 20x20 --runs "${LAUNCHES_RUNS:-1000}" \
        --json "$OUT/launches.json" --no-write
    echo "launches exit status $?"
    ;;
speed)
    phase "device check"
    if [ -z "${INIT_BLOCK:-}" ]; then
        INIT_BLOCK=$("$PY" -c "import json, sys; print(2048 if json.load(open(sys.argv[1]))['agrees'] else 10)" \
            "$OUT/doctor_quick.json" 2>/dev/null || echo 10)
    fi
    INIT_BLOCK=${INIT_BLOCK:-10}
    echo "runs initialised $INIT_BLOCK at a time"
    PYTHONPATH="$HERE" JAXGA_TRUST_DEVICE=1 timeout "$(( ${SPEED_BUDGET_S:-330} + 30 ))" \
        "$PY" benchmarks/device_check.py --json "$OUT/device_check.json" --no-write \
        --budget-s "${SPEED_BUDGET_S:-330}" --skip "${SPEED_SKIP:-main_job}" \
        --maps 20x20,64x64 --init-block "$INIT_BLOCK" ${SPEED_ARGS:-}
    echo "device check exit status $?"
    ;;
calls)
    phase "the sweep in calls of up to ${MAX_RUNS:-16384} runs"
    PYTHONPATH="$HERE" JAXGA_TRUST_DEVICE=1 timeout "${CALLS_S:-200}" \
        "$PY" benchmarks/device_check.py --json "$OUT/device_check_calls.json" --no-write \
        --skip main_job,agreement,throughput --max-runs-per-call "${MAX_RUNS:-16384}" \
        --init-block "${INIT_BLOCK:-2048}" ${CALLS_ARGS:-}
    echo "device check (calls) exit status $?"
    ;;
*)
    echo "unknown mode $mode (diagnose, verify, launches, speed, calls)"
    ;;
esac
done
phase "done"
