// A minimal parallel-for on std::thread. Items are claimed dynamically from an
// atomic counter, so load balances across tiles of uneven cost. Plain
// std::thread keeps ThreadSanitizer builds free of false reports from
// uninstrumented task schedulers.
#pragma once

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

}  // namespace vsl
