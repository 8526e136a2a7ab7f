#!/usr/bin/env bash
# Installs what the yasps build and tests need on Debian 12, skipping whatever is present.
# Safe to run again: every step checks before it acts.
set -euo pipefail

LLVM_PREFIX=${LLVM_PREFIX:-/usr/lib/llvm-22}
DEB_PACKAGES=(cmake ninja-build ccache g++ python3-dev libgtest-dev llvm-22-dev llvm-22-tools libmlir-22-dev mlir-22-tools
  clang-22 libclang-rt-22-dev libegl1 libegl-mesa0 libgl1-mesa-dri)
# Python packages: the pins of requirements.txt.
REQUIREMENTS="$(cd "$(dirname "$0")/.." && pwd)/requirements.txt"

sudo_if_needed() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}

missing=()
for pkg in "${DEB_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing Debian packages: ${missing[*]}"
  sudo_if_needed apt-get update -qq
  sudo_if_needed env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}"
fi

[ -x "$LLVM_PREFIX/bin/mlir-tblgen" ] || { echo "setup: $LLVM_PREFIX/bin/mlir-tblgen not found" >&2; exit 1; }

PYTHON=${PYTHON:-python3}
py_missing=()
# One listing of what is installed, names normalised (lower case, '-').
normalise() { tr 'A-Z_' 'a-z-'; }
installed=$("$PYTHON" -m pip list --format=freeze 2>/dev/null | normalise)
while read -r pin; do
  grep -qxF "$(echo "$pin" | normalise)" <<<"$installed" || py_missing+=("$pin")
done < <(grep -E '^[A-Za-z0-9_.-]+==' "$REQUIREMENTS")
if [ ${#py_missing[@]} -gt 0 ]; then
  echo "setup: installing Python packages: ${py_missing[*]}"
  "$PYTHON" -m pip install -q "${py_missing[@]}"
fi
