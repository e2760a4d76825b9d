// `vsl sweep`: runs a grid of methods, light counts and radius scales against
// a reference EXR and charts what each gives up for speed. Every progressive
// step is a point (compute seconds, relMSE of the indirect image). A run's
// final result is its last point within the time budget (--time, 2% slack),
// so that methods are compared at equal time even where a batch or an MRCS
// pass ends past the budget (its point is charted, not final; a run does not
// start a step that its last step's length, scaled by the next step's share
// of the work, predicts to end past the budget); a run with no point inside
// the budget has its first point final, and the -sets methods, which --time
// does not cap, their last. Each configuration runs with
// --sets independent light sets (or path-tracer seeds), and its finals are
// summarised by the median, the quartiles and the worst 1% of pixels' share of
// the squared error (summary.csv), the LDR-FLIP of the final images, and the
// split of their error into bias2 and variance over the independent runs.
// relMSE uses the reference-relative eps (core/compare.h), stated in the JSON.
// Output: sweep.csv (every point), summary.csv, sweep.json (both), a table
// on stdout, and error_vs_time.png, pareto.png and flip_vs_time.png
// (gnuplot, from Debian's gnuplot-nox, when installed; the .gp scripts are
// written either way); finals/: each configuration's first final image (EXR,
// PNG) and the reference's PNG.
// Fan-out: --shard I/N runs the configurations whose index in the grid is I
// mod N; --merge joins shard directories into the outputs of one run.
#include "app/sweep.h"

#include "app/cli.h"
#include "app/estimator_options.h"
#include "app/finite_options.h"
#include "app/param_options.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>

#include "core/compare.h"
#include "core/estimator.h"
#include "core/flip.h"
#include "core/image_io.h"
#include "core/many_light.h"
#include "core/params.h"
#include "core/reference.h"
#include "core/settings.h"
#include "core/stopwatch.h"

namespace vsl {

namespace {

// A sweep method, parsed once from its name: what it renders, with which
// estimator (its registered name, core/estimator_registry.h), and whether it runs in passes of independent light sets
// (the progressive ones shrinking the VSL radius per pass; the "-sets" ones stopping after --batches passes of one
// batch each: the mean of that many light sets).
struct SweepMethod {
  const char* name;
  Method gather;  // Pt, Vsl or Vpl
  const char* estimator;
  bool progressiveRadius, passes, passesCappedByBatches;
  // VSL with this cone integral whatever --vsl-integral says (vsl-sg: the
  // closed form, core/vsl_sg.h; vsl-quadrature: the paper's); unset: the
  // settings' (the closed form by default).
  std::optional<VslIntegral> integral{};
};
constexpr SweepMethod kSweepMethods[] = {
    {"pt", Method::Pt, "brute-force", false, false, false},
    {"vpl", Method::Vpl, "brute-force", false, false, false},
    {"vsl", Method::Vsl, "brute-force", false, false, false},
    {"vsl-sg", Method::Vsl, "brute-force", false, false, false, VslIntegral::Sg},
    {"vsl-quadrature", Method::Vsl, "brute-force", false, false, false, VslIntegral::Quadrature},
    {"vsl-progressive", Method::Vsl, "brute-force", true, true, false},
    {"vsl-mrcs", Method::Vsl, "mrcs", false, true, false},
    {"vpl-mrcs", Method::Vpl, "mrcs", false, true, false},
    {"vsl-mrcs-progressive", Method::Vsl, "mrcs", true, true, false},
    {"vsl-slc", Method::Vsl, "slc", false, false, false},
    {"vpl-slc", Method::Vpl, "slc", false, false, false},
    {"vsl-sets", Method::Vsl, "brute-force", false, true, true},
    {"vpl-sets", Method::Vpl, "brute-force", false, true, true},
};
// The method of a name the command line accepted (CLI::IsMember); names
// read back from a shard's CSV that are not methods of this version are
// treated as the brute-force VPL (only their labels matter when merging).
const SweepMethod& sweepMethod(const std::string& name) {
  for (const SweepMethod& m : kSweepMethods)
    if (name == m.name) return m;
  return kSweepMethods[1];
}

std::vector<std::string> sweepMethodNames() {
  std::vector<std::string> names;
  for (const SweepMethod& m : kSweepMethods) names.push_back(m.name);
  return names;
}

struct Point {
  std::string method;
  uint32_t lights = 0;
  float radiusScale = 0;
  int set = 0;  // independent run of the configuration
  int step = 0;
  double seconds = 0;
  double relMse = 0, rmse = 0, mean = 0, worst1 = 0;
  bool final = false;
  // Final points only (NaN elsewhere): LDR-FLIP of the image; bias2 and
  // variance of the configuration's finals over its independent runs (the
  // same on each of them; NaN with one run).
  double flip = NAN, bias2 = NAN, variance = NAN;
  // Where the run predicted, after this point, the next step would end
  // (seconds; NaN where it did not predict: the -sets methods, which stop
  // after --batches). It starts that step only if the end is within the
  // budget (sweep.json's nextStepPredictedEnd; null in a merged sweep, whose
  // points come from the shards' CSV; test Cli.SweepFinalsAreAtEqualTime).
  double nextEnd = NAN;
  std::string series() const {
    std::ostringstream s;
    const Method gather = sweepMethod(method).gather;
    s << method;
    if (gather != Method::Pt) s << " N=" << lights;
    if (gather == Method::Vsl) s << " s=" << radiusScale;
    return s.str();
  }
};

// The finals of one configuration over its independent runs.
struct Summary {
  std::string method, series;
  uint32_t lights = 0;
  float radiusScale = 0;
  int sets = 0;
  double seconds = 0, relMse = 0, q1 = 0, q3 = 0, mean = 0, worst1 = 0;  // medians and quartiles
  double flip = 0, bias2 = NAN, variance = NAN;                          // FLIP: median
};

// One configuration of the grid, in the order an unsharded run visits them.
struct Config {
  std::string method;
  uint32_t lights = 0;
  float radiusScale = 0;
};

std::vector<Config> gridOf(const std::vector<std::string>& methods, const std::vector<uint32_t>& lights,
                           const std::vector<float>& scales) {
  std::vector<Config> g;
  for (const std::string& m : methods) {
    const Method gather = sweepMethod(m).gather;
    if (gather == Method::Pt) {
      g.push_back({m, 0, 0});
      continue;
    }
    for (uint32_t n : lights)
      for (float sc : gather == Method::Vsl ? scales : std::vector<float>{0.0f}) g.push_back({m, n, sc});
  }
  return g;
}

// What the outputs need besides the points; --merge reads it back from sweep.json.
struct SweepMeta {
  std::string scene, reference, referenceB, settings;
  int width = 0, height = 0, sets = 0;
  double epsilon = 0, refMean = 0, refNoise = 0;
  RelMseEpsilon epsilonSpec;
  std::vector<std::string> methods;
  std::vector<uint32_t> lights;
  std::vector<float> radiusScales;
  int shardIndex = 0, shardCount = 1;
  double time = 0;  // --time: the budget the finals keep (0: a sweep.json from before 2026-12-03)
};

// ---- CSV of the points: written by every run, read back by --merge --------

std::string csvNumber(double v) {
  if (std::isnan(v)) return "nan";  // not empty: a trailing empty field is easy to lose
  std::ostringstream s;
  s << v;
  return s.str();
}

const char* kPointsHeader =
    "method,lights,radius_scale,set,step,seconds,relmse,rmse,mean,worst1_share,final,relmse_minus_ref_noise,flip_ldr,"
    "bias2,variance\n";

std::string pointsCsv(const std::vector<Point>& pts, double refNoise) {
  std::ostringstream csv;
  csv << kPointsHeader;
  for (const Point& p : pts)
    csv << p.method << "," << p.lights << "," << p.radiusScale << "," << p.set << "," << p.step << "," << p.seconds
        << "," << p.relMse << "," << p.rmse << "," << p.mean << "," << p.worst1 << "," << (p.final ? 1 : 0) << ","
        << p.relMse - refNoise << "," << csvNumber(p.flip) << "," << csvNumber(p.bias2) << "," << csvNumber(p.variance)
        << "\n";
  return csv.str();
}

// Parses pointsCsv()'s text; an error on a malformed line (named in it).
Result<void> parsePoints(const std::string& text, std::vector<Point>& pts) {
  std::istringstream in(text);
  std::string line;
  std::getline(in, line);
  if (line + "\n" != kPointsHeader) {
    return Error("not a sweep.csv of this version (header '" + line + "')");
  }
  auto num = [](const std::string& f) { return f == "nan" ? NAN : std::stod(f); };
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::istringstream ls(line);
    for (std::string x; std::getline(ls, x, ',');) f.push_back(x);
    if (!line.empty() && line.back() == ',') f.push_back("");
    if (f.size() != 15) {
      return Error("malformed line '" + line + "'");
    }
    try {
      Point p;
      p.method = f[0];
      p.lights = uint32_t(std::stoul(f[1]));
      p.radiusScale = std::stof(f[2]);
      p.set = std::stoi(f[3]);
      p.step = std::stoi(f[4]);
      p.seconds = std::stod(f[5]);
      p.relMse = std::stod(f[6]);
      p.rmse = std::stod(f[7]);
      p.mean = std::stod(f[8]);
      p.worst1 = std::stod(f[9]);
      p.final = f[10] == "1";
      p.flip = num(f[12]);
      p.bias2 = num(f[13]);
      p.variance = num(f[14]);
      pts.push_back(p);
    } catch (const std::exception&) {
      return Error("malformed number in '" + line + "'");
    }
  }
  return {};
}

// Linear-interpolated quantile of unsorted values.
double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  double x = q * double(v.size() - 1);
  size_t i = size_t(x);
  return i + 1 < v.size() ? v[i] + (x - double(i)) * (v[i + 1] - v[i]) : v[i];
}

