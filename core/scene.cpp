// Geometry on a loaded Scene: camera rays, punctual lights, triangle areas and
// normals, surface hits with their BRDF and emission. The glTF loader that
// fills a Scene is core/loader.cpp.
#include "core/scene.h"

namespace vsl {

Ray Camera::generateRay(float x, float y, int width, int height) const {
  float tanHalf = std::tan(0.5f * yfov);
  float aspectRatio = float(width) / float(height);
  float sx = (2.0f * x / width - 1.0f) * tanHalf * aspectRatio;
  float sy = (1.0f - 2.0f * y / height) * tanHalf;
  Ray r;
  r.o = position;
  r.d = normalize(forward + right * sx + up * sy);
  return r;
}

float PunctualLight::falloff(const Vec3& dirFromLight) const {
  if (type != Type::Spot) return 1.0f;
  float cd = dot(direction, dirFromLight);
  float scale = 1.0f / std::max(0.001f, cosInner - cosOuter);
  float a = clamp((cd - cosOuter) * scale, 0.0f, 1.0f);
  return a * a;
}

float PunctualLight::power(float sceneRadius) const {
  float I = luminance(intensity);
  if (type == Type::Point) return 4 * kPi * I;
  if (type == Type::Directional) return kPi * sceneRadius * sceneRadius * I;
  // Integrate the falloff over the cone: 2 pi * integral over cos in [cosOuter, 1].
  const int n = 256;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    float c = cosOuter + (1 - cosOuter) * (i + 0.5f) / n;
    float a = clamp((c - cosOuter) / std::max(0.001f, cosInner - cosOuter), 0.0f, 1.0f);
    sum += a * a;
  }
  return float(2 * kPi * I * sum * (1 - cosOuter) / n);
}

float Scene::triangleArea(uint32_t tri) const {
  const Vec3& p0 = positions[indices[3 * tri]];
  const Vec3& p1 = positions[indices[3 * tri + 1]];
  const Vec3& p2 = positions[indices[3 * tri + 2]];
  return 0.5f * length(cross(p1 - p0, p2 - p0));
}

Vec3 Scene::triangleNormal(uint32_t tri) const {
  const Vec3& p0 = positions[indices[3 * tri]];
  const Vec3& p1 = positions[indices[3 * tri + 1]];
  const Vec3& p2 = positions[indices[3 * tri + 2]];
  return normalize(cross(p1 - p0, p2 - p0));
}

namespace {

// The smallest cosine between a normal-mapped shading normal and the
// geometric normal; a map tilted further is bent back to it. A hack with a
// reason: beyond it most viewers and lights fall below the shading
// hemisphere (black texels), and the light tracer's adjoint factor
// |wo.ns| / |wo.ng| grows without need (docs/REFERENCE.md, "Normal maps and
// shading normals"). View-independent, so the BRDF stays reciprocal.
constexpr float kMinNormalMapCos = 0.2f;

// The shading normal from a tangent-space normal m (glTF 2.0, 3.9.3): the
// frame is the interpolated normal ns, the tangent t made orthogonal to it
// (Gram-Schmidt) and the bitangent cross(ns, t) * sign; all on the side of
// the front face's geometric normal ng.
Vec3 normalMapped(const Vec3& ns, const Vec3& t, float sign, const Vec3& ng, const Vec3& m) {
  const Frame tbn(ns, t);
  Vec3 n = normalize(tbn.s * m.x + tbn.t * (sign * m.y) + tbn.n * m.z);
  if (!isFinite(n)) return ns;
  const float c = dot(n, ng);
  if (c >= kMinNormalMapCos) return n;
  const Vec3 side = n - ng * c;
  const float l = length(side);
  if (!(l > 1e-6f)) return ng;
  return normalize(ng * kMinNormalMapCos + side * (std::sqrt(1 - sqr(kMinNormalMapCos)) / l));
}

// A UV set interpolated at Embree barycentrics (u, v) of triangle tri.
Vec2 uvAt(const Scene& s, const std::vector<Vec2>& set, uint32_t tri, float u, float v) {
  uint32_t i0 = s.indices[3 * tri], i1 = s.indices[3 * tri + 1], i2 = s.indices[3 * tri + 2];
  float w = 1 - u - v;
  return {set[i0].x * w + set[i1].x * u + set[i2].x * v, set[i0].y * w + set[i1].y * u + set[i2].y * v};
}

}  // namespace

Vec3 Scene::normalMapTexel(const Material& m, Vec2 uv) const { return normalTexel(m.normalTexture, m.normalScale, uv); }

