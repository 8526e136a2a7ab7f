#!/usr/bin/env bash
# The GPU checks that run without MLIR or the Python extension, on a GPU
# machine (docs/gpu.md, "On a GPU machine"): the runtime's unit tests with
# the real driver (GPU solve against the CPU), the SpMV/PCG benchmark on
# the bunny, cuSPARSE (through PyTorch) on the same matrix, stable
# Neo-Hookean's generated derivative kernels against PyTorch and JAX, one
# Newton iteration of the bunny scene on the GPU, in stages, and the
# real-driver tests again under compute-sanitizer (racecheck, synccheck,
# memcheck: the races, barrier misuse and out-of-range accesses that the
# stand-in driver of CI cannot show).
#
#   bash scripts/device_check.sh [--dry-run] KIT [OUT]
#
# --dry-run runs the whole script here, without a GPU, on the stand-in
# driver of the runtime's tests (the kit's libYaspsFakeCuda.so): the same
# steps, limits, summary and archive. What the stand-in cannot run is
# marked in the summary: the generated kernels (it launches them but
# computes nothing, so their checks are off), the peers (PyTorch and JAX
# on a GPU) and compute-sanitizer.
#
# KIT is what scripts/device_kit.sh gathered; logs go to OUT (default: the
# current folder): summary.txt (each step's status and time, then the
# measured lines) and logs.tar.gz, which replaces the single logs at the
# end (a run cut short leaves them as they are). A GPU window is short, so no step can
# cost the others: each has a time limit (STEP_LIMIT seconds, default 150),
# each log is written as it is produced, and a failed step is recorded and
# the next one runs. A missing or unusable driver, a failed check and a
# real-driver test that skips are failures (exit status 1).
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
dry=0
if [ "${1:-}" = --dry-run ]; then
  dry=1
  shift
fi
kit=$(cd "$1" && pwd)
out=$(mkdir -p "${2:-.}" && cd "${2:-.}" && pwd)
limit=${STEP_LIMIT:-150}
summary=$out/summary.txt
status=0
: >"$summary"

# step NAME LOG COMMAND...: runs COMMAND under the time limit, its output
# shown and kept in OUT/LOG, and records its status and time.
step() {
  local name=$1 log=$out/$2
  shift 2
  echo "== $name"
  local start=$SECONDS
  timeout --kill-after=10 "$limit" "$@" 2>&1 | tee "$log"
  local rc=${PIPESTATUS[0]}
  local verdict=ok
  if [ "$rc" = 124 ] || [ "$rc" = 137 ]; then
    verdict="TIMED OUT after ${limit} s"
  elif [ "$rc" != 0 ]; then
    verdict="FAILED (exit $rc)"
  fi
  [ "$verdict" = ok ] || status=1
  printf '%-44s %-24s %4d s\n' "$name" "$verdict" $((SECONDS - start)) \
    >>"$summary"
}

# skipped NAME WHY: a step a dry run leaves out, in the summary.
skipped() {
  echo "== $1: skipped ($2)"
  printf '%-44s %s\n' "$1" "skipped in a dry run: $2" >>"$summary"
}

# in_kit FILE NAME: whether the kit holds FILE (scripts/device_kit.sh's
# KIT_PARTS); if not, the step NAME is recorded as not in the kit.
in_kit() {
  [ -e "$kit/$1" ] && return 0
  echo "== $2: not in the kit"
  printf '%-44s %s\n' "$2" "not in the kit" >>"$summary"
  return 1
}

if [ $dry = 1 ]; then
  # The stand-in plays the real driver too: every "ThisMachine" test runs.
  export YASPS_CUDA_LIBRARY="$kit/libYaspsFakeCuda.so"
  echo "dry run: the stand-in driver, no GPU" | tee "$out/gpu.log"
  cat "$out/gpu.log" >>"$summary"
fi

if [ $dry = 0 ]; then
  if ! nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv \
    >"$out/gpu.log" 2>&1; then
    echo "no usable NVIDIA driver (nvidia-smi failed)" | tee -a "$out/gpu.log"
    status=1
  fi
  cat "$out/gpu.log"
  cat "$out/gpu.log" >>"$summary"
fi

if in_kit YaspsRuntimeTests "runtime unit tests (stand-in and real driver)"; then
  # A dry run takes the GPU's tests on the plain stand-in alone (1 s): the
  # test command's lit runs them all, the stand-in on fibers (43 s) under
  # ThreadSanitizer too; the whole suite took 98 s of the test command.
  gtest_args=()
  [ $dry = 1 ] && gtest_args=(
    --gtest_filter='Drivers/GpuSystemTest.*/StandIn:CudaDriver.*:GpuLaunch.*')
  step "runtime unit tests (stand-in and real driver)" gtest.log \
    env YASPS_FAKE_CUDA="$kit/libYaspsFakeCuda.so" "$kit/YaspsRuntimeTests" \
    "${gtest_args[@]}"
  # The real-driver instances must run: a skip means the GPU was not used.
  skipped=$(grep -cE "^\[  SKIPPED \] .*ThisMachine" "$out/gtest.log")
  if [ "$skipped" != 0 ]; then
    printf '%-44s %s\n' "real-driver tests skipped" \
      "FAILED ($skipped skipped)" >>"$summary"
    status=1
  fi

  step "SpMV, assembly and PCG on the bunny" spmv.log \
    "$kit/yasps-spmv-bench" "$kit/bunny-19k.msh" --repeat 100 \
    --export /tmp/yasps-bunny-hessian
  ms=$(awk '/GPU SpMV/ {print $3}' "$out/spmv.log")

  # The stand-in runs the kernels' host images one thread after another:
  # their values are checked as on a GPU, their timings mean nothing.
  kernel_repeat=100
  if [ $dry = 1 ]; then
    kernel_repeat=1
    skipped "cuSPARSE on the same matrix" "cuSPARSE needs a GPU"
  else
    step "cuSPARSE on the same matrix" cusparse.log \
      python3 "$root/bench/gpu_cusparse.py" /tmp/yasps-bunny-hessian \
      ${ms:+--yasps-ms "$ms"}
  fi

  step "stable Neo-Hookean kernels (yasps)" kernels.log \
    "$kit/yasps-kernel-bench" "$kit/snh" --repeat "$kernel_repeat"

  if [ $dry = 1 ]; then
    skipped "stable Neo-Hookean with PyTorch and JAX" "the peers need a GPU"
  else
    step "stable Neo-Hookean with PyTorch and JAX" peers.log \
      python3 "$root/bench/gpu_peers.py" "$kit/snh" \
      --yasps-log "$out/kernels.log"
  fi

  step "one Newton iteration of the bunny, in stages" newton.log \
    "$kit/yasps-newton-bench" "$kit/newton"
