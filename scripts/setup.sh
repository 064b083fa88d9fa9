#!/usr/bin/env bash
# PSub one-step set-up: installs the Debian packages the build needs (quiet when they are
# already there), builds in ./build, then runs `psub demo` (mode demo) or the tests (mode test).
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-demo}
case "$mode" in demo | test) ;; *) echo "usage: scripts/setup.sh demo|test" >&2; exit 2 ;; esac

packages=(cmake ninja-build g++ pkg-config python3 libosd-dev libcli11-dev libgtest-dev)
missing=()
for package in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done
if [ ${#missing[@]} -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  echo "setup: installing ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DPSUB_WERROR=ON >/dev/null
cmake --build build -j "$(nproc)"
if [ "$mode" = demo ]; then
  build/cli/psub demo
else
  ctest --test-dir build --output-on-failure -j "$(nproc)"
fi
