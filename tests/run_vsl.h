// Runs the `vsl` command line from tests: its exit code and output.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace vsl::test {

struct Proc {
  int code;
  std::string out;  // stdout, and stderr when asked for
};

// Runs `build/bin/vsl ARGS` (ARGS as the shell reads them).
inline Proc runVsl(const std::string& args, bool withStderr = true) {
  std::string cmd = std::string(VSL_BINARY_DIR) + "/bin/vsl " + args + (withStderr ? " 2>&1" : " 2>/dev/null");
  Proc r{-1, ""};
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) r.out.append(buf.data(), n);
  int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace vsl::test
