#include "core/log.h"

#include <atomic>
#include <cstdio>
#include <deque>
#include <mutex>

namespace vsl::log {
namespace {
std::mutex gMutex;
std::deque<LogEntry> gEntries;
std::atomic<int> gEcho{int(LogLevel::Warning)};
constexpr size_t kMaxEntries = 10000;
}  // namespace

const char* levelName(LogLevel level) {
  switch (level) {
    case LogLevel::Debug:
      return "debug";
    case LogLevel::Info:
      return "info";
    case LogLevel::Warning:
      return "warning";
    case LogLevel::Error:
      return "error";
  }
  return "?";
}

void write(LogLevel level, const std::string& message) {
  std::lock_guard<std::mutex> lock(gMutex);
  if (int(level) >= gEcho.load()) std::fprintf(stderr, "[%s] %s\n", levelName(level), message.c_str());
  gEntries.push_back({level, message});
  if (gEntries.size() > kMaxEntries) gEntries.pop_front();
}

void setEchoLevel(LogLevel level) { gEcho.store(int(level)); }

std::vector<LogEntry> entries() {
  std::lock_guard<std::mutex> lock(gMutex);
  return {gEntries.begin(), gEntries.end()};
}

void clear() {
  std::lock_guard<std::mutex> lock(gMutex);
  gEntries.clear();
}

}  // namespace vsl::log
