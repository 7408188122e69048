#!/usr/bin/env python3
"""Writes the seed corpora of raypack's fuzz targets (tests/fuzz/): small valid inputs of every
format, generated here rather than copied from ../shared. Usage: fuzz-seeds.py OUTDIR; makes
OUTDIR/<target>/seed_*."""
import json
import os
import struct
import sys
import zlib

out = sys.argv[1] if len(sys.argv) > 1 else "fuzz-corpus"


def write(target, name, data):
    folder = os.path.join(out, target)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


QUAD = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]

# ---- PLY: ascii and both binary byte orders, triangles and a quad, normals, colours, a skipped element.
def ply_header(fmt, vertex_props, face_props, extra=""):
    h = "ply\nformat %s 1.0\ncomment raypack_material 255 0 0 red\n%selement vertex 4\n" % (fmt, extra)
    h += "".join("property %s %s\n" % p for p in vertex_props)
    h += "element face 2\n" + "".join("property %s\n" % p for p in face_props) + "end_header\n"
    return h


write("ply", "seed_ascii.ply", ply_header("ascii", [("float", "x"), ("float", "y"), ("float", "z")],
                                          ["list uchar int vertex_indices"])
      + "".join("%g %g %g\n" % v for v in QUAD) + "3 0 1 2\n4 0 1 2 3\n")
write("ply", "seed_ascii_colour.ply",
      ply_header("ascii", [("float", "x"), ("float", "y"), ("float", "z"), ("float", "nx"), ("float", "ny"),
                           ("float", "nz")],
                 ["list uchar int vertex_indices", "uchar red", "uchar green", "uchar blue"],
                 "element junk 2\nproperty int j\n")
      + "1\n2\n" + "".join("%g %g %g 0 0 1\n" % v for v in QUAD) + "3 0 1 2 255 0 0\n3 0 2 3 0 255 0\n")
for order, fmt in (("<", "binary_little_endian"), (">", "binary_big_endian")):
    body = b"".join(struct.pack(order + "3f", *v) for v in QUAD)
    body += struct.pack(order + "B3i", 3, 0, 1, 2) + struct.pack(order + "B4i", 4, 0, 1, 2, 3)
    write("ply", "seed_%s.ply" % fmt,
          ply_header(fmt, [("float", "x"), ("float", "y"), ("float", "z")], ["list uchar int vertex_indices"]).encode()
          + body)
body = b"".join(struct.pack("<3d", *v) + struct.pack("<3B", 10, 20, 30) for v in QUAD)
body += struct.pack("<H3H", 3, 0, 1, 2) + struct.pack("<H3H", 3, 0, 2, 3)
write("ply", "seed_double_ushort.ply",
      ply_header("binary_little_endian", [("double", "x"), ("double", "y"), ("double", "z"), ("uchar", "red"),
                                          ("uchar", "green"), ("uchar", "blue")],
                 ["list ushort ushort vertex_indices"]).encode() + body)

# ---- OBJ (+ MTL after "\n#MTL\n", written as input.mtl by the target).
mtl = "newmtl red\nKd 0.9 0.1 0.1\nnewmtl blue\nKd 0 0 1\nd 0.5\n"
write("obj", "seed_plain.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 2 3 4\n")
write("obj", "seed_mtl.obj", "mtllib input.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\n"
      "vt 0 0\nvt 1 0\nvt 1 1\nusemtl red\nf 1/1/1 2/2/1 3/3/1\nusemtl blue\nf -4//1 -2//1 -1//1\ng g\n"
      "usemtl none\nf 1 3 4\n\n#MTL\n" + mtl)
write("obj", "seed_missing_mtl.obj", "mtllib nothere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n")

# ---- glTF (+ buffer after "\n#BIN\n", written as input.bin) and GLB.
positions = b"".join(struct.pack("<3f", *v) for v in QUAD)
normals = struct.pack("<3f", 0, 0, 1) * 4
indices = struct.pack("<6H", 0, 1, 2, 0, 2, 3)
binary = positions + normals + indices


