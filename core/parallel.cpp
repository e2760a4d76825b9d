#include "core/parallel.h"

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace vsl {

namespace {
std::atomic<int> gThreads{0};
}

int threadCount() {
  int n = gThreads.load();
  if (n > 0) return n;
  return std::max(1u, std::thread::hardware_concurrency());
}

void setThreadCount(int n) { gThreads.store(std::max(n, 0)); }

void parallelFor(size_t count, const std::function<void(size_t)>& body) {
  size_t workers = std::min<size_t>(size_t(threadCount()), count);
  if (workers <= 1) {
    for (size_t i = 0; i < count; ++i) body(i);
    return;
  }
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t i = next.fetch_add(1); i < count; i = next.fetch_add(1)) body(i);
  };
  std::vector<std::thread> threads;
  threads.reserve(workers - 1);
  for (size_t t = 0; t + 1 < workers; ++t) threads.emplace_back(work);
  work();  // the calling thread works too
  for (std::thread& t : threads) t.join();
}

bool parallelForTiles(int width, int height, const std::atomic<bool>* stop,
                      const std::function<void(int, int, int, int)>& body) {
  constexpr int kTile = 16;
  const int tilesX = (width + kTile - 1) / kTile, tilesY = (height + kTile - 1) / kTile;
  std::atomic<bool> stopped{false};
  parallelFor(size_t(tilesX) * tilesY, [&](size_t tile) {
    if (stopped.load(std::memory_order_relaxed)) return;
    if (stop && stop->load(std::memory_order_relaxed)) {
      stopped.store(true);
      return;
    }
    const int x0 = int(tile % tilesX) * kTile, y0 = int(tile / tilesX) * kTile;
    body(x0, y0, std::min(x0 + kTile, width), std::min(y0 + kTile, height));
  });
  return !stopped.load();
}

}  // namespace vsl
