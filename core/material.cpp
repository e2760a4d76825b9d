#include "core/material.h"

#include <array>
#include <cstring>
#include <mutex>

#include "core/parallel.h"
#include "core/sampling.h"
#include "core/simd.h"

namespace vsl {

// ---- GGX ------------------------------------------------------------------

float GGX::D(const Vec3& h) const {
  if (h.z <= 0) return 0;
  float e = sqr(h.x / ax) + sqr(h.y / ay) + sqr(h.z);
  return 1.0f / (kPi * ax * ay * e * e);
}

float GGX::lambda(const Vec3& w) const {
  float z2 = w.z * w.z;
  if (z2 <= 0) return kInf;
  float a2tan2 = (sqr(ax * w.x) + sqr(ay * w.y)) / z2;
  return (std::sqrt(1.0f + a2tan2) - 1.0f) * 0.5f;
}

GGX::VisibleFrame GGX::visibleNormalFrame(const Vec3& wo) const {
  VisibleFrame v;
  // Stretch the view vector to the unit-roughness configuration.
  v.vh = normalize(Vec3(ax * wo.x, ay * wo.y, wo.z));
  // Orthonormal basis around vh (T1 is horizontal).
  float lensq = v.vh.x * v.vh.x + v.vh.y * v.vh.y;
  v.t1 = lensq > 1e-14f ? Vec3(-v.vh.y, v.vh.x, 0) / std::sqrt(lensq) : Vec3(1, 0, 0);
  v.t2 = cross(v.vh, v.t1);
  v.s = 0.5f * (1.0f + v.vh.z);
  return v;
}

Vec3 GGX::sampleVisibleNormal(const VisibleFrame& v, Vec2 u) const {
  // Sample the projected area of the hemisphere: a disk warped toward vh.
  float r = std::sqrt(u.x), sinPhi, cosPhi;
  sinCosTwoPi(u.y, sinPhi, cosPhi);
  float p1 = r * cosPhi, p2 = r * sinPhi;
  p2 = (1.0f - v.s) * safeSqrt(1.0f - p1 * p1) + v.s * p2;
  Vec3 nh = p1 * v.t1 + p2 * v.t2 + safeSqrt(1.0f - p1 * p1 - p2 * p2) * v.vh;
  // Unstretch.
  return normalize(Vec3(ax * nh.x, ay * nh.y, std::max(1e-7f, nh.z)));
}

float GGX::visibleNormalPdf(const Vec3& wo, const Vec3& h) const {
  if (wo.z <= 0) return 0;
  return G1(wo) * std::max(0.0f, dot(wo, h)) * D(h) / wo.z;
}

// ---- Fresnel --------------------------------------------------------------

static inline float schlickWeight(float cosTheta) {
  float m = clamp(1.0f - cosTheta, 0.0f, 1.0f);
  float m2 = m * m;
  return m2 * m2 * m;
}

// ---- Dielectric specular albedo table --------------------------------------

namespace {
constexpr int kTableMu = 64, kTableAlpha = 32, kTableStrata = 32;

struct AlbedoTable {
  // E[a][m]: row per roughness r = sqrt(alpha) in [0,1], column per cos in [0,1].
  std::array<std::array<float, kTableMu>, kTableAlpha> E{};
  std::array<float, kTableAlpha> Eavg{};

