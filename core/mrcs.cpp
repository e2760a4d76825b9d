#include "core/mrcs.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <numeric>
#include <queue>
#include <utility>

#include "core/check.h"
#include "core/gather.h"
#include "core/lobe_gather.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "core/stopwatch.h"

namespace vsl {

Result<void> MrcsSettings::validate() const {
  if (rows < 1 || rows > 100000) return Error("mrcs rows: must be in [1,100000] (got " + std::to_string(rows) + ")");
  if (clusters < 1 || clusters > 1000000)
    return Error("mrcs clusters: must be in [1,1000000] (got " + std::to_string(clusters) + ")");
  if (!(uniformMix >= 0 && uniformMix <= 1))
    return Error("mrcs uniform mix: must be in [0,1] (got " + std::to_string(uniformMix) + ")");
  return {};
}

int MrcsSettings::rowsFor(uint64_t pixels) const {
  return int(std::clamp<uint64_t>(uint64_t(std::max(rows, 1)), 1, std::max<uint64_t>(pixels, 1)));
}

int MrcsSettings::clustersFor(uint64_t lights) const {
  return int(std::clamp<uint64_t>(uint64_t(std::max(clusters, 1)), 1, std::max<uint64_t>(lights, 1)));
}

// ---- Clustering ----------------------------------------------------------------------

namespace {

constexpr int kDims = 32;  // random projection of the reduced columns

struct Cluster {
  std::vector<uint32_t> members;  // indices into the nonzero-column list
  double cost = 0;
};

// Gaussian from two uniforms (Box-Muller).
float gaussian(Rng& r) {
  float u1 = std::max(r.uniform(), 1e-7f), u2 = r.uniform();
  return std::sqrt(-2.0f * std::log(u1)) * std::cos(2 * kPi * u2);
}

}  // namespace

namespace {

// The nonzero columns as points for clustering: norms n_i and unit
// directions u_i of their random projections to kDims.
struct ColumnSpace {
  std::vector<double> norm;  // per light
  std::vector<uint32_t> nz;  // lights whose column is nonzero
  std::vector<float> u;      // per nonzero column, kDims each

