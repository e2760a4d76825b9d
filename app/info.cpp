// `vsl info SCENE`: what the loader made of a scene: triangles, bounds,
// materials (with their triangle counts), emitters and their power, the
// camera and the loader's warnings.
#include <cstdio>

#include "app/cli.h"
#include "core/lights.h"

namespace vsl {

namespace {

struct InfoArgs {
  std::string scene, camera;
};

// Each material that is used (or is not the glTF default) with its triangle count.
void printMaterials(const Scene& s) {
  std::printf("materials  %zu (plus the glTF default)\n", s.materials.size() - 1);
  std::vector<size_t> useCount(s.materials.size(), 0);
  for (uint32_t m : s.triMaterial) ++useCount[m];
  for (size_t i = 0; i < s.materials.size(); ++i) {
    const Material& m = s.materials[i];
    if (i + 1 == s.materials.size() && useCount[i] == 0) continue;
    std::printf("  %-20s base (%.3g %.3g %.3g) metallic %.3g roughness %.3g", m.name.c_str(), m.baseColor.x,
                m.baseColor.y, m.baseColor.z, m.metallic, m.roughness);
    if (m.anisotropyStrength > 0) std::printf(" anisotropy %.3g rot %.3g", m.anisotropyStrength, m.anisotropyRotation);
    if (m.clearcoat > 0) std::printf(" clearcoat %.3g roughness %.3g", m.clearcoat, m.clearcoatRoughness);
    if (m.isEmissive()) std::printf(" emission (%.4g %.4g %.4g)", m.emission.x, m.emission.y, m.emission.z);
    if (m.alphaMode == AlphaMode::Mask) std::printf(" alpha MASK %.3g cutoff %.3g", m.alpha, m.alphaCutoff);
    if (m.alphaMode == AlphaMode::Blend) std::printf(" alpha BLEND %.3g", m.alpha);
    std::printf(" [%zu triangles]\n", useCount[i]);
  }
}

// Emitter power per emissive material, and each punctual light.
void printLights(const Scene& s) {
  LightSampler lights(s);
  std::vector<double> power(s.materials.size(), 0.0);
  for (uint32_t t = 0; t < s.triangleCount(); ++t) {
    const Material& m = s.materials[s.triMaterial[t]];
    if (m.isEmissive())
      power[s.triMaterial[t]] += luminance(m.emission) * s.triangleArea(t) * kPi * (m.doubleSided ? 2 : 1);
  }
  std::printf("lights     %zu emissive triangles, %zu punctual; total power %.6g W (luminance)\n",
              lights.emissiveTriangleCount(), s.punctualLights.size(), lights.totalPower());
  for (size_t i = 0; i < s.materials.size(); ++i)
    if (power[i] > 0) std::printf("  emissive material %-20s power %.6g W\n", s.materials[i].name.c_str(), power[i]);
  for (const PunctualLight& L : s.punctualLights) {
    const float R = s.boundingRadius();
    if (L.type == PunctualLight::Type::Directional)
      std::printf("  sun   %-20s toward (%g %g %g) irradiance (%.4g %.4g %.4g) power %.6g W over the scene\n",
                  L.name.c_str(), L.direction.x, L.direction.y, L.direction.z, L.intensity.x, L.intensity.y,
                  L.intensity.z, L.power(R));
    else
      std::printf("  %s %-20s at (%g %g %g) intensity (%.4g %.4g %.4g) power %.6g W\n",
                  L.type == PunctualLight::Type::Spot ? "spot " : "point", L.name.c_str(), L.position.x, L.position.y,
                  L.position.z, L.intensity.x, L.intensity.y, L.intensity.z, L.power(R));
  }
}

int cmdInfo(const InfoArgs& a) {
  LoadOptions opts;
  opts.cameraName = a.camera;
  SceneResult r = loadScene(a.scene, opts);
  if (!r) return fail(kExitBadInput, r.error());
  const Scene& s = **r;
  std::printf("scene      %s\n", a.scene.c_str());
  std::printf("triangles  %zu (%zu vertices)\n", s.triangleCount(), s.positions.size());
  std::printf("bounds     [%g %g %g] - [%g %g %g]\n", s.boundsMin.x, s.boundsMin.y, s.boundsMin.z, s.boundsMax.x,
              s.boundsMax.y, s.boundsMax.z);
  printMaterials(s);
  printLights(s);
  const Camera& c = s.camera;
  std::printf("camera     %s%s: position (%g %g %g) forward (%.3g %.3g %.3g) yfov %.4g rad", c.name.c_str(),
              s.cameraFromFile ? "" : " (generated)", c.position.x, c.position.y, c.position.z, c.forward.x,
              c.forward.y, c.forward.z, c.yfov);
  if (c.aspect > 0) std::printf(" aspect %.4g", c.aspect);
  std::printf("\n");
  std::printf("warnings   %zu\n", s.warnings.size());
  for (const std::string& w : s.warnings) std::printf("  %s\n", w.c_str());
  return 0;
}

}  // namespace

Subcommand addInfoCommand(CLI::App& app) {
  auto args = std::make_shared<InfoArgs>();
  CLI::App* info = app.add_subcommand("info", "Print a scene's triangles, materials, lights, camera and warnings");
  info->add_option("scene", args->scene, "Scene file (.gltf or .glb)")->required();
  info->add_option("--camera", args->camera, "Camera name");
  return {info, [args] { return cmdInfo(*args); }};
}

}  // namespace vsl
