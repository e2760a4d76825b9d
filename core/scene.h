// core::Scene: flattened world-space triangles, materials, textures, punctual
// lights and the camera. core/loader.h fills one from a glTF 2.0 file (and is
// included here, so that a Scene's users can load one).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/loader.h"
#include "core/material.h"
#include "core/math.h"
#include "core/result.h"

namespace vsl {

struct Ray {
  Vec3 o, d;
  float tMin = 0, tMax = kInf;
};

// Pinhole perspective camera. The image plane spans yfov vertically; pixel
// (0,0) is the top-left corner.
struct Camera {
  std::string name = "default";
  Vec3 position{0, 0, 5};
  Vec3 forward{0, 0, -1}, right{1, 0, 0}, up{0, 1, 0};
  float yfov = 0.785398f;  // radians
  float aspect = 0;        // width/height from the file; 0 = unspecified

  // Ray through film position (x, y) in pixels for a W x H image.
  Ray generateRay(float x, float y, int width, int height) const;
};

// KHR_lights_punctual: a point, a spot, or a directional light (the sun: a
// parallel beam from infinitely far, docs/REFERENCE.md "Lights").
struct PunctualLight {
  enum class Type { Point, Spot, Directional };
  std::string name;
  Type type = Type::Point;
  Vec3 position;             // unused for a directional light
  Vec3 direction{0, 0, -1};  // spot axis, or the direction a directional light travels (world)
  // Colour x intensity: radiant intensity (W/sr per unit convention) of a
  // point or spot; irradiance on a surface facing a directional light
  // (W/m^2 per unit, glTF's lux).
  Vec3 intensity;
  float cosInner = 1, cosOuter = 0.70710678f;
  // Angular falloff of glTF spots: smoothstep-free linear ramp squared, as in
  // the KHR_lights_punctual reference implementation.
  float falloff(const Vec3& dirFromLight) const;
  // Total emitted power (for choosing lights in proportion to power); a
  // directional light's is what crosses the disk of the scene's bounding
  // sphere, of radius sceneRadius.
  float power(float sceneRadius) const;
};

// Everything a shading routine needs at a surface hit.
struct SurfaceHit {
  Vec3 p;
  Vec3 ng;        // geometric normal (unit, front face = glTF CCW winding)
  Frame shading;  // shading frame: n = shading normal, s = anisotropy direction
  Vec2 uv;
  Vec2 uv1;  // TEXCOORD_1 (uv where the scene has none)
  uint32_t triangle = 0;
  uint32_t material = 0;
  bool frontFace = true;  // the ray arrived on the front side
  // The shading normal comes from a normal map (Material::normalTexture).
  // Light tracing then applies the adjoint correction for shading normals
  // (docs/REFERENCE.md, "Normal maps and shading normals").
  bool normalMapped = false;
  // The clear coat's normal (world, unit, on the shading normal's side):
  // the interpolated normal, bent by clearcoatNormalTexture where there is
  // one (KHR_materials_clearcoat). Zero on a material without a coat.
  Vec3 coatNormal{0.0f};
};

struct Scene {
  std::string path;
  // Flattened world-space vertex data (one entry per vertex).
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;   // unit; zero vector = use the geometric normal
  std::vector<Vec3> tangents;  // unit xyz; zero = none
  std::vector<float> tangentSigns;
  std::vector<Vec2> uvs;
  std::vector<Vec2> uvs1;             // TEXCOORD_1; empty when no primitive has one
  std::vector<uint32_t> indices;      // 3 per triangle
  std::vector<uint32_t> triMaterial;  // per triangle
  std::vector<Material> materials;    // last entry is the glTF default material
  std::vector<Texture> textures;
  std::vector<PunctualLight> punctualLights;
  Camera camera;
  bool cameraFromFile = false;
  Vec3 boundsMin{kInf}, boundsMax{-kInf};
  std::vector<std::string> warnings;

  size_t triangleCount() const { return triMaterial.size(); }
  float triangleArea(uint32_t tri) const;
  Vec3 triangleNormal(uint32_t tri) const;  // unit geometric normal
  Vec3 center() const { return (boundsMin + boundsMax) * 0.5f; }
  float boundingRadius() const { return 0.5f * length(boundsMax - boundsMin); }

  // Fills a SurfaceHit for triangle tri at Embree barycentrics (u, v), where
  // p = (1-u-v) p0 + u p1 + v p2, hit by a ray with direction d.
  SurfaceHit surfaceHit(uint32_t tri, float u, float v, const Vec3& d) const;
  // The normal map's texel at uv as a unit tangent-space normal (+z = the
  // interpolated normal), with the material's scale applied to x and y. The
  // one place a normal map is read (a texture transform hooks in here).
  Vec3 normalMapTexel(const Material& m, Vec2 uv) const;
  // The same for any normal texture (the clear coat's) and its scale.
  Vec3 normalTexel(int texture, float scale, Vec2 uv) const;
  // The BRDF at a hit, with textures applied.
  Brdf brdf(const SurfaceHit& hit) const;
  // b under the material's clear coat at the hit (its textures applied).
  Brdf withCoat(const Material& m, const SurfaceHit& hit, const Brdf& b) const;
  // Emitted radiance leaving the hit toward direction w (zero from the back
  // face unless the material is double-sided).
  Vec3 emitted(const SurfaceHit& hit, const Vec3& w) const;
  // Emitted radiance of a triangle at barycentrics, ignoring direction. On
  // a Mask or Blend material it is weighted by the opacity there (0 or 1,
  // or alpha): emitters are sampled by area, holes included.
  Vec3 emission(uint32_t tri, Vec2 uv) const;

  // The texture coordinates a slot reads at a hit: its UV set, transformed
  // (KHR_texture_transform; core/material.h).
  Vec2 texCoord(const SurfaceHit& hit, const TextureTransform& t) const {
    return t.apply(t.texCoord() == 1 ? hit.uv1 : hit.uv);
  }
  // Alpha at triangle tri, Embree barycentrics (u, v): baseColorFactor's
  // alpha times the base colour texture's (glTF 2.0, 3.9.4; COLOR_0 is not
  // read). In [0,1].
  float alpha(uint32_t tri, float u, float v) const;
  // Whether a ray meets triangle tri at (u, v), given a uniform xi in [0,1)
  // that the ray chooses (Accel: a hash of the ray): always on an Opaque
  // material, where alpha >= alphaCutoff on Mask, where xi < alpha on Blend
  // (docs/REFERENCE.md, "Alpha: MASK and BLEND").
  bool surfacePresent(uint32_t tri, float u, float v, float xi) const;
  // Whether any triangle's material is Mask or Blend.
  bool hasAlpha() const;
};

// A camera that frames the bounding box from the +z side.
Camera frameBounds(const Vec3& bmin, const Vec3& bmax);

}  // namespace vsl
