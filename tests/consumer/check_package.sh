#!/usr/bin/env bash
# The installed package as another project sees it (run by ctest, tests/CMakeLists.txt):
#   check_package.sh install BUILD WORK            cmake --install BUILD into WORK/prefix; no
#                                                  source or build path in its text files, and
#                                                  each installed header compiles on its own,
#                                                  and tests/consumer/all (every component) builds
#   check_package.sh consumer cpu|vulkan WORK PREFIX MODEL LEVELS FRAMES
#                                                  builds tests/consumer/<kind> against PREFIX
#                                                  (plain, -j2) and runs it on MODEL
#   check_package.sh core SOURCE WORK [LAUNCHER]   configures PSub with PSUB_CORE_ONLY=ON, builds
#                                                  the core libraries, installs them, checks that
#                                                  nothing optional was looked for or installed,
#                                                  builds the CPU consumer against that, and
#                                                  checks the Vulkan consumer is refused clearly
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source_dir=$(cd "$here/../.." && pwd)

fail() { echo "check_package: $*" >&2; exit 1; }

build_consumer() {  # KIND BUILD_DIR PREFIX
  rm -rf "$2"
  cmake -S "$here/$1" -B "$2" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$3" >/dev/null
  cmake --build "$2" -j2 >/dev/null
}

case "${1:-}" in
install)
  build=$2 work=$3
  rm -rf "$work/prefix"
  cmake --install "$build" --prefix "$work/prefix" >/dev/null
  for name in PSubConfig.cmake PSubConfigVersion.cmake PSub-compute-targets.cmake; do
    [ -f "$work/prefix/lib/cmake/PSub/$name" ] || fail "lib/cmake/PSub/$name was not installed"
  done
  build_abs=$(cd "$build" && pwd)
  # Text files only: the static libraries keep __FILE__ strings of their sources.
  if grep -rIl -e "$source_dir" -e "$build_abs" "$work/prefix"; then
    fail "the files above name the source ($source_dir) or build ($build_abs) directory"
  fi
  # Every installed header compiles on its own with only the prefix on the include path.
  for header in "$work/prefix/include/psub/"*.h; do
    echo "#include \"psub/$(basename "$header")\"" |
      "${CXX:-c++}" -std=c++20 -fsyntax-only -I"$work/prefix/include" -x c++ - ||
      fail "$header does not compile on its own from the install"
  done
  # Every component at once: find_package(PSub) finds what they need, and all of them link.
  build_consumer all "$work/all-consumer" "$work/prefix"
  echo "installed to $work/prefix; no source or build path in its text files; every header self-contained;" \
       "every component found and linked"
  ;;
consumer)
  kind=$2 work=$3 prefix=$4 model=$5 levels=$6 frames=$7
  build_consumer "$kind" "$work/$kind-consumer" "$prefix"
  "$work/$kind-consumer/${kind}_consumer" "$model" "$levels" "$frames"
  ;;
core)
  src=$2 work=$3 launcher=${4:-}
  rm -rf "$work/core-build" "$work/core-prefix"
  cmake -S "$src" -B "$work/core-build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPSUB_WERROR=ON -DPSUB_CORE_ONLY=ON \
    ${launcher:+-DCMAKE_CXX_COMPILER_LAUNCHER=$launcher} >/dev/null
  # Nothing beyond the compiler and OpenMP was looked for.
  for key in Vulkan_LIBRARY OPENSUBDIV_CPU_LIBRARY TinyGLTF_DIR PNG_LIBRARY Eigen3_DIR CLI11_INCLUDE_DIR GTest_DIR \
             PSUB_GLSLANG_VALIDATOR glm_DIR; do
    if grep -q "^$key:" "$work/core-build/CMakeCache.txt"; then fail "the core-only configure looked for $key"; fi
  done
  cmake --build "$work/core-build" -j2 --target psub_output psub_topology psub_stencils psub_compute >/dev/null
  cmake --install "$work/core-build" --prefix "$work/core-prefix" >/dev/null
  installed=$(cd "$work/core-prefix/lib/cmake/PSub" && ls PSub-*-targets.cmake | sed 's/PSub-\(.*\)-targets.cmake/\1/' | sort | tr '\n' ' ')
  [ "$installed" = "compute output stencils tables topology " ] || fail "core-only install has components: $installed"
  build_consumer cpu "$work/core-cpu-consumer" "$work/core-prefix"
  "$work/core-cpu-consumer/cpu_consumer" "$work/core-prefix/share/psub/cube.obj" 4 3
  # Asking that install for Vulkan is refused, naming the component.
  if out=$(cmake -S "$here/vulkan" -B "$work/core-vulkan-consumer" -G Ninja \
             -DCMAKE_PREFIX_PATH="$work/core-prefix" 2>&1); then
    fail "find_package(PSub COMPONENTS vulkan) succeeded on a core-only install"
  fi
  grep -q "PSub component(s) vulkan not installed" <<<"$out" || fail "unclear refusal: $out"
  echo "core-only: built, installed ($installed), consumed; vulkan refused clearly"
  ;;
*)
  echo "usage: check_package.sh install BUILD WORK | consumer cpu|vulkan WORK PREFIX MODEL LEVELS FRAMES |" \
       "core SOURCE WORK [LAUNCHER]" >&2
  exit 2
  ;;
esac
