// Sections: [1] settings  [2] set-up and batches  [3] one batch  [4] gather
//           [5] images  [6] prepareManyLights
#include "core/many_light.h"

#include <algorithm>
#include <chrono>
#include <mutex>
#include <numeric>
#include <sstream>

#include "core/check.h"
#include "core/gather.h"
#include "core/lobe_gather.h"
#include "core/parallel.h"
#include "core/params.h"
#include "core/rng.h"
#include "core/stopwatch.h"

namespace vsl {

// ---- [1] Settings -----------------------------------------------------------------

// The parameters' ranges are their declarations' (core/params.cpp).
Result<void> ManyLightSettings::validate() const {
  std::ostringstream e;
  if (width < 0 || width > RenderSettings::kMaxResolution)
    e << "width: out of range (got " << width << ")";
  else if (height < 0 || height > RenderSettings::kMaxResolution)
    e << "height: out of range (got " << height << ")";
  if (std::string m = e.str(); !m.empty()) return Error(m);
  return manyLightParams().check(*this);
}

std::string ManyLightSettings::describe(bool withGrid) const {
  std::ostringstream s;
  if (withGrid) s << "--lights " << lights << " ";
  s << "--seed " << seed;
  // A size of 0 means "the scene's"; the CLI refuses --width 0, so it is left out.
  if (width > 0) s << " --width " << width;
  if (height > 0) s << " --height " << height;
  // A sweep's grid sets the light count and the radius scale per configuration.
  std::vector<std::string> skip = {"lights"};
  if (!withGrid) skip.push_back("radius-scale");
  s << manyLightParams().describe(*this, skip);
  return s.str();
}

// ---- [2] Set-up and batches ------------------------------------------------------

float progressiveRadiusFactor(int pass, float alpha) {
  double f2 = 1;
  for (int k = 1; k <= pass; ++k) f2 *= (k + double(alpha)) / (k + 1.0);
  return float(std::sqrt(f2));
}

float manyLightClampBound(const Scene& scene, const ManyLightSettings& settings) {
  float R = std::max(scene.boundingRadius(), 1e-6f);
  return settings.clamp < 0 ? 1.0f / (kPi * kPi * sqr(0.1f * R)) : settings.clamp;
}

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

std::vector<double> batchWeights(size_t lights, int batches) {
  const int B = int(std::min<size_t>(size_t(std::max(batches, 1)), std::max<size_t>(lights, 1)));
  // Weights 2^min(b, c): c doublings, then B - c equal batches. c is B/2
  // unless the first batch would then hold less than one light's share.
  auto total = [&](int c) { return std::ldexp(1.0, c) - 1 + double(B - c) * std::ldexp(1.0, c); };
  int c = B / 2;
  while (c > 0 && double(lights) < total(c)) --c;
  std::vector<double> w(static_cast<size_t>(B));
  for (int b = 0; b < B; ++b) w[size_t(b)] = std::ldexp(1.0, std::min(b, c));
  return w;
}

ManyLightRenderer::ManyLightRenderer(const Scene& scene, const Accel& accel, const LightSampler& lights,
                                     const VirtualLightSet& set, const std::vector<float>& radii,
                                     const ManyLightSettings& settings, const std::atomic<bool>* stop,
                                     LobeGatherCache* lobeMaps)
    : scene_(scene),
      accel_(accel),
      set_(set),
      radii_(radii),
      settings_(settings),
      direct_(scene, accel, lights, directSettings(settings)),
      directFilm_(direct_.width(), direct_.height()),
      sharedFilm_(direct_.width(), direct_.height()) {
  VSL_CHECK_EQ(radii.size(), set.lights.size());
  width_ = direct_.width();
  height_ = direct_.height();
  clamp_ = manyLightClampBound(scene, settings);

  // Random order, then the batches of batchWeights().
  size_t N = set.lights.size();
  order_.resize(N);
  std::iota(order_.begin(), order_.end(), 0u);
  Rng rng(settings.seed, 99);
  for (size_t i = N; i > 1; --i) std::swap(order_[i - 1], order_[rng.uniformInt(uint32_t(i))]);
  const std::vector<double> weights = batchWeights(N, settings.batches);
  const int B = int(weights.size());
  const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
  double cumulative = 0;
  size_t prev = 0;
  for (int b = 0; b < B; ++b) {
    cumulative += weights[size_t(b)];
    double share = cumulative / total;
    size_t end = b + 1 == B ? N : std::max(prev + 1, size_t(std::llround(N * share)));
    end = std::min(end, N);
    batchEnd_.push_back(end);
    // Samples of a total spread like the lights, at least one per batch.
    auto addEnd = [&](std::vector<int>& ends, int samples) {
      const int e = std::max(b + 1, int(std::lround(samples * share)));
      ends.push_back(std::max(e, ends.empty() ? 1 : ends.back() + 1));
    };
    addEnd(directEnd_, settings.directSamples);
    addEnd(sharedEnd_, Gatherer::kSharedEyePaths);
    prev = end;
  }
  if (settings.lobeGather > 0 && settings.computeVsl) {
    // Its cost is VSL's own gather time.
    Stopwatch clock;
    lobeMap_ = lobeMaps ? lobeMaps->get(scene, accel, direct_.lightSampler(), settings, stop, stats_.nonFinite)
                        : buildLobeGatherMap(scene, accel, direct_.lightSampler(), settings, stop, stats_.nonFinite);
    if (lobeMap_) lobeFilm_.emplace(width_, height_);
    stats_.gatherSeconds += clock.seconds();
    stats_.vslSeconds += clock.seconds();
  }
  // The films are built in place (a Film copies where it could move).
  gather_.reserve(kGatherLayers);
  for (int k = 0; k < kGatherLayers; ++k) gather_.emplace_back(width_, height_);
}

// ---- [3] One batch: its lights, per-batch buffers, tiles --------------------------

// Everything one batch's tiles share. Its per-pixel results go to the
// renderer's batch buffers, which are merged into the films only if the
// batch completes.
struct ManyLightRenderer::Batch {
  int b = 0;
  size_t begin = 0, end = 0;  // this batch's range of order_
  int dBegin = 0, dEnd = 0;   // this batch's range of direct samples
  std::vector<GatherLight> lights;
  Vec3 *direct = nullptr, *shared = nullptr, *lobe = nullptr, *layers[kGatherLayers] = {};
  std::atomic<bool> abandoned{false};
  std::mutex timeMutex;
  double threadTime = 0, vplTime = 0, vslTime = 0;  // summed over threads
  double lightTime = 0, lobeTime = 0;               // threadTime's loops over the lights, and the lobe gather's
  float rouletteThreshold = 0;                      // the pair roulette's (0: not played)
  uint64_t roulettePairs = 0;                       // offered to it, summed over threads
};

bool ManyLightRenderer::renderBatch(int b, const std::atomic<bool>* stop) {
  if (b != batchesDone_ || b >= batchCount()) return false;
  Stopwatch wallClock;
  Batch batch;
  batch.b = b;
  batch.begin = b == 0 ? 0 : batchEnd_[b - 1];
  batch.end = batchEnd_[b];
  batch.dBegin = b == 0 ? 0 : directEnd_[b - 1];
  batch.dEnd = directEnd_[b];
  const size_t nb = batch.end - batch.begin;
  if (settings_.pairRoulette > 0 && roulettePairs_ > 0) {
    const double t = settings_.pairRoulette * rouletteLuminance_ / double(roulettePairs_);
    batch.rouletteThreshold = std::isfinite(t) && t < double(std::numeric_limits<float>::max()) ? float(t) : 0.0f;
  }

  // Decode this batch's lights once.
  batch.lights.resize(nb);
  parallelForChunks(nb, 4096, [&](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i)
      batch.lights[i] = decodeGatherLight(set_.lights[order_[batch.begin + i]], radii_[order_[batch.begin + i]]);
  });
  Gatherer gatherer(scene_, accel_, direct_.lightSampler(), settings_, clamp_, settings_.computeVsl,
                    settings_.computeVpl, lobeMap_.get());
  // Every tile writes every one of its pixels, so the buffers need no clearing.
  const size_t np = size_t(width_) * height_;
  batchDirect_.resize(np);
  batchShared_.resize(np);
  batch.direct = batchDirect_.data();
  batch.shared = batchShared_.data();
  if (lobeMap_) {
    batchLobe_.resize(np);
    batch.lobe = batchLobe_.data();
  }
  for (int k = 0; k < kGatherLayers; ++k) {
    batchLayers_[k].resize(np);
    batch.layers[k] = batchLayers_[k].data();
  }
  const bool complete = parallelForTiles(width_, height_, stop, [&](int x0, int y0, int x1, int y1) {
    gatherTile(batch, gatherer, stop, x0, y0, x1, y1);
  });
  if (batch.abandoned || !complete) return false;
  mergeBatch(batch, wallClock.seconds());
  return true;
}

