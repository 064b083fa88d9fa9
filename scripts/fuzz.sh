#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (AddressSanitizer + UBSan) in ./build-fuzz and runs
# each for SECONDS (default 60), seeded with the bundled and bad models. Any crash, leak or
# timeout fails the run; the input that did it is left in build-fuzz/artifacts/.
#   scripts/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
scripts/install-packages.sh clang libclang-rt-14-dev cmake ninja-build libosd-dev libcli11-dev libeigen3-dev libpng-dev libjpeg-dev \
  libtinygltf-dev libstb-dev nlohmann-json3-dev libglm-dev

cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DPSUB_FUZZ=ON -DPSUB_BUILD_TESTS=OFF -DPSUB_BUILD_CLI=OFF -DPSUB_BUILD_VULKAN=OFF >/dev/null
cmake --build build-fuzz -j "$(nproc)" --target fuzz_obj fuzz_refine fuzz_gltf fuzz_compare

# Every PSub library must carry libFuzzer's coverage instrumentation, or the fuzzers run blind
# (they would see only the harness's own branches). grep reads all of nm's output: with -q it
# would stop early and nm's SIGPIPE would fail the pipeline under pipefail.
for library in $(find build-fuzz -name 'libpsub_*.a'); do
  nm "$library" 2>/dev/null | grep __sanitizer_cov >/dev/null || { echo "fuzz: $library has no coverage instrumentation" >&2; exit 1; }
done
mkdir -p build-fuzz/artifacts
for target in fuzz_obj fuzz_refine fuzz_gltf fuzz_compare; do
  corpus=build-fuzz/corpus/$target
  mkdir -p "$corpus"
  seeds=(data tests/data/bad tests/data/osd-shapes tests/fuzz/regressions tests/fuzz/obj-seeds)
  dict=tests/fuzz/obj.dict
  [ "$target" = fuzz_gltf ] && seeds=(tests/fuzz/gltf-seeds) && dict=tests/fuzz/gltf.dict
  echo "fuzz: $target for ${seconds}s"
  build-fuzz/tests/fuzz/$target -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -dict="$dict" \
    -max_len=16384 -print_final_stats=1 -artifact_prefix=build-fuzz/artifacts/$target- \
    "$corpus" "${seeds[@]}" 2>&1 | tail -n 12
done

# The CLI's option parsing, with its own dictionary of option tokens.
cmake --build build-fuzz -j "$(nproc)" --target fuzz_options
mkdir -p build-fuzz/corpus/fuzz_options
echo "fuzz: fuzz_options for ${seconds}s"
build-fuzz/tests/fuzz/fuzz_options -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=4096 \
  -print_final_stats=1 -dict=tests/fuzz/options.dict -artifact_prefix=build-fuzz/artifacts/fuzz_options- \
  build-fuzz/corpus/fuzz_options tests/fuzz/options-seeds 2>&1 | tail -n 12
# Texture decoding (stb_image: PNG and JPEG).
cmake --build build-fuzz -j "$(nproc)" --target fuzz_image
mkdir -p build-fuzz/corpus/fuzz_image
echo "fuzz: fuzz_image for ${seconds}s"
build-fuzz/tests/fuzz/fuzz_image -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
  -print_final_stats=1 -artifact_prefix=build-fuzz/artifacts/fuzz_image- \
  build-fuzz/corpus/fuzz_image tests/fuzz/image-seeds 2>&1 | tail -n 12
echo "fuzz: no crash, leak or timeout"
