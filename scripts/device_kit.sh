#!/usr/bin/env bash
# Gathers what the GPU checks of scripts/device_check.sh need into
# .device-kit/ (ignored by git; $KIT_DIR to put it elsewhere), for a GPU
# machine that has neither MLIR nor this build:
#
# - the runtime's test binary and stand-in driver, the SpMV, kernel and
#   Newton benchmarks, the bunny meshes, and the kits of bench/gpu_kit.py
#   (stable Neo-Hookean's derivative kernels, and the bunny scene's Newton
#   iteration, compiled for sm_80/sm_90 with their inputs and CPU values);
# - for whole simulations: src/, the sources of the runtime-only build of
#   the Python package (CMake option YASPS_RUNTIME_ONLY: no LLVM or MLIR),
#   with bench/device_sim.py and the scenes' examples; store/, the kernel
#   store of the scenes $KIT_SCENES (default: the README demo) with CPU
#   kernels for any x86 machine with AVX2 and GPU kernels for $KIT_CHIPS
#   (default sm_90, and "host" for the stand-in driver of a dry run); and
#   wheels/, the Python packages the machine lacks (ipctk, meshio) for its
#   Python ($KIT_PYTHON_VERSION, default 3.12), from $KIT_WHEELS if that
#   folder has them, else downloaded (KIT_WHEELS=none: none, as for a dry
#   run, which uses this machine's packages).
#
# $KIT_PARTS picks what goes in (default "checks sim"): "checks" the first
# list, "sim" the second; the kernel benches' inputs take 33 MB of the
# device tool's 64 MiB, so the scale series' larger scenes go in a kit of
# "sim" alone. Builds what it needs first. The kit holds no LLVM or MLIR
# library.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build}
kit=${KIT_DIR:-$root/.device-kit}
data=${YASPS_DATA_DIR:-$root/../shared/data}
scenes=${KIT_SCENES:-demo}
chips=${KIT_CHIPS:-sm_90 host}
python_version=${KIT_PYTHON_VERSION:-3.12}

parts=${KIT_PARTS:-checks sim}
has() { case " $parts " in *" $1 "*) return 0 ;; esac; return 1; }

cmake --build "$build" --target YaspsRuntimeTests YaspsFakeCuda
rm -rf "$kit" && mkdir -p "$kit"
# The stand-in driver plays the GPU in a dry run of either part.
cp "$build/runtime/test/libYaspsFakeCuda.so" "$data/bunny-19k.msh" \
   "$data/bunny-1.8k.msh" "$kit/"
if has checks; then
  cmake --build "$build" --target yasps-spmv-bench yasps-kernel-bench \
    yasps-newton-bench
  cp "$build/runtime/test/YaspsRuntimeTests" "$build/bin/yasps-spmv-bench" \
     "$build/bin/yasps-kernel-bench" "$build/bin/yasps-newton-bench" "$kit/"
  YASPS_BUILD_DIR="$build" python3 "$root/bench/gpu_kit.py" "$kit"
fi
if ! has sim; then
  du -sh "$kit"
  exit 0
fi

# The runtime-only build's sources and the scripts the simulations run.
(cd "$root" && git ls-files -z CMakeLists.txt runtime python/CMakeLists.txt \
   python/src python/yasps bench/device_sim.py bench/benchlib \
   examples/contact_demo.py examples/paper |
   tar --null -T - -cf - | (mkdir -p "$kit/src" && tar -xf - -C "$kit/src"))

# The scenes' kernels, compiled ahead into the kit's store.
YASPS_BUILD_DIR="$build" YASPS_DATA_DIR="$data" \
  YASPS_CACHE_DIR="${YASPS_CACHE_DIR:-$HOME/.cache/yasps}" \
  python3 "$root/bench/device_sim.py" prepare "$kit/store" \
  --scenes $scenes --chips $chips

mkdir -p "$kit/wheels"
[ "${KIT_WHEELS:-}" = none ] && wheels="" || wheels="ipctk meshio"
for wheel in $wheels; do
  version=$(python3 -c "import importlib.metadata as m; print(m.version('$wheel'))")
  if ls "${KIT_WHEELS:-/nonexistent}"/$wheel-"$version"-*.whl >/dev/null 2>&1; then
    cp "${KIT_WHEELS}"/$wheel-"$version"-*.whl "$kit/wheels/"
  elif ! python3 -m pip download -q --no-deps --only-binary=:all: \
      --python-version "$python_version" --platform manylinux_2_28_x86_64 \
      -d "$kit/wheels" "$wheel==$version" 2>/dev/null; then
    echo "device_kit: no $wheel wheel for Python $python_version" >&2
  fi
done
du -sh "$kit"
