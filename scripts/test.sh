#!/usr/bin/env bash
# The test command: installs what is missing, builds, and runs every test
# (lit/FileCheck compiler tests, runtime unit tests, Python tests).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build}

bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"

echo "== lit: compiler and runtime unit tests"
cmake --build "$build" --target check-yasps

echo "== pytest: Python package"
YASPS_BUILD_DIR="$build" python3 -m pytest -q "$root/python/tests"
