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
  tableau         the paper's anisotropic tableau: a ceiling spot aimed at three
                  brushed-metal reflector panels, which light metal and glazed
                  objects on a polished table by glossy reflection (clamped VPL
                  keeps about a third of the indirect light).
  kitchen         the paper's kitchen: LED strips hidden under the wall
                  cabinets and small diffusers under pendant domes; glossy stone
                  counter, tiled splashback and floor, lacquered cabinets,
                  brushed-steel range hood and fridge (clamped VPL loses about a
                  quarter of the indirect light).
  spot-panel      a path tracer's hard case: a narrow spot lights only a glossy
                  metal panel (roughness 0.15), whose reflection lights a diffuse
                  room; the light reaches the floor and walls almost only after
                  the glossy bounce (docs/RESULTS.md, "Bidirectional reference").
  hall            the paper's concert hall: curved walls and ceiling sails of
                  pure metal (metallic 1, no diffuse component) washed by spots,
                  organ pipes, a stage and terraced seats (the walls carry most
                  of the indirect light; diffuse-only VPLs get none of it).
  waterbottle     a real asset: two of Khronos's WaterBottle (CC0, Microsoft;
                  normal-mapped, textured metal and plastic, kept unchanged in
                  scenes/WaterBottle/ and referenced by URI) on a glossy table,
                  lit by a spot aimed at the wall.
The many-light fractions are asserted by tests/test_scenes.cpp.
Only the Python standard library is used; output is deterministic.

    python3 assets/generate_scenes.py --sunroom OUT.gltf

writes a room with one window and no light of its own (not bundled), as
interiors from other tools come: it renders black until an environment light
lights it through the window (`vsl render OUT.gltf --sky 0.5 --sun 1,0.6,0.3`;
docs/REFERENCE.md, "Environment light").

    python3 assets/generate_scenes.py --dense TRIANGLES OUT.gltf [BASE] [--textured]

writes a dense version of a bundled scene (BASE, default cornell-glossy) for
measuring how costs grow with geometry (docs/RESULTS.md, "Cost growth with
geometry and lights"): every quad face except emitters is tessellated into a grid and
dented (displaced against its normal) by smooth noise that vanishes on its edges
(so boxes stay closed), with about TRIANGLES triangles in all. Not bundled: a
million triangles make a ~40 MB file. With --textured every non-emissive
material also gets a 1024x1024 base-colour texture and normal map (tiles),
embedded (docs/RESULTS.md, "Loading a textured million-triangle asset").
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



def grid_surface(f, nu, nv, toward=None, closed_u=False):
    """Parametric surface P = f(u, v), u and v in [0, 1], on an nu x nv grid of quads.
    Normals come from the partial derivatives; the front face is flipped so that, at
    the surface's middle, it faces toward the given point. Tangents run
    along dP/du (the brushing direction of anisotropic metals)."""
    m = Mesh()
    e = 1e-4

    def frame(u, v):
        p = f(u, v)
        du = sub(f(min(u + e, 1.0), v), f(max(u - e, 0.0), v))
        dv = sub(f(u, min(v + e, 1.0)), f(u, max(v - e, 0.0)))
        if dot(du, du) < 1e-20:  # pole: the circumference shrinks to a point
            du = sub(f(min(u + e, 1.0), min(max(v, 1e-3), 1 - 1e-3)), f(max(u - e, 0.0), min(max(v, 1e-3), 1 - 1e-3)))
        if dot(dv, dv) < 1e-20:
            dv = sub(f(u, min(v + 1e-3, 1.0)), f(u, max(v - 1e-3, 0.0)))
        return p, norm(du), norm(cross(du, dv))

    flip = False
    if toward is not None:
        p, _, n = frame(0.5, 0.5)
        flip = dot(n, sub(toward, p)) < 0
    for j in range(nv + 1):
        for i in range(nu + 1):
            u, v = i / nu, j / nv
            if closed_u and i == nu:
                u = 0.0
            p, t, n = frame(u, v)
            m.p.append(p)
            m.n.append(mul(n, -1) if flip else n)
            m.t.append(t + [1.0])
            m.uv.append([u, 1 - v])
    w = nu + 1
    for j in range(nv):
        for i in range(nu):
            a, b, c, d = j * w + i, j * w + i + 1, (j + 1) * w + i + 1, (j + 1) * w + i
            for tri in ([a, d, c], [a, c, b]) if flip else ([a, b, c], [a, c, d]):
                # Skip the zero-area triangles at poles (a circumference of radius 0).
                p0, p1, p2 = (m.p[k] for k in tri)
                area2 = cross(sub(p1, p0), sub(p2, p0))
                if dot(area2, area2) > 1e-18:
                    m.idx += tri
    return m


def lathe(center, profile, segments=48, steps=None, crease_deg=30.0):
    """Surface of revolution about +Y through center. profile: points (r, y) traced
    from the axis at the bottom, over the outside and (for hollow objects) back down
    the inside; faces point away from the material. With `steps`, each profile
    segment is split in proportion to its length. Normals are smooth along the
    profile except at corners sharper than crease_deg, where vertices are split.
    Tangents run around the axis (lathe-turned brushing)."""
    lengths = [math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(profile, profile[1:])]
    pts = [profile[0]]
    for (r0, y0), (r1, y1), length in zip(profile, profile[1:], lengths):
        n = max(1, round(steps * length / sum(lengths))) if steps else 1
        pts += [(r0 + (r1 - r0) * k / n, y0 + (y1 - y0) * k / n) for k in range(1, n + 1)]
    # Outward normal of each profile segment in the (r, y) plane.
    seg_n = []
    for (r0, y0), (r1, y1) in zip(pts, pts[1:]):
        l = math.hypot(r1 - r0, y1 - y0)
        seg_n.append((((y1 - y0) / l, -(r1 - r0) / l) if l > 0 else (0.0, 0.0)))
    # Rings: (profile index, normal); a crease gives two rings at one point.
    rings = [(0, seg_n[0])]
    cos_crease = math.cos(math.radians(crease_deg))
    for k in range(1, len(pts) - 1):
        n0, n1 = seg_n[k - 1], seg_n[k]
        if n0[0] * n1[0] + n0[1] * n1[1] < cos_crease:
            rings += [(k, n0), (k, n1)]
        else:
            l = math.hypot(n0[0] + n1[0], n0[1] + n1[1])
            rings.append((k, ((n0[0] + n1[0]) / l, (n0[1] + n1[1]) / l)))
    rings.append((len(pts) - 1, seg_n[-1]))
    m = Mesh()
    for k, (nr, ny) in rings:
        r, y = pts[k]
        for i in range(segments + 1):
            a = 2 * math.pi * (i % segments) / segments
            c, s_ = math.cos(a), math.sin(a)
            m.p.append([center[0] + r * c, center[1] + y, center[2] - r * s_])
            m.n.append([nr * c, ny, -nr * s_])
            m.t.append([-s_, 0.0, -c, 1.0])
            m.uv.append([i / segments, 1 - k / (len(pts) - 1)])
    w = segments + 1
    for j in range(len(rings) - 1):
        if rings[j][0] == rings[j + 1][0]:
            continue  # the two rings of a crease
        for i in range(segments):
            a, b, c, d = j * w + i, j * w + i + 1, (j + 1) * w + i + 1, (j + 1) * w + i
            for tri in ([a, b, c], [a, c, d]):
                p0, p1, p2 = (m.p[q] for q in tri)
                area2 = cross(sub(p1, p0), sub(p2, p0))
                if dot(area2, area2) > 1e-18:  # skip the zero-area triangles at the axis
                    m.idx += tri
    return m


def torus(center, major, minor, axis_angle=0.0, segments=64, rings=24):
    """Torus around the Y axis tilted by axis_angle about X (outward faces)."""
    ca, sa = math.cos(axis_angle), math.sin(axis_angle)

    def f(u, v):
        a, b = 2 * math.pi * u, 2 * math.pi * v
        x = (major + minor * math.cos(b)) * math.cos(a)
        z = -(major + minor * math.cos(b)) * math.sin(a)
        y = minor * math.sin(b)
        return [center[0] + x, center[1] + ca * y - sa * z, center[2] + sa * y + ca * z]

    return grid_surface(f, segments, rings, closed_u=True)


def curved_panel(center, width, height, bend, yaw=0.0, nu=32, nv=8):
    """Rectangular panel width x height centred at center, bent into an arc of
    sagitta `bend` along its width, rotated by yaw about +Y; the front face (its
    concave side) looks along the rotated +Z."""
    def f(u, v):
        x = (u - 0.5) * width
        y = (v - 0.5) * height
        z = bend * (1 - (2 * u - 1) ** 2)
        return add(center, rot_y([x, y, z], yaw))

    return grid_surface(f, nu, nv, toward=add(center, rot_y([0, 0, 10], yaw)))


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
        self.external_buffers = []

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
                                       base64.b64encode(bytes(self.blob)).decode("ascii")}] + self.external_buffers
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


