// Stochastic lightcuts as an estimator: Yuksel, "Stochastic Lightcuts",
// HPG 2019, over the virtual lights, for every gather layer (VSL, clamped,
// unclamped and diffuse-only VPL). Each gather point draws its lights from
// a light tree (light_tree.h): from the root, a child with probability
// proportional to a bound of its lights' contribution (flux, distance, the
// orientation cone of Conty Estevez and Kulla 2018, and a conservative
// bound of the receiver's GGX lobe, LightTreeReceiver), and adds each
// light's contribution over its probability. Eye paths, direct light,
// shadow rays and the transfers are brute force's (core/gather.h).
//
// Parameters (docs/REFERENCE.md, "Stochastic lightcuts"):
//   slc-samples  4     lights drawn per gather point per step (the first
//                      of several steps draws one: its first picture)
//   slc-steps    16    steps per light set (the picture refines per step)
//   slc-floor    0.05  share of descents by flux alone
//   slc-independent off  each draw its own descent (off: a step's draws
//                      split over the tree in proportion to their
//                      probabilities, LightTree::sampleSplit)
//   slc-lobe-rays  1    the lobe strategy's directions per gather point
//                      per step (below; 0: off)
//   slc-lobe-alpha 0.05 its receivers: specular lobe narrower than this
//
// The lobe strategy. A narrow receiver lobe whose mirror direction meets a
// VSL's sphere takes most of that light from the first sphere it meets,
// which the tree's bounds cannot tell from the spheres behind it (they
// know no visibility): that light is drawn rarely and weighs much
// (docs/RESULTS.md, "Stochastic lightcuts"). So at such receivers M
// directions are also drawn from the receiver's BRDF, and every light
// whose cone holds a direction (LightTree::lightsOnRay) adds its VSL
// integrand there over the direction's pdf (Gatherer::vslAlong). The two
// strategies are combined per light (Veach 1997's balance heuristic over
// the light's expected draws): light i counts w_A = K p(i) / (K p(i) +
// M q(i)) of its VSL contribution from the tree's draws and w_B = 1 - w_A
// from the directions, p(i) its tree probability, q(i) the estimated share
// of BRDF samples that land in its cone (Gatherer::vslConeMass). The
// weights sum to one for every light and each strategy covers the lights
// it weighs, so the sum stays unbiased; only VSL's layer uses the
// directions (a VPL has no sphere to meet). The directions integrate the
// quadrature's integrand (the closed form has none per direction), so at
// the lobe strategy's receivers VSL takes the quadrature on both sides
// (quadrature_, below) whatever --vsl-integral says; elsewhere it takes the
// integral chosen. With the closed form the image differs from brute
// force's at those receivers by the closed form's own bias there.
//
// Bias: none for a fixed light set (the floor gives every light with flux
// a non-zero probability at every gather point); each step is an
// unbiased estimate of brute force's all-lights image (with VSL's closed
// form: of that image with the quadrature at the lobe strategy's
// receivers, above) and the images are their mean weighted by each step's
// draws (the mean over all draws). It refuses the pair roulette and the
// lobe gather.
#include "core/estimators/slc/slc.h"

#include <cstdio>
#include <limits>
#include <mutex>

#include "core/estimator_registry.h"
#include "core/estimators/slc/light_tree.h"
#include "core/gather.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "core/settings.h"
#include "core/stopwatch.h"

