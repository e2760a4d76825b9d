// Image files: multi-layer OpenEXR (float RGB per layer), tone-mapped sRGB PNG,
// and atomic text files. Every writer writes a temporary file beside the
// target and renames it, so a failed write never destroys an existing file.
// All functions return false and set *error ("path: reason") on failure.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "core/film.h"

namespace vsl {

struct Layer {
  std::string name;  // empty = the default layer (channels R, G, B)
  Image image;
};

bool writeExr(const std::string& path, const std::vector<Layer>& layers, std::string* error,
              const std::map<std::string, std::string>& attributes = {});
// Reads every RGB layer (channels NAME.R/G/B, or R/G/B for the default layer).
bool readExr(const std::string& path, std::vector<Layer>& layers, std::string* error);

// Tone mapping for display and PNG: linear * 2^exposure, clamped, sRGB-encoded.
uint8_t toSrgb8(float linear);
bool writePng(const std::string& path, const Image& image, float exposure, std::string* error);
// 8-bit RGB pixels as they are.
bool writePngRgb8(const std::string& path, int width, int height, const std::vector<uint8_t>& rgb, std::string* error);
bool writeTextFile(const std::string& path, const std::string& text, std::string* error);

}  // namespace vsl
