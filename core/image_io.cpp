#include "core/image_io.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <stb_image_write.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>

namespace vsl {

namespace {

// A temporary path beside the target, unique within and across processes.
std::string temporaryPath(const std::string& path) {
  static std::atomic<uint64_t> counter{0};
  return path + ".tmp-" + std::to_string(getpid()) + "-" + std::to_string(counter.fetch_add(1));
}

// Moves the finished temporary file over the target, or removes it on failure.
bool commit(const std::string& tmp, const std::string& path, bool ok, std::string* error) {
  std::error_code ec;
  if (!ok) {
    std::filesystem::remove(tmp, ec);
    return false;
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    if (error) *error = path + ": cannot rename the finished file into place (" + ec.message() + ")";
    return false;
  }
  return true;
}

std::string channelName(const std::string& layer, char c) {
  return layer.empty() ? std::string(1, c) : layer + "." + c;
}

}  // namespace

bool writeExr(const std::string& path, const std::vector<Layer>& layers, std::string* error,
              const std::map<std::string, std::string>& attributes) {
  if (layers.empty()) {
    if (error) *error = path + ": no layers to write";
    return false;
  }
  int w = layers[0].image.width, h = layers[0].image.height;
  for (const Layer& l : layers)
    if (l.image.width != w || l.image.height != h || l.image.rgb.size() != size_t(w) * h * 3) {
      if (error) *error = path + ": layer '" + l.name + "' has a different size";
      return false;
    }
  std::string tmp = temporaryPath(path);
  bool ok = true;
  try {
    Imf::Header header(w, h);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const auto& [k, v] : attributes) header.insert(k, Imf::StringAttribute(v));
    Imf::FrameBuffer fb;
    for (const Layer& l : layers)
      for (int c = 0; c < 3; ++c) {
        std::string name = channelName(l.name, "RGB"[c]);
        header.channels().insert(name, Imf::Channel(Imf::FLOAT));
        fb.insert(name, Imf::Slice(Imf::FLOAT, (char*)(l.image.rgb.data() + c), sizeof(float) * 3,
                                   sizeof(float) * 3 * size_t(w)));
      }
    Imf::OutputFile file(tmp.c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(h);
  } catch (const std::exception& e) {
    if (error) *error = path + ": cannot write EXR (" + e.what() + ")";
    ok = false;
  }
  return commit(tmp, path, ok, error);
}

bool readExr(const std::string& path, std::vector<Layer>& layers, std::string* error) {
  layers.clear();
  try {
    Imf::InputFile file(path.c_str());
    const Imf::Header& header = file.header();
    Imath::Box2i dw = header.dataWindow();
    int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
    if (w <= 0 || h <= 0 || size_t(w) * h > (size_t(1) << 30)) {
      if (error) *error = path + ": absurd data window";
      return false;
    }
    // Layers: the prefixes of channels ending in .R (or R alone).
    std::vector<std::string> names;
    for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
      std::string n = it.name();
      if (n == "R")
        names.push_back("");
      else if (n.size() > 2 && n.compare(n.size() - 2, 2, ".R") == 0)
        names.push_back(n.substr(0, n.size() - 2));
    }
    if (names.empty()) {
      if (error) *error = path + ": no RGB layer (no channel named R or *.R)";
      return false;
    }
    Imf::FrameBuffer fb;
    layers.resize(names.size());
    for (size_t i = 0; i < names.size(); ++i) {
      layers[i].name = names[i];
      layers[i].image = Image(w, h);
      char* base = (char*)layers[i].image.rgb.data() - (size_t(dw.min.x) + size_t(dw.min.y) * w) * sizeof(float) * 3;
      for (int c = 0; c < 3; ++c)
        fb.insert(channelName(names[i], "RGB"[c]), Imf::Slice(Imf::FLOAT, base + c * sizeof(float), sizeof(float) * 3,
                                                              sizeof(float) * 3 * size_t(w), 1, 1, 0.0));
    }
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
  } catch (const std::exception& e) {
    if (error) *error = path + ": cannot read EXR (" + e.what() + ")";
    layers.clear();
    return false;
  }
  return true;
}

uint8_t toSrgb8(float v) {
  if (!(v > 0)) return 0;  // also maps NaN to black
  if (v >= 1) return 255;
  float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1 / 2.4f) - 0.055f;
  return uint8_t(std::lround(s * 255.0f));
}

bool writePngRgb8(const std::string& path, int width, int height, const std::vector<uint8_t>& rgb, std::string* error) {
  std::string tmp = temporaryPath(path);
  bool ok = stbi_write_png(tmp.c_str(), width, height, 3, rgb.data(), width * 3) != 0;
  if (!ok && error) *error = path + ": cannot write PNG";
  return commit(tmp, path, ok, error);
}

bool writePng(const std::string& path, const Image& image, float exposure, std::string* error) {
  std::vector<uint8_t> px(image.rgb.size());
  float scale = std::exp2(exposure);
  for (size_t i = 0; i < px.size(); ++i) px[i] = toSrgb8(image.rgb[i] * scale);
  return writePngRgb8(path, image.width, image.height, px, error);
}

bool writeTextFile(const std::string& path, const std::string& text, std::string* error) {
  std::string tmp = temporaryPath(path);
  bool ok;
  {
    std::ofstream f(tmp, std::ios::binary);
    f << text;
    f.flush();
    ok = bool(f);
  }
  if (!ok && error) *error = path + ": cannot write";
  return commit(tmp, path, ok, error);
}

}  // namespace vsl