def vase_profile(h, r_foot, r_belly, r_neck, r_lip, wall=0.008, n=24):
    """Closed profile of a hollow vase: bottom, outside up to the lip, inside down."""
    out = [(0.0, 0.0)]
    for k in range(n + 1):
        t = k / n
        # Belly at 35% height, neck at 80%, flaring lip at the top.
        r = (r_foot + (r_belly - r_foot) * math.sin(min(t / 0.35, 1.0) * math.pi / 2) if t < 0.35 else
             r_belly + (r_neck - r_belly) * (0.5 - 0.5 * math.cos(math.pi * (t - 0.35) / 0.45)) if t < 0.8 else
             r_neck + (r_lip - r_neck) * ((t - 0.8) / 0.2) ** 2)
        out.append((r, t * h))
    inner = [(max(r - wall, 0.002), y) for r, y in reversed(out[1:])]
    inner[-1] = (inner[-1][0], wall)
    return out + inner + [(0.0, wall)]


def bowl_profile(r, h, wall=0.01, n=16):
    """Closed profile of a hemispherical bowl on a small foot."""
    out = [(0.0, 0.0), (r * 0.35, 0.0)]
    for k in range(1, n + 1):
        a = (math.pi / 2) * k / n
        out.append((r * 0.35 + (r - r * 0.35) * math.sin(a), h * (1 - math.cos(a))))
    inner = [(max(x - wall, 0.002), y + wall * 0.5) for x, y in reversed(out[2:])]
    return out + inner + [(0.0, wall)]


