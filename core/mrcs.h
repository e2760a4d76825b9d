// Matrix Row-Column Sampling (Hasan, Pellacini, Bala, "Matrix Row-Column
// Sampling for the Many-Light Problem", SIGGRAPH 2007) for the VSL and VPL
// gathers.
//
// The image is the sum of the columns of a pixels x lights matrix. MRCS
//   1. computes R rows fully: one random pixel in each of R image blocks,
//      against every light (the reduced columns rho_j, one value per row);
//   2. clusters the reduced columns into C clusters: about two thirds seeded by
//      sampling columns in proportion to their summed distance to all the
//      others, sum_j d(i,j) = n_i (sum_j n_j - u_i . sum_j n_j u_j), and assigning every column
//      to the closest seed under d(i,j) = |rho_i||rho_j| - rho_i.rho_j, the rest
//      by splitting the costliest cluster (cost = (sum |rho|)^2 - |sum rho|^2)
//      along a random projection;
//   3. picks one representative per cluster with probability proportional to
//      its column norm (optionally mixed with a uniform choice), weighted by
//      one over that probability;
//   4. renders full columns for the representatives only.
// Cost: R x N + C x P pairs instead of P x N. Bias: lights whose reduced
// column is zero (dark at every sampled row) are dropped; otherwise, for a
// fixed clustering, the estimate is unbiased over the representative choice.
// Clustering distances use a 32-dimensional random projection of the reduced
// columns (Johnson-Lindenstrauss) to keep the cost at O(N C 32).
// VSL and VPL (the clamped, chosen-emission variant) are clustered separately,
// from the same rows: VSL's rows, clustering and columns come first, so that
// its image is complete (MrcsProgress::onVslImage) before VPL's are begun;
// VPL's rows then reuse the visibility VSL's rows traced. Shadow rays go to
// Embree in coherent batches (Gatherer::connectMany): a light against all
// the rows' points, a representative against an image row.
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <string>

#include "core/many_light.h"