Vec3 Scene::normalTexel(int texture, float scale, Vec2 uv) const {
  float texel[4];
  textures[texture].lookup(uv, false, texel);
  const Vec3 n((texel[0] * 2 - 1) * scale, (texel[1] * 2 - 1) * scale, texel[2] * 2 - 1);
  const Vec3 unit = normalize(n);
  return isFinite(unit) ? unit : Vec3(0, 0, 1);
}

SurfaceHit Scene::surfaceHit(uint32_t tri, float u, float v, const Vec3& d) const {
  SurfaceHit h;
  uint32_t i0 = indices[3 * tri], i1 = indices[3 * tri + 1], i2 = indices[3 * tri + 2];
  float w = 1 - u - v;
  h.triangle = tri;
  h.material = triMaterial[tri];
  h.p = positions[i0] * w + positions[i1] * u + positions[i2] * v;
  h.ng = triangleNormal(tri);
  h.uv = {uvs[i0].x * w + uvs[i1].x * u + uvs[i2].x * v, uvs[i0].y * w + uvs[i1].y * u + uvs[i2].y * v};
  h.uv1 = uvs1.empty() ? h.uv : uvAt(*this, uvs1, tri, u, v);
  Vec3 ns = normals[i0] * w + normals[i1] * u + normals[i2] * v;
  ns = isFinite(ns) && lengthSquared(ns) > 1e-12f ? normalize(ns) : h.ng;
  // Keep the shading normal on the geometric normal's side.
  if (dot(ns, h.ng) < 0) ns = -ns;
  Vec3 t = tangents[i0] * w + tangents[i1] * u + tangents[i2] * v;
  float sign = tangentSigns[i0] < 0 ? -1.0f : 1.0f;
  const Material& m = materials[h.material];
  // The clear coat's normal: its own map, or the interpolated normal
  // (KHR_materials_clearcoat: the base's normal map does not bend it).
  if (m.clearcoat > 0) {
    h.coatNormal = ns;
    if (m.clearcoatNormalTexture >= 0 && lengthSquared(t) > 1e-12f)
      h.coatNormal = normalMapped(
          ns, t, sign, h.ng,
          normalTexel(m.clearcoatNormalTexture, m.clearcoatNormalScale, texCoord(h, m.clearcoatNormalTransform)));
  }
  if (m.normalTexture >= 0 && lengthSquared(t) > 1e-12f) {
    ns = normalMapped(ns, t, sign, h.ng, normalMapTexel(m, texCoord(h, m.normalTransform)));
    h.normalMapped = true;
  }
  h.frontFace = dot(d, h.ng) < 0;
  if (!h.frontFace) {
    // Shade the back side as a mirror image: flip the normals.
    h.ng = -h.ng;
    ns = -ns;
    h.coatNormal = -h.coatNormal;
    sign = -sign;
  }
  // Anisotropy direction: the tangent rotated by the material's rotation in
  // the tangent-bitangent plane (KHR_materials_anisotropy).
  if (m.anisotropyStrength > 0 && lengthSquared(t) > 1e-12f) {
    Frame tb(ns, t);
    Vec3 bt = tb.t * sign;
    float rot = m.anisotropyRotation;
    float dirX = std::cos(rot), dirY = std::sin(rot);
    if (m.anisotropyTexture >= 0) {
      float texel[4];
      textures[m.anisotropyTexture].lookup(texCoord(h, m.anisotropyTransform), false, texel);
      Vec2 dtex{texel[0] * 2 - 1, texel[1] * 2 - 1};
      float x = dtex.x * dirX - dtex.y * dirY, y = dtex.x * dirY + dtex.y * dirX;
      dirX = x;
      dirY = y;
    }
    h.shading = Frame(ns, tb.s * dirX + bt * dirY);
  } else {
    h.shading = Frame(ns, t);
  }
  return h;
}

Brdf Scene::brdf(const SurfaceHit& hit) const {
  const Material& m = materials[hit.material];
  Vec3 base = m.baseColor;
  float metallic = m.metallic, roughness = m.roughness, aniso = m.anisotropyStrength;
  float texel[4];
  if (m.baseColorTexture >= 0) {
    textures[m.baseColorTexture].lookup(texCoord(hit, m.baseColorTransform), true, texel);
    base *= Vec3(texel[0], texel[1], texel[2]);
  }
  if (m.metallicRoughnessTexture >= 0) {
    textures[m.metallicRoughnessTexture].lookup(texCoord(hit, m.metallicRoughnessTransform), false, texel);
    roughness *= texel[1];
    metallic *= texel[2];
  }
  if (m.anisotropyTexture >= 0 && aniso > 0) {
    textures[m.anisotropyTexture].lookup(texCoord(hit, m.anisotropyTransform), false, texel);
    aniso *= texel[2];
  }
  const Brdf b = Brdf::fromGltf(base, metallic, roughness, aniso, m.specularWeight);
  return m.clearcoat > 0 ? withCoat(m, hit, b) : b;
}

