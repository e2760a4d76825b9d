// Memory estimates made before a render starts, so that a setting that cannot
// fit is refused with a number instead of growing until the process dies.
//
// The estimate is an upper bound in the usual case, built from the sizes of
// the buffers the studio's pipeline holds at its peak (see memory_budget.cpp
// for the itemised counts): per virtual light (the set while it grows, radii,
// the k-d tree, the decoded batch) and per pixel (the many-light films and
// batch buffers, the reference films, the snapshots in flight, the GL
// textures). Scene geometry is not counted: it is already loaded when the
// estimate matters.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"

namespace vsl {

struct MemoryEstimate {
  uint64_t bytesPerLight = 0, bytesPerPixel = 0;
  uint64_t fixedBytes = 0, lightBytes = 0, pixelBytes = 0;
  uint64_t total() const { return fixedBytes + lightBytes + pixelBytes; }
};

// What an estimator holds beyond brute force's buffers, per light and per
// pixel (EstimatorInfo::memory, estimator_registry.h; MRCS: every light
// decoded at once, its reduced columns and the clustering's projection, and
// a gather point per pixel).
struct ExtraMemory {
  uint64_t bytesPerLight = 0, bytesPerPixel = 0;
};

// The studio's peak for `lights` virtual lights at width x height pixels,
// with the estimator's extra.
MemoryEstimate estimateStudioMemory(uint64_t lights, int width, int height, ExtraMemory extra = {});

// The lobe gather's second light set of `lobeLights` lights
// (ManyLightSettings::lobeGather): the set while it grows (twice its size),
// every light decoded, the k-d tree, and each light's list of candidate
// neighbours.
uint64_t lobeGatherBytes(uint64_t lobeLights);

// Bytes this process may still allocate: MemAvailable from /proc/meminfo,
// lowered to the cgroup's memory.max minus its current use when that is
// smaller. 0 when neither can be read (then no limit is applied).
uint64_t availableMemoryBytes();

// Hands the C heap's free pages back to the system (glibc's malloc_trim;
// nothing elsewhere). Many threads' arenas otherwise keep what a replaced
// scene or render freed, and resident memory creeps up with use while the
// memory in use stays flat (docs/RESULTS.md, "The studio under random
// input"). Costs about a millisecond per 100 MB held.
void returnFreeMemory();

// Asks the kernel to back [data, data + bytes) with huge pages where it
// can (Linux's madvise(MADV_HUGEPAGE), for the whole 2 MB pages inside the
// range; nothing elsewhere or below 4 MB). Call it on a large buffer before
// its first write: with 4 KB pages a first write of 64 MB takes 16,000
// page faults, a fifth of the light tracing of a million lights
// (docs/RESULTS.md, "Stochastic lightcuts", the first picture). The contents do not change.
void adviseHugePages(void* data, size_t bytes);

// v.reserve(n), the new storage advised as adviseHugePages says: for a
// large vector about to be filled (resize or push_back after it).
template <class T>
void reserveHugePages(std::vector<T>& v, size_t n) {
  v.reserve(n);
  adviseHugePages(v.data(), v.capacity() * sizeof(T));
}

// A vector of n value-initialised T, its storage advised so.
template <class T>
std::vector<T> hugePageVector(size_t n) {
  std::vector<T> v;
  reserveHugePages(v, n);
  v.resize(n);
  return v;
}

// "1.5 GB", "730 MB", "12 KB".
std::string formatBytes(uint64_t bytes);

// Success when the estimate fits in `fraction` of `available` bytes (or when
// available is 0, unknown); else an error that states the estimate, the
// budget and the largest light count and width that fit, e.g.
// "needs about 286 GB (1.1 KB per pixel at 16384x16384, 178 B per light);
// 19 GB may be used (75% of 25 GB available); with these lights a width of
// at most 4177 px fits".
Result<void> checkStudioMemory(uint64_t lights, int width, int height, uint64_t available, double fraction = 0.75,
                               ExtraMemory extra = {});

}  // namespace vsl