// Indices of the points on the lower-left (time, error) envelope.
template <class T>
std::vector<size_t> paretoFront(const std::vector<T>& pts, const std::vector<size_t>& idx) {
  std::vector<size_t> sorted = idx;
  std::sort(sorted.begin(), sorted.end(), [&](size_t a, size_t b) { return pts[a].seconds < pts[b].seconds; });
  std::vector<size_t> front;
  double best = 1e300;
  for (size_t i : sorted)
    if (pts[i].relMse < best) {
      best = pts[i].relMse;
      front.push_back(i);
    }
  return front;
}

// A series ("vsl N=3000 s=1") as a file name ("vsl-N3000-s1").
std::string finalImageName(const std::string& series) {
  std::string out;
  for (char ch : series)
    if (ch == ' ')
      out += '-';
    else if (std::isalnum(static_cast<unsigned char>(ch)) || ch == '.' || ch == '-')
      out += ch;
  return out;
}

// Everything one run needs: the scene, the reference and the arguments.
struct SweepContext {
  const SweepArgs& a;
  const RenderContext& ctx;
  const Image& ref;
  int W, H;
  std::vector<Point>& pts;
  Image refSrgb;                     // the reference as LDR-FLIP sees it
  std::vector<Image> finals;         // this configuration's final images, one per run
  std::vector<size_t> finalIndices;  // and their points
  static constexpr size_t kNoPoint = size_t(-1);
  Image runFinalImage;         // the current run's final candidate's image
  size_t runFinal = kNoPoint;  // and its point

  // The latest point of a run capped by --time that may be its final one.
  double budget() const { return a.time * 1.02; }
  // Does a step of dt seconds started at el end within the budget? A run does
  // not start a step that would not (a brute-force batch predicted by the
  // estimator from what the batches done cost, part by part; a pass as long
  // as the last), since the point it would give could not be the run's final
  // one.
  bool nextFits(double el, double dt) const { return el + dt <= budget(); }
  // The same, keeping the prediction on the run's latest point
  // (Point::nextEnd): the steps of brute force and of passes.
  bool nextFitsAfterPoint(double el, double dt) {
    pts.back().nextEnd = el + dt;
    return nextFits(el, dt);
  }
  // Records a point; it becomes the run's final candidate unless the run is
  // time-capped, already has a candidate and this point is past the budget.
  void record(const std::string& method, uint32_t n, float sc, int set, int step, double seconds, const Image& img,
              bool timeCapped) {
    if (!timeCapped || runFinal == kNoPoint || seconds <= budget()) {
      runFinal = pts.size();
      runFinalImage = img;
    }
    CompareResult c = compareImages(img, ref);
    pts.push_back({method, n, sc, set, step, seconds, c.average.relMse, c.average.rmse, c.average.meanTest,
                   worstPixelShare(img, ref), false});
    const Point& p = pts.back();
    std::fprintf(stderr, "sweep: %-34s set %d step %3d  %8.2f s  relMSE %.5f\n", p.series().c_str(), set, step, seconds,
                 p.relMse);
  }
  // Marks the run's final candidate final, with the LDR-FLIP of its image.
  void finish() {
    if (runFinal == kNoPoint) return;
    Point& p = pts[runFinal];
    p.final = true;
    p.flip = flipLdr(toSrgbImage(runFinalImage), refSrgb).mean;
    finals.push_back(std::move(runFinalImage));
    finalIndices.push_back(runFinal);
    runFinal = kNoPoint;
  }
  // After a configuration's independent runs: bias2 and variance of their
  // finals, and the first run's final image written to look at.
  void endConfiguration() {
    if (!finals.empty()) writeFinalImage(pts[finalIndices.front()].series(), finals.front());
    if (finals.size() >= 2) {
      std::vector<const Image*> imgs;
      for (const Image& f : finals) imgs.push_back(&f);
      BiasVarianceResult bv = biasVariance(imgs, ref);
      for (size_t i : finalIndices) {
        pts[i].bias2 = bv.average.bias2;
        pts[i].variance = bv.average.variance;
      }
    }
    finals.clear();
    finalIndices.clear();
  }
  // finals/NAME.exr (layers indirect and default; withExr) and finals/NAME.png
  // (exposure 0, the tone map LDR-FLIP sees), NAME the series made
  // file-safe. A failed write is reported and remembered (the sweep's tables
  // are still written, then the sweep exits 1).
  std::string imageError;
  void writeFinalImage(const std::string& series, const Image& img, bool withExr = true) {
    const std::filesystem::path dir = std::filesystem::path(a.outDir) / "finals";
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    Result<void> w = ec ? Result<void>(Error(dir.string() + ": cannot create the directory (" + ec.message() + ")"))
                        : Result<void>();
    const std::string base = (dir / finalImageName(series)).string();
    if (w && withExr) w = writeExr(base + ".exr", {{"", img}, {"indirect", img}});
    if (w) w = writePng(base + ".png", img, 0.0f);
    if (!w) {
      std::fprintf(stderr, "sweep: %s\n", w.error().c_str());
      if (imageError.empty()) imageError = w.error();
    }
  }
  // Independent runs differ in every seed.
  uint64_t seedOf(int set, int pass = 0) const {
    return a.seed + 7919ull * uint64_t(set) + 1000003ull * uint64_t(pass);
  }
  ManyLightSettings manySettings(const std::string& method, uint32_t n, float scale, uint64_t seed) const {
    ManyLightSettings m = a.many;
    m.lights = n;
    m.width = W;
    m.height = H;
    m.seed = seed;
    m.directSamples = 1;
    m.radiusScale = scale > 0 ? scale : 1.0f;
    m.computeVsl = sweepMethod(method).gather == Method::Vsl;
    if (const std::optional<VslIntegral> i = sweepMethod(method).integral) m.vslIntegral = *i;
    m.computeVpl = !m.computeVsl;
    return m;
  }