def tableau():
    """The paper's anisotropic tableau: the only light is a ceiling spot aimed at
    three brushed-metal reflector panels behind a table, so the table and the
    objects on it are lit by glossy reflection from the panels, and most of what
    the camera sees is glossy (metal objects, a lacquered tray) reflecting them."""
    g = Gltf("tableau")
    wall = g.material("wall", base=(0.16, 0.15, 0.14), roughness=1.0)
    ceiling = g.material("ceiling", base=(0.3, 0.3, 0.3), roughness=1.0)
    floor = g.material("floor", base=(0.18, 0.12, 0.08), roughness=0.6)
    table_top = g.material("polished-walnut", base=(0.2, 0.11, 0.06), roughness=0.15)
    wood = g.material("table-wood", base=(0.25, 0.14, 0.07), roughness=0.5)
    tray = g.material("black-lacquer", base=(0.03, 0.03, 0.03), roughness=0.12)
    brushed_v = g.material("brushed-steel-v", base=(0.93, 0.93, 0.95), metallic=1.0, roughness=0.15,
                           anisotropy=0.8, rotation=math.pi / 2)
    brushed_h = g.material("brushed-steel-h", base=(0.93, 0.93, 0.95), metallic=1.0, roughness=0.15,
                           anisotropy=0.8, rotation=0.0)
    brass = g.material("brushed-brass", base=(0.95, 0.78, 0.45), metallic=1.0, roughness=0.2, anisotropy=0.85)
    copper = g.material("brushed-copper", base=(0.95, 0.62, 0.5), metallic=1.0, roughness=0.22, anisotropy=0.7)
    alu = g.material("brushed-aluminium", base=(0.91, 0.92, 0.92), metallic=1.0, roughness=0.2, anisotropy=0.9)
    silver = g.material("polished-silver", base=(0.97, 0.96, 0.94), metallic=1.0, roughness=0.12)
    gold = g.material("gold", base=(1.0, 0.8, 0.4), metallic=1.0, roughness=0.18)
    glaze = g.material("blue-glaze", base=(0.08, 0.16, 0.45), roughness=0.1)
    red = g.material("red-glaze", base=(0.5, 0.06, 0.05), roughness=0.15)
    # Room 6 x 3.2 x 6, table top at y = 0.8.
    g.mesh("room-walls", box([0, 1.6, 0], [6, 3.2, 6], inward=True, skip=("+y", "-y")), wall)
    g.mesh("ceiling", quad([-3, 3.2, -3], [6, 0, 0], [0, 0, 6]), ceiling)
    g.mesh("floor", quad([-3, 0, 3], [6, 0, 0], [0, 0, -6]), floor)
    g.mesh("table-top", box([0, 0.78, -0.7], [2.4, 0.04, 1.2]), table_top)
    for i, (lx, lz) in enumerate(((-1.1, -1.22), (1.1, -1.22), (-1.1, -0.18), (1.1, -0.18))):
        g.mesh("table-leg-%d" % i, box([lx, 0.38, lz], [0.07, 0.76, 0.07]), wood)
    g.mesh("tray", box([0.45, 0.81, -0.55], [0.6, 0.02, 0.36], angle=-0.15), tray)
    # Three brushed reflector panels standing on the table's back edge, gently
    # concave, like a folding screen (brushing vertical in the middle,
    # horizontal outside), each on a thin wooden back.
    for name, cx, cz, yaw, mat in (("panel-left", -0.78, -1.08, 0.5, brushed_h),
                                   ("panel-centre", 0.0, -1.25, 0.0, brushed_v),
                                   ("panel-right", 0.78, -1.08, -0.5, brushed_h)):
        g.mesh(name, curved_panel([cx, 1.21, cz], 0.75, 0.78, 0.04, yaw=yaw, nu=40, nv=16), mat, tangents=True)
        back = [cx - 0.015 * math.sin(yaw), 1.21, cz - 0.015 * math.cos(yaw)]
        g.mesh(name + "-back", curved_panel(back, 0.75, 0.78, 0.04, yaw=yaw + math.pi, nu=8, nv=1), wood)
    # Objects on the table in front of the panels, below the spot's beam.
    g.mesh("brushed-sphere", sphere([0.05, 0.955, -0.8], 0.155, rings=48, segments=96), alu, tangents=True)
    g.mesh("brass-vase", lathe([-0.5, 0.801, -0.85], vase_profile(0.4, 0.06, 0.11, 0.04, 0.065), segments=64),
           brass, tangents=True)
    g.mesh("copper-bowl", lathe([0.55, 0.83, -0.62], bowl_profile(0.13, 0.08), segments=64), copper, tangents=True)
    g.mesh("silver-goblet", lathe([-0.2, 0.801, -0.55], [(0.0, 0.0), (0.06, 0.0), (0.065, 0.008), (0.012, 0.02),
                                                        (0.01, 0.12), (0.05, 0.16), (0.065, 0.26),
                                                        (0.058, 0.26), (0.044, 0.165), (0.0, 0.15)],
                                   segments=48, steps=40), silver, tangents=True)
    g.mesh("gold-ring", torus([0.33, 0.89, -0.9], 0.075, 0.018, axis_angle=1.3), gold)
    g.mesh("blue-vase", lathe([-0.85, 0.801, -0.6], vase_profile(0.26, 0.045, 0.085, 0.035, 0.045), segments=48), glaze)
    g.mesh("red-cube", box([0.8, 0.871, -0.85], [0.14, 0.14, 0.14], angle=0.5), red)
    g.mesh("steel-cube", box([-0.3, 0.856, -0.95], [0.11, 0.11, 0.11], angle=-0.4), brushed_h, tangents=True)
    # A ceiling spot aimed steeply at the panels: its beam passes over the
    # objects, and the panels reflect it down onto them from 0.2-0.6 m away.
    g.spot("key", [0.2, 3.1, 0.2], [0.0, 1.25, -1.2], 360.0, color=(1.0, 0.95, 0.85), inner_deg=12, outer_deg=17)
    g.camera("main", [0.0, 1.5, 1.3], [0.0, 0.98, -0.85], 40, 4 / 3)
    return g


def cylinder(center, radius, height, segments=24):
    """Closed vertical cylinder standing on center (outward faces)."""
    return lathe(center, [(0.0, 0.0), (radius, 0.0), (radius, height), (0.0, height)], segments=segments, steps=6)