  double n(size_t i) const { return norm[nz[i]]; }
  const float* dir(size_t i) const { return &u[i * kDims]; }
  // Cluster cost (sum n)^2 - |sum n u|^2 >= 0.
  double cost(const std::vector<uint32_t>& m) const {
    double sn = 0, v[kDims] = {};
    for (uint32_t i : m) {
      sn += n(i);
      for (int d = 0; d < kDims; ++d) v[d] += n(i) * dir(i)[d];
    }
    double s2 = 0;
    for (double x : v) s2 += x * x;
    return std::max(sn * sn - s2, 0.0);
  }
};

// Norms of every column; the nonzero ones (zero columns cannot be
// represented: they are dark at every row).
void columnNorms(const std::vector<float>& columns, size_t lights, int rows, ColumnSpace& cs) {
  cs.norm.assign(lights, 0.0);
  for (size_t j = 0; j < lights; ++j) {
    double s = 0;
    for (int r = 0; r < rows; ++r) s += double(columns[j * rows + r]) * columns[j * rows + r];
    cs.norm[j] = std::sqrt(s);
    if (cs.norm[j] > 0 && std::isfinite(cs.norm[j])) cs.nz.push_back(uint32_t(j));
  }
}

// Random projection to kDims, then unit directions u_i (n_i keeps the norm).
void projectColumns(const std::vector<float>& columns, int rows, Rng& rng, ColumnSpace& cs) {
  const size_t n = cs.nz.size();
  std::vector<float> M(size_t(rows) * kDims);
  for (float& m : M) m = gaussian(rng);
  cs.u.assign(n * kDims, 0.0f);
  parallelForChunks(n, 1024, [&](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i) {
      const float* col = &columns[size_t(cs.nz[i]) * rows];
      float* ui = &cs.u[i * kDims];
      // All kDims sums at once, each over r in order (independent sums
      // vectorise; the order within each keeps the result bit for bit).
      double s[kDims] = {};
      for (int r = 0; r < rows; ++r) {
        const double c = col[r];
        const float* Mr = &M[size_t(r) * kDims];
        for (int d = 0; d < kDims; ++d) s[d] += c * Mr[d];
      }
      double len = 0;
      for (int d = 0; d < kDims; ++d) {
        ui[d] = float(s[d]);
        len += s[d] * s[d];
      }
      float inv = len > 0 ? float(1.0 / std::sqrt(len)) : 0.0f;
      for (int d = 0; d < kDims; ++d) ui[d] *= inv;
    }
  });
}

// 1. Sampling: about two thirds of the clusters from seeds drawn in
//    proportion to each column's summed distance to all others (as in the
//    MRCS paper), every column joining its closest seed.
std::vector<Cluster> seedClusters(const ColumnSpace& cs, int clusters, Rng& rng) {
  const size_t n = cs.nz.size();
  // alpha_i = sum_j d(i, j) = n_i (sum_j n_j - u_i . sum_j n_j u_j).
  double sumN = 0, sumV[kDims] = {};
  for (size_t i = 0; i < n; ++i) {
    sumN += cs.n(i);
    for (int d = 0; d < kDims; ++d) sumV[d] += cs.n(i) * cs.dir(i)[d];
  }
  std::vector<double> w(n);
  for (size_t i = 0; i < n; ++i) {
    double uv = 0;
    for (int d = 0; d < kDims; ++d) uv += cs.dir(i)[d] * sumV[d];
    w[i] = cs.n(i) * std::max(sumN - uv, 0.0);
  }
  DiscreteDistribution bySummedDistance(w);
  std::vector<uint32_t> seeds;
  std::vector<char> isSeed(n, 0);
  int want = std::max(1, (2 * clusters) / 3);
  for (int k = 0; k < 4 * want && int(seeds.size()) < want; ++k) {
    uint32_t s = uint32_t(bySummedDistance.sample(rng.uniform(), nullptr));
    if (!isSeed[s]) {
      isSeed[s] = 1;
      seeds.push_back(s);
    }
  }
  // The seeds' directions by dimension (seedDir[d * Sp + k], zero past the
  // last seed) and norms, so that a column's cosines to a block of seeds are
  // summed side by side in fixed-size blocks (which the compiler vectorises).
  constexpr size_t kBlock = 16;
  const size_t S = seeds.size(), Sp = (S + kBlock - 1) / kBlock * kBlock;
  std::vector<float> seedDir(kDims * Sp, 0.0f);
  std::vector<double> seedN(S);
  for (size_t k = 0; k < S; ++k) {
    seedN[k] = cs.n(seeds[k]);
    for (int d = 0; d < kDims; ++d) seedDir[d * Sp + k] = cs.dir(seeds[k])[d];
  }
  std::vector<uint32_t> assign(n);
  parallelForChunks(n, 512, [&](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i) {
      const float* ui = cs.dir(i);
      double best = 1e300;
      uint32_t bk = 0;
      for (size_t k0 = 0; k0 < S; k0 += kBlock) {
        // Each cosine is a float sum over d in order.
        float cosine[kBlock] = {};
        for (int d = 0; d < kDims; ++d) {
          const float* sd = &seedDir[d * Sp + k0];
          for (size_t q = 0; q < kBlock; ++q) cosine[q] += ui[d] * sd[q];
        }
        for (size_t q = 0; q < std::min(kBlock, S - k0); ++q) {
          // d(i, s) = n_i n_s (1 - cos); n_i is common to every seed.
          const double dist = seedN[k0 + q] * (1.0 - cosine[q]);
          if (dist < best) {
            best = dist;
            bk = uint32_t(k0 + q);
          }
        }
      }
      assign[i] = bk;
    }
  });
  std::vector<Cluster> cl(seeds.size());
  for (size_t i = 0; i < n; ++i) cl[assign[i]].members.push_back(uint32_t(i));
  return cl;
}

// Splits cluster c along a random projection at the cut that minimises the
// two halves' total cost; returns the right half (c keeps the left).
Cluster splitCluster(const ColumnSpace& cs, Cluster& c, Rng& rng) {
  float dir[kDims];
  for (float& x : dir) x = gaussian(rng);
  std::vector<std::pair<float, uint32_t>> t;
  for (uint32_t i : c.members) {
    float s = 0;
    for (int d = 0; d < kDims; ++d) s += cs.dir(i)[d] * dir[d];
    t.push_back({s, i});
  }
  std::sort(t.begin(), t.end());
  // Prefix sums give every cut's cost in O(size x dims).
  size_t m = t.size();
  std::vector<double> pn(m + 1, 0.0), pv((m + 1) * kDims, 0.0);
  for (size_t q = 0; q < m; ++q) {
    double nq = cs.n(t[q].second);
    pn[q + 1] = pn[q] + nq;
    for (int d = 0; d < kDims; ++d) pv[(q + 1) * kDims + d] = pv[q * kDims + d] + nq * cs.dir(t[q].second)[d];
  }
  double best = 1e300;
  size_t cut = m / 2;
  for (size_t q = 1; q < m; ++q) {
    double l2 = 0, r2 = 0;
    for (int d = 0; d < kDims; ++d) {
      double lv = pv[q * kDims + d], rv = pv[m * kDims + d] - lv;
      l2 += lv * lv;
      r2 += rv * rv;
    }
    double ln = pn[q], rn = pn[m] - pn[q];
    double cost = std::max(ln * ln - l2, 0.0) + std::max(rn * rn - r2, 0.0);
    if (cost < best) {
      best = cost;
      cut = q;
    }
  }
  Cluster right;
  for (size_t q = cut; q < m; ++q) right.members.push_back(t[q].second);
  c.members.clear();
  for (size_t q = 0; q < cut; ++q) c.members.push_back(t[q].second);
  c.cost = cs.cost(c.members);
  right.cost = cs.cost(right.members);
  return right;
}

