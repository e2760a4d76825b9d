// png_stats FILE MIN_STDDEV: prints the mean and standard deviation of a PNG's
// 8-bit values and exits 1 when the image is (nearly) blank.
#include <stb_image.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: png_stats FILE MIN_STDDEV\n");
    return 2;
  }
  int w = 0, h = 0, n = 0;
  unsigned char* px = stbi_load(argv[1], &w, &h, &n, 3);
  if (!px) {
    std::fprintf(stderr, "%s: cannot read PNG\n", argv[1]);
    return 1;
  }
  double s = 0, s2 = 0;
  size_t count = size_t(w) * h * 3;
  for (size_t i = 0; i < count; ++i) {
    s += px[i];
    s2 += double(px[i]) * px[i];
  }
  stbi_image_free(px);
  double mean = s / count, sd = std::sqrt(std::max(s2 / count - mean * mean, 0.0));
  std::printf("%s: %dx%d mean %.2f stddev %.2f\n", argv[1], w, h, mean, sd);
  return sd >= std::atof(argv[2]) ? 0 : 1;
}
