// Sections: [1] values as text  [2] names  [3] the many-light parameters
//           [4] the path tracer's and the run parameters  [5] the docs table
#include "core/params.h"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "core/environment.h"
#include "core/many_light.h"
#include "core/session.h"
#include "core/settings.h"

namespace vsl {

// ---- [1] Values as text ------------------------------------------------------------

namespace {
// The shortest text that reads back to the same float (every Real parameter
// is held in a float), or the same integer.
std::string numberText(const ParamSpec& p, double v) {
  char buf[64];
  std::to_chars_result r = p.kind == ParamKind::Real ? std::to_chars(buf, buf + sizeof buf, float(v))
                                                     : std::to_chars(buf, buf + sizeof buf, (long long)v);
  return std::string(buf, r.ptr);
}

std::string wordsText(const ParamSpec& p) {
  std::string s;
  for (const ParamWord& w : p.words) s += (s.empty() ? "" : ", ") + std::string(w.word);
  return s;
}
}  // namespace

namespace {
bool inNumberRange(const ParamSpec& p, double v) {
  return (p.minOpen ? v > p.min : v >= p.min) && v <= p.max && (p.kind != ParamKind::Int || v == std::floor(v));
}
}  // namespace

// A word names a value the numbers cannot ("auto" = 0 of [1,4096]); a
// value the numbers can say stays a number ("--lobe-floor 0").
std::string formatParamValue(const ParamSpec& p, double v) {
  for (const ParamWord& w : p.words)
    if (w.value == v && (p.kind == ParamKind::Choice || !inNumberRange(p, v))) return w.word;
  if (p.kind == ParamKind::Flag) return v != 0 ? "true" : "false";
  return numberText(p, v);
}

std::string paramRangeText(const ParamSpec& p) {
  if (p.kind == ParamKind::Choice) return "one of " + wordsText(p);
  if (p.kind == ParamKind::Flag) return "flag";
  std::string s = std::string(p.minOpen ? "(" : "[") + numberText(p, p.min) + "," + numberText(p, p.max) + "]";
  if (!p.words.empty()) s += " or " + wordsText(p);
  return s;
}

Result<void> checkParamValue(const ParamSpec& p, double v) {
  for (const ParamWord& w : p.words)
    if (w.value == v) return {};
  if (p.kind == ParamKind::Flag || (p.kind != ParamKind::Choice && inNumberRange(p, v))) return {};
  return Error(std::string(p.name) + ": must be " + (p.kind == ParamKind::Choice ? "" : "in ") + paramRangeText(p) +
               " (got " + numberText(p, v) + ")");
}

Result<double> parseParamValue(const ParamSpec& p, std::string_view text) {
  for (const ParamWord& w : p.words)
    if (text == w.word) return w.value;
  auto refuse = [&] {
    return Error(std::string(p.name) + ": must be " + (p.kind == ParamKind::Choice ? "" : "in ") + paramRangeText(p) +
                 " (got '" + std::string(text) + "')");
  };
  if (p.kind == ParamKind::Choice) return refuse();
  if (p.kind == ParamKind::Flag) {
    if (text == "true" || text == "1" || text == "on") return 1.0;
    if (text == "false" || text == "0" || text == "off") return 0.0;
    return refuse();
  }
  double v = 0;
  const std::string s(text);
  char* end = nullptr;
  if (p.kind == ParamKind::Int) {
    const long long n = std::strtoll(s.c_str(), &end, 10);
    v = double(n);
  } else {
    v = double(std::strtof(s.c_str(), &end));  // as the float field holds it
  }
  if (s.empty() || end != s.c_str() + s.size()) return refuse();
  if (!std::isfinite(v)) return Error(std::string(p.name) + ": must be a finite number (got '" + s + "')");
  // A number must be in range, or be what "off" stands for ("--lobe-gather
  // 0"); other words are given as words ("--vsl-samples 0" is refused).
  bool off = false;
  for (const ParamWord& w : p.words) off |= w.value == v && std::string_view(w.word) == "off";
  if (!off && !inNumberRange(p, v)) return refuse();
  return v;
}

// ---- [2] Names ------------------------------------------------------------------------

size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string nearestName(std::string_view name, const std::vector<std::string>& names) {
  std::string best;
  size_t bestDistance = std::min<size_t>(3, std::max<size_t>(1, name.size() / 3)) + 1;
  for (const std::string& n : names) {
    const size_t d = editDistance(name, n);
    if (d < bestDistance) {
      bestDistance = d;
      best = n;
    }
  }
  return best;
}

// ---- [3] The many-light parameters ----------------------------------------------------

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
using M = ManyLightSettings;

std::vector<Param<M>> lightSetParams() {
  return {
      bindField({.name = "lights",
                 .key = "lights",
                 .kind = ParamKind::Int,
                 .appliesTo = "VSL, VPL",
                 .min = 1,
                 .max = 50'000'000,
                 .unit = "lights",
                 .help = "Virtual lights traced from the emitters",
                 .why = "paper scale; the studio starts at 5,000 for a fast first picture ([RESULTS](RESULTS.md))",
                 .uiMin = 100,
                 .uiMax = 1'000'000,
                 .uiLog = true},
                &M::lights),
      bindField({.name = "batches",
                 .key = "batches",
                 .kind = ParamKind::Int,
                 .appliesTo = "VSL, VPL",
                 .min = 1,
                 .max = 64,
                 .help = "Progressive light batches of growing size (each brings a new eye sample)",
                 .why = "8 eye samples beat 1 at the same pair count "
                        "([notebook](notebook/2026-12-02-relative-eps-and-eye-samples.md))",
                 .uiMin = 1,
                 .uiMax = 64},
                &M::batches),
      bindField({.name = "direct-samples",
                 .key = "directSamples",
                 .kind = ParamKind::Int,
                 .appliesTo = "VSL, VPL",
                 .min = 1,
                 .max = 65536,
                 .unit = "per pixel",
                 .help = "Direct-light samples per pixel",
                 .why = "direct light's noise small next to the indirect differences compared; not tuned",
                 .uiMin = 1,
                 .uiMax = 1024,
                 .uiLog = true},
                &M::directSamples),
      bindField({.name = "light-max-depth",
                 .key = "lightMaxDepth",
                 .kind = ParamKind::Int,
                 .appliesTo = "VSL, VPL",
                 .min = 1,
                 .max = 1024,
                 .unit = "bounces",
                 .help = "Longest light path that deposits virtual lights",
                 .why = "long enough for the bundled scenes' glossy chains; not tuned",
                 .uiMin = 1,
                 .uiMax = 64},
                &M::lightMaxDepth),
  };
}

std::vector<Param<M>> vslParams() {
  return {
      bindField({.name = "radius",
                 .key = "globalRadius",
                 .min = 0,
                 .max = 1e9,
                 .unit = "x scene radius",
                 .help = "One global VSL radius as a fraction of the scene's bounding radius (replaces k-NN radii)",
                 .why = "off: the paper's k-NN radii; an alternative, not measured as better",
                 .words = {{"off", 0}},
                 .quiet = 0,
                 .uiMin = 1e-4,
                 .uiMax = 0.5,
                 .uiLog = true,
                 .uiStart = 0.02,
                 .preset = true},
                &M::globalRadius),
      bindField({.name = "radius-scale",
                 .key = "radiusScale",
                 .min = 0,
                 .max = 1e9,
                 .minOpen = true,
                 .help = "VSL radius = scale x distance to the k-th nearest light",
                 .why = "larger radii darken every scene by 6-11% "
                        "([notebook](notebook/2026-12-01-radius-and-first-comparisons.md))",
                 .uiMin = 1e-3,
                 .uiMax = 100,
                 .uiLog = true,
                 .preset = true},
                &M::radiusScale),
      bindField({.name = "knn",
                 .key = "knn",
                 .kind = ParamKind::Int,
                 .min = 1,
                 .max = 1000,
                 .help = "k: the VSL radius is the distance to the k-th nearest other light",
                 .why = "k = 10 at scale 1 has the lower median error "
                        "([notebook](notebook/2026-12-01-radius-and-first-comparisons.md))",
                 .uiMin = 1,
                 .uiMax = 64,
                 .preset = true},
                &M::knn),
      bindField({.name = "vsl-samples",
                 .key = "vslSamples",
                 .kind = ParamKind::Int,
                 .min = 1,
                 .max = 4096,
                 .unit = "per strategy",
                 .help = "VSL cone-integral samples per strategy (auto: see vsl-count)",
                 .why = "no fixed count wins every scene "
                        "([notebook](notebook/2026-12-03-equal-time-64px-256px.md))",
                 .words = {{"auto", 0}},
                 .uiMin = 1,
                 .uiMax = 128,
                 .uiLog = true,
                 .uiStart = 4,
                 .preset = true},
                &M::vslSamples),
      bindField({.name = "clipped-disk",
                 .key = "clippedDisk",
                 .kind = ParamKind::Flag,
                 .help = "Spread each light's flux over the part of its disk on the receiver's side",
                 .why = "a variant of the authors' shader; no gain on tableau "
                        "([notebook](notebook/2026-12-01-radius-and-first-comparisons.md))",
                 .quiet = 0,
                 .preset = true},
                &M::clippedDisk),
  };
}

// The cone integral's form (core/vsl_sg.h).
std::vector<Param<M>> vslIntegralParams() {
  return {
      bindField({.name = "vsl-integral",
                 .key = "vslIntegral",
                 .kind = ParamKind::Choice,
                 .appliesTo = "VSL",
                 .help = "VSL's cone integral: quadrature (Monte Carlo, the paper's) or sg (closed form by spherical "
                         "Gaussians, no samples; biased)",
                 .why = "sg: at equal time (256 px, 15 s) 0.53-0.70x the quadrature's error at the other defaults on "
                        "kitchen, hall and tableau, level with the lobe gather, its mean within 1.6% of the "
                        "quadrature's; not yet measured at 512 px / 60 s; quadrature: the paper's, unbiased per pair "
                        "(`--preset paper`) ([results](RESULTS.md#at-equal-time-256-px-15-s))",
                 .words = {{"quadrature", double(VslIntegral::Quadrature)}, {"sg", double(VslIntegral::Sg)}},
                 // Always described: a settings string written while the
                 // quadrature was the default (before 2026-12-08) left it out.
                 .preset = true},
                &M::vslIntegral),
      bindField({.name = "vsl-sg-max-angle",
                 .key = "vslSgMaxAngle",
                 .tier = ParamTier::Experimental,
                 .min = 0,
                 .max = 90,
                 .unit = "degrees",
                 .help = "Closed-form VSL: pairs whose cone's half-angle exceeds this use the quadrature",
                 .why = "5: kitchen's mean within 1.5% of the quadrature's, 60% of its draws left "
                        "([results](RESULTS.md#closed-form-vsl-by-spherical-gaussians))",
                 .quiet = ManyLightSettings::kDefaultVslSgMaxAngle,
                 .needs = "vsl-integral",
                 .needsValue = double(VslIntegral::Sg),
                 .uiMin = 0,
                 .uiMax = 90,
                 .preset = true},
                &M::vslSgMaxAngle),
  };
}

std::vector<Param<M>> vplParams() {
  return {
      bindField({.name = "clamp",
                 .key = "clamp",
                 .appliesTo = "VPL",
                 .min = 0,
                 .max = 1e30,
                 .minOpen = true,
                 .help = "Bound on the luminance of f_x cos f_p cos / d^2 per light (auto: 1/(pi^2 (0.1 R)^2))",
                 .why = "scene-relative, so every scene is clamped alike; a convention, not tuned",
                 .words = {{"auto", -1}, {"off", kInf}},
                 .uiMin = 1e-3,
                 .uiMax = 1e4,
                 .uiLog = true,
                 .uiStart = 1},
                &M::clamp),
      bindField({.name = "diffuse-vpl",
                 .key = "diffuseOnly",
                 .kind = ParamKind::Flag,
                 .appliesTo = "VPL",
                 .help = "VPLs emit with their diffuse lobe only",
                 .why = "a variant that shows what glossy emission carries",
                 .quiet = 0},
                &M::diffuseOnly),
  };
}

std::vector<Param<M>> heuristicParams() {
  constexpr ParamTier X = ParamTier::Experimental;
  return {
      bindField({.name = "vsl-count",
                 .key = "vslCount",
                 .kind = ParamKind::Choice,
                 .tier = X,
                 .help = "VSL's automatic sample count: lobe (the authors' count, scaled down where both lobes are "
                         "broad), authors (1 + floor(100 theta / (pi/2))), shares",
                 .why = "lobe: the authors' error in 20-30% less time on broad lobes "
                        "([notebook](notebook/2026-12-02-light-sets-and-vsl-counts.md))",
                 .words = {{"authors", double(VslCount::Authors)},
                           {"lobe", double(VslCount::Lobe)},
                           {"shares", double(VslCount::Shares)}},
                 .preset = true},
                &M::vslCount),
      bindField({.name = "lobe-radius",
                 .key = "lobeRadius",
                 .tier = X,
                 .min = 0,
                 .max = 100,
                 .help = "VSL radius at least F x distance x the light's GGX alpha",
                 .why = "no gain on tableau; F = 4 slower and worse "
                        "([notebook](notebook/2026-12-02-relative-eps-and-eye-samples.md))",
                 .words = {{"off", 0}},
                 .quiet = 0,
                 .uiMin = 0,
                 .uiMax = 4,
                 .preset = true},
                &M::lobeRadius),
      bindField({.name = "lobe-floor",
                 .key = "lobeFloor",
                 .tier = X,
                 .min = 0,
                 .max = 100,
                 .help = "A metal light's GGX alpha at least F x its cone's half-angle: spheres, not beams",
                 .why = "hall's error 2.1-2.4x lower, no bundled scene loses "
                        "([notebook](notebook/2026-12-03-lobe-floor.md))",
                 .words = {{"off", 0}},
                 .uiMin = 0,
                 .uiMax = 2,
                 .preset = true},
                &M::lobeFloor),
      bindField({.name = "continue-alpha",
                 .key = "continueAlpha",
                 .tier = X,
                 .appliesTo = "VSL, VPL",
                 .min = 0,
                 .max = 1,
                 .unit = "GGX alpha",
                 .help = "Eye paths continue through pure metals narrower than this instead of gathering there",
                 .why = "lowered both methods' error on a near-mirror box "
                        "([notebook](notebook/2026-12-01-radius-and-first-comparisons.md))",
                 .words = {{"off", 0}},
                 .uiMin = 0,
                 .uiMax = 0.2,
                 .preset = true},
                &M::continueAlpha),
      bindField({.name = "split-alpha",
                 .key = "splitAlpha",
                 .tier = X,
                 .appliesTo = "VSL, VPL",
                 .min = 0,
                 .max = 1,
                 .unit = "GGX alpha",
                 .help = "Gather points narrower than this gather their diffuse lobe and continue the specular one",
                 .why = "helps polished floors at 8+ eye samples, 40% slower first picture "
                        "([notebook](notebook/2026-12-02-splitting-and-radius.md))",
                 .words = {{"off", 0}},
                 .quiet = 0,
                 .uiMin = 0,
                 .uiMax = 0.2,
                 .preset = true},
                &M::splitAlpha),
  };
}

std::vector<Param<M>> lobeGatherParams() {
  constexpr ParamTier X = ParamTier::Experimental;
  return {
      bindField({.name = "lobe-gather",
                 .key = "lobeGather",
                 .kind = ParamKind::Int,
                 .tier = X,
                 .min = double(M::kLobeGatherK),
                 .max = 50'000'000,
                 .unit = "lights",
                 .help = "VSL: narrow receivers sample their specular lobe against a second light set of N lights",
                 .why = "wins kitchen and hall at equal time, but its second set costs every restart "
                        "([notebook](notebook/2026-12-04-lobe-gather.md))",
                 .words = {{"off", 0}},
                 .quiet = 0,
                 .uiMin = M::kLobeGatherK,
                 .uiMax = 1e7,
                 .uiLog = true,
                 .uiStart = 100'000,
                 .preset = true},
                &M::lobeGather),
      bindField({.name = "lobe-gather-rays",
                 .key = "lobeGatherRays",
                 .kind = ParamKind::Int,
                 .tier = X,
                 .min = 1,
                 .max = M::kMaxLobeGatherRays,
                 .unit = "per gather point",
                 .help = "Lobe gather: directions per gather point (the first batch takes an eighth)",
                 .why = "128 with 32 lights halved tableau's error against 8 with 256 "
                        "([notebook](notebook/2026-12-04-lobe-gather.md))",
                 .needs = "lobe-gather",
                 .uiMin = 1,
                 .uiMax = 1024,
                 .uiLog = true,
                 .preset = true},
                &M::lobeGatherRays),
      bindField({.name = "lobe-gather-alpha",
                 .key = "lobeGatherAlpha",
                 .tier = X,
                 .min = M::kMinLobeGatherAlpha,
                 .max = 1,
                 .unit = "GGX alpha",
                 .help = "Lobe gather: receivers narrower than this are lobe-gathered",
                 .why = "near-mirrors and brushed metals; 0.15 also hall's walls "
                        "([notebook](notebook/2026-12-05-lobe-gather-search-and-hall-walls.md))",
                 .quiet = M::kLobeGatherAlpha,
                 .needs = "lobe-gather",
                 .uiMin = M::kMinLobeGatherAlpha,
                 .uiMax = 1,
                 .uiLog = true,
                 .preset = true},
                &M::lobeGatherAlpha),
      bindField({.name = "pair-roulette",
                 .key = "pairRoulette",
                 .tier = X,
                 .appliesTo = "VSL, VPL",
                 .min = 0,
                 .max = 100,
                 .help = "Brute force: pairs below K x the mean pair's are gathered with probability "
                         "estimate / (K x mean), weighted by its inverse (unbiased)",
                 .why = "pays on hall (VPL 1.55x faster), costs variance on kitchen "
                        "([notebook](notebook/2026-12-05-batches-and-pair-roulette.md))",
                 .words = {{"off", 0}},
                 .quiet = 0,
                 .uiMin = 0,
                 .uiMax = 100,
                 .preset = true},
                &M::pairRoulette),
  };
}
}  // namespace

