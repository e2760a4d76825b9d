#!/usr/bin/env python3
"""Generates the bundled vsl-studio scenes as self-contained glTF 2.0 files.

    python3 assets/generate_scenes.py [OUTPUT_DIR]   (default: assets/scenes)

Unit convention shared by every scene: metres, +Y up; emitted radiance =
emissiveFactor x KHR_materials_emissive_strength, from the front face only
(counter-clockwise winding); punctual intensities are radiant intensity in
W/sr (the renderer treats glTF's candela as that unit).

Scenes
  furnace         closed diffuse box, uniform emission Le = 1, albedo a = 0.5,
                  no specular lobe (KHR_materials_specular specularFactor 0):
                  radiance everywhere is Le / (1 - a) = 2.
  cornell-glossy  Cornell box with a glossy floor and a metal box.
  tableau         brushed anisotropic metal panels and objects on a table,
                  lit mostly indirectly by a spot aimed at a wall.
  kitchen         room lit by cove lights hidden on the upper cabinets and aimed
                  at the ceiling; glossy counter, anisotropic range hood,
                  diffuse cabinets.
  hall            curved pure-metal walls (no diffuse component) lit by a stage
                  spot light.
Only the Python standard library is used; output is deterministic.
"""
import base64
import json
import math
import os
import struct
import sys


# ---- small vector helpers ---------------------------------------------------

def add(a, b): return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
def sub(a, b): return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
def mul(a, s): return [a[0] * s, a[1] * s, a[2] * s]
def dot(a, b): return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
def cross(a, b): return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    l = math.sqrt(dot(a, a))
    return [a[0] / l, a[1] / l, a[2] / l]


def rot_y(v, ang):
    c, s = math.cos(ang), math.sin(ang)
    return [c * v[0] + s * v[2], v[1], -s * v[0] + c * v[2]]