  // The path tracer, measured at 1, 2, 4, ... passes and at its last two
  // passes (the last: the one after which another would end past the budget).
  void runPt(int set) {
    RenderSettings rs;
    rs.width = W;
    rs.height = H;
    rs.seed = seedOf(set);
    PathTracer pt(ctx.scene(), ctx.accel(), ctx.lights(), rs);
    Film d(W, H), ind(W, H);
    PtCounters c;
    double el = 0;
    int next = 1;
    for (int pass = 0;; ++pass) {
      Stopwatch passTime;
      pt.renderPass(pass, d, ind, c);
      const double dt = passTime.seconds();
      el += dt;
      const bool last = !nextFits(el, dt);
      // Also the pass before the predicted last: a last pass slower than the
      // one before may end past the budget, and the final would fall back to
      // the last power of two.
      if (pass + 1 == next || !nextFits(el, 2 * dt)) {
        record("pt", 0, 0, set, pass + 1, el, ind.image(), true);
        if (pass + 1 == next) next *= 2;
      }
      if (last) break;
    }
    finish();
  }

  // Pass-based methods: independent light sets, each rendered in full, the
  // estimate being their mean. "-progressive" shrinks the radius per pass
  // (r^2 *= (i+alpha)/(i+1)); "-mrcs" renders each pass with matrix
  // row-column sampling instead of the brute-force gather; "-sets" stops
  // after --batches passes (one eye sample per pixel each), and only then (not
  // at --time), so that its final image is the mean of that many light sets.
  void runPasses(const std::string& method, uint32_t n, float sc, int set) {
    const SweepMethod& sm = sweepMethod(method);
    Stopwatch clock;
    Image sum(W, H);
    double before = 0;  // the clock when this pass started
    for (int pass = 0;; ++pass) {
      ManyLightSettings m = manySettings(method, n, sc, seedOf(set, pass));
      m.batches = 1;
      if (sm.progressiveRadius) m.radiusScale *= progressiveRadiusFactor(pass, a.alpha);
      EstimatorSettings e = a.estimator;
      e.name = sm.estimator;
      e.seed = m.seed;
      std::unique_ptr<ManyLightEstimator> est = makeEstimator(ctx, prepareManyLights(ctx, m), m, e);
      while (est->step()) {
      }
      const ManyLightImages im = est->images();
      const Image& v = m.computeVsl ? im.vsl : im.vpl;
      for (size_t i = 0; i < sum.rgb.size(); ++i) sum.rgb[i] += v.rgb[i];
      Image mean = sum;
      for (float& x : mean.rgb) x /= float(pass + 1);
      double el = clock.seconds();
      record(method, n, sc, set, pass + 1, el, mean, !sm.passesCappedByBatches);
      if (sm.passesCappedByBatches ? pass + 1 >= a.batches : !nextFitsAfterPoint(el, el - before)) break;
      before = el;
    }
    finish();
  }

  // Brute force (or stochastic lightcuts): one light set in progressive
  // batches (steps), each an unbiased estimate of the all-lights image,
  // capped by the budget. The clock includes light tracing and k-NN (and
  // the light tree), and only this method's own gather.
  void runBatches(const std::string& method, uint32_t n, float sc, int set) {
    ManyLightSettings m = manySettings(method, n, sc, seedOf(set));
    m.batches = a.batches;
    Stopwatch clock;
    EstimatorSettings e = a.estimator;
    e.name = sweepMethod(method).estimator;
    e.seed = m.seed;
    std::unique_ptr<ManyLightEstimator> est = makeEstimator(ctx, prepareManyLights(ctx, m), m, e);
    double before = clock.seconds();  // when this step started (light tracing and k-NN are done)
    double gatheredBefore = est->stats().gatherSeconds;
    while (est->step()) {
      ManyLightImages im = est->images();
      double el = clock.seconds();
      record(method, n, sc, set, est->stepsDone(), el, m.computeVsl ? im.vsl : im.vpl, true);
      // The next batch's time as its parts cost so far (it may hold more
      // lights than this one, and the lobe gather's first batch fewer
      // directions), plus what this step spent outside its batch (images,
      // the comparison).
      const double gathered = est->stats().gatherSeconds;
      const double outside = std::max(el - before - (gathered - gatheredBefore), 0.0);
      if (!nextFitsAfterPoint(el, est->nextStepSeconds().value_or(el - before) + outside)) break;
      before = el;
      gatheredBefore = gathered;
    }
    finish();
  }
};

std::vector<Summary> summarise(const std::vector<Point>& pts) {
  std::map<std::string, std::vector<size_t>> groups;
  std::vector<std::string> order;
  for (size_t i = 0; i < pts.size(); ++i)
    if (pts[i].final) {
      std::string key = pts[i].series();
      if (!groups.count(key)) order.push_back(key);
      groups[key].push_back(i);
    }
  std::vector<Summary> out;
  for (const std::string& key : order) {
    const std::vector<size_t>& idx = groups[key];
    std::vector<double> sec, rel, mean, worst, flip;
    for (size_t i : idx) {
      sec.push_back(pts[i].seconds);
      rel.push_back(pts[i].relMse);
      mean.push_back(pts[i].mean);
      worst.push_back(pts[i].worst1);
      flip.push_back(pts[i].flip);
    }
    const Point& p = pts[idx.front()];
    out.push_back({p.method, key, p.lights, p.radiusScale, int(idx.size()), quantile(sec, 0.5), quantile(rel, 0.5),
                   quantile(rel, 0.25), quantile(rel, 0.75), quantile(mean, 0.5), quantile(worst, 0.5),
                   quantile(flip, 0.5), p.bias2, p.variance});
  }
  return out;
}

// The reference a sweep measures against, and its own noise.
struct SweepReference {
  Reference ref;
  std::string name;  // the file, or "cache: PATH"
  double noise = 0;  // relMSE the reference's own noise adds to every measurement
};