ManyLightRenderer::~ManyLightRenderer() = default;

// ---- [4] Gather ---------------------------------------------------------------------

// One tile's pixels in gatherTile: their eye samples and gather points, what
// they gather (per pixel, kGatherLayers sums) and the tile's counts.
struct ManyLightRenderer::Tile {
  struct Sums {
    double v[kGatherLayers][3] = {};
  };
  Tile(int left, int top, int right, int bottom, int imageWidth)
      : x0(left),
        y0(top),
        tw(right - left),
        n(tw * (bottom - top)),
        width(imageWidth),
        gps(size_t(n)),
        acc(size_t(n)) {}
  size_t pixelOf(int i) const { return size_t(y0 + i / tw) * width + (x0 + i % tw); }

  // The gather points by index (first, split-off: ManyLightSettings::
  // splitAlpha), whether any pixel has one, their BRDFs packed once for the
  // VPL transfers in blocks and for the closed-form VSL (its receivers:
  // packVslReceivers), and with the pair roulette, its seeds: each
  // point's quadrature stream.
  void prepareReceivers(const Gatherer& gatherer, bool roulette) {
    for (int k = 0; k < kMaxGatherPoints; ++k) {
      pts[k].assign(size_t(n), nullptr);
      for (int i = 0; i < n; ++i) {
        pts[k][size_t(i)] = gps[size_t(i)].point(k);
        any[k] = any[k] || pts[k][size_t(i)];
      }
    }
    for (int k = 0; k < kMaxGatherPoints; ++k)
      if (any[k]) {
        gatherer.packReceivers(pts[k], packedRx[k]);
        gatherer.packVslReceivers(pts[k], packedVslRx[k]);
      }
    for (int k = 0; k < kMaxGatherPoints; ++k)
      if (any[k] && roulette)
        for (int i = 0; i < n; ++i) streams[k].push_back(gatherStream(pixelOf(i), k));
  }