def kitchen():
    """The paper's kitchen: most of the room is lit indirectly. Small hidden
    sources (LED strips under the wall cabinets, small diffusers under the
    pendant domes) light a glossy stone counter, a glossy tiled splashback and a
    glossy island top; the rest of the room (lacquered cabinets, a brushed-steel
    range hood and fridge, a glossy tiled floor) is lit by what they reflect."""
    g = Gltf("kitchen")
    wall = g.material("wall", base=(0.62, 0.6, 0.55), roughness=1.0)
    ceiling = g.material("ceiling", base=(0.8, 0.8, 0.78), roughness=1.0)
    floor = g.material("floor-tiles", base=(0.3, 0.28, 0.26), roughness=0.1)
    cabinet = g.material("cabinet-lacquer", base=(0.22, 0.3, 0.36), roughness=0.3)
    counter = g.material("granite-counter", base=(0.1, 0.1, 0.11), roughness=0.1)
    splash = g.material("splashback-tiles", base=(0.82, 0.82, 0.8), roughness=0.1)
    quartz = g.material("quartz-top", base=(0.85, 0.84, 0.8), roughness=0.08)
    glass = g.material("cooktop-glass", base=(0.02, 0.02, 0.02), roughness=0.05)
    hood = g.material("range-hood", base=(0.9, 0.9, 0.92), metallic=1.0, roughness=0.25, anisotropy=0.8,
                      rotation=math.pi / 2)
    fridge = g.material("fridge-steel", base=(0.88, 0.88, 0.9), metallic=1.0, roughness=0.25, anisotropy=0.8,
                        rotation=math.pi / 2)
    steel = g.material("polished-steel", base=(0.85, 0.85, 0.87), metallic=1.0, roughness=0.15)
    copper = g.material("copper-shade", base=(0.95, 0.64, 0.54), metallic=1.0, roughness=0.2)
    enamel = g.material("white-enamel", base=(0.9, 0.9, 0.88), roughness=0.2)
    wood = g.material("oak", base=(0.5, 0.33, 0.18), roughness=0.6)
    fruit = g.material("oranges", base=(0.8, 0.3, 0.03), roughness=0.5)
    strip = g.material("led-strip", base=(0.8, 0.8, 0.8), roughness=1.0, emission=(1.0, 0.82, 0.62), strength=500.0)
    diffuser = g.material("pendant-diffuser", base=(0.8, 0.8, 0.8), roughness=1.0, emission=(1.0, 0.8, 0.6),
                          strength=40.0)
    # Room 4.6 x 2.7 x 4.2; the back wall is at z = -2.1.
    g.mesh("walls", box([0, 1.35, 0], [4.6, 2.7, 4.2], inward=True, skip=("+y", "-y")), wall)
    g.mesh("ceiling", quad([-2.3, 2.7, -2.1], [4.6, 0, 0], [0, 0, 4.2]), ceiling)
    g.mesh("floor", quad([-2.3, 0, 2.1], [4.6, 0, 0], [0, 0, -4.2]), floor)
    # Base cabinets and counter along the back wall, a cooktop, a splashback.
    g.mesh("base-cabinets", box([-0.6, 0.44, -1.8], [3.4, 0.88, 0.6]), cabinet)
    g.mesh("plinth", box([-0.6, 0.05, -1.48], [3.4, 0.1, 0.04]), wood)
    g.mesh("counter", box([-0.6, 0.9, -1.785], [3.42, 0.04, 0.63]), counter)
    g.mesh("cooktop", quad([-0.9, 0.921, -1.55], [0.6, 0, 0], [0, 0, -0.5]), glass)
    g.mesh("splashback", quad([-2.29, 0.92, -2.099], [3.4, 0, 0], [0, 0.53, 0]), splash)
    # Wall cabinets, with LED strips on their undersides (out of sight from
    # standing height).
    for name, cx, w in (("wall-cabinet-left", -1.65, 1.3), ("wall-cabinet-right", 0.45, 1.3)):
        g.mesh(name, box([cx, 1.85, -1.925], [w, 0.8, 0.35]), cabinet)
        g.mesh(name + "-strip", quad([cx - w / 2 + 0.05, 1.449, -1.82], [w - 0.1, 0, 0], [0, 0, 0.03]), strip)
    # Range hood between the wall cabinets: a sloped canopy and a chimney.
    g.mesh("hood-canopy", box([-0.6, 1.6, -1.86], [0.8, 0.16, 0.48]), hood, tangents=True)
    g.mesh("hood-chimney", box([-0.6, 2.18, -1.97], [0.3, 1.04, 0.26]), hood, tangents=True)
    g.mesh("kettle", lathe([-0.75, 0.922, -1.8], [(0.0, 0.0), (0.09, 0.0), (0.1, 0.03), (0.1, 0.14), (0.07, 0.2),
                                                 (0.03, 0.22), (0.0, 0.22)], segments=48, steps=24), steel,
           tangents=True)
    g.mesh("pot", lathe([-0.4, 0.922, -1.65], [(0.0, 0.0), (0.11, 0.0), (0.11, 0.13), (0.1, 0.13), (0.1, 0.01),
                                              (0.0, 0.01)], segments=48, steps=16), steel)
    # A brushed-steel fridge on the right of the counter.
    g.mesh("fridge", box([1.7, 1.0, -1.75], [0.9, 2.0, 0.7]), fridge, tangents=True)
    g.mesh("fridge-handle", box([1.32, 1.15, -1.38], [0.03, 0.6, 0.03]), steel)
    # The island with a glossy quartz top, two pendants above it and stools.
    g.mesh("island", box([-0.3, 0.44, 0.1], [2.0, 0.88, 0.9]), cabinet)
    g.mesh("island-top", box([-0.3, 0.9, 0.1], [2.1, 0.04, 1.0]), quartz)
    g.mesh("fruit-bowl", lathe([-0.7, 0.921, 0.05], bowl_profile(0.15, 0.08), segments=48), enamel)
    for i, (ox, oz) in enumerate(((-0.74, 0.03), (-0.66, 0.09), (-0.69, -0.02))):
        g.mesh("orange-%d" % i, sphere([ox, 0.995 + 0.01 * i, oz], 0.045, rings=12, segments=24), fruit)
    g.mesh("cutting-board", box([0.25, 0.931, 0.15], [0.45, 0.02, 0.3], angle=0.2), wood)
    # Pendants: solid copper domes with a small diffuser disc underneath (a shade
    # lit from inside would be a thin two-sided surface).
    for name, px in (("pendant-left", -0.85), ("pendant-right", 0.25)):
        g.mesh(name + "-shade", lathe([px, 1.45, 0.1], [(0.0, 0.0), (0.17, 0.0), (0.165, 0.03), (0.06, 0.22),
                                                       (0.03, 0.28), (0.0, 0.28)], segments=48, steps=32), copper)
        g.mesh(name + "-diffuser", lathe([px, 1.449, 0.1], [(0.0, 0.0), (0.12, 0.0)], segments=48), diffuser)
        g.mesh(name + "-cord", box([px, 2.215, 0.1], [0.01, 0.97, 0.01]), steel)
    for i, sx in enumerate((-0.85, -0.3, 0.25)):
        g.mesh("stool-seat-%d" % i, cylinder([sx, 0.7, 0.9], 0.18, 0.05), wood)
        g.mesh("stool-post-%d" % i, cylinder([sx, 0.02, 0.9], 0.025, 0.68, segments=12), steel)
        g.mesh("stool-foot-%d" % i, cylinder([sx, 0.001, 0.9], 0.16, 0.019), steel)
    g.camera("main", [1.7, 1.6, 1.95], [-0.5, 1.0, -1.3], 55, 4 / 3)
    return g


