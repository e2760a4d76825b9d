// libFuzzer harness over the EXR reader (vsl::readExr), as `vsl compare` and
// `vsl tonemap` use it, and over the environment light built from the same
// file as a lat-long map (vsl::Environment, `--env`). The input is written to
// a temporary file and read.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/environment.h"
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
  // As a map: an environment, or an error naming the file.
  vsl::EnvironmentSettings env;
  env.map = path;
  auto made = vsl::Environment::create(env);
  if (made) {
    auto s = (*made)->sample(0.5f, {0.25f, 0.75f});
    if (s && !(s->pdf > 0 && std::isfinite(s->pdf))) std::abort();
  } else if (made.error().find(path) == std::string::npos) {
    std::abort();
  }
  return 0;
}
