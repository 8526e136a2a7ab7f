#!/usr/bin/env bash
# Gathers what the GPU checks of scripts/device_check.sh need into
# .device-kit/ (ignored by git), for a GPU machine that has neither MLIR
# nor this build: the runtime's test binary and stand-in driver, the SpMV
# benchmark, and the bunny mesh. Builds them first.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build}
kit=$root/.device-kit
data=${YASPS_DATA_DIR:-$root/../shared/data}

cmake --build "$build" --target YaspsRuntimeTests YaspsFakeCuda yasps-spmv-bench
rm -rf "$kit" && mkdir -p "$kit"
cp "$build/runtime/test/YaspsRuntimeTests" "$build/runtime/test/libYaspsFakeCuda.so" \
   "$build/bin/yasps-spmv-bench" "$data/bunny-19k.msh" "$kit/"
du -sh "$kit"