// 2. Splitting: split the costliest cluster until there are enough.
void splitCostliest(const ColumnSpace& cs, int clusters, Rng& rng, std::vector<Cluster>& cl) {
  auto cmp = [&](size_t a, size_t b) { return cl[a].cost < cl[b].cost; };
  std::priority_queue<size_t, std::vector<size_t>, decltype(cmp)> queue(cmp);
  for (size_t k = 0; k < cl.size(); ++k) {
    cl[k].cost = cs.cost(cl[k].members);
    queue.push(k);
  }
  size_t live = 0;
  for (const Cluster& c : cl) live += !c.members.empty();
  while (live < size_t(clusters) && !queue.empty()) {
    size_t k = queue.top();
    queue.pop();
    if (cl[k].members.size() < 2 || cl[k].cost <= 0) continue;
    Cluster right = splitCluster(cs, cl[k], rng);
    cl.push_back(std::move(right));
    queue.push(k);
    queue.push(cl.size() - 1);
    ++live;
  }
}

// 3. One representative per cluster, chosen with probability
//    p_i = (1 - mix) n_i / sum n + mix / |cluster| and weighted by 1 / p_i
//    (mix = 0: the cluster's norm sum over its own norm).
std::vector<Representative> pickRepresentatives(const ColumnSpace& cs, const std::vector<Cluster>& cl,
                                                double uniformMix, Rng& rng) {
  std::vector<Representative> reps;
  for (const Cluster& c : cl) {
    if (c.members.empty()) continue;
    double total = 0;
    for (uint32_t i : c.members) total += cs.n(i);
    const double m = double(c.members.size());
    uint32_t pick = c.members.back();
    if (rng.uniformDouble() < uniformMix) {
      pick = c.members[std::min(size_t(rng.uniformDouble() * m), c.members.size() - 1)];
    } else {
      double x = rng.uniformDouble() * total;
      for (uint32_t i : c.members) {
        x -= cs.n(i);
        if (x < 0) {
          pick = i;
          break;
        }
      }
    }
    const double p = (1 - uniformMix) * cs.n(pick) / total + uniformMix / m;
    reps.push_back({cs.nz[pick], 1.0 / p});
  }
  return reps;
}

}  // namespace

std::vector<Representative> clusterColumns(const std::vector<float>& columns, size_t lights, int rows, int clusters,
                                           uint64_t seed, size_t* zeroColumns, double uniformMix) {
  Rng rng(seed, 0x5eed);
  ColumnSpace cs;
  columnNorms(columns, lights, rows, cs);
  if (zeroColumns) *zeroColumns = lights - cs.nz.size();
  std::vector<Representative> reps;
  if (cs.nz.empty()) return reps;
  if (cs.nz.size() <= size_t(clusters)) {
    for (uint32_t j : cs.nz) reps.push_back({j, 1.0});
    return reps;
  }
  projectColumns(columns, rows, rng, cs);
  std::vector<Cluster> cl = seedClusters(cs, clusters, rng);
  splitCostliest(cs, clusters, rng, cl);
  return pickRepresentatives(cs, cl, uniformMix, rng);
}

std::string MrcsProgress::text() const {
  static const char* const kNames[] = {"", "eye paths", "rows", "clustering", "columns", ""};
  const int st = stage.load();
  if (st <= kIdle || st >= kDone) return "";
  const uint64_t n = total.load(), d = std::min(done.load(), n);
  char t[48];  // snprintf, not string concatenation: GCC 12 -O3 warns falsely (-Wrestrict) on the latter
  if (n > 0)
    std::snprintf(t, sizeof t, "MRCS %s %d%%", kNames[st], int(100 * d / n));
  else
    std::snprintf(t, sizeof t, "MRCS %s", kNames[st]);
  return t;
}

