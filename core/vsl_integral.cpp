#include "core/vsl_integral.h"

#include <algorithm>
#include <optional>

#include "core/sampling.h"
#include "core/simd.h"

namespace vsl {

double vslConeOneMinusCos(double r, double d) {
  if (!(d > r)) return 1.0;
  double s2 = (r / d) * (r / d);
  return s2 / (1.0 + std::sqrt(1.0 - s2));
}

int vslAutoSamples(double oneMinusCos) {
  // Below theta = pi/200 (0.9 degrees) the count is 1: most pairs at 100,000
  // lights, answered without the asin. The bound sits a hair inside that
  // angle, so the rule below decides every cone near it exactly as before.
  // NaN gives 1 too.
  static const double kOneSample = 2.0 * std::pow(std::sin(0.5 * 0.99999 * M_PI / 200.0), 2);
  if (!(oneMinusCos >= kOneSample)) return 1;
  // theta = 2 asin(sqrt((1 - cos) / 2)) keeps precision for tiny cones.
  double theta = 2.0 * std::asin(std::sqrt(std::clamp(0.5 * oneMinusCos, 0.0, 1.0)));
  return 1 + int(std::floor(100.0 * theta / (0.5 * M_PI) + 1e-9));
}

const char* vslCountName(VslCount c) {
  switch (c) {
    case VslCount::Authors:
      return "authors";
    case VslCount::Lobe:
      return "lobe";
    case VslCount::Shares:
      return "shares";
  }
  return "?";
}

std::optional<VslCount> parseVslCount(const std::string& name) {
  for (VslCount c : kVslCounts)
    if (name == vslCountName(c)) return c;
  return std::nullopt;
}

VslStrategyCounts vslStrategyCounts(int n, double massX, double massP) {
  const bool useX = massX > kVslStrategyMass, useP = massP > kVslStrategyMass;
  auto share = [n](double w) { return std::max(1, int(std::lround(double(n) * std::min(1.0, std::max(w, 0.0))))); };
  const double widest = std::max({useX ? massX : 0.0, useP ? massP : 0.0, 1.0});
  return {share(1.0 / widest), useX ? share(massX) : 0, useP ? share(massP) : 0};
}

int vslLobeAwareSamples(int n, double mass) {
  if (!(mass < kVslStrategyMass)) return n;
  return std::max(1, int(std::lround(double(n) * std::max(mass, 0.0) / kVslStrategyMass)));
}

double vslClippedDiskArea(double r, double h) {
  if (!(r > 0)) return 0;
  double t = h / r;
  if (t >= 1) return M_PI * r * r;
  if (t <= -1) return 0;
  return r * r * (0.5 * M_PI + std::asin(t) + t * std::sqrt(1.0 - t * t));
}

bool vslLobeFloorApplies(const VslReceiver& x, const VslEmitter& p) {
  // The cheap test first: this runs for every pair that reaches the VSL.
  if (p.f.brdf().metallic < kVslLobeFloorMinLightMetallic) return false;
  const Brdf& xb = x.f.brdf();
  const bool xHasSpecular = x.f.specularOn() && (xb.metallic > 0 || xb.specularWeight > 0 || xb.hasCoat());
  return !(xHasSpecular && xb.minAlpha() < kVslLobeFloorMinReceiverAlpha);
}

bool vslLobeFloor(const VslReceiver& x, const VslEmitter& p, double radius, double d, double factor, VslEmitter& out) {
  return factor > 0 && vslLobeFloorApplies(x, p) && vslWidenLobe(p, radius, d, factor, out);
}

bool vslWidenLobe(const VslEmitter& p, double radius, double d, double factor, VslEmitter& out) {
  if (!(factor > 0)) return false;
  const double theta = d > radius ? std::asin(radius / d) : 0.5 * M_PI;
  return widenLobeTo(p, float(std::min(double(kVslLobeFloorMaxAlpha), factor * theta)), out);
}

bool widenLobeTo(const VslEmitter& p, float alpha, VslEmitter& out) {
  const Brdf b = p.f.brdf();
  if (!(b.ggx.ax < alpha || b.ggx.ay < alpha || (b.hasCoat() && b.coat.ax < alpha))) return false;
  out = p;
  out.f = BrdfAt(b.widened(alpha), p.f.w());
  return true;
}

namespace {

// What both forms of the quadrature share: the cone toward the sphere, the
// sample count, the strategies in use and the normalisation.
struct VslCone {
  double d, omc, pdfCone;
  Vec3 axis;
  Frame frame;
  int n;  // rounds: the largest count
  bool useX, useP;
  int nCone, nX, nP;  // samples per strategy (0: not used)
  double coneTerm;    // nCone pdfCone, pdfSum's first term

