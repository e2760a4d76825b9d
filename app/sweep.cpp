// `vsl sweep`: runs a grid of methods, light counts and radius scales against
// a reference EXR and charts what each gives up for speed. Every progressive
// step is a point (compute seconds, relMSE of the indirect image); the last
// point of each run is its final result. Each configuration runs with
// --sets independent light sets (or path-tracer seeds), and its finals are
// summarised by the median, the quartiles and the worst 1% of pixels' share of
// the squared error (summary.csv).
// Output: sweep.csv, sweep.json, error_vs_time.png and pareto.png (gnuplot,
// from Debian's gnuplot-nox, when installed; the .gp scripts are written
// either way).
#include "app/sweep.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/compare.h"
#include "core/image_io.h"
#include "core/many_light.h"
#include "core/mrcs.h"

namespace vsl {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct Point {
  std::string method;
  uint32_t lights = 0;
  float radiusScale = 0;
  int set = 0;  // independent run of the configuration
  int step = 0;
  double seconds = 0;
  double relMse = 0, rmse = 0, mean = 0, worst1 = 0;
  bool final = false;
  std::string series() const {
    std::ostringstream s;
    s << method;
    if (method != "pt") s << " N=" << lights;
    if (method.rfind("vsl", 0) == 0) s << " s=" << radiusScale;
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
};

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
    if (pts[i].relMse < best) best = pts[i].relMse, front.push_back(i);
  return front;
}

// Everything one run needs: the scene, the reference and the arguments.
struct SweepContext {
  const SweepArgs& a;
  const Scene& scene;
  const Accel& accel;
  const LightSampler& lights;
  const Image& ref;
  int W, H;
  std::vector<Point>& pts;

  void record(const std::string& method, uint32_t n, float sc, int set, int step, double seconds, const Image& img) {
    CompareResult c = compareImages(img, ref);
    pts.push_back({method, n, sc, set, step, seconds, c.average.relMse, c.average.rmse, c.average.meanTest,
                   worstPixelShare(img, ref), false});
    const Point& p = pts.back();
    std::fprintf(stderr, "sweep: %-34s set %d step %3d  %8.2f s  relMSE %.5f\n", p.series().c_str(), set, step, seconds,
                 p.relMse);
  }
  void finish() {
    if (!pts.empty()) pts.back().final = true;
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
    m.computeVsl = method.rfind("vsl", 0) == 0;
    m.computeVpl = !m.computeVsl;
    return m;
  }

  // The path tracer, measured at 1, 2, 4, ... passes and at the budget.
  void runPt(int set) {
    RenderSettings rs;
    rs.width = W;
    rs.height = H;
    rs.seed = seedOf(set);
    PathTracer pt(scene, accel, lights, rs);
    Film d(W, H), ind(W, H);
    PtCounters c;
    double el = 0;
    int next = 1;
    for (int pass = 0;; ++pass) {
      auto t0 = Clock::now();
      pt.renderPass(pass, d, ind, c);
      el += since(t0);
      bool last = el >= a.time;
      if (pass + 1 == next || last) {
        record("pt", 0, 0, set, pass + 1, el, ind.image());
        next *= 2;
      }
      if (last) break;
    }
    finish();
  }

  // Pass-based methods: independent light sets, each rendered in full, the
  // estimate being their mean. "-progressive" shrinks the radius per pass
  // (r^2 *= (i+alpha)/(i+1)); "-mrcs" renders each pass with matrix
  // row-column sampling instead of the brute-force gather.
  void runPasses(const std::string& method, uint32_t n, float sc, int set) {
    const bool mrcs = method.find("-mrcs") != std::string::npos;
    const bool progressive = method.find("progressive") != std::string::npos;
    auto t0 = Clock::now();
    Image sum(W, H);
    for (int pass = 0;; ++pass) {
      ManyLightSettings m = manySettings(method, n, sc, seedOf(set, pass));
      m.batches = 1;
      if (progressive) m.radiusScale *= progressiveRadiusFactor(pass, a.alpha);
      ManyLightRun run = prepareManyLights(scene, accel, lights, m);
      Image v;
      if (mrcs) {
        MrcsSettings ms = a.mrcs;
        ms.seed = m.seed;
        MrcsResult mr = renderMrcs(scene, accel, lights, run.set, run.radii, m, ms);
        v = m.computeVsl ? mr.images.vsl : mr.images.vpl;
      } else {
        ManyLightRenderer r(scene, accel, lights, run.set, run.radii, m);
        r.renderBatch(0);
        v = m.computeVsl ? r.images().vsl : r.images().vpl;
      }
      for (size_t i = 0; i < sum.rgb.size(); ++i) sum.rgb[i] += v.rgb[i];
      Image mean = sum;
      for (float& x : mean.rgb) x /= float(pass + 1);
      double el = since(t0);
      record(method, n, sc, set, pass + 1, el, mean);
      if (el >= a.time) break;
    }
    finish();
  }

