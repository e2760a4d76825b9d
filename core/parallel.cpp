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

}  // namespace vsl
