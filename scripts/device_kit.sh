#!/usr/bin/env bash
# Gathers what the GPU checks of scripts/device_check.sh need into
# .device-kit/ (ignored by git), for a GPU machine that has neither MLIR
# nor this build: the runtime's test binary and stand-in driver, the SpMV
# and kernel benchmarks, the bunny mesh, and stable Neo-Hookean's
# derivative kernels compiled for sm_80/sm_90 with their inputs and CPU
# values (bench/gpu_kit.py). Builds them first. About 45 MB.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build}
kit=$root/.device-kit
data=${YASPS_DATA_DIR:-$root/../shared/data}

cmake --build "$build" --target YaspsRuntimeTests YaspsFakeCuda \
  yasps-spmv-bench yasps-kernel-bench
rm -rf "$kit" && mkdir -p "$kit/snh"
cp "$build/runtime/test/YaspsRuntimeTests" "$build/runtime/test/libYaspsFakeCuda.so" \
   "$build/bin/yasps-spmv-bench" "$build/bin/yasps-kernel-bench" \
   "$data/bunny-19k.msh" "$kit/"
YASPS_BUILD_DIR="$build" python3 "$root/bench/gpu_kit.py" "$kit/snh"
du -sh "$kit"
