#!/usr/bin/env bash
# The test command: installs what is missing, builds, and runs every test
# (lit/FileCheck compiler tests, runtime unit tests, the type checker, Python
# tests), then the robustness checks: the same lit and unit tests in the
# sanitizer build (ASan + UBSan), the GPU solver's unit tests under
# ThreadSanitizer, the Python tests of inputs and values on the ASan build's
# extensions, and a bounded fuzz run (docs/robustness.md). FUZZ_SECONDS (default 120)
# bounds the fuzz run; 0 skips it.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build}
sanitize=${SANITIZE_DIR:-$root/build-sanitize}

bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"

echo "== lit: compiler and runtime unit tests"
cmake --build "$build" --target check-yasps

echo "== mypy: the package's types"
# pyproject.toml's [tool.mypy] names the package and the settings.
(cd "$root" && python3 -m mypy)

echo "== pytest: Python package"
# One pytest worker per core (pytest-xdist; PYTEST_WORKERS overrides): a
# test keeps about one core busy, so on two cores the suite took 9.8 min
# instead of 18.2. Workers share the kernel cache (its writes are atomic);
# worksteal evens out the long scene tests.
YASPS_BUILD_DIR="$build" python3 -m pytest -q -n "${PYTEST_WORKERS:-$(nproc)}" \
  --dist worksteal "$root/python/tests"

bash "$root/scripts/sanitize.sh"
bash "$root/scripts/tsan.sh"

echo "== pytest under the sanitizers: inputs, values and errors"
# The extensions of the sanitizer build need the ASan runtime loaded first;
# allocator_may_return_null lets a refused huge allocation reach numpy as
# MemoryError, as without ASan (test_errors checks what yasps makes of it).
# use_sigaltstack=0: LLVM gives a thread that compiles its own, larger
# signal stack where CPUs need more room for the signal frame (seen on AMD
# EPYC hosts), and ASan then fails to unmap it, as its own, when that
# thread exits ("failed to deallocate ... unable to unmmap").
YASPS_BUILD_DIR="$sanitize" YASPS_CACHE_DIR=off \
  LD_PRELOAD="$("${LLVM_PREFIX:-/usr/lib/llvm-22}/bin/clang" -print-file-name=libclang_rt.asan-x86_64.so)" \
  ASAN_OPTIONS=allow_user_poisoning=0:detect_leaks=0:allocator_may_return_null=1:halt_on_error=1:use_sigaltstack=0 \
  UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
  python3 -m pytest -q -p no:cacheprovider -n "${PYTEST_WORKERS:-$(nproc)}" \
  "$root/python/tests/test_errors.py" \
  "$root/python/tests/test_values.py" "$root/python/tests/test_compute.py"

if [ "${FUZZ_SECONDS:-120}" != 0 ]; then
  bash "$root/scripts/fuzz.sh" "${FUZZ_SECONDS:-120}"
fi
