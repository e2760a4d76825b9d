// The film holds sums, not averages: per pixel a double RGB sum and a double
// weight, normalised on read (pbrt's RGBFilm). add() is the only entry point;
// it rejects non-finite values (their weight still counts, with value zero)
// and counts them.
// Thread-safety: concurrent add() calls are safe for *different* pixels.
#pragma once

#include <atomic>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/check.h"
#include "core/math.h"

namespace vsl {

struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;  // linear, row-major, top row first
  Image() = default;
  Image(int w, int h) : width(w), height(h), rgb(size_t(w) * h * 3, 0.0f) {}
  Vec3 at(int x, int y) const {
    VSL_DCHECK(x >= 0 && x < width && y >= 0 && y < height);
    const float* p = &rgb[(size_t(y) * width + x) * 3];
    return {p[0], p[1], p[2]};
  }
  void set(int x, int y, const Vec3& v) {
    VSL_DCHECK(x >= 0 && x < width && y >= 0 && y < height);
    float* p = &rgb[(size_t(y) * width + x) * 3];
    p[0] = v.x;
    p[1] = v.y;
    p[2] = v.z;
  }
};

// The per-pixel mean of two images of equal size (VSL_CHECK): 0.5 (a + b).
inline Image average(const Image& a, const Image& b) {
  VSL_CHECK_EQ(a.width, b.width);
  VSL_CHECK_EQ(a.height, b.height);
  Image m(a.width, a.height);
  for (size_t i = 0; i < m.rgb.size(); ++i) m.rgb[i] = 0.5f * (a.rgb[i] + b.rgb[i]);
  return m;
}

// The per-pixel sum and difference of two images of equal size (VSL_CHECK).
inline Image sum(const Image& a, const Image& b) {
  VSL_CHECK_EQ(a.width, b.width);
  VSL_CHECK_EQ(a.height, b.height);
  Image m(a.width, a.height);
  for (size_t i = 0; i < m.rgb.size(); ++i) m.rgb[i] = a.rgb[i] + b.rgb[i];
  return m;
}
inline Image difference(const Image& a, const Image& b) {
  VSL_CHECK_EQ(a.width, b.width);
  VSL_CHECK_EQ(a.height, b.height);
  Image m(a.width, a.height);
  for (size_t i = 0; i < m.rgb.size(); ++i) m.rgb[i] = a.rgb[i] - b.rgb[i];
  return m;
}

class Film {
 public:
  Film() = default;
  Film(int width, int height);
  Film(const Film& o);
  Film& operator=(const Film& o);

  int width() const { return width_; }
  int height() const { return height_; }
  // (x, y) must lie inside the film (VSL_CHECK: a bug otherwise, and it aborts).
  void add(int x, int y, const Vec3& value, double weight = 1.0);
  Vec3 pixel(int x, int y) const;  // sum / weight, zero where weight is zero
  double weight(int x, int y) const { return weight_[size_t(y) * width_ + x]; }
  Image image() const;
  uint64_t rejected() const { return rejected_.load(std::memory_order_relaxed); }
  void clear();
  // Exchanges the contents with o without copying (neither film may be in use).
  void swap(Film& o) noexcept {
    std::swap(width_, o.width_);
    std::swap(height_, o.height_);
    sum_.swap(o.sum_);
    weight_.swap(o.weight_);
    const uint64_t r = rejected();
    rejected_.store(o.rejected(), std::memory_order_relaxed);
    o.rejected_.store(r, std::memory_order_relaxed);
  }

 private:
  int width_ = 0, height_ = 0;
  std::vector<double> sum_;     // 3 per pixel
  std::vector<double> weight_;  // 1 per pixel
  std::atomic<uint64_t> rejected_{0};
};

}  // namespace vsl