  const int x0, y0, tw, n, width;
  std::vector<EyeSample> gps;
  std::vector<Sums> acc;
  GatherCounters c;
  std::vector<const GatherPoint*> pts[kMaxGatherPoints];
  bool any[kMaxGatherPoints] = {};
  std::vector<float> packedRx[kMaxGatherPoints], packedVslRx[kMaxGatherPoints];
  std::vector<uint64_t> streams[kMaxGatherPoints];
  // VPL's and VSL's own transfer times, and the loop over the lights' time.
  double vplOwn = 0, vslOwn = 0, lightSeconds = 0;
};

// The pixels of a tile against one light at a time: the tile's gather
// points stay in cache, each light is read once per tile, and the tile's
// shadow rays toward one light go to Embree as one coherent batch.
void ManyLightRenderer::gatherTile(Batch& batch, const Gatherer& gatherer, const std::atomic<bool>* stop, int x0,
                                   int y0, int x1, int y1) {
  Stopwatch tileClock;
  Tile tile(x0, y0, x1, y1, width_);
  traceTileEyePaths(batch, gatherer, tile);
  tile.prepareReceivers(gatherer, settings_.pairRoulette > 0);
  if (!gatherTileLights(batch, gatherer, stop, tile)) return;
  writeTile(batch, tile);
  countTile(batch, tile, tileClock.seconds());
}