const ParamTable<ManyLightSettings>& manyLightParams() {
  static const ParamTable<ManyLightSettings> table = [] {
    std::vector<Param<M>> all;
    for (auto part : {lightSetParams, vslParams, vslIntegralParams, vplParams, heuristicParams, lobeGatherParams})
      for (Param<M>& p : part()) all.push_back(std::move(p));
    return ParamTable<ManyLightSettings>(std::move(all));
  }();
  return table;
}

// ---- [4] The path tracer's and the run parameters -----------------------------------

const ParamTable<RenderSettings>& pathTracerParams() {
  static const ParamTable<RenderSettings> table({
      bindField({.name = "spp",
                 .key = "spp",
                 .kind = ParamKind::Int,
                 .appliesTo = "PT",
                 .min = 1,
                 .max = 1 << 24,
                 .unit = "samples",
                 .help = "Samples per pixel of the path tracer",
                 .why = "render: a quick look; reference: 1,024 is below a fifth of the methods' errors at 64 px "
                        "([references](../assets/references/README.md))"},
                &RenderSettings::spp),
      bindField({.name = "max-depth",
                 .key = "maxDepth",
                 .kind = ParamKind::Int,
                 .appliesTo = "PT",
                 .min = 1,
                 .max = 1024,
                 .unit = "bounces",
                 .help = "Maximum scattering events per path",
                 .why = "Russian roulette ends paths long before 64 in the bundled scenes"},
                &RenderSettings::maxDepth),
  });
  return table;
}