// A reference's indirect layer must be light to measure against: a black or
// negative mean makes every relMSE meaningless (exit 1). A few negative values
// (a reconstruction filter with negative lobes) are kept, with a warning.
Result<void> checkRadiance(const Image& ind, const std::string& name) {
  const Vec3 m = imageMean(ind);
  const double mean = (double(m.x) + m.y + m.z) / 3.0;
  if (!(mean > 0))
    return Error(name + ": the indirect layer's mean is " + defaultText(mean) +
                 "; a reference must hold the scene's indirect light (radiance is never negative), or every "
                 "relMSE against it means nothing");
  const size_t negative = size_t(std::count_if(ind.rgb.begin(), ind.rgb.end(), [](float v) { return v < 0; }));
  if (negative > 0)
    std::fprintf(stderr, "warning: %s: %zu of %zu values of the indirect layer are negative (kept)\n", name.c_str(),
                 negative, ind.rgb.size());
  return {};
}

// The sweep ranks methods on indirect light (docs/REFERENCE.md, "Metrics"); a
// full-only image (reference.h, Reference::fullOnly) can serve the studio only.
std::string indirectOnlyError(const std::string& path) {
  return path +
         ": has a full image but no 'indirect' layer; the sweep compares indirect light: render a reference "
         "with `vsl reference`, or open this one in vsl-studio, which compares the full image";
}

// The reference (reference.h): the file given, else the cached one for this
// scene at --width. Its own noise comes from its halves (relMSE(A, B) / 4) or
// from a second, independent reference B (relMSE(B, A) / 2); every measured
// relMSE carries it on top of the method's error, and the "minus reference
// noise" columns subtract it. Returns 0, or the exit code after reporting.
int loadSweepReference(const SweepArgs& a, const Scene& scene, SweepReference& out) {
  out.name = a.reference;
  if (!a.reference.empty()) {
    Result<Reference> read = readReference(a.reference, 0, 0);
    if (!read) return fail(kExitBadInput, read.error());
    if (read->fullOnly()) return fail(kExitBadInput, indirectOnlyError(a.reference));
    if (Result<void> same = checkReferenceScene(*read, scene, a.reference); !same)
      return fail(kExitBadInput, same.error());
    out.ref = std::move(read).value();
  } else {
    int w = a.width, h = 0;
    resolveResolution(scene, w, h);
    const std::string key = referenceKey(scene, w, h, RenderSettings().maxDepth);
    auto cached = findCachedReferenceAnyMethod(scene, w, h, RenderSettings().maxDepth, {}, ReferenceMethod::PathTracer);
    if (!cached)
      return failf(kExitBadInput,
                   "%s: no --reference given and no cached reference at %dx%d (%s); render one with\n"
                   "  vsl reference %s --width %d --spp 4096",
                   a.scene.c_str(), w, h, referenceCachePath(key).c_str(), a.scene.c_str(), w);
    out.name = "cache: " + cached->source;
    out.ref = std::move(*cached);
  }
  const Image& ref = out.ref.indirect;
  if (Result<void> radiance = checkRadiance(ref, out.name); !radiance) return fail(kExitBadInput, radiance.error());
  out.noise = std::max(out.ref.indirectNoise(), 0.0);
  const std::string spp = out.ref.spp > 0 ? ", " + std::to_string(out.ref.spp) + " spp" : "";
  std::fprintf(stderr, "sweep: reference %s (%dx%d%s), own noise %s\n", out.name.c_str(), ref.width, ref.height,
               spp.c_str(),
               out.ref.hasHalves() ? ("relMSE(A, B) / 4 = " + std::to_string(out.noise)).c_str() : "unknown");
  if (!a.referenceB.empty()) {
    Result<Reference> b = readReference(a.referenceB, ref.width, ref.height);
    if (!b) return fail(kExitBadInput, b.error());
    if (b->fullOnly()) return fail(kExitBadInput, indirectOnlyError(a.referenceB));
    if (Result<void> radiance = checkRadiance(b->indirect, a.referenceB); !radiance)
      return fail(kExitBadInput, radiance.error());
    if (Result<void> same = checkReferenceScene(*b, scene, a.referenceB); !same)
      return fail(kExitBadInput, same.error());
    out.noise = 0.5 * compareImages(b->indirect, ref).average.relMse;
    std::fprintf(stderr, "sweep: reference noise relMSE(B, A) / 2 = %.5f (errors below it are not resolved)\n",
                 out.noise);
  }
  return 0;
}

// Runs every configuration of the grid in this shard, each with --sets
// independent runs.
void runConfigurations(SweepContext& ctx, int shardIndex, int shardCount) {
  const SweepArgs& a = ctx.a;
  const std::vector<Config> grid = gridOf(a.methods, a.lights, a.radiusScales);
  for (size_t i = 0; i < grid.size(); ++i) {
    if (int(i % size_t(shardCount)) != shardIndex) continue;
    const Config& g = grid[i];
    const SweepMethod& m = sweepMethod(g.method);
    for (int set = 0; set < a.sets; ++set) {
      if (m.gather == Method::Pt)
        ctx.runPt(set);
      else if (m.passes)
        ctx.runPasses(g.method, g.lights, g.radiusScale, set);
      else
        ctx.runBatches(g.method, g.lights, g.radiusScale, set);
    }
    ctx.endConfiguration();
  }
}

// The settings every run of the sweep shares, as options (sweep.json's
// "settings", which --merge compares): the many-light template as
// SweepContext::manySettings applies it (one direct sample, the reference's
// size; the grid's light counts and radius scales are the grid's, the seeds
// per set derived from --seed), the brute-force batches, --alpha and the
// -mrcs methods' settings.
std::string sweepSettings(const SweepArgs& a, int W, int H) {
  ManyLightSettings m = a.many;
  m.seed = a.seed;
  m.batches = a.batches;
  m.directSamples = 1;
  m.width = W;
  m.height = H;
  std::ostringstream s;
  s << m.describe(false) << " --alpha " << a.alpha;
  // Every estimator's parameters (those of estimators no method uses too).
  for (const EstimatorInfo& info : estimators()) {
    EstimatorSettings e = a.estimator;
    e.name = info.name;
    s << e.describeParams();
  }
  return s.str();
}

// Runs this shard's part of the grid; fills the points and what the outputs need.
// imageError: the first final image that could not be written, if any.
int runGrid(const SweepArgs& a, int shardIndex, int shardCount, SweepMeta& meta, std::vector<Point>& pts,
            std::string& imageError) {
  Result<std::unique_ptr<RenderContext>> loaded = RenderContext::load(a.scene);
  if (!loaded) return fail(kExitBadInput, loaded.error());
  const RenderContext& context = **loaded;
  const Scene& scene = context.scene();
  SweepReference reference;
  if (int rc = loadSweepReference(a, scene, reference); rc != 0) return rc;
  const Image* ref = &reference.ref.indirect;
  std::error_code ec;
  std::filesystem::create_directories(a.outDir, ec);
  if (ec) return failf(kExitBadInput, "%s: cannot create the directory (%s)", a.outDir.c_str(), ec.message().c_str());
  const int W = ref->width, H = ref->height;
  const CompareResult self = compareImages(*ref, *ref);
  SweepContext ctx{a, context, *ref, W, H, pts, toSrgbImage(*ref), {}, {}, {}, SweepContext::kNoPoint, {}};
  // The reference's PNG first (its EXR is the input): a directory that
  // cannot take the images fails the sweep before it runs.
  ctx.writeFinalImage("reference", *ref, false);
  if (!ctx.imageError.empty()) return fail(kExitBadInput, ctx.imageError);
  runConfigurations(ctx, shardIndex, shardCount);
  imageError = ctx.imageError;
  meta = {
      a.scene,      reference.name,       a.referenceB,    sweepSettings(a, W, H), W,         H,        a.sets,
      self.epsilon, self.average.meanRef, reference.noise, self.epsilonSpec,       a.methods, a.lights, a.radiusScales,
      shardIndex,   shardCount,           a.time};
  // Summaries are taken from the points as the CSV holds them, so a merged
  // run reproduces them exactly.
  std::vector<Point> exact;
  if (Result<void> parsed = parsePoints(pointsCsv(pts, reference.noise), exact); !parsed)
    return fail(kExitBadInput, parsed.error());
  // The CSV does not hold the predictions: they are carried over (sweep.json).
  for (size_t i = 0; i < exact.size() && i < pts.size(); ++i) exact[i].nextEnd = pts[i].nextEnd;
  pts = std::move(exact);
  return 0;
}

