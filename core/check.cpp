#include "core/check.h"

#include <cstdio>
#include <cstdlib>

namespace vsl::detail {

void checkFailed(const char* file, int line, const char* what, const std::string& detail) {
  // One write, so that lines from threads failing together do not interleave.
  std::string message = std::string(file) + ":" + std::to_string(line) + ": " + what;
  if (!detail.empty()) message += ": " + detail;
  message += "\n";
  std::fputs(message.c_str(), stderr);
  std::fflush(stderr);
  std::abort();
}

}  // namespace vsl::detail
