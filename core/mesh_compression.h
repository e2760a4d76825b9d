// Compressed glTF geometry, decoded into plain buffer views and accessors
// before the loader reads them (core/loader.cpp):
//   EXT_meshopt_compression (KhronosGroup/glTF, extensions/2.0/Vendor/
//     EXT_meshopt_compression): each bufferView's bytes are decoded from the
//     extension's compressed byte range with meshoptimizer (modes ATTRIBUTES,
//     TRIANGLES, INDICES; filters NONE, OCTAHEDRAL, QUATERNION, EXPONENTIAL).
//   KHR_draco_mesh_compression (extensions/2.0/Khronos/
//     KHR_draco_mesh_compression): each primitive's Draco mesh is decoded
//     with libdraco into new float attribute and uint32 index accessors.
// Either library may be missing at build time (CMake finds them optionally);
// meshoptAvailable() and dracoAvailable() say which were built in, and the
// loader refuses files that need a missing one, naming the Debian package.
// Every count, stride, offset and length is checked against the buffers
// before decoding; errors read "element: reason" (the caller adds the file).
#pragma once

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "core/result.h"

namespace tinygltf {
class Model;
}

namespace vsl {

inline constexpr const char* kMeshoptExtension = "EXT_meshopt_compression";
inline constexpr const char* kDracoExtension = "KHR_draco_mesh_compression";
inline constexpr const char* kMeshoptPackage = "libmeshoptimizer-dev";
inline constexpr const char* kDracoPackage = "libdraco-dev";

// True when this build links the decoder (meshoptimizer, Draco).
bool meshoptAvailable();
bool dracoAvailable();

// A buffer that holds no data in the file (no uri; EXT_meshopt_compression
// section "Fallback buffers"): its bytes are only the decoded buffer views.
struct FallbackBuffer {
  int index = -1;
  uint64_t byteLength = 0;  // as declared
};

// A Draco primitive's indices accessor, which has no bufferView (the data is
// in the Draco stream) and which tinygltf 2.7.0 refuses for that reason.
struct DracoIndices {
  int mesh = -1, primitive = -1, accessor = -1;
};

// What tinygltf 2.7.0 cannot parse in files with compressed geometry, taken
// out of the JSON before its parse and given back by the decoders.
struct TinygltfStubs {
  std::vector<FallbackBuffer> fallbackBuffers;
  std::vector<DracoIndices> dracoIndices;
  bool empty() const { return fallbackBuffers.empty() && dracoIndices.empty(); }
};

// Edits the parsed glTF JSON doc (isBinary: from a .glb) so that tinygltf
// accepts it: each buffer without a uri that EXT_meshopt_compression
// bufferViews decode into gets a 3-byte data: URI instead (decodeMeshopt()
// allocates its declared byteLength); with Draco built in, each
// KHR_draco_mesh_compression primitive whose indices accessor has no
// bufferView loses its "indices" (decodeDraco() restores and decodes them).
// Changes nothing when nothing needs it.
TinygltfStubs stubForTinygltf(nlohmann::json& doc, bool isBinary);

// Decodes every bufferView with EXT_meshopt_compression into its buffer's
// bytes, after giving each fallback buffer its declared size (zeros).
// inputBytes: the bytes the file and its buffers hold, which bound what
// compressed data can decode to (at most 64 bytes per compressed byte).
Result<void> decodeMeshopt(tinygltf::Model& model, const std::vector<FallbackBuffer>& fallbacks, uint64_t inputBytes);

// Decodes every triangle primitive with KHR_draco_mesh_compression: its
// attributes named in the extension and its indices are replaced by new
// accessors on a new buffer (float attributes, uint32 indices), and the
// extension is removed from the primitive. dracoIndices: the indices that
// stubForTinygltf() took out. maxTriangles bounds each mesh.
Result<void> decodeDraco(tinygltf::Model& model, const std::vector<DracoIndices>& dracoIndices, uint64_t maxTriangles);

}  // namespace vsl