// Plots (gnuplot scripts with inline data, rendered when gnuplot is
// installed): the first run of each configuration against time, the medians
// with their quartiles and Pareto fronts, and the median FLIP against time.
int writePlots(const SweepMeta& meta, const std::vector<Point>& pts, const std::vector<Summary>& summary,
               const std::map<std::string, std::vector<size_t>>& finals,
               const std::map<std::string, std::vector<size_t>>& fronts, const std::filesystem::path& dir) {
  const double refNoise = meta.refNoise;
  std::map<std::string, std::vector<size_t>> series;
  for (size_t i = 0; i < pts.size(); ++i)
    if (pts[i].set == 0) series[pts[i].series()].push_back(i);
  std::ostringstream gp1, gp2, gp3;
  const std::string sceneName = std::filesystem::path(meta.scene).stem().string();
  gp1 << "set terminal pngcairo size 1000,700\nset output '" << (dir / "error_vs_time.png").string() << "'\n"
      << "set logscale xy\nset xlabel 'compute time (s)'\nset ylabel 'relMSE of the indirect image (eps = "
      << meta.epsilonSpec.describe() << ")'\n"
      << "set title 'Error against time (first of " << meta.sets << " runs each): " << sceneName
      << "'\nset key outside\n"
      << "plot ";
  bool first = true;
  for (auto& [name, idx] : series) {
    gp1 << (first ? "" : ", ") << "'-' using 1:2 with linespoints title '" << name << "'";
    first = false;
  }
  if (refNoise > 0) gp1 << ", " << refNoise << " with lines dashtype 2 lc rgb 'gray40' title 'reference noise'";
  gp1 << "\n";
  for (auto& [name, idx] : series) {
    for (size_t i : idx) gp1 << pts[i].seconds << " " << std::max(pts[i].relMse, 1e-12) << "\n";
    gp1 << "e\n";
  }
  gp2 << "set terminal pngcairo size 1000,700\nset output '" << (dir / "pareto.png").string() << "'\n"
      << "set logscale xy\nset xlabel 'compute time (s, median)'\n"
      << "set ylabel 'relMSE of the indirect image (median, bars: quartiles)'\n"
      << "set title 'Pareto fronts (lower left is better): " << sceneName << "'\nset key outside\nplot ";
  first = true;
  for (auto& [m, idx] : finals) {
    gp2 << (first ? "" : ", ") << "'-' using 1:2:3:4 with yerrorbars pt 7 title '" << m
        << " configurations', '-' using 1:2 with lines lw 2 title '" << m << " front'";
    first = false;
  }
  gp2 << "\n";
  for (auto& [m, idx] : finals) {
    for (size_t i : idx)
      gp2 << summary[i].seconds << " " << std::max(summary[i].relMse, 1e-12) << " " << std::max(summary[i].q1, 1e-12)
          << " " << std::max(summary[i].q3, 1e-12) << "\n";
    gp2 << "e\n";
    for (size_t i : fronts.at(m)) gp2 << summary[i].seconds << " " << std::max(summary[i].relMse, 1e-12) << "\n";
    gp2 << "e\n";
  }
  // LDR-FLIP of the final images (median over the runs) against time.
  gp3 << "set terminal pngcairo size 1000,700\nset output '" << (dir / "flip_vs_time.png").string() << "'\n"
      << "set logscale x\nset xlabel 'compute time (s, median)'\n"
      << "set ylabel 'LDR-FLIP of the indirect image (median, " << kFlipPixelsPerDegree << " pixels/degree)'\n"
      << "set title 'FLIP against time (lower is better): " << sceneName << "'\nset key outside\nplot ";
  first = true;
  for (auto& [m, idx] : finals) {
    gp3 << (first ? "" : ", ") << "'-' using 1:2 with points pt 7 title '" << m << "'";
    first = false;
  }
  gp3 << "\n";
  for (auto& [m, idx] : finals) {
    for (size_t i : idx) gp3 << summary[i].seconds << " " << summary[i].flip << "\n";
    gp3 << "e\n";
  }
  for (auto [name, text] : {std::pair<std::string, std::string>{"error_vs_time.gp", gp1.str()},
                            {"pareto.gp", gp2.str()},
                            {"flip_vs_time.gp", gp3.str()}}) {
    std::string path = (dir / name).string();
    if (Result<void> written = writeTextFile(path, text); !written) return fail(kExitBadInput, written.error());
    if (std::system("command -v gnuplot >/dev/null 2>&1") == 0) {
      std::string cmd = "gnuplot '" + path + "'";
      if (std::system(cmd.c_str()) != 0) std::fprintf(stderr, "warning: gnuplot failed on %s\n", path.c_str());
    } else {
      std::fprintf(stderr, "warning: gnuplot is not installed (scripts/setup.sh installs gnuplot-nox); wrote %s only\n",
                   path.c_str());
    }
  }
  return 0;
}

// NaN (no value) as JSON null.
nlohmann::json jsonNumber(double v) { return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v); }

// sweep.json without its summary and Pareto fronts: the metadata and every point.
nlohmann::json pointsJson(const SweepMeta& meta, const std::vector<Point>& pts) {
  nlohmann::json js = {
      {"scene", meta.scene},
      {"reference", meta.reference},
      {"width", meta.width},
      {"height", meta.height},
      {"sets", meta.sets},
      {"relMseEpsilon", meta.epsilon},
      {"relMseEpsilonMode", meta.epsilonSpec.modeName()},
      {"relMseEpsilonFactor", meta.epsilonSpec.value},
      {"flipPixelsPerDegree", kFlipPixelsPerDegree},
      {"referenceIndirectMean", meta.refMean},
      {"settings", meta.settings},
      {"time", meta.time},
      {"grid", {{"methods", meta.methods}, {"lights", meta.lights}, {"radiusScales", meta.radiusScales}}},
      {"points", nlohmann::json::array()},
      {"summary", nlohmann::json::array()}};
  js["referenceNoiseRelMSE"] = meta.refNoise;  // 0 without --reference-b
  if (!meta.referenceB.empty()) js["referenceB"] = meta.referenceB;
  if (meta.shardCount > 1) js["shard"] = {{"index", meta.shardIndex}, {"count", meta.shardCount}};
  for (const Point& p : pts) {
    js["points"].push_back({{"method", p.method},
                            {"lights", p.lights},
                            {"radiusScale", p.radiusScale},
                            {"set", p.set},
                            {"step", p.step},
                            {"seconds", p.seconds},
                            {"relMSE", p.relMse},
                            {"rmse", p.rmse},
                            {"mean", p.mean},
                            {"worst1Share", p.worst1},
                            {"final", p.final},
                            {"flipLdr", jsonNumber(p.flip)},
                            {"bias2", jsonNumber(p.bias2)},
                            {"variance", jsonNumber(p.variance)},
                            {"nextStepPredictedEnd", jsonNumber(p.nextEnd)}});
  }
  return js;
}

