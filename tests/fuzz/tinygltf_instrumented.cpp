// The fuzz build compiles tinygltf's implementation itself, instrumented for
// coverage and the sanitizers. The Debian package's libtinygltf.so (what the
// release builds use) is uninstrumented, so the fuzzer would be blind inside
// the parser; definitions in the executable take precedence over the shared
// library's. stb_image still comes from libstb.so (uninstrumented).
#define TINYGLTF_IMPLEMENTATION
#include <tiny_gltf.h>
