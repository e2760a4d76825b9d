#include "core/film.h"

#include "core/check.h"

namespace vsl {

Film::Film(int width, int height)
    : width_(width), height_(height), sum_(size_t(width) * height * 3, 0.0), weight_(size_t(width) * height, 0.0) {}

Film::Film(const Film& o)
    : width_(o.width_), height_(o.height_), sum_(o.sum_), weight_(o.weight_), rejected_(o.rejected()) {}

Film& Film::operator=(const Film& o) {
  width_ = o.width_;
  height_ = o.height_;
  sum_ = o.sum_;
  weight_ = o.weight_;
  rejected_.store(o.rejected());
  return *this;
}

void Film::add(int x, int y, const Vec3& value, double weight) {
  VSL_CHECK_GE(x, 0);
  VSL_CHECK_LT(x, width_);
  VSL_CHECK_GE(y, 0);
  VSL_CHECK_LT(y, height_);
  size_t i = size_t(y) * width_ + x;
  if (!(std::isfinite(weight) && weight >= 0)) {
    rejected_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  weight_[i] += weight;
  if (!isFinite(value)) {
    rejected_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  sum_[3 * i] += double(value.x) * weight;
  sum_[3 * i + 1] += double(value.y) * weight;
  sum_[3 * i + 2] += double(value.z) * weight;
}

Vec3 Film::pixel(int x, int y) const {
  VSL_DCHECK(x >= 0 && x < width_ && y >= 0 && y < height_);
  size_t i = size_t(y) * width_ + x;
  double w = weight_[i];
  if (!(w > 0)) return Vec3(0.0f);
  return {float(sum_[3 * i] / w), float(sum_[3 * i + 1] / w), float(sum_[3 * i + 2] / w)};
}

Image Film::image() const {
  Image img(width_, height_);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) img.set(x, y, pixel(x, y));
  return img;
}

void Film::clear() {
  std::fill(sum_.begin(), sum_.end(), 0.0);
  std::fill(weight_.begin(), weight_.end(), 0.0);
  rejected_.store(0);
}

}  // namespace vsl
