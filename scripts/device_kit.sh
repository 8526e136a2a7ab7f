#!/usr/bin/env bash
# Gathers what the GPU checks of scripts/device_check.sh need into
# .device-kit/ (ignored by git; $KIT_DIR to put it elsewhere), for a GPU machine that has neither MLIR
# nor this build: the runtime's test binary and stand-in driver, the SpMV,
# kernel and Newton benchmarks, the bunny mesh, and the kits of
# bench/gpu_kit.py (stable Neo-Hookean's derivative kernels, and the bunny
# scene's Newton iteration, compiled for sm_80/sm_90 with their inputs and
# CPU values). Builds them first.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build}
kit=${KIT_DIR:-$root/.device-kit}
data=${YASPS_DATA_DIR:-$root/../shared/data}

cmake --build "$build" --target YaspsRuntimeTests YaspsFakeCuda \
  yasps-spmv-bench yasps-kernel-bench yasps-newton-bench
rm -rf "$kit" && mkdir -p "$kit"
cp "$build/runtime/test/YaspsRuntimeTests" "$build/runtime/test/libYaspsFakeCuda.so" \
   "$build/bin/yasps-spmv-bench" "$build/bin/yasps-kernel-bench" \
   "$build/bin/yasps-newton-bench" "$data/bunny-19k.msh" "$kit/"
YASPS_BUILD_DIR="$build" python3 "$root/bench/gpu_kit.py" "$kit"
du -sh "$kit"