// Per pixel: direct light (the reference's estimator, this batch's share of
// samples), the eye path to its gather points, and the light behind specular
// chains (the batch's share of the eye paths).
void ManyLightRenderer::traceTileEyePaths(Batch& batch, const Gatherer& gatherer, Tile& tile) const {
  const int eyes = sharedEyes(batch.b);
  Gatherer::EyePathOptions options = Gatherer::eyePathOptions(eyes);
  options.lobeRays = lobeRays(batch.b);
  for (int i = 0; i < tile.n; ++i) {
    const int x = tile.x0 + i % tile.tw, y = tile.y0 + i / tile.tw;
    const size_t pix = tile.pixelOf(i);
    batch.direct[pix] = directLight(direct_, x, y, batch.dBegin, batch.dEnd, tile.c);
    Rng rng = Rng::forItem(pix, uint64_t(batch.b), 2, settings_.seed);
    tile.gps[size_t(i)] = gatherer.eyePath(x, y, width_, height_, rng, tile.c, options);
    batch.shared[pix] =
        gatherer.sharedLight(tile.gps[size_t(i)], eyes, x, y, width_, height_, uint64_t(batch.b), tile.c);
  }
}

// Each light against the tile's gather points in three timed parts: the
// shared connection (orientation, the batch of shadow rays), then VPL's
// and VSL's own transfers, so that each method is charged its own time
// (three clock reads per light and tile). A pixel adds what it gathers in
// the order it always has, block of kOrderBlock lights by block: its first
// gather point's lights, then its split-off point's (ManyLightSettings::
// splitAlpha), so the sums are those of a pixel-by-pixel loop.
bool ManyLightRenderer::gatherTileLights(Batch& batch, const Gatherer& gatherer, const std::atomic<bool>* stop,
                                         Tile& tile) const {
  constexpr size_t kOrderBlock = 256;
  const size_t nb = batch.lights.size(), tilePoints = size_t(tile.n);
  Gatherer::VplBrdfs vplBrdfs;
  Gatherer::VslBlock vslBlock;
  std::vector<PairGeometry> geo(tilePoints);
  std::vector<uint8_t> visible(tilePoints);
  std::vector<uint32_t> list(tilePoints);
  Gatherer::ConnectScratch scratch;
  GatherCounters& c = tile.c;
  size_t checked = 0;
  // The loop over the lights is the part of the tile's time that grows with
  // them (BatchCostModel); the rest (eye paths, direct light, set-up and
  // writing out) is per pixel.
  Stopwatch lightClock;
  for (size_t l0 = 0; l0 < nb; l0 += kOrderBlock)
    for (int k = 0; k < kMaxGatherPoints; ++k) {
      if (!tile.any[k]) continue;
      for (size_t l = l0; l < std::min(nb, l0 + kOrderBlock); ++l) {
        // A restart waits for at most 16 lights against the tile.
        if (checked++ % 16 == 0 && stop && stop->load(std::memory_order_relaxed)) {
          batch.abandoned = true;
          return false;
        }
        const GatherLight& L = batch.lights[l];
        const PairRoulette roulette{batch.rouletteThreshold, order_[batch.begin + l], tile.streams[k].data()};
        gatherer.connectMany(tile.pts[k], L, geo.data(), visible.data(), scratch, c, {},
                             settings_.pairRoulette > 0 ? &roulette : nullptr);
        size_t nv = 0;
        for (size_t i = 0; i < tilePoints; ++i)
          if (visible[i]) list[nv++] = uint32_t(i);
        // No point sees the light: no transfer to time (a clock read costs
        // ~30 ns).
        if (nv == 0) continue;
        Stopwatch own;
        if (settings_.computeVpl) {
          gatherer.vplBrdfs(tile.pts[k], tile.packedRx[k].data(), list.data(), nv, L, geo.data(), vplBrdfs);
          for (size_t v = 0; v < nv; ++v)
            gatherer.addVpl(*tile.pts[k][list[v]], L, geo[list[v]], vplBrdfs.fx(v), vplBrdfs.fp(v), tile.acc[list[v]].v,
                            c);
          tile.vplOwn += own.lap();
        }
        if (settings_.computeVsl) {
          const float* packedVslRx = tile.packedVslRx[k].empty() ? nullptr : tile.packedVslRx[k].data();
          gatherer.vslPrepare(tile.pts[k], packedVslRx, list.data(), nv, L, geo.data(), vslBlock);
          for (size_t v = 0; v < nv; ++v) {
            const size_t i = list[v];
            gatherer.addVslPrepared(vslBlock, v, *tile.pts[k][i], L, geo[i], order_[batch.begin + l],
                                    gatherStream(tile.pixelOf(int(i)), k), tile.acc[i].v, c);
          }
          tile.vslOwn += own.seconds();
        }
      }
    }
  tile.lightSeconds = lightClock.seconds();
  return true;
}

