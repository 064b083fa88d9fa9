#!/usr/bin/env bash
# The GPU run of issue 13 (a benchmark, not a test), in two halves:
#   bench/gpu_run.sh prepare [BUILD_DIR=build]
#       here, after building: copies psub_gpu_frame and the shared libraries it loads (all but
#       the C library's own) into .gpu/ at the repository's root, which git ignores
#       ($PSUB_GPU_DIR instead of .gpu/ where set: the smoke test's).
#   bench/gpu_run.sh run [quick] [KERNEL...]
#       on the GPU's machine, from the repository's root, with .gpu/ carried there: the device's
#       copy bandwidth (a device-to-device copy through PyTorch, where python3 has it), then
#       psub_gpu_frame on the torus at 1M, 4.2M and 16.8M faces (the tile kernel the device
#       gets, then at 16.8M session 20's choices: blocks of 32, 128 invocations, the separate
#       normal pass and staged control points; today's without the normals in the tile kernel;
#       and blocks of 16), with nvidia-smi's clocks sampled meanwhile. `quick`: one small torus,
#       for trying the script on lavapipe (its kernel, then the workgroup kernel with each block
#       side and the separate normal pass, and blocks of 16 with 64 invocations and staged
#       control points). KERNELs: psub_gpu_frame's kernel names to time at the largest size
#       instead of those. Results: $OUT/gpu.md,
#       $OUT/gpu.jsonl and $OUT/clocks.csv (./gpu-out/ when OUT is unset).
# bench/README.md ("A run for a GPU") has the commands and what was measured.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${PSUB_GPU_DIR:-.gpu}

prepare() {
    local build=${1:-build} binary
    binary="$build/bench/psub_gpu_frame"
    [[ -x $binary ]] || { echo "gpu_run.sh: $binary is not built (ninja -C $build bench/psub_gpu_frame)" >&2; exit 1; }
    rm -rf "$dir" && mkdir -p "$dir/lib"
    cp "$binary" "$dir/"
    ldd "$binary" | awk '/=> \// { print $3 }' | while read -r lib; do
        case "$(basename "$lib")" in
            libc.so.*|libm.so.*|libpthread.so.*|libdl.so.*|librt.so.*|ld-linux*) ;;
            *) cp -L "$lib" "$dir/lib/" ;;
        esac
    done
    if [[ $dir == .gpu && -d .git/info ]]; then grep -qx '/.gpu/' .git/info/exclude 2>/dev/null || echo '/.gpu/' >> .git/info/exclude; fi
    echo "gpu_run.sh: $dir holds $(du -sh "$dir" | cut -f1): carry it, and run: bash bench/gpu_run.sh run"
}

run() {
    local out=${OUT:-gpu-out} bandwidth=0
    mkdir -p "$out"
    [[ -x $dir/psub_gpu_frame ]] || { echo "gpu_run.sh: no $dir/psub_gpu_frame (run 'prepare' first, and carry $dir)" >&2; exit 1; }
    local libs
    libs="$(cd "$dir" && pwd)/lib"
    export LD_LIBRARY_PATH="$libs${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
    local icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
    [[ -f $icd && -z ${VK_DRIVER_FILES:-} ]] && export VK_DRIVER_FILES=$icd
    {
        echo "# psub_gpu_frame, $(date -u '+%Y-%m-%d %H:%M UTC')"
        echo
        echo '```'
        nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm,clocks.max.mem --format=csv 2>/dev/null || echo "no nvidia-smi"
        echo '```'
    } > "$out/gpu.md"
    if python3 -c 'import torch; assert torch.cuda.is_available()' 2>/dev/null; then
        # Bytes read and written by a 4 GiB device-to-device copy, best of 10 after 3 warm-ups.
        bandwidth=$(python3 - <<'EOF'
import torch
a = torch.empty(1 << 30, dtype=torch.float32, device="cuda"); b = torch.empty_like(a)
best = 1e9
for i in range(13):
    s, e = torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)
    s.record(); b.copy_(a); e.record(); torch.cuda.synchronize()
    if i >= 3: best = min(best, s.elapsed_time(e))
print(f"{2 * a.numel() * 4 / (best * 1e6):.1f}")
EOF
)
        printf '\nDevice copy bandwidth (PyTorch, 4 GiB device to device, read + write, best of 10): %s GB/s\n' "$bandwidth" >> "$out/gpu.md"
    fi
    printf '\n```\n' >> "$out/gpu.md"
    : > "$out/gpu.jsonl"
    local sizes=("512 2" "512 4" "512 6") others=(workgroup32x128+separate+staged workgroup+separate workgroup16) status=0 sampler=
    [[ ${1:-} == quick ]] && sizes=("64 2") && others=(workgroup16+separate workgroup32+separate workgroup16x64+staged) && shift
    (($# > 0)) && others=("$@")
    # The GPU's clocks every 250 ms while the frames run (a GPU left idle between frames may
    # not reach its highest clock).
    if command -v nvidia-smi > /dev/null; then
        nvidia-smi --query-gpu=timestamp,clocks.sm,clocks.mem,utilization.gpu,power.draw --format=csv -lms 250 \
            > "$out/clocks.csv" 2> /dev/null &
        sampler=$!
    fi
    # One measurement: its text line to gpu.md, its JSON line to gpu.jsonl; a failure (an error,
    # or a frame that disagrees with the CPU) is written down and the next sizes still run.
    frame() {
        if "$dir/psub_gpu_frame" "$@" "$bandwidth" > "$out/frame.txt" 2> "$out/error.txt"; then
            head -n -1 "$out/frame.txt" | tee -a "$out/gpu.md"
            tail -n 1 "$out/frame.txt" >> "$out/gpu.jsonl"
        else
            status=1
            echo "FAILED: psub_gpu_frame $*" | cat - "$out/frame.txt" "$out/error.txt" | tee -a "$out/gpu.md" >&2
        fi
    }
    for size in "${sizes[@]}"; do
        # shellcheck disable=SC2086
        frame $size 200 auto
    done
    for other in "${others[@]}"; do
        # shellcheck disable=SC2086
        frame ${sizes[-1]} 100 "$other"
    done
    rm -f "$out/frame.txt" "$out/error.txt"
    printf '```\n' >> "$out/gpu.md"
    if [[ -n $sampler ]]; then
        kill "$sampler" 2> /dev/null || true
        wait "$sampler" 2> /dev/null || true
        awk -F', ' 'NR > 1 { split($2, c, " "); if (c[1] + 0 > top) top = c[1] + 0 }
            END { printf "\nHighest SM clock sampled during the frames: %d MHz (every sample: clocks.csv)\n", top }' \
            "$out/clocks.csv" >> "$out/gpu.md"
    fi
    echo "gpu_run.sh: results in $out/gpu.md and $out/gpu.jsonl"
    return "$status"
}

case "${1:-}" in
    prepare) shift; prepare "$@" ;;
    run) shift; run "$@" ;;
    *) echo "usage: bench/gpu_run.sh prepare [BUILD_DIR] | run [quick] [KERNEL...]" >&2; exit 2 ;;
esac
