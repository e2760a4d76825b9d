#include "core/accel.h"

#include <embree3/rtcore.h>

#include <cstring>
#include <vector>

#include "core/check.h"
#include "core/log.h"
#include "core/rng.h"

namespace vsl {

// Triangles of Mask or Blend materials, in a geometry of their own that
// carries the alpha filter (docs/REFERENCE.md, "Alpha: MASK and BLEND").
struct AlphaGeometry {
  const Scene* scene = nullptr;
  std::vector<uint32_t> triangles;  // Embree primID -> scene triangle
};

// Geometry IDs: every triangle of a scene without Mask or Blend materials is
// in kOpaqueGeometry, in scene order (primID = triangle); otherwise the
// opaque ones are there (opaqueTriangles maps primID) and the others in
// kAlphaGeometry, the only one with filter functions, so that opaque
// geometry pays nothing for them.
constexpr unsigned kOpaqueGeometry = 0, kAlphaGeometry = 1;

struct Accel::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<uint32_t> opaqueTriangles;  // empty: the identity
  AlphaGeometry alpha;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
  uint32_t sceneTriangle(unsigned geomID, unsigned primID) const {
    if (geomID == kAlphaGeometry) return alpha.triangles[primID];
    return opaqueTriangles.empty() ? primID : opaqueTriangles[primID];
  }
};

namespace {
void embreeError(void*, RTCError code, const char* str) {
  log::error(std::string("Embree error ") + std::to_string(int(code)) + ": " + (str ? str : ""));
}

inline void toRTCRay(const Ray& r, RTCRay& out) {
  out.org_x = r.o.x;
  out.org_y = r.o.y;
  out.org_z = r.o.z;
  out.dir_x = r.d.x;
  out.dir_y = r.d.y;
  out.dir_z = r.d.z;
  out.tnear = r.tMin;
  out.tfar = r.tMax;
  out.time = 0;
  out.mask = 0xFFFFFFFFu;
  out.id = 0;
  out.flags = 0;
}

// The random number of a Blend decision: a uniform in [0,1) hashed from the
// ray's origin and direction (its bits) and the scene triangle it meets.
// Every sample traces its own rays, so the numbers are independent across
// samples, yet the same ray always gets the same answer: renders stay
// reproducible and independent of threads (docs/REFERENCE.md, "Alpha").
float blendUniform(RTCRayN* ray, unsigned N, unsigned i, uint32_t triangle) {
  const float f[6] = {RTCRayN_org_x(ray, N, i), RTCRayN_org_y(ray, N, i), RTCRayN_org_z(ray, N, i),
                      RTCRayN_dir_x(ray, N, i), RTCRayN_dir_y(ray, N, i), RTCRayN_dir_z(ray, N, i)};
  uint64_t h = mix64(triangle + 0x51ed270b27e1a4c3ULL);
  for (float v : f) {
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    h = hashCombine(h, bits);
  }
  return float(h >> 40) * 0x1p-24f;
}

// Embree's intersection and occlusion filter on kAlphaGeometry: rejects a
// hit where the surface is absent (a Mask hole, or a Blend surface the ray
// passes through); traversal then goes on behind it.
void alphaFilter(const RTCFilterFunctionNArguments* args) {
  const auto* g = static_cast<const AlphaGeometry*>(args->geometryUserPtr);
  const Scene& scene = *g->scene;
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const uint32_t tri = g->triangles[RTCHitN_primID(args->hit, args->N, i)];
    const float u = RTCHitN_u(args->hit, args->N, i), v = RTCHitN_v(args->hit, args->N, i);
    const bool blend = scene.materials[scene.triMaterial[tri]].alphaMode == AlphaMode::Blend;
    const float xi = blend ? blendUniform(args->ray, args->N, i, tri) : 0.0f;
    if (!scene.surfacePresent(tri, u, v, xi)) args->valid[i] = 0;
  }
}

// A committed triangle geometry over the scene's vertices and the listed
// triangles (all, in order, when triangles is null); null on failure.
RTCGeometry triangleGeometry(RTCDevice device, const Scene& scene, const std::vector<uint32_t>* triangles) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  size_t nv = scene.positions.size(), nt = triangles ? triangles->size() : scene.triangleCount();
  auto* verts = static_cast<float*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
  auto* idx = static_cast<unsigned*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), nt));
  if (!verts || !idx) {
    rtcReleaseGeometry(geom);
    return nullptr;
  }
  for (size_t i = 0; i < nv; ++i) {
    verts[3 * i] = scene.positions[i].x;
    verts[3 * i + 1] = scene.positions[i].y;
    verts[3 * i + 2] = scene.positions[i].z;
  }
  if (!triangles) {
    for (size_t i = 0; i < 3 * nt; ++i) idx[i] = scene.indices[i];
  } else {
    for (size_t k = 0; k < nt; ++k)
      for (int c = 0; c < 3; ++c) idx[3 * k + c] = scene.indices[3 * size_t((*triangles)[k]) + c];
  }
  return geom;
}

