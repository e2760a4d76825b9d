// Environment light: light from infinitely far away for scenes that bring
// none (docs/REFERENCE.md, "Environment light"). Up to three parts, summed:
//
//   - a lat-long (equirectangular) EXR map, times a scale, importance-sampled
//     by a 2D piecewise-constant distribution over its pixels weighted by
//     sin(theta) (pbrt-v4's ImageInfiniteLight has the same structure;
//     "Physically Based Rendering", 4th ed., sections 12.5.3 and A.5.6);
//   - a constant sky radiance, sampled uniformly over the sphere;
//   - a sun: a disk of directions of a given angular diameter and uniform
//     radiance, sampled uniformly in its cone, whose intensity is the
//     irradiance E it gives a surface facing it (W/m^2, like glTF's
//     directional lights): radiance E / (pi sin^2 alpha), alpha the
//     half-angle.
//
// Directions are world space, glTF's +Y up. A direction w "toward the sky"
// points away from the scene; radiance(w) is what a ray leaving the scene
// along w sees. The map's pixel (x, y) covers phi in [2 pi x/W, 2 pi (x+1)/W)
// and theta in [pi y/H, pi (y+1)/H), with w = (sin theta sin phi, cos theta,
// -sin theta cos phi): the top row is the zenith, the left edge (u = 0)
// looks along -Z, u = 0.25 along +X and the middle (u = 0.5) along +Z.
// Lookups are nearest-pixel, so that the sampling pdf matches the map
// exactly.
//
// Immutable after construction; safe to share between threads.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/film.h"
#include "core/math.h"
#include "core/result.h"
#include "core/sampling.h"

namespace vsl {

// What an environment is made of: plain values, printable and comparable.
struct EnvironmentSettings {
  std::string map;               // lat-long EXR (default RGB layer); empty = none
  float scale = 1;               // multiplies the map
  Vec3 sky{0.0f};                // constant radiance from every direction
  Vec3 sunDirection{0.0f};       // toward the sun (need not be unit); zero = no sun
  float sunDiameterDeg = 0.53f;  // angular diameter, degrees (the real sun's)
  float sunIrradiance = 3;       // on a surface facing it (W/m^2); colour is white

  bool hasMap() const { return !map.empty(); }
  bool hasSky() const { return sky.x > 0 || sky.y > 0 || sky.z > 0; }
  bool hasSun() const { return sunIrradiance > 0 && lengthSquared(sunDirection) > 0; }
  bool any() const { return hasMap() || hasSky() || hasSun(); }
  // Ranges: scale in [0, 1e6]; sky components in [0, 1e6]; sun diameter in
  // (0, 90] degrees; sun irradiance in [0, 1e9]; all finite. The error names
  // the option and the range.
  Result<void> validate() const;
  // The command-line options that give these settings (" --sky 0.5,0.5,0.5
  // --sun 1,1,0"; "" for none), for replay commands. The map's path is
  // quoted for a POSIX shell.
  std::string options() const;
  // "none", or e.g. "map sky.exr x2, sky 0.5,0.5,0.5, sun (0,1,0) 0.53deg E=3".
  std::string describe() const;
  bool operator==(const EnvironmentSettings& o) const {
    auto same = [](const Vec3& a, const Vec3& b) { return a.x == b.x && a.y == b.y && a.z == b.z; };
    return map == o.map && scale == o.scale && same(sky, o.sky) && same(sunDirection, o.sunDirection) &&
           sunDiameterDeg == o.sunDiameterDeg && sunIrradiance == o.sunIrradiance;
  }
};

// A sampled direction toward the environment.
struct EnvironmentSample {
  Vec3 w;         // unit, toward the sky
  Vec3 L;         // radiance(w)
  float pdf = 0;  // solid angle
};

class Environment {
 public:
  // Reads settings.map (if any) with readExr (its default RGB layer, or the
  // first layer) and builds the distributions. Negative map values are
  // clamped to zero. Fails with "FILE: reason" on a file that cannot be read
  // or decoded or has a non-finite pixel, on invalid settings, and when
  // nothing emits (an all-black map and no sky or sun).
  static Result<std::shared_ptr<const Environment>> create(const EnvironmentSettings& settings);
  // The same from a map already in memory (tests); map may be empty.
  static Result<std::shared_ptr<const Environment>> create(const EnvironmentSettings& settings, Image map);

  const EnvironmentSettings& settings() const { return settings_; }
  // Radiance seen along w (unit, toward the sky): map + sky + sun.
  Vec3 radiance(const Vec3& w) const;
  // Picks a part in proportion to its power (uPart) and a direction in it
  // (u); pdf is the mixture's, over all parts. Empty if the direction has
  // zero pdf (never for u in [0,1)^2 on a valid environment).
  std::optional<EnvironmentSample> sample(float uPart, Vec2 u) const;
  // The solid-angle pdf of sample() returning w.
  float pdf(const Vec3& w) const;
  // Integral of luminance(radiance) over the sphere (W/m^2/unit): a disk of
  // radius R facing any direction receives power pi R^2 times this.
  double powerPerArea() const { return partPower_.total(); }

  // Map helpers (exposed for tests): the pixel a direction falls in, and
  // the direction through the centre of (x, y).
  int mapWidth() const { return map_.width; }
  int mapHeight() const { return map_.height; }
  Vec2 directionToUv(const Vec3& w) const;
  static Vec3 uvToDirection(Vec2 uv);

 private:
  Environment() = default;
  Result<void> build(Image map);
  float mapPdf(const Vec3& w) const;

  EnvironmentSettings settings_;
  Image map_;
  // Piecewise-constant 2D distribution over the map: rows by their summed
  // weight (marginal), then columns within a row (conditional); weights are
  // mean(RGB) x sin(theta of the row's centre).
  std::vector<double> rowCdf_;  // H + 1
  std::vector<float> colCdf_;   // H x (W + 1), each row normalised
  std::vector<double> rowSum_;  // H
  double mapIntegral_ = 0;      // sum of weights / (W H), over the unit square
  Vec3 sunDir_{0, 1, 0};
  float sunOmc_ = 0;  // 1 - cos(half-angle)
  Vec3 sunL_{0.0f};
  DiscreteDistribution partPower_;  // map, sky, sun (zero weight if absent)
};

}  // namespace vsl