// The lobe gather's estimates (per eye sample, not per light) go to their
// own film, each batch's weighted by its directions (lobeRays); the gathered
// layers to theirs.
void ManyLightRenderer::writeTile(Batch& batch, const Tile& tile) const {
  if (batch.lobe)
    for (int i = 0; i < tile.n; ++i) {
      Vec3 sum(0.0f);
      for (int k = 0; k < kMaxGatherPoints; ++k)
        if (const GatherPoint* gp = tile.gps[size_t(i)].point(k); gp && gp->lobe) sum += gp->vslLobe;
      batch.lobe[tile.pixelOf(i)] = sum;
    }
  for (int i = 0; i < tile.n; ++i) {
    const auto& a = tile.acc[size_t(i)].v;
    for (int k = 0; k < kGatherLayers; ++k)
      batch.layers[k][tile.pixelOf(i)] = Vec3(float(a[k][0]), float(a[k][1]), float(a[k][2]));
  }
}

// The tile's times (VSL's own including the lobe gather's, in the eye paths)
// into the batch's sums, and its counts into the stats.
void ManyLightRenderer::countTile(Batch& batch, const Tile& tile, double tileSeconds) {
  const GatherCounters& c = tile.c;
  {
    std::lock_guard<std::mutex> lock(batch.timeMutex);
    batch.threadTime += tileSeconds;
    batch.vplTime += tile.vplOwn;
    batch.vslTime += tile.vslOwn + c.vslOwnSeconds;
    batch.lightTime += tile.lightSeconds;
    batch.lobeTime += c.vslOwnSeconds;
    batch.roulettePairs += c.rouletteOffered;
  }
  stats_.rouletteDropped.fetch_add(c.rouletteDropped, std::memory_order_relaxed);
  stats_.pairs.fetch_add(c.pairs, std::memory_order_relaxed);
  stats_.shadowRays.fetch_add(c.shadowRays + c.rays, std::memory_order_relaxed);
  stats_.vslEvaluations.fetch_add(c.vslEvaluations, std::memory_order_relaxed);
  stats_.nonFinite.fetch_add(c.nonFinite, std::memory_order_relaxed);
}

int ManyLightRenderer::sharedEyes(int b) const {
  return Gatherer::sharedEyePaths(sharedEnd_[size_t(b)] - (b > 0 ? sharedEnd_[size_t(b) - 1] : 0));
}