namespace vsl {

SlcSettings slcSettings(const EstimatorSettings& est) {
  SlcSettings s;
  s.samples = int(est.value("slc-samples"));
  s.steps = int(est.value("slc-steps"));
  s.floor = float(est.value("slc-floor"));
  s.independent = est.value("slc-independent") != 0;
  s.lobeRays = int(est.value("slc-lobe-rays"));
  s.lobeAlpha = float(est.value("slc-lobe-alpha"));
  return s;
}

EstimatorSettings slcEstimatorSettings(const SlcSettings& s) {
  EstimatorSettings e;
  e.name = "slc";
  e.values = {{"slc-samples", s.samples},     {"slc-steps", s.steps},
              {"slc-floor", double(s.floor)}, {"slc-independent", s.independent ? 1.0 : 0.0},
              {"slc-lobe-rays", s.lobeRays},  {"slc-lobe-alpha", double(s.lobeAlpha)}};
  return e;
}

namespace {

// The light choices' random stream (eye paths use 2, as brute force's).
constexpr uint64_t kPickStream = 0x51c;

RenderSettings directSettings(const ManyLightSettings& s) {
  RenderSettings r;
  r.width = s.width;
  r.height = s.height;
  r.seed = s.seed;
  r.maxDepth = 1;  // emission + one scattering event: the reference's direct part
  return r;
}

// The VSL quadrature stream of a light set's draw `draw` (counted over its
// steps) at gather point k: draw 0 is brute force's (gatherStream), so that
// a tree of one light gives brute force's picture.
uint64_t drawStream(size_t pix, int k, int draw) { return gatherStream(pix, k) ^ (uint64_t(uint32_t(draw)) << 24); }

class SlcEstimator final : public ManyLightEstimator {
 public:
  SlcEstimator(const RenderContext& ctx, ManyLightRun run, const ManyLightSettings& many, const SlcSettings& slc);
  const std::string& name() const override {
    static const std::string kName = "slc";
    return kName;
  }
  bool step(const std::atomic<bool>* stop) override;
  ManyLightImages images() const override;
  int stepsDone() const override { return done_; }
  int stepCount() const override { return slc_.steps; }
  std::optional<double> nextStepSeconds() const override {
    if (done() || done_ == 0) return std::nullopt;
    return laterStepSeconds();
  }
  std::optional<double> remainingSeconds() const override {
    if (done()) return 0.0;
    if (done_ == 0) return std::nullopt;
    return laterStepSeconds() * (slc_.steps - done_);
  }
  // The light set's share gathered: lights x draws done / draws in all.
  size_t lightsProcessed() const override {
    return size_t(double(run_.set.lights.size()) * drawsBefore(done_) / std::max(drawsBefore(slc_.steps), 1));
  }
  const ManyLightStats& stats() const override { return stats_; }
  std::vector<std::pair<std::string, double>> statistics() const override {
    return {{"treeSeconds", tree_.buildSeconds()},
            {"treeMegabytes", double(tree_.bytes()) / 1e6},
            {"samplesPerGatherPoint", double(drawsBefore(done_))}};
  }
  StepReport stepReport(double stepSeconds) const override;
  int width() const override { return width_; }
  int height() const override { return height_; }
  float clampBound() const override { return clamp_; }

 private:
  struct Step;
  void gatherTile(Step& st, const Gatherer& gatherer, int x0, int y0, int x1, int y1);
  void gatherPoint(Step& st, const Gatherer& gatherer, const GatherPoint& gp, size_t pix, int k, Rng& pick,
                   double acc[kGatherLayers][3], GatherCounters& c, double& vplOwn, double& vslOwn) const;
  void lobeDirections(const Gatherer& gatherer, const GatherPoint& gp, const LightTreeReceiver& r, int K, int M,
                      Rng& pick, double acc[kGatherLayers][3], GatherCounters& c) const;
  // The lobe strategy's directions at gp in step s (0: not used there).
  int lobeRaysAt(const GatherPoint& gp, const LightTreeReceiver& r, int s) const {
    if (slc_.lobeRays <= 0 || !many_.computeVsl || gp.lobe || !r.specularOn) return 0;
    if (!(std::min(r.ax, r.ay) < slc_.lobeAlpha)) return 0;
    // None in the first step of several: its quick picture costs what it did
    // (each step is unbiased on its own, whatever its M).
    return s == 0 && slc_.steps > 1 ? 0 : slc_.lobeRays;
  }
  void merge(const Step& st);
  // Draws per gather point in step s: slc-samples, but one in the first
  // step of a light set of several, so that its first picture costs about
  // a quarter of a step of four (docs/RESULTS.md, "Stochastic lightcuts").
  // And the draws in the steps before step s.
  int drawsIn(int s) const { return s == 0 && slc_.steps > 1 ? 1 : slc_.samples; }
  int drawsBefore(int s) const { return s <= 0 ? 0 : drawsIn(0) + (s - 1) * slc_.samples; }
  // A step after the first: the mean of those done, or after the first
  // alone its time scaled by the draws (an upper bound: the eye paths and
  // direct light do not grow with the draws).
  double laterStepSeconds() const {
    if (done_ >= 2) return (stepSeconds_ - firstStepSeconds_) / (done_ - 1);
    return firstStepSeconds_ * drawsIn(1) / drawsIn(0);
  }
  int sharedEyes(int s) const {
    return Gatherer::sharedEyePaths(sharedEnd_[size_t(s)] - (s > 0 ? sharedEnd_[size_t(s) - 1] : 0));
  }