// summary.csv, and the same rows appended to js["summary"].
std::string summaryCsv(const SweepMeta& meta, const std::vector<Summary>& summary, nlohmann::json& js) {
  const double refNoise = meta.refNoise, refMean = meta.refMean;
  std::ostringstream sumCsv;
  sumCsv << "method,lights,radius_scale,sets,seconds_median,relmse_median,relmse_q1,relmse_q3,"
            "relmse_median_minus_ref_noise,mean_median,mean_vs_reference,worst1_share_median,flip_ldr_median,bias2,"
            "variance\n";
  for (const Summary& m : summary) {
    double meanRatio = refMean > 0 ? m.mean / refMean - 1 : 0;
    sumCsv << m.method << "," << m.lights << "," << m.radiusScale << "," << m.sets << "," << m.seconds << ","
           << m.relMse << "," << m.q1 << "," << m.q3 << "," << m.relMse - refNoise << "," << m.mean << "," << meanRatio
           << "," << m.worst1 << "," << m.flip << "," << csvNumber(m.bias2) << "," << csvNumber(m.variance) << "\n";
    js["summary"].push_back({{"method", m.method},
                             {"lights", m.lights},
                             {"radiusScale", m.radiusScale},
                             {"sets", m.sets},
                             {"secondsMedian", m.seconds},
                             {"relMSEMedian", m.relMse},
                             {"relMSEQ1", m.q1},
                             {"relMSEQ3", m.q3},
                             {"relMSEMedianMinusReferenceNoise", m.relMse - refNoise},
                             {"meanMedian", m.mean},
                             {"meanVsReference", meanRatio},
                             {"worst1ShareMedian", m.worst1},
                             {"flipLdrMedian", m.flip},
                             {"bias2", jsonNumber(m.bias2)},
                             {"variance", jsonNumber(m.variance)}});
  }
  return sumCsv.str();
}

// The summary as a table on stdout.
void printSummary(const SweepMeta& meta, const std::vector<Summary>& summary) {
  const double refNoise = meta.refNoise, refMean = meta.refMean;
  std::printf("%d independent runs per configuration; reference indirect mean %.5g; eps = %s = %.3g\n", meta.sets,
              refMean, meta.epsilonSpec.describe().c_str(), meta.epsilon);
  std::printf("%-30s %9s %10s %21s %10s %9s %7s %7s %10s %10s\n", "configuration", "seconds", "relMSE", "quartiles",
              "-ref noise", "mean", "worst1%", "FLIP", "bias2", "variance");
  for (const Summary& m : summary)
    std::printf("%-30s %9.2f %10.5f   [%8.5f, %8.5f] %10.5f %+8.1f%% %7.2f %7.4f %10.5f %10.5f\n", m.series.c_str(),
                m.seconds, m.relMse, m.q1, m.q3, m.relMse - refNoise, refMean > 0 ? 100 * (m.mean / refMean - 1) : 0.0,
                m.worst1, m.flip, m.bias2, m.variance);
}

// sweep.csv, summary.csv, sweep.json, the plots and the table, from the points.
int writeOutputs(const SweepMeta& meta, const std::vector<Point>& pts, const std::string& outDir) {
  std::error_code ec;
  std::filesystem::create_directories(outDir, ec);
  if (ec) return failf(kExitBadInput, "%s: cannot create the directory (%s)", outDir.c_str(), ec.message().c_str());
  const std::vector<Summary> summary = summarise(pts);

  // CSV and JSON: every point, and the summary of the finals per configuration.
  nlohmann::json js = pointsJson(meta, pts);
  const std::string sumCsv = summaryCsv(meta, summary, js);
  // Pareto fronts of the configurations' medians, per method.
  std::map<std::string, std::vector<size_t>> finals;
  for (size_t i = 0; i < summary.size(); ++i) finals[summary[i].method].push_back(i);
  std::map<std::string, std::vector<size_t>> fronts;
  for (auto& [m, idx] : finals) {
    fronts[m] = paretoFront(summary, idx);
    for (size_t i : fronts[m])
      js["pareto"][m].push_back({{"lights", summary[i].lights},
                                 {"radiusScale", summary[i].radiusScale},
                                 {"seconds", summary[i].seconds},
                                 {"relMSE", summary[i].relMse}});
  }
  std::filesystem::path dir(outDir);
  for (auto [name, text] : {std::pair<std::string, std::string>{"sweep.csv", pointsCsv(pts, meta.refNoise)},
                            {"summary.csv", sumCsv},
                            {"sweep.json", js.dump(2) + "\n"}})
    if (Result<void> written = writeTextFile((dir / name).string(), text); !written)
      return fail(kExitBadInput, written.error());

  // A shard with no configuration of the grid has nothing to plot (gnuplot
  // fails on an empty plot command).
  if (pts.empty()) {
    std::fprintf(stderr,
                 "sweep: this shard holds no configuration of the grid; wrote %s/{sweep.csv, summary.csv, "
                 "sweep.json} without points\n",
                 outDir.c_str());
    return 0;
  }
  if (int rc = writePlots(meta, pts, summary, finals, fronts, dir); rc != 0) return rc;
  printSummary(meta, summary);
  std::fprintf(stderr,
               "wrote %s/{sweep.csv, summary.csv, sweep.json, error_vs_time.png, pareto.png, flip_vs_time.png, "
               "finals/}\n",
               outDir.c_str());
  return 0;
}

// Reads one shard's sweep.json and sweep.csv.
Result<void> readShard(const std::string& dir, SweepMeta& meta, std::vector<Point>& pts) {
  const std::filesystem::path d(dir);
  auto slurp = [&](const std::string& name, std::string& out) -> Result<void> {
    std::ifstream in(d / name, std::ios::binary);
    if (!in) return Error((d / name).string() + ": cannot read (is it a sweep output directory?)");
    std::ostringstream ss;
    ss << in.rdbuf();
    out = ss.str();
    return {};
  };
  std::string js, csv;
  if (Result<void> r = slurp("sweep.json", js); !r) return r;
  if (Result<void> r = slurp("sweep.csv", csv); !r) return r;
  try {
    nlohmann::json j = nlohmann::json::parse(js);
    meta.scene = j.at("scene");
    meta.reference = j.at("reference");
    meta.referenceB = j.value("referenceB", std::string());
    meta.settings = j.at("settings");
    meta.time = j.value("time", 0.0);
    meta.width = j.at("width");
    meta.height = j.at("height");
    meta.sets = j.at("sets");
    meta.epsilon = j.at("relMseEpsilon");
    meta.epsilonSpec = j.at("relMseEpsilonMode") == "absolute" ? RelMseEpsilon(double(j.at("relMseEpsilonFactor")))
                                                               : RelMseEpsilon::relative(j.at("relMseEpsilonFactor"));
    meta.refMean = j.at("referenceIndirectMean");
    meta.refNoise = j.at("referenceNoiseRelMSE");
    meta.methods = j.at("grid").at("methods").get<std::vector<std::string>>();
    meta.lights = j.at("grid").at("lights").get<std::vector<uint32_t>>();
    meta.radiusScales = j.at("grid").at("radiusScales").get<std::vector<float>>();
    meta.shardIndex = j.contains("shard") ? int(j["shard"].at("index")) : 0;
    meta.shardCount = j.contains("shard") ? int(j["shard"].at("count")) : 1;
  } catch (const std::exception& e) {
    return Error((d / "sweep.json").string() + ": " + e.what());
  }
  if (Result<void> parsed = parsePoints(csv, pts); !parsed)
    return Error((d / "sweep.csv").string() + ": " + parsed.error());
  return {};
}