  // One row per roughness, in parallel (a row reads nothing of another):
  // the first BRDF of a process waits for it (about 0.1 s on one core).
  AlbedoTable() {
    parallelFor(kTableAlpha, [this](size_t row) {
      const int ia = int(row);
      float r = float(ia) / (kTableAlpha - 1);
      GGX g{std::max(r * r, kMinAlpha), std::max(r * r, kMinAlpha)};
      for (int im = 0; im < kTableMu; ++im) {
        float mu = std::max(float(im) / (kTableMu - 1), 1e-3f);
        Vec3 wo(safeSqrt(1 - mu * mu), 0, mu);
        // Stratified quadrature of F * G2 / G1(wo) under visible-normal sampling.
        double sum = 0;
        for (int i = 0; i < kTableStrata; ++i)
          for (int j = 0; j < kTableStrata; ++j) {
            Vec2 u{(i + 0.5f) / kTableStrata, (j + 0.5f) / kTableStrata};
            Vec3 h = g.sampleVisibleNormal(wo, u);
            Vec3 wi = reflect(wo, h);
            if (wi.z <= 0) continue;
            float F = kDielectricF0 + (1 - kDielectricF0) * schlickWeight(dot(wo, h));
            sum += F * g.G2(wo, wi) / g.G1(wo);
          }
        E[ia][im] = float(sum / (kTableStrata * kTableStrata));
      }
      // E_avg = 2 * integral of E(mu) mu dmu (trapezoid).
      double avg = 0;
      for (int im = 0; im + 1 < kTableMu; ++im) {
        float m0 = float(im) / (kTableMu - 1), m1 = float(im + 1) / (kTableMu - 1);
        avg += 0.5 * (E[ia][im] * m0 + E[ia][im + 1] * m1) * (m1 - m0);
      }
      Eavg[ia] = float(2 * avg);
    });
  }
};

const AlbedoTable& albedoTable() {
  static const AlbedoTable table;  // thread-safe initialisation (C++11 statics)
  return table;
}

}  // namespace

void prepareMaterialTables() { albedoTable(); }

namespace {

AlbedoRow albedoRow(float alpha) {
  float fa = clamp(std::sqrt(std::max(alpha, 0.0f)), 0.0f, 1.0f) * (kTableAlpha - 1);
  int a0 = std::min(int(fa), kTableAlpha - 2);
  return {a0, fa - a0};
}

float albedoAt(AlbedoRow r, float cosTheta) {
  const AlbedoTable& t = albedoTable();
  // NaN reads row 0 (clamp() would pass it on to the index).
  float fm = (cosTheta > 0 ? std::min(cosTheta, 1.0f) : 0.0f) * (kTableMu - 1);
  int m0 = std::min(int(fm), kTableMu - 2);
  float dm = fm - m0;
  float e0 = t.E[r.a0][m0] * (1 - dm) + t.E[r.a0][m0 + 1] * dm;
  float e1 = t.E[r.a0 + 1][m0] * (1 - dm) + t.E[r.a0 + 1][m0 + 1] * dm;
  return e0 * (1 - r.da) + e1 * r.da;
}

float albedoAverageAt(AlbedoRow r) {
  const AlbedoTable& t = albedoTable();
  return t.Eavg[r.a0] * (1 - r.da) + t.Eavg[r.a0 + 1] * r.da;
}
}  // namespace

float dielectricSpecularAlbedo(float cosTheta, float alpha) { return albedoAt(albedoRow(alpha), cosTheta); }

float dielectricSpecularAlbedoAverage(float alpha) { return albedoAverageAt(albedoRow(alpha)); }

// ---- Brdf -----------------------------------------------------------------

Brdf Brdf::fromGltf(const Vec3& baseColor, float metallic, float roughness, float anisotropy, float specularWeight) {
  Brdf b;
  b.specularWeight = clamp(specularWeight, 0, 1);
  b.baseColor = Vec3(clamp(baseColor.x, 0, 1), clamp(baseColor.y, 0, 1), clamp(baseColor.z, 0, 1));
  b.metallic = clamp(metallic, 0, 1);
  float alpha = std::max(sqr(clamp(roughness, 0, 1)), kMinAlpha);
  float s = clamp(anisotropy, 0, 1);
  b.ggx.ax = std::max(alpha + (1.0f - alpha) * s * s, kMinAlpha);
  b.ggx.ay = alpha;
  return b;
}

Brdf Brdf::withClearcoat(float weight, float roughness, const Vec3& n) const {
  Brdf b = *this;
  b.clearcoat = clamp(weight, 0, 1);
  b.coat.ax = b.coat.ay = std::max(sqr(clamp(roughness, 0, 1)), kMinAlpha);
  b.coatNormal = isFinite(n) && n.z > 0 && std::abs(lengthSquared(n) - 1) < 1e-3f ? n : Vec3(0, 0, 1);
  return b;
}

Vec3 Brdf::evalDiffuse(const Vec3& wo, const Vec3& wi) const { return BrdfAt(*this, wo).evalParts(wi).diffuse; }

Vec3 Brdf::eval(const Vec3& wo, const Vec3& wi) const { return BrdfAt(*this, wo).eval(wi); }

float Brdf::specularProbability(const Vec3& wo) const { return BrdfAt(*this, wo).specularProbability(); }

float Brdf::pdf(const Vec3& wo, const Vec3& wi) const { return BrdfAt(*this, wo).pdf(wi); }

std::optional<BrdfSample> Brdf::sample(const Vec3& wo, float u1, Vec2 u2) const {
  return BrdfAt(*this, wo).sample(u1, u2);
}

// ---- BrdfAt ---------------------------------------------------------------

BrdfAt::BrdfAt(const Brdf& brdf, const Vec3& w) : b_(brdf), w_(w), above_(w.z > 0) {
  coat_ = b_.clearcoat > 0;
  if (!above_) return;
  const float s = b_.specularWeight, m = b_.metallic;
  lambdaW_ = b_.ggx.lambda(w);
  // Lobe selection: the specular lobe's share of the albedo, kept within
  // [0.1, 0.9] when both lobes exist so that MIS never divides by a
  // vanishing pdf. A metal has no diffuse lobe.
  ps_ = 1;
  if (m < 1) {
    row_ = albedoRow(std::sqrt(b_.ggx.ax * b_.ggx.ay));
    float E = s * albedoAt(row_, w.z);
    kd_ = b_.baseColor * ((1 - m) * kInvPi * (1 - E) / std::max(1 - s * albedoAverageAt(row_), 1e-4f));
    float spec = m + (1 - m) * E;
    float diff = (1 - m) * (1 - E) * std::max(luminance(b_.baseColor), 0.0f);
    ps_ = !(spec > 0) ? 0.0f : !(diff > 0) ? 1.0f : clamp(spec / (spec + diff), 0.1f, 0.9f);
    baseSpecW_ = spec;
    baseDiffW_ = diff;
  } else {
    baseSpecW_ = 1;
  }
  // Visible-normal sampling: pdf(wi) = G1(w) D(h) / (4 w.z).
  specPdfScale_ = ps_ / ((1 + lambdaW_) * 4 * w.z);
  pdfBound_ = (1 - ps_) * kInvPi + specPdfScale_ / (kPi * b_.ggx.ax * b_.ggx.ay);
  if (coat_) initCoat();
}

BrdfAt BrdfAt::diffuseLobe() const {
  BrdfAt d = *this;
  d.specularOn_ = false;
  d.ps_ = 0;
  d.specPdfScale_ = 0;
  d.pdfBound_ = kInvPi;
  if (coat_) {
    d.restricted_ = 1;
    d.setLobeProbabilities();
  }
  return d;
}

BrdfAt BrdfAt::specularLobe() const {
  BrdfAt s = *this;
  s.kd_ = Vec3(0.0f);
  if (!above_) return s;
  s.ps_ = 1;
  s.specPdfScale_ = 1.0f / ((1 + lambdaW_) * 4 * w_.z);
  s.pdfBound_ = s.specPdfScale_ / (kPi * b_.ggx.ax * b_.ggx.ay);
  if (coat_) {
    s.restricted_ = 2;
    s.setLobeProbabilities();
  }
  return s;
}

BrdfAt::Parts BrdfAt::evalParts(const Vec3& wi, float* pdfOut) const {
  if (coat_) return evalPartsCoated(wi, pdfOut);
  Parts p{Vec3(0.0f), Vec3(0.0f)};
  if (pdfOut) *pdfOut = 0;
  if (!above_ || !(wi.z > 0)) return p;  // (NaN too: zero, as the block forms give)
  const float s = b_.specularWeight, m = b_.metallic;
  if (m < 1) p.diffuse = kd_ * (1 - s * albedoAt(row_, wi.z));
  // (1 - pc_) is 1 without a coat: the product then rounds to 1 - ps_.
  if (pdfOut) *pdfOut = (1 - pc_) * (1 - ps_) * cosineHemispherePdf(wi.z);
  if (!specularOn_) return p;
  Vec3 h = w_ + wi;
  float hl = length(h);
  if (!(hl > 0)) return p;
  h /= hl;
  const float D = b_.ggx.D(h), voh = dot(w_, h);
  if (pdfOut && voh > 0) *pdfOut += specPdfScale_ * D;
  float w = schlickWeight(std::max(voh, 0.0f));
  // Fresnel blended between the dielectric (F0 = 0.04) and the metal (F0 = c).
  Vec3 Fm = b_.baseColor + (Vec3(1.0f) - b_.baseColor) * w;
  float Fd = s * (kDielectricF0 + (1 - kDielectricF0) * w);
  Vec3 F = Vec3(Fd * (1 - m)) + Fm * m;
  float G2 = 1.0f / (1.0f + lambdaW_ + b_.ggx.lambda(wi));
  p.specular = F * (D * G2 / (4 * w_.z * wi.z));
  return p;
}

float BrdfAt::pdf(const Vec3& wi) const {
  if (coat_) {
    float p = 0;
    evalPartsCoated(wi, &p);
    return p;
  }
  if (!above_ || wi.z <= 0) return 0;
  float pdf = (1 - ps_) * cosineHemispherePdf(wi.z);
  if (!specularOn_) return pdf;
  Vec3 h = normalize(w_ + wi);
  if (dot(w_, h) > 0) pdf += specPdfScale_ * b_.ggx.D(h);
  return pdf;
}

bool BrdfAt::sampleDirection(float u1, Vec2 u2, Vec3& wi, bool& specular) const {
  if (!above_) return false;
  if (coat_) return sampleDirectionCoated(u1, u2, wi, specular);
  return sampleDirectionIn(b_.ggx.visibleNormalFrame(w_), u1, u2, wi, specular);
}

bool BrdfAt::sampleDirectionIn(const GGX::VisibleFrame& v, float u1, Vec2 u2, Vec3& wi, bool& specular) const {
  specular = u1 < ps_;
  if (specular) {
    Vec3 h = b_.ggx.sampleVisibleNormal(v, u2);
    wi = reflect(w_, h);
  } else {
    wi = sampleCosineHemisphere(u2);
  }
  return wi.z > 0;
}

void BrdfAt::sampleDirections(int n, const float* const u[3], float* const wi[3], int32_t* ok) const {
  if (n >= 4 && simdAvailable() && !coat_)
    sampleDirectionsAvx2(n, u, wi, ok);
  else
    sampleDirectionsScalar(n, u, wi, ok);
}

void BrdfAt::sampleDirectionsScalar(int n, const float* const u[3], float* const wi[3], int32_t* ok) const {
  const GGX::VisibleFrame v = b_.ggx.visibleNormalFrame(w_);
  for (int i = 0; i < n; ++i) {
    Vec3 w(0.0f);
    bool specular;
    const Vec2 u2{u[1][i], u[2][i]};
    const bool drawn =
        coat_ ? sampleDirection(u[0][i], u2, w, specular) : above_ && sampleDirectionIn(v, u[0][i], u2, w, specular);
    ok[i] = drawn ? -1 : 0;
    for (int c = 0; c < 3; ++c) wi[c][i] = w[c];
  }
}

std::optional<BrdfSample> BrdfAt::sample(float u1, Vec2 u2) const {
  Vec3 wi;
  bool spec = false;
  if (!sampleDirection(u1, u2, wi, spec)) return std::nullopt;
  float p = 0;
  Vec3 f = evalParts(wi, &p).total();
  if (!(p > 0) || !std::isfinite(p)) return std::nullopt;
  return BrdfSample{wi, f, p, spec};
}

// ---- [Clear coat] ---------------------------------------------------------
// KHR_materials_clearcoat as layered in core/material.h: the coat's lobe
// cc F D G2 / (4 cos cos) in the coat's frame, the base times the
// transmissions (1 - cc E_c) at both directions. sample() picks the coat
// with probability pc_ (its share of the albedo at w, kept in [0.1, 0.9]
// when the base reflects too, as the base's own lobes are), the base's lobes
// otherwise, and pdf() is the mixture's.

void BrdfAt::initCoat() {
  const Vec3& n = b_.coatNormal;
  coatTilted_ = n.x != 0 || n.y != 0;
  if (coatTilted_) coatFrame_ = Frame(n);  // the coat is isotropic: any tangent will do
  wc_ = toCoat(w_);
  rowC_ = albedoRow(b_.coat.ax);
  const float cc = b_.clearcoat, Ec = albedoAt(rowC_, wc_.z);
  coatT_ = 1 - cc * Ec;
  coatW_ = wc_.z > 0 ? cc * Ec : 0.0f;
  lambdaWc_ = wc_.z > 0 ? b_.coat.lambda(wc_) : 0.0f;
  kd_ *= coatT_;
  setLobeProbabilities();
}

void BrdfAt::setLobeProbabilities() {
  if (!above_) return;
  const float coatW = restricted_ == 1 ? 0.0f : coatW_;
  const float baseW = coatT_ * ((restricted_ == 1 ? 0.0f : baseSpecW_) + (restricted_ == 2 ? 0.0f : baseDiffW_));
  pc_ = !(coatW > 0) ? 0.0f : !(baseW > 0) ? 1.0f : clamp(coatW / (coatW + baseW), 0.1f, 0.9f);
  specPdfScale_ = (1 - pc_) * ps_ / ((1 + lambdaW_) * 4 * w_.z);
  coatPdfScale_ = wc_.z > 0 ? pc_ / ((1 + lambdaWc_) * 4 * wc_.z) : 0.0f;
  pdfBound_ = (1 - pc_) * (1 - ps_) * kInvPi + specPdfScale_ / (kPi * b_.ggx.ax * b_.ggx.ay) +
              coatPdfScale_ / (kPi * b_.coat.ax * b_.coat.ay);
}

BrdfAt::Parts BrdfAt::evalPartsCoated(const Vec3& wi, float* pdfOut) const {
  Parts p{Vec3(0.0f), Vec3(0.0f)};
  if (pdfOut) *pdfOut = 0;
  if (!above_ || !(wi.z > 0)) return p;
  // The base's lobes (kd_ holds the transmission at w; its specular lobe
  // takes both here) and their pdfs, already scaled by 1 - pc_.
  const float s = b_.specularWeight, m = b_.metallic;
  const Vec3 wic = toCoat(wi);
  const float ti = 1 - b_.clearcoat * albedoAt(rowC_, wic.z);
  if (m < 1) p.diffuse = kd_ * ((1 - s * albedoAt(row_, wi.z)) * ti);
  if (pdfOut) *pdfOut = (1 - pc_) * (1 - ps_) * cosineHemispherePdf(wi.z);
  if (!specularOn_) return p;
  Vec3 h = w_ + wi;
  float hl = length(h);
  if (hl > 0) {
    h /= hl;
    const float D = b_.ggx.D(h), voh = dot(w_, h);
    if (pdfOut && voh > 0) *pdfOut += specPdfScale_ * D;
    const float w = schlickWeight(std::max(voh, 0.0f));
    const Vec3 Fm = b_.baseColor + (Vec3(1.0f) - b_.baseColor) * w;
    const float Fd = s * (kDielectricF0 + (1 - kDielectricF0) * w);
    const Vec3 F = Vec3(Fd * (1 - m)) + Fm * m;
    const float G2 = 1.0f / (1.0f + lambdaW_ + b_.ggx.lambda(wi));
    p.specular = F * (D * G2 / (4 * w_.z * wi.z) * coatT_ * ti);
  }
  // The coat's lobe, in its frame (zero where either direction is below it).
  if (!(wc_.z > 0)) return p;
  Vec3 hc = wc_ + wic;
  const float hcl = length(hc);
  if (!(hcl > 0)) return p;
  hc /= hcl;
  const float Dc = b_.coat.D(hc), vohc = dot(wc_, hc);
  if (pdfOut && vohc > 0) *pdfOut += coatPdfScale_ * Dc;
  if (!(wic.z > 0)) return p;
  const float Fc = kDielectricF0 + (1 - kDielectricF0) * schlickWeight(std::max(vohc, 0.0f));
  const float G2c = 1.0f / (1.0f + lambdaWc_ + b_.coat.lambda(wic));
  p.specular += Vec3(b_.clearcoat * Fc * Dc * G2c / (4 * wc_.z * wic.z));
  return p;
}

bool BrdfAt::sampleDirectionCoated(float u1, Vec2 u2, Vec3& wi, bool& specular) const {
  if (u1 < pc_) {
    // The coat: a visible normal of its GGX seen from w (Heitz 2018), mirrored.
    specular = true;
    const Vec3 wic = reflect(wc_, b_.coat.sampleVisibleNormal(wc_, u2));
    wi = coatTilted_ ? coatFrame_.toWorld(wic) : wic;
    return wi.z > 0;
  }
  // The base's lobes, u1 rescaled to [0, 1).
  const float ub = std::min((u1 - pc_) / (1 - pc_), 0x1.fffffep-1f);
  return sampleDirectionIn(b_.ggx.visibleNormalFrame(w_), ub, u2, wi, specular);
}

// ---- BrdfAt, blocks of directions ------------------------------------------

bool simdAvailable() {
  static const bool ok = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return ok;
}

namespace {
// A few directions cost less in the scalar forms than a register's set-up.
bool useSimd(int n) { return n >= 4 && simdAvailable(); }
}  // namespace

void BrdfAt::evalTotals(int n, const float* wx, const float* wy, const float* wz, float* const f[3], float* pdf) const {
  if (useSimd(n) && !coat_)
    evalTotalsAvx2(n, wx, wy, wz, f, pdf);
  else
    evalTotalsScalar(n, wx, wy, wz, f, pdf);
}

// The packed layout: three rows of eight floats (evalTotalsPackedAvx2
// transposes each into eight lanes).
namespace {
enum PackedTerm {
  kBase = 0,  // 3
  kKd = 3,    // 3
  kW = 6,     // 3
  kS = 9,
  kM,
  kAx,
  kAy,
  kLambdaW,
  kPs,
  kSpecPdfScale,
  kDa,
  kA0,  // the bits of an int32
  kAbove,
  kDiffuse,
  kSpecular,  // masks: all bits set or none
  // The clear coat (the AVX2 form reads none of it: a group with a coat
  // takes the scalar form): its weight (0: none), its alpha, and the bits
  // of a uint32 holding the restriction (bits 0-1) and the coat normal's x
  // and y as 15-bit snorms (bits 2-16, 17-31; z > 0 follows).
  kClearcoat,
  kCoatAlpha,
  kCoatBits,
};
static_assert(kCoatBits < BrdfAt::kPackedFloats, "the packed terms fit");
constexpr float kSnorm15 = 16383.0f;
uint32_t toSnorm15(float v) { return uint32_t(std::lround(clamp(v, -1.0f, 1.0f) * kSnorm15) + 16384) & 0x7fffu; }
float fromSnorm15(uint32_t b) { return (float(b & 0x7fffu) - 16384) / kSnorm15; }
float bitsOf(int32_t v) {
  float f;
  std::memcpy(&f, &v, sizeof f);
  return f;
}
int32_t intOf(float f) {
  int32_t v;
  std::memcpy(&v, &f, sizeof v);
  return v;
}
}  // namespace

void BrdfAt::pack(float* out) const {
  for (int i = 0; i < kPackedFloats; ++i) out[i] = 0;
  for (int c = 0; c < 3; ++c) {
    out[kBase + c] = b_.baseColor[c];
    out[kKd + c] = kd_[c];
    out[kW + c] = w_[c];
  }
  out[kS] = b_.specularWeight;
  out[kM] = b_.metallic;
  out[kAx] = b_.ggx.ax;
  out[kAy] = b_.ggx.ay;
  out[kLambdaW] = lambdaW_;
  out[kPs] = ps_;
  out[kSpecPdfScale] = specPdfScale_;
  out[kDa] = row_.da;
  out[kA0] = bitsOf(row_.a0);
  out[kAbove] = bitsOf(above_ ? -1 : 0);
  out[kDiffuse] = bitsOf(b_.metallic < 1 ? -1 : 0);
  out[kSpecular] = bitsOf(specularOn_ ? -1 : 0);
  if (!coat_) return;
  out[kClearcoat] = b_.clearcoat;
  out[kCoatAlpha] = b_.coat.ax;
  const uint32_t bits = uint32_t(restricted_) | (toSnorm15(b_.coatNormal.x) << 2) | (toSnorm15(b_.coatNormal.y) << 17);
  out[kCoatBits] = bitsOf(int32_t(bits));
}

BrdfAt BrdfAt::unpack(const float* in) {
  BrdfAt b;
  if (in[kClearcoat] > 0) {
    // A coated BRDF is rebuilt from its parameters and its restriction.
    Brdf c;
    for (int k = 0; k < 3; ++k) c.baseColor[k] = in[kBase + k];
    c.specularWeight = in[kS];
    c.metallic = in[kM];
    c.ggx.ax = in[kAx];
    c.ggx.ay = in[kAy];
    c.clearcoat = in[kClearcoat];
    c.coat.ax = c.coat.ay = in[kCoatAlpha];
    const uint32_t bits = uint32_t(intOf(in[kCoatBits]));
    const float nx = fromSnorm15(bits >> 2), ny = fromSnorm15(bits >> 17);
    c.coatNormal = Vec3(nx, ny, safeSqrt(1 - nx * nx - ny * ny));
    if (nx != 0 || ny != 0) c.coatNormal = normalize(c.coatNormal);
    const BrdfAt full(c, Vec3(in[kW], in[kW + 1], in[kW + 2]));
    const int r = int(bits & 3u);
    return r == 1 ? full.diffuseLobe() : r == 2 ? full.specularLobe() : full;
  }
  for (int c = 0; c < 3; ++c) {
    b.b_.baseColor[c] = in[kBase + c];
    b.kd_[c] = in[kKd + c];
    b.w_[c] = in[kW + c];
  }
  b.b_.specularWeight = in[kS];
  b.b_.metallic = in[kM];
  b.b_.ggx.ax = in[kAx];
  b.b_.ggx.ay = in[kAy];
  b.lambdaW_ = in[kLambdaW];
  b.ps_ = in[kPs];
  b.specPdfScale_ = in[kSpecPdfScale];
  b.row_.da = in[kDa];
  b.row_.a0 = intOf(in[kA0]);
  b.above_ = intOf(in[kAbove]) != 0;
  b.specularOn_ = intOf(in[kSpecular]) != 0;
  return b;
}

void BrdfAt::evalTotalsPacked(int n, const float* const* packed, const float* wx, const float* wy, const float* wz,
                              bool diffuseOnly, float* const f[3]) {
  if (useSimd(n)) return evalTotalsPackedAvx2(n, packed, wx, wy, wz, diffuseOnly, f);
  evalTotalsPackedScalar(n, packed, wx, wy, wz, diffuseOnly, f);
}

void BrdfAt::evalTotalsPackedScalar(int n, const float* const* packed, const float* wx, const float* wy,
                                    const float* wz, bool diffuseOnly, float* const f[3]) {
  for (int i = 0; i < n; ++i) {
    const Parts p = unpack(packed[i]).evalParts(Vec3(wx[i], wy[i], wz[i]));
    const Vec3 v = diffuseOnly ? p.diffuse : p.total();
    for (int c = 0; c < 3; ++c) f[c][i] = v[c];
  }
}

void BrdfAt::evalTotalsScalar(int n, const float* wx, const float* wy, const float* wz, float* const f[3],
                              float* pdf) const {
  for (int i = 0; i < n; ++i) {
    float p = 0;
    Vec3 v = evalParts(Vec3(wx[i], wy[i], wz[i]), pdf ? &p : nullptr).total();
    for (int c = 0; c < 3; ++c) f[c][i] = v[c];
    if (pdf) pdf[i] = p;
  }
}

// The AVX2 form: evalParts() on eight lanes, operation for operation in the
// same order (no FMA, so no contraction: the results are bit-identical).
// std::max(v, lo) is _mm256_max_ps(lo, v) and std::min(v, hi) is
// _mm256_min_ps(hi, v), which agree with std:: on every input.
namespace {
using namespace simd;

// A BrdfAt's fixed terms on eight lanes: one BRDF on every lane
// (evalTotalsAvx2) or eight BRDFs (evalTotalsPackedAvx2). Derived constants
// (1 - m, 4 w.z, ...) are computed on the lanes with the scalar code's
// operations, so they round as there.
struct BrdfLanes {
  __m256 base[3], kd[3], w[3];
  __m256 s, m, ax, ay, lambdaW, ps, specPdfScale, da;
  __m256i a0;
  __m256 above, diffuse, specular;  // masks: w.z > 0, m < 1, the specular lobe on
};

// albedoAt(r, cosTheta) on eight lanes, each with its own row.
VSL_AVX2 __m256 albedoAt8(const BrdfLanes& k, __m256 cosTheta) {
  const float* E = albedoTable().E[0].data();  // rows of kTableMu, one after the other
  // As albedoAt: NaN reads row 0 (_mm256_max_ps returns its second operand then).
  __m256 fm = mul(_mm256_min_ps(splat(1), _mm256_max_ps(cosTheta, _mm256_setzero_ps())), splat(kTableMu - 1));
  __m256i m0 = _mm256_min_epi32(_mm256_cvttps_epi32(fm), _mm256_set1_epi32(kTableMu - 2));
  __m256 dm = sub(fm, _mm256_cvtepi32_ps(m0)), rdm = sub(splat(1), dm);
  const __m256i i00 = _mm256_add_epi32(_mm256_mullo_epi32(k.a0, _mm256_set1_epi32(kTableMu)), m0);
  const __m256i one = _mm256_set1_epi32(1), row = _mm256_set1_epi32(kTableMu);
  const __m256i i10 = _mm256_add_epi32(i00, row);
  __m256 e0 =
      add(mul(_mm256_i32gather_ps(E, i00, 4), rdm), mul(_mm256_i32gather_ps(E, _mm256_add_epi32(i00, one), 4), dm));
  __m256 e1 =
      add(mul(_mm256_i32gather_ps(E, i10, 4), rdm), mul(_mm256_i32gather_ps(E, _mm256_add_epi32(i10, one), 4), dm));
  return add(mul(e0, sub(splat(1), k.da)), mul(e1, k.da));
}

// schlickWeight(max(c, 0)) and GGX::lambda(wi) on eight lanes.
VSL_AVX2 __m256 schlick8(__m256 c) {
  __m256 m = clamp01(sub(splat(1), _mm256_max_ps(_mm256_setzero_ps(), c)));
  __m256 m2 = mul(m, m);
  return mul(mul(m2, m2), m);
}
VSL_AVX2 __m256 lambda8(const BrdfLanes& k, __m256 x, __m256 y, __m256 z) {
  __m256 z2 = mul(z, z);
  __m256 ax = mul(k.ax, x), ay = mul(k.ay, y);
  __m256 a2tan2 = div(add(mul(ax, ax), mul(ay, ay)), z2);
  __m256 l = mul(sub(_mm256_sqrt_ps(add(splat(1), a2tan2)), splat(1)), splat(0.5f));
  return _mm256_blendv_ps(splat(kInf), l, greater(z2, _mm256_setzero_ps()));
}

// The specular lobe of evalParts(wi, pdf) on eight lanes: adds its pdf term
// to pdf and returns the RGB value in spec (zero where the half vector is).
VSL_AVX2 void specular8(const BrdfLanes& k, __m256 x, __m256 y, __m256 z, __m256 spec[3], __m256& pdf) {
  __m256 hx = add(k.w[0], x), hy = add(k.w[1], y), hz = add(k.w[2], z);
  __m256 hl = _mm256_sqrt_ps(add(add(mul(hx, hx), mul(hy, hy)), mul(hz, hz)));
  const __m256 hok = greater(hl, _mm256_setzero_ps());
  __m256 inv = div(splat(1), hl);
  hx = mul(hx, inv);
  hy = mul(hy, inv);
  hz = mul(hz, inv);
  // GGX::D(h)
  __m256 ex = div(hx, k.ax), ey = div(hy, k.ay);
  __m256 e = add(add(mul(ex, ex), mul(ey, ey)), mul(hz, hz));
  __m256 D = div(splat(1), mul(mul(mul(mul(splat(kPi), k.ax), k.ay), e), e));
  D = where(greater(hz, _mm256_setzero_ps()), D);
  __m256 voh = add(add(mul(k.w[0], hx), mul(k.w[1], hy)), mul(k.w[2], hz));
  pdf = add(pdf, where(_mm256_and_ps(hok, greater(voh, _mm256_setzero_ps())), mul(k.specPdfScale, D)));
  // Fresnel blended between the dielectric and the metal; Smith's G2.
  __m256 w = schlick8(voh);
  __m256 Fd = mul(k.s, add(splat(kDielectricF0), mul(splat(1 - kDielectricF0), w)));
  __m256 Fdm = mul(Fd, sub(splat(1), k.m));
  __m256 G2 = div(splat(1), add(add(splat(1.0f), k.lambdaW), lambda8(k, x, y, z)));
  __m256 t = div(mul(D, G2), mul(mul(splat(4), k.w[2]), z));
  for (int c = 0; c < 3; ++c) {
    __m256 Fm = add(k.base[c], mul(sub(splat(1.0f), k.base[c]), w));
    spec[c] = where(hok, mul(add(Fdm, mul(Fm, k.m)), t));
  }
}

// evalParts(wi, pdf) on eight lanes, the lobes kept apart (zero where a
// lane's BrdfAt is below its surface or wi is).
VSL_AVX2 void evalParts8(const BrdfLanes& k, __m256 x, __m256 y, __m256 z, __m256 diff[3], __m256 spec[3],
                         __m256& pdf) {
  const __m256 up = _mm256_and_ps(k.above, greater(z, _mm256_setzero_ps()));
  for (int c = 0; c < 3; ++c) diff[c] = spec[c] = _mm256_setzero_ps();
  if (!none(k.diffuse)) {
    __m256 t = sub(splat(1), mul(k.s, albedoAt8(k, z)));
    for (int c = 0; c < 3; ++c) diff[c] = where(_mm256_and_ps(up, k.diffuse), mul(k.kd[c], t));
  }
  pdf = mul(sub(splat(1), k.ps), mul(z, splat(kInvPi)));
  if (!none(k.specular)) {
    __m256 specPdf = _mm256_setzero_ps();
    specular8(k, x, y, z, spec, specPdf);
    for (int c = 0; c < 3; ++c) spec[c] = where(_mm256_and_ps(up, k.specular), spec[c]);
    pdf = _mm256_blendv_ps(pdf, add(pdf, specPdf), k.specular);
  }
  pdf = where(up, pdf);
}

// evalParts(wi, pdf).total() on eight lanes.
VSL_AVX2 void evalTotals8(const BrdfLanes& k, __m256 x, __m256 y, __m256 z, __m256 f[3], __m256& pdf) {
  __m256 diff[3], spec[3];
  evalParts8(k, x, y, z, diff, spec, pdf);
  for (int c = 0; c < 3; ++c) f[c] = add(diff[c], spec[c]);
}

// The lanes of packed BRDF terms (pack()'s layout, one vector per term);
// diffuseOnly turns every lane's specular lobe off.
VSL_AVX2 BrdfLanes lanesOf(const __m256 v[BrdfAt::kPackedFloats], bool diffuseOnly) {
  BrdfLanes k;
  for (int c = 0; c < 3; ++c) {
    k.base[c] = v[kBase + c];
    k.kd[c] = v[kKd + c];
    k.w[c] = v[kW + c];
  }
  k.s = v[kS];
  k.m = v[kM];
  k.ax = v[kAx];
  k.ay = v[kAy];
  k.lambdaW = v[kLambdaW];
  k.ps = v[kPs];
  k.specPdfScale = v[kSpecPdfScale];
  k.da = v[kDa];
  k.a0 = _mm256_castps_si256(v[kA0]);
  k.above = v[kAbove];
  k.diffuse = v[kDiffuse];
  k.specular = diffuseOnly ? _mm256_setzero_ps() : v[kSpecular];
  return k;
}

// One BRDF's packed terms on every lane.
VSL_AVX2 BrdfLanes lanesOfOne(const BrdfAt& f) {
  float terms[BrdfAt::kPackedFloats];
  f.pack(terms);
  __m256 v[BrdfAt::kPackedFloats];
  for (int i = 0; i < BrdfAt::kPackedFloats; ++i) v[i] = splat(terms[i]);
  return lanesOf(v, false);
}

}  // namespace

VSL_AVX2 void BrdfAt::evalTotalsAvx2(int n, const float* wx, const float* wy, const float* wz, float* const f[3],
                                     float* pdf) const {
  if (coat_) return evalTotalsScalar(n, wx, wy, wz, f, pdf);
  if (!above_) {
    for (int i = 0; i < n; ++i) {
      f[0][i] = f[1][i] = f[2][i] = 0;
      if (pdf) pdf[i] = 0;
    }
    return;
  }
  const BrdfLanes k = lanesOfOne(*this);
  for (int i0 = 0; i0 < n; i0 += 8) {
    const int m = std::min(8, n - i0);
    // Lanes past n get wi.z = 0, which evaluates to zero.
    __m256 fv[3], pv;
    evalTotals8(k, loadFirst(wx + i0, m), loadFirst(wy + i0, m), loadFirst(wz + i0, m), fv, pv);
    for (int c = 0; c < 3; ++c) storeFirst(f[c] + i0, fv[c], m);
    if (pdf) storeFirst(pdf + i0, pv, m);
  }
}

void BrdfAt::evalPartsMany(int n, const float* wx, const float* wy, const float* wz, float* const diffuse[3],
                           float* const specular[3]) const {
  if (useSimd(n) && !coat_) return evalPartsManyAvx2(n, wx, wy, wz, diffuse, specular);
  for (int i = 0; i < n; ++i) {
    const Parts p = evalParts(Vec3(wx[i], wy[i], wz[i]));
    for (int c = 0; c < 3; ++c) {
      diffuse[c][i] = p.diffuse[c];
      specular[c][i] = p.specular[c];
    }
  }
}

VSL_AVX2 void BrdfAt::evalPartsManyAvx2(int n, const float* wx, const float* wy, const float* wz,
                                        float* const diffuse[3], float* const specular[3]) const {
  if (coat_) {
    for (int i = 0; i < n; ++i) {
      const Parts p = evalParts(Vec3(wx[i], wy[i], wz[i]));
      for (int c = 0; c < 3; ++c) {
        diffuse[c][i] = p.diffuse[c];
        specular[c][i] = p.specular[c];
      }
    }
    return;
  }
  const BrdfLanes k = lanesOfOne(*this);
  for (int i0 = 0; i0 < n; i0 += 8) {
    const int m = std::min(8, n - i0);
    __m256 dv[3], sv[3], pv;
    evalParts8(k, loadFirst(wx + i0, m), loadFirst(wy + i0, m), loadFirst(wz + i0, m), dv, sv, pv);
    for (int c = 0; c < 3; ++c) {
      storeFirst(diffuse[c] + i0, dv[c], m);
      storeFirst(specular[c] + i0, sv[c], m);
    }
  }
}

namespace {
// Rows r[0..7] (eight floats each) transposed: out[j] holds float j of every row.
VSL_AVX2 void transpose8(const __m256 r[8], __m256 out[8]) {
  const __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
  const __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
  const __m256 t4 = _mm256_unpacklo_ps(r[4], r[5]), t5 = _mm256_unpackhi_ps(r[4], r[5]);
  const __m256 t6 = _mm256_unpacklo_ps(r[6], r[7]), t7 = _mm256_unpackhi_ps(r[6], r[7]);
  const __m256 u0 = _mm256_shuffle_ps(t0, t2, 0x44), u1 = _mm256_shuffle_ps(t0, t2, 0xee);
  const __m256 u2 = _mm256_shuffle_ps(t1, t3, 0x44), u3 = _mm256_shuffle_ps(t1, t3, 0xee);
  const __m256 u4 = _mm256_shuffle_ps(t4, t6, 0x44), u5 = _mm256_shuffle_ps(t4, t6, 0xee);
  const __m256 u6 = _mm256_shuffle_ps(t5, t7, 0x44), u7 = _mm256_shuffle_ps(t5, t7, 0xee);
  out[0] = _mm256_permute2f128_ps(u0, u4, 0x20);
  out[1] = _mm256_permute2f128_ps(u1, u5, 0x20);
  out[2] = _mm256_permute2f128_ps(u2, u6, 0x20);
  out[3] = _mm256_permute2f128_ps(u3, u7, 0x20);
  out[4] = _mm256_permute2f128_ps(u0, u4, 0x31);
  out[5] = _mm256_permute2f128_ps(u1, u5, 0x31);
  out[6] = _mm256_permute2f128_ps(u2, u6, 0x31);
  out[7] = _mm256_permute2f128_ps(u3, u7, 0x31);
}

// The m (<= 8) packed records of a group transposed to lanes, field by field
// (lanes past m read a record of zeros: below its surface). False, with
// nothing loaded, where a record has a clear coat: the group then takes the
// scalar form (the lanes model the base alone).
VSL_AVX2 bool loadPackedGroup(const float* const* packed, int m, __m256 v[BrdfAt::kPackedFloats]) {
  static const float kZero[BrdfAt::kPackedFloats] = {};
  for (int j = 0; j < m; ++j)
    if (packed[j][kClearcoat] > 0) return false;
  for (int g = 0; g < BrdfAt::kPackedFloats / 8; ++g) {
    __m256 rows[8];
    for (int j = 0; j < 8; ++j) rows[j] = _mm256_loadu_ps((j < m ? packed[j] : kZero) + 8 * g);
    transpose8(rows, v + 8 * g);
  }
  return true;
}
}  // namespace

VSL_AVX2 void BrdfAt::evalTotalsPackedAvx2(int n, const float* const* packed, const float* wx, const float* wy,
                                           const float* wz, bool diffuseOnly, float* const f[3]) {
  for (int i0 = 0; i0 < n; i0 += 8) {
    const int m = std::min(8, n - i0);
    __m256 v[kPackedFloats];
    if (!loadPackedGroup(packed + i0, m, v)) {
      float* const fi[3] = {f[0] + i0, f[1] + i0, f[2] + i0};
      evalTotalsPackedScalar(m, packed + i0, wx + i0, wy + i0, wz + i0, diffuseOnly, fi);
      continue;
    }
    const BrdfLanes k = lanesOf(v, diffuseOnly);
    __m256 fv[3], pv;
    evalTotals8(k, loadFirst(wx + i0, m), loadFirst(wy + i0, m), loadFirst(wz + i0, m), fv, pv);
    for (int c = 0; c < 3; ++c) storeFirst(f[c] + i0, fv[c], m);
  }
}

void BrdfAt::evalPartsPacked(int n, const float* const* packed, const float* wx, const float* wy, const float* wz,
                             float* const diffuse[3], float* const specular[3]) {
  if (useSimd(n)) return evalPartsPackedAvx2(n, packed, wx, wy, wz, diffuse, specular);
  evalPartsPackedScalar(n, packed, wx, wy, wz, diffuse, specular);
}

void BrdfAt::evalPartsPackedScalar(int n, const float* const* packed, const float* wx, const float* wy, const float* wz,
                                   float* const diffuse[3], float* const specular[3]) {
  for (int i = 0; i < n; ++i) {
    const Parts p = unpack(packed[i]).evalParts(Vec3(wx[i], wy[i], wz[i]));
    for (int c = 0; c < 3; ++c) {
      diffuse[c][i] = p.diffuse[c];
      specular[c][i] = p.specular[c];
    }
  }
}

// As evalTotalsPackedAvx2, the lobes kept apart.
VSL_AVX2 void BrdfAt::evalPartsPackedAvx2(int n, const float* const* packed, const float* wx, const float* wy,
                                          const float* wz, float* const diffuse[3], float* const specular[3]) {
  for (int i0 = 0; i0 < n; i0 += 8) {
    const int m = std::min(8, n - i0);
    __m256 v[kPackedFloats];
    if (!loadPackedGroup(packed + i0, m, v)) {
      float* const di[3] = {diffuse[0] + i0, diffuse[1] + i0, diffuse[2] + i0};
      float* const si[3] = {specular[0] + i0, specular[1] + i0, specular[2] + i0};
      evalPartsPackedScalar(m, packed + i0, wx + i0, wy + i0, wz + i0, di, si);
      continue;
    }
    const BrdfLanes k = lanesOf(v, false);
    __m256 dv[3], sv[3], pv;
    evalParts8(k, loadFirst(wx + i0, m), loadFirst(wy + i0, m), loadFirst(wz + i0, m), dv, sv, pv);
    for (int c = 0; c < 3; ++c) {
      storeFirst(diffuse[c] + i0, dv[c], m);
      storeFirst(specular[c] + i0, sv[c], m);
    }
  }
}

// ---- Texture --------------------------------------------------------------

TextureTransform TextureTransform::make(Vec2 offset, float rotation, Vec2 scale, int texCoord) {
  TextureTransform t;
  t.offset_ = offset;
  t.rotation_ = rotation;
  t.scale_ = scale;
  t.texCoord_ = texCoord;
  // R S with R = [cos -sin; sin cos] (KHR_texture_transform README, its
  // column-major mat3 written out by rows) and S = diag(sx, sy).
  const float c = std::cos(rotation), s = std::sin(rotation);
  t.m_[0] = c * scale.x;
  t.m_[1] = -s * scale.y;
  t.m_[2] = s * scale.x;
  t.m_[3] = c * scale.y;
  t.identity_ = offset.x == 0 && offset.y == 0 && rotation == 0 && scale.x == 1 && scale.y == 1;
  return t;
}

static inline float srgbToLinear(float v) { return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f); }