void MrcsProgress::plan(const Work& work) {
  std::lock_guard<std::mutex> lock(mutex_);
  work_ = work;
}

void MrcsProgress::begin(Stage s, uint64_t units) {
  std::lock_guard<std::mutex> lock(mutex_);
  done.store(0);
  total.store(units);
  stage.store(s);
}

double MrcsProgress::overall() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const int st = stage.load();
  if (st >= kDone) return 1.0;
  const double P = double(work_.pixels), N = double(work_.lights);
  const double eye = P * (1 + work_.directSamples) / 4, rows = work_.rows * N,
               columns = work_.methods * work_.clusters * P, all = eye + rows + columns;
  if (st <= kIdle || !(all > 0)) return 0.0;
  const uint64_t n = total.load();
  const double share = n ? std::min(1.0, double(done.load()) / double(n)) : 0.0;
  double f = 0;
  if (st == kEyePaths) f = eye * share;
  if (st == kRows) f = eye + rows * share;
  if (st == kClustering) f = eye + rows;
  if (st == kColumns) f = eye + rows + columns * share;
  return f / all;
}

namespace {

// What the MRCS stages share: the image, the light set decoded for
// gathering, one gather point set per pixel, and the three gatherers (both
// estimators for the eye paths, each alone for its own rows and columns).
struct MrcsJob {
  int W = 0, H = 0;
  size_t N = 0;
  int vplLayer = kVplFullClamped;
  bool doVsl = true, doVpl = true;
  const std::atomic<bool>* stop = nullptr;
  // settings.lobeGather > 0 with VSL: used by `both`'s eye paths only, and
  // released after them (their gather points hold its estimates).
  std::unique_ptr<LobeGatherMap> lobeMap;
  bool lobe = false;  // the eye paths gathered with lobeMap
  std::unique_ptr<Gatherer> both, vslOnly, vplOnly;
  std::vector<EyeSample> gps;  // per pixel
  // Per pixel: the shared light of Gatherer::sharedEyePaths eye paths (the
  // first is gps'), which every estimate adds.
  std::vector<Vec3> shared;
  std::vector<GatherLight> gl;
  std::atomic<uint64_t> pairs{0}, nonFinite{0};
  // The eye paths' thread time and their lobe gathers' share of it.
  double eyeThreadSeconds = 0, eyeLobeSeconds = 0;
  std::mutex eyeTimeMutex;
  MrcsProgress* progress = nullptr;
  bool stopped() const { return stop && stop->load(std::memory_order_relaxed); }
  void begin(MrcsProgress::Stage st, uint64_t units) const {
    if (progress) progress->begin(st, units);
  }
  void advance(uint64_t units) const {
    if (progress) progress->advance(units);
  }
};

// Gather points (one eye sample per pixel), their shared light (from more
// eye paths, Gatherer::sharedEyePaths) and direct light, in the eye paths'
// progress stage (begun by the caller).
void eyePathsAndDirect(const Scene& scene, const Accel& accel, const LightSampler& lights,
                       const ManyLightSettings& settings, MrcsJob& job, Image& directOut) {
  RenderSettings rs;
  rs.width = job.W;
  rs.height = job.H;
  rs.seed = settings.seed;
  rs.maxDepth = 1;
  PathTracer direct(scene, accel, lights, rs);
  job.gps.resize(size_t(job.W) * job.H);
  job.shared.resize(job.gps.size());
  directOut = Image(job.W, job.H);
  const int eyes = Gatherer::sharedEyePaths(Gatherer::kSharedEyePaths);
  parallelFor(size_t(job.H), [&](size_t y) {
    // With the lobe gather the eye paths are most of a pass: a restart must
    // not wait for all of them.
    if (job.stopped()) return;
    Stopwatch rowClock;
    GatherCounters c;
    for (int x = 0; x < job.W; ++x) {
      size_t pix = y * job.W + x;
      Rng rng = Rng::forItem(pix, 0, 2, settings.seed);
      job.gps[pix] = job.both->eyePath(x, int(y), job.W, job.H, rng, c, Gatherer::eyePathOptions(eyes));
      job.shared[pix] = job.both->sharedLight(job.gps[pix], eyes, x, int(y), job.W, job.H, 0, c);
      directOut.set(x, int(y), directLight(direct, x, int(y), 0, settings.directSamples, c));
    }
    job.nonFinite.fetch_add(c.nonFinite, std::memory_order_relaxed);
    {
      std::lock_guard<std::mutex> lock(job.eyeTimeMutex);
      job.eyeThreadSeconds += rowClock.seconds();
      job.eyeLobeSeconds += c.vslOwnSeconds;
    }
    job.advance(1);
  });
}

// 1. Rows: one random pixel per block (a valid gather point where possible),
//    every light's reduced column (luminance at the rows) per estimator.
std::vector<size_t> pickRows(const MrcsJob& job, int rows, Rng& rng) {
  const int W = job.W, H = job.H;
  int bx = std::max(1, int(std::lround(std::sqrt(double(rows) * W / H)))), by = (rows + bx - 1) / bx;
  std::vector<size_t> rowPix;
  for (int j = 0; j < by; ++j)
    for (int i = 0; i < bx && int(rowPix.size()) < rows; ++i) {
      int x0 = i * W / bx, x1 = std::max(x0 + 1, (i + 1) * W / bx), y0 = j * H / by,
          y1 = std::max(y0 + 1, (j + 1) * H / by);
      size_t pick = size_t(y0) * W + x0;
      for (int tries = 0; tries < 8; ++tries) {
        size_t p = size_t(y0 + int(rng.uniformInt(uint32_t(y1 - y0)))) * W +
                   size_t(x0 + int(rng.uniformInt(uint32_t(x1 - x0))));
        pick = p;
        if (job.gps[p].anyValid()) break;
      }
      rowPix.push_back(pick);
    }
  return rowPix;
}

// One method's reduced columns (`gatherer`'s `layer`) into col. Each light
// meets all the rows' gather points at once, its shadow rays traced as one
// batch (they share the light's end). With `reuse` false the rays are traced
// and, if `visibility` is given, their outcomes kept in it (a bit per light
// and row point); with `reuse` true the kept outcomes stand in for the rays,
// so that a second method's rows cost no ray and count no pair again.
void reducedColumns(MrcsJob& job, const Gatherer& gatherer, int layer, const std::vector<size_t>& rowPix,
                    std::vector<float>& col, std::vector<uint8_t>* visibility, bool reuse) {
  const int R = int(rowPix.size());
  col.assign(job.N * size_t(R), 0.0f);
  std::vector<const GatherPoint*> pts(size_t(R) * kMaxGatherPoints, nullptr);
  for (int r = 0; r < R; ++r)
    for (int k = 0; k < kMaxGatherPoints; ++k)
      pts[size_t(r) * kMaxGatherPoints + size_t(k)] = job.gps[rowPix[r]].point(k);
  const size_t bytesPerLight = (pts.size() + 7) / 8;
  std::vector<float> packed;  // the row points' BRDFs, for the VPL transfers in blocks
  gatherer.packReceivers(pts, packed);
  if (visibility && !reuse) visibility->assign(job.N * bytesPerLight, 0);
  parallelForChunks(job.N, 256, [&](size_t j0, size_t j1) {
    GatherCounters cnt;
    std::vector<PairGeometry> geo(pts.size());
    std::vector<uint8_t> visible(pts.size()), known(reuse ? pts.size() : 0);
    std::vector<double> acc(size_t(R) * kGatherLayers * 3);
    std::vector<uint32_t> list(pts.size());
    Gatherer::ConnectScratch scratch;
    Gatherer::VplBrdfs blocks;
    for (size_t j = j0; j < j1; ++j) {
      if (job.stopped()) return;
      uint8_t* bits = visibility ? &(*visibility)[j * bytesPerLight] : nullptr;
      if (reuse)
        for (size_t i = 0; i < pts.size(); ++i) known[i] = (bits[i / 8] >> (i % 8)) & 1;
      gatherer.connectMany(pts, job.gl[j], geo.data(), visible.data(), scratch, cnt, known);
      if (bits && !reuse)
        for (size_t i = 0; i < pts.size(); ++i) bits[i / 8] |= uint8_t(visible[i] << (i % 8));
      std::fill(acc.begin(), acc.end(), 0.0);
      auto accOf = [&](int r) { return reinterpret_cast<double(*)[3]>(&acc[size_t(r) * kGatherLayers * 3]); };
      size_t nv = 0;
      for (size_t i = 0; i < pts.size(); ++i)
        if (visible[i]) list[nv++] = uint32_t(i);
      gatherer.addConnectedMany(
          pts, packed.data(), list.data(), nv, job.gl[j], geo.data(), j,
          [&](uint32_t i) { return gatherStream(rowPix[i / kMaxGatherPoints], int(i % kMaxGatherPoints)); },
          [&](uint32_t i, const double(&pair)[kGatherLayers][3]) {
            double(*a)[3] = accOf(int(i / kMaxGatherPoints));
            for (int l = 0; l < kGatherLayers; ++l)
              for (int ch = 0; ch < 3; ++ch) a[l][ch] += pair[l][ch];
          },
          blocks, cnt);
      for (int r = 0; r < R; ++r) {
        const double* a = accOf(r)[layer];
        col[j * R + r] = float(0.2126 * a[0] + 0.7152 * a[1] + 0.0722 * a[2]);
      }
    }
    if (!reuse) {
      job.advance(j1 - j0);
      job.pairs.fetch_add(cnt.pairs);
    }
  });
}

// 4. Full columns for one method's representatives (its layer, gathered by
//    `gatherer`; repGl[q] is representative q's light): every pixel's
//    estimate is its shared light plus the weighted representatives'
//    contributions. Without representatives (a method not rendered) the
//    image is the shared light alone, and its rows do not count as progress.
void representativeColumns(MrcsJob& job, const Gatherer& gatherer, int layer, const std::vector<Representative>& reps,
                           const std::vector<GatherLight>& repGl, Image& out) {
  // VSL's image adds the lobe gather's estimates, which no column holds.
  const bool withLobe = layer == kVslLayer && job.lobe;
  out = Image(job.W, job.H);
  const bool counted = !reps.empty();
  // A row of pixels against one representative at a time, so that its
  // shadow rays go to Embree as one coherent batch; each pixel still adds the
  // representatives in order, so the sums are those of a pixel-by-pixel loop.
  parallelFor(size_t(job.H), [&](size_t y) {
    if (job.stopped()) return;
    GatherCounters cnt;
    const size_t n = size_t(job.W) * kMaxGatherPoints;
    std::vector<const GatherPoint*> pts(n, nullptr);
    std::vector<double> sums(3 * n, 0.0);
    std::vector<PairGeometry> geo(n);
    std::vector<uint8_t> visible(n);
    std::vector<uint32_t> list(n);
    Gatherer::ConnectScratch scratch;
    Gatherer::VplBrdfs blocks;
    const size_t row = y * size_t(job.W);
    for (int x = 0; x < job.W; ++x)
      for (int g = 0; g < kMaxGatherPoints; ++g)
        pts[size_t(x) * kMaxGatherPoints + size_t(g)] = job.gps[row + size_t(x)].point(g);
    std::vector<float> packed;
    if (!reps.empty()) gatherer.packReceivers(pts, packed);
    for (size_t q = 0; q < reps.size(); ++q) {
      if (job.stopped()) return;
      const Representative& r = reps[q];
      gatherer.connectMany(pts, repGl[q], geo.data(), visible.data(), scratch, cnt);
      size_t nv = 0;
      for (size_t i = 0; i < n; ++i)
        if (visible[i]) list[nv++] = uint32_t(i);
      gatherer.addConnectedMany(
          pts, packed.data(), list.data(), nv, repGl[q], geo.data(), r.light,
          [&](uint32_t i) { return gatherStream(row + i / kMaxGatherPoints, int(i % kMaxGatherPoints)); },
          [&](uint32_t i, const double(&acc)[kGatherLayers][3]) {
            for (int k = 0; k < 3; ++k) sums[3 * size_t(i) + size_t(k)] += r.weight * acc[layer][k];
          },
          blocks, cnt);
    }
    for (int x = 0; x < job.W; ++x) {
      const EyeSample& es = job.gps[row + size_t(x)];
      Vec3 L = job.shared[row + size_t(x)];
      for (int g = 0; g < es.count; ++g) {
        const GatherPoint* gp = es.point(g);
        if (!gp) continue;
        if (withLobe && gp->lobe) L += gp->vslLobe;
        const double* s = &sums[3 * (size_t(x) * kMaxGatherPoints + size_t(g))];
        L += Vec3(float(s[0]), float(s[1]), float(s[2]));
      }
      if (!isFinite(L)) {
        ++cnt.nonFinite;
        L = Vec3(0.0f);
      }
      out.set(x, int(y), L);
    }
    if (counted) job.advance(1);
    job.pairs.fetch_add(cnt.pairs);
    job.nonFinite.fetch_add(cnt.nonFinite, std::memory_order_relaxed);
  });
}

// The job's image size, light count, methods and layer, and the rows and
// clusters the render uses (in res, and planned in the progress).
void setUpJob(const Scene& scene, const VirtualLightSet& set, const std::vector<float>& radii,
              const ManyLightSettings& settings, const MrcsSettings& mrcs, const std::atomic<bool>* stop,
              MrcsProgress* progress, MrcsJob& job, MrcsResult& res) {
  job.progress = progress;
  job.W = settings.width;
  job.H = settings.height;
  resolveResolution(scene, job.W, job.H);
  job.N = set.lights.size();
  VSL_CHECK_EQ(radii.size(), job.N);
  job.stop = stop;
  job.vplLayer = settings.diffuseOnly ? kVplDiffuseClamped : kVplFullClamped;
  job.doVsl = settings.computeVsl;
  job.doVpl = settings.computeVpl;
  res.rowsUsed = mrcs.rowsFor(uint64_t(job.W) * uint64_t(job.H));
  res.clustersUsed = mrcs.clustersFor(job.N);
  if (progress)
    progress->plan({.pixels = uint64_t(job.W) * uint64_t(job.H),
                    .lights = job.N,
                    .rows = res.rowsUsed,
                    .clusters = res.clustersUsed,
                    .methods = int(job.doVsl) + int(job.doVpl),
                    .directSamples = settings.directSamples});
}

// The eye paths' stage: the lobe gather's light set (VSL's own cost), before
// the eye paths that use it (its tracing shows as the stage at 0%); the
// gatherers; the gather points and direct light; then the lights decoded for
// the rows and columns. Its times go into res; false if stopped.
bool eyePathStage(const Scene& scene, const Accel& accel, const LightSampler& lights, const VirtualLightSet& set,
                  const std::vector<float>& radii, const ManyLightSettings& settings, float clampBound, MrcsJob& job,
                  MrcsResult& res, Stopwatch& clock) {
  job.begin(MrcsProgress::kEyePaths, uint64_t(job.H));
  job.lobeMap = buildLobeGatherMap(scene, accel, lights, settings, job.stop, job.nonFinite);
  job.lobe = job.lobeMap != nullptr;
  const double lobeMapSeconds = job.lobe ? clock.lap() : 0.0;
  if (job.stopped()) return false;
  job.both =
      std::make_unique<Gatherer>(scene, accel, lights, settings, clampBound, job.doVsl, job.doVpl, job.lobeMap.get());
  job.vslOnly = std::make_unique<Gatherer>(scene, accel, lights, settings, clampBound, true, false);
  job.vplOnly = std::make_unique<Gatherer>(scene, accel, lights, settings, clampBound, false, true);

  eyePathsAndDirect(scene, accel, lights, settings, job, res.images.direct);
  if (job.stopped()) return false;
  // The rows and columns use no lobe gather (a lobe point's estimate is in its
  // gather point): the set's memory goes back now.
  job.both.reset();
  job.lobeMap.reset();
  job.gl.resize(job.N);
  parallelForChunks(job.N, 4096, [&](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i) job.gl[i] = decodeGatherLight(set.lights[i], radii[i]);
  });
  res.eyeSeconds = clock.lap();
  res.lobeSeconds =
      lobeMapSeconds +
      (job.eyeThreadSeconds > 0 ? res.eyeSeconds * std::min(1.0, job.eyeLobeSeconds / job.eyeThreadSeconds) : 0.0);
  res.eyeSeconds += lobeMapSeconds;
  return true;
}

