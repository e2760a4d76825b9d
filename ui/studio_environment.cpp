// The studio's environment-light controls (core/environment.h; docs/
// REFERENCE.md, "Environment light"): a lat-long EXR map and its scale, a
// constant sky, and a sun given by elevation and azimuth. A map can also be
// dropped on the window (Studio::openEnvironment). A change reloads the
// scene's lights, so a restart follows as for any other setting.
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <cmath>

#include "ui/studio.h"

namespace vsl::ui {

namespace {

constexpr float kDegrees = 180.0f / kPi;

// A sun direction (toward the sun, +Y up) as elevation above the horizon and
// azimuth from -Z toward +X, in degrees (the lat-long map's u: azimuth/360).
void toElevationAzimuth(const Vec3& d, float& elevation, float& azimuth) {
  const Vec3 n = normalize(d);
  elevation = std::asin(std::clamp(n.y, -1.0f, 1.0f)) * kDegrees;
  azimuth = std::atan2(n.x, -n.z) * kDegrees;
  if (azimuth < 0) azimuth += 360;
}

Vec3 fromElevationAzimuth(float elevation, float azimuth) {
  const float e = elevation / kDegrees, a = azimuth / kDegrees;
  return {std::cos(e) * std::sin(a), std::sin(e), -std::cos(e) * std::cos(a)};
}

}  // namespace

bool Studio::environmentControls() {
  EnvironmentSettings& env = settings_.env;
  bool changed = false;
  ImGui::TextUnformatted("Environment light");
  ImGui::SetNextItemWidth(-60);
  const bool enter = ImGui::InputText("##envmap", &envPathInput_, ImGuiInputTextFlags_EnterReturnsTrue);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("A lat-long (equirectangular) .exr lighting the scene from far away; or drop one on the window");
  ImGui::SameLine();
  if (ImGui::Button("Set##env") || enter) {
    env.map = envPathInput_;
    changed = true;
  }
  if (env.hasMap()) {
    changed |= ImGui::DragFloat("map scale", &env.scale, 0.01f, 0.0f, 1e6f, "%.3g", ImGuiSliderFlags_Logarithmic);
    if (ImGui::SmallButton("remove map")) {
      env.map.clear();
      envPathInput_.clear();
      changed = true;
    }
  }
  changed |= ImGui::ColorEdit3("sky", &env.sky.x, ImGuiColorEditFlags_HDR | ImGuiColorEditFlags_Float);
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("Constant sky radiance from every direction (black: none)");
  bool sun = lengthSquared(env.sunDirection) > 0;
  if (ImGui::Checkbox("sun", &sun)) {
    env.sunDirection = sun ? fromElevationAzimuth(45, 60) : Vec3(0.0f);
    changed = true;
  }
  if (sun) {
    float elevation = 0, azimuth = 0;
    toElevationAzimuth(env.sunDirection, elevation, azimuth);
    bool moved = ImGui::SliderFloat("sun elevation", &elevation, -90, 90, "%.1f deg");
    moved |= ImGui::SliderFloat("sun azimuth", &azimuth, 0, 360, "%.1f deg");
    if (moved) env.sunDirection = fromElevationAzimuth(elevation, azimuth);
    changed |= moved;
    changed |= ImGui::SliderFloat("sun diameter", &env.sunDiameterDeg, 0.1f, 30, "%.2f deg");
    changed |= ImGui::DragFloat("sun irradiance", &env.sunIrradiance, 0.05f, 0, 1e6f, "%.3g W/m^2");
    env.sunDiameterDeg = std::clamp(env.sunDiameterDeg, 0.1f, 90.0f);
    env.sunIrradiance = std::max(env.sunIrradiance, 0.0f);
  }
  errorField("env-scale");
  errorField("sky");
  errorField("sun");
  return changed;
}

}  // namespace vsl::ui
