// `vsl sweep`: runs a grid of methods, light counts and radius scales against
// a reference EXR and charts what each gives up for speed. Every progressive
// step is a point (compute seconds, relMSE of the indirect image); the last
// point of each configuration is its final result.
// Output: sweep.csv, sweep.json, error_vs_time.png and pareto.png (gnuplot,
// from Debian's gnuplot-nox, when installed; the .gp scripts are written
// either way).
#include "app/sweep.h"

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
  int step = 0;
  double seconds = 0;
  double relMse = 0, rmse = 0, mean = 0;
  bool final = false;
  std::string series() const {
    std::ostringstream s;
    s << method;
    if (method != "pt") s << " N=" << lights;
    if (method.rfind("vsl", 0) == 0) s << " s=" << radiusScale;
    return s.str();
  }
};

Point measure(const std::string& method, uint32_t lights, float scale, int step, double seconds, const Image& img,
              const Image& ref) {
  CompareResult c = compareImages(img, ref);
  return {method, lights, scale, step, seconds, c.average.relMse, c.average.rmse, c.average.meanTest, false};
}

// Indices of the points on the lower-left (time, error) envelope.
std::vector<size_t> paretoFront(const std::vector<Point>& pts, const std::vector<size_t>& idx) {
  std::vector<size_t> sorted = idx;
  std::sort(sorted.begin(), sorted.end(), [&](size_t a, size_t b) { return pts[a].seconds < pts[b].seconds; });
  std::vector<size_t> front;
  double best = 1e300;
  for (size_t i : sorted)
    if (pts[i].relMse < best) best = pts[i].relMse, front.push_back(i);
  return front;
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
  std::vector<Point> pts;
  auto finish = [&] {
    if (!pts.empty()) pts.back().final = true;
  };
  auto log = [&](const Point& p) {
    std::fprintf(stderr, "sweep: %-34s step %3d  %8.2f s  relMSE %.5f\n", p.series().c_str(), p.step, p.seconds,
                 p.relMse);
  };

  for (const std::string& method : a.methods) {
    if (method == "pt") {
      RenderSettings rs;
      rs.width = W;
      rs.height = H;
      rs.seed = a.seed;
      PathTracer pt(scene, *accel, lights, rs);
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
          pts.push_back(measure("pt", 0, 0, pass + 1, el, ind.image(), *ref));
          log(pts.back());
          next *= 2;
        }
        if (last) break;
      }
      finish();
      continue;
    }
    // Pass-based methods: independent light sets, each rendered in full, the
    // estimate being their mean. "-progressive" shrinks the radius per pass
    // (r^2 *= (i+alpha)/(i+1)); "-mrcs" renders each pass with matrix
    // row-column sampling instead of the brute-force gather.
    const bool mrcs = method.find("-mrcs") != std::string::npos;
    const bool progressive = method.find("progressive") != std::string::npos;
    if (mrcs || progressive) {
      const bool vsl = method.rfind("vsl", 0) == 0;
      for (uint32_t n : a.lights)
        for (float sc : vsl ? a.radiusScales : std::vector<float>{0.0f}) {
          auto t0 = Clock::now();
          Image sum;
          for (int pass = 0;; ++pass) {
            ManyLightSettings m;
            m.lights = n;
            m.width = W;
            m.height = H;
            m.seed = a.seed + 1000003ull * uint64_t(pass);
            m.batches = 1;
            m.directSamples = 1;
            m.radiusScale = (sc > 0 ? sc : 1.0f) * (progressive ? progressiveRadiusFactor(pass, a.alpha) : 1.0f);
            m.computeVsl = vsl;
            m.computeVpl = !vsl;
            ManyLightRun run = prepareManyLights(scene, *accel, lights, m);
            Image v;
            if (mrcs) {
              MrcsSettings ms = a.mrcs;
              ms.seed = m.seed;
              MrcsResult mr = renderMrcs(scene, *accel, lights, run.set, run.radii, m, ms);
              v = vsl ? mr.images.vsl : mr.images.vpl;
            } else {
              ManyLightRenderer r(scene, *accel, lights, run.set, run.radii, m);
              r.renderBatch(0);
              v = vsl ? r.images().vsl : r.images().vpl;
            }
            if (pass == 0) sum = Image(W, H);
            for (size_t i = 0; i < sum.rgb.size(); ++i) sum.rgb[i] += v.rgb[i];
            Image mean = sum;
            for (float& x : mean.rgb) x /= float(pass + 1);
            double el = since(t0);
            pts.push_back(measure(method, n, sc, pass + 1, el, mean, *ref));
            log(pts.back());
            if (el >= a.time) break;
          }
          finish();
        }
      continue;
    }
    std::vector<float> scales = method == "vsl" ? a.radiusScales : std::vector<float>{0.0f};
    for (uint32_t n : a.lights)
      for (float sc : scales) {
        ManyLightSettings m;
        m.lights = n;
        m.width = W;
        m.height = H;
        m.seed = a.seed;
        m.batches = a.batches;
        m.directSamples = 1;
        m.radiusScale = sc > 0 ? sc : 1.0f;
        m.computeVsl = method == "vsl";
        m.computeVpl = method == "vpl";
        auto t0 = Clock::now();
        ManyLightRun run = prepareManyLights(scene, *accel, lights, m);
        ManyLightRenderer r(scene, *accel, lights, run.set, run.radii, m);
        for (int b = 0; b < r.batchCount(); ++b) {
          r.renderBatch(b);
          ManyLightImages im = r.images();
          double el = since(t0);  // includes light tracing and k-NN
          pts.push_back(measure(method, n, sc, b + 1, el, method == "vsl" ? im.vsl : im.vpl, *ref));
          log(pts.back());
          if (a.time > 0 && el >= a.time) break;
        }
        finish();
      }
  }

  // ---- CSV and JSON.
  std::ostringstream csv;
  csv << "method,lights,radius_scale,step,seconds,relmse,rmse,mean,final,relmse_minus_ref_noise\n";
  nlohmann::json js = {{"scene", a.scene}, {"reference", a.reference},        {"width", W},
                       {"height", H},      {"relMseEpsilon", kRelMseEpsilon}, {"points", nlohmann::json::array()}};
  js["referenceNoiseRelMSE"] = refNoise;  // 0 without --reference-b
  if (!a.referenceB.empty()) js["referenceB"] = a.referenceB;
  for (const Point& p : pts) {
    csv << p.method << "," << p.lights << "," << p.radiusScale << "," << p.step << "," << p.seconds << "," << p.relMse
        << "," << p.rmse << "," << p.mean << "," << (p.final ? 1 : 0) << "," << p.relMse - refNoise << "\n";
    js["points"].push_back({{"method", p.method},
                            {"lights", p.lights},
                            {"radiusScale", p.radiusScale},
                            {"step", p.step},
                            {"seconds", p.seconds},
                            {"relMSE", p.relMse},
                            {"rmse", p.rmse},
                            {"mean", p.mean},
                            {"final", p.final}});
  }
  // Pareto fronts of the final points, per method.
  std::map<std::string, std::vector<size_t>> finals;
  for (size_t i = 0; i < pts.size(); ++i)
    if (pts[i].final) finals[pts[i].method].push_back(i);
  std::map<std::string, std::vector<size_t>> fronts;
  for (auto& [m, idx] : finals) {
    fronts[m] = paretoFront(pts, idx);
    for (size_t i : fronts[m])
      js["pareto"][m].push_back({{"lights", pts[i].lights},
                                 {"radiusScale", pts[i].radiusScale},
                                 {"seconds", pts[i].seconds},
                                 {"relMSE", pts[i].relMse}});
  }
  std::filesystem::path dir(a.outDir);
  for (auto [name, text] :
       {std::pair<std::string, std::string>{"sweep.csv", csv.str()}, {"sweep.json", js.dump(2) + "\n"}})
    if (!writeTextFile((dir / name).string(), text, &err)) {
      std::fprintf(stderr, "error: %s\n", err.c_str());
      return 1;
    }

  // ---- Plots (gnuplot scripts with inline data).
  std::map<std::string, std::vector<size_t>> series;
  for (size_t i = 0; i < pts.size(); ++i) series[pts[i].series()].push_back(i);
  std::ostringstream gp1, gp2;
  gp1 << "set terminal pngcairo size 1000,700\nset output '" << (dir / "error_vs_time.png").string() << "'\n"
      << "set logscale xy\nset xlabel 'compute time (s)'\nset ylabel 'relMSE of the indirect image (eps = 0.01)'\n"
      << "set title 'Error against time: " << std::filesystem::path(a.scene).stem().string() << "'\nset key outside\n"
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
      << "set logscale xy\nset xlabel 'compute time (s)'\nset ylabel 'relMSE of the indirect image'\n"
      << "set title 'Pareto fronts (lower left is better): " << std::filesystem::path(a.scene).stem().string()
      << "'\nset key outside\nplot ";
  first = true;
  for (auto& [m, idx] : finals) {
    gp2 << (first ? "" : ", ") << "'-' using 1:2 with points pt 7 title '" << m
        << " runs', '-' using 1:2 with lines lw 2 title '" << m << " front'";
    first = false;
  }
  gp2 << "\n";
  for (auto& [m, idx] : finals) {
    for (size_t i : idx) gp2 << pts[i].seconds << " " << std::max(pts[i].relMse, 1e-12) << "\n";
    gp2 << "e\n";
    for (size_t i : fronts[m]) gp2 << pts[i].seconds << " " << std::max(pts[i].relMse, 1e-12) << "\n";
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
  std::printf("%-34s %10s %12s %16s\n", "configuration", "seconds", "relMSE", "minus ref noise");
  for (const Point& p : pts)
    if (p.final)
      std::printf("%-34s %10.2f %12.5f %16.5f\n", p.series().c_str(), p.seconds, p.relMse, p.relMse - refNoise);
  std::fprintf(stderr, "wrote %s/{sweep.csv, sweep.json, error_vs_time.png, pareto.png}\n", a.outDir.c_str());
  return 0;
}

}  // namespace vsl
