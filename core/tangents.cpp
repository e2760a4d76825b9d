// MikkTSpace-compatible tangent generation (core/tangents.h has the method).
#include "core/tangents.h"

#include <cmath>
#include <cstring>
#include <unordered_map>
#include <vector>

namespace vsl {

namespace {

// The attributes that decide which corners share a tangent frame, compared
// bit for bit (MikkTSpace welds corners with identical position, normal and
// texture coordinate).
struct CornerKey {
  float v[8];
  bool operator==(const CornerKey& o) const { return std::memcmp(v, o.v, sizeof v) == 0; }
};
struct CornerKeyHash {
  size_t operator()(const CornerKey& k) const {
    uint64_t h = 1469598103934665603ull;  // FNV-1a over the bytes
    const auto* b = reinterpret_cast<const unsigned char*>(k.v);
    for (size_t i = 0; i < sizeof k.v; ++i) h = (h ^ b[i]) * 1099511628211ull;
    return size_t(h);
  }
};

// A triangle's dP/du and the glTF bitangent direction -dP/dv (glTF's v runs
// down the image while the normal map's +y is up: its bitangent is
// cross(n, t) w = dP/dv' with v' = 1 - v). False for a degenerate mapping.
bool triangleDerivatives(const Vec3 p[3], const Vec2 uv[3], Vec3& dpdu, Vec3& bitangent) {
  const Vec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
  const float du1 = uv[1].x - uv[0].x, dv1 = uv[1].y - uv[0].y;
  const float du2 = uv[2].x - uv[0].x, dv2 = uv[2].y - uv[0].y;
  const float det = du1 * dv2 - du2 * dv1;
  if (!(std::abs(det) > 1e-20f)) return false;
  dpdu = (e1 * dv2 - e2 * dv1) / det;
  const Vec3 dpdv = (e2 * du1 - e1 * du2) / det;
  bitangent = -dpdv;
  return isFinite(dpdu) && isFinite(bitangent);
}

// v without its component along the unit normal n, normalised (zero if
// nothing is left).
Vec3 projectUnit(const Vec3& v, const Vec3& n) {
  const Vec3 p = v - n * dot(n, v);
  const float l = length(p);
  return l > 1e-20f && std::isfinite(l) ? p / l : Vec3(0.0f);
}

// The angle at corner a of the triangle (a, b, c).
float cornerAngle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 u = b - a, w = c - a;
  const float denom = length(u) * length(w);
  if (!(denom > 0)) return 0;
  return std::acos(clamp(dot(u, w) / denom, -1.0f, 1.0f));
}

}  // namespace

void generateMikkTangents(std::span<const Vec3> positions, std::span<const Vec3> normals, std::span<const Vec2> uvs,
                          std::span<const uint32_t> tris, uint32_t first, std::span<Vec3> tangents,
                          std::span<float> signs) {
  // Group the vertices from `first` on by (position, normal, uv).
  const size_t count = positions.size() - first;
  std::unordered_map<CornerKey, uint32_t, CornerKeyHash> groupOf;
  std::vector<uint32_t> group(count);
  for (size_t i = 0; i < count; ++i) {
    const Vec3 &p = positions[first + i], &n = normals[first + i];
    const Vec2& t = uvs[first + i];
    const CornerKey key{{p.x, p.y, p.z, n.x, n.y, n.z, t.x, t.y}};
    group[i] = groupOf.try_emplace(key, uint32_t(groupOf.size())).first->second;
  }
  // Sum each corner's projected, normalised, angle-weighted frame.
  // (sumN: the faces' normals, for vertices without a normal of their own.)
  std::vector<Vec3> sumT(groupOf.size(), Vec3(0.0f)), sumB(groupOf.size(), Vec3(0.0f));
  std::vector<Vec3> sumN(groupOf.size(), Vec3(0.0f));
  for (size_t k = 0; k + 2 < tris.size(); k += 3) {
    const uint32_t idx[3] = {tris[k], tris[k + 1], tris[k + 2]};
    const Vec3 p[3] = {positions[idx[0]], positions[idx[1]], positions[idx[2]]};
    const Vec2 uv[3] = {uvs[idx[0]], uvs[idx[1]], uvs[idx[2]]};
    Vec3 dpdu, bitangent;
    if (!triangleDerivatives(p, uv, dpdu, bitangent)) continue;
    const Vec3 ng = normalize(cross(p[1] - p[0], p[2] - p[0]));
    if (!isFinite(ng)) continue;
    for (int c = 0; c < 3; ++c) {
      const Vec3 n = lengthSquared(normals[idx[c]]) > 0 ? normals[idx[c]] : ng;
      const float angle = cornerAngle(p[c], p[(c + 1) % 3], p[(c + 2) % 3]);
      const uint32_t g = group[idx[c] - first];
      sumT[g] += projectUnit(dpdu, n) * angle;
      sumB[g] += projectUnit(bitangent, n) * angle;
      sumN[g] += ng * angle;
    }
  }
  // Orthogonalise against the vertex normal; the handedness from the
  // bitangent's side of cross(n, t).
  for (size_t i = 0; i < count; ++i) {
    const uint32_t g = group[i];
    const Vec3 n = lengthSquared(normals[first + i]) > 0 ? normals[first + i] : projectUnit(sumN[g], Vec3(0.0f));
    const Vec3 t = projectUnit(sumT[g], n);
    tangents[first + i] = t;
    signs[first + i] = dot(cross(n, t), sumB[g]) < 0 ? -1.0f : 1.0f;
  }
}

}  // namespace vsl
