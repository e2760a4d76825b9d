// `vsl reference SCENE`: a converged reference (the path tracer, or BDPT with
// --method bdpt) rendered as two
// independent halves (core/reference.h), written to -o and to the reference
// cache, with its own noise (relMSE(A, B) / 4) reported. It stops at --spp
// (default 1024), at --time, or once the noise reaches --target-relmse.
#include <algorithm>
#include <cstdio>

#include "app/cli.h"
#include "app/environment_options.h"
#include "app/finite_options.h"
#include "app/param_options.h"
#include "core/log.h"
#include "core/params.h"
#include "core/reference.h"
#include "core/render_context.h"

namespace vsl {

namespace {

struct ReferenceArgs {
  std::string scene, out, camera;
  RenderSettings settings;  // width, height, spp, timeLimit, seed, maxDepth
  double target = 0;        // stop once the indirect noise estimate is at most this
  bool sppGiven = false, noCache = false;
  bool half = false;  // 16-bit channels (the shipped references)
  EnvironmentOptions envOptions;
  int method = 0;  // ReferenceMethod: 0 the path tracer, 1 BDPT
};

std::string formatSeconds(double s) {
  char b[32];
  if (s < 90)
    std::snprintf(b, sizeof b, "%.0f s", s);
  else if (s < 5400)
    std::snprintf(b, sizeof b, "%.1f min", s / 60);
  else
    std::snprintf(b, sizeof b, "%.1f h", s / 3600);
  return b;
}

// Pass pairs until the sample count, the time or the noise target is reached,
// with a progress bar that estimates the time left.
void renderUntilDone(ReferenceRenderer& rr, const ReferenceArgs& a, int maxSpp) {
  const RenderSettings& s = a.settings;
  Progress progress("reference");
  Stopwatch clock;
  double noise = -1;
  while (true) {
    rr.step();
    double el = clock.seconds();
    const int spp = rr.spp();
    // The noise estimate costs one image comparison: check it every pass
    // pair when it decides, else every 16th.
    if (a.target > 0 || spp % 32 == 0) noise = rr.indirectNoise();
    const double perSpp = el / spp;
    double frac = double(spp) / maxSpp, remaining = (maxSpp - spp) * perSpp;
    if (s.timeLimit > 0) {
      frac = std::max(frac, el / s.timeLimit);
      remaining = std::min(remaining, s.timeLimit - el);
    }
    // The noise falls as 1/spp: the samples still needed follow from it.
    if (a.target > 0 && noise > 0 && spp >= 16) {
      double need = spp * noise / a.target;
      frac = std::max(frac, spp / std::max(need, double(spp)));
      remaining = std::min(remaining, std::max(need - spp, 0.0) * perSpp);
    }
    bool done = spp >= maxSpp || (s.timeLimit > 0 && el >= s.timeLimit) ||
                (a.target > 0 && spp >= 16 && noise >= 0 && noise <= a.target);
    char detail[160], noiseText[32] = "n/a";
    if (noise >= 0) std::snprintf(noiseText, sizeof noiseText, "%.2e", noise);
    std::snprintf(detail, sizeof detail, "%d spp, noise %s, %s, about %s left", spp, noiseText,
                  formatSeconds(el).c_str(), formatSeconds(std::max(remaining, 0.0)).c_str());
    progress.update(done ? 1.0 : std::min(frac, 0.999), detail);
    if (done) break;
  }
  progress.finish();
}

// Writes the reference to -o and to the cache (unless --no-cache).
int writeOutputs(const ReferenceArgs& a, const Reference& ref) {
  if (!a.out.empty()) {
    if (Result<void> written = writeReference(a.out, ref, a.scene, a.half); !written)
      return fail(kExitBadInput, written.error());
    std::fprintf(stderr, "wrote %s (layers: full, direct, indirect and halves A.*, B.*)\n", a.out.c_str());
  }
  if (!a.noCache) {
    Result<std::string> stored = storeCachedReference(ref, a.scene, a.half);
    if (!stored) return fail(kExitBadInput, stored.error());
    const std::string& written = *stored;
    if (written.empty())
      std::fprintf(stderr, "cache: kept %s (it has at least as many samples)\n", referenceCachePath(ref.key).c_str());
    else
      std::fprintf(stderr, "cache: stored %s\n", written.c_str());
  }
  return 0;
}

int cmdReference(ReferenceArgs& a) {
  RenderSettings& s = a.settings;
  if (Result<void> v = s.validate(); !v) return fail(kExitBadArguments, v.error());
  if (!(a.target >= 0) || a.target >= 1e3)
    return failf(kExitBadArguments, "--target-relmse must be in (0, 1000), or 0 for none (got %g)", a.target);
  // Without a time or noise target, --spp (default 1024) decides; with one,
  // --spp is an upper bound only when given.
  const bool bySpp = s.timeLimit <= 0 && a.target <= 0;
  const int maxSpp = bySpp || a.sppGiven ? std::max(2, s.spp + (s.spp & 1)) : (1 << 20);
  Result<EnvironmentSettings> env = resolveEnvironmentOptions(a.envOptions);
  if (!env) return fail(kExitBadArguments, env.error());
  auto scene = loadOrReport(a.scene, a.camera);
  if (!scene) return kExitBadInput;
  int w = s.width, h = s.height;
  resolveResolution(*scene, w, h);
  if (w > RenderSettings::kMaxResolution || h > RenderSettings::kMaxResolution)
    return failf(kExitBadArguments,
                 "%s: the camera's aspect ratio turns the requested size into %dx%d; give both --width "
                 "and --height",
                 a.scene.c_str(), w, h);
  s.width = w;
  s.height = h;
  Result<std::unique_ptr<RenderContext>> ctx = RenderContext::create(scene, 0, *env);
  if (!ctx) return fail(kExitBadInput, ctx.error());
  const ReferenceMethod method = ReferenceMethod(a.method);
  const std::string key = referenceKey(*scene, w, h, s.maxDepth, *env, method);
  ReferenceRenderer rr(*scene, (*ctx)->accel(), (*ctx)->lights(), s, method);
  std::fprintf(stderr, "reference: %s, %s, %dx%d, max depth %d, cache key %s\n", a.scene.c_str(),
               referenceMethodName(method), w, h, s.maxDepth, key.c_str());
  renderUntilDone(rr, a, maxSpp);
  Reference ref = rr.result();
  ref.key = key;
  std::fprintf(stderr, "reference: %d spp in %s; own noise: indirect relMSE %.3g, full %.3g (relMSE(A, B) / 4)\n",
               ref.spp, formatSeconds(ref.seconds).c_str(), ref.indirectNoise(), ref.fullNoise());
  if (rr.rejected() > 0) log::warning("rejected " + std::to_string(rr.rejected()) + " non-finite contributions");
  return writeOutputs(a, ref);
}

}  // namespace

Subcommand addReferenceCommand(CLI::App& app) {
  auto args = std::make_shared<ReferenceArgs>();
  ReferenceArgs& rfa = *args;
  rfa.settings.spp = 1024;
  rfa.settings.seed = kReferenceSeed;
  CLI::App* reference = app.add_subcommand(
      "reference",
      "Render a converged reference (path tracing, or BDPT with --method bdpt) in two independent halves, to a file "
      "and the cache");
  reference->add_option("scene", rfa.scene, "Scene file (.gltf or .glb)")->required();
  addParamOptions(reference, pathTracerParams(), rfa.settings);  // --spp is rounded up to even
  CLI::Option* spp = reference->get_option("--spp");
  reference->add_option("--time", rfa.settings.timeLimit, "Stop after this many seconds")->check(positiveSeconds());
  addParamOption(reference, runParam("target-relmse"), rfa.target);
  addParamOption(reference, runParam("reference-method"), rfa.method);
  reference->add_option("--width", rfa.settings.width, "Image width (default: from the scene, or 512)")
      ->check(CLI::Range(1, RenderSettings::kMaxResolution));
  reference->add_option("--height", rfa.settings.height, "Image height (default: from the scene, or 512)")
      ->check(CLI::Range(1, RenderSettings::kMaxResolution));
  reference
      ->add_option("--seed", rfa.settings.seed,
                   "Random seed (default: one that neither the studio's live path tracer nor vsl sweep uses)")
      ->default_str(std::to_string(kReferenceSeed))
      ->check(seedValue());
  reference->add_option("--camera", rfa.camera, "Camera name (default: the first perspective camera)");
  reference->add_option("-o,--output", rfa.out, "Output EXR (the cache gets a copy either way)");
  reference->add_flag("--no-cache", rfa.noCache, "Do not store the result in the reference cache");
  addEnvironmentOptions(reference, rfa.envOptions);
  reference->add_flag("--half", rfa.half,
                      "Write 16-bit channels (half the size; relative precision 2^-11, far below a reference's noise)");
  return {reference, [args, spp] {
            args->sppGiven = spp->count() > 0;
            return cmdReference(*args);
          }};
}

}  // namespace vsl