int ManyLightRenderer::lobeRays(int b) const {
  const int rays = std::clamp(settings_.lobeGatherRays, 1, ManyLightSettings::kMaxLobeGatherRays);
  const int64_t B = batchCount();
  if (B <= 1) return rays;
  const int64_t kMax = ManyLightSettings::kMaxLobeGatherRays;
  const int64_t first = std::max<int64_t>({1, rays / kFirstBatchLobeRaysDivisor, int64_t(rays) * B - kMax * (B - 1)});
  if (b == 0) return int(first);
  // The others share what the first left, so that a render's directions
  // are still lobeGatherRays per batch.
  const int64_t rest = int64_t(rays) * B - first;
  const int64_t share = rest * b / (B - 1) - rest * (b - 1) / (B - 1);
  return int(std::min(share, kMax));
}

// Merge: each batch estimates the all-N image as (N / nb) x its sum, with
// weight nb / N, so the films hold the running unbiased estimate.

void ManyLightRenderer::mergeBatch(const Batch& batch, double wall) {
  const size_t nb = batch.end - batch.begin, N = set_.lights.size();
  const float scale = nb ? float(double(N) / double(nb)) : 0.0f;
  const double weight = N ? double(nb) / double(N) : 0.0;
  const int dCount = batch.dEnd - batch.dBegin;
  // Each batch's shared light is the mean of its eye paths.
  const int eyes = sharedEyes(batch.b);
  const int rays = lobeRays(batch.b);
  // Rows in parallel: Film::add is safe for different pixels, and each
  // pixel's sums see the same additions in the same order as serially.
  parallelForChunks(size_t(height_), 16, [&](size_t y0, size_t y1) {
    for (int y = int(y0); y < int(y1); ++y)
      for (int x = 0; x < width_; ++x) {
        size_t pix = size_t(y) * width_ + x;
        directFilm_.add(x, y, batch.direct[pix], double(dCount));
        sharedFilm_.add(x, y, batch.shared[pix], double(eyes));
        if (batch.lobe) lobeFilm_->add(x, y, batch.lobe[pix], double(rays));
        for (int k = 0; k < kGatherLayers; ++k) gather_[k].add(x, y, batch.layers[k][pix] * scale, weight);
      }
  });
  processed_ = batch.end;
  ++batchesDone_;
  roulettePairs_ += batch.roulettePairs;
  if (settings_.pairRoulette > 0) {
    // What the batch gathered (its weights applied): VSL's and unclamped
    // VPL's luminance, summed row by row in order, so that the next
    // threshold does not depend on which thread finished first.
    std::vector<double> rows(size_t(height_), 0.0);
    parallelForChunks(size_t(height_), 16, [&](size_t y0, size_t y1) {
      for (size_t y = y0; y < y1; ++y)
        for (int x = 0; x < width_; ++x) {
          const size_t pix = y * size_t(width_) + size_t(x);
          for (int k : {int(kVslLayer), int(kVplFull)})
            if (const Vec3 v = batch.layers[k][pix]; isFinite(v)) rows[y] += double(std::max(0.0f, luminance(v)));
        }
    });
    for (double r : rows) rouletteLuminance_ += r;
  }
  // Each method's own time: the batch's wall time less the share of thread
  // time spent in the other method's own transfer (what it would have taken
  // alone; the shared eye paths, direct light and shadow rays go to both).
  stats_.gatherSeconds += wall;
  if (batch.threadTime > 0) {
    stats_.vslSeconds += wall * std::max(0.0, 1.0 - batch.vplTime / batch.threadTime);
    stats_.vplSeconds += wall * std::max(0.0, 1.0 - batch.vslTime / batch.threadTime);
    // The batch's wall time split in the proportions of its thread time:
    // the lights' loops, the lobe gather's directions, and the rest (per
    // pixel; with the batch's serial set-up).
    const double lights = wall * std::min(batch.lightTime / batch.threadTime, 1.0);
    const double lobe = wall * std::min(batch.lobeTime / batch.threadTime, 1.0);
    costs_.add({std::max(wall - lights - lobe, 0.0), lobe, lights}, batchUnits(batch.b));
  }
}

BatchCostModel::Units ManyLightRenderer::batchUnits(int b) const {
  BatchCostModel::Units u;
  u.pixel = double(directEnd_[size_t(b)] - (b > 0 ? directEnd_[size_t(b) - 1] : 0)) + double(sharedEyes(b));
  u.lobe = lobeFilm_ ? double(lobeRays(b)) : 0.0;
  u.lights = double(batchLights(b));
  return u;
}

