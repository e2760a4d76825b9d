// libFuzzer harness over the EXR reader (vsl::readExr), as `vsl compare` and
// `vsl tonemap` use it. The input is written to a temporary file and read.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static std::string path = [] {
    const char* base = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    return std::string(base) + "/vsl_fuzz_exr_" + std::to_string(getpid()) + ".exr";
  }();
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  if (std::fclose(f) != 0) std::abort();
  vsl::Result<std::vector<vsl::Layer>> layers = vsl::readExr(path);
  if (layers ? layers->empty() : layers.error().find(path) == std::string::npos) std::abort();
  return 0;
}
