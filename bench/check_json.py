#!/usr/bin/env python3
"""Smoke test of `psub bench --quick`: exit 0, a markdown table on stdout, JSON that parses
with the stable field names, an SVG that parses. Never judges speed.

usage: check_json.py PSUB WORKDIR
"""
import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

STABLE = {
    "model": str, "scheme": str, "levels": int, "refined_faces": int, "evaluator": str,
    "threads": int, "build_ms": (int, float), "frame_ms_median": (int, float),
    "frame_ms_min": (int, float), "bytes_per_frame": int, "bandwidth_fraction": (int, float),
    "floor_ms": (int, float), "floor_ratio": (int, float), "write_floor_ms": (int, float),
    "write_floor_ratio": (int, float),
}
EVALUATORS = {"psub-cpu-perlevel", "psub-cpu-factorized", "psub-cpu-tiled", "osd-cpu", "osd-omp"}


def fail(message):
    print("FAIL:", message)
    sys.exit(1)


def main():
    psub, workdir = sys.argv[1], sys.argv[2]
    os.makedirs(workdir, exist_ok=True)
    json_path = os.path.join(workdir, "bench.json")
    svg_path = os.path.join(workdir, "bench.svg")
    for path in (json_path, svg_path):
        if os.path.exists(path):
            os.remove(path)

    help_text = subprocess.run([psub, "bench", "--help"], capture_output=True, text=True)
    if help_text.returncode != 0 or "Example" not in help_text.stdout:
        fail("psub bench --help does not show an example")

    run = subprocess.run([psub, "bench", "--quick", "--torus", "16", "--json", json_path, "--plot", svg_path],
                         capture_output=True, text=True)
    if run.returncode != 0:
        fail(f"psub bench exited {run.returncode}: {run.stderr[-2000:]}")
    if "| model |" not in run.stdout:
        fail("no markdown table on stdout")

    with open(json_path) as f:
        data = json.load(f)
    for key in ("machine", "triad_gbs", "triad_gbs_1thread", "write_only_gbs", "core_round_trip_ns",
                "core_round_trip_ns_end", "command", "results"):
        if key not in data:
            fail(f"top-level field {key!r} missing")
    # Its value depends on the machine and its load (the tests run side by side): a number only.
    for key in ("core_round_trip_ns", "core_round_trip_ns_end"):
        if not isinstance(data[key], (int, float)) or data[key] < 0:
            fail(f"{key} is {data[key]!r}")
    for key in ("cpu", "cores", "date", "compiler", "opensubdiv", "tile_kernel"):
        if key not in data["machine"]:
            fail(f"machine.{key} missing")
    if data["machine"]["tile_kernel"] not in ("avx512f", "avx2", "baseline"):
        fail(f"machine.tile_kernel is {data['machine']['tile_kernel']!r}")
    results = data["results"]
    if not results:
        fail("no results")
    for record in results:
        for key, kind in STABLE.items():
            if key not in record:
                fail(f"record lacks {key!r}: {record}")
            if not isinstance(record[key], kind) or isinstance(record[key], bool):
                fail(f"record field {key!r} has type {type(record[key]).__name__}: {record}")
        if record["scheme"] not in ("ps", "cc"):
            fail(f"scheme {record['scheme']!r}")
        if record["refined_faces"] <= 0 or record["frame_ms_median"] < record["frame_ms_min"]:
            fail(f"implausible record: {record}")
        if record["max_diff_rel"] is None or record["max_diff_rel"] > 1e-5:
            fail(f"evaluators disagree: {record}")
        if record["floor_ms"] <= 0 or abs(record["floor_ratio"] * record["floor_ms"] - record["frame_ms_median"]) > \
                1e-6 * max(1.0, record["frame_ms_median"]):
            fail(f"floor_ratio is not frame_ms_median / floor_ms: {record}")
        # --quick times one cold frame (each after the caches are written over) for every record.
        for key in ("cold_frames", "cold_frame_ms_median", "cold_frame_ms_min", "cold_floor_ratio",
                    "cold_ratio_vs_osd_best"):
            if not isinstance(record.get(key), (int, float)) or isinstance(record.get(key), bool):
                fail(f"record lacks {key!r}: {record}")
        if record["cold_frames"] != 1 or not 0 < record["cold_frame_ms_min"] <= record["cold_frame_ms_median"] or \
                abs(record["cold_floor_ratio"] * record["floor_ms"] - record["cold_frame_ms_median"]) > \
                1e-6 * max(1.0, record["cold_frame_ms_median"]):
            fail(f"cold frame fields implausible or cold_floor_ratio off: {record}")
        if record["evaluator"].startswith("psub-"):  # frames with normals, against 24 B per vertex
            for key in ("normals_frame_ms_median", "normals_floor_ms", "normals_floor_ratio"):
                if not isinstance(record.get(key), (int, float)) or record[key] <= 0:
                    fail(f"PSub record lacks {key!r}: {record}")
            if abs(record["normals_floor_ms"] - 2 * record["floor_ms"]) > 1e-9 * record["floor_ms"] or \
                    abs(record["normals_floor_ratio"] * record["normals_floor_ms"] -
                        record["normals_frame_ms_median"]) > 1e-6 * max(1.0, record["normals_frame_ms_median"]):
                fail(f"normals_floor_ms is not 24 B per vertex or its ratio is off: {record}")
    if data["frames"].get("cold_frames") != 1 or data["frames"].get("cold_flush_bytes") != 64 << 20:
        fail(f"frames settings lack the quick run's one cold frame after 64 MB: {data['frames']}")
    for size in data["sizes"]:
        best = min(r["cold_frame_ms_median"] for r in results
                   if r["scheme"] == "cc" and r["model"] == size["model"] and r["refined_faces"] > 0 and
                   r["cc_level"] == size["cc_levels"])
        if abs(size["osd_best_cold_frame_ms"] - best) > 1e-12:
            fail(f"osd_best_cold_frame_ms is not OpenSubdiv's fastest cold frame: {size}")
    seen = {r["evaluator"] for r in results}
    if not EVALUATORS <= seen:
        fail(f"evaluators missing: {sorted(EVALUATORS - seen)}")
    models = {r["model"] for r in results}
    for model in ("cow", "spot_control_mesh", "cube", "torus16"):
        if model not in models:
            fail(f"model {model} missing from the results")
    ET.parse(svg_path)
    print(f"ok: {len(results)} records, {len(models)} models")


if __name__ == "__main__":
    main()
