// Sections: [1] settings  [2] set-up and batches  [3] eye paths  [4] gather
//           [5] images  [6] prepareManyLights
#include "core/many_light.h"

#include <chrono>
#include <numeric>
#include <sstream>

#include "core/parallel.h"
#include "core/rng.h"
#include "core/vsl_integral.h"

namespace vsl {

// ---- [1] Settings -----------------------------------------------------------------

std::string ManyLightSettings::validate() const {
  std::ostringstream e;
  if (lights < 1 || lights > 50'000'000)
    e << "lights: must be in [1,50000000] (got " << lights << ")";
  else if (width < 0 || width > RenderSettings::kMaxResolution)
    e << "width: out of range (got " << width << ")";
  else if (height < 0 || height > RenderSettings::kMaxResolution)
    e << "height: out of range (got " << height << ")";
  else if (batches < 1 || batches > 64)
    e << "batches: must be in [1,64] (got " << batches << ")";
  else if (directSamples < 1 || directSamples > 65536)
    e << "direct-samples: must be in [1,65536] (got " << directSamples << ")";
  else if (!(radiusScale > 0 && radiusScale <= 1e9f))
    e << "radius-scale: must be in (0,1e9] (got " << radiusScale << ")";
  else if (knn < 1 || knn > 1000)
    e << "knn: must be in [1,1000] (got " << knn << ")";
  else if (!(globalRadius >= 0 && globalRadius <= 1e9f))
    e << "radius: must be in [0,1e9] (got " << globalRadius << ")";
  else if (vslSamples < 0 || vslSamples > 4096)
    e << "vsl-samples: must be auto or in [1,4096] (got " << vslSamples << ")";
  else if (std::isnan(clamp))
    e << "clamp: must be a number, 'auto' or 'off'";
  else if (lightMaxDepth < 1 || lightMaxDepth > 1024)
    e << "light-depth: must be in [1,1024] (got " << lightMaxDepth << ")";
  return e.str();
}

std::string ManyLightSettings::describe() const {
  std::ostringstream s;
  s << "--lights " << lights << " --seed " << seed << " --width " << width << " --height " << height << " --batches "
    << batches << " --direct-samples " << directSamples;
  if (globalRadius > 0)
    s << " --radius " << globalRadius;
  else
    s << " --radius-scale " << radiusScale << " --knn " << knn;
  s << " --vsl-samples " << (vslSamples > 0 ? std::to_string(vslSamples) : std::string("auto")) << " --clamp ";
  if (clamp < 0)
    s << "auto";
  else if (std::isinf(clamp))
    s << "off";
  else
    s << clamp;
  if (diffuseOnly) s << " --diffuse-vpl";
  return s.str();
}

// ---- [2] Set-up and batches ------------------------------------------------------

struct ManyLightRenderer::GatherLight {
  Vec3 p, Phi, n, ng;
  VslEmitter em;
  float radius;
};

namespace {
RenderSettings directSettings(const ManyLightSettings& s) {
  RenderSettings r;
  r.width = s.width;
  r.height = s.height;
  r.seed = s.seed;
  r.maxDepth = 1;  // emission + one scattering event: exactly the reference's direct part
  return r;
}
}  // namespace

ManyLightRenderer::ManyLightRenderer(const Scene& scene, const Accel& accel, const LightSampler& lights,
                                     const VirtualLightSet& set, const std::vector<float>& radii,
                                     const ManyLightSettings& settings)
    : scene_(scene),
      accel_(accel),
      set_(set),
      radii_(radii),
      settings_(settings),
      direct_(scene, accel, lights, directSettings(settings)) {
  width_ = direct_.width();
  height_ = direct_.height();
  float R = std::max(scene.boundingRadius(), 1e-6f);
  clamp_ = settings.clamp < 0 ? 1.0f / (kPi * kPi * sqr(0.1f * R)) : settings.clamp;

  // Random order, then batches whose sizes double up to a cap and then stay
  // constant: weights 2^min(b, B/2). The first picture comes quickly and no
  // single batch holds more than a modest share of the work.
  size_t N = set.lights.size();
  order_.resize(N);
  std::iota(order_.begin(), order_.end(), 0u);
  Rng rng(settings.seed, 99);
  for (size_t i = N; i > 1; --i) std::swap(order_[i - 1], order_[rng.uniformInt(uint32_t(i))]);
  int B = int(std::min<size_t>(size_t(settings.batches), std::max<size_t>(N, 1)));
  std::vector<double> cumulative(B + 1, 0.0);
  for (int b = 0; b < B; ++b) cumulative[b + 1] = cumulative[b] + std::ldexp(1.0, std::min(b, B / 2));
  const double total = cumulative[B];
  size_t prev = 0;
  for (int b = 0; b < B; ++b) {
    double share = cumulative[b + 1] / total;
    size_t end = b + 1 == B ? N : std::max(prev + 1, size_t(std::llround(N * share)));
    end = std::min(end, N);
    batchEnd_.push_back(end);
    int dEnd = std::max(b + 1, int(std::lround(settings.directSamples * share)));
    directEnd_.push_back(std::max(dEnd, directEnd_.empty() ? 1 : directEnd_.back() + 1));
    prev = end;
  }
  directFilm_ = Film(width_, height_);
  sharedFilm_ = Film(width_, height_);
  for (Film& f : gather_) f = Film(width_, height_);
}

// ---- [3] Eye paths -----------------------------------------------------------------

namespace {
struct GatherPoint {
  bool valid = false;
  Vec3 p, beta;
  VslReceiver rx;
  Vec3 shared;  // indirect light found on the way (see the header)
};
constexpr int kMaxSpecularChain = 8;
}  // namespace

// ---- [4] Gather -------------------------------------------------------------------

bool ManyLightRenderer::renderBatch(int b, const std::atomic<bool>* stop) {
  if (b != batchesDone_ || b >= batchCount()) return false;
  auto t0 = std::chrono::steady_clock::now();
  const size_t begin = b == 0 ? 0 : batchEnd_[b - 1], end = batchEnd_[b];
  const size_t nb = end - begin, N = set_.lights.size();
  const int dBegin = b == 0 ? 0 : directEnd_[b - 1], dEnd = directEnd_[b];

  // Decode this batch's lights once.
  std::vector<GatherLight> batch(nb);
  parallelFor((nb + 4095) / 4096, [&](size_t c) {
    for (size_t i = c * 4096; i < std::min(nb, (c + 1) * 4096); ++i) {
      const VirtualLight& v = set_.lights[order_[begin + i]];
      GatherLight& g = batch[i];
      g.p = v.p;
      g.Phi = v.Phi;
      g.n = decodeUnit(v.n);
      g.ng = decodeUnit(v.ng);
      g.em.brdf = v.brdf();
      g.em.frame = v.frame();
      g.em.wiLocal = g.em.frame.toLocal(decodeUnit(v.wi));
      g.radius = radii_[order_[begin + i]];
    }
  });

  const LightSampler& lights = direct_.lightSampler();
  const Camera& cam = scene_.camera;
  const uint64_t seed = settings_.seed;
  auto eyePath = [&](int x, int y, Rng& rng, uint64_t& rays) {
    GatherPoint gp;
    Ray ray = cam.generateRay(x + rng.uniform(), y + rng.uniform(), width_, height_);
    Vec3 beta(1.0f);
    for (int j = 0; j < kMaxSpecularChain; ++j) {
      ++rays;
      std::optional<Hit> hit = accel_.intersect(ray);
      if (!hit) return gp;
      SurfaceHit sh = scene_.surfaceHit(hit->triangle, hit->u, hit->v, ray.d);
      Vec3 wo = -ray.d;
      // Emission after two or more scattering events is indirect.
      if (j >= 2) gp.shared += beta * scene_.emitted(sh, wo);
      Brdf brdf = scene_.brdf(sh);
      Vec3 woL = sh.shading.toLocal(wo);
      if (woL.z <= 0) return gp;
      if (brdf.isNearSpecular() && j + 1 < kMaxSpecularChain) {
        auto bs = brdf.sample(woL, rng.uniform(), {rng.uniform(), rng.uniform()});
        if (!bs) return gp;
        Vec3 wi = sh.shading.toWorld(bs->wi);
        if (dot(wi, sh.ng) <= 0) return gp;
        beta *= bs->f * (bs->wi.z / bs->pdf);
        ray.o = offsetRayOrigin(sh.p, sh.ng, wi);
        ray.d = wi;
        continue;
      }
      // The gather point. Behind a specular chain, its own direct light is
      // indirect for the image (two or more scattering events).
      if (j >= 1) {
        if (auto ls = lights.sampleLi(sh.p, rng.uniform(), {rng.uniform(), rng.uniform()})) {
          Vec3 wiL = sh.shading.toLocal(ls->wi);
          if (wiL.z > 0 && dot(ls->wi, sh.ng) > 0) {
            Ray s;
            s.o = offsetRayOrigin(sh.p, sh.ng, ls->wi);
            Vec3 target = ls->delta ? ls->pLight : offsetRayOrigin(ls->pLight, ls->nLight, -ls->wi);
            Vec3 dd = target - s.o;
            float dist = length(dd);
            s.d = dd / dist;
            s.tMax = dist * (1 - 1e-4f);
            ++rays;
            if (!accel_.occluded(s)) gp.shared += beta * brdf.eval(woL, wiL) * ls->Li * (wiL.z / ls->pdf);
          }
        }
      }
      gp.valid = true;
      gp.p = sh.p;
      gp.beta = beta;
      gp.rx.brdf = brdf;
      gp.rx.frame = sh.shading;
      gp.rx.ng = sh.ng;
      gp.rx.woLocal = woL;
      return gp;
    }
    return gp;
  };

  // Per-batch buffers, merged into the films only if the batch completes.
  const size_t np = size_t(width_) * height_;
  std::vector<Vec3> direct(np), shared(np), layers[kLayers];
  for (auto& l : layers) l.assign(np, Vec3(0.0f));
  constexpr int kTile = 16;
  const int tilesX = (width_ + kTile - 1) / kTile, tilesY = (height_ + kTile - 1) / kTile;
  std::atomic<bool> stopped{false};
  const float clampBound = clamp_;
  const int vslSamples = settings_.vslSamples;
  const bool computeVsl = settings_.computeVsl, computeVpl = settings_.computeVpl;

  parallelFor(size_t(tilesX) * tilesY, [&](size_t tile) {
    if (stopped.load(std::memory_order_relaxed)) return;
    if (stop && stop->load(std::memory_order_relaxed)) {
      stopped.store(true);
      return;
    }
    const int x0 = int(tile % tilesX) * kTile, y0 = int(tile / tilesX) * kTile;
    const int x1 = std::min(x0 + kTile, width_), y1 = std::min(y0 + kTile, height_);
    uint64_t rays = 0, pairs = 0, shadow = 0, vslEvals = 0, nonFinite = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const size_t pix = size_t(y) * width_ + x;
        // Direct light: the reference's estimator, this batch's share of samples.
        Vec3 dsum(0.0f);
        for (int s = dBegin; s < dEnd; ++s) {
          Vec3 Ld, Lind;
          direct_.samplePixel(x, y, s, Ld, Lind, rays, nonFinite);
          dsum += Ld;
        }
        direct[pix] = dsum / float(dEnd - dBegin);

        Rng rng = Rng::forItem(pix, uint64_t(b), 2, seed);
        GatherPoint gp = eyePath(x, y, rng, rays);
        shared[pix] = gp.shared;
        if (!gp.valid) continue;
        double acc[kLayers][3] = {};
        for (size_t i = 0; i < nb; ++i) {
          const GatherLight& L = batch[i];
          ++pairs;
          Vec3 d = L.p - gp.p;
          float d2 = lengthSquared(d);
          float dist = std::sqrt(d2);
          Vec3 l = dist > 0 ? d / dist : gp.rx.frame.n;
          float cosX = dot(gp.rx.frame.n, l), cosXg = dot(gp.rx.ng, l);
          float cosP = -dot(L.n, l), cosPg = -dot(L.ng, l);
          // VPL transfer (full BRDF and diffuse-only emission).
          Vec3 Tfull(0.0f), Tdiff(0.0f);
          bool vpl = computeVpl && d2 > 0 && cosX > 0 && cosXg > 0 && cosP > 0 && cosPg > 0;
          if (vpl) {
            Vec3 fx = gp.rx.brdf.eval(gp.rx.woLocal, gp.rx.frame.toLocal(l));
            Vec3 lp = L.em.frame.toLocal(-l);
            float G = cosX * cosP / d2;
            Tfull = fx * L.em.brdf.eval(L.em.wiLocal, lp) * G;
            Tdiff = fx * L.em.brdf.evalDiffuse(L.em.wiLocal, lp) * G;
            vpl = !isBlack(Tfull) || !isBlack(Tdiff);
          }
          // Could any direction of the VSL cone see both hemispheres?
          float sinC = dist > L.radius ? L.radius / dist : 1.0f;
          bool vslPossible = computeVsl && cosX > -sinC && cosP > -sinC;
          if (!vpl && !vslPossible) continue;
          // One visibility ray feeds every estimate.
          Ray s;
          s.o = offsetRayOrigin(gp.p, gp.rx.ng, l);
          Vec3 target = offsetRayOrigin(L.p, L.ng, -l);
          Vec3 sd = target - s.o;
          float sl = length(sd);
          if (sl > 0) {
            s.d = sd / sl;
            s.tMax = sl * (1 - 1e-4f);
            ++shadow;
            if (accel_.occluded(s)) continue;
          }
          Vec3 w = gp.beta * L.Phi;
          auto add = [&](int layer, const Vec3& T) {
            Vec3 c = w * T;
            if (!isFinite(c)) {
              ++nonFinite;
              return;
            }
            for (int k = 0; k < 3; ++k) acc[layer][k] += c[k];
          };
          auto clamped = [&](const Vec3& T) {
            float lum = luminance(T);
            return lum > clampBound ? T * (clampBound / lum) : T;
          };
          if (vpl) {
            add(kVplFull, Tfull);
            add(kVplFullClamped, clamped(Tfull));
            add(kVplDiffuse, Tdiff);
            add(kVplDiffuseClamped, clamped(Tdiff));
          }
          if (vslPossible) {
            Rng prng = Rng::forItem(pix, order_[begin + i], 3, seed);
            VslResult r = vslTransfer(gp.rx, L.em, d, L.radius, vslSamples, prng);
            vslEvals += uint64_t(r.evaluations);
            add(kVsl, r.transfer);
          }
        }
        for (int k = 0; k < kLayers; ++k) layers[k][pix] = Vec3(float(acc[k][0]), float(acc[k][1]), float(acc[k][2]));
      }
    stats_.pairs.fetch_add(pairs, std::memory_order_relaxed);
    stats_.shadowRays.fetch_add(shadow + rays, std::memory_order_relaxed);
    stats_.vslEvaluations.fetch_add(vslEvals, std::memory_order_relaxed);
    stats_.nonFinite.fetch_add(nonFinite, std::memory_order_relaxed);
  });
  if (stopped.load()) return false;