const ParamTable<EnvironmentSettings>& environmentParams() {
  static const ParamTable<EnvironmentSettings> table({
      bindField({.name = "env-scale",
                 .key = "envScale",
                 .appliesTo = "all",
                 .min = 0,
                 .max = 1e6,
                 .help = "Multiplies the --env map's radiance",
                 .why = "1: the map's values as they are"},
                &EnvironmentSettings::scale),
      bindField({.name = "sun-diameter",
                 .key = "sunDiameter",
                 .appliesTo = "all",
                 .min = 0,
                 .max = 90,
                 .minOpen = true,
                 .unit = "degrees",
                 .help = "The --sun's angular diameter: a cone of directions of uniform radiance",
                 .why = "0.53: the real sun's; wider suns give softer shadows"},
                &EnvironmentSettings::sunDiameterDeg),
      bindField({.name = "sun-irradiance",
                 .key = "sunIrradiance",
                 .appliesTo = "all",
                 .min = 0,
                 .max = 1e9,
                 .unit = "W/m^2",
                 .help = "The --sun's irradiance on a surface facing it (as a glTF directional light's lux)",
                 .why = "3: a white Lambertian surface facing it has radiance 3/pi, about display white"},
                &EnvironmentSettings::sunIrradiance),
  });
  return table;
}

