#!/usr/bin/env bash
# The GPU solver's unit tests under ThreadSanitizer: the runtime's tests and
# the stand-in driver built with clang -fsanitize=thread, then every
# GpuSystemTest on the stand-in, its blocks phase by phase, as fibers (each
# a thread to ThreadSanitizer, ordered only by the barriers: FiberBlock.h)
# and, for the kernels that add atomically, as OS threads (OsThreadTeam.h).
# Any report fails the run. Then the check that this catches something: a
# solve whose yasps_dot skips a barrier must be reported as a data race.
# TSAN_DIR (default build-tsan/), LLVM_PREFIX and JOBS override the defaults.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${TSAN_DIR:-$root/build-tsan}
llvm=${LLVM_PREFIX:-/usr/lib/llvm-22}

if [ ! -f "$build/build.ninja" ]; then
  cmake -G Ninja -S "$root" -B "$build" \
    -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_C_FLAGS_RELEASE="-O1 -DNDEBUG" \
    -DCMAKE_CXX_FLAGS_RELEASE="-O1 -DNDEBUG" \
    -DCMAKE_C_COMPILER="$llvm/bin/clang" \
    -DCMAKE_CXX_COMPILER="$llvm/bin/clang++" \
    -DLLVM_USE_SANITIZER=Thread \
    -DMLIR_DIR="$llvm/lib/cmake/mlir" \
    -DLLVM_EXTERNAL_LIT="$llvm/bin/lit" \
    -DPython_EXECUTABLE="$(command -v python3)" >/dev/null
fi
cmake --build "$build" --target YaspsRuntimeTests YaspsFakeCuda \
  -- -j"${JOBS:-$(nproc)}"
tests="$build/runtime/test/YaspsRuntimeTests"

echo "== ThreadSanitizer: the GPU solver's tests on the stand-in driver"
TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1 "$tests" --gtest_brief=1 \
  --gtest_filter='Drivers/GpuSystemTest.*:CudaDriver.*:GpuLaunch.*'

echo "== ThreadSanitizer: a missing barrier is reported"
log=$(mktemp)
# halt_on_error=1: the first report is the dot's race, and the run stops
# there (run to its end, reporting every race of the solve, it took 4.4 min
# of the test command on two cores).
if TSAN_OPTIONS=halt_on_error=1:exitcode=66 "$tests" \
    --gtest_filter='StandIns/StandInBarrierTest.*/StandInFibers' >"$log" 2>&1; then
  cat "$log"
  echo "FAILED: a solve with a barrier left out ran without a report"
  exit 1
fi
if ! grep -q "WARNING: ThreadSanitizer: data race" "$log" ||
   ! grep -q "dotBody" "$log"; then
  cat "$log"
  echo "FAILED: the run failed, but not with a data race in yasps_dot"
  exit 1
fi
rm -f "$log"
echo "ok: reported as a data race in yasps_dot"
