#!/usr/bin/env bash
# The demo command: installs what is missing, builds, and runs the main demo:
# a soft box dropped onto the ground (implicit Euler, stable Neo-Hookean,
# IPC barrier, Newton with yasps' directions) on the CPU, after the paper's
# running example (two bunnies, UNION, dynamic collision pairs) through
# yasps-opt and through Python.
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

echo "== examples/drop.py: a soft box dropped onto the ground"
YASPS_BUILD_DIR="$build" python3 "$root/examples/drop.py"
