// Float textures and the shader that displays them. Tone mapping (exposure,
// sRGB) and the colour scales of maps (false colour, magma, signed) are shader
// uniforms: changing the exposure or a map's scale never re-uploads a texture
// or restarts a render. The maps themselves (error, FLIP, signed difference)
// are computed on the CPU and uploaded when the display, the component or the
// picture changes (Studio::updateTextures).
#pragma once

#include <imgui.h>

#include "core/film.h"

namespace vsl::ui {

// An RGB32F texture. Uploads only when given a new image.
class FloatTexture {
 public:
  FloatTexture() = default;
  ~FloatTexture();
  FloatTexture(const FloatTexture&) = delete;
  FloatTexture& operator=(const FloatTexture&) = delete;
  void upload(const Image& image);
  bool valid() const { return tex_ != 0 && width_ > 0; }
  int width() const { return width_; }
  int height() const { return height_; }
  ImTextureID id() const { return (ImTextureID)(intptr_t)tex_; }

 private:
  unsigned tex_ = 0;
  int width_ = 0, height_ = 0;
};

enum class DisplayMode : int {
  Tonemap = 0,         // rgb * scale, clamped, sRGB-encoded
  FalseColour = 1,     // channel mean * scale in [0,1] through falseColour()
  Signed = 2,          // channel mean * scale in [-1,1]: blue (negative), white, red (positive)
  Magma = 3,           // channel mean * scale in [0,1] through magma() (core/flip.h): FLIP maps
  Filmic = 4,          // rgb * scale through the ACES fit (studio_internal.h acesFilmic), sRGB-encoded
  LogFalseColour = 5,  // log10 luminance of rgb * scale over kFalseColourDecades through falseColour()
};

struct DisplayParams {
  DisplayMode mode = DisplayMode::Tonemap;
  float scale = 1;  // exposure multiplier, or 1/vmax for the maps
};

// Call once per frame before drawing images (releases last frame's parameters).
void beginFrame();
// Draws a texture over [p0,p1] with UVs [uv0,uv1] into the draw list, through
// the display shader. Safe only on the UI thread, inside an ImGui frame.
void drawImage(ImDrawList* list, const FloatTexture& tex, ImVec2 p0, ImVec2 p1, ImVec2 uv0, ImVec2 uv1,
               const DisplayParams& params);
// Releases the GL program (before the context goes away).
void shutdown();

}  // namespace vsl::ui