namespace vsl {

struct MrcsSettings {
  int rows = 300;
  int clusters = 900;
  uint64_t seed = 0;  // row and cluster choices (the light set has its own seed)
  // Defensive share of the representative choice: a member is picked with
  // probability (1 - mix) n_i / sum n + mix / |cluster|. 0 is the paper's
  // norm-proportional choice; a positive share bounds the weight of a light
  // whose sampled rows miss the region it lights (see clusterColumns).
  double uniformMix = kDefaultUniformMix;
  static constexpr double kDefaultUniformMix = 0.0;
  // Optional: a VSL representative that stands for weight w gets radius
  // r sqrt(w), so its w-fold flux spreads over a w-fold area, as one light at
  // the representatives' density would (k-NN radii on surfaces scale with
  // density^-1/2). Without it, a light whose sampled rows miss the small patch
  // it lights brightly multiplies that patch ~N/C-fold (blobs). Measured on
  // kitchen, 512x512, 100k lights, 900 clusters: relMSE against the reference
  // 0.16 -> 0.044, but the mean drops by 11% (large VSL spheres lose energy,
  // the darkening the VSL paper reports for large radii). Off by default: the
  // paper's estimator, unbiased against brute force for a fixed clustering.
  bool spreadVslRadius = false;
  Result<void> validate() const;  // the first invalid setting
  // The rows and clusters a render uses: these capped at the image's pixels
  // (more rows would repeat pixels) and at the lights (more clusters would
  // stay empty; a cluster per light is brute force), at least one each.
  int rowsFor(uint64_t pixels) const;
  int clustersFor(uint64_t lights) const;
};

struct MrcsResult {
  ManyLightImages images;  // direct, vsl, vpl; the other layers stay black
  // Wall time of the stages (rows, clustering and columns: both methods';
  // the time spent in MrcsProgress::onVslImage is in none of them).
  double eyeSeconds = 0, rowSeconds = 0, clusterSeconds = 0, columnSeconds = 0;
  double vslColumnSeconds = 0;  // VSL's share of columnSeconds
  // VSL's own share of eyeSeconds with the lobe gather
  // (ManyLightSettings::lobeGather): tracing and indexing its light set, and
  // the gather points' lobe gathers (their share of the eye paths' thread time).
  double lobeSeconds = 0;
  uint64_t pairs = 0;
  uint64_t nonFinite = 0;                         // lights and contributions rejected as NaN or Inf
  size_t zeroColumnsVsl = 0, zeroColumnsVpl = 0;  // lights dropped (dark at every row)
  int rowsUsed = 0, clustersUsed = 0;             // MrcsSettings::rowsFor and clustersFor
  bool stopped = false;
};

// Where a render is, so that a long one shows progress while it runs:
// written by the render's threads, read from any thread. The stage's work is
// counted in its own units (image rows for the eye paths and the columns,
// lights for the rows); clustering has no count. overall() weighs the stages
// by the work plan() recorded when the render began.
// With both methods, the rows stage computes VSL's rows only, and the
// columns stage renders VSL's columns first, then computes VPL's rows (from
// the visibility VSL's rows kept: no rays, no progress counted), clusters
// them and renders VPL's columns: the VSL image is complete halfway through
// it, and is handed to onVslImage before VPL's work begins.
struct MrcsProgress {
  enum Stage : int { kIdle, kEyePaths, kRows, kClustering, kColumns, kDone };
  // A render's size, from which its stages' weights follow.
  struct Work {
    uint64_t pixels = 0, lights = 0;
    int rows = 0, clusters = 0;
    int methods = 0;  // VSL and/or VPL: 1 or 2
    int directSamples = 0;
  };
  std::atomic<int> stage{kIdle};
  std::atomic<uint64_t> done{0}, total{0};
  // Optional: called by renderMrcs on its calling thread once the VSL image
  // is complete and VPL's rows, clustering and columns are still to come (only when
  // both methods are rendered, and not once stopped), with the direct and vsl
  // layers set and the others black. No render thread runs meanwhile, and
  // VPL's work waits for it to return (the studio renders a reference pass
  // and publishes the VSL picture there). Set and cleared by the owner
  // between renders, on the thread that calls renderMrcs.
  std::function<void(const ManyLightImages&)> onVslImage;
  // Recorded by renderMrcs before its first stage.
  void plan(const Work& work);
  void begin(Stage s, uint64_t units);
  void advance(uint64_t units) { done.fetch_add(units, std::memory_order_relaxed); }
  // "MRCS rows 43%", "MRCS clustering"; empty when idle or done.
  std::string text() const;
  // The whole render's share done, in [0, 1]: each stage weighted by its
  // pairs (rows x lights for the rows, methods x clusters x pixels for the
  // columns; eye paths and direct light by their samples, a quarter of a pair
  // each: pixels x (1 + directSamples) / 4), clustering counted as no work.
  // 0 when idle or with no work planned, 1 when done. Reads the stage and its
  // counts together (begin() cannot come in between), so it never decreases
  // while one render runs.
  double overall() const;

 private:
  mutable std::mutex mutex_;  // begin() and plan() against overall()
  Work work_;
};

// Renders the VSL and VPL indirect images (and direct light with
// settings.directSamples samples) from `set` with MRCS. `progress`, if given,
// follows the stages. With the lobe gather (settings.lobeGather), its light set
// is traced first, the eye paths gather the narrow receivers' specular lobes
// (as in ManyLightRenderer), and the VSL image adds them to the
// representatives' columns, which gather the rest.
MrcsResult renderMrcs(const Scene& scene, const Accel& accel, const LightSampler& lights, const VirtualLightSet& set,
                      const std::vector<float>& radii, const ManyLightSettings& settings, const MrcsSettings& mrcs,
                      const std::atomic<bool>* stop = nullptr, MrcsProgress* progress = nullptr);

// The clustering and representative choice alone, on reduced columns given as
// rows x lights values (row-major per light: columns[j * rows + r]). Returns,
// per cluster, the representative light and its weight. Exposed for tests.
struct Representative {
  uint32_t light;
  double weight;
};
std::vector<Representative> clusterColumns(const std::vector<float>& columns, size_t lights, int rows, int clusters,
                                           uint64_t seed, size_t* zeroColumns = nullptr,
                                           double uniformMix = MrcsSettings::kDefaultUniformMix);

}  // namespace vsl
