#!/usr/bin/env bash
# The demo command: installs what is missing, builds, and runs the main demo:
# a soft and an affine box falling onto a pinned cloth (three
# parameterisations in one UNION, IPC contact with friction, implicit Euler)
# on the CPU, after the paper's running example (two bunnies, UNION, dynamic
# collision pairs) through yasps-opt and through Python.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build}

bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"

echo "== examples/ir/two_bunnies.mlir after yasps-inline-reads (barrier energy)"
"$build/bin/yasps-opt" "$root/examples/ir/two_bunnies.mlir" \
  --yasps-inline-reads --canonicalize --cse |
  sed -n '/yasps.attr @point_point/,/^      }/p'

echo "== examples/two_bunnies.py"
YASPS_BUILD_DIR="$build" python3 "$root/examples/two_bunnies.py"

echo "== examples/contact_demo.py: a soft and an affine box fall onto a pinned cloth"
YASPS_BUILD_DIR="$build" python3 "$root/examples/contact_demo.py" --output out/contact
