#!/usr/bin/env python3
"""Repairs the two skin defects the Khronos glTF Validator reports in older skinned .glb files.

1. WEIGHTS_n rows that do not sum to 1 (ACCESSOR_WEIGHTS_NON_NORMALIZED): each vertex's weights
   are divided by their sum, in the accessor's component type (float, or normalized unsigned
   byte/short by largest remainder so the integers sum to exactly 255/65535); the accessor's
   min/max are recomputed. Rows that already pass are left bit for bit.
2. A skinned-mesh node under a parent (NODE_SKINNED_MESH_NON_ROOT): the node is moved to the
   root of every scene that held it. glTF ignores a skinned mesh node's transform and its
   parents', so the pose does not change.

Everything else (every other byte of the binary chunk, every other JSON property) is kept; the
JSON chunk is re-serialized compactly. Standard library only.

usage: repair_glb_skin.py IN.glb OUT.glb
"""
import json
import math
import struct
import sys

FLOAT, UNSIGNED_BYTE, UNSIGNED_SHORT = 5126, 5121, 5123
FORMATS = {FLOAT: ("<f", 4), UNSIGNED_BYTE: ("<B", 1), UNSIGNED_SHORT: ("<H", 2)}
GLB_MAGIC, JSON_CHUNK, BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942


def fail(message):
    sys.exit(f"repair_glb_skin: {message}")


def f32(value):
    return struct.unpack("<f", struct.pack("<f", value))[0]


def read_glb(path):
    with open(path, "rb") as source:
        data = source.read()
    if len(data) < 20 or struct.unpack_from("<I", data, 0)[0] != GLB_MAGIC:
        fail(f"{path}: not a binary glTF (.glb)")
    json_length, json_type = struct.unpack_from("<II", data, 12)
    if json_type != JSON_CHUNK:
        fail(f"{path}: the first chunk is not JSON")
    document = json.loads(data[20:20 + json_length])
    offset = 20 + json_length
    if offset + 8 > len(data):
        fail(f"{path}: no binary chunk")
    bin_length, bin_type = struct.unpack_from("<II", data, offset)
    if bin_type != BIN_CHUNK:
        fail(f"{path}: the second chunk is not BIN")
    return document, bytearray(data[offset + 8:offset + 8 + bin_length])


def write_glb(path, document, binary):
    text = json.dumps(document, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary = bytes(binary) + b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(text) + 8 + len(binary)
    with open(path, "wb") as out:
        out.write(struct.pack("<III", GLB_MAGIC, 2, total))
        out.write(struct.pack("<II", len(text), JSON_CHUNK) + text)
        out.write(struct.pack("<II", len(binary), BIN_CHUNK) + binary)


def weight_slots(document, index):
    """(format, size, byte offsets of the 4 components of each row) of a VEC4 weights accessor."""
    accessor = document["accessors"][index]
    kind = accessor["componentType"]
    if accessor.get("type") != "VEC4" or kind not in FORMATS or "sparse" in accessor:
        fail(f"accessor {index}: weights must be a dense VEC4 of float, unsigned byte or short")
    if kind != FLOAT and not accessor.get("normalized"):
        fail(f"accessor {index}: integer weights must be normalized")
    view = document["bufferViews"][accessor["bufferView"]]
    if view.get("buffer", 0) != 0:
        fail(f"accessor {index}: weights outside the binary chunk")
    fmt, size = FORMATS[kind]
    stride = view.get("byteStride", 4 * size)
    start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    rows = [[start + r * stride + c * size for c in range(4)] for r in range(accessor["count"])]
    return fmt, kind, rows


def float_row_passes(weights):
    """The validator's check: a float32 running sum within 2e-7 per non-zero weight of 1."""
    total, tolerance = 0.0, 0.0
    for w in weights:
        if w != 0:
            total = f32(total + w)
            tolerance += 2e-7
    return abs(total - 1) <= tolerance


def normalized_floats(weights):
    total = math.fsum(weights)
    out = [f32(w / total) for w in weights]
    for _ in range(8):  # nudge the largest weight until the float32 sum passes
        if float_row_passes(out):
            return out
        largest = max(range(4), key=lambda k: out[k])
        out[largest] = f32(out[largest] + (1 - math.fsum(out)))
    fail(f"weights {weights} cannot be normalized in float32")


def normalized_integers(weights, full):
    total = sum(weights)
    exact = [w * full / total for w in weights]
    out = [math.floor(e) for e in exact]
    by_remainder = sorted(range(4), key=lambda k: exact[k] - out[k], reverse=True)
    for k in by_remainder[:full - sum(out)]:
        out[k] += 1
    return out


def normalize_weights(document, binary, index):
    fmt, kind, rows = weight_slots(document, index)
    full = {UNSIGNED_BYTE: 255, UNSIGNED_SHORT: 65535}.get(kind)
    changed = 0
    for r, slots in enumerate(rows):
        weights = [struct.unpack_from(fmt, binary, s)[0] for s in slots]
        if any(w < 0 or not math.isfinite(w) for w in weights) or sum(weights) == 0:
            fail(f"accessor {index} row {r}: weights {weights} cannot be normalized")
        if full is None:
            if float_row_passes(weights):
                continue
            repaired = normalized_floats(weights)
        else:
            if sum(weights) == full:
                continue
            repaired = normalized_integers(weights, full)
        for s, w in zip(slots, repaired):
            struct.pack_into(fmt, binary, s, w)
        changed += 1
    accessor = document["accessors"][index]
    if "min" in accessor or "max" in accessor:
        columns = list(zip(*([struct.unpack_from(fmt, binary, s)[0] for s in slots] for slots in rows)))
        accessor["min"] = [min(c) for c in columns]
        accessor["max"] = [max(c) for c in columns]
    return changed


def reachable(document, roots):
    seen, stack = set(), list(roots)
    while stack:
        node = stack.pop()
        if node not in seen:
            seen.add(node)
            stack.extend(document["nodes"][node].get("children", []))
    return seen


def move_skinned_nodes_to_root(document):
    nodes = document.get("nodes", [])
    scenes = document.get("scenes", [])
    held = [reachable(document, scene.get("nodes", [])) for scene in scenes]
    moved = []
    for parent in nodes:
        children = parent.get("children", [])
        for child in [c for c in children if "mesh" in nodes[c] and "skin" in nodes[c]]:
            children.remove(child)
            moved.append(child)
        if "children" in parent and not children:
            del parent["children"]
    for node in moved:
        for scene, nodes_held in zip(scenes, held):
            if node in nodes_held:
                scene["nodes"].append(node)
    return moved


def main():
    if len(sys.argv) != 3:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        sys.exit(2)
    document, binary = read_glb(sys.argv[1])
    weight_accessors = sorted({
        index
        for mesh in document.get("meshes", [])
        for primitive in mesh["primitives"]
        for name, index in primitive["attributes"].items()
        if name.startswith("WEIGHTS_")})
    if any(name == "WEIGHTS_1" for mesh in document.get("meshes", []) for p in mesh["primitives"]
           for name in p["attributes"]):
        fail("WEIGHTS_1 present: rows spanning several weight sets are not handled")
    for index in weight_accessors:
        print(f"accessor {index}: renormalized {normalize_weights(document, binary, index)} rows")
    print(f"skinned-mesh nodes moved to the scene root: {move_skinned_nodes_to_root(document)}")
    write_glb(sys.argv[2], document, binary)


if __name__ == "__main__":
    main()