std::optional<double> ManyLightRenderer::remainingSeconds() const {
  if (batchesDone_ >= batchCount()) return 0.0;
  if (!costs_.measured()) return std::nullopt;
  double s = 0;
  for (int b = batchesDone_; b < batchCount(); ++b) s += costs_.predict(batchUnits(b));
  return s;
}

std::optional<double> ManyLightRenderer::nextBatchSeconds() const {
  if (batchesDone_ >= batchCount() || !costs_.measured()) return std::nullopt;
  return costs_.predict(batchUnits(batchesDone_));
}

void BatchCostModel::add(const Units& seconds, const Units& units) {
  seconds_ += seconds;
  units_ += units;
  ++batches_;
}

double BatchCostModel::predict(const Units& u) const {
  auto part = [](double s, double done, double want) { return done > 0 ? s / done * want : 0.0; };
  return part(seconds_.pixel, units_.pixel, u.pixel) + part(seconds_.lobe, units_.lobe, u.lobe) +
         part(seconds_.lights, units_.lights, u.lights);
}

// ---- [5] Images -------------------------------------------------------------------

// The films are read in parallel, one per item: the studio's first picture
// of a restart waits for this.
ManyLightImages ManyLightRenderer::images() const {
  ManyLightImages im;
  Image shared, layer[kGatherLayers];
  parallelFor(kGatherLayers + 2, [&](size_t k) {
    if (k == kGatherLayers)
      im.direct = directFilm_.image();
    else if (k == kGatherLayers + 1)
      shared = sharedFilm_.image();
    else
      layer[k] = gather_[k].image();
  });
  // Indirect = the gathered layer plus the light found on the eye paths.
  parallelFor(kGatherLayers, [&](size_t k) {
    for (size_t i = 0; i < layer[k].rgb.size(); ++i) layer[k].rgb[i] += shared.rgb[i];
  });
  if (lobeFilm_) {
    const Image lobe = lobeFilm_->image();
    for (size_t i = 0; i < lobe.rgb.size(); ++i) layer[kVslLayer].rgb[i] += lobe.rgb[i];
  }
  return imagesFromLayers(layer, std::move(im.direct), settings_.diffuseOnly);
}

ManyLightImages imagesFromLayers(Image (&layer)[kGatherLayers], Image direct, bool diffuseOnly) {
  ManyLightImages im;
  im.direct = std::move(direct);
  const int u = diffuseOnly ? kVplDiffuse : kVplFull;
  const int c = diffuseOnly ? kVplDiffuseClamped : kVplFullClamped;
  const int w = layer[kVslLayer].width, h = layer[kVslLayer].height;
  im.lostToClamping = Image(w, h);
  im.lostToDiffuse = Image(w, h);
  for (size_t i = 0; i < layer[kVslLayer].rgb.size(); ++i) {
    im.lostToClamping.rgb[i] = layer[u].rgb[i] - layer[c].rgb[i];
    im.lostToDiffuse.rgb[i] = layer[kVplFull].rgb[i] - layer[kVplDiffuse].rgb[i];
  }
  im.vsl = std::move(layer[kVslLayer]);
  im.vpl = std::move(layer[c]);
  im.vplUnclamped = std::move(layer[kVplFull]);
  im.vplDiffuse = std::move(layer[kVplDiffuse]);
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
  Stopwatch knnClock;
  float R = std::max(scene.boundingRadius(), 1e-6f);
  if (settings.globalRadius > 0) {
    run.radii.assign(run.set.lights.size(), settings.globalRadius * R);
  } else {
    run.radii = knnRadii(run.set.lights, settings.knn, settings.radiusScale, 0.1f * R, 1e-9f * R, stop);
  }
  run.knnSeconds = knnClock.seconds();
  return run;
}

}  // namespace vsl
