#include "core/memory_budget.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#if defined(__linux__)
#include <sys/mman.h>
#endif

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "core/film.h"
#include "core/gather.h"
#include "core/lobe_gather.h"
#include "core/many_light.h"
#include "core/virtual_lights.h"

namespace vsl {

MemoryEstimate estimateStudioMemory(uint64_t lights, int width, int height, ExtraMemory extra) {
  MemoryEstimate e;
  // Per light: the set's vector may hold twice its size while it grows
  // (capacity doubling), radii and the batch order (4 B each), the k-d
  // tree's index (8 B) and nodes (~8 B), and the decoded GatherLights of the
  // largest batch (at most a quarter of the lights with the studio's batch
  // schedule).
  e.bytesPerLight = 2 * sizeof(VirtualLight) + sizeof(float) + sizeof(uint32_t) + 8 + 8 + sizeof(GatherLight) / 4;
  // Per pixel, in the order the pipeline allocates:
  const uint64_t film = 4 * sizeof(double);  // Film: RGB sum + weight
  const uint64_t rgb = 3 * sizeof(float);    // Image / Vec3
  uint64_t px = 0;
  px += 7 * film;      // many-light films: direct, shared, 5 gather layers
  px += 7 * rgb;       // one batch's buffers before they are merged
  px += 12 * rgb;      // images(): 7 layers and 5 temporaries
  px += 2 * film + 8;  // the reference's films and squared sums
  px += 3 * 9 * rgb;   // snapshots: the session's, the UI's, one being built
  px += 2 * 7 * rgb;   // GL textures (llvmpipe keeps them in RAM) and their upload copies
  px += 4 * rgb;       // UI scratch: error map, component sums, metrics
  px += 28 * rgb;      // an export: 17 EXR layers and the 11 images they are made of
  // The estimator's own (EstimatorInfo::memory).
  e.bytesPerLight += extra.bytesPerLight;
  px += extra.bytesPerPixel;
  e.bytesPerPixel = px;
  e.fixedBytes = uint64_t(150) << 20;  // measured: the GL driver, ImGui, threads, a small scene and its BVH
  e.lightBytes = lights * e.bytesPerLight;
  e.pixelBytes = uint64_t(std::max(width, 0)) * uint64_t(std::max(height, 0)) * e.bytesPerPixel;
  return e;
}

uint64_t lobeGatherBytes(uint64_t lobeLights) {
  // The set while it grows (twice), the decoded lights, their records for
  // the estimates and their widened BRDFs for the chains, the tree's index,
  // nodes and packed positions (8 + 8 + 12), each light's candidate list (2k
  // indices and a radius) and its Morton code.
  return lobeLights * (2 * sizeof(VirtualLight) + sizeof(GatherLight) +
                       (LobeGatherMap::kRecordFloats + BrdfAt::kPackedFloats) * sizeof(float) + 8 + 8 + 12 +
                       2 * ManyLightSettings::kLobeGatherK * sizeof(uint32_t) + sizeof(float) + sizeof(uint32_t));
}

uint64_t availableMemoryBytes() {
  uint64_t avail = 0;
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  uint64_t kb = 0;
  std::string unit;
  while (meminfo >> key >> kb >> unit) {
    if (key == "MemAvailable:") {
      avail = kb * 1024;
      break;
    }
  }
  // cgroup v2 limit (containers): memory.max may be "max".
  std::ifstream maxFile("/sys/fs/cgroup/memory.max"), curFile("/sys/fs/cgroup/memory.current");
  std::string maxText;
  uint64_t current = 0;
  if (maxFile >> maxText && maxText != "max" && curFile >> current) {
    uint64_t limit = std::strtoull(maxText.c_str(), nullptr, 10);
    uint64_t left = limit > current ? limit - current : 0;
    avail = avail ? std::min(avail, left) : left;
  }
  return avail;
}

void returnFreeMemory() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

void adviseHugePages(void* data, size_t bytes) {
#if defined(__linux__)
  constexpr uintptr_t kHuge = uintptr_t(2) << 20;
  if (!data || bytes < 2 * kHuge) return;
  const uintptr_t b = (reinterpret_cast<uintptr_t>(data) + kHuge - 1) & ~(kHuge - 1);
  const uintptr_t e = (reinterpret_cast<uintptr_t>(data) + bytes) & ~(kHuge - 1);
  // Advice only: a kernel without transparent huge pages refuses it, and
  // the buffer works as before.
  if (e > b) (void)madvise(reinterpret_cast<void*>(b), e - b, MADV_HUGEPAGE);
#else
  (void)data;
  (void)bytes;
#endif
}

std::string formatBytes(uint64_t bytes) {
  const char* units[] = {"B", "KB", "MB", "GB", "TB"};
  double v = double(bytes);
  int u = 0;
  while (v >= 1000 && u < 4) {
    v /= 1000;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, v < 10 && u > 0 ? "%.1f %s" : "%.0f %s", v, units[u]);
  return buf;
}

Result<void> checkStudioMemory(uint64_t lights, int width, int height, uint64_t available, double fraction,
                               ExtraMemory extra) {
  MemoryEstimate e = estimateStudioMemory(lights, width, height, extra);
  if (available == 0) return {};
  const uint64_t budget = uint64_t(double(available) * fraction);
  if (e.total() <= budget) return {};
  std::ostringstream m;
  m << "needs about " << formatBytes(e.total()) << " (" << formatBytes(e.bytesPerPixel) << " per pixel at " << width
    << "x" << height << ", " << formatBytes(e.bytesPerLight) << " per light); " << formatBytes(budget)
    << " may be used (" << int(fraction * 100) << "% of " << formatBytes(available) << " available)";
  // The largest settings that fit, each with the other held.
  if (e.pixelBytes < budget)
    m << "; at this resolution at most " << (budget - e.pixelBytes - e.fixedBytes) / e.bytesPerLight << " lights fit";
  if (e.lightBytes + e.fixedBytes < budget && width > 0 && height > 0) {
    double pixels = double(budget - e.lightBytes - e.fixedBytes) / double(e.bytesPerPixel);
    double aspect = double(width) / double(height);
    int maxWidth = int(std::floor(std::sqrt(pixels * aspect)));
    if (maxWidth >= 8) m << "; with these lights a width of at most " << maxWidth << " px fits";
  }
  return Error(m.str());
}

}  // namespace vsl
