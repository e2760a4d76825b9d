// A minimal parallel-for on std::thread. Items are claimed dynamically from an
// atomic counter, so load balances across tiles of uneven cost. Plain
// std::thread keeps ThreadSanitizer builds free of false reports from
// uninstrumented task schedulers.
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <string>

namespace vsl {

// Worker threads used by parallelFor (default: the hardware's concurrency).
int threadCount();
// Sets the worker count; n <= 0 restores the default. Not thread-safe with
// concurrent parallelFor calls: set it at start-up or in tests.
void setThreadCount(int n);

// Runs body(i) for every i in [0, count) and returns when all are done.
// body must be safe to call concurrently for different i.
// Exceptions: if body throws on any thread, the first exception is kept, no
// further item starts (items already running finish), every thread is joined
// and that exception is rethrown here, on the calling thread. Which items ran
// is then unspecified.
void parallelFor(size_t count, const std::function<void(size_t)>& body);
// The items [0, count) in chunks of `chunk` items (the last may be shorter):
// one body(begin, end) call per chunk, in parallel (pbrt-v4's ParallelFor
// over a range).
inline void parallelForChunks(size_t count, size_t chunk, const std::function<void(size_t, size_t)>& body) {
  parallelFor((count + chunk - 1) / chunk,
              [&](size_t c) { body(c * chunk, count < (c + 1) * chunk ? count : (c + 1) * chunk); });
}

// Tests: the next parallelFor (or parallelForTiles) call, from any thread,
// throws std::runtime_error(message) on a worker at `item` (the last item if
// there are fewer) instead of running body there. One-shot. Thread-safe.
void failParallelForTesting(size_t item, const std::string& message);

// Runs body(x0, y0, x1, y1) over the 16x16 tiles of a width x height image
// in parallel. Once *stop is set no further tile starts; returns false then
// (the tiles already run have had their effect). An exception from body is
// carried back to the caller as parallelFor does.
bool parallelForTiles(int width, int height, const std::atomic<bool>* stop,
                      const std::function<void(int x0, int y0, int x1, int y1)>& body);

}  // namespace vsl
