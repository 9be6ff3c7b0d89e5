#!/usr/bin/env python3
"""Writes a copy of a GLB with one more camera, close in, as its first camera.

For the motion-blur benchmark's scene where the character fills the frame
(BENCHMARKS.md, "Motion blur"): soupray renders a file's first camera, and
the shipped animation has none.

    scripts/closeup.py animations/walker/walker.glb out/closeup.glb [X Y Z [YFOV]]

The camera looks down -Z from (X, Y, Z) (default 0 0.8 1.3, yfov 0.7 rad).
"""
import json
import struct
import sys


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    src, dst = sys.argv[1], sys.argv[2]
    pos = [float(v) for v in sys.argv[3:6]] if len(sys.argv) >= 6 else [0.0, 0.8, 1.3]
    yfov = float(sys.argv[6]) if len(sys.argv) >= 7 else 0.7
    data = open(src, "rb").read()
    magic, version, _ = struct.unpack_from("<III", data, 0)
    if magic != 0x46546C67 or version != 2:
        sys.exit(f"{src}: not a glTF 2.0 binary")
    length, kind = struct.unpack_from("<II", data, 12)
    if kind != 0x4E4F534A:
        sys.exit(f"{src}: the first chunk is not JSON")
    doc = json.loads(data[20:20 + length])
    rest = data[20 + length:]
    doc.setdefault("cameras", []).insert(0, {
        "type": "perspective",
        "perspective": {"yfov": yfov, "aspectRatio": 16 / 9, "znear": 0.01, "zfar": 100.0},
    })
    for node in doc.get("nodes", []):
        if "camera" in node:
            node["camera"] += 1
    doc["nodes"].append({"name": "closeup", "camera": 0, "translation": pos})
    doc["scenes"][doc.get("scene", 0)]["nodes"].append(len(doc["nodes"]) - 1)
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + rest
    with open(dst, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)


if __name__ == "__main__":
    main()