def hall():
    """The paper's concert hall: curved walls and ceiling sails of pure metal
    (metallic 1, no diffuse component), washed by spots from the stage edge, so
    most indirect light reaches the seats, stage and floor by glossy reflection
    from the walls, which diffuse-only VPLs cannot emit."""
    g = Gltf("hall")
    metal = g.material("hall-metal", base=(0.95, 0.8, 0.62), metallic=1.0, roughness=0.35)
    pipes = g.material("organ-pipes", base=(0.92, 0.9, 0.86), metallic=1.0, roughness=0.2)
    floor = g.material("stage-floor", base=(0.5, 0.34, 0.2), roughness=0.5)
    aisle = g.material("aisle-floor", base=(0.3, 0.2, 0.12), roughness=0.7)
    shell = g.material("dark-shell", base=(0.12, 0.1, 0.09), roughness=1.0)
    seats = g.material("seating", base=(0.5, 0.07, 0.07), roughness=0.9)
    piano = g.material("piano-lacquer", base=(0.02, 0.02, 0.02), roughness=0.08)
    # The enclosing shell: 16 x 11 x 18, the stage at the back (z < -3).
    g.mesh("shell", box([0, 5.5, 0], [16, 11, 18], inward=True, skip=("-y",)), shell)
    g.mesh("floor", quad([-8, 0, 9], [16, 0, 0], [0, 0, -18]), aisle)
    g.mesh("stage", box([0, 0.5, -6.0], [12, 1.0, 6.0]), floor, tangents=False)
    # Curved side walls: sails that lean in toward the top and ripple along the
    # hall, from the back of the stage to the back of the seating.
    for side in (-1, 1):
        def wall_surface(u, v, side=side):
            z = -8.8 + 17.6 * u
            y = 0.2 + 9.6 * v
            x = side * (7.4 - 0.45 * math.sin(2 * math.pi * 2.5 * u) * (0.6 + 0.4 * v) - 1.6 * v * v
                        + 0.5 * math.sin(math.pi * u) * v)
            return [x, y, z]
        g.mesh("curved-wall-%s" % ("lr"[side > 0]), grid_surface(wall_surface, 160, 48, toward=[0, 4, 0]), metal)
    # Ceiling sails: shallow vaults, convex downward, between the walls.
    for k, zc in enumerate((-6.5, -3.0, 0.5, 4.0, 7.5)):
        def sail(u, v, zc=zc, k=k):
            x = -5.6 + 11.2 * u
            z = zc - 1.6 + 3.2 * v
            y = 9.4 - 0.3 * (k % 2) - 0.7 * math.sin(math.pi * u) - 0.25 * math.sin(math.pi * v)
            return [x, y, z]
        g.mesh("ceiling-sail-%d" % k, grid_surface(sail, 48, 12, toward=[0, 0, zc]), metal)
    # Organ: pipes in a curved front on the back wall.
    for i in range(31):
        t = (i - 15) / 15
        h = 4.8 - 2.2 * abs(t) + 0.6 * math.cos(7 * t)
        x = 4.5 * t
        z = -8.3 + 0.8 * t * t
        g.mesh("organ-pipe-%02d" % i, cylinder([x, 1.001, z], 0.12, h + 1.0, segments=16), pipes)
    g.mesh("piano", box([1.8, 1.5, -5.2], [1.5, 1.0, 2.2], angle=0.4, skip=("-y",)), piano)
    # Terraced seating: 11 rows in three blocks, each row a riser, a cushion
    # and a back.
    for r in range(11):
        z = -1.5 + 0.95 * r
        rise = 0.18 * r
        if r:
            g.mesh("riser-%02d" % r, box([0, rise / 2, z], [14.0, rise, 0.95]), aisle)
        for bi, (cx, w) in enumerate(((-4.6, 3.6), (0.0, 4.6), (4.6, 3.6))):
            g.mesh("seats-%02d-%d" % (r, bi), box([cx, rise + 0.251, z + 0.05], [w, 0.5, 0.5]), seats)
            g.mesh("backs-%02d-%d" % (r, bi), box([cx, rise + 0.7, z + 0.32], [w, 0.9, 0.1]), seats)
    # Light: a stage spot and four wall washers on the lighting bridge, aimed at
    # the curved walls, which reflect their light down onto the seats.
    g.spot("stage-light", [0.0, 7.4, 4.0], [0.0, 1.0, -5.0], 500.0, color=(1.0, 0.9, 0.75), inner_deg=14,
           outer_deg=20)
    for name, x, z in (("wash-left-stage", -2.5, -4.5), ("wash-left-seats", -2.5, 2.5),
                       ("wash-right-stage", 2.5, -4.5), ("wash-right-seats", 2.5, 2.5)):
        g.spot(name, [x, 7.5, z], [2.7 * x, 4.0, z], 1250.0, color=(1.0, 0.85, 0.7), inner_deg=16, outer_deg=24)
    g.camera("main", [0.0, 4.8, 8.4], [0.0, 2.6, -6.0], 62, 16 / 9)
    return g


