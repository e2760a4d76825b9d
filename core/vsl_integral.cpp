#include "core/vsl_integral.h"

#include <algorithm>
#include <optional>

#include "core/sampling.h"

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
  static const double kOneSample = 2.0 * std::pow(std::sin(0.5 * 0.99999 * M_PI / 200.0), 2);
  if (oneMinusCos < kOneSample) return 1;
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
  const bool xHasSpecular = x.f.specularOn() && (xb.metallic > 0 || xb.specularWeight > 0);
  return !(xHasSpecular && std::min(xb.ggx.ax, xb.ggx.ay) < kVslLobeFloorMinReceiverAlpha);
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
  if (!(b.ggx.ax < alpha || b.ggx.ay < alpha)) return false;
  out.f = BrdfAt(b.widened(alpha), p.f.w());
  out.frame = p.frame;
  return true;
}

namespace {

// Marks a BRDF sample whose value and pdf are not evaluated yet (block form).
constexpr float kPendingPdf = -1.0f;

// What both forms of the quadrature share: the cone toward the sphere, the
// sample count, the strategies in use and the normalisation.
struct VslCone {
  double d, omc, pdfCone;
  Vec3 axis;
  Frame frame;
  int n;  // rounds: the largest count
  bool useX, useP;
  int nCone, nX, nP;  // samples per strategy (0: not used)

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
  }
  int draws() const { return nCone + nX + nP; }
  // The balance heuristic's denominator: sum over strategies of count x pdf.
  double pdfSum(double pdfX, double pdfP) const { return nCone * pdfCone + nX * pdfX + nP * pdfP; }
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

  // Draws the samples of strategy round i in order (the random stream is the
  // same for both forms) and hands each to visit(l, coneSample, fromX, fromP);
  // a failed BRDF sample is visited with l = 0 and both pointers null. With
  // kDefer, a BRDF sample comes with its direction only, its f and pdf set to
  // kPendingPdf (the block form evaluates them with the others and drops the
  // sample then if sample() would have failed).
  template <bool kDefer, typename Visit>
  void drawRound(int round, const VslReceiver& x, const VslEmitter& p, Rng& rng, Visit&& visit) const {
    // Strategy 1: uniform in the cone.
    if (round < nCone)
      visit(frame.toWorld(sampleUniformConeOmc({rng.uniform(), rng.uniform()}, float(omc))), true, nullptr, nullptr);
    // Strategy 2: the receiver's BRDF.
    if (round < nX) {
      if (auto s = sampleBrdf<kDefer>(x.f, rng))
        visit(x.frame.toWorld(s->wi), false, &*s, nullptr);
      else
        visit(Vec3(0.0f), false, nullptr, nullptr);
    }
    // Strategy 3: the light's BRDF about its incoming direction (emission
    // leaves p along w; the receiver sees it along l = -w).
    if (round < nP) {
      if (auto s = sampleBrdf<kDefer>(p.f, rng))
        visit(-p.frame.toWorld(s->wi), false, nullptr, &*s);
      else
        visit(Vec3(0.0f), false, nullptr, nullptr);
    }
  }
  // Both branches draw u1 and u2 in one call expression, as the quadrature
  // always has: the order of the three draws is the compiler's (unspecified
  // argument order), and writing them out in sequence would change every
  // VSL image.
  template <bool kDefer>
  static std::optional<BrdfSample> sampleBrdf(const BrdfAt& f, Rng& rng) {
    if constexpr (!kDefer) {
      return f.sample(rng.uniform(), {rng.uniform(), rng.uniform()});
    } else {
      BrdfSample s{Vec3(0.0f), Vec3(kPendingPdf), kPendingPdf, false};
      if (!f.sampleDirection(rng.uniform(), {rng.uniform(), rng.uniform()}, s.wi, s.specularLobe)) return std::nullopt;
      return s;
    }
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

// Adds one sample's f / (sum of pdfs) to sum (the balance heuristic's term).
void addBalanced(const Vec3& f, double pdfSum, double sum[3]) {
  if (isBlack(f) || !(pdfSum > 0)) return;
  for (int c = 0; c < 3; ++c) sum[c] += double(f[c]) / pdfSum;
}

}  // namespace

namespace {

// The scalar quadrature: every sample's BRDFs evaluated as it is drawn.
VslResult scalarQuadrature(const VslReceiver& x, const VslEmitter& p, const VslCone& cone, const Vec3& toLight,
                           double radius, const VslOptions& options, Rng& rng) {
  VslResult res;
  double sum[3] = {0, 0, 0};
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
    addBalanced(fx * fp * (lx.z * lp.z), cone.pdfSum(pdfX, pdfP), sum);
  };
  for (int i = 0; i < cone.n; ++i) cone.drawRound<false>(i, x, p, rng, accumulate);
  res.transfer = cone.normalise(sum, x, toLight, radius, options);
  return res;
}

}  // namespace