def quat_from_basis(right, up, back):
    """Quaternion (x, y, z, w) of the rotation whose columns are right, up, back."""
    m00, m01, m02 = right[0], up[0], back[0]
    m10, m11, m12 = right[1], up[1], back[1]
    m20, m21, m22 = right[2], up[2], back[2]
    tr = m00 + m11 + m22
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        w, x, y, z = 0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s
    elif m00 > m11 and m00 > m22:
        s = math.sqrt(1.0 + m00 - m11 - m22) * 2
        w, x, y, z = (m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s
    elif m11 > m22:
        s = math.sqrt(1.0 + m11 - m00 - m22) * 2
        w, x, y, z = (m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s
    else:
        s = math.sqrt(1.0 + m22 - m00 - m11) * 2
        w, x, y, z = (m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s
    n = math.sqrt(x * x + y * y + z * z + w * w)
    return [x / n, y / n, z / n, w / n]


def look_rotation(eye, target, up=(0, 1, 0)):
    """Rotation for a node at eye whose -Z axis (glTF cameras, spot lights) points at target."""
    fwd = norm(sub(target, eye))
    right = norm(cross(fwd, list(up)))
    true_up = cross(right, fwd)
    return quat_from_basis(right, true_up, mul(fwd, -1))


# ---- mesh pieces: each returns (positions, normals, tangents, uvs, indices) --

class Mesh:
    def __init__(self):
        self.p, self.n, self.t, self.uv, self.idx = [], [], [], [], []

    def extend(self, other):
        base = len(self.p)
        self.p += other.p
        self.n += other.n
        self.t += other.t
        self.uv += other.uv
        self.idx += [i + base for i in other.idx]
        return self


def quad(origin, eu, ev, subdiv=1):
    """Parallelogram origin + s*eu + t*ev, front face along cross(eu, ev)."""
    m = Mesh()
    nrm = norm(cross(eu, ev))
    tan = norm(eu)
    for j in range(subdiv + 1):
        for i in range(subdiv + 1):
            s, t = i / subdiv, j / subdiv
            m.p.append(add(origin, add(mul(eu, s), mul(ev, t))))
            m.n.append(nrm)
            m.t.append(tan + [1.0])
            m.uv.append([s, 1 - t])
    w = subdiv + 1
    for j in range(subdiv):
        for i in range(subdiv):
            a, b, c, d = j * w + i, j * w + i + 1, (j + 1) * w + i + 1, (j + 1) * w + i
            m.idx += [a, b, c, a, c, d]
    return m


def box(center, size, angle=0.0, inward=False, skip=()):
    """Axis-aligned box rotated about +Y by angle. Faces named +x -x +y -y +z -z."""
    hx, hy, hz = size[0] / 2, size[1] / 2, size[2] / 2
    faces = {
        "+x": ([hx, -hy, hz], [0, 0, -2 * hz], [0, 2 * hy, 0]),
        "-x": ([-hx, -hy, -hz], [0, 0, 2 * hz], [0, 2 * hy, 0]),
        "+y": ([-hx, hy, hz], [2 * hx, 0, 0], [0, 0, -2 * hz]),
        "-y": ([-hx, -hy, -hz], [2 * hx, 0, 0], [0, 0, 2 * hz]),
        "+z": ([-hx, -hy, hz], [2 * hx, 0, 0], [0, 2 * hy, 0]),
        "-z": ([hx, -hy, -hz], [-2 * hx, 0, 0], [0, 2 * hy, 0]),
    }
    m = Mesh()
    for name, (o, eu, ev) in faces.items():
        if name in skip:
            continue
        if inward:
            o, eu = add(o, eu), mul(eu, -1)
        o, eu, ev = rot_y(o, angle), rot_y(eu, angle), rot_y(ev, angle)
        m.extend(quad(add(center, o), eu, ev))
    return m


def cylinder_wall(center, radius, height, a0, a1, segments, inward=True):
    """Vertical cylindrical wall between angles a0..a1 (around +Y, angle 0 = -Z).
    Tangents run along the circumference (brushing follows the curve)."""
    m = Mesh()
    for i in range(segments + 1):
        a = a0 + (a1 - a0) * i / segments
        d = [math.sin(a), 0.0, -math.cos(a)]
        circ = [math.cos(a), 0.0, math.sin(a)]
        n = mul(d, -1) if inward else d
        for j in (0, 1):
            m.p.append(add(center, [d[0] * radius, j * height, d[2] * radius]))
            m.n.append(n)
            m.t.append(circ + [1.0])
            m.uv.append([i / segments, 1 - j])
    for i in range(segments):
        a, b, c, d = 2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1
        # Winding so that the front face matches n.
        if inward:
            m.idx += [a, d, c, a, c, b]
        else:
            m.idx += [a, b, c, a, c, d]
    return m


def sphere(center, radius, rings=24, segments=48):
    m = Mesh()
    for r in range(rings + 1):
        th = math.pi * r / rings
        for s in range(segments + 1):
            ph = 2 * math.pi * s / segments
            n = [math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)]
            m.p.append(add(center, mul(n, radius)))
            m.n.append(n)
            m.t.append([-math.sin(ph), 0.0, math.cos(ph), 1.0])
            m.uv.append([s / segments, r / rings])
    w = segments + 1
    for r in range(rings):
        for s in range(segments):
            a, b, c, d = r * w + s, r * w + s + 1, (r + 1) * w + s + 1, (r + 1) * w + s
            if r != 0:
                m.idx += [a, b, d]
            if r != rings - 1:
                m.idx += [b, c, d]
    return m


# ---- glTF writer ------------------------------------------------------------

class Gltf:
    def __init__(self, name):
        self.name = name
        self.blob = bytearray()
        self.doc = {
            "asset": {"version": "2.0", "generator": "vsl-studio assets/generate_scenes.py"},
            "scene": 0, "scenes": [{"name": name, "nodes": []}],
            "nodes": [], "meshes": [], "materials": [], "accessors": [], "bufferViews": [], "buffers": [],
        }
        self.used = set()
        self.lights = []

    def material(self, name, base=(0.8, 0.8, 0.8), metallic=0.0, roughness=0.5, emission=None, strength=1.0,
                 anisotropy=None, rotation=0.0, specular=None):
        m = {"name": name, "pbrMetallicRoughness": {"baseColorFactor": list(base) + [1.0],
                                                    "metallicFactor": metallic, "roughnessFactor": roughness}}
        ext = {}
        if emission is not None:
            m["emissiveFactor"] = list(emission)
            if strength != 1.0:
                ext["KHR_materials_emissive_strength"] = {"emissiveStrength": strength}
        if anisotropy is not None:
            ext["KHR_materials_anisotropy"] = {"anisotropyStrength": anisotropy, "anisotropyRotation": rotation}
        if specular is not None:
            ext["KHR_materials_specular"] = {"specularFactor": specular}
        if ext:
            m["extensions"] = ext
            self.used.update(ext.keys())
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def _view(self, data, target):
        while len(self.blob) % 4:
            self.blob.append(0)
        off = len(self.blob)
        self.blob += data
        self.doc["bufferViews"].append({"buffer": 0, "byteOffset": off, "byteLength": len(data), "target": target})
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, values, comps, ctype=5126, target=34962, minmax=False):
        flat = [x for v in values for x in (v if comps > 1 else [v])]
        fmt = "<%d%s" % (len(flat), "f" if ctype == 5126 else "I")
        view = self._view(struct.pack(fmt, *flat), target)
        acc = {"bufferView": view, "componentType": ctype, "count": len(values),
               "type": {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}[comps]}
        if minmax:
            acc["min"] = [min(v[i] for v in values) for i in range(comps)]
            acc["max"] = [max(v[i] for v in values) for i in range(comps)]
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def mesh(self, name, mesh, material, tangents=False):
        # Round to float32 first so that min/max match the stored values exactly.
        f32 = lambda v: [struct.unpack("<f", struct.pack("<f", x))[0] for x in v]
        pos = [f32(p) for p in mesh.p]
        attrs = {"POSITION": self._accessor(pos, 3, minmax=True),
                 "NORMAL": self._accessor(mesh.n, 3),
                 "TEXCOORD_0": self._accessor(mesh.uv, 2)}
        if tangents:
            attrs["TANGENT"] = self._accessor(mesh.t, 4)
        idx = self._accessor(mesh.idx, 1, ctype=5125, target=34963)
        self.doc["meshes"].append({"name": name, "primitives": [{"attributes": attrs, "indices": idx,
                                                                 "material": material}]})
        self.node({"name": name, "mesh": len(self.doc["meshes"]) - 1})

    def node(self, node):
        self.doc["nodes"].append(node)
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def camera(self, name, eye, target, yfov_deg, aspect):
        self.doc.setdefault("cameras", []).append({"name": name, "type": "perspective", "perspective": {
            "yfov": math.radians(yfov_deg), "aspectRatio": aspect, "znear": 0.01, "zfar": 100.0}})
        self.node({"name": name, "camera": len(self.doc["cameras"]) - 1, "translation": list(eye),
                   "rotation": look_rotation(eye, target)})

    def spot(self, name, eye, target, intensity, color=(1, 1, 1), inner_deg=20, outer_deg=30):
        self.lights.append({"name": name, "type": "spot", "color": list(color), "intensity": intensity,
                            "spot": {"innerConeAngle": math.radians(inner_deg),
                                     "outerConeAngle": math.radians(outer_deg)}})
        self.used.add("KHR_lights_punctual")
        self.node({"name": name, "translation": list(eye), "rotation": look_rotation(eye, target),
                   "extensions": {"KHR_lights_punctual": {"light": len(self.lights) - 1}}})

    def write(self, path):
        if self.lights:
            self.doc.setdefault("extensions", {})["KHR_lights_punctual"] = {"lights": self.lights}
        if self.used:
            self.doc["extensionsUsed"] = sorted(self.used)
        self.doc["buffers"] = [{"byteLength": len(self.blob),
                                "uri": "data:application/octet-stream;base64," +
                                       base64.b64encode(bytes(self.blob)).decode("ascii")}]
        with open(path, "w") as f:
            json.dump(self.doc, f, indent=1)
            f.write("\n")


# ---- scenes -----------------------------------------------------------------

def furnace():
    g = Gltf("furnace")
    # Albedo a = 0.5, Le = 0.5 x strength 2 = 1: radiance Le / (1 - a) = 2.
    m = g.material("furnace-wall", base=(0.5, 0.5, 0.5), metallic=0.0, roughness=1.0,
                   emission=(0.5, 0.5, 0.5), strength=2.0, specular=0.0)
    g.mesh("enclosure", box([0, 0, 0], [2, 2, 2], inward=True), m)
    g.camera("inside", [0, 0, 0.3], [0, 0, -1], 60, 1.0)
    return g


def cornell_glossy():
    g = Gltf("cornell-glossy")
    white = g.material("white", base=(0.73, 0.73, 0.73), roughness=1.0)
    red = g.material("red", base=(0.63, 0.065, 0.05), roughness=1.0)
    green = g.material("green", base=(0.14, 0.45, 0.091), roughness=1.0)
    floor = g.material("glossy-floor", base=(0.55, 0.55, 0.55), roughness=0.15)
    metal = g.material("metal", base=(0.95, 0.93, 0.88), metallic=1.0, roughness=0.25)
    light = g.material("light", base=(0.8, 0.8, 0.8), roughness=1.0, emission=(1.0, 0.85, 0.65), strength=15.0)
    g.mesh("floor", quad([-1, 0, 1], [2, 0, 0], [0, 0, -2]), floor)
    g.mesh("ceiling", quad([-1, 2, -1], [2, 0, 0], [0, 0, 2]), white)
    g.mesh("back-wall", quad([-1, 0, -1], [2, 0, 0], [0, 2, 0]), white)
    g.mesh("left-wall", quad([-1, 0, 1], [0, 0, -2], [0, 2, 0]), red)
    g.mesh("right-wall", quad([1, 0, -1], [0, 0, 2], [0, 2, 0]), green)
    g.mesh("ceiling-light", quad([-0.25, 1.995, -0.25], [0.5, 0, 0], [0, 0, 0.5]), light)
    g.mesh("tall-box", box([-0.35, 0.6, -0.35], [0.6, 1.2, 0.6], angle=0.3, skip=("-y",)), white)
    g.mesh("metal-box", box([0.4, 0.3, 0.35], [0.6, 0.6, 0.6], angle=-0.3, skip=("-y",)), metal)
    g.camera("main", [0, 1, 3.9], [0, 1, 0], 40, 1.0)
    return g


def tableau():
    g = Gltf("tableau")
    wall = g.material("wall", base=(0.75, 0.73, 0.7), roughness=1.0)
    card = g.material("reflector-card", base=(0.9, 0.88, 0.85), roughness=1.0)
    wood = g.material("table", base=(0.35, 0.2, 0.1), roughness=0.45)
    brushed_h = g.material("brushed-steel-h", base=(0.92, 0.92, 0.94), metallic=1.0, roughness=0.35,
                           anisotropy=0.85, rotation=0.0)
    brushed_v = g.material("brushed-steel-v", base=(0.95, 0.8, 0.55), metallic=1.0, roughness=0.35,
                           anisotropy=0.85, rotation=math.pi / 2)
    brushed_s = g.material("brushed-sphere", base=(0.9, 0.9, 0.92), metallic=1.0, roughness=0.3, anisotropy=0.9)
    blue = g.material("blue-ceramic", base=(0.1, 0.2, 0.6), roughness=0.2)
    # Room 6 x 3 x 6.
    g.mesh("room", box([0, 1.5, 0], [6, 3, 6], inward=True), wall)
    g.mesh("table", box([0, 0.75, -0.5], [2.4, 0.08, 1.4]), wood)
    g.mesh("table-leg", box([0, 0.355, -0.5], [0.2, 0.71, 0.2]), wood)
    g.mesh("panel-left", box([-0.6, 1.14, -0.85], [0.7, 0.7, 0.03], angle=0.35), brushed_h, tangents=True)
    g.mesh("panel-right", box([0.55, 1.14, -0.9], [0.7, 0.7, 0.03], angle=-0.3), brushed_v, tangents=True)
    g.mesh("sphere", sphere([0.05, 0.99, -0.3], 0.2), brushed_s, tangents=True)
    g.mesh("cube", box([-0.55, 0.89, -0.15], [0.2, 0.2, 0.2], angle=0.6), blue)
    # The spot lights a large white card on the left; the table sees the card.
    g.mesh("card", quad([-2.9, 0.5, 1.0], [0, 0, -2.5], [0, 2.3, 0]), card)
    g.spot("key", [1.5, 2.6, 1.8], [-2.9, 1.6, -0.2], 250.0, color=(1.0, 0.95, 0.85), inner_deg=15, outer_deg=22)
    g.camera("main", [0.0, 1.55, 1.9], [0.0, 0.95, -0.6], 38, 4 / 3)
    return g


def kitchen():
    g = Gltf("kitchen")
    wall = g.material("wall", base=(0.8, 0.78, 0.72), roughness=1.0)
    floor = g.material("floor-tiles", base=(0.45, 0.42, 0.38), roughness=0.3)
    cabinet = g.material("cabinet", base=(0.55, 0.6, 0.65), roughness=0.9)
    counter = g.material("granite-counter", base=(0.12, 0.12, 0.13), roughness=0.08)
    hood = g.material("range-hood", base=(0.9, 0.9, 0.92), metallic=1.0, roughness=0.3, anisotropy=0.8,
                      rotation=math.pi / 2)
    steel = g.material("stove-steel", base=(0.7, 0.7, 0.72), metallic=1.0, roughness=0.2)
    cove = g.material("cove-light", base=(0.8, 0.8, 0.8), roughness=1.0, emission=(1.0, 0.8, 0.6), strength=6.0)
    # Room 4 x 2.6 x 4, back wall at z = -2.
    g.mesh("room", box([0, 1.3, 0], [4, 2.6, 4], inward=True), wall, )
    g.mesh("floor", quad([-1.999, 0.001, 1.999], [3.998, 0, 0], [0, 0, -3.998]), floor)
    # Base cabinets with a glossy counter along the back wall (a gap for the stove).
    for name, cx, w in (("base-left", -1.15, 1.7), ("base-right", 1.15, 1.7)):
        g.mesh(name, box([cx, 0.43, -1.7], [w, 0.86, 0.6]), cabinet)
        g.mesh(name + "-top", box([cx, 0.88, -1.69], [w, 0.04, 0.64]), counter)
    g.mesh("stove", box([0, 0.45, -1.7], [0.6, 0.9, 0.6]), steel)
    # Upper cabinets, with a range hood between them.
    for name, cx in (("upper-left", -1.15), ("upper-right", 1.15)):
        g.mesh(name, box([cx, 1.85, -1.8], [1.7, 0.8, 0.4]), cabinet)
    g.mesh("hood", box([0, 1.75, -1.75], [0.6, 0.5, 0.5]), hood, tangents=True)
    g.mesh("hood-chimney", box([0, 2.3, -1.85], [0.3, 0.6, 0.3]), hood, tangents=True)
    # Cove lights on top of the upper cabinets, facing the ceiling, hidden by a valance.
    for name, cx in (("cove-left", -1.15), ("cove-right", 1.15)):
        g.mesh(name, quad([cx - 0.8, 2.255, -1.65], [1.6, 0, 0], [0, 0, -0.3]), cove)
        g.mesh(name + "-valance", box([cx, 2.3, -1.58], [1.7, 0.1, 0.02]), cabinet)
    g.camera("main", [1.3, 1.45, 1.8], [-0.4, 1.05, -1.8], 55, 4 / 3)
    return g


def hall():
    g = Gltf("hall")
    metal = g.material("hall-metal", base=(0.95, 0.75, 0.55), metallic=1.0, roughness=0.2)
    floor = g.material("stage-floor", base=(0.5, 0.35, 0.2), roughness=0.7)
    seats = g.material("seating", base=(0.45, 0.08, 0.08), roughness=0.9)
    g.mesh("floor", quad([-6, 0, 3], [12, 0, 0], [0, 0, -10], subdiv=4), floor)
    g.mesh("curved-walls", cylinder_wall([0, 0, 0], 5.0, 4.0, -1.9, 1.9, 64), metal)
    g.mesh("inner-shell", cylinder_wall([0, 0, -0.5], 3.2, 2.6, -0.9, 0.9, 48), metal)
    g.mesh("stage", box([0, 0.3, -2.0], [3.0, 0.6, 1.6]), floor)
    for i in range(3):
        g.mesh("seats-%d" % i, box([0, 0.25 + 0.1 * i, 0.4 + 0.8 * i], [3.5, 0.5 + 0.2 * i, 0.4]), seats)
    g.spot("stage-light", [0.0, 3.6, 2.5], [0.0, 0.6, -1.6], 60.0, color=(1.0, 0.9, 0.75), inner_deg=22,
           outer_deg=32)
    g.camera("main", [0.0, 2.4, 4.2], [0.0, 1.2, -2.5], 60, 16 / 9)
    return g


SCENES = {"furnace": furnace, "cornell-glossy": cornell_glossy, "tableau": tableau, "kitchen": kitchen,
          "hall": hall}


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "scenes")
    os.makedirs(out, exist_ok=True)
    for name, make in SCENES.items():
        path = os.path.join(out, name + ".gltf")
        make().write(path)
        print("wrote", path)


if __name__ == "__main__":
    main()