def import_asset(g, folder, name, drop=("occlusionTexture",)):
    """Adds the glTF asset folder/name.gltf (next to the written scene, in the
    subfolder `folder`) to g by reference: its buffers, images, samplers,
    textures, materials and meshes, with every URI prefixed by folder and every
    index shifted past g's own. The material slots in `drop` are left out.
    Returns the index of the asset's first mesh."""
    here = os.path.dirname(os.path.abspath(__file__))
    with open(os.path.join(here, "scenes", folder, name + ".gltf")) as f:
        a = json.load(f)
    d = g.doc
    nb, nv, na = 1 + len(g.external_buffers), len(d["bufferViews"]), len(d["accessors"])
    nm, ni, ns, nt = len(d["materials"]), len(d.get("images", [])), len(d.get("samplers", [])), len(d.get("textures", []))
    for b in a["buffers"]:
        g.external_buffers.append({"byteLength": b["byteLength"], "uri": folder + "/" + b["uri"]})
    for v in a["bufferViews"]:
        d["bufferViews"].append(dict(v, buffer=v["buffer"] + nb))
    for acc in a["accessors"]:
        d["accessors"].append(dict(acc, bufferView=acc["bufferView"] + nv))
    for im in a.get("images", []):
        d.setdefault("images", []).append(dict(im, uri=folder + "/" + im["uri"]))
    for sm in a.get("samplers", []):
        d.setdefault("samplers", []).append(dict(sm))
    for t in a.get("textures", []):
        t2 = dict(t, source=t["source"] + ni)
        if "sampler" in t:
            t2["sampler"] = t["sampler"] + ns
        d.setdefault("textures", []).append(t2)

    def shift_textures(m):
        for k, v in list(m.items()):
            if isinstance(v, dict):
                m[k] = shift_textures(dict(v))
        if "index" in m and isinstance(m["index"], int):
            m["index"] += nt
        return m
    for m in a["materials"]:
        m = {k: v for k, v in m.items() if k not in drop}
        d["materials"].append(shift_textures(m))
    first = len(d["meshes"])
    for mesh in a["meshes"]:
        prims = []
        for p in mesh["primitives"]:
            p2 = dict(p, attributes={k: i + na for k, i in p["attributes"].items()})
            if "indices" in p:
                p2["indices"] = p["indices"] + na
            if "material" in p:
                p2["material"] = p["material"] + nm
            prims.append(p2)
        d["meshes"].append(dict(mesh, primitives=prims))
    return first


def quat_y(angle):
    return [0.0, math.sin(angle / 2), 0.0, math.cos(angle / 2)]


def waterbottle():
    """A real asset bundled: Khronos's WaterBottle (CC0, Microsoft; its files
    and LICENSE.md in scenes/WaterBottle/, unchanged), referenced, not copied:
    two bottles on a glossy lacquered table in a corner of two diffuse walls,
    with a brushed-steel reflector. One spot aimed at the back wall lights the
    bottles mostly by what the walls, the table and the steel reflect. The
    asset's occlusion texture is left out (a path tracer computes occlusion)."""
    g = Gltf("waterbottle")
    lacquer = g.material("table-lacquer", base=(0.06, 0.05, 0.045), roughness=0.12)
    wall = g.material("wall-plaster", base=(0.75, 0.72, 0.66), roughness=1.0)
    teal = g.material("teal-panel", base=(0.16, 0.42, 0.45), roughness=0.9)
    steel = g.material("brushed-steel", base=(0.9, 0.9, 0.92), metallic=1.0, roughness=0.2, anisotropy=0.7,
                       rotation=math.pi / 2)
    g.mesh("table", box([0, -0.02, 0], [1.4, 0.04, 0.8]), lacquer)
    g.mesh("back-wall", quad([-0.7, -0.04, -0.4], [1.4, 0, 0], [0, 0.94, 0]), wall)
    g.mesh("left-wall", quad([-0.7, -0.04, 0.4], [0, 0, -0.8], [0, 0.94, 0]), teal)
    g.mesh("reflector", box([0.5, 0.2, -0.18], [0.01, 0.4, 0.36], angle=-0.5), steel, tangents=True)
    bottle = import_asset(g, "WaterBottle", "WaterBottle")
    # The asset stands on y = -0.1302 (its bounds): lift it onto the table.
    g.node({"name": "bottle-left", "mesh": bottle, "translation": [-0.12, 0.1303, -0.06], "rotation": quat_y(0.6)})
    g.node({"name": "bottle-right", "mesh": bottle, "translation": [0.13, 0.1303, 0.07], "rotation": quat_y(-2.2)})
    g.spot("key-light", [0.45, 0.75, 0.7], [-0.35, 0.3, -0.4], 6.0, color=(1.0, 0.92, 0.8), inner_deg=24,
           outer_deg=34)
    g.camera("main", [0.1, 0.3, 0.98], [0.0, 0.14, 0.0], 38, 4 / 3)
    return g


def sunroom():
    """A room with one window and no light of its own (not bundled: an
    interior as other tools ship them, lit by `--sky`, `--sun` or `--env`;
    docs/REFERENCE.md, "Environment light"). The window is in the +x wall."""
    g = Gltf("sunroom")
    wall = g.material("wall", base=(0.7, 0.68, 0.64), roughness=1.0)
    floor = g.material("floor-boards", base=(0.45, 0.3, 0.18), roughness=0.25)
    sofa = g.material("sofa", base=(0.2, 0.35, 0.5), roughness=0.9)
    steel = g.material("polished-steel", base=(0.85, 0.85, 0.87), metallic=1.0, roughness=0.1)
    # Room 4 x 2.7 x 4; the window, z in [-0.8, 0.8] and y in [0.8, 2.2], faces -x.
    g.mesh("walls", box([0, 1.35, 0], [4, 2.7, 4], inward=True, skip=("+x", "-y")), wall)
    g.mesh("floor", quad([-2, 0, 2], [4, 0, 0], [0, 0, -4]), floor)
    window_wall = quad([2, 0, -2], [0, 0, 4], [0, 0.8, 0])
    window_wall.extend(quad([2, 2.2, -2], [0, 0, 4], [0, 0.5, 0]))
    window_wall.extend(quad([2, 0.8, -2], [0, 0, 1.2], [0, 1.4, 0]))
    window_wall.extend(quad([2, 0.8, 0.8], [0, 0, 1.2], [0, 1.4, 0]))
    g.mesh("window-wall", window_wall, wall)
    g.mesh("sofa", box([-1.4, 0.3, -0.5], [0.9, 0.6, 2.2]), sofa)
    g.mesh("sphere", sphere([0.2, 0.45, -1.2], 0.45), steel)
    g.camera("room", [-1.7, 1.5, 1.8], [0.6, 0.5, -0.8], 60, 1.5)
    return g


