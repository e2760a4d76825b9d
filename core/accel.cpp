#include "core/accel.h"

#include <embree3/rtcore.h>

#include <vector>

#include "core/check.h"
#include "core/log.h"

namespace vsl {

struct Accel::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
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
  RTCGeometry geom = rtcNewGeometry(I.device, RTC_GEOMETRY_TYPE_TRIANGLE);
  size_t nv = scene.positions.size(), nt = scene.triangleCount();
  auto* verts = static_cast<float*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
  auto* idx = static_cast<unsigned*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), nt));
  if (!verts || !idx) {
    rtcReleaseGeometry(geom);
    return Error("Embree: cannot allocate geometry buffers (" + std::to_string(nt) + " triangles)");
  }
  for (size_t i = 0; i < nv; ++i) {
    verts[3 * i] = scene.positions[i].x;
    verts[3 * i + 1] = scene.positions[i].y;
    verts[3 * i + 2] = scene.positions[i].z;
  }
  for (size_t i = 0; i < 3 * nt; ++i) idx[i] = scene.indices[i];
  rtcCommitGeometry(geom);
  rtcAttachGeometry(I.scene, geom);
  rtcReleaseGeometry(geom);
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
  return Hit{rh.ray.tfar, rh.hit.primID, rh.hit.u, rh.hit.v};
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