const std::vector<ParamSpec>& runParams() {
  static const std::vector<ParamSpec> specs = {
      {.name = "light-sets",
       .key = "lightSets",
       .kind = ParamKind::Int,
       .appliesTo = "VSL, VPL",
       .min = 1,
       .max = StudioSettings::kMaxLightSets,
       .help = "Independent light sets rendered and averaged; from two on, each method's bias and noise are measured",
       .why = "a many-light method's error is heavy-tailed: judge it on five sets or more "
              "([RESULTS](RESULTS.md))",
       .alias = "sets"},
      {.name = "progressive-radius",
       .key = "progressiveRadius",
       .appliesTo = "VSL",
       .min = 0,
       .max = 0.99,
       .minOpen = true,
       .help = "Consistent progressive VSL: light set k's r^2 shrinks by (k+ALPHA)/(k+1) per set",
       .why = "0.7 as in progressive photon mapping (Hachisuka et al. 2008); off in the studio",
       .words = {{"off", 0}},
       .uiMin = 0.05,
       .uiMax = 0.95,
       .uiStart = 0.7,
       .alias = "alpha"},
      {.name = "target-relmse",
       .key = "targetRelMse",
       .appliesTo = "reference",
       .min = 0,
       .max = 1,
       .help = "Stop once the reference's own indirect relMSE, from its two halves, is at most this (0: no target)",
       .why = "a fifth of the smallest method error the comparison shows ([references](../assets/references/"
              "README.md))"},
      {.name = "reference-method",
       .key = "referenceMethod",
       .kind = ParamKind::Choice,
       .appliesTo = "reference",
       .help = "Renderer of converged references: the path tracer (pt) or bidirectional path tracing (bdpt); "
               "the cache keeps them apart",
       .why = "pt: the shipped references' method; bdpt has 3-75x less equal-time noise on every bundled scene "
              "but the furnace, 57,000x on spot-panel ([RESULTS](RESULTS.md#bidirectional-path-tracing-as-the-"
              "reference))",
       .words = {{"pt", 0}, {"bdpt", 1}},
       .alias = "method"},
      {.name = "background-reference",
       .key = "backgroundReferenceSpp",
       .kind = ParamKind::Int,
       .appliesTo = "studio",
       .min = 0,
       .max = 1 << 20,
       .unit = "samples",
       .help = "Once the methods are done, render a reference of this many spp into the cache and use it (0: no)",
       .why = "off: a shipped or cached reference is found by key first ([references](../assets/references/"
              "README.md))"},
  };
  return specs;
}