  VslCone(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius, const VslOptions& options) {
    d = length(toLight);
    // The cone's axis; a point exactly at the light looks along its normal.
    axis = d > 0 ? toLight / float(d) : x.frame.n;
    omc = vslConeOneMinusCos(radius, d);
    pdfCone = 1.0 / (2.0 * M_PI * omc);
    frame = Frame(axis);
    // Strategies 2 and 3 only where their samples can land in the cone.
    const double coneSolidAngle = 2.0 * M_PI * omc;
    const double massX = double(x.f.pdfBound()) * coneSolidAngle, massP = double(p.f.pdfBound()) * coneSolidAngle;
    useX = massX > kVslStrategyMass;
    useP = massP > kVslStrategyMass;
    const bool automatic = options.samplesPerStrategy <= 0;
    n = automatic ? vslAutoSamples(omc) : options.samplesPerStrategy;
    if (automatic && options.count != VslCount::Authors) n = vslLobeAwareSamples(n, std::max(massX, massP));
    VslStrategyCounts c{n, useX ? n : 0, useP ? n : 0};
    if (automatic && options.count == VslCount::Shares) c = vslStrategyCounts(n, massX, massP);
    nCone = c.cone;
    nX = c.x;
    nP = c.p;
    n = std::max({nCone, nX, nP});  // rounds: round i draws strategy s if i < its count
    coneTerm = nCone * pdfCone;
  }
  int draws() const { return nCone + nX + nP; }
  // The balance heuristic's denominator: sum over strategies of count x pdf.
  double pdfSum(double pdfX, double pdfP) const { return coneTerm + nX * pdfX + nP * pdfP; }
  // Is l inside the cone? 1 - cos(l, axis) = |l - axis|^2 / 2 keeps precision.
  bool inCone(const Vec3& l) const { return 0.5 * double(lengthSquared(l - axis)) <= omc; }

  // The tests every drawn sample passes before its BRDFs count (a BRDF
  // sample must land in the cone; both sides' hemispheres), giving the
  // direction in each side's local frame. False for a failed BRDF sample.
  bool accept(const VslReceiver& x, const VslEmitter& p, const Vec3& l, bool coneSample, const BrdfSample* fromX,
              const BrdfSample* fromP, Vec3& lx, Vec3& lp) const {
    if (!coneSample && !fromX && !fromP) return false;  // a failed BRDF sample
    if ((!coneSample && !inCone(l)) || dot(l, x.ng) <= 0) return false;
    lx = fromX ? fromX->wi : x.frame.toLocal(l);
    lp = fromP ? fromP->wi : p.frame.toLocal(-l);
    return lx.z > 0 && lp.z > 0;
  }

