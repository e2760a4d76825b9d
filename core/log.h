// Thread-safe log for runtime conditions (Embree warnings, loader warnings,
// rejected samples). Messages are kept in memory for the UI's log panel and
// echoed to stderr at or above the echo level.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace vsl {

enum class LogLevel { Debug, Info, Warning, Error };

struct LogEntry {
  LogLevel level;
  std::string message;
};

namespace log {
void write(LogLevel level, const std::string& message);
inline void info(const std::string& m) { write(LogLevel::Info, m); }
inline void warning(const std::string& m) { write(LogLevel::Warning, m); }
inline void error(const std::string& m) { write(LogLevel::Error, m); }
// Messages at or above this level are echoed to stderr (default Warning).
void setEchoLevel(LogLevel level);
// A copy of the retained messages (the newest 10,000).
std::vector<LogEntry> entries();
void clear();
const char* levelName(LogLevel level);
}  // namespace log

}  // namespace vsl