// Joins shard directories: every shard of one grid exactly once; the points
// are put back in the order of an unsharded run.
int mergeShards(const SweepArgs& a) {
  SweepMeta meta;
  std::vector<std::vector<Point>> shardPts;
  std::vector<int> seen;
  for (const std::string& dir : a.merge) {
    SweepMeta m;
    std::vector<Point> pts;
    if (Result<void> read = readShard(dir, m, pts); !read) return fail(kExitBadInput, read.error());
    if (seen.empty()) {
      meta = m;
      seen.assign(size_t(m.shardCount), 0);
    } else if (m.scene != meta.scene || m.reference != meta.reference || m.width != meta.width ||
               m.height != meta.height || m.sets != meta.sets || m.settings != meta.settings ||
               m.methods != meta.methods || m.lights != meta.lights || m.radiusScales != meta.radiusScales ||
               m.shardCount != meta.shardCount || m.epsilon != meta.epsilon || m.time != meta.time) {
      return failf(kExitBadInput,
                   "%s: another sweep (scene, reference, grid, settings, time budget or shard count differ from %s)",
                   dir.c_str(), a.merge[0].c_str());
    }
    if (m.shardIndex < 0 || m.shardIndex >= int(seen.size()) || seen[size_t(m.shardIndex)]++)
      return failf(kExitBadInput, "%s: shard %d/%d given twice or out of range", dir.c_str(), m.shardIndex,
                   m.shardCount);
    shardPts.push_back(std::move(pts));
  }
  for (size_t i = 0; i < seen.size(); ++i)
    if (!seen[i]) return failf(kExitBadInput, "shard %zu/%d is missing", i, meta.shardCount);
  // Each shard's final images (a configuration lives in one shard; the
  // reference's image is the same in every shard).
  const std::filesystem::path finalsOut = std::filesystem::path(a.outDir) / "finals";
  for (const std::string& dir : a.merge) {
    const std::filesystem::path from = std::filesystem::path(dir) / "finals";
    std::error_code ec;
    if (!std::filesystem::is_directory(from, ec)) continue;
    std::filesystem::create_directories(finalsOut, ec);
    if (!ec)
      std::filesystem::copy(
          from, finalsOut, std::filesystem::copy_options::overwrite_existing | std::filesystem::copy_options::recursive,
          ec);
    if (ec)
      return failf(kExitBadInput, "%s: cannot copy its final images to %s (%s)", from.c_str(), finalsOut.c_str(),
                   ec.message().c_str());
  }
  // Configuration by configuration, in grid order (a configuration lives in one shard).
  auto key = [](const std::string& m, uint32_t n, float sc) {
    std::ostringstream s;
    s << m << "," << n << "," << sc;
    return s.str();
  };
  std::map<std::string, std::vector<Point>> byConfig;
  for (const std::vector<Point>& pts : shardPts)
    for (const Point& p : pts) byConfig[key(p.method, p.lights, p.radiusScale)].push_back(p);
  std::vector<Point> all;
  for (const Config& g : gridOf(meta.methods, meta.lights, meta.radiusScales)) {
    auto it = byConfig.find(key(g.method, g.lights, g.radiusScale));
    if (it == byConfig.end()) continue;
    all.insert(all.end(), it->second.begin(), it->second.end());
    byConfig.erase(it);
  }
  meta.shardIndex = 0;
  meta.shardCount = 1;
  std::fprintf(stderr, "sweep: merged %zu shards, %zu points\n", a.merge.size(), all.size());
  return writeOutputs(meta, all, a.outDir);
}

}  // namespace

namespace {

// The axis NAME=V1,V2,... as the parameter and its values' texts, or an error.
Result<std::pair<std::string, std::vector<std::string>>> parseVary(const std::string& vary, const SweepArgs& a) {
  const size_t eq = vary.find('=');
  if (eq == std::string::npos || eq + 1 == vary.size())
    return Error("--vary must be NAME=V1,V2,... (got '" + vary + "')");
  const std::string name = vary.substr(0, eq);
  Result<const Param<ManyLightSettings>*> p = manyLightParams().lookup(name);
  if (!p) return Error("--vary: " + p.error());
  if (name == "lights" || name == "radius-scale" || name == "batches")
    return Error("--vary: " + name + " has its own option (--" + name + ")");
  std::vector<std::string> texts;
  std::set<std::string> seen;
  for (size_t at = eq + 1; at <= vary.size();) {
    const size_t comma = std::min(vary.find(',', at), vary.size());
    const std::string text = vary.substr(at, comma - at);
    ManyLightSettings s = a.many;
    if (Result<void> r = manyLightParams().setText(s, name, text); !r) return Error("--vary: " + r.error());
    if (Result<void> r = manyLightParams().check(s); !r) return Error("--vary: " + r.error());
    const std::string canonical = formatParamValue((*p)->spec, (*p)->get(s));
    if (!seen.insert(canonical).second) return Error("--vary: " + name + " " + canonical + " is given twice");
    texts.push_back(canonical);
    at = comma + 1;
  }
  bool vsl = false, vpl = false;
  for (const std::string& m : a.methods) {
    vsl |= sweepMethod(m).gather == Method::Vsl;
    vpl |= sweepMethod(m).gather == Method::Vpl;
  }
  if (Result<void> used = manyLightParams().checkUsed(a.many, {name}, vsl, vpl); !used)
    return Error("--vary: " + used.error());
  return std::pair{name, texts};
}

// Runs one sweep per value of --vary, each into outDir/NAME=V, then joins
// their summary.csv files into outDir/vary.csv.
int runVary(const SweepArgs& a) {
  if (!a.shard.empty() || !a.merge.empty()) return fail(kExitBadArguments, "--vary: not with --shard or --merge");
  Result<std::pair<std::string, std::vector<std::string>>> axis = parseVary(a.vary, a);
  if (!axis) return fail(kExitBadArguments, axis.error());
  const auto& [name, texts] = *axis;
  std::string joined;
  for (const std::string& text : texts) {
    SweepArgs one = a;
    one.vary.clear();
    (void)manyLightParams().setText(one.many, name, text);
    one.outDir = (std::filesystem::path(a.outDir) / (name + "=" + text)).string();
    std::fprintf(stderr, "sweep: %s = %s -> %s\n", name.c_str(), text.c_str(), one.outDir.c_str());
    if (int rc = runSweep(one); rc != 0) return rc;
    std::ifstream in(std::filesystem::path(one.outDir) / "summary.csv");
    std::string line;
    for (bool header = true; std::getline(in, line); header = false)
      if (!header || joined.empty()) joined += (header ? name : text) + "," + line + "\n";
  }
  const std::string path = (std::filesystem::path(a.outDir) / "vary.csv").string();
  if (Result<void> written = writeTextFile(path, joined); !written) return fail(kExitBadInput, written.error());
  std::fprintf(stderr, "wrote %s: each value's summary, with a column for %s\n", path.c_str(), name.c_str());
  return 0;
}

}  // namespace

