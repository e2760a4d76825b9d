// vsl_outliers: which (receiver, light) pairs make VSL's worst pixels
// (docs/notebook/2026-12-02-outliers.md). Not a test.
//
// One light set, one eye sample per pixel, every light gathered at every
// gather point (the `--batches 1` estimator). Against a path-traced reference
// it reports VSL's and clamped VPL's relMSE on luminance (eps relative, as in
// core/compare.h), the share of VSL's squared error held by the worst 1% of
// pixels, and that error split by the pixel's strongest VSL light: on a
// narrow metal or not (pure metal, narrower GGX axis below --alpha) and seen
// by a narrow receiver or not (the first gather point's narrower axis below
// --alpha). With --list K it prints the K worst pixels with their strongest
// light: its depth, lobe, radius, cone half-angle and the receiver's lobe.
//   vsl_outliers SCENE.gltf REFERENCE.exr [--seed 1] [--lights 10000]
//                [--width 64] [--alpha 0.05] [--list 0] [--split-alpha 0]
//                [--lobe-radius 0] [--lobe-floor 1] [--radius-scale 1]
// (the defaults of vsl render; the notebook's tables dated before
// 2026-12-03 were made with the floor off, --lobe-floor 0)
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "core/compare.h"
#include "core/gather.h"
#include "core/image_io.h"
#include "core/many_light.h"
#include "core/parallel.h"
#include "core/render_context.h"
#include "core/rng.h"

using namespace vsl;

