// An OpenGL 3.3 core context without any window system: EGL on Mesa's
// surfaceless platform, rendering into a framebuffer object.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"

namespace vsl::ui {

class HeadlessGL {
 public:
  HeadlessGL() = default;
  ~HeadlessGL();
  HeadlessGL(const HeadlessGL&) = delete;
  HeadlessGL& operator=(const HeadlessGL&) = delete;
  // Creates the context and a width x height RGBA8 framebuffer, and makes
  // them current. An error with the reason on failure.
  Result<void> init(int width, int height);
  void bind() const;
  int width() const { return width_; }
  int height() const { return height_; }
  // The framebuffer's pixels as RGB8, top row first.
  std::vector<uint8_t> readPixels() const;

 private:
  void* display_ = nullptr;
  void* context_ = nullptr;
  unsigned fbo_ = 0, color_ = 0;
  int width_ = 0, height_ = 0;
};

// Reads the currently bound framebuffer's rectangle (x, y from the top-left)
// as RGB8, top row first.
std::vector<uint8_t> readFramebuffer(int x, int y, int w, int h, int framebufferHeight);

}  // namespace vsl::ui
