#include "core/environment.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "core/image_io.h"

namespace vsl {

// ---- Settings -------------------------------------------------------------------

Result<void> EnvironmentSettings::validate() const {
  auto bad = [](const std::string& what) { return Error(what); };
  auto finiteIn = [](float v, float lo, float hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (!finiteIn(scale, 0, 1e6f)) return bad("env-scale: must be in [0,1e6] (got " + std::to_string(scale) + ")");
  for (float c : {sky.x, sky.y, sky.z})
    if (!finiteIn(c, 0, 1e6f)) return bad("sky: each component must be in [0,1e6] (got " + std::to_string(c) + ")");
  if (!isFinite(sunDirection)) return bad("sun: the direction must be finite");
  if (!(std::isfinite(sunDiameterDeg) && sunDiameterDeg > 0 && sunDiameterDeg <= 90))
    return bad("sun-diameter: must be in (0,90] degrees (got " + std::to_string(sunDiameterDeg) + ")");
  if (!finiteIn(sunIrradiance, 0, 1e9f))
    return bad("sun-irradiance: must be in [0,1e9] (got " + std::to_string(sunIrradiance) + ")");
  return {};
}

std::string EnvironmentSettings::describe() const {
  if (!any()) return "none";
  std::ostringstream o;
  const char* sep = "";
  if (hasMap()) {
    o << "map " << map << " x" << scale;
    sep = ", ";
  }
  if (hasSky()) {
    o << sep << "sky " << sky.x << "," << sky.y << "," << sky.z;
    sep = ", ";
  }
  if (hasSun())
    o << sep << "sun " << sunDirection.x << "," << sunDirection.y << "," << sunDirection.z << " " << sunDiameterDeg
      << "deg E=" << sunIrradiance;
  return o.str();
}

std::string EnvironmentSettings::options() const {
  std::ostringstream o;
  o.precision(9);
  const EnvironmentSettings d;
  if (hasMap()) {
    std::string quoted = "'";
    for (char c : map) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
    o << " --env " << quoted << "'";
    if (scale != d.scale) o << " --env-scale " << scale;
  }
  if (hasSky()) o << " --sky " << sky.x << "," << sky.y << "," << sky.z;
  if (hasSun()) {
    o << " --sun " << sunDirection.x << "," << sunDirection.y << "," << sunDirection.z;
    if (sunDiameterDeg != d.sunDiameterDeg) o << " --sun-diameter " << sunDiameterDeg;
    if (sunIrradiance != d.sunIrradiance) o << " --sun-irradiance " << sunIrradiance;
  }
  return o.str();
}

// ---- Construction ----------------------------------------------------------------

namespace {

// The map's RGB layer: the default one, else the first.
Result<Image> readMap(const std::string& path) {
  Result<std::vector<Layer>> layers = readExr(path);
  if (!layers) return Error(layers.error());
  if (layers->empty()) return Error(path + ": no RGB layer (channels R, G, B)");
  for (Layer& l : *layers)
    if (l.name.empty()) return std::move(l.image);
  return std::move(layers->front().image);
}

inline float mean(const Vec3& c) { return (c.x + c.y + c.z) / 3; }

// Index of the bucket of cdf (size n+1, cdf[0] = 0, cdf[n] = 1) holding u,
// skipping empty buckets; *remapped is u rescaled within it.
template <class T>
size_t sampleCdf(const T* cdf, size_t n, double u, double* remapped) {
  size_t i = size_t(std::upper_bound(cdf, cdf + n + 1, T(u)) - cdf);
  i = std::clamp<size_t>(i, 1, n) - 1;
  while (i + 1 < n && !(cdf[i + 1] > cdf[i])) ++i;  // land on a bucket with weight
  const double w = double(cdf[i + 1]) - double(cdf[i]);
  *remapped = w > 0 ? std::clamp((u - double(cdf[i])) / w, 0.0, 0.99999994) : 0.5;
  return i;
}

}  // namespace

Result<std::shared_ptr<const Environment>> Environment::create(const EnvironmentSettings& settings) {
  Image map;
  if (settings.hasMap()) {
    Result<Image> read = readMap(settings.map);
    if (!read) return Error(read.error());
    map = std::move(read).value();
  }
  return create(settings, std::move(map));
}

Result<std::shared_ptr<const Environment>> Environment::create(const EnvironmentSettings& settings, Image map) {
  if (Result<void> ok = settings.validate(); !ok) return Error(ok.error());
  std::shared_ptr<Environment> env(new Environment());
  env->settings_ = settings;
  if (Result<void> built = env->build(std::move(map)); !built) return Error(built.error());
  return std::shared_ptr<const Environment>(std::move(env));
}

Result<void> Environment::build(Image map) {
  const std::string name = settings_.hasMap() ? settings_.map : std::string("environment map");
  const int W = map.width, H = map.height;
  double mapPower = 0;
  if (W > 0 && H > 0) {
    for (size_t i = 0; i < map.rgb.size(); ++i) {
      if (!std::isfinite(map.rgb[i]))
        return Error(name + ": pixel (" + std::to_string(i / 3 % W) + ", " + std::to_string(i / 3 / W) +
                     ") is not finite");
      map.rgb[i] = std::max(map.rgb[i], 0.0f) * settings_.scale;
    }
    map_ = std::move(map);
    // Weights: mean(RGB) x sin(theta) at the row's centre (the sin(theta) of
    // the lat-long parameterisation's Jacobian, PBR 4th ed. 12.5.3).
    rowCdf_.assign(size_t(H) + 1, 0.0);
    rowSum_.assign(size_t(H), 0.0);
    colCdf_.assign(size_t(H) * (W + 1), 0.0f);
    std::vector<double> row(size_t(W) + 1);
    for (int y = 0; y < H; ++y) {
      const double theta0 = kPi * double(y) / H, theta1 = kPi * double(y + 1) / H;
      const double sinTheta = std::sin(0.5 * (theta0 + theta1));
      const double dOmega = 2 * double(kPi) / W * (std::cos(theta0) - std::cos(theta1));
      row[0] = 0;
      for (int x = 0; x < W; ++x) {
        const Vec3 c = map_.at(x, y);
        row[size_t(x) + 1] = row[size_t(x)] + mean(c) * sinTheta;
        mapPower += double(luminance(c)) * dOmega;
      }
      rowSum_[size_t(y)] = row[size_t(W)];
      rowCdf_[size_t(y) + 1] = rowCdf_[size_t(y)] + row[size_t(W)];
      float* cdf = &colCdf_[size_t(y) * (W + 1)];
      for (int x = 0; x <= W; ++x)
        cdf[x] = row[size_t(W)] > 0 ? float(row[size_t(x)] / row[size_t(W)]) : float(x) / float(W);
      cdf[W] = 1.0f;
    }
    const double total = rowCdf_[size_t(H)];
    mapIntegral_ = total / (double(W) * H);
    if (total > 0)
      for (double& c : rowCdf_) c /= total;
    rowCdf_[size_t(H)] = 1.0;
  }
  // The sun: uniform radiance over its cone, E / (pi sin^2 alpha).
  double sunPower = 0;
  if (settings_.hasSun()) {
    const float alpha = 0.5f * settings_.sunDiameterDeg * kPi / 180;
    sunDir_ = normalize(settings_.sunDirection);
    sunOmc_ = 2 * sqr(std::sin(0.5f * alpha));  // 1 - cos(alpha), without cancellation
    sunL_ = Vec3(settings_.sunIrradiance / (kPi * sqr(std::sin(alpha))));
    sunPower = double(luminance(sunL_)) * 2 * kPi * sunOmc_;
  }
  const double skyPower = 4 * double(kPi) * luminance(settings_.sky);
  if (!(mapIntegral_ > 0)) mapPower = 0;  // an all-black map is never sampled
  const double parts[3] = {mapPower, skyPower, sunPower};
  partPower_ = DiscreteDistribution(parts);
  if (!(partPower_.total() > 0)) return Error(name + ": the environment emits nothing (black map, no sky, no sun)");
  return {};
}

// ---- Directions and lookups ------------------------------------------------------

Vec3 Environment::uvToDirection(Vec2 uv) {
  const float phi = 2 * kPi * uv.x, theta = kPi * uv.y;
  const float s = std::sin(theta);
  return {s * std::sin(phi), std::cos(theta), -s * std::cos(phi)};
}

Vec2 Environment::directionToUv(const Vec3& w) const {
  float phi = std::atan2(w.x, -w.z);
  if (phi < 0) phi += 2 * kPi;
  const float theta = std::acos(std::clamp(w.y, -1.0f, 1.0f));
  return {phi / (2 * kPi), theta / kPi};
}

Vec3 Environment::radiance(const Vec3& w) const {
  Vec3 L = settings_.sky;
  if (map_.width > 0) {
    const Vec2 uv = directionToUv(w);
    const int x = std::clamp(int(uv.x * map_.width), 0, map_.width - 1);
    const int y = std::clamp(int(uv.y * map_.height), 0, map_.height - 1);
    L += map_.at(x, y);
  }
  if (sunOmc_ > 0 && 1 - dot(w, sunDir_) <= sunOmc_) L += sunL_;
  return L;
}

// ---- Sampling -----------------------------------------------------------------------

float Environment::mapPdf(const Vec3& w) const {
  if (!(mapIntegral_ > 0)) return 0;
  const Vec2 uv = directionToUv(w);
  const int x = std::clamp(int(uv.x * map_.width), 0, map_.width - 1);
  const int y = std::clamp(int(uv.y * map_.height), 0, map_.height - 1);
  const float sinTheta = std::sqrt(std::max(0.0f, 1 - sqr(w.y)));
  if (!(sinTheta > 0)) return 0;
  // Density over the unit square: weight / mean weight; the lat-long map's
  // Jacobian is dOmega = 2 pi^2 sin(theta) du dv.
  const float* cdf = &colCdf_[size_t(y) * (map_.width + 1)];
  const double weight = rowSum_[size_t(y)] * double(cdf[x + 1] - cdf[x]);
  const double pUv = weight / mapIntegral_;
  return float(pUv / (2 * double(kPi) * kPi * sinTheta));
}

float Environment::pdf(const Vec3& w) const {
  float p = 0;
  if (float pm = partPower_.pmf(0); pm > 0) p += pm * mapPdf(w);
  if (float ps = partPower_.pmf(1); ps > 0) p += ps * uniformSpherePdf();
  if (float pu = partPower_.pmf(2); pu > 0 && 1 - dot(w, sunDir_) <= sunOmc_) p += pu * uniformConeOmcPdf(sunOmc_);
  return p;
}

std::optional<EnvironmentSample> Environment::sample(float uPart, Vec2 u) const {
  float pmf = 0;
  const size_t part = partPower_.sample(uPart, &pmf);
  EnvironmentSample s;
  if (part == 0) {
    const int W = map_.width, H = map_.height;
    double du = 0, dv = 0;
    const size_t y = sampleCdf(rowCdf_.data(), size_t(H), u.y, &dv);
    const size_t x = sampleCdf(&colCdf_[y * (size_t(W) + 1)], size_t(W), u.x, &du);
    const Vec2 uv{float((double(x) + du) / W), float((double(y) + dv) / H)};
    s.w = uvToDirection(uv);
  } else if (part == 1) {
    s.w = sampleUniformSphere(u);
  } else {
    s.w = Frame(sunDir_).toWorld(sampleUniformConeOmc(u, sunOmc_));
  }
  s.pdf = pdf(s.w);
  if (!(s.pdf > 0)) return std::nullopt;
  s.L = radiance(s.w);
  return s;
}

}  // namespace vsl
