#!/usr/bin/env bash
# The sanitizer build: the compiler, the runtime, their Python modules and
# the fuzz target, built with clang and AddressSanitizer +
# UndefinedBehaviorSanitizer (and libFuzzer's coverage), then the lit tests
# and the runtime's unit tests run on it. Any report fails the run.
# SANITIZE_DIR (default build-sanitize/), LLVM_PREFIX and JOBS override the
# defaults; `--build-only` stops after building (scripts/fuzz.sh uses it).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SANITIZE_DIR:-$root/build-sanitize}
llvm=${LLVM_PREFIX:-/usr/lib/llvm-22}

if [ ! -f "$build/build.ninja" ]; then
  # -O1: sanitized code at -O3 compiles much slower and runs barely faster.
  cmake -G Ninja -S "$root" -B "$build" \
    -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_C_FLAGS_RELEASE="-O1 -DNDEBUG" \
    -DCMAKE_CXX_FLAGS_RELEASE="-O1 -DNDEBUG" \
    -DCMAKE_C_COMPILER="$llvm/bin/clang" \
    -DCMAKE_CXX_COMPILER="$llvm/bin/clang++" \
    -DLLVM_USE_SANITIZER="Address;Undefined" \
    -DLLVM_USE_SANITIZE_COVERAGE=ON \
    -DMLIR_DIR="$llvm/lib/cmake/mlir" \
    -DLLVM_EXTERNAL_LIT="$llvm/bin/lit" \
    -DPython_EXECUTABLE="$(command -v python3)" >/dev/null
fi
targets=(yasps-opt yasps-fuzz YaspsRuntimeTests YaspsFakeCuda _yasps_compiler
  _yasps_runtime)
cmake --build "$build" --target "${targets[@]}" -- -j"${JOBS:-$(nproc)}"
[ "${1:-}" = "--build-only" ] && exit 0

# halt_on_error: a report is a failure, not a warning in a log. lit.cfg.py
# adds allow_user_poisoning=0 (why: see there).
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
echo "== sanitizers: lit and runtime unit tests (AddressSanitizer, UBSan)"
"$llvm/bin/lit" -q "$build/test" "$build/test/Unit"
