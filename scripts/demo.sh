#!/usr/bin/env bash
# The demo command: installs what is missing, builds, and runs the main demo.
# Until the simulation runtime exists the demo is the paper's running example
# (two bunnies, UNION, dynamic collision pairs): first its IR through the
# attribute-inlining pipeline of yasps-opt, then built in Python and
# evaluated with compiled CPU kernels.
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