// The representatives' lights; with `spread`, a representative of weight w
// gets radius r sqrt(w) (MrcsSettings::spreadVslRadius).
std::vector<GatherLight> representativeLights(const MrcsJob& job, const std::vector<Representative>& reps,
                                              bool spread) {
  std::vector<GatherLight> repGl;
  for (const Representative& r : reps) {
    repGl.push_back(job.gl[r.light]);
    if (spread) repGl.back().radius *= float(std::sqrt(std::max(r.weight, 1.0)));
  }
  return repGl;
}

// The complete VSL image (and direct light) to progress.onVslImage, with the
// other layers black.
void handOutVslImage(const MrcsJob& job, const ManyLightImages& images, MrcsProgress& progress) {
  ManyLightImages vslImages;
  vslImages.direct = images.direct;
  vslImages.vsl = images.vsl;
  for (Image* img : {&vslImages.vpl, &vslImages.vplUnclamped, &vslImages.vplDiffuse, &vslImages.lostToClamping,
                     &vslImages.lostToDiffuse})
    *img = Image(job.W, job.H);
  progress.onVslImage(vslImages);
}

}  // namespace

MrcsResult renderMrcs(const Scene& scene, const Accel& accel, const LightSampler& lights, const VirtualLightSet& set,
                      const std::vector<float>& radii, const ManyLightSettings& settings, const MrcsSettings& mrcs,
                      const std::atomic<bool>* stop, MrcsProgress* progress) {
  MrcsResult res;
  MrcsJob job;
  setUpJob(scene, set, radii, settings, mrcs, stop, progress, job, res);
  const float clampBound = manyLightClampBound(scene, settings);
  // A stopped render is discarded: no image, the progress idle.
  auto stoppedResult = [&] {
    res.stopped = true;
    job.begin(MrcsProgress::kIdle, 0);
    return std::move(res);
  };
  Stopwatch clock;
  if (!eyePathStage(scene, accel, lights, set, radii, settings, clampBound, job, res, clock)) return stoppedResult();

  // 1. Rows.
  Rng rng(hashCombine(settings.seed, mrcs.seed), 0x7077);
  const std::vector<size_t> rowPix = pickRows(job, res.rowsUsed, rng);
  const int R = int(rowPix.size());
  // VSL's rows first, keeping their rays' outcomes for VPL's rows, which
  // wait until the VSL image is out (with VPL alone, its rows trace them).
  std::vector<float> colVsl, colVpl;
  std::vector<uint8_t> rowVisibility;
  job.begin(MrcsProgress::kRows, job.N);
  if (job.doVsl)
    reducedColumns(job, *job.vslOnly, kVslLayer, rowPix, colVsl, job.doVpl ? &rowVisibility : nullptr, false);
  else if (job.doVpl)
    reducedColumns(job, *job.vplOnly, job.vplLayer, rowPix, colVpl, nullptr, false);
  res.rowSeconds = clock.lap();
  if (job.stopped()) return stoppedResult();

  // 2-3. Clustering and representatives: VSL's now, VPL's after VSL's
  // columns, so that the VSL image is complete as early as it can be (each
  // clustering has its own seed: the order changes nothing).
  job.begin(MrcsProgress::kClustering, 0);
  const uint64_t cseed = hashCombine(settings.seed, mrcs.seed);
  std::vector<Representative> repVsl, repVpl;
  if (job.doVsl)
    repVsl = clusterColumns(colVsl, job.N, R, res.clustersUsed, cseed, &res.zeroColumnsVsl, mrcs.uniformMix);
  colVsl = {};
  res.clusterSeconds = clock.lap();

  // 4. Full columns for the representatives: VSL's, then (the VSL image
  // handed out) VPL's clustering and columns.
  job.begin(MrcsProgress::kColumns, uint64_t(job.H) * uint64_t(int(job.doVsl) + int(job.doVpl)));
  representativeColumns(job, *job.vslOnly, kVslLayer, repVsl, representativeLights(job, repVsl, mrcs.spreadVslRadius),
                        res.images.vsl);
  res.vslColumnSeconds = res.columnSeconds = clock.lap();
  if (job.doVsl && job.doVpl && !job.stopped() && progress && progress->onVslImage) {
    handOutVslImage(job, res.images, *progress);
    clock.lap();  // the caller's time, not MRCS's
  }
  if (job.doVsl && job.doVpl && !job.stopped()) {
    reducedColumns(job, *job.vplOnly, job.vplLayer, rowPix, colVpl, &rowVisibility, true);
    rowVisibility = {};
    res.rowSeconds += clock.lap();
  }
  if (job.doVpl && !job.stopped()) {
    repVpl = clusterColumns(colVpl, job.N, R, res.clustersUsed, cseed + 1, &res.zeroColumnsVpl, mrcs.uniformMix);
    res.clusterSeconds += clock.lap();
  }
  colVpl = {};
  if (!job.stopped())
    representativeColumns(job, *job.vplOnly, job.vplLayer, repVpl, representativeLights(job, repVpl, false),
                          res.images.vpl);
  res.columnSeconds += clock.lap();
  res.stopped = job.stopped();
  job.begin(MrcsProgress::kDone, 0);
  res.pairs = job.pairs.load();
  res.nonFinite = job.nonFinite.load();
  for (Image* img :
       {&res.images.vplUnclamped, &res.images.vplDiffuse, &res.images.lostToClamping, &res.images.lostToDiffuse})
    *img = Image(job.W, job.H);
  return res;
}

}  // namespace vsl