  const RenderContext& ctx_;
  ManyLightSettings many_;
  // many_ with the quadrature: the VSL pairs of the lobe strategy's
  // receivers (see the top of this file).
  ManyLightSettings quadrature_;
  SlcSettings slc_;
  PathTracer direct_;
  LightTree tree_;
  int width_ = 0, height_ = 0;
  float clamp_ = 0;
  int done_ = 0;
  double stepSeconds_ = 0, firstStepSeconds_ = 0;
  std::vector<int> directEnd_, sharedEnd_;  // cumulative per step, as brute force's batches
  Film directFilm_, sharedFilm_;
  std::vector<Film> gather_;  // kGatherLayers films, one unbiased estimate per step
  std::vector<Vec3> stepDirect_, stepShared_, stepLayers_[kGatherLayers];
  ManyLightStats stats_;
};

SlcEstimator::SlcEstimator(const RenderContext& ctx, ManyLightRun run, const ManyLightSettings& many,
                           const SlcSettings& slc)
    : ManyLightEstimator(std::move(run)),
      ctx_(ctx),
      many_(many),
      quadrature_(many),
      slc_(slc),
      direct_(ctx.scene(), ctx.accel(), ctx.lights(), directSettings(many)),
      tree_(LightTree::build(run_.set, run_.radii)),
      width_(direct_.width()),
      height_(direct_.height()),
      clamp_(manyLightClampBound(ctx.scene(), many)),
      directFilm_(width_, height_),
      sharedFilm_(width_, height_) {
  quadrature_.vslIntegral = VslIntegral::Quadrature;
  // Shared eye paths spread evenly over the steps, at least one each (as
  // brute force's batches spread them: every step traces an eye path).
  // Direct samples spread evenly too, but a step of many may take none
  // (they are the direct light's, not the gather's: a sweep of thousands
  // of steps would otherwise trace thousands per pixel).
  for (int s = 0; s < slc_.steps; ++s) {
    const double share = double(s + 1) / slc_.steps;
    const int e = std::max(s + 1, int(std::lround(Gatherer::kSharedEyePaths * share)));
    sharedEnd_.push_back(std::max(e, sharedEnd_.empty() ? 1 : sharedEnd_.back() + 1));
    const int d = std::max(1, int(std::lround(many.directSamples * share)));
    directEnd_.push_back(std::max(d, directEnd_.empty() ? 1 : directEnd_.back()));
  }
  gather_.reserve(kGatherLayers);
  for (int k = 0; k < kGatherLayers; ++k) gather_.emplace_back(width_, height_);
}

// What one step's tiles share; its per-pixel results are merged only if
// the step completes.
struct SlcEstimator::Step {
  int s = 0, dBegin = 0, dEnd = 0, eyes = 1;
  const Gatherer* quadrature = nullptr;  // VSL at the lobe strategy's receivers
  const std::atomic<bool>* stop = nullptr;
  std::atomic<bool> abandoned{false};
  std::mutex mutex;
  double threadTime = 0, vplTime = 0, vslTime = 0;
};

bool SlcEstimator::step(const std::atomic<bool>* stop) {
  if (done() || run_.set.lights.empty()) return false;
  Stopwatch wall;
  Step st;
  st.s = done_;
  st.dBegin = st.s == 0 ? 0 : directEnd_[size_t(st.s) - 1];
  st.dEnd = directEnd_[size_t(st.s)];
  st.eyes = sharedEyes(st.s);
  st.stop = stop;
  const Gatherer gatherer(ctx_.scene(), ctx_.accel(), direct_.lightSampler(), many_, clamp_, many_.computeVsl,
                          many_.computeVpl);
  const Gatherer quadrature(ctx_.scene(), ctx_.accel(), direct_.lightSampler(), quadrature_, clamp_, many_.computeVsl,
                            many_.computeVpl);
  st.quadrature = &quadrature;
  const size_t np = size_t(width_) * height_;
  stepDirect_.resize(np);
  stepShared_.resize(np);
  for (auto& l : stepLayers_) l.resize(np);
  const bool complete = parallelForTiles(
      width_, height_, stop, [&](int x0, int y0, int x1, int y1) { gatherTile(st, gatherer, x0, y0, x1, y1); });
  if (!complete || st.abandoned) return false;
  merge(st);
  const double seconds = wall.seconds();
  stepSeconds_ += seconds;
  if (done_ == 0) firstStepSeconds_ = seconds;
  stats_.gatherSeconds += seconds;
  if (st.threadTime > 0) {
    stats_.vslSeconds += seconds * std::max(0.0, 1.0 - st.vplTime / st.threadTime);
    stats_.vplSeconds += seconds * std::max(0.0, 1.0 - st.vslTime / st.threadTime);
  }
  ++done_;
  return true;
}

// Per pixel: direct light (this step's share of samples), the eye path to
// its gather points and the light behind specular chains (as brute force's
// batch), then each gather point's draws.
void SlcEstimator::gatherTile(Step& st, const Gatherer& gatherer, int x0, int y0, int x1, int y1) {
  Stopwatch clock;
  GatherCounters c;
  double vplOwn = 0, vslOwn = 0;
  Gatherer::EyePathOptions options = Gatherer::eyePathOptions(st.eyes);
  // Past the 64 eye paths' schedule (one per step), one next-event sample
  // per step for the light behind specular chains: the steps average them.
  if (slc_.steps > Gatherer::kSharedEyePaths) options.lightSamples = 1;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      if (st.abandoned || (st.stop && st.stop->load(std::memory_order_relaxed))) {
        st.abandoned = true;
        return;
      }
      const size_t pix = size_t(y) * width_ + x;
      if (st.dEnd > st.dBegin) stepDirect_[pix] = directLight(direct_, x, y, st.dBegin, st.dEnd, c);
      Rng rng = Rng::forItem(pix, uint64_t(st.s), 2, many_.seed);
      const EyeSample es = gatherer.eyePath(x, y, width_, height_, rng, c, options);
      stepShared_[pix] = gatherer.sharedLight(es, st.eyes, x, y, width_, height_, uint64_t(st.s), c);
      double acc[kGatherLayers][3] = {};
      Rng pick = Rng::forItem(pix, uint64_t(st.s), kPickStream, many_.seed);
      for (int k = 0; k < kMaxGatherPoints; ++k)
        if (const GatherPoint* gp = es.point(k)) gatherPoint(st, gatherer, *gp, pix, k, pick, acc, c, vplOwn, vslOwn);
      for (int l = 0; l < kGatherLayers; ++l)
        stepLayers_[l][pix] = Vec3(float(acc[l][0]), float(acc[l][1]), float(acc[l][2]));
    }
  {
    std::lock_guard<std::mutex> lock(st.mutex);
    st.threadTime += clock.seconds();
    st.vplTime += vplOwn;
    st.vslTime += vslOwn;
  }
  ManyLightStats& s = stats_;
  s.pairs.fetch_add(c.pairs, std::memory_order_relaxed);
  s.shadowRays.fetch_add(c.shadowRays + c.rays, std::memory_order_relaxed);
  s.vslEvaluations.fetch_add(c.vslEvaluations, std::memory_order_relaxed);
  s.nonFinite.fetch_add(c.nonFinite, std::memory_order_relaxed);
}

// K lights drawn from the tree, each pair's transfers (one shadow ray, as
// brute force's) over K times its probability. Each method's own transfer
// is timed where both are computed.
void SlcEstimator::gatherPoint(Step& st, const Gatherer& gatherer, const GatherPoint& gp, size_t pix, int k, Rng& pick,
                               double acc[kGatherLayers][3], GatherCounters& c, double& vplOwn, double& vslOwn) const {
  // The tree's caps for the estimator that matters most: VSL where it is
  // computed, else the clamped VPL.
  const LightTreeReceiver r = LightTreeReceiver::make(gp, many_.computeVsl, many_.computeVsl ? kInf : clamp_);
  const int K = drawsIn(st.s);
  const int M = lobeRaysAt(gp, r, st.s);
  const Gatherer& vsl = M > 0 ? *st.quadrature : gatherer;  // VSL's pairs (the top of this file)
  const bool both = many_.computeVpl && many_.computeVsl;
  thread_local std::vector<LightTree::Sample> drawn;
  drawn.resize(size_t(K));
  int n = K;
  if (!slc_.independent)
    n = tree_.sampleSplit(r, pick, slc_.floor, K, drawn.data());
  else
    tree_.sampleMany(r, pick, slc_.floor, K, drawn.data());
  for (int j = 0; j < n; ++j) {
    const LightTree::Sample smp = drawn[size_t(j)];
    if (!(smp.pdf > 0)) continue;  // a light without flux
    const GatherLight L = decodeGatherLight(run_.set.lights[smp.light], run_.radii[smp.light]);
    PairGeometry g;
    if (!gatherer.connect(gp, L, g, c)) continue;
    double one[kGatherLayers][3] = {};
    Stopwatch own;
    gatherer.addVpl(gp, L, g, one, c);
    if (both) vplOwn += own.lap();
    vsl.addVsl(gp, L, g, smp.light, drawStream(pix, k, drawsBefore(st.s) + j), one, c);
    if (M > 0) {  // the tree's share of the light (the lobe strategy, above)
      const double Kp = double(K) * smp.pdf, wA = Kp / (Kp + double(M) * vsl.vslConeMass(gp, L, g));
      for (double& v : one[kVslLayer]) v *= wA;
    }
    if (both) vslOwn += own.seconds();
    const double w = smp.count / (double(K) * smp.pdf);
    for (int l = 0; l < kGatherLayers; ++l)
      for (int ch = 0; ch < 3; ++ch) acc[l][ch] += one[l][ch] * w;
  }
  if (M > 0) {
    Stopwatch own;
    lobeDirections(vsl, gp, r, K, M, pick, acc, c);
    if (both) vslOwn += own.seconds();
  }
}

// The lobe strategy's share (see the top of this file): M directions from
// the receiver's BRDF, each light whose cone holds one adding w_B of its
// integrand there over M x the direction's pdf.
void SlcEstimator::lobeDirections(const Gatherer& gatherer, const GatherPoint& gp, const LightTreeReceiver& r, int K,
                                  int M, Rng& pick, double acc[kGatherLayers][3], GatherCounters& c) const {
  const float scale = gatherer.vslRadiusScaleBound();
  for (int m = 0; m < M; ++m) {
    const float u0 = pick.uniform(), u1 = pick.uniform(), u2 = pick.uniform();
    const std::optional<BrdfSample> s = gp.rx.f.sample(u0, {u1, u2});
    if (!s || !(s->pdf > 0)) continue;
    const Vec3 l = gp.rx.frame.toWorld(s->wi);
    if (!(dot(l, gp.rx.ng) > 0)) continue;  // the integrand is zero below the surface
    tree_.lightsOnRay(gp.p, l, scale, [&](uint32_t i) {
      if (!Gatherer::facing(gp, run_.set.lights[i])) return;  // before decoding it
      const GatherLight L = decodeGatherLight(run_.set.lights[i], run_.radii[i]);
      PairGeometry g;
      const Vec3 v = gatherer.vslAlong(gp, L, l, g, c);
      if (isBlack(v)) return;
      const double Mq = double(M) * gatherer.vslConeMass(gp, L, g);
      if (!(Mq > 0)) return;  // the tree's draws hold all of this light
      const double wB = Mq / (Mq + double(K) * tree_.pdf(r, i, slc_.floor));
      const double w = wB / (double(M) * double(s->pdf));
      const Vec3 add = v * float(w);
      if (!isFinite(add)) {
        ++c.nonFinite;
        return;
      }
      for (int ch = 0; ch < 3; ++ch) acc[kVslLayer][ch] += add[ch];
    });
  }
}

// Each step is an unbiased estimate of the all-lights image, the mean of
// its draws: weighted by them.
void SlcEstimator::merge(const Step& st) {
  const int dCount = st.dEnd - st.dBegin;
  const double draws = drawsIn(st.s);
  parallelForChunks(size_t(height_), 16, [&](size_t y0, size_t y1) {
    for (int y = int(y0); y < int(y1); ++y)
      for (int x = 0; x < width_; ++x) {
        const size_t pix = size_t(y) * width_ + x;
        if (dCount > 0) directFilm_.add(x, y, stepDirect_[pix], double(dCount));
        sharedFilm_.add(x, y, stepShared_[pix], double(st.eyes));
        for (int k = 0; k < kGatherLayers; ++k) gather_[size_t(k)].add(x, y, stepLayers_[k][pix], draws);
      }
  });
}

// As brute force's (ManyLightRenderer::images): indirect = gathered + the
// light found on the eye paths; the lost layers are differences.
ManyLightImages SlcEstimator::images() const {
  ManyLightImages im;
  im.direct = directFilm_.image();
  const Image shared = sharedFilm_.image();
  Image layer[kGatherLayers];
  for (int k = 0; k < kGatherLayers; ++k) {
    layer[k] = gather_[size_t(k)].image();
    for (size_t i = 0; i < layer[k].rgb.size(); ++i) layer[k].rgb[i] += shared.rgb[i];
  }
  return imagesFromLayers(layer, std::move(im.direct), many_.diffuseOnly);
}

StepReport SlcEstimator::stepReport(double stepSeconds) const {
  StepReport out;
  char text[160];
  if (done_ == 1) {
    std::snprintf(text, sizeof text, "SLC light tree over %zu lights: %.2f s, %.1f MB", tree_.lights(),
                  tree_.buildSeconds(), double(tree_.bytes()) / 1e6);
    out.info.push_back(text);
  }
  std::snprintf(text, sizeof text, "SLC step %d/%d: %.2f s, %d lights per gather point", done_, slc_.steps, stepSeconds,
                drawsBefore(done_));
  out.info.push_back(text);
  return out;
}

// ---- Its parameters ---------------------------------------------------------------------

std::vector<EstimatorParam> slcParams() {
  return {
      {{.name = "slc-samples",
        .key = "slcSamples",
        .kind = ParamKind::Int,
        .appliesTo = "VSL, VPL",
        .min = 1,
        .max = 4096,
        .unit = "lights",
        .help = "Stochastic lightcuts: lights drawn from the light tree per gather point per step (the first of "
                "several steps of a light set draws one, for a quick first picture)",
        .why = "4 keeps a step at 256 px near a second for the progressive picture; 16 did a little better at "
               "equal time (kitchen, 100,000 VSLs, 20 s: 2.82 against 3.28, one set; "
               "[RESULTS](RESULTS.md#stochastic-lightcuts))",
        .uiMin = 1,
        .uiMax = 256,
        .uiLog = true},
       SlcSettings::kDefaultSamples},
      {{.name = "slc-steps",
        .key = "slcSteps",
        .kind = ParamKind::Int,
        .appliesTo = "VSL, VPL",
        .min = 1,
        .max = 100000,
        .unit = "steps",
        .help = "Stochastic lightcuts: steps per light set, each adding slc-samples draws per gather point (the "
                "first of several, one)",
        .why = "16 steps of 4 draws: 61 draws per gather point per light set (the sweep sets more, to fill its time)",
        .uiMin = 1,
        .uiMax = 1024,
        .uiLog = true},
       SlcSettings::kDefaultSteps},
      {{.name = "slc-floor",
        .key = "slcFloor",
        .tier = ParamTier::Experimental,
        .appliesTo = "VSL, VPL",
        .min = 0,
        .max = 1,
        .minOpen = true,
        .help = "Stochastic lightcuts: share of descents by flux alone (every light keeps a non-zero probability)",
        .why = "every light keeps at least 5% of its flux share whatever the bounds miss (a glossy light's lobe), "
               "for 5% of the draws ([RESULTS](RESULTS.md#stochastic-lightcuts))",
        .uiMin = 0.001,
        .uiMax = 1,
        .uiLog = true},
       SlcSettings::kDefaultFloor},
      {{.name = "slc-independent",
        .key = "slcIndependent",
        .kind = ParamKind::Flag,
        .appliesTo = "VSL, VPL",
        .help = "Stochastic lightcuts: each draw descends the tree on its own, instead of a gather point's draws "
                "of a step split over the tree's nodes in proportion to their probabilities (stratified, as a "
                "lightcut's nodes each get a draw)",
        .why = "off: kitchen, 100,000 VSLs, 256 px, 20 s, five light sets: relMSE 0.48 [0.42, 0.85] split (0.41 "
               "[0.39, 0.85] in a second run) against 0.63 [0.59, 0.91] independent "
               "([RESULTS](RESULTS.md#stochastic-lightcuts)); unbiased either way"},
       0},
  };
}

// The lobe strategy's (the top of this file).
std::vector<EstimatorParam> slcLobeParams() {
  return {
      {{.name = "slc-lobe-rays",
        .key = "slcLobeRays",
        .kind = ParamKind::Int,
        .tier = ParamTier::Experimental,
        .appliesTo = "VSL",
        .min = 0,
        .max = 1024,
        .unit = "per gather point",
        .help = "Stochastic lightcuts: directions drawn from the receiver's BRDF per step at narrow receivers, each "
                "light whose sphere a direction meets combined with the tree's draws by MIS (the lobe strategy)",
        .why = "1: 100,000 VSLs, 256 px, 20 s, five light sets, relMSE: kitchen 0.47 -> 0.41, hall 1.44 -> 0.86, "
               "tableau 20.6 -> 3.98, cornell-glossy 0.075 -> 0.072; kitchen at 1,000,000: 1.86 -> 0.70; 2 was "
               "slower for less ([RESULTS](RESULTS.md#stochastic-lightcuts))",
        .words = {{"off", 0}},
        .uiMin = 0,
        .uiMax = 64},
       SlcSettings::kDefaultLobeRays},
      {{.name = "slc-lobe-alpha",
        .key = "slcLobeAlpha",
        .tier = ParamTier::Experimental,
        .appliesTo = "VSL",
        .min = 0,
        .max = 1,
        .minOpen = true,
        .unit = "GGX alpha",
        .help = "Stochastic lightcuts' lobe strategy: receivers whose specular lobe is narrower than this",
        .why = "covers kitchen's near-mirror receivers (GGX alpha 0.01), where the tail was; not tuned "
               "([RESULTS](RESULTS.md#stochastic-lightcuts))",
        .uiMin = 0.001,
        .uiMax = 1,
        .uiLog = true},
       SlcSettings::kDefaultLobeAlpha},
  };
}

}  // namespace

