#!/usr/bin/env bash
# The long fuzz runs of the README: builds the libFuzzer targets like scripts/fuzz.sh (in
# ./build-fuzz), then runs each named target (default: all six) until its process has used
# CPU_SECONDS of CPU time (user + system, read from /proc), JOBS targets at a time. A machine
# that is busy elsewhere makes the run take longer, not shorter. Each target's log, with the
# fuzzer's final statistics, goes to build-fuzz/long/TARGET.log; any crash, leak or timeout
# fails the run and leaves the input in build-fuzz/artifacts/. Never stop a fuzzer midway
# (SIGSTOP): libFuzzer's -timeout counts wall time and reports the pause as a timeout.
#   scripts/fuzz-cpu.sh CPU_SECONDS [JOBS] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."
cpu_seconds=${1:?usage: scripts/fuzz-cpu.sh CPU_SECONDS [JOBS] [TARGET...]}
jobs=${2:-1}
shift $(( $# >= 2 ? 2 : 1 ))
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_obj fuzz_refine fuzz_gltf fuzz_compare fuzz_options fuzz_image)

cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DPSUB_FUZZ=ON -DPSUB_BUILD_TESTS=OFF -DPSUB_BUILD_CLI=OFF -DPSUB_BUILD_VULKAN=OFF >/dev/null
cmake --build build-fuzz -j "$(nproc)" --target "${targets[@]}"
for library in $(find build-fuzz -name 'libpsub_*.a'); do
  nm "$library" 2>/dev/null | grep __sanitizer_cov >/dev/null || { echo "fuzz: $library has no coverage instrumentation" >&2; exit 1; }
done
mkdir -p build-fuzz/artifacts build-fuzz/long

# Arguments per target: the same seeds, dictionaries and limits as scripts/fuzz.sh.
arguments() {
  local target=$1 corpus=build-fuzz/corpus/$1
  mkdir -p "$corpus"
  local common=(-timeout=10 -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix=build-fuzz/artifacts/$target-)
  case $target in
    fuzz_gltf) echo "${common[@]} -max_len=16384 -dict=tests/fuzz/gltf.dict $corpus tests/fuzz/gltf-seeds" ;;
    fuzz_options) echo "${common[@]} -max_len=4096 -dict=tests/fuzz/options.dict $corpus tests/fuzz/options-seeds" ;;
    fuzz_image) echo "${common[@]} -max_len=65536 $corpus tests/fuzz/image-seeds" ;;
    *) echo "${common[@]} -max_len=16384 -dict=tests/fuzz/obj.dict $corpus data tests/data/bad tests/data/osd-shapes tests/fuzz/regressions tests/fuzz/obj-seeds" ;;
  esac
}

cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat" 2>/dev/null || echo 0; }

# Runs one target until it has used cpu_seconds; returns the fuzzer's status (0 when stopped
# by the CPU limit, which interrupts it with SIGINT and makes it print its final statistics).
run_one() {
  local target=$1 log=build-fuzz/long/$1.log ticks_per_second limit
  ticks_per_second=$(getconf CLK_TCK)
  limit=$((cpu_seconds * ticks_per_second))
  # shellcheck disable=SC2046
  build-fuzz/tests/fuzz/$target $(arguments "$target") >"$log" 2>&1 &
  local pid=$! start=$SECONDS interrupted=0
  while kill -0 "$pid" 2>/dev/null; do
    if [ "$(cpu_ticks "$pid")" -ge "$limit" ]; then kill -INT "$pid"; interrupted=1; break; fi
    sleep 5
  done
  local status=0
  wait "$pid" || status=$?
  # libFuzzer exits 72 when interrupted (clang 14 has no -interrupted_exit_code).
  if [ "$interrupted" = 1 ] && [ "$status" = 72 ] && grep -q 'run interrupted' "$log"; then status=0; fi
  echo "fuzz: $target: status $status, $((SECONDS - start)) s wall for ${cpu_seconds} CPU-s;" \
    "$(grep -Eo 'stat::number_of_executed_units: [0-9]+' "$log" | tail -1)" \
    "$(grep -Eo 'cov: [0-9]+ ft: [0-9]+ corp: [0-9]+/[0-9a-zA-Z]+' "$log" | tail -1)"
  return "$status"
}

# JOBS lanes; lane i runs targets i, i + JOBS, ... one after the other.
lane() {
  local first=$1 failed=0 i
  for ((i = first; i < ${#targets[@]}; i += jobs)); do run_one "${targets[i]}" || failed=1; done
  return "$failed"
}
lanes=()
for ((i = 0; i < jobs && i < ${#targets[@]}; i++)); do lane "$i" & lanes+=($!); done
failed=0
for pid in "${lanes[@]}"; do wait "$pid" || failed=1; done
[ "$failed" = 0 ] && echo "fuzz: no crash, leak or timeout" || { echo "fuzz: FAILED (see build-fuzz/long/ and build-fuzz/artifacts/)"; exit 1; }
