#include "core/pathtracer.h"

#include "core/path.h"

#include "core/check.h"
#include "core/parallel.h"
#include "core/rng.h"

namespace vsl {

void resolveResolution(const Scene& scene, int& width, int& height) {
  const int d = RenderSettings::kDefaultResolution;
  float aspect = scene.camera.aspect > 0 ? scene.camera.aspect : 1.0f;
  if (width > 0 && height > 0) return;
  if (width > 0)
    height = std::max(1, int(std::lround(width / aspect)));
  else if (height > 0)
    width = std::max(1, int(std::lround(height * aspect)));
  else {
    width = d;
    height = std::max(1, int(std::lround(d / aspect)));
  }
}

PathTracer::PathTracer(const Scene& scene, const Accel& accel, const LightSampler& lights,
                       const RenderSettings& settings)
    : scene_(scene), accel_(accel), lights_(lights), settings_(settings) {
  width_ = settings.width;
  height_ = settings.height;
  resolveResolution(scene, width_, height_);
}

namespace {
inline Vec2 u2(Rng& r) { return {r.uniform(), r.uniform()}; }
}  // namespace

void PathTracer::samplePixel(int x, int y, int s, Vec3& Ld, Vec3& Lind, uint64_t& rays, uint64_t& nonFinite) const {
  Rng rng = Rng::forItem(uint64_t(y) * width_ + x, uint64_t(s), 0, settings_.seed);
  Ld = Vec3(0.0f);
  Lind = Vec3(0.0f);
  auto deposit = [&](int bounces, const Vec3& c) {
    if (!isFinite(c)) {
      ++nonFinite;
      return;
    }
    (bounces <= 1 ? Ld : Lind) += c;
  };

  Ray ray = scene_.camera.generateRay(x + rng.uniform(), y + rng.uniform(), width_, height_);
  Vec3 beta(1.0f);
  float prevPdf = 0;  // solid-angle pdf of the BRDF sample that produced `ray`
  Vec3 prevP;
  const int maxDepth = settings_.maxDepth;
  for (int depth = 0;; ++depth) {
    // `depth` scattering events happened before this vertex.
    ++rays;
    std::optional<Hit> hit = accel_.intersect(ray);
    if (!hit) {
      // The ray leaves the scene: the environment, weighted against its
      // next-event sampling as emission is (power heuristic).
      if (const Environment* env = lights_.environment()) {
        float w = depth > 0 ? powerHeuristic(prevPdf, lights_.pdfEnvironment(ray.d)) : 1.0f;
        deposit(depth, beta * env->radiance(ray.d) * w);
      }
      break;
    }
    SurfaceHit sh = scene_.surfaceHit(hit->triangle, hit->u, hit->v, ray.d);
    Vec3 wo = -ray.d;

    // Emission reached by the camera ray or by BRDF sampling.
    Vec3 Le = scene_.emitted(sh, wo);
    if (!isBlack(Le)) {
      float w = 1.0f;
      if (depth > 0) w = powerHeuristic(prevPdf, lights_.pdfLi(prevP, sh.triangle, sh.p));
      deposit(depth, beta * Le * w);
    }
    if (depth >= maxDepth) break;

    Brdf brdf = scene_.brdf(sh);
    const Frame& frame = sh.shading;
    Vec3 woL = frame.toLocal(wo);
    if (woL.z <= 0) break;  // viewer below the shading hemisphere

    // Next-event estimation.
    if (auto ls = lights_.sampleLi(sh.p, rng.uniform(), u2(rng))) {
      Vec3 wiL = frame.toLocal(ls->wi);
      if (dot(ls->wi, sh.ng) > 0 && wiL.z > 0) {
        Vec3 f = brdf.eval(woL, wiL);
        if (!isBlack(f)) {
          Ray shadow;
          ++rays;
          if (segmentRay(sh.p, sh.ng, ls->pLight, ls->nLight, shadow) && !accel_.occluded(shadow)) {
            float w = ls->delta ? 1.0f : powerHeuristic(ls->pdf, brdf.pdf(woL, wiL));
            deposit(depth + 1, beta * f * ls->Li * (wiL.z * w / ls->pdf));
          }
        }
      }
    }

    // Continue the path by sampling the BRDF.
    std::optional<BrdfSample> bs = continuePath(BrdfAt(brdf, woL), sh, rng.uniform(), u2(rng), beta, ray);
    if (!bs) break;
    if (!isFinite(beta)) {
      ++nonFinite;
      break;
    }
    prevPdf = bs->pdf;
    prevP = sh.p;
    if (depth + 1 >= settings_.rrDepth) {
      float q = std::min(0.95f, maxComponent(beta));
      if (rng.uniform() >= q) break;
      beta /= q;
    }
  }
}

bool PathTracer::renderPass(int pass, Film& direct, Film& indirect, PtCounters& counters, const std::atomic<bool>* stop,
                            std::vector<double>* indirectSquares) const {
  VSL_CHECK_EQ(direct.width(), width_);
  VSL_CHECK_EQ(direct.height(), height_);
  VSL_CHECK_EQ(indirect.width(), width_);
  VSL_CHECK_EQ(indirect.height(), height_);
  if (indirectSquares) VSL_CHECK_EQ(indirectSquares->size(), size_t(width_) * height_);
  return parallelForTiles(width_, height_, stop, [&](int x0, int y0, int x1, int y1) {
    uint64_t rays = 0, nonFinite = 0, paths = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        Vec3 Ld, Li;
        samplePixel(x, y, pass, Ld, Li, rays, nonFinite);
        direct.add(x, y, Ld);
        indirect.add(x, y, Li);
        if (indirectSquares) (*indirectSquares)[size_t(y) * width_ + x] += sqr((double(Li.x) + Li.y + Li.z) / 3);
        ++paths;
      }
    counters.rays.fetch_add(rays, std::memory_order_relaxed);
    counters.nonFinite.fetch_add(nonFinite, std::memory_order_relaxed);
    counters.paths.fetch_add(paths, std::memory_order_relaxed);
  });
}

}  // namespace vsl
