// A minimal parallel-for on std::thread. Items are claimed dynamically from an
// atomic counter, so load balances across tiles of uneven cost. Plain
// std::thread keeps ThreadSanitizer builds free of false reports from
// uninstrumented task schedulers.
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>

namespace vsl {

// Worker threads used by parallelFor (default: the hardware's concurrency).
int threadCount();
// Sets the worker count; n <= 0 restores the default. Not thread-safe with
// concurrent parallelFor calls: set it at start-up or in tests.
void setThreadCount(int n);

// Runs body(i) for every i in [0, count) and returns when all are done.
// body must be safe to call concurrently for different i.
void parallelFor(size_t count, const std::function<void(size_t)>& body);

// Runs body(x0, y0, x1, y1) over the 16x16 tiles of a width x height image
// in parallel. Once *stop is set no further tile starts; returns false then
// (the tiles already run have had their effect).
bool parallelForTiles(int width, int height, const std::atomic<bool>* stop,
                      const std::function<void(int x0, int y0, int x1, int y1)>& body);

}  // namespace vsl
