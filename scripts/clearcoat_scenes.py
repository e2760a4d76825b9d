#!/usr/bin/env python3
"""Writes clear-coat variants of the bundled Cornell box for the images in
docs/RESULTS.md ("Clear coat"): the tall box and the left wall become a red
plastic (base roughness 0.5) under a clear coat (KHR_materials_clearcoat,
factor 1, roughness 0.05), and the same scene with the coat's factor 0.

    python3 scripts/clearcoat_scenes.py OUTDIR   # OUTDIR/cornell-coat-{on,off}.gltf
"""
import copy
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.join(HERE, "..", "assets", "scenes", "cornell-glossy.gltf")


def variant(scene, factor):
    g = copy.deepcopy(scene)
    red = {"name": "red-lacquer",
           "pbrMetallicRoughness": {"baseColorFactor": [0.63, 0.065, 0.05, 1.0],
                                    "metallicFactor": 0.0, "roughnessFactor": 0.5},
           "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": factor,
                                                      "clearcoatRoughnessFactor": 0.05}}}
    g["materials"].append(red)
    index = len(g["materials"]) - 1
    for node in g["nodes"]:
        if node.get("name") in ("tall-box", "left-wall"):
            for prim in g["meshes"][node["mesh"]]["primitives"]:
                prim["material"] = index
    used = g.setdefault("extensionsUsed", [])
    if "KHR_materials_clearcoat" not in used:
        used.append("KHR_materials_clearcoat")
    # The buffers are referenced relative to the bundled scene.
    for b in g.get("buffers", []):
        uri = b.get("uri", "")
        if uri and not uri.startswith("data:"):
            b["uri"] = os.path.relpath(os.path.join(os.path.dirname(SOURCE), uri), OUTDIR)
    return g


if __name__ == "__main__":
    OUTDIR = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "out")
    os.makedirs(OUTDIR, exist_ok=True)
    with open(SOURCE) as f:
        scene = json.load(f)
    for name, factor in (("on", 1.0), ("off", 0.0)):
        path = os.path.join(OUTDIR, f"cornell-coat-{name}.gltf")
        with open(path, "w") as f:
            json.dump(variant(scene, factor), f)
        print(path)