def gltf(uri, extra_nodes=False):
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "children": [1] if extra_nodes else []}]
                 + ([{"mesh": 0, "translation": [0, 0, 1], "rotation": [0, 0, 0, 1], "scale": [2, 2, 2]}]
                    if extra_nodes else []),
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1]}}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 12},
        ],
        "buffers": [{"byteLength": len(binary)}],
    }
    if uri:
        doc["buffers"][0]["uri"] = uri
    return doc


write("gltf", "seed_external.gltf", json.dumps(gltf("input.bin", True)).encode() + b"\n#BIN\n" + binary)
import base64
write("gltf", "seed_datauri.gltf",
      json.dumps(gltf("data:application/octet-stream;base64," + base64.b64encode(binary).decode())))


def glb(doc, payload):
    text = json.dumps(doc).encode()
    text += b" " * ((4 - len(text) % 4) % 4)
    payload += b"\0" * ((4 - len(payload) % 4) % 4)
    chunks = struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(payload), b"BIN\0") + payload
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


write("glb", "seed.glb", glb(gltf(None, True), binary))
write("glb", "seed_flat.glb", glb(gltf(None), binary))

# ---- Settings JSON (render --from), every key.
settings = {
    "scene": "gen:default", "width": 64, "height": 48,
    "camera": {"eye": [0, 1, 5], "at": [0, 0, 0], "up": [0, 1, 0], "fov_y_degrees": 60},
    "light_height": 0.5, "shadows": True,
    "phong": {"ambient": 0.1, "diffuse": 0.7, "specular": 0.2, "shininess": 32},
    "background": [0.1, 0.1, 0.1], "kernel": "packet", "packet": {"width": 8, "height": 4},
    "collect_counters": False, "view": "shaded",
    "bvh": {"builder": "sah-binned", "leaf_size": 4, "traversal_cost": 1, "intersection_cost": 1, "bin_count": 16},
}
write("settings_json", "seed_full.json", json.dumps(settings, indent=1))
write("settings_json", "seed_small.json", json.dumps({"scene": "gen:terrain:1k", "width": 8, "height": 8}))

# ---- Hits files (docs/hits-format.md): 32-byte header, 40 bytes a pixel.
def hits(width, height):
    data = b"RPKHITS1" + struct.pack("<II3fI", width, height, 0, 10, 0, 0)
    for i in range(width * height):
        if i % 2:
            data += struct.pack("<7f3I", 0, 0, 5, 0, 0, -1, 4.5, i, 1, 0)
        else:
            data += struct.pack("<6f", 0, 0, 5, 0, 0, -1) + struct.pack("<I3I", 0x7F800000, 0xFFFFFFFF, 0, 0)
    return data


write("hits", "seed_2x2.hits", hits(2, 2))
write("hits", "seed_3x1.hits", hits(3, 1))

# ---- PNG: RGBA8, RGB8, grey, grey+alpha, a paletted one, written with zlib.
def png(width, height, colour_type, bit_depth, pixel_bytes, rows, extra_chunks=b""):
    def chunk(kind, payload):
        return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(kind + payload))
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, colour_type, 0, 0, 0)
    raw = b"".join(b"\0" + row for row in rows)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + extra_chunks + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


write("png", "seed_rgba.png", png(3, 2, 6, 8, 4, [bytes(range(12)), bytes(range(12, 24))]))
write("png", "seed_rgb.png", png(2, 2, 2, 8, 3, [bytes([255, 0, 0, 0, 255, 0]), bytes([0, 0, 255, 9, 9, 9])]))
write("png", "seed_grey.png", png(4, 1, 0, 8, 1, [bytes([0, 80, 160, 255])]))
write("png", "seed_grey_alpha.png", png(2, 1, 4, 8, 2, [bytes([10, 255, 200, 0])]))
palette = struct.pack(">I", 6) + b"PLTE" + bytes([255, 0, 0, 0, 0, 255])
palette += struct.pack(">I", zlib.crc32(b"PLTE" + bytes([255, 0, 0, 0, 0, 255])))
write("png", "seed_palette.png", png(2, 2, 3, 8, 1, [bytes([0, 1]), bytes([1, 0])], palette))
print("raypack: seed corpora in %s: %s" % (out, ", ".join(sorted(os.listdir(out)))))