def spot_panel():
    """A narrow spot aimed at a glossy metal panel on the back wall of a diffuse
    room: the panel's blurred mirror image of the spot lands on the floor, and
    the room is lit almost only by that reflection. A path tracer finds the
    light only through a BRDF-sampled bounce onto the panel followed by a
    next-event connection through its narrow lobe; a light subpath finds the
    floor directly."""
    g = Gltf("spot-panel")
    wall = g.material("wall", base=(0.7, 0.7, 0.68), roughness=1.0)
    blue = g.material("blue-wall", base=(0.2, 0.3, 0.6), roughness=1.0)
    floor = g.material("floor", base=(0.6, 0.55, 0.5), roughness=1.0)
    panel = g.material("glossy-metal", base=(0.95, 0.93, 0.9), metallic=1.0, roughness=0.15)
    crate = g.material("crate", base=(0.7, 0.4, 0.2), roughness=1.0)
    # Room 4 x 2.6 x 4 (x, z in [-2, 2]); the panel hangs 1 cm off the back wall.
    g.mesh("walls", box([0, 1.3, 0], [4, 2.6, 4], inward=True, skip=("-y", "-x")), wall)
    g.mesh("left-wall", quad([-2, 0, 2], [0, 0, -4], [0, 2.6, 0]), blue)
    g.mesh("floor", quad([-2, 0, 2], [4, 0, 0], [0, 0, -4]), floor)
    g.mesh("panel", quad([-0.45, 0.85, -1.99], [0.9, 0, 0], [0, 0.9, 0]), panel)
    g.mesh("crate", box([0.9, 0.25, 0.2], [0.5, 0.5, 0.5], angle=0.4, skip=("-y",)), crate)
    # Aimed at the panel's centre from 2.1 m; its 8-degree cone stays on the panel.
    g.spot("spot", [0.0, 2.5, -0.3], [0.0, 1.3, -1.99], 200.0, color=(1.0, 0.95, 0.85), inner_deg=5, outer_deg=8)
    g.camera("main", [0.0, 1.5, 1.95], [0.0, 0.5, -1.0], 60, 4 / 3)
    return g


SCENES = {"furnace": furnace, "cornell-glossy": cornell_glossy, "tableau": tableau, "kitchen": kitchen,
          "hall": hall, "waterbottle": waterbottle, "spot-panel": spot_panel}


# ---- dense scenes for the geometry-scale measurement -------------------------

def _read_accessor(g, index):
    """The values of accessor `index` of a Gltf built above (float or uint32)."""
    acc = g.doc["accessors"][index]
    view = g.doc["bufferViews"][acc["bufferView"]]
    comps = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[acc["type"]]
    fmt = "<%d%s" % (acc["count"] * comps, "f" if acc["componentType"] == 5126 else "I")
    flat = struct.unpack_from(fmt, g.blob, view["byteOffset"])
    return [list(flat[i:i + comps]) for i in range(0, len(flat), comps)] if comps > 1 else list(flat)


