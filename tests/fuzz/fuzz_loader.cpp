// libFuzzer harness over the glTF / GLB loader (vsl::loadScene, and
// vsl::sceneReferencedFiles, which the CLI runs on a scene first). The input is
// written to a file in a private temporary folder (the loader reads files,
// and URIs resolve inside that folder), then loaded. Any crash, sanitizer
// report, leak, timeout or out-of-memory is a finding; a SceneResult with an
// error is the expected outcome for most inputs.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "core/scene.h"

namespace {

std::string scenePath(bool binary) {
  static std::string dir = [] {
    const char* base = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    std::string tmpl = std::string(base) + "/vsl_fuzz_loader_XXXXXX";
    if (!mkdtemp(tmpl.data())) std::abort();
    return tmpl;
  }();
  return dir + (binary ? "/input.glb" : "/input.gltf");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  bool binary = size >= 4 && data[0] == 'g' && data[1] == 'l' && data[2] == 'T' && data[3] == 'F';
  std::string path = scenePath(binary);
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  if (std::fclose(f) != 0) std::abort();
  // Every file a scene names lies in its folder (the URI policy).
  static const std::string folder =
      std::filesystem::weakly_canonical(std::filesystem::path(path).parent_path()).string() + "/";
  for (const std::string& named : vsl::sceneReferencedFiles(path))
    if (named.rfind(folder, 0) != 0) std::abort();
  vsl::LoadOptions options;
  options.maxTriangles = 2'000'000;  // keeps every input within libFuzzer's memory limit
  vsl::SceneResult r = vsl::loadScene(path, options);
  // Either a scene or an error naming the file, never both or neither.
  if (r ? !r.error().empty() : r.error().find(path) == std::string::npos) std::abort();
  return 0;
}