  // Draws the samples of strategy round i in order and hands each to
  // visit(l, coneSample, fromX, fromP); a failed BRDF sample is visited with
  // l = 0 and both pointers null. The random stream, which the block form
  // draws in the same order: per round, the cone's two uniforms, then the
  // receiver's BRDF's three (lobe, then direction), then the light's three.
  template <typename Visit>
  void drawRound(int round, const VslReceiver& x, const VslEmitter& p, Rng& rng, Visit&& visit) const {
    // Strategy 1: uniform in the cone.
    if (round < nCone) {
      const float u0 = rng.uniform(), u1 = rng.uniform();
      visit(frame.toWorld(sampleUniformConeOmc({u0, u1}, float(omc))), true, nullptr, nullptr);
    }
    // Strategy 2: the receiver's BRDF.
    if (round < nX) {
      if (auto s = sampleBrdf(x.f, rng))
        visit(x.frame.toWorld(s->wi), false, &*s, nullptr);
      else
        visit(Vec3(0.0f), false, nullptr, nullptr);
    }
    // Strategy 3: the light's BRDF about its incoming direction (emission
    // leaves p along w; the receiver sees it along l = -w).
    if (round < nP) {
      if (auto s = sampleBrdf(p.f, rng))
        visit(-p.frame.toWorld(s->wi), false, nullptr, &*s);
      else
        visit(Vec3(0.0f), false, nullptr, nullptr);
    }
  }
  static std::optional<BrdfSample> sampleBrdf(const BrdfAt& f, Rng& rng) {
    const float u0 = rng.uniform(), u1 = rng.uniform(), u2 = rng.uniform();
    return f.sample(u0, {u1, u2});
  }
  // The largest float t with 0.5 double(t) <= omc: inCone's test as a float
  // comparison of |l - axis|^2 with t (the block form's).
  float inConeLimit() const {
    float t = float(2.0 * omc);
    if (0.5 * double(t) > omc) t = std::nextafter(t, -kInf);
    return t;
  }

