#include "core/parallel.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

namespace vsl {

namespace {
std::atomic<int> gThreads{0};
// Test hook: a one-shot fault for the next parallelFor.
std::atomic<bool> gFaultArmed{false};
std::mutex gFaultMutex;
size_t gFaultItem = 0;
std::string gFaultMessage;
}  // namespace

void failParallelForTesting(size_t item, const std::string& message) {
  std::lock_guard<std::mutex> lock(gFaultMutex);
  gFaultItem = item;
  gFaultMessage = message;
  gFaultArmed.store(true);
}

int threadCount() {
  int n = gThreads.load();
  if (n > 0) return n;
  return std::max(1u, std::thread::hardware_concurrency());
}

void setThreadCount(int n) { gThreads.store(std::max(n, 0)); }

void parallelFor(size_t count, const std::function<void(size_t)>& body) {
  if (gFaultArmed.load(std::memory_order_relaxed) && gFaultArmed.exchange(false)) {
    size_t item;
    std::string message;
    {
      std::lock_guard<std::mutex> lock(gFaultMutex);
      item = std::min(gFaultItem, count ? count - 1 : 0);
      message = gFaultMessage;
    }
    return parallelFor(count, [&](size_t i) {
      if (i == item) throw std::runtime_error(message);
      body(i);
    });
  }
  size_t workers = std::min<size_t>(size_t(threadCount()), count);
  if (workers <= 1) {
    for (size_t i = 0; i < count; ++i) body(i);
    return;
  }
  // The first exception wins; once one is caught no worker claims another
  // item (items already running finish), and it is rethrown here after every
  // thread has joined. Nothing reaches std::terminate.
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex errorMutex;
  std::exception_ptr error;
  auto work = [&] {
    try {
      for (size_t i = next.fetch_add(1); i < count && !failed.load(std::memory_order_relaxed); i = next.fetch_add(1))
        body(i);
    } catch (...) {
      std::lock_guard<std::mutex> lock(errorMutex);
      if (!error) error = std::current_exception();
      failed.store(true);
    }
  };
  std::vector<std::thread> threads;
  threads.reserve(workers - 1);
  try {
    for (size_t t = 0; t + 1 < workers; ++t) threads.emplace_back(work);
  } catch (const std::system_error&) {
    // No more threads to be had: the ones started and this one share the items.
  }
  work();  // the calling thread works too
  for (std::thread& t : threads) t.join();
  if (error) std::rethrow_exception(error);
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