VslResult vslTransfer(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                      const VslOptions& options, Rng& rng) {
  return scalarQuadrature(x, p, VslCone(x, p, toLight, radius, options), toLight, radius, options, rng);
}

// ---- The block form ---------------------------------------------------------

namespace {

// Samples that passed the cone and hemisphere tests, in the order drawn,
// waiting for their BRDF values (structure of arrays for BrdfAt::evalTotals).
struct VslPending {
  static constexpr int kCapacity = 64;
  int n = 0;
  float lx[3][kCapacity], lp[3][kCapacity];
  float fx[3][kCapacity], fp[3][kCapacity], pdfX[kCapacity], pdfP[kCapacity];
  bool haveX[kCapacity], haveP[kCapacity];        // the value came with a BRDF sample
  bool sampledX[kCapacity], sampledP[kCapacity];  // a BRDF sample still to be evaluated

  void push(const Vec3& lxv, const Vec3& lpv, const BrdfSample* fromX, const BrdfSample* fromP) {
    for (int c = 0; c < 3; ++c) {
      lx[c][n] = lxv[c];
      lp[c][n] = lpv[c];
      if (fromX) fx[c][n] = fromX->f[c];
      if (fromP) fp[c][n] = fromP->f[c];
    }
    sampledX[n] = fromX && fromX->pdf == kPendingPdf;
    sampledP[n] = fromP && fromP->pdf == kPendingPdf;
    haveX[n] = fromX && !sampledX[n];
    haveP[n] = fromP && !sampledP[n];
    if (fromX) pdfX[n] = fromX->pdf;
    if (fromP) pdfP[n] = fromP->pdf;
    ++n;
  }
  // Evaluates both BRDFs on every pending sample at once, adds the balance
  // heuristic's terms in the order drawn, and empties the block.
  void flush(const VslReceiver& x, const VslEmitter& p, const VslCone& cone, double sum[3]) {
    float ex[3][kCapacity], ep[3][kCapacity], exPdf[kCapacity], epPdf[kCapacity];
    float* const exRows[3] = {ex[0], ex[1], ex[2]};
    float* const epRows[3] = {ep[0], ep[1], ep[2]};
    x.f.evalTotals(n, lx[0], lx[1], lx[2], exRows, cone.useX ? exPdf : nullptr);
    p.f.evalTotals(n, lp[0], lp[1], lp[2], epRows, cone.useP ? epPdf : nullptr);
    for (int i = 0; i < n; ++i) {
      Vec3 fxv = haveX[i] ? Vec3(fx[0][i], fx[1][i], fx[2][i]) : Vec3(ex[0][i], ex[1][i], ex[2][i]);
      Vec3 fpv = haveP[i] ? Vec3(fp[0][i], fp[1][i], fp[2][i]) : Vec3(ep[0][i], ep[1][i], ep[2][i]);
      float px = haveX[i] ? pdfX[i] : cone.useX ? exPdf[i] : 0.0f;
      float pp = haveP[i] ? pdfP[i] : cone.useP ? epPdf[i] : 0.0f;
      // sample() fails on a pdf that is not positive and finite.
      if ((sampledX[i] && !(px > 0 && std::isfinite(px))) || (sampledP[i] && !(pp > 0 && std::isfinite(pp)))) continue;
      addBalanced(fxv * fpv * (lx[2][i] * lp[2][i]), cone.pdfSum(px, pp), sum);
    }
    n = 0;
  }
};

}  // namespace

VslResult vslTransferBlock(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                           const VslOptions& options, Rng& rng) {
  const VslCone cone(x, p, toLight, radius, options);
  // Fewer than four samples in all would be evaluated one by one anyway
  // (BrdfAt::evalTotals): the scalar form does that without the block's
  // bookkeeping (most pairs at 100,000 lights). Both give the same bits.
  if (cone.draws() < 4) return scalarQuadrature(x, p, cone, toLight, radius, options, rng);
  VslResult res;
  double sum[3] = {0, 0, 0};
  VslPending pending;
  // The same tests as vslTransfer's (VslCone::accept); the BRDF values wait.
  auto collect = [&](const Vec3& l, bool coneSample, const BrdfSample* fromX, const BrdfSample* fromP) {
    ++res.evaluations;
    Vec3 lx, lp;
    if (cone.accept(x, p, l, coneSample, fromX, fromP, lx, lp)) pending.push(lx, lp, fromX, fromP);
  };
  for (int i = 0; i < cone.n; ++i) {
    cone.drawRound<true>(i, x, p, rng, collect);
    if (pending.n > VslPending::kCapacity - 3) pending.flush(x, p, cone, sum);
  }
  pending.flush(x, p, cone, sum);
  res.transfer = cone.normalise(sum, x, toLight, radius, options);
  return res;
}

}  // namespace vsl