int runSweep(const SweepArgs& a) {
  if (!a.vary.empty()) return runVary(a);
  if (!a.merge.empty()) {
    if (!a.scene.empty())
      return failf(kExitBadArguments, "--merge joins shard directories and takes no scene (got '%s')", a.scene.c_str());
    return mergeShards(a);
  }
  if (a.scene.empty())
    return fail(kExitBadArguments,
                "sweep needs a scene (or --merge DIR...)\n\nUsage: vsl sweep SCENE [--reference REF.exr] -o DIR "
                "[--shard I/N] ...\n       vsl sweep --merge DIR... -o DIR");
  int shardIndex = 0, shardCount = 1;
  if (!a.shard.empty()) {
    size_t pos = 0;
    const bool read = readInt(a.shard, pos, shardIndex) && pos < a.shard.size() && a.shard[pos++] == '/' &&
                      readInt(a.shard, pos, shardCount) && pos == a.shard.size();
    if (!read || shardCount < 1 || shardIndex < 0 || shardIndex >= shardCount)
      return failf(kExitBadArguments, "--shard must be I/N with 0 <= I < N (got '%s')", a.shard.c_str());
  }
  for (const std::string& m : a.methods)
    if (m.find("progressive") != std::string::npos && !(a.alpha > 0))
      return failf(kExitBadArguments, "%s needs --progressive-radius (--alpha) in (0,0.99], not off", m.c_str());
  // Two configurations with one name (--lights 1000,1000; scales equal to six
  // digits) would share a row of the summary and a final image.
  std::map<std::string, int> names;
  for (const Config& g : gridOf(a.methods, a.lights, a.radiusScales)) {
    Point p;
    p.method = g.method;
    p.lights = g.lights;
    p.radiusScale = g.radiusScale;
    if (names[finalImageName(p.series())]++ == 1)
      return failf(kExitBadArguments,
                   "two configurations are both '%s': give distinct --lights and --radius-scale values",
                   p.series().c_str());
  }
  for (const std::string& m : a.methods) {
    EstimatorSettings e = a.estimator;
    e.name = sweepMethod(m).estimator;
    if (Result<void> v = e.validateWith(a.many); !v)
      return failf(kExitBadArguments, "--%s (method %s)", v.error().c_str(), m.c_str());
  }
  SweepMeta meta;
  std::vector<Point> pts;
  std::string imageError;
  if (int rc = runGrid(a, shardIndex, shardCount, meta, pts, imageError); rc != 0) return rc;
  if (int rc = writeOutputs(meta, pts, a.outDir); rc != 0) return rc;
  if (!imageError.empty()) return fail(kExitBadInput, imageError + " (the tables above were written)");
  return 0;
}

// The command line of `vsl sweep`: the grid's arguments and the -mrcs settings,
// parsed once the command line is.
struct SweepCommandArgs {
  SweepArgs sweep;
  EstimatorOptions estimator;  // the estimators' parameters (the methods choose the estimator)
};

Subcommand addSweepCommand(CLI::App& app) {
  auto args = std::make_shared<SweepCommandArgs>();
  SweepArgs& sw = args->sweep;
  CLI::App* sweep = app.add_subcommand("sweep", "Error against time for a grid of methods, light counts and radii");
  sweep->add_option("scene", sw.scene, "Scene file (not with --merge)");
  sweep
      ->add_option(
          "--methods", sw.methods,
          "Methods: pt, vpl, vsl; vsl-sg, vsl-quadrature (vsl with --vsl-integral sg or quadrature); vsl-progressive "
          "(independent light sets with shrinking radii); vsl-mrcs, vpl-mrcs (independent light sets, each with matrix "
          "row-column sampling); "
          "vsl-mrcs-progressive (both); vsl-slc, vpl-slc (one light set in stochastic lightcuts steps, capped by "
          "--time like vsl and vpl); vsl-sets, vpl-sets (the mean of --batches independent light "
          "sets, one eye sample per pixel each; not capped by --time)")
      ->delimiter(',')
      ->check(CLI::IsMember(sweepMethodNames()))
      ->default_str("pt,vpl,vsl");
  // The grid's axes: parameters of the registry (core/params.h).
  addParamAxisOption(sweep, manyLightParams().find("lights")->spec, sw.lights);
  addParamAxisOption(sweep, manyLightParams().find("radius-scale")->spec, sw.radiusScales);
  sweep
      ->add_option("--time", sw.time,
                   "Budget per run, seconds: each run's final result is its last point within it (2% slack; not the "
                   "-sets methods)")
      ->default_str("30")
      ->check(CLI::Range(0.01, 1e6));
  // vsl-progressive's ALPHA; the batches (for vsl-sets and vpl-sets: the
  // light sets averaged); the light sets per configuration.
  addParamOption(sweep, runParam("progressive-radius"), sw.alpha);
  addParamOption(sweep, manyLightParams().find("batches")->spec, sw.batches);
  addParamOption(sweep, runParam("light-sets"), sw.sets);
  addEstimatorOptions(sweep, args->estimator, false);
  sweep->add_option("--seed", sw.seed, "Random seed (must differ from the reference's)")
      ->default_str("1")
      ->check(seedValue());
  sweep->add_option("--reference", sw.reference,
                    "Reference EXR with an 'indirect' layer (vsl reference writes one with halves that measure its "
                    "noise); default: the cached reference at --width");
  sweep->add_option("--width", sw.width, "Without --reference: the width of the cached reference to use")
      ->default_str("256")
      ->check(CLI::Range(8, 16384));
  sweep
      ->add_option("--vary", sw.vary,
                   "Another grid axis: NAME=V1,V2,... for any method parameter (`vsl params`); each value's sweep "
                   "goes to OUTPUT/NAME=V and OUTPUT/vary.csv joins their summaries")
      ->group("Grid axes");
  sweep->add_option("--shard", sw.shard, "I/N: run only the configurations whose grid index is I mod N");
  sweep->add_option("--merge", sw.merge, "Join these shard output directories into -o (no scene needed)");
  sweep->add_option("--reference-b", sw.referenceB,
                    "A second reference with another seed: relMSE(B, A)/2 estimates the reference's own noise, "
                    "reported and subtracted in the column relmse_minus_ref_noise");
  sweep->add_option("-o,--output", sw.outDir, "Output directory")->required();
  // The grid's axes and the batches are the sweep's own options above.
  addVslOptions(sweep, sw.many, {"lights", "radius-scale", "batches"});
  return {sweep, [args] {
            Result<EstimatorSettings> e = resolveEstimatorOptions(args->estimator);
            if (!e) return fail(kExitBadArguments, e.error());
            args->sweep.estimator = *e;
            return runSweep(args->sweep);
          }};
}

}  // namespace vsl
