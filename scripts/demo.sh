#!/usr/bin/env bash
# The demo command: installs what is missing, builds, and runs the main demo.
# Until the simulation runtime exists the demo is the compiler front half: the
# paper's running example (two bunnies, UNION, dynamic collision pairs) is
# verified, its computed attributes are inlined down to stored data, JOINs and
# UNIONs, and the result is canonicalised and printed.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build}

bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"

"$build/bin/yasps-opt" "$root/examples/ir/two_bunnies.mlir" \
  --yasps-inline-reads --canonicalize --cse