void Texture::lookup(Vec2 uv, bool srgb, float out[4]) const {
  if (width <= 0 || height <= 0 || !std::isfinite(uv.x) || !std::isfinite(uv.y)) {
    out[0] = out[1] = out[2] = out[3] = 1;
    return;
  }
  float x = (uv.x - std::floor(uv.x)) * width - 0.5f;
  float y = (uv.y - std::floor(uv.y)) * height - 0.5f;
  int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  float dx = x - x0, dy = y - y0;
  auto wrap = [](int v, int n) { return ((v % n) + n) % n; };
  for (int c = 0; c < 4; ++c) out[c] = 0;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      float w = (i ? dx : 1 - dx) * (j ? dy : 1 - dy);
      const float* p = &rgba[(size_t(wrap(y0 + j, height)) * width + wrap(x0 + i, width)) * 4];
      for (int c = 0; c < 4; ++c) out[c] += w * p[c];
    }
  if (srgb)
    for (int c = 0; c < 3; ++c) out[c] = srgbToLinear(out[c]);
}

// sampleDirection on eight lanes: both lobes' directions computed, one kept
// per lane, with the scalar operations in their order (sampleCosineHemisphere,
// GGX::sampleVisibleNormal and reflect, as written in math.h and sampling.cpp).
VSL_AVX2 void BrdfAt::sampleDirectionsAvx2(int n, const float* const u[3], float* const wi[3], int32_t* ok) const {
  if (coat_) return sampleDirectionsScalar(n, u, wi, ok);
  if (!above_) {
    for (int i = 0; i < n; ++i) {
      wi[0][i] = wi[1][i] = wi[2][i] = 0;
      ok[i] = 0;
    }
    return;
  }
  const GGX::VisibleFrame v = b_.ggx.visibleNormalFrame(w_);
  const __m256 one = splat(1.0f), zero = _mm256_setzero_ps(), signBit = splat(-0.0f);
  for (int i0 = 0; i0 < n; i0 += 8) {
    const int m = std::min(8, n - i0);
    const __m256 u1 = loadFirst(u[0] + i0, m), ux = loadFirst(u[1] + i0, m), uy = loadFirst(u[2] + i0, m);
    const __m256 specular = less(u1, splat(ps_));
    const int specularLanes = _mm256_movemask_ps(specular);
    __m256 sx = zero, sy = zero, sz = zero, dx = zero, dy = zero, dz = zero;
    if (specularLanes != 0) {
      // The specular lobe: a visible normal, then the mirror of w about it.
      __m256 sinPhi, cosPhi;
      sinCosTwoPi8(uy, sinPhi, cosPhi);
      const __m256 r = _mm256_sqrt_ps(ux);
      const __m256 p1 = mul(r, cosPhi);
      const __m256 vs = splat(v.s);
      __m256 p2 = mul(r, sinPhi);
      p2 = add(mul(sub(one, vs), safeSqrt8(sub(one, mul(p1, p1)))), mul(vs, p2));
      const __m256 q = safeSqrt8(sub(sub(one, mul(p1, p1)), mul(p2, p2)));
      const __m256 nx = add(add(mul(splat(v.t1.x), p1), mul(splat(v.t2.x), p2)), mul(splat(v.vh.x), q));
      const __m256 ny = add(add(mul(splat(v.t1.y), p1), mul(splat(v.t2.y), p2)), mul(splat(v.vh.y), q));
      const __m256 nz = add(add(mul(splat(v.t1.z), p1), mul(splat(v.t2.z), p2)), mul(splat(v.vh.z), q));
      // std::max(1e-7f, nz) is _mm256_max_ps(nz, 1e-7f), NaN included.
      __m256 hx = mul(splat(b_.ggx.ax), nx), hy = mul(splat(b_.ggx.ay), ny), hz = _mm256_max_ps(nz, splat(1e-7f));
      const __m256 len = _mm256_sqrt_ps(add(add(mul(hx, hx), mul(hy, hy)), mul(hz, hz)));
      const __m256 inv = div(one, len), lenOk = greater(len, zero);
      hx = where(lenOk, mul(hx, inv));
      hy = where(lenOk, mul(hy, inv));
      hz = where(lenOk, mul(hz, inv));
      const __m256 wx = splat(w_.x), wy = splat(w_.y), wz = splat(w_.z);
      const __m256 twoDot = mul(splat(2.0f), add(add(mul(wx, hx), mul(wy, hy)), mul(wz, hz)));
      sx = sub(mul(twoDot, hx), wx);
      sy = sub(mul(twoDot, hy), wy);
      sz = sub(mul(twoDot, hz), wz);
    }
    if (specularLanes != 0xff) {
      // The diffuse lobe: the concentric disk lifted to the hemisphere.
      const __m256 ox = sub(mul(splat(2.0f), ux), one), oy = sub(mul(splat(2.0f), uy), one);
      const __m256 wide = greater(_mm256_andnot_ps(signBit, ox), _mm256_andnot_ps(signBit, oy));
      const __m256 centre = both(_mm256_cmp_ps(ox, zero, _CMP_EQ_OQ), _mm256_cmp_ps(oy, zero, _CMP_EQ_OQ));
      __m256 sa, ca;
      sinCosQuarterPi8(div(select(wide, oy, ox), select(wide, ox, oy)), sa, ca);
      dx = _mm256_andnot_ps(centre, select(wide, mul(ox, ca), mul(oy, sa)));
      dy = _mm256_andnot_ps(centre, select(wide, mul(ox, sa), mul(oy, ca)));
      dz = safeSqrt8(sub(sub(one, mul(dx, dx)), mul(dy, dy)));
    }
    const __m256 x = select(specular, sx, dx), y = select(specular, sy, dy), z = select(specular, sz, dz);
    storeFirst(wi[0] + i0, x, m);
    storeFirst(wi[1] + i0, y, m);
    storeFirst(wi[2] + i0, z, m);
    storeFirst(reinterpret_cast<float*>(ok + i0), greater(z, zero), m);
  }
}

}  // namespace vsl