def _quad_faces(g, prim):
    """The parallelograms (origin, eu, ev) of a primitive made of quad(..., subdiv=1)
    pieces (4 vertices and 2 triangles each, as quad() and box() write them), or
    None if it is made of anything else."""
    p = _read_accessor(g, prim["attributes"]["POSITION"])
    idx = _read_accessor(g, prim["indices"])
    if len(p) % 4 or len(idx) != len(p) // 4 * 6:
        return None
    faces = []
    for k in range(len(p) // 4):
        a = 4 * k
        if idx[6 * k:6 * k + 6] != [a, a + 1, a + 3, a, a + 3, a + 2]:
            return None
        faces.append((p[a], sub(p[a + 1], p[a]), sub(p[a + 2], p[a])))
    return faces


# Smooth noise: three plane waves (unit direction, wavelength in metres, phase).
_WAVES = [([0.48, 0.64, 0.60], 0.37, 0.3), ([-0.80, 0.36, 0.48], 0.17, 1.7), ([0.28, -0.96, 0.0], 0.071, 4.1)]


def _noise(x):
    """Value in [-1, 1] and gradient of the smooth noise at world point x."""
    v, grad = 0.0, [0.0, 0.0, 0.0]
    for k, (d, wavelength, phase) in enumerate(_WAVES):
        f, a = 2 * math.pi / wavelength, 0.5 ** k / 1.75
        arg = f * dot(d, x) + phase
        v += a * math.sin(arg)
        grad = add(grad, mul(d, a * f * math.cos(arg)))
    return v, grad


def displaced_quad(origin, eu, ev, nu, nv, amplitude):
    """quad() on an nu x nv grid, displaced against its normal (dents, so that
    nothing moves in front of the face: a ceiling stays above its light) by
    h = -amplitude x 16 s(1-s) t(1-t) x (1 + noise(P)) / 2, which is zero on the
    edges, so neighbouring faces still meet. Normals are those of the displaced
    surface."""
    m = Mesh()
    nrm = norm(cross(eu, ev))
    for j in range(nv + 1):
        for i in range(nu + 1):
            s, t = i / nu, j / nv
            x = add(origin, add(mul(eu, s), mul(ev, t)))
            v, grad = _noise(x)
            w = 16 * s * (1 - s) * t * (1 - t)
            k = -amplitude / 2
            h = k * w * (1 + v)
            dh_ds = k * (16 * (1 - 2 * s) * t * (1 - t) * (1 + v) + w * dot(grad, eu))
            dh_dt = k * (16 * s * (1 - s) * (1 - 2 * t) * (1 + v) + w * dot(grad, ev))
            m.p.append(add(x, mul(nrm, h)))
            m.n.append(norm(cross(add(eu, mul(nrm, dh_ds)), add(ev, mul(nrm, dh_dt)))))
            m.t.append(norm(eu) + [1.0])
            m.uv.append([s, 1 - t])
    w = nu + 1
    for j in range(nv):
        for i in range(nu):
            a, b, c, d = j * w + i, j * w + i + 1, (j + 1) * w + i + 1, (j + 1) * w + i
            m.idx += [a, b, c, a, c, d]
    return m


def _grid_sizes(faces, density):
    """Grid cells along each side of each face at `density` cells per metre."""
    return [(max(1, round(density * math.sqrt(dot(eu, eu)))), max(1, round(density * math.sqrt(dot(ev, ev)))))
            for _, eu, ev in faces]


def dense_scene(base, triangles):
    """`base` with its non-emissive quad faces tessellated to about `triangles`
    triangles in all (see the module docstring)."""
    src = SCENES[base]()
    g = Gltf(base + "-dense")
    g.doc["materials"], g.used, g.lights = src.doc["materials"], src.used, src.lights
    if "cameras" in src.doc:
        g.doc["cameras"] = src.doc["cameras"]
    parts = []  # (name, material, faces, emitter, tangents)
    for node in src.doc["nodes"]:
        if "mesh" not in node:
            g.node(node)
            continue
        mesh = src.doc["meshes"][node["mesh"]]
        prim = mesh["primitives"][0]
        faces = _quad_faces(src, prim)
        if faces is None:
            raise ValueError("%s: mesh '%s' is not made of quads" % (base, mesh["name"]))
        emitter = "emissiveFactor" in src.doc["materials"][prim["material"]]
        parts.append((mesh["name"], prim["material"], faces, emitter, "TANGENT" in prim["attributes"]))
    # Pick the density (cells per metre) whose total is closest to the request;
    # emitters stay flat, one quad each, so the light sources do not change.
    free = [f for _, _, faces, emitter, _ in parts if not emitter for f in faces]
    fixed = sum(2 * len(faces) for _, _, faces, emitter, _ in parts if emitter)
    count = lambda d: fixed + sum(2 * nu * nv for nu, nv in _grid_sizes(free, d))
    lo, hi = 0.0, 1.0
    while count(hi) < triangles:
        hi *= 2
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if count(mid) < triangles else (lo, mid)
    density = min((lo, hi), key=lambda d: abs(count(d) - triangles))
    for name, material, faces, emitter, tangents in parts:
        m = Mesh()
        for (o, eu, ev), (nu, nv) in zip(faces, _grid_sizes(faces, 0.0 if emitter else density)):
            amplitude = 0.0 if emitter else 0.03 * math.sqrt(min(dot(eu, eu), dot(ev, ev)))
            m.extend(displaced_quad(o, eu, ev, nu, nv, amplitude))
        g.mesh(name, m, material, tangents=tangents)
    return g


def _png(width, height, pixel):
    """A PNG (8-bit RGB, no filtering) of pixel(x, y) -> (r, g, b) in 0..255."""
    import zlib
    rows = bytearray()
    for y in range(height):
        rows.append(0)
        for x in range(width):
            rows += bytes(pixel(x, y))
    chunk = lambda kind, data: (struct.pack(">I", len(data)) + kind + data +
                                struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(bytes(rows), 6)) + chunk(b"IEND", b""))


def texture_materials(g, size):
    """Gives every non-emissive material of g a base-colour texture (tiles
    with grout, modulating the material's colour) and a normal map (the
    tiles' bevelled edges), size x size pixels each, embedded in the buffer and
    shared: what a textured asset asks of the loader."""
    tiles = 8
    def colour(x, y):
        u, v = (x * tiles / size) % 1, (y * tiles / size) % 1
        grout = min(u, v, 1 - u, 1 - v) < 0.04
        shade = 150 + 60 * ((x * tiles // size + y * tiles // size) % 2)
        return (90, 90, 90) if grout else (shade, shade, shade)
    def normal(x, y):
        u, v = (x * tiles / size) % 1, (y * tiles / size) % 1
        edge = 0.08
        nx = -0.5 if u < edge else 0.5 if u > 1 - edge else 0.0
        ny = -0.5 if v < edge else 0.5 if v > 1 - edge else 0.0
        n = norm([nx, ny, 1.0])
        return tuple(int(round(255 * (c * 0.5 + 0.5))) for c in n)
    images = []
    for name, pixel in (("tiles-colour", colour), ("tiles-normal", normal)):
        view = g._view(_png(size, size, pixel), None)
        del g.doc["bufferViews"][view]["target"]
        g.doc.setdefault("images", []).append({"name": name, "bufferView": view, "mimeType": "image/png"})
        g.doc.setdefault("textures", []).append({"source": len(g.doc["images"]) - 1})
        images.append(len(g.doc["textures"]) - 1)
    for m in g.doc["materials"]:
        if "emissiveFactor" in m:
            continue
        m["pbrMetallicRoughness"]["baseColorTexture"] = {"index": images[0]}
        m["normalTexture"] = {"index": images[1]}


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--dense":
        textured = "--textured" in sys.argv
        if textured:
            sys.argv.remove("--textured")
        if len(sys.argv) not in (4, 5):
            sys.exit("usage: generate_scenes.py --dense TRIANGLES OUT.gltf [BASE] [--textured]")
        base = sys.argv[4] if len(sys.argv) == 5 else "cornell-glossy"
        g = dense_scene(base, int(sys.argv[2]))
        if textured:
            texture_materials(g, 1024)
        g.write(sys.argv[3])
        tris = sum(len(_read_accessor(g, m["primitives"][0]["indices"])) // 3 for m in g.doc["meshes"])
        print("wrote %s (%d triangles)" % (sys.argv[3], tris))
        return
    if len(sys.argv) == 3 and sys.argv[1] == "--sunroom":
        sunroom().write(sys.argv[2])
        print("wrote", sys.argv[2])
        return
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "scenes")
    os.makedirs(out, exist_ok=True)
    for name, make in SCENES.items():
        path = os.path.join(out, name + ".gltf")
        make().write(path)
        print("wrote", path)


if __name__ == "__main__":
    main()
