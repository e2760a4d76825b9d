#include "core/vsl_integral.h"

#include <algorithm>

#include "core/sampling.h"

namespace vsl {

double vslConeOneMinusCos(double r, double d) {
  if (!(d > r)) return 1.0;
  double s2 = (r / d) * (r / d);
  return s2 / (1.0 + std::sqrt(1.0 - s2));
}

int vslAutoSamples(double oneMinusCos) {
  // theta = 2 asin(sqrt((1 - cos) / 2)) keeps precision for tiny cones.
  double theta = 2.0 * std::asin(std::sqrt(std::clamp(0.5 * oneMinusCos, 0.0, 1.0)));
  return 1 + int(std::floor(100.0 * theta / (0.5 * M_PI) + 1e-9));
}

double vslClippedDiskArea(double r, double h) {
  if (!(r > 0)) return 0;
  double t = h / r;
  if (t >= 1) return M_PI * r * r;
  if (t <= -1) return 0;
  return r * r * (0.5 * M_PI + std::asin(t) + t * std::sqrt(1.0 - t * t));
}

VslResult vslTransfer(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                      const VslOptions& options, Rng& rng) {
  VslResult res;
  double d = length(toLight);
  // The cone's axis; a point exactly at the light looks along its normal.
  Vec3 axis = d > 0 ? toLight / float(d) : x.frame.n;
  double omc = vslConeOneMinusCos(radius, d);
  int n = options.samplesPerStrategy > 0 ? options.samplesPerStrategy : vslAutoSamples(omc);
  double pdfCone = 1.0 / (2.0 * M_PI * omc);
  Frame coneFrame(axis);
  // Is l inside the cone? 1 - cos(l, axis) = |l - axis|^2 / 2 keeps precision.
  auto inCone = [&](const Vec3& l) { return 0.5 * double(lengthSquared(l - axis)) <= omc; };

  // Strategies 2 and 3 only where their samples can land in the cone.
  const double coneSolidAngle = 2.0 * M_PI * omc;
  const bool useX = double(x.f.pdfBound()) * coneSolidAngle > kVslStrategyMass;
  const bool useP = double(p.f.pdfBound()) * coneSolidAngle > kVslStrategyMass;

  double sum[3] = {0, 0, 0};
  // Cone samples are inside by construction (re-testing them in float would
  // reject some near the rim of tiny cones). A BRDF-sampled direction brings
  // its own BRDF's value and pdf.
  auto accumulate = [&](const Vec3& l, bool coneSample, const BrdfSample* fromX, const BrdfSample* fromP) {
    ++res.evaluations;
    if ((!coneSample && !inCone(l)) || dot(l, x.ng) <= 0) return;
    Vec3 lx = fromX ? fromX->wi : x.frame.toLocal(l), lp = fromP ? fromP->wi : p.frame.toLocal(-l);
    if (lx.z <= 0 || lp.z <= 0) return;
    float pdfX = 0, pdfP = 0;
    Vec3 fx = fromX ? fromX->f : x.f.evalParts(lx, useX ? &pdfX : nullptr).total();
    Vec3 fp = fromP ? fromP->f : p.f.evalParts(lp, useP ? &pdfP : nullptr).total();
    if (fromX) pdfX = fromX->pdf;
    if (fromP) pdfP = fromP->pdf;
    Vec3 f = fx * fp * (lx.z * lp.z);
    if (isBlack(f)) return;
    double pdfSum = pdfCone + double(pdfX) + double(pdfP);
    if (!(pdfSum > 0)) return;
    for (int c = 0; c < 3; ++c) sum[c] += double(f[c]) / pdfSum;
  };

  for (int i = 0; i < n; ++i) {
    // Strategy 1: uniform in the cone.
    accumulate(coneFrame.toWorld(sampleUniformConeOmc({rng.uniform(), rng.uniform()}, float(omc))), true, nullptr,
               nullptr);
    // Strategy 2: the receiver's BRDF.
    if (useX) {
      if (auto s = x.f.sample(rng.uniform(), {rng.uniform(), rng.uniform()}))
        accumulate(x.frame.toWorld(s->wi), false, &*s, nullptr);
      else
        ++res.evaluations;
    }
    // Strategy 3: the light's BRDF about its incoming direction (emission
    // leaves p along w; the receiver sees it along l = -w).
    if (useP) {
      if (auto s = p.f.sample(rng.uniform(), {rng.uniform(), rng.uniform()}))
        accumulate(-p.frame.toWorld(s->wi), false, nullptr, &*s);
      else
        ++res.evaluations;
    }
  }
  // Balance heuristic with n samples per strategy: (1/n) sum f / sum_j pdf_j.
  double area = options.clippedDisk ? vslClippedDiskArea(radius, dot(toLight, x.ng)) : M_PI * radius * radius;
  if (!(area > 0)) return res;
  double norm = 1.0 / (double(n) * area);
  Vec3 t(float(sum[0] * norm), float(sum[1] * norm), float(sum[2] * norm));
  res.transfer = isFinite(t) ? t : Vec3(0.0f);
  return res;
}

}  // namespace vsl
