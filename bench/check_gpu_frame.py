#!/usr/bin/env python3
"""Smoke test of the GPU run's script on whatever Vulkan device this machine has (lavapipe in
the tests): `bench/gpu_run.sh prepare` into WORKDIR/carried, then `run quick` into WORKDIR/out;
both JSON lines parse with their fields, the device gave timestamps, and its frame agreed with
the CPU's tiled evaluator. Never judges speed.
No Vulkan device fails, unless PSUB_ALLOW_NO_VULKAN=1 (then exit 77: skipped).

usage: check_gpu_frame.py BUILD_DIR WORKDIR
"""
import json
import os
import shutil
import subprocess
import sys

FIELDS = {"device": str, "torus": int, "levels": int, "faces": (int, float), "vertices": (int, float),
          "double_steps": int, "tiles": int, "tile_block": int, "tile_threads": int, "controls_in_place": bool,
          "tiled_share": float, "tile_kernel": str, "frames": int,
          "timestamps": bool, "gpu_ms_median": (int, float), "positions_ms_median": (int, float),
          "normals_ms_median": (int, float), "upload_ms_median": (int, float), "wall_ms_median": (int, float),
          "host_write_ms_median": (int, float), "host_wait_ms_median": (int, float), "reached_gbs": (int, float)}


def fail(message):
    print("FAIL:", message)
    sys.exit(1)


def main():
    build, workdir = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "gpu_run.sh")
    shutil.rmtree(workdir, ignore_errors=True)
    env = dict(os.environ, PSUB_GPU_DIR=os.path.join(workdir, "carried"), OUT=os.path.join(workdir, "out"))
    prepare = subprocess.run(["bash", script, "prepare", build], env=env, capture_output=True, text=True)
    if prepare.returncode != 0:
        fail("prepare: " + prepare.stderr)
    run = subprocess.run(["bash", script, "run", "quick"], env=env, capture_output=True, text=True)
    if run.returncode != 0:
        if os.environ.get("PSUB_ALLOW_NO_VULKAN") == "1":
            print("SKIP: no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1):", run.stderr)
            sys.exit(77)
        fail("run quick: " + run.stdout + run.stderr)
    with open(os.path.join(workdir, "out", "gpu.jsonl")) as f:
        records = [json.loads(line) for line in f if line.strip()]
    if [r.get("tile_kernel") for r in records] != ["auto", "workgroup16+separate", "workgroup32+separate",
                                                    "workgroup16x64+staged"]:
        fail("expected the auto kernel's record, then the workgroup kernel's with each block side and the separate "
             "normal pass, then blocks of 16 with 64 invocations and staged control points: %s" % records)
    if [r.get("tile_block") for r in records[1:]] != [16, 32, 16] or records[3].get("tile_threads") != 64:
        fail("the workgroup kernel's records name blocks of 16, 32 and 16, the last with 64 invocations: %s" % records)
    # Lavapipe's own kernel (the unrolled one) writes no normals; the separate pass where asked;
    # the tile kernel's blocks of 16 on lavapipe (its shared memory holds their kept grid) by default.
    if [r.get("normals_in_tile_kernel") for r in records] != [False, False, False, True]:
        fail("the normals in the tile kernel only where by default on the workgroup kernel: %s" % records)
    # Lavapipe shares the host's memory: control points in place unless staged.
    if [r.get("controls_in_place") for r in records] != [True, True, True, False]:
        fail("control points in place except where staged: %s" % records)
    for r in records:
        for name, kind in FIELDS.items():
            if not isinstance(r.get(name), kind):
                fail("field %s missing or not %s in %s" % (name, kind, r))
        if not r["timestamps"] or r["gpu_ms_median"] <= 0 or r["faces"] != 16384 or r["tiled_share"] != 1.0:
            fail("no GPU time, or not the quick torus wholly tiled: %s" % r)
        if r.get("agrees") is not True:
            fail("the device's frame differs from the CPU's tiled evaluator: %s" % r)
    with open(os.path.join(workdir, "out", "gpu.md")) as f:
        if f.read().count("GPU ") < 4:
            fail("gpu.md lacks the four frame lines")
    print("OK")


if __name__ == "__main__":
    main()