namespace {

struct PixelResult {
  double vsl = 0, vpl = 0;  // luminance of the indirect estimates
  double top = 0;           // the strongest light's VSL contribution
  int topLight = -1;
  EyeSample eye;
};

double lum(const double v[3]) { return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]; }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("vsl_outliers: which pairs make VSL's worst pixels");
  std::string scenePath, refPath;
  ManyLightSettings s;
  s.seed = 1;
  s.width = 64;
  float alpha = 0.05f;
  int list = 0;
  app.add_option("scene", scenePath, "Scene file")->required();
  app.add_option("reference", refPath, "Path-traced reference EXR (its indirect layer)")->required();
  app.add_option("--seed", s.seed, "Light set seed");
  app.add_option("--lights", s.lights, "Virtual lights")->check(CLI::Range(1, 10'000'000));
  app.add_option("--width", s.width, "Image width (the reference's)")->check(CLI::Range(1, 4096));
  app.add_option("--alpha", alpha, "Narrow: GGX alpha (narrower axis) below this")->check(CLI::Range(0.0, 1.0));
  app.add_option("--list", list, "Print this many worst pixels")->check(CLI::Range(0, 10000));
  app.add_option("--split-alpha", s.splitAlpha, "Lobe splitting (as in vsl render)")->check(CLI::Range(0.0, 1.0));
  app.add_option("--lobe-floor", s.lobeFloor, "Lobe floor (as in vsl render)")->check(CLI::Range(0.0, 100.0));
  app.add_option("--lobe-radius", s.lobeRadius, "Lobe-aware minimum radius (as in vsl render)")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--radius-scale", s.radiusScale, "VSL radius scale (as in vsl render)")
      ->check(CLI::Range(0.01, 100.0));
  CLI11_PARSE(app, argc, argv);

  auto context = RenderContext::load(scenePath);
  if (!context) {
    std::fprintf(stderr, "vsl_outliers: %s\n", context.error().c_str());
    return 1;
  }
  const Scene& scene = (*context)->scene();
  s.height = 0;
  resolveResolution(scene, s.width, s.height);
  auto layers = readExr(refPath);
  if (!layers) {
    std::fprintf(stderr, "vsl_outliers: %s\n", layers.error().c_str());
    return 1;
  }
  const Image* ref = nullptr;
  for (const Layer& l : *layers)
    if (l.name == "indirect") ref = &l.image;
  if (!ref || ref->width != s.width || ref->height != s.height) {
    std::fprintf(stderr, "vsl_outliers: %s: no indirect layer of %dx%d\n", refPath.c_str(), s.width, s.height);
    return 1;
  }

  ManyLightRun run = prepareManyLights(scene, (*context)->accel(), (*context)->lights(), s);
  Gatherer gatherer(scene, (*context)->accel(), (*context)->lights(), s, manyLightClampBound(scene, s), true, true);
  std::vector<GatherLight> lights(run.set.lights.size());
  for (size_t i = 0; i < lights.size(); ++i) lights[i] = decodeGatherLight(run.set.lights[i], run.radii[i]);

  const int W = s.width, H = s.height;
  std::vector<PixelResult> px(size_t(W) * H);
  parallelFor(px.size(), [&](size_t i) {
    Rng rng = Rng::forItem(i, 0, 9, s.seed);
    GatherCounters c;
    PixelResult& p = px[i];
    p.eye = gatherer.eyePath(int(i % W), int(i / W), W, H, rng, c);
    p.vsl = p.vpl = luminance(p.eye.shared());
    for (int k = 0; k < p.eye.count; ++k) {
      if (!p.eye.points[k].valid) continue;
      for (size_t j = 0; j < lights.size(); ++j) {
        double acc[kGatherLayers][3] = {};
        gatherer.evaluate(p.eye.points[k], lights[j], j, gatherStream(i, k), acc, c);
        double v = lum(acc[kVslLayer]);
        p.vsl += v;
        p.vpl += lum(acc[kVplFullClamped]);
        if (v > p.top) {
          p.top = v;
          p.topLight = int(j);
        }
      }
    }
  });

  const double eps = RelMseEpsilon().resolve(*ref);  // relMSE's default, as vsl compare uses it
  std::vector<std::pair<double, int>> err;
  double vslErr = 0, vplErr = 0, byClass[2][2] = {};
  for (int i = 0; i < W * H; ++i) {
    const PixelResult& p = px[size_t(i)];
    double r = luminance(ref->at(i % W, i / W));
    double e = sqr(p.vsl - r) / (r * r + eps);
    vslErr += e;
    vplErr += sqr(p.vpl - r) / (r * r + eps);
    err.push_back({e, i});
    bool narrowLight = false, narrowReceiver = false;
    if (p.topLight >= 0) {
      const GatherLight& L = lights[size_t(p.topLight)];
      narrowLight = L.em.f.brdf().metallic >= 1.0f && L.alpha < alpha;
    }
    for (int k = 0; k < p.eye.count; ++k)
      if (p.eye.points[k].valid) {
        const Brdf& b = p.eye.points[k].rx.f.brdf();
        narrowReceiver = std::min(b.ggx.ax, b.ggx.ay) < alpha;
        break;
      }
    byClass[narrowLight][narrowReceiver] += e;
  }
  std::sort(err.rbegin(), err.rend());
  double worst = 0;
  for (int k = 0; k < W * H / 100; ++k) worst += err[size_t(k)].first;
  const double n = double(W) * H, tot = std::max(vslErr, 1e-300);
  std::printf("%s seed %llu, %u lights, %dx%d, one eye sample per pixel\n", scenePath.c_str(),
              (unsigned long long)s.seed, s.lights, W, H);
  std::printf("relMSE (luminance)  VSL %.4f  clamped VPL %.4f  VSL worst 1%% of pixels: %.2f of its squared error\n",
              vslErr / n, vplErr / n, worst / tot);
  std::printf(
      "VSL squared error by the pixel's strongest light (narrow metal or not) and receiver (narrow or not), alpha < "
      "%.3g:\n  other light, other receiver %.2f | other light, narrow receiver %.2f | narrow metal, other receiver "
      "%.2f | narrow metal, narrow receiver %.2f\n",
      alpha, byClass[0][0] / tot, byClass[0][1] / tot, byClass[1][0] / tot, byClass[1][1] / tot);
  for (int k = 0; k < std::min(list, W * H); ++k) {
    int i = err[size_t(k)].second;
    const PixelResult& p = px[size_t(i)];
    std::printf("(%d,%d) error %.1f  ref %.4f  VSL %.4f  VPL %.4f  strongest light %.4f", i % W, i / W,
                err[size_t(k)].first, luminance(ref->at(i % W, i / W)), p.vsl, p.vpl, p.top);
    if (p.topLight >= 0)
      for (int q = 0; q < p.eye.count; ++q) {
        const GatherPoint& gp = p.eye.points[q];
        if (!gp.valid) continue;
        const GatherLight& L = lights[size_t(p.topLight)];
        const Brdf &rb = gp.rx.f.brdf(), &lb = L.em.f.brdf();
        float dist = length(L.p - gp.p);
        double halfAngle = std::acos(1 - vslConeOneMinusCos(L.radius, dist)) * 180 / kPi;
        std::printf(
            " | point %d: receiver alpha (%.3f, %.3f) metallic %.2f; light depth %d alpha (%.3f, %.3f) metallic "
            "%.2f radius %.3f distance %.2f cone %.1f deg",
            q, rb.ggx.ax, rb.ggx.ay, rb.metallic, int(run.set.lights[size_t(p.topLight)].depth), lb.ggx.ax, lb.ggx.ay,
            lb.metallic, L.radius, dist, halfAngle);
      }
    std::printf("\n");
  }
  return 0;
}