  // Balance heuristic with n_j samples of strategy j: sum f / sum_j n_j pdf_j
  // (the counts are in pdfSum).
  Vec3 normalise(const double sum[3], const VslReceiver& x, const Vec3& toLight, double radius,
                 const VslOptions& options) const {
    double area = options.clippedDisk ? vslClippedDiskArea(radius, dot(toLight, x.ng)) : M_PI * radius * radius;
    if (!(area > 0)) return Vec3(0.0f);
    double norm = 1.0 / area;
    Vec3 t(float(sum[0] * norm), float(sum[1] * norm), float(sum[2] * norm));
    return isFinite(t) ? t : Vec3(0.0f);
  }
};

// Adds one sample's f / (sum of pdfs) to sum (the balance heuristic's term),
// as f times the sum's reciprocal: one division for the three channels (in
// the block form a double division per four lanes, not three).
void addBalanced(const Vec3& f, double pdfSum, double sum[3]) {
  if (isBlack(f) || !(pdfSum > 0)) return;
  const double inv = 1.0 / pdfSum;
  for (int c = 0; c < 3; ++c) sum[c] += double(f[c]) * inv;
}

// The quadrature's sum: each strategy's terms added in the order drawn, the
// three sums then added, cone + receiver's BRDF first. (Both forms sum so;
// the block form's strategies are blocks of their own.)
struct VslSums {
  double s[3][3] = {};  // [strategy: cone, receiver, light][channel]
  void total(double out[3]) const {
    for (int c = 0; c < 3; ++c) out[c] = (s[0][c] + s[1][c]) + s[2][c];
  }
};

}  // namespace

namespace {

// The scalar quadrature: every sample's BRDFs evaluated as it is drawn.
VslResult scalarQuadrature(const VslReceiver& x, const VslEmitter& p, const VslCone& cone, const Vec3& toLight,
                           double radius, const VslOptions& options, Rng& rng) {
  VslResult res;
  VslSums sums;
  // Cone samples are inside by construction (re-testing them in float would
  // reject some near the rim of tiny cones). A BRDF-sampled direction brings
  // its own BRDF's value and pdf.
  auto accumulate = [&](const Vec3& l, bool coneSample, const BrdfSample* fromX, const BrdfSample* fromP) {
    ++res.evaluations;
    Vec3 lx, lp;
    if (!cone.accept(x, p, l, coneSample, fromX, fromP, lx, lp)) return;
    float pdfX = 0, pdfP = 0;
    Vec3 fx = fromX ? fromX->f : x.f.evalParts(lx, cone.useX ? &pdfX : nullptr).total();
    Vec3 fp = fromP ? fromP->f : p.f.evalParts(lp, cone.useP ? &pdfP : nullptr).total();
    if (fromX) pdfX = fromX->pdf;
    if (fromP) pdfP = fromP->pdf;
    addBalanced(fx * fp * (lx.z * p.cosine(lp)), cone.pdfSum(pdfX, pdfP), sums.s[fromX ? 1 : fromP ? 2 : 0]);
  };
  for (int i = 0; i < cone.n; ++i) cone.drawRound(i, x, p, rng, accumulate);
  double sum[3];
  sums.total(sum);
  res.transfer = cone.normalise(sum, x, toLight, radius, options);
  return res;
}

}  // namespace

Vec3 vslIntegrand(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                  const VslOptions& options, const Vec3& l) {
  // VslCone's axis, inCone, accept and normalise, for one direction.
  const double d = length(toLight);
  const Vec3 axis = d > 0 ? toLight / float(d) : x.frame.n;
  if (0.5 * double(lengthSquared(l - axis)) > vslConeOneMinusCos(radius, d) || dot(l, x.ng) <= 0) return Vec3(0.0f);
  const Vec3 lx = x.frame.toLocal(l), lp = p.frame.toLocal(-l);
  if (!(lx.z > 0 && lp.z > 0)) return Vec3(0.0f);
  const double area = options.clippedDisk ? vslClippedDiskArea(radius, dot(toLight, x.ng)) : M_PI * radius * radius;
  if (!(area > 0)) return Vec3(0.0f);
  const Vec3 f = x.f.eval(lx) * p.f.eval(lp) * (lx.z * p.cosine(lp));
  const Vec3 v(float(f.x / area), float(f.y / area), float(f.z / area));
  return isFinite(v) ? v : Vec3(0.0f);
}

VslResult vslTransfer(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                      const VslOptions& options, Rng& rng) {
  return scalarQuadrature(x, p, VslCone(x, p, toLight, radius, options), toLight, radius, options, rng);
}

// ---- The block form ---------------------------------------------------------

namespace {

// For each 8-bit mask, the lanes it keeps, in order, then the others: a
// left-pack by _mm256_permutevar8x32_ps.
struct LeftPackTable {
  alignas(32) int32_t index[256][8];
};
constexpr LeftPackTable leftPackTable() {
  LeftPackTable t{};
  for (int m = 0; m < 256; ++m) {
    int k = 0;
    for (int j = 0; j < 8; ++j)
      if (m >> j & 1) t.index[m][k++] = j;
    for (int j = 0; j < 8; ++j)
      if (!(m >> j & 1)) t.index[m][k++] = j;
  }
  return t;
}
constexpr LeftPackTable kLeftPack = leftPackTable();

// One strategy's samples of up to kRounds rounds: their uniforms, then each
// sample's direction in both local frames and whether it passed the tests.
struct VslStrategyBlock {
  static constexpr int kRounds = 32;
  alignas(32) float u[3][kRounds];
  alignas(32) float lx[3][kRounds], lp[3][kRounds];
  alignas(32) int32_t ok[kRounds];
  int count = 0;
  // Zeroes the first `rows` rows of uniforms in the lanes past count, up to
  // the last register (the cone's two, which it loads whole).
  void clearTail(int rows) {
    for (int k = 0; k < rows; ++k)
      for (int j = count; j < ((count + 7) & ~7); ++j) u[k][j] = 0;
  }
};

// Samples that passed the cone and hemisphere tests, each strategy's in the
// order drawn and the strategies one after the other, waiting for their
// BRDF values (structure of arrays for BrdfAt::evalTotals).
struct VslPending {
  static constexpr int kCapacity = 96;
  int n = 0;
  int start[4] = {0, 0, 0, 0};  // strategy s's samples: [start[s], start[s + 1])
  // Eight lanes of slack: a left-pack stores a whole register.
  alignas(32) float lx[3][kCapacity + 8], lp[3][kCapacity + 8];

