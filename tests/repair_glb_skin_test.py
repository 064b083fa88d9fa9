#!/usr/bin/env python3
"""Tests scripts/repair_glb_skin.py on small generated .glb files: float and normalized
unsigned-byte weights that do not sum to 1 are renormalized, rows already normalized and every
other byte are kept, min/max follow, a nested skinned-mesh node moves to the scene root."""
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import unittest

SCRIPT = os.path.join(os.path.dirname(__file__), "..", "scripts", "repair_glb_skin.py")
sys.path.insert(0, os.path.dirname(SCRIPT))
import repair_glb_skin as repair  # noqa: E402


def make_glb(path, float_rows, byte_rows):
    """A glb with a float WEIGHTS_0 accessor (0), a normalized ubyte one (1), 8 marker bytes
    before and after each, node 1 (mesh + skin) a child of node 0."""
    marker = bytes(range(1, 9))
    binary = bytearray(marker)
    float_offset = len(binary)
    for row in float_rows:
        binary += struct.pack("<4f", *row)
    binary += marker
    byte_offset = len(binary)
    for row in byte_rows:
        binary += struct.pack("<4B", *row)
    binary += marker
    columns = list(zip(*float_rows))
    document = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}, {"nodes": [2]}],
        "nodes": [{"children": [1], "matrix": [1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1]},
                  {"mesh": 0, "skin": 0}, {"name": "other"}],
        "meshes": [{"primitives": [{"attributes": {"WEIGHTS_0": 0}},
                                   {"attributes": {"WEIGHTS_0": 1}}]}],
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": [{"buffer": 0, "byteOffset": float_offset, "byteLength": 16 * len(float_rows)},
                        {"buffer": 0, "byteOffset": byte_offset, "byteLength": 4 * len(byte_rows)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(float_rows), "type": "VEC4",
                       "min": [min(c) for c in columns], "max": [max(c) for c in columns]},
                      {"bufferView": 1, "componentType": 5121, "normalized": True, "count": len(byte_rows),
                       "type": "VEC4"}],
    }
    repair.write_glb(path, document, binary)
    return binary


class RepairGlbSkin(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.source = os.path.join(self.dir.name, "in.glb")
        self.repaired = os.path.join(self.dir.name, "out.glb")

    def tearDown(self):
        self.dir.cleanup()

    def run_repair(self):
        subprocess.run([sys.executable, SCRIPT, self.source, self.repaired], check=True,
                       stdout=subprocess.DEVNULL)
        return repair.read_glb(self.repaired)

    def test_weights_renormalized_and_nothing_else(self):
        float_rows = [(0.5, 0.25, 0.0, 0.0), (0.25, 0.25, 0.25, 0.25), (0.3, 0.2, 0.1, 0.0)]
        byte_rows = [(100, 50, 0, 0), (255, 0, 0, 0), (1, 1, 1, 0)]
        original = make_glb(self.source, float_rows, byte_rows)
        document, binary = self.run_repair()
        self.assertEqual(len(binary), len(original))
        floats = [struct.unpack_from("<4f", binary, 8 + 16 * r) for r in range(3)]
        for row, before in zip(floats, float_rows):
            self.assertTrue(repair.float_row_passes(row), row)
            for w, b in zip(row, before):  # same proportions
                self.assertAlmostEqual(w, b / math.fsum(before), places=6)
        self.assertEqual(floats[1], float_rows[1])  # already normalized: kept exactly
        byte_start = 8 + 48 + 8
        ubytes = [struct.unpack_from("<4B", binary, byte_start + 4 * r) for r in range(3)]
        self.assertEqual(ubytes, [(170, 85, 0, 0), (255, 0, 0, 0), (85, 85, 85, 0)])
        changed = set(range(8, 8 + 48)) | set(range(byte_start, byte_start + 12))
        for i in set(range(len(binary))) - changed:
            self.assertEqual(binary[i], original[i], f"byte {i} changed")
        columns = list(zip(*floats))
        self.assertEqual(document["accessors"][0]["max"], [max(c) for c in columns])
        self.assertEqual(document["accessors"][0]["min"], [min(c) for c in columns])
        self.assertNotIn("min", document["accessors"][1])

    def test_skinned_node_moved_to_root_of_its_scene_only(self):
        make_glb(self.source, [(1.0, 0.0, 0.0, 0.0)], [(255, 0, 0, 0)])
        document, _ = self.run_repair()
        self.assertEqual(document["scenes"], [{"nodes": [0, 1]}, {"nodes": [2]}])
        self.assertNotIn("children", document["nodes"][0])
        self.assertEqual(document["nodes"][0]["matrix"][6], -1)
        self.assertEqual(document["nodes"][1], {"mesh": 0, "skin": 0})

    def test_zero_weights_refused(self):
        make_glb(self.source, [(0.0, 0.0, 0.0, 0.0)], [(255, 0, 0, 0)])
        result = subprocess.run([sys.executable, SCRIPT, self.source, self.repaired],
                                capture_output=True, text=True)
        self.assertNotEqual(result.returncode, 0)
        self.assertIn("accessor 0 row 0", result.stderr)
        self.assertFalse(os.path.exists(self.repaired))


if __name__ == "__main__":
    unittest.main()
