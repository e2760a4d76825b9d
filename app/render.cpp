// `vsl render SCENE -o OUT.exr`: one image, as a multi-layer EXR (full,
// direct, indirect, or the many-light layers), optionally a tone-mapped PNG
// and statistics as JSON. This file holds the options, their validation,
// scene loading and the path tracer (--method pt: progressive passes of one
// sample per pixel until --spp or --time); the many-light methods are in
// render_many_lights.cpp.
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "app/cli.h"
#include "app/estimator_options.h"
#include "app/finite_options.h"
#include "app/param_options.h"
#include "app/render.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/params.h"
#include "core/pathtracer.h"

namespace vsl {

namespace {

using json = nlohmann::json;

// ---- Options and their validation ---------------------------------------------

void addRenderOptions(CLI::App* render, RenderArgs& ra) {
  render->add_option("scene", ra.scene, "Scene file (.gltf or .glb)")->required();
  render
      ->add_option("--method", ra.settings.method,
                   "pt (path-traced reference), vsl, vpl, or all (VSL, clamped VPL and the missing-energy layers "
                   "from one light set); vsl-sg and vsl-quadrature are vsl with --vsl-integral sg or quadrature")
      ->check(CLI::IsMember({"pt", "vsl", "vpl", "all", "vsl-sg", "vsl-quadrature"}))
      ->default_str("pt");
  addVslOptions(render, ra.many);
  addEstimatorOptions(render, ra.estimatorOptions);
  addParamOptions(render, pathTracerParams(), ra.settings);
  render->add_option("--time", ra.settings.timeLimit, "Render for this many seconds instead of --spp")
      ->check(positiveSeconds())
      ->excludes("--spp");
  render->add_option("--width", ra.settings.width, "Image width (default: from the scene, or 512)")
      ->check(CLI::Range(1, RenderSettings::kMaxResolution));
  render->add_option("--height", ra.settings.height, "Image height (default: from the scene, or 512)")
      ->check(CLI::Range(1, RenderSettings::kMaxResolution));
  render->add_option("--seed", ra.settings.seed, "Random seed")->default_str("0")->check(seedValue());
  render->add_option("--component", ra.component, "Component for the default EXR layer and the PNG")
      ->check(CLI::IsMember({"full", "direct", "indirect"}))
      ->default_str("full");
  render->add_option("--camera", ra.camera, "Camera name (default: the first perspective camera)");
  render->add_option("-o,--output", ra.out, "Output EXR")->required();
  render->add_option("--png", ra.png, "Also write a tone-mapped sRGB PNG");
  render->add_option("--exposure", ra.exposure, "PNG exposure in stops")->default_str("0");
  render->add_option("--json", ra.jsonPath, "Write statistics as JSON");
  addEnvironmentOptions(render, ra.envOptions);
}

// Fills a.many and a.estimator for the many-light methods from the command line.
// Returns 0, or the exit code after reporting.
int resolveManyLightArgs(RenderArgs& a) {
  ManyLightSettings& m = a.many;
  m.seed = a.settings.seed;
  m.computeVsl = a.method != Method::Vpl;
  m.computeVpl = a.method != Method::Vsl;
  m.width = a.settings.width;
  m.height = a.settings.height;
  if (Result<void> v = m.validate(); !v) return fail(kExitBadArguments, v.error());
  std::vector<std::string> given;
  for (const std::string& option : a.manyLightOptionsGiven) given.push_back(option.substr(2));
  if (Result<void> used = manyLightParams().checkUsed(m, given, m.computeVsl, m.computeVpl); !used)
    return fail(kExitBadArguments, "--" + used.error());
  Result<EstimatorSettings> e = resolveEstimatorOptions(a.estimatorOptions);
  if (!e) return fail(kExitBadArguments, e.error());
  a.estimator = *e;
  if (Result<void> with = a.estimator.validateWith(m); !with) return fail(kExitBadArguments, "--" + with.error());
  return 0;
}

// ---- The path tracer --------------------------------------------------------------

// Progressive passes, one sample per pixel each, until spp or the time limit;
// returns the number of passes.
int renderPasses(PathTracer& pt, const RenderSettings& s, Film& direct, Film& indirect, PtCounters& counters) {
  Progress progress("render");
  Stopwatch clock;
  int passes = 0;
  while (true) {
    // At least one pass: a time budget too short for one still renders one.
    if (passes > 0 && (s.timeLimit > 0 ? clock.seconds() >= s.timeLimit : passes >= s.spp)) break;
    pt.renderPass(passes, direct, indirect, counters);
    ++passes;
    double el = clock.seconds();
    double frac = s.timeLimit > 0 ? el / s.timeLimit : double(passes) / s.spp;
    char detail[128];
    std::snprintf(detail, sizeof detail, "%d spp, %.2f Mpaths/s, %.1f s", passes, counters.paths / el * 1e-6, el);
    progress.update(frac, detail);
  }
  progress.finish();
  return passes;
}

// The layers of a path-traced render.
struct PtImages {
  Image direct, indirect, full;
  const Image& chosen(Component c) const {
    return c == Component::Direct ? direct : c == Component::Indirect ? indirect : full;
  }
};

// The EXR (default layer = the chosen component) and the optional PNG.
int writePtImages(const RenderArgs& a, const PtImages& im, int passes) {
  const RenderSettings& s = a.settings;
  const Image& chosen = im.chosen(s.component);
  std::map<std::string, std::string> attrs = {{"vsl.version", VSL_VERSION},
                                              {"vsl.scene", a.scene},
                                              {"vsl.settings", s.describe()},
                                              {"vsl.environment", a.env.describe()},
                                              {"vsl.component", componentName(s.component)}};
  if (Result<void> written =
          writeExr(a.out, {{"", chosen}, {"full", im.full}, {"direct", im.direct}, {"indirect", im.indirect}}, attrs);
      !written)
    return fail(kExitBadInput, written.error());
  std::fprintf(stderr, "wrote %s (%dx%d, %d spp, layers: default=%s, full, direct, indirect)\n", a.out.c_str(),
               im.full.width, im.full.height, passes, componentName(s.component));
  if (!a.png.empty()) {
    if (Result<void> written = writePng(a.png, chosen, a.exposure); !written)
      return fail(kExitBadInput, written.error());
    std::fprintf(stderr, "wrote %s\n", a.png.c_str());
  }
  return 0;
}

// Everything --json reports about a path-traced render.
struct PtStats {
  int passes = 0;
  double loadSeconds = 0, bvhSeconds = 0, renderSeconds = 0;
  uint64_t paths = 0, rays = 0, rejected = 0;
};

int writePtJson(const RenderArgs& a, const Scene& scene, const PtImages& im, const PtStats& st) {
  const RenderSettings& s = a.settings;
  json j = {{"version", VSL_VERSION},
            {"scene", a.scene},
            {"camera", scene.camera.name},
            {"method", s.method},
            {"settings", s.describe()},
            {"environment", a.env.describe()},
            {"width", im.full.width},
            {"height", im.full.height},
            {"spp", st.passes},
            {"seed", s.seed},
            {"maxDepth", s.maxDepth},
            {"component", componentName(s.component)},
            {"seconds", {{"load", st.loadSeconds}, {"bvh", st.bvhSeconds}, {"render", st.renderSeconds}}},
            {"paths", st.paths},
            {"rays", st.rays},
            {"pathsPerSecond", st.paths / std::max(st.renderSeconds, 1e-9)},
            {"raysPerSecond", st.rays / std::max(st.renderSeconds, 1e-9)},
            {"nonFiniteRejected", st.rejected},
            {"mean",
             {{"full", imageMeanJson(im.full)},
              {"direct", imageMeanJson(im.direct)},
              {"indirect", imageMeanJson(im.indirect)}}},
            {"warnings", scene.warnings}};
  if (Result<void> written = writeTextFile(a.jsonPath, j.dump(2) + "\n"); !written)
    return fail(kExitBadInput, written.error());
  std::fprintf(stderr, "wrote %s\n", a.jsonPath.c_str());
  return 0;
}

int renderPathTraced(const RenderArgs& a, const RenderContext& ctx) {
  const Scene& scene = ctx.scene();
  PathTracer pt(scene, ctx.accel(), ctx.lights(), a.settings);
  int w = pt.width(), h = pt.height();
  Film direct(w, h), indirect(w, h);
  PtCounters counters;
  Stopwatch clock;
  PtStats st;
  st.passes = renderPasses(pt, a.settings, direct, indirect, counters);
  st.renderSeconds = clock.seconds();
  st.loadSeconds = ctx.loadSeconds();
  st.bvhSeconds = ctx.bvhSeconds();

  PtImages im{direct.image(), indirect.image(), {}};
  im.full = addImages(im.direct, im.indirect);
  if (int rc = writePtImages(a, im, st.passes); rc != 0) return rc;
  st.rejected = counters.nonFinite + direct.rejected() + indirect.rejected();
  if (st.rejected > 0) log::warning("rejected " + std::to_string(st.rejected) + " non-finite contributions");
  st.paths = counters.paths.load();
  st.rays = counters.rays.load();
  if (!a.jsonPath.empty()) return writePtJson(a, scene, im, st);
  return 0;
}

// ---- The command ----------------------------------------------------------------

int cmdRender(RenderArgs& a) {
  if (!parseComponent(a.component, &a.settings.component))
    return failf(kExitBadArguments, "--component must be full, direct or indirect (got '%s')", a.component.c_str());
  // --method vsl-sg / vsl-quadrature: VSL with that cone integral
  // (core/vsl_sg.h, core/vsl_integral.h); recorded as vsl with
  // --vsl-integral, so that replays need no alias.
  if (a.settings.method == "vsl-sg" || a.settings.method == "vsl-quadrature") {
    a.many.vslIntegral = a.settings.method == "vsl-sg" ? VslIntegral::Sg : VslIntegral::Quadrature;
    a.settings.method = "vsl";
  }
  if (Result<void> v = a.settings.validate(); !v) return fail(kExitBadArguments, v.error());
  Result<EnvironmentSettings> env = resolveEnvironmentOptions(a.envOptions);
  if (!env) return fail(kExitBadArguments, env.error());
  a.env = *env;
  a.method = parseMethod(a.settings.method).value_or(Method::Pt);  // validated above
  const bool many = a.method != Method::Pt;
  if (!many && !a.manyLightOptionsGiven.empty()) {
    std::string names;
    for (const std::string& n : a.manyLightOptionsGiven) names += (names.empty() ? "" : ", ") + n;
    return failf(kExitBadArguments,
                 "%s: for the many-light methods, but --method is pt (the path tracer, the default); remove "
                 "them, or give --method vsl, vpl or all",
                 names.c_str());
  }
  if (many)
    if (int rc = resolveManyLightArgs(a); rc != 0) return rc;
  Stopwatch loadClock;
  auto scene = loadOrReport(a.scene, a.camera);
  const double loadSeconds = loadClock.seconds();
  if (!scene) return kExitBadInput;
  // The camera's aspect ratio fills in a missing side: the result must still
  // be within the resolution cap.
  int w0 = a.settings.width, h0 = a.settings.height;
  resolveResolution(*scene, w0, h0);
  if (w0 > RenderSettings::kMaxResolution || h0 > RenderSettings::kMaxResolution)
    return failf(kExitBadArguments,
                 "%s: the camera's aspect ratio %g turns the requested size into %dx%d, over the limit of %d "
                 "a side; give both --width and --height",
                 a.scene.c_str(), scene->camera.aspect, w0, h0, RenderSettings::kMaxResolution);
  Result<std::unique_ptr<RenderContext>> ctx = RenderContext::create(scene, loadSeconds, a.env);
  if (!ctx) return fail(kExitBadInput, ctx.error());
  if (many) return renderManyLights(a, **ctx);
  if (!(*ctx)->hasEmitters())
    std::fprintf(stderr, "warning: %s has no lights, so the image is black (light it with --env, --sky or --sun)\n",
                 a.scene.c_str());
  return renderPathTraced(a, **ctx);
}

}  // namespace

json imageMeanJson(const Image& img) {
  Vec3 m = imageMean(img);
  return json::array({m.x, m.y, m.z});
}

Subcommand addRenderCommand(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* render = app.add_subcommand("render", "Render a glTF scene to a multi-layer EXR (full, direct, indirect)");
  addRenderOptions(render, *args);
  return {render, [args, render] {
            // Everything but these belongs to the many-light methods.
            static const std::set<std::string> kAnyMethod = {
                "scene",       "--method",       "--spp",           "--time",   "--width",  "--height",
                "--seed",      "--max-depth",    "--component",     "--camera", "--output", "--png",
                "--exposure",  "--json",         "--help",          "--env",    "--sky",    "--sun",
                "--env-scale", "--sun-diameter", "--sun-irradiance"};
            for (const CLI::Option* o : render->get_options()) {
              const std::string name = o->get_lnames().empty() ? o->get_name() : "--" + o->get_lnames().front();
              if (o->count() > 0 && !kAnyMethod.count(name)) args->manyLightOptionsGiven.push_back(name);
            }
            return cmdRender(*args);
          }};
}

}  // namespace vsl
