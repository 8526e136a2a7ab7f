#!/usr/bin/env bash
# The GPU checks that run without MLIR or the Python extension, on a GPU
# machine (docs/gpu.md, "On a GPU machine"): the runtime's unit tests with
# the real driver (GPU solve against the CPU), the SpMV/PCG benchmark on
# the bunny, cuSPARSE (through PyTorch) on the same matrix, stable
# Neo-Hookean's generated derivative kernels against PyTorch and JAX, and
# one Newton iteration of the bunny scene on the GPU, in stages.
#
#   bash scripts/device_check.sh KIT [OUT]
#
# KIT is what scripts/device_kit.sh gathered; logs go to OUT (default: the
# current folder).
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
kit=$(cd "$1" && pwd)
out=${2:-.}
status=0

nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv \
  | tee "$out/gpu.log" || true
echo "== runtime unit tests (stand-in and real driver)"
YASPS_FAKE_CUDA="$kit/libYaspsFakeCuda.so" "$kit/YaspsRuntimeTests" \
  2>&1 | tee "$out/gtest.log" | grep -E "^\[  (PASSED|FAILED|SKIPPED) |Failure" \
  || status=1
grep -q "FAILED" "$out/gtest.log" && status=1
echo "== SpMV, assembly and PCG on the bunny"
"$kit/yasps-spmv-bench" "$kit/bunny-19k.msh" --repeat 100 \
  --export /tmp/yasps-bunny-hessian 2>&1 | tee "$out/spmv.log" || status=1
ms=$(awk '/GPU SpMV/ {print $3}' "$out/spmv.log")
echo "== cuSPARSE on the same matrix"
python3 "$root/bench/gpu_cusparse.py" /tmp/yasps-bunny-hessian \
  ${ms:+--yasps-ms "$ms"} 2>&1 | tee "$out/cusparse.log" || status=1
echo "== stable Neo-Hookean derivatives: yasps kernels, PyTorch, JAX"
"$kit/yasps-kernel-bench" "$kit/snh" --repeat 100 2>&1 \
  | tee "$out/kernels.log" || status=1
python3 "$root/bench/gpu_peers.py" "$kit/snh" --yasps-log "$out/kernels.log" \
  2>&1 | tee "$out/peers.log" || status=1
echo "== one Newton iteration of the bunny scene, in stages"
"$kit/yasps-newton-bench" "$kit/newton" 2>&1 | tee "$out/newton.log" \
  || status=1
exit $status