Brdf Scene::withCoat(const Material& m, const SurfaceHit& hit, const Brdf& b) const {
  float weight = m.clearcoat, roughness = m.clearcoatRoughness, texel[4];
  if (m.clearcoatTexture >= 0) {
    textures[m.clearcoatTexture].lookup(texCoord(hit, m.clearcoatTransform), false, texel);
    weight *= texel[0];
  }
  if (m.clearcoatRoughnessTexture >= 0) {
    textures[m.clearcoatRoughnessTexture].lookup(texCoord(hit, m.clearcoatRoughnessTransform), false, texel);
    roughness *= texel[1];
  }
  // The coat's normal in the shading frame (+z where the two agree).
  Vec3 n = lengthSquared(hit.coatNormal) > 0 ? hit.shading.toLocal(hit.coatNormal) : Vec3(0, 0, 1);
  if (std::abs(n.x) < 1e-6f && std::abs(n.y) < 1e-6f) n = Vec3(0, 0, 1);
  return b.withClearcoat(weight, roughness, n.z > 0 ? normalize(n) : Vec3(0, 0, 1));
}

Vec3 Scene::emission(uint32_t tri, Vec2 bary) const {
  const Material& m = materials[triMaterial[tri]];
  if (!m.isEmissive()) return Vec3(0.0f);
  Vec3 e = m.emission;
  if (m.emissiveTexture >= 0) {
    const TextureTransform& t = m.emissiveTransform;
    Vec2 uv = uvAt(*this, t.texCoord() == 1 && !uvs1.empty() ? uvs1 : uvs, tri, bary.x, bary.y);
    float texel[4];
    textures[m.emissiveTexture].lookup(t.apply(uv), true, texel);
    e = e * Vec3(texel[0], texel[1], texel[2]);
  }
  // A sampled point in a hole emits nothing; on Blend the expected opacity
  // (a hit on the surface is kept with probability alpha, Accel).
  if (m.alphaMode == AlphaMode::Mask) return alpha(tri, bary.x, bary.y) >= m.alphaCutoff ? e : Vec3(0.0f);
  if (m.alphaMode == AlphaMode::Blend) return e * alpha(tri, bary.x, bary.y);
  return e;
}

float Scene::alpha(uint32_t tri, float u, float v) const {
  const Material& m = materials[triMaterial[tri]];
  float a = m.alpha;
  if (m.baseColorTexture >= 0) {
    const TextureTransform& t = m.baseColorTransform;
    float texel[4];
    textures[m.baseColorTexture].lookup(
        t.apply(uvAt(*this, t.texCoord() == 1 && !uvs1.empty() ? uvs1 : uvs, tri, u, v)), false, texel);
    a *= texel[3];
  }
  return clamp(a, 0.0f, 1.0f);
}

bool Scene::surfacePresent(uint32_t tri, float u, float v, float xi) const {
  const Material& m = materials[triMaterial[tri]];
  switch (m.alphaMode) {
    case AlphaMode::Opaque:
      return true;
    case AlphaMode::Mask:
      return alpha(tri, u, v) >= m.alphaCutoff;
    case AlphaMode::Blend:
      return xi < alpha(tri, u, v);
  }
  return true;
}

bool Scene::hasAlpha() const {
  for (const Material& m : materials)
    if (m.hasAlpha()) return true;
  return false;
}

Vec3 Scene::emitted(const SurfaceHit& hit, const Vec3& w) const {
  const Material& m = materials[hit.material];
  if (!m.isEmissive()) return Vec3(0.0f);
  // hit.ng faces the side the ray came from; frontFace says which side that is.
  if (!hit.frontFace && !m.doubleSided) return Vec3(0.0f);
  if (dot(w, hit.ng) <= 0) return Vec3(0.0f);
  Vec3 e = m.emission;
  if (m.emissiveTexture >= 0) {
    float texel[4];
    textures[m.emissiveTexture].lookup(texCoord(hit, m.emissiveTransform), true, texel);
    e *= Vec3(texel[0], texel[1], texel[2]);
  }
  return e;
}

Camera frameBounds(const Vec3& bmin, const Vec3& bmax) {
  Camera c;
  Vec3 center = (bmin + bmax) * 0.5f;
  float radius = std::max(0.5f * length(bmax - bmin), 1e-3f);
  float dist = radius / std::sin(0.5f * c.yfov);
  c.position = center + Vec3(0, 0, dist);
  c.forward = Vec3(0, 0, -1);
  c.right = Vec3(1, 0, 0);
  c.up = Vec3(0, 1, 0);
  c.name = "default (frames the scene)";
  return c;
}

}  // namespace vsl
