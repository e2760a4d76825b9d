// Loading glTF 2.0 (.gltf or .glb) into a core::Scene, with tinygltf.
//
// What is modelled: triangle meshes (triangles, strips, fans) through the node
// hierarchy; POSITION, NORMAL, TANGENT, TEXCOORD_0, TEXCOORD_1; the
// metallic-roughness material with base-colour, metallic-roughness and
// emissive textures; alphaMode MASK and BLEND (docs/REFERENCE.md, "Alpha:
// MASK and BLEND"); KHR_texture_transform on every texture slot read;
// KHR_materials_emissive_strength; KHR_materials_anisotropy;
// KHR_lights_punctual point, spot and directional lights; perspective cameras;
// EXT_meshopt_compression and KHR_draco_mesh_compression geometry, decoded
// first (core/mesh_compression.h).
// Everything else a file uses is reported in Scene::warnings by element name;
// invalid data makes loadScene() fail with a message naming file and element.
// Only glTF 2.0 is read (asset.version 2.x, minVersion at most 2.0, GLB
// container version 2), with the accessor formats core glTF 2.0 allows for
// each attribute (KHR_mesh_quantization is not supported); indices and
// offsets the validator would refuse (negative, or past 2^31 - 1 for indices)
// and perspective cameras outside the specification's ranges are refused.
//
// This header needs only a declaration of Scene, so core/scene.h includes it.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "core/result.h"

namespace vsl {

struct Scene;

struct LoadOptions {
  std::string cameraName;  // empty = the first perspective camera
  // The flattened scene may hold at most this many triangles (instancing
  // through the node hierarchy multiplies a small file's meshes).
  size_t maxTriangles = 20'000'000;
  // Texels of all textures together (each is expanded to float RGBA).
  size_t maxTexels = size_t(1) << 27;
};

// Loads a .gltf or .glb file. Never throws; never crashes on hostile input.
// Limits: the file and every buffer or image it references must be regular
// files of at most 2 GiB; URIs resolve inside the scene's folder only (no
// absolute paths, no "..", no symlinks leading out, no fallback to the current
// directory); JSON nesting at most 64 levels; node hierarchy at most 1024
// levels and 1,000,000 node instances; options.maxTriangles triangles;
// textures at most 2^26 pixels each and options.maxTexels together; world-space coordinates of geometry, camera
// and lights within +-1e9; camera aspectRatio in [1/32, 32].
// On failure the error reads "file: element: reason".
using SceneResult = Result<std::shared_ptr<const Scene>>;
SceneResult loadScene(const std::string& path, const LoadOptions& options = {});

// The files a .gltf or .glb names in its buffers' and images' URIs that
// loading it would read (decoded and resolved inside its folder as the loader
// does; data: URIs and refused ones left out), from its JSON alone, so that a
// command can refuse to write over them before it starts. Empty for a file
// that cannot be read or parsed (loading it says why).
std::vector<std::string> sceneReferencedFiles(const std::string& path);

}  // namespace vsl