namespace plugins {
EstimatorInfo slc();
}

// The registration function core/estimator_registry.cpp calls (its name is
// this folder's, from core/CMakeLists.txt's vsl_estimator(slc)).
EstimatorInfo plugins::slc() {
  EstimatorInfo e;
  e.name = "slc";
  e.label = "stochastic lightcuts";
  e.help =
      "Stochastic lightcuts (Yuksel 2019): per gather point, SAMPLES lights drawn from a light tree by bounds of "
      "their contribution, in STEPS progressive steps (unbiased after each step)";
  e.params = slcParams();
  for (EstimatorParam& p : slcLobeParams()) e.params.push_back(std::move(p));
  // VSL's radii shape the tree's bounds, and VPL's draws with them.
  e.methodsShareChoices = true;
  e.validateWith = [](const ManyLightSettings& many, const EstimatorSettings& est) -> Result<void> {
    if (many.pairRoulette > 0) return Error("pair-roulette: brute force only, not with stochastic lightcuts");
    if (many.lobeGather > 0) return Error("lobe-gather: not with stochastic lightcuts");
    if (many.lobeRadius > 0 && est.value("slc-lobe-rays") > 0)
      return Error("lobe-radius: not with stochastic lightcuts' lobe strategy (slc-lobe-rays)");
    return {};
  };
  // The tree: about one wide node per two lights (kitchen's and random
  // lights' 0.5-0.51: the nodes next to the lights hold two or three
  // entries), 0.6 allowed, each with a parent index; a leaf index and a
  // sort key per light.
  e.memory = [](const EstimatorSettings&, uint64_t) -> ExtraMemory {
    return {(sizeof(LightTreeWide) + sizeof(int32_t)) * 3 / 5 + sizeof(int32_t) + sizeof(uint64_t), 0};
  };
  e.create = [](const RenderContext& ctx, ManyLightRun run, const ManyLightSettings& many, const EstimatorSettings& est,
                StepProgress*, const std::atomic<bool>*) -> std::unique_ptr<ManyLightEstimator> {
    return std::make_unique<SlcEstimator>(ctx, std::move(run), many, slcSettings(est));
  };
  return e;
}

}  // namespace vsl