  // Merge: each batch estimates the all-N image as (N / nb) x its sum, with
  // weight nb / N, so the films hold the running unbiased estimate.
  const float scale = nb ? float(double(N) / double(nb)) : 0.0f;
  const double weight = N ? double(nb) / double(N) : 0.0;
  const int dCount = dEnd - dBegin;
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      size_t pix = size_t(y) * width_ + x;
      directFilm_.add(x, y, direct[pix], double(dCount));
      sharedFilm_.add(x, y, shared[pix], 1.0);
      for (int k = 0; k < kLayers; ++k) gather_[k].add(x, y, layers[k][pix] * scale, weight);
    }
  processed_ = end;
  ++batchesDone_;
  stats_.gatherSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return true;
}

// ---- [5] Images -------------------------------------------------------------------

ManyLightImages ManyLightRenderer::images() const {
  ManyLightImages im;
  im.direct = directFilm_.image();
  Image shared = sharedFilm_.image();
  auto indirect = [&](int layer) {
    Image g = gather_[layer].image();
    for (size_t i = 0; i < g.rgb.size(); ++i) g.rgb[i] += shared.rgb[i];
    return g;
  };
  im.vsl = indirect(kVsl);
  Image full = indirect(kVplFull), fullC = indirect(kVplFullClamped);
  Image diff = indirect(kVplDiffuse), diffC = indirect(kVplDiffuseClamped);
  const Image& selU = settings_.diffuseOnly ? diff : full;
  const Image& selC = settings_.diffuseOnly ? diffC : fullC;
  im.vpl = selC;
  im.vplUnclamped = full;
  im.vplDiffuse = diff;
  im.lostToClamping = Image(width_, height_);
  im.lostToDiffuse = Image(width_, height_);
  for (size_t i = 0; i < selU.rgb.size(); ++i) {
    im.lostToClamping.rgb[i] = selU.rgb[i] - selC.rgb[i];
    im.lostToDiffuse.rgb[i] = full.rgb[i] - diff.rgb[i];
  }
  return im;
}

// ---- [6] prepareManyLights --------------------------------------------------------

ManyLightRun prepareManyLights(const Scene& scene, const Accel& accel, const LightSampler& lights,
                               const ManyLightSettings& settings, const std::atomic<bool>* stop) {
  ManyLightRun run;
  LightTracingSettings lt;
  lt.count = settings.lights;
  lt.seed = settings.seed;
  lt.maxDepth = settings.lightMaxDepth;
  run.set = traceVirtualLights(scene, accel, lights, lt, stop);
  auto t0 = std::chrono::steady_clock::now();
  float R = std::max(scene.boundingRadius(), 1e-6f);
  if (settings.globalRadius > 0) {
    run.radii.assign(run.set.lights.size(), settings.globalRadius * R);
  } else {
    run.radii = knnRadii(run.set.lights, settings.knn, settings.radiusScale, 0.1f * R, 1e-9f * R);
  }
  run.knnSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return run;
}

}  // namespace vsl
