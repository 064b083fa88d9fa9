#!/usr/bin/env bash
# PSub one-step set-up: installs the Debian packages the build needs (quiet when they are
# already there), builds, then runs `psub demo` (mode demo, ./build), the tests (mode test,
# ./build), or the tests under AddressSanitizer + UBSan (mode sanitize, ./build-asan). The
# test modes also install the glTF validator from the npm registry.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-demo}
case "$mode" in demo | test | sanitize) ;; *) echo "usage: scripts/setup.sh demo|test|sanitize" >&2; exit 2 ;; esac

packages=(cmake ninja-build g++ pkg-config python3 libosd-dev libcli11-dev libgtest-dev libeigen3-dev libpng-dev libjpeg-dev
          libtinygltf-dev libstb-dev nlohmann-json3-dev libglm-dev
          libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers glslang-tools nodejs
          libglfw3-dev xvfb xauth)
scripts/install-packages.sh "${packages[@]}"
# Debian's nodejs comes without npm (the npm package); some nodejs builds bundle it.
command -v npm >/dev/null || scripts/install-packages.sh npm
# The Khronos glTF Validator (npm, version pinned in tests/gltf_validator/package-lock.json),
# which the tests run on every bundled and written glTF file.
if [ "$mode" != demo ] && [ ! -d tests/gltf_validator/node_modules/gltf-validator ]; then
  npm ci --prefix tests/gltf_validator --silent --no-audit --no-fund >/dev/null
fi

if [ "$mode" = sanitize ]; then
  # Line tables only (-g1): the sanitizers' reports still name file and line, and the build is
  # the larger part of this job on two cores.
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" \
    -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DPSUB_SANITIZE=ON >/dev/null
  cmake --build build-asan -j "$(nproc)"
  # The Node glTF validator on the bundled file runs no code of ours: the plain run has it.
  # (The package tests are not defined in a sanitizer build.) The two tests of tables and
  # vertex buffers past 128 MiB (lavapipe's binding limit) are left to the plain run too: under
  # the sanitizers they took 110 s of the job, and the binding split they exercise runs here
  # with small limits forced (Vulkan.SmallBindingLimitsSplitDispatchesAndBindWindowsWithTheSameResults,
  # VulkanTiled.SmallBindingsSplitTheTilesIntoDispatchesWithTheSameResults).
  # Mesa's lavapipe (22.3.6-1+deb12u2) keeps a 128-byte buffer in a global; the Vulkan loader
  # unloads the driver when the instance goes, which leaves the buffer unreachable, and
  # LeakSanitizer reports it from "<unknown module>" (no suppression can name an unloaded
  # module). Preloading the driver keeps it mapped, and its globals reachable, to the end of
  # each process; leaks of our own still show.
  lavapipe=$(ls /usr/lib/*/libvulkan_lvp.so 2>/dev/null | head -n 1 || true)
  env ${lavapipe:+LD_PRELOAD="$lavapipe"} ASAN_OPTIONS=detect_leaks=1:verify_asan_link_order=0 \
    UBSAN_OPTIONS=print_stacktrace=1 \
    ctest --test-dir build-asan --output-on-failure -j "$(nproc)" \
    -E '^GltfValidator[.]|^Vulkan[.](TablesAndVertexBuffers|FactorizedTable)Beyond128MiB'
  exit 0
fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DPSUB_WERROR=ON >/dev/null
cmake --build build -j "$(nproc)"
if [ "$mode" = demo ]; then
  build/cli/psub demo
else
  ctest --test-dir build --output-on-failure -j "$(nproc)"
fi