const ParamSpec& runParam(std::string_view name) {
  for (const ParamSpec& p : runParams())
    if (name == p.name) return p;
  std::fprintf(stderr, "internal error: no run parameter '%.*s'\n", int(name.size()), name.data());
  std::abort();
}

// ---- [5] The docs table ---------------------------------------------------------------------

std::string paramTableMarkdown(const std::vector<ParamSpec>& specs, const std::vector<double>& defaults) {
  std::vector<std::string> texts;
  for (size_t i = 0; i < specs.size(); ++i) texts.push_back(formatParamValue(specs[i], defaults[i]));
  return paramTableMarkdown(specs, texts);
}

std::string paramTableMarkdown(const std::vector<ParamSpec>& specs, const std::vector<std::string>& defaults) {
  std::ostringstream s;
  s << "| parameter | default | range | unit | tier | methods | meaning | why the default |\n"
    << "|---|---|---|---|---|---|---|---|\n";
  for (size_t i = 0; i < specs.size(); ++i) {
    const ParamSpec& p = specs[i];
    std::string range = paramRangeText(p);
    std::replace(range.begin(), range.end(), '|', '/');
    s << "| `--" << p.name << "` | " << defaults[i] << " | " << range << " | " << p.unit << " | "
      << (p.tier == ParamTier::Method ? "method" : "experimental") << " | " << p.appliesTo << " | " << p.help << " | "
      << p.why << " |\n";
  }
  return s.str();
}

}  // namespace vsl