  // Queues the samples of a strategy's block that passed (b.ok), in order.
  VSL_AVX2 void push(const VslStrategyBlock& b) {
    for (int i0 = 0; i0 < b.count; i0 += 8) {
      const int m = std::min(8, b.count - i0);
      const int keep = _mm256_movemask_ps(_mm256_load_ps(reinterpret_cast<const float*>(b.ok + i0))) & ((1 << m) - 1);
      const __m256i perm = _mm256_load_si256(reinterpret_cast<const __m256i*>(kLeftPack.index[keep]));
      for (int c = 0; c < 3; ++c) {
        _mm256_storeu_ps(lx[c] + n, _mm256_permutevar8x32_ps(_mm256_load_ps(b.lx[c] + i0), perm));
        _mm256_storeu_ps(lp[c] + n, _mm256_permutevar8x32_ps(_mm256_load_ps(b.lp[c] + i0), perm));
      }
      n += __builtin_popcount(unsigned(keep));
    }
  }
  // dot(lp_i, n) for lanes i0..i0+7, in VslEmitter::cosine's order of
  // operations (x, then y, then z; no fused multiply-adds).
  static VSL_AVX2 __m256 dot8(const float (*v)[kCapacity + 8], int i0, const Vec3& n) {
    using namespace simd;
    return add(add(mul(_mm256_load_ps(v[0] + i0), splat(n.x)), mul(_mm256_load_ps(v[1] + i0), splat(n.y))),
               mul(_mm256_load_ps(v[2] + i0), splat(n.z)));
  }
  // Evaluates both BRDFs on every pending sample at once, adds the balance
  // heuristic's terms to their strategies' sums in order, and empties the
  // queue. The terms are addBalanced's, eight (float) and four (double)
  // lanes at a time; only the additions, whose order is fixed, are scalar.
  VSL_AVX2 void flush(const VslReceiver& x, const VslEmitter& p, const VslCone& cone, VslSums& sums) {
    using namespace simd;
    alignas(32) float ex[3][kCapacity], ep[3][kCapacity], exPdf[kCapacity], epPdf[kCapacity];
    float* const exRows[3] = {ex[0], ex[1], ex[2]};
    float* const epRows[3] = {ep[0], ep[1], ep[2]};
    x.f.evalTotals(n, lx[0], lx[1], lx[2], exRows, cone.useX ? exPdf : nullptr);
    p.f.evalTotals(n, lp[0], lp[1], lp[2], epRows, cone.useP ? epPdf : nullptr);
    alignas(32) double terms[kCapacity][4];
    const __m256 zero = _mm256_setzero_ps(), inf = splat(kInf), signBit = splat(-0.0f);
    const __m256i allBits = _mm256_set1_epi32(-1);
    for (int i0 = 0; i0 < n; i0 += 8) {
      // px, pp: the pdfs of the BRDF strategies in use, else 0.
      const __m256 px = cone.useX ? _mm256_load_ps(exPdf + i0) : zero;
      const __m256 pp = cone.useP ? _mm256_load_ps(epPdf + i0) : zero;
      // A BRDF sample whose pdf is not positive and finite failed
      // (BrdfAt::sample()'s guard, mirrored; no sampled direction has been
      // seen to need it); fromX, fromP: the lanes of those strategies.
      const __m256i lane = _mm256_add_epi32(_mm256_set1_epi32(i0), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
      auto within = [&](int lo, int hi) VSL_AVX2 {
        return _mm256_castsi256_ps(_mm256_andnot_si256(_mm256_cmpgt_epi32(_mm256_set1_epi32(lo), lane),
                                                       _mm256_cmpgt_epi32(_mm256_set1_epi32(hi), lane)));
      };
      auto positiveFinite = [&](__m256 v)
                                VSL_AVX2 { return both(greater(v, zero), less(_mm256_andnot_ps(signBit, v), inf)); };
      const __m256 failed = _mm256_or_ps(_mm256_andnot_ps(positiveFinite(px), within(start[1], start[2])),
                                         _mm256_andnot_ps(positiveFinite(pp), within(start[2], start[3])));
      // f = fx fp (lx.z lp.z), and whether it is black (a normal-mapped
      // light: VslEmitter::cosine's geometric cosine for lp.z).
      const __m256 cosP = p.geometricCosine ? _mm256_max_ps(zero, dot8(lp, i0, p.ngLocal)) : _mm256_load_ps(lp[2] + i0);
      const __m256 cosines = mul(_mm256_load_ps(lx[2] + i0), cosP);
      __m256 f[3], black = _mm256_castsi256_ps(allBits);
      for (int c = 0; c < 3; ++c) {
        f[c] = mul(mul(_mm256_load_ps(ex[c] + i0), _mm256_load_ps(ep[c] + i0)), cosines);
        black = both(black, _mm256_cmp_ps(f[c], zero, _CMP_EQ_OQ));
      }
      const __m256 skip = _mm256_or_ps(failed, black);
      for (int h = 0; h < 2; ++h) {
        auto half = [&](__m256 v) VSL_AVX2 { return h == 0 ? _mm256_castps256_ps128(v) : _mm256_extractf128_ps(v, 1); };
        // pdfSum in double: coneTerm + nX px + nP pp.
        const __m256d sumPdf =
            _mm256_add_pd(_mm256_add_pd(_mm256_set1_pd(cone.coneTerm),
                                        _mm256_mul_pd(_mm256_set1_pd(double(cone.nX)), _mm256_cvtps_pd(half(px)))),
                          _mm256_mul_pd(_mm256_set1_pd(double(cone.nP)), _mm256_cvtps_pd(half(pp))));
        // Kept: not skipped and pdfSum > 0 (addBalanced's tests).
        const __m256d skipWide = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm_castps_si128(half(skip))));
        const __m256d keep = _mm256_andnot_pd(skipWide, _mm256_cmp_pd(sumPdf, _mm256_setzero_pd(), _CMP_GT_OQ));
        __m256d t[4];
        const __m256d inv = _mm256_div_pd(_mm256_set1_pd(1.0), sumPdf);
        for (int c = 0; c < 3; ++c) t[c] = _mm256_and_pd(keep, _mm256_mul_pd(_mm256_cvtps_pd(half(f[c])), inv));
        t[3] = _mm256_setzero_pd();
        // Four samples' (r, g, b, 0) rows: a 4x4 transpose.
        const __m256d a0 = _mm256_unpacklo_pd(t[0], t[1]), a1 = _mm256_unpackhi_pd(t[0], t[1]);
        const __m256d a2 = _mm256_unpacklo_pd(t[2], t[3]), a3 = _mm256_unpackhi_pd(t[2], t[3]);
        double* row = terms[i0 + 4 * h];
        _mm256_store_pd(row, _mm256_permute2f128_pd(a0, a2, 0x20));
        _mm256_store_pd(row + 4, _mm256_permute2f128_pd(a1, a3, 0x20));
        _mm256_store_pd(row + 8, _mm256_permute2f128_pd(a0, a2, 0x31));
        _mm256_store_pd(row + 12, _mm256_permute2f128_pd(a1, a3, 0x31));
      }
    }
    // Each strategy's sum, its terms in order (a dropped term is +0, which
    // leaves the non-negative sums as they are); the channels side by side.
    for (int st = 0; st < 3; ++st) {
      __m256d acc = _mm256_setr_pd(sums.s[st][0], sums.s[st][1], sums.s[st][2], 0.0);
      for (int i = start[st]; i < start[st + 1]; ++i) acc = _mm256_add_pd(acc, _mm256_load_pd(terms[i]));
      alignas(32) double out[4];
      _mm256_store_pd(out, acc);
      for (int c = 0; c < 3; ++c) sums.s[st][c] = out[c];
    }
    n = 0;
  }
};

enum class VslStrategy { Cone, X, P };

// The directions of a block of one strategy's samples, and VslCone::accept's
// tests on them, eight lanes at a time with the scalar form's operations:
// the cone's samples from their uniforms, a BRDF's (directions already drawn
// in its local frame, in b.lx or b.lp) turned to the other side's frame.
template <VslStrategy kS>
VSL_AVX2 void connectBlock(const VslReceiver& x, const VslEmitter& p, const VslCone& cone, float coneLimit,
                           VslStrategyBlock& b) {
  using namespace simd;
  const __m256 zero = _mm256_setzero_ps();
  for (int i0 = 0; i0 < b.count; i0 += 8) {
    Vec3x8 l, lx, lp;
    __m256 pass;
    if constexpr (kS == VslStrategy::Cone) {
      // sampleUniformConeOmc, then the cone's frame.
      const __m256 v = mul(_mm256_load_ps(b.u[0] + i0), splat(float(cone.omc)));
      const __m256 sinTheta = safeSqrt8(mul(v, sub(splat(2.0f), v)));
      __m256 sinPhi, cosPhi;
      sinCosTwoPi8(_mm256_load_ps(b.u[1] + i0), sinPhi, cosPhi);
      const Vec3x8 local{mul(cosPhi, sinTheta), mul(sinPhi, sinTheta), sub(splat(1.0f), v)};
      toWorld8(cone.frame, local, l);
      pass = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    } else {
      const Frame& f = kS == VslStrategy::X ? x.frame : p.frame;
      const float(*wi)[VslStrategyBlock::kRounds] = kS == VslStrategy::X ? b.lx : b.lp;
      const Vec3x8 local{_mm256_load_ps(wi[0] + i0), _mm256_load_ps(wi[1] + i0), _mm256_load_ps(wi[2] + i0)};
      toWorld8(f, local, l);
      if constexpr (kS == VslStrategy::P) l = {neg(l.x), neg(l.y), neg(l.z)};
      // inCone: |l - axis|^2 against the float form of 2 omc.
      const __m256 dx = sub(l.x, splat(cone.axis.x)), dy = sub(l.y, splat(cone.axis.y)),
                   dz = sub(l.z, splat(cone.axis.z));
      const __m256 d2 = add(add(mul(dx, dx), mul(dy, dy)), mul(dz, dz));
      pass = both(_mm256_castsi256_ps(_mm256_load_si256(reinterpret_cast<const __m256i*>(b.ok + i0))),
                  lessEqual(d2, splat(coneLimit)));
      if constexpr (kS == VslStrategy::X) lx = local;
      if constexpr (kS == VslStrategy::P) lp = local;
    }
    // dot(l, ng) <= 0 fails (a NaN passes, as in the scalar test).
    pass = both(pass, _mm256_cmp_ps(dot8(l, x.ng), zero, _CMP_NLE_UQ));
    if constexpr (kS != VslStrategy::X) toLocal8(x.frame, l, lx);
    if constexpr (kS != VslStrategy::P) {
      const Vec3x8 back{neg(l.x), neg(l.y), neg(l.z)};
      toLocal8(p.frame, back, lp);
    }
    pass = both(pass, both(greater(lx.z, zero), greater(lp.z, zero)));
    _mm256_store_ps(b.lx[0] + i0, lx.x);
    _mm256_store_ps(b.lx[1] + i0, lx.y);
    _mm256_store_ps(b.lx[2] + i0, lx.z);
    _mm256_store_ps(b.lp[0] + i0, lp.x);
    _mm256_store_ps(b.lp[1] + i0, lp.y);
    _mm256_store_ps(b.lp[2] + i0, lp.z);
    _mm256_store_si256(reinterpret_cast<__m256i*>(b.ok + i0), _mm256_castps_si256(pass));
  }
}

// The quadrature in blocks of rounds: the uniforms drawn in the scalar form's
// order, each strategy's directions and tests eight at a time, the samples
// that pass queued strategy by strategy and their BRDFs evaluated in blocks.
VSL_AVX2 VslResult blockQuadrature(const VslReceiver& x, const VslEmitter& p, const VslCone& cone, const Vec3& toLight,
                                   double radius, const VslOptions& options, Rng& rng) {
  constexpr int kRounds = VslStrategyBlock::kRounds;
  static_assert(3 * kRounds <= VslPending::kCapacity, "a block's samples fit the queue");
  VslResult res;
  res.evaluations = cone.draws();
  VslSums sums;
  const float coneLimit = cone.inConeLimit();
  VslPending pending;
  VslStrategyBlock c, bx, bp;
  for (int r0 = 0; r0 < cone.n; r0 += kRounds) {
    const int r1 = std::min(cone.n, r0 + kRounds);
    c.count = std::clamp(cone.nCone - r0, 0, kRounds);
    bx.count = std::clamp(cone.nX - r0, 0, kRounds);
    bp.count = std::clamp(cone.nP - r0, 0, kRounds);
    // The chunk's uniforms in one stream, handed out in the scalar form's
    // order (per round: cone 2, receiver 3, light 3).
    float draws[8 * kRounds];
    rng.uniforms(draws, 2 * c.count + 3 * bx.count + 3 * bp.count);
    const float* d = draws;
    for (int j = 0; j < r1 - r0; ++j) {
      if (j < c.count)
        for (int k = 0; k < 2; ++k) c.u[k][j] = *d++;
      if (j < bx.count)
        for (int k = 0; k < 3; ++k) bx.u[k][j] = *d++;
      if (j < bp.count)
        for (int k = 0; k < 3; ++k) bp.u[k][j] = *d++;
    }
    c.clearTail(2);  // the BRDFs' sampleDirections loads no lane past its count
    if (c.count) connectBlock<VslStrategy::Cone>(x, p, cone, coneLimit, c);
    if (bx.count) {
      const float* const u[3] = {bx.u[0], bx.u[1], bx.u[2]};
      float* const wi[3] = {bx.lx[0], bx.lx[1], bx.lx[2]};
      x.f.sampleDirections(bx.count, u, wi, bx.ok);
      connectBlock<VslStrategy::X>(x, p, cone, coneLimit, bx);
    }
    if (bp.count) {
      const float* const u[3] = {bp.u[0], bp.u[1], bp.u[2]};
      float* const wi[3] = {bp.lp[0], bp.lp[1], bp.lp[2]};
      p.f.sampleDirections(bp.count, u, wi, bp.ok);
      connectBlock<VslStrategy::P>(x, p, cone, coneLimit, bp);
    }
    // The samples that passed, strategy by strategy.
    pending.push(c);
    pending.start[1] = pending.n;
    pending.push(bx);
    pending.start[2] = pending.n;
    pending.push(bp);
    pending.start[3] = pending.n;
    pending.flush(x, p, cone, sums);
  }
  double sum[3];
  sums.total(sum);
  res.transfer = cone.normalise(sum, x, toLight, radius, options);
  return res;
}

}  // namespace

VslResult vslTransferBlock(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                           const VslOptions& options, Rng& rng) {
  const VslCone cone(x, p, toLight, radius, options);
  // Fewer than four samples in all would be evaluated one by one anyway
  // (BrdfAt::evalTotals): the scalar form does that without the block's
  // bookkeeping (most pairs at 100,000 lights), and it is the whole
  // quadrature on a CPU without AVX2. Both give the same bits.
  if (cone.draws() < 4 || !simdAvailable()) return scalarQuadrature(x, p, cone, toLight, radius, options, rng);
  return blockQuadrature(x, p, cone, toLight, radius, options, rng);
}

}  // namespace vsl
