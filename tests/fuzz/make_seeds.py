#!/usr/bin/env python3
"""Writes the crafted part of the loader's seed corpus (corpus/loader/).

The bundled scenes are copied as they are; every other seed is one of the
hostile files of issue 12, derived from the furnace scene (its buffers are
data URIs, so each seed is self-contained). The compressed-mesh seeds
meshopt.glb and draco.glb are not written here: they need the libraries'
encoders, so tests/test_compressed_meshes writes them (as
/tmp/vsl_meshopt_glb_indices_exp/packed.glb and /tmp/vsl_draco_1/packed.glb)
and they were copied in. Run from anywhere:
    python3 tests/fuzz/make_seeds.py
"""
import copy
import json
import os
import shutil
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
OUT = os.path.join(HERE, "corpus", "loader")


def nested(depth):
    v = 1
    for _ in range(depth):
        v = [v]
    return v


def glb(doc, bin_chunk=b""):
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    bin_chunk += b"\0" * (-len(bin_chunk) % 4)
    body = struct.pack("<I4s", len(js), b"JSON") + js
    if bin_chunk:
        body += struct.pack("<I4s", len(bin_chunk), b"BIN\0") + bin_chunk
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def main():
    os.makedirs(OUT, exist_ok=True)
    for name in sorted(os.listdir(os.path.join(ROOT, "assets", "scenes"))):
        if name.endswith(".gltf"):
            shutil.copy(os.path.join(ROOT, "assets", "scenes", name), os.path.join(OUT, "scene-" + name))
    with open(os.path.join(ROOT, "assets", "scenes", "furnace.gltf")) as f:
        base = json.load(f)
    cam_node = next(i for i, n in enumerate(base["nodes"]) if "camera" in n)

    def variant(name, edit, binary=False):
        d = copy.deepcopy(base)
        edit(d)
        path = os.path.join(OUT, name)
        with open(path, "wb") as f:
            f.write(glb(d) if binary else json.dumps(d, separators=(",", ":")).encode())

    variant("furnace.glb", lambda d: None, binary=True)
    variant("nested-extras", lambda d: d["asset"].__setitem__("extras", nested(80)))
    variant("nested-extras.glb", lambda d: d["asset"].__setitem__("extras", nested(80)), binary=True)

    def chain(d):
        n = len(d["nodes"])
        d["nodes"] += [{"children": [n + i + 1]} for i in range(1500)] + [{"mesh": 0}]
        d["scenes"][0]["nodes"] = [n]
    variant("deep-hierarchy", chain)

    def dag(d):
        n = len(d["nodes"])
        d["nodes"] += [{"children": [n + i + 1, n + i + 1]} for i in range(24)] + [{"mesh": 0}]
        d["scenes"][0]["nodes"] = [n, cam_node]
    variant("dag", dag)

    def zeros(d):
        d["accessors"][0].pop("bufferView", None)
        d["accessors"][0]["count"] = 300000000
    variant("zero-accessor", zeros)
    variant("aspect-tiny", lambda d: d["cameras"][0]["perspective"].__setitem__("aspectRatio", 1e-5))
    variant("aspect-huge", lambda d: d["cameras"][0]["perspective"].__setitem__("aspectRatio", 1e30))
    variant("camera-far", lambda d: d["nodes"][cam_node].__setitem__("translation", [0, 0, 2e18]))
    variant("scaled-emitter", lambda d: d["nodes"][0].__setitem__("scale", [1e10, 1e10, 1e10]))

    def light(d):
        d["extensionsUsed"] = ["KHR_lights_punctual"]
        d["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "spot", "intensity": 5,
                                                               "spot": {"outerConeAngle": 0.5}}]}}
        d["nodes"].append({"translation": [1e30, 0, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}})
        d["scenes"][0]["nodes"].append(len(d["nodes"]) - 1)
    variant("light-far", light)
    variant("uri-shadow", lambda d: d["buffers"][0].__setitem__("uri", "../../../etc/shadow"))
    variant("uri-absolute", lambda d: d["buffers"][0].__setitem__("uri", "/etc/passwd"))
    variant("uri-dir", lambda d: d["buffers"][0].__setitem__("uri", "."))
    variant("wrong-type", lambda d: d["materials"][0]["pbrMetallicRoughness"].__setitem__("roughnessFactor", "0.5"))
    variant("recursive", lambda d: d["nodes"][0].__setitem__("children", [0]))


if __name__ == "__main__":
    main()