fi

# Whole simulations: the runtime-only build of the Python package (no LLVM
# or MLIR) from the kit's sources, the wheels this Python lacks, then the
# kit's scenes from its kernel store on the GPU and, beside them, on the
# CPU (bench/device_sim.py). A dry run takes the demo's first frames on
# the stand-in driver and this machine's own packages.
work=${WORK_DIR:-$(mktemp -d)}
python=$(command -v python3)
if in_kit store "whole simulations (GPU beside CPU)"; then
step "runtime-only build (no LLVM or MLIR)" runtime_build.log \
  bash -c "cmake -S '$kit/src' -B '$work/build' -G Ninja \
    -DYASPS_RUNTIME_ONLY=ON -DPython_EXECUTABLE='$python' >/dev/null &&
    cmake --build '$work/build'"
if [ $dry = 0 ] && ls "$kit"/wheels/*.whl >/dev/null 2>&1; then
  step "wheels the machine lacks" wheels.log \
    "$python" -m pip install --no-index --no-deps --target "$work/site" \
    "$kit"/wheels/*.whl
fi
sim_frames=${SIM_FRAMES:-100}
sim_limit=${SIM_LIMIT:-60}
sim_options=
# A dry run solves tightly, so that the stand-in's positions compare with
# the CPU's to round-off (at the default tolerances the two backends' PCG
# sums in other orders take Newton to points a tolerance apart).
[ $dry = 1 ] && sim_frames=${SIM_FRAMES:-2} && sim_options=--tight
scenes=$(cat "$kit/store/scenes.txt" 2>/dev/null || echo demo)
# Each scene runs twice (GPU, CPU), each at most sim_limit seconds of
# stepping plus its start.
limit=$(( $(echo $scenes | wc -w) * 2 * (sim_limit + 120) ))
step "whole simulations (GPU beside CPU)" sim.log \
  env YASPS_BUILD_DIR="$work/build" YASPS_DATA_DIR="$kit" \
  PYTHONPATH="$kit/src/python:$work/site" \
  "$python" "$kit/src/bench/device_sim.py" run "$kit/store" \
  --scenes $scenes --frames "$sim_frames" --limit "$sim_limit" $sim_options \
  --json "$out/sim.json"
limit=${STEP_LIMIT:-150}
fi

sanitizer=$(command -v compute-sanitizer ||
  ls /usr/local/cuda/bin/compute-sanitizer 2>/dev/null)
if [ $dry = 1 ]; then
  skipped "real-driver tests under compute-sanitizer" "it needs a GPU"
elif [ ! -e "$kit/YaspsRuntimeTests" ]; then
  printf '%-44s %s\n' "real-driver tests under compute-sanitizer" \
    "not in the kit" >>"$summary"
elif [ -n "$sanitizer" ]; then
  # racecheck is the slow one: about 250 s on an H200 (138 s of it in
  # SolvesLikeTheCpu), against 6 s for synccheck and 74 s for memcheck.
  for tool in synccheck memcheck racecheck; do
    [ "$tool" = racecheck ] && limit=${RACECHECK_LIMIT:-400}
    step "real-driver tests under $tool" "$tool.log" \
      "$sanitizer" --tool "$tool" --error-exitcode 3 \
      "$kit/YaspsRuntimeTests" --gtest_filter='*ThisMachine*'
  done
else
  printf '%-44s %s\n' "compute-sanitizer" "FAILED (not found)" >>"$summary"
  status=1
fi

{
  echo
  echo "== measured"
  grep -hE "ms|GB/s|within|iterations|FAILED|differs" \
    "$out/spmv.log" "$out/cusparse.log" "$out/kernels.log" \
    "$out/peers.log" "$out/newton.log" 2>/dev/null
  grep -hE "^sim |^  [0-9]+ Newton iterations" "$out/sim.log" 2>/dev/null
  grep -hE "^\[  (PASSED|FAILED) |ERROR SUMMARY|RACECHECK SUMMARY" \
    "$out"/gtest.log "$out"/racecheck.log "$out"/synccheck.log \
    "$out"/memcheck.log 2>/dev/null
} >>"$summary"
echo
cat "$summary"
logs=$(cd "$out" && ls *.log *.json 2>/dev/null)
tar -czf "$out/logs.tar.gz" -C "$out" $logs && (cd "$out" && rm -f $logs)
exit $status