// Splits the triangles into opaque ones and those of Mask or Blend
// materials (left empty when there are none).
void splitByAlpha(const Scene& scene, std::vector<uint32_t>& opaque, std::vector<uint32_t>& alpha) {
  if (!scene.hasAlpha()) return;
  for (uint32_t t = 0; t < scene.triangleCount(); ++t)
    (scene.materials[scene.triMaterial[t]].hasAlpha() ? alpha : opaque).push_back(t);
  if (alpha.empty()) opaque.clear();
}
}  // namespace

Accel::Accel() : impl_(std::make_unique<Impl>()) {}
Accel::~Accel() = default;

Result<std::unique_ptr<Accel>> Accel::build(const Scene& scene) {
  std::unique_ptr<Accel> a(new Accel());
  Impl& I = *a->impl_;
  I.device = rtcNewDevice(nullptr);
  if (!I.device) {
    return Error("Embree: cannot create a device (error " + std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
  }
  rtcSetDeviceErrorFunction(I.device, embreeError, nullptr);
  I.scene = rtcNewScene(I.device);
  rtcSetSceneBuildQuality(I.scene, RTC_BUILD_QUALITY_HIGH);
  I.alpha.scene = &scene;
  splitByAlpha(scene, I.opaqueTriangles, I.alpha.triangles);
  const bool split = !I.alpha.triangles.empty();
  if (split && rtcGetDeviceProperty(I.device, RTC_DEVICE_PROPERTY_FILTER_FUNCTION_SUPPORTED) == 0)
    return Error("Embree: this Embree was built without filter functions; alphaMode MASK and BLEND need them");
  auto attach = [&](const std::vector<uint32_t>* triangles, unsigned id) -> Result<void> {
    RTCGeometry geom = triangleGeometry(I.device, scene, triangles);
    if (!geom)
      return Error("Embree: cannot allocate geometry buffers (" + std::to_string(scene.triangleCount()) +
                   " triangles)");
    if (id == kAlphaGeometry) {
      rtcSetGeometryUserData(geom, &I.alpha);
      rtcSetGeometryIntersectFilterFunction(geom, alphaFilter);
      rtcSetGeometryOccludedFilterFunction(geom, alphaFilter);
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(I.scene, geom, id);
    rtcReleaseGeometry(geom);
    return {};
  };
  Result<void> ok = !split                      ? attach(nullptr, kOpaqueGeometry)
                    : I.opaqueTriangles.empty() ? Result<void>{}
                                                : attach(&I.opaqueTriangles, kOpaqueGeometry);
  if (ok && split) ok = attach(&I.alpha.triangles, kAlphaGeometry);
  if (!ok) return Error(ok.error());
  rtcCommitScene(I.scene);
  RTCError err = rtcGetDeviceError(I.device);
  if (err != RTC_ERROR_NONE) {
    return Error("Embree: scene build failed (error " + std::to_string(int(err)) + ")");
  }
  return a;
}

std::optional<Hit> Accel::intersect(const Ray& ray) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  toRTCRay(ray, rh.ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
  return Hit{rh.ray.tfar, impl_->sceneTriangle(rh.hit.geomID, rh.hit.primID), rh.hit.u, rh.hit.v};
}

bool Accel::occluded(const Ray& ray) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  toRTCRay(ray, r);
  rtcOccluded1(impl_->scene, &ctx, &r);
  return r.tfar < 0;  // Embree sets tfar = -inf on a hit
}

void Accel::occluded(std::span<const Ray> rays, std::span<uint8_t> blocked) const {
  VSL_CHECK_EQ(blocked.size(), rays.size());
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  constexpr size_t kChunk = 256;
  RTCRay buf[kChunk];
  for (size_t start = 0; start < rays.size(); start += kChunk) {
    size_t n = std::min(kChunk, rays.size() - start);
    for (size_t i = 0; i < n; ++i) toRTCRay(rays[start + i], buf[i]);
    rtcOccluded1M(impl_->scene, &ctx, buf, unsigned(n), sizeof(RTCRay));
    for (size_t i = 0; i < n; ++i) blocked[start + i] = buf[i].tfar < 0 ? 1 : 0;
  }
}

}  // namespace vsl
