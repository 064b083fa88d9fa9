#!/usr/bin/env bash
# bench/view_fps.sh: frames per second of `psub view` in a 1280x720 window under Xvfb (lavapipe
# where there is no GPU), with and without the HUD, for Spot at 23k, 187k and 750k faces and
# the cow at 1.1M faces. Prints a markdown table: median frame ms (the log's frame_ms, frame 0
# left out: it includes the first present) and the fps that median gives, and the
# stage medians of the run without the HUD. Timings only; nothing here is a test.
#
# Usage: bench/view_fps.sh [PSUB] [EXTRA VIEW OPTIONS...]
#   PSUB defaults to build/cli/psub; e.g. bench/view_fps.sh build/cli/psub --backend vulkan
# FRAMES_SCALE=N multiplies the frame counts (default 1).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
psub="${1:-$here/build/cli/psub}"
shift || true
scale="${FRAMES_SCALE:-1}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# model, P-S steps (psub stats: the face counts named above), frames
runs=(
  "spot_control_mesh.obj 6 60"
  "spot_control_mesh.obj 9 20"
  "spot_control_mesh.obj 11 10"
  "cow.obj 7 8"
)

# Median frame ms, fps from it, faces, and stage medians (deform/upload/evaluate/normals/render/readback/present).
summarise() {
  python3 - "$1" <<'PY'
import json, statistics, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
frames = lines[1:] or lines
ms = statistics.median(l["frame_ms"] for l in frames)
stages = ["deform", "upload", "evaluate", "normals", "render", "readback", "present"]
med = [statistics.median(l["stages"][s + "_ms"] for l in frames) for s in stages]
print(f'{ms:.1f}|{1000.0 / ms:.2f}|{lines[0]["refined_faces"]:,}|{lines[0]["frames_in_flight"]}|' + " / ".join(f"{m:.2f}" for m in med))
PY
}

echo "| model, steps | refined faces | frames in flight | frames | with HUD: median frame ms (fps) | without HUD: median frame ms (fps) | stage medians without HUD (ms) |"
echo "|---|---:|---:|---:|---:|---:|---|"
for run in "${runs[@]}"; do
  read -r model levels frames <<<"$run"
  frames=$((frames * scale))
  for hud in on off; do
    flag=(); [ "$hud" = off ] && flag=(--no-hud)
    xvfb-run -a -s '-screen 0 1600x1200x24' "$psub" view "$here/data/$model" --levels "$levels" --size 1280x720 \
      --no-vsync --frames "$frames" --log "$work/$hud.jsonl" "${flag[@]}" "$@" >"$work/$hud.out" 2>&1 ||
      { cat "$work/$hud.out" >&2; exit 1; }
  done
  IFS='|' read -r onMs onFps faces inFlight _ <<<"$(summarise "$work/on.jsonl")"
  IFS='|' read -r offMs offFps _ _ stages <<<"$(summarise "$work/off.jsonl")"
  echo "| ${model%%[_.]*} L$levels | $faces | $inFlight | $frames | $onMs ($onFps) | $offMs ($offFps) | $stages |"
done