  // Brute force: one light set in progressive batches (each batch an unbiased
  // estimate of the all-lights image), capped by the budget. The clock
  // includes light tracing and k-NN, and only this method's own gather.
  void runBatches(const std::string& method, uint32_t n, float sc, int set) {
    ManyLightSettings m = manySettings(method, n, sc, seedOf(set));
    m.batches = a.batches;
    auto t0 = Clock::now();
    ManyLightRun run = prepareManyLights(scene, accel, lights, m);
    ManyLightRenderer r(scene, accel, lights, run.set, run.radii, m);
    for (int b = 0; b < r.batchCount(); ++b) {
      r.renderBatch(b);
      ManyLightImages im = r.images();
      double el = since(t0);
      record(method, n, sc, set, b + 1, el, m.computeVsl ? im.vsl : im.vpl);
      if (a.time > 0 && el >= a.time) break;
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
    std::vector<double> sec, rel, mean, worst;
    for (size_t i : idx) {
      sec.push_back(pts[i].seconds);
      rel.push_back(pts[i].relMse);
      mean.push_back(pts[i].mean);
      worst.push_back(pts[i].worst1);
    }
    const Point& p = pts[idx.front()];
    out.push_back({p.method, key, p.lights, p.radiusScale, int(idx.size()), quantile(sec, 0.5), quantile(rel, 0.5),
                   quantile(rel, 0.25), quantile(rel, 0.75), quantile(mean, 0.5), quantile(worst, 0.5)});
  }
  return out;
}

}  // namespace

int runSweep(const SweepArgs& a) {
  std::string err;
  LoadResult lr = loadScene(a.scene);
  if (!lr.scene) {
    std::fprintf(stderr, "error: %s\n", lr.error.c_str());
    return 1;
  }
  const Scene& scene = *lr.scene;
  auto accel = Accel::build(scene, &err);
  if (!accel) {
    std::fprintf(stderr, "error: %s\n", err.c_str());
    return 1;
  }
  LightSampler lights(scene);
  // The reference's indirect layer; a second, independent reference measures
  // the first one's own noise: E relMSE(B vs A) ~ 2 x A's noise, and every
  // measured relMSE carries A's noise on top of the method's error.
  auto readIndirect = [&](const std::string& path, Image& out) {
    std::vector<Layer> layers;
    if (!readExr(path, layers, &err)) {
      std::fprintf(stderr, "error: %s\n", err.c_str());
      return false;
    }
    for (Layer& l : layers)
      if (l.name == "indirect") {
        out = std::move(l.image);
        return true;
      }
    std::fprintf(stderr, "error: %s: no 'indirect' layer (render it with vsl render --method pt)\n", path.c_str());
    return false;
  };
  Image refImage, refB;
  if (!readIndirect(a.reference, refImage)) return 1;
  const Image* ref = &refImage;
  double refNoise = 0;
  if (!a.referenceB.empty()) {
    if (!readIndirect(a.referenceB, refB)) return 1;
    if (refB.width != ref->width || refB.height != ref->height) {
      std::fprintf(stderr, "error: %s: %dx%d, but the reference is %dx%d\n", a.referenceB.c_str(), refB.width,
                   refB.height, ref->width, ref->height);
      return 1;
    }
    refNoise = 0.5 * compareImages(refB, *ref).average.relMse;
    std::fprintf(stderr, "sweep: reference noise relMSE(B, A) / 2 = %.5f (errors below it are not resolved)\n",
                 refNoise);
  }
  std::error_code ec;
  std::filesystem::create_directories(a.outDir, ec);
  if (ec) {
    std::fprintf(stderr, "error: %s: cannot create the directory (%s)\n", a.outDir.c_str(), ec.message().c_str());
    return 1;
  }
  const int W = ref->width, H = ref->height;
  const double refMean = compareImages(*ref, *ref).average.meanRef;
  std::vector<Point> pts;
  SweepContext ctx{a, scene, *accel, lights, *ref, W, H, pts};
  for (const std::string& method : a.methods) {
    if (method == "pt") {
      for (int set = 0; set < a.sets; ++set) ctx.runPt(set);
      continue;
    }
    const bool passes = method.find("-mrcs") != std::string::npos || method.find("progressive") != std::string::npos;
    const bool vsl = method.rfind("vsl", 0) == 0;
    for (uint32_t n : a.lights)
      for (float sc : vsl ? a.radiusScales : std::vector<float>{0.0f})
        for (int set = 0; set < a.sets; ++set)
          passes ? ctx.runPasses(method, n, sc, set) : ctx.runBatches(method, n, sc, set);
  }
  const std::vector<Summary> summary = summarise(pts);

  // ---- CSV and JSON: every point, and the summary of the finals per configuration.
  std::ostringstream csv, sumCsv;
  csv << "method,lights,radius_scale,set,step,seconds,relmse,rmse,mean,worst1_share,final,relmse_minus_ref_noise\n";
  nlohmann::json js = {{"scene", a.scene},
                       {"reference", a.reference},
                       {"width", W},
                       {"height", H},
                       {"sets", a.sets},
                       {"relMseEpsilon", kRelMseEpsilon},
                       {"referenceIndirectMean", refMean},
                       {"settings", a.many.describe()},
                       {"points", nlohmann::json::array()},
                       {"summary", nlohmann::json::array()}};
  js["referenceNoiseRelMSE"] = refNoise;  // 0 without --reference-b
  if (!a.referenceB.empty()) js["referenceB"] = a.referenceB;
  for (const Point& p : pts) {
    csv << p.method << "," << p.lights << "," << p.radiusScale << "," << p.set << "," << p.step << "," << p.seconds
        << "," << p.relMse << "," << p.rmse << "," << p.mean << "," << p.worst1 << "," << (p.final ? 1 : 0) << ","
        << p.relMse - refNoise << "\n";
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
                            {"final", p.final}});
  }
  sumCsv << "method,lights,radius_scale,sets,seconds_median,relmse_median,relmse_q1,relmse_q3,"
            "relmse_median_minus_ref_noise,mean_median,mean_vs_reference,worst1_share_median\n";
  for (const Summary& m : summary) {
    double meanRatio = refMean > 0 ? m.mean / refMean - 1 : 0;
    sumCsv << m.method << "," << m.lights << "," << m.radiusScale << "," << m.sets << "," << m.seconds << ","
           << m.relMse << "," << m.q1 << "," << m.q3 << "," << m.relMse - refNoise << "," << m.mean << "," << meanRatio
           << "," << m.worst1 << "\n";
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
                             {"worst1ShareMedian", m.worst1}});
  }
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
  std::filesystem::path dir(a.outDir);
  for (auto [name, text] : {std::pair<std::string, std::string>{"sweep.csv", csv.str()},
                            {"summary.csv", sumCsv.str()},
                            {"sweep.json", js.dump(2) + "\n"}})
    if (!writeTextFile((dir / name).string(), text, &err)) {
      std::fprintf(stderr, "error: %s\n", err.c_str());
      return 1;
    }

  // ---- Plots (gnuplot scripts with inline data): the first run of each
  // configuration against time, and the medians with their quartiles.
  std::map<std::string, std::vector<size_t>> series;
  for (size_t i = 0; i < pts.size(); ++i)
    if (pts[i].set == 0) series[pts[i].series()].push_back(i);
  std::ostringstream gp1, gp2;
  gp1 << "set terminal pngcairo size 1000,700\nset output '" << (dir / "error_vs_time.png").string() << "'\n"
      << "set logscale xy\nset xlabel 'compute time (s)'\nset ylabel 'relMSE of the indirect image (eps = 0.01)'\n"
      << "set title 'Error against time (first of " << a.sets
      << " runs each): " << std::filesystem::path(a.scene).stem().string() << "'\nset key outside\n"
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
      << "set title 'Pareto fronts (lower left is better): " << std::filesystem::path(a.scene).stem().string()
      << "'\nset key outside\nplot ";
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
    for (size_t i : fronts[m]) gp2 << summary[i].seconds << " " << std::max(summary[i].relMse, 1e-12) << "\n";
    gp2 << "e\n";
  }
  for (auto [name, text] :
       {std::pair<std::string, std::string>{"error_vs_time.gp", gp1.str()}, {"pareto.gp", gp2.str()}}) {
    std::string path = (dir / name).string();
    if (!writeTextFile(path, text, &err)) {
      std::fprintf(stderr, "error: %s\n", err.c_str());
      return 1;
    }
    if (std::system("command -v gnuplot >/dev/null 2>&1") == 0) {
      std::string cmd = "gnuplot '" + path + "'";
      if (std::system(cmd.c_str()) != 0) std::fprintf(stderr, "warning: gnuplot failed on %s\n", path.c_str());
    } else {
      std::fprintf(stderr, "warning: gnuplot is not installed (scripts/setup.sh installs gnuplot-nox); wrote %s only\n",
                   path.c_str());
    }
  }
  std::printf("%d independent runs per configuration; reference indirect mean %.5g; eps = %.3g\n", a.sets, refMean,
              kRelMseEpsilon);
  std::printf("%-30s %9s %10s %21s %10s %9s %7s\n", "configuration", "seconds", "relMSE", "quartiles", "-ref noise",
              "mean", "worst1%");
  for (const Summary& m : summary)
    std::printf("%-30s %9.2f %10.5f   [%8.5f, %8.5f] %10.5f %+8.1f%% %7.2f\n", m.series.c_str(), m.seconds, m.relMse,
                m.q1, m.q3, m.relMse - refNoise, refMean > 0 ? 100 * (m.mean / refMean - 1) : 0.0, m.worst1);
  std::fprintf(stderr, "wrote %s/{sweep.csv, summary.csv, sweep.json, error_vs_time.png, pareto.png}\n",
               a.outDir.c_str());
  return 0;
}

}  // namespace vsl
