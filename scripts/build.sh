#!/usr/bin/env bash
# Configures (once) and builds yasps. BUILD_DIR (default build/), LLVM_PREFIX
# (default /usr/lib/llvm-22) and JOBS override the defaults.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build}
llvm=${LLVM_PREFIX:-/usr/lib/llvm-22}

if [ ! -f "$build/build.ninja" ]; then
  cmake -G Ninja -S "$root" -B "$build" \
    -DCMAKE_BUILD_TYPE=Release \
    -DMLIR_DIR="$llvm/lib/cmake/mlir" \
    -DLLVM_EXTERNAL_LIT="$llvm/bin/lit" \
    -DPython_EXECUTABLE="$(command -v python3)"
fi
cmake --build "$build" -- -j"${JOBS:-$(nproc)}"

# `import yasps` from any folder: this checkout's python/ goes on the
# interpreter's path (a .pth file in its site-packages).
python3 "$root/scripts/register_checkout.py" "$root" "$build"
