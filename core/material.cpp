#include "core/material.h"

#include <array>
#include <mutex>

#include "core/sampling.h"

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

Vec3 GGX::sampleVisibleNormal(const Vec3& wo, Vec2 u) const {
  // Stretch the view vector to the unit-roughness configuration.
  Vec3 vh = normalize(Vec3(ax * wo.x, ay * wo.y, wo.z));
  // Orthonormal basis around vh (T1 is horizontal).
  float lensq = vh.x * vh.x + vh.y * vh.y;
  Vec3 t1 = lensq > 1e-14f ? Vec3(-vh.y, vh.x, 0) / std::sqrt(lensq) : Vec3(1, 0, 0);
  Vec3 t2 = cross(vh, t1);
  // Sample the projected area of the hemisphere: a disk warped toward vh.
  float r = std::sqrt(u.x), phi = 2 * kPi * u.y;
  float p1 = r * std::cos(phi), p2 = r * std::sin(phi);
  float s = 0.5f * (1.0f + vh.z);
  p2 = (1.0f - s) * safeSqrt(1.0f - p1 * p1) + s * p2;
  Vec3 nh = p1 * t1 + p2 * t2 + safeSqrt(1.0f - p1 * p1 - p2 * p2) * vh;
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

  AlbedoTable() {
    for (int ia = 0; ia < kTableAlpha; ++ia) {
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
    }
  }
};

const AlbedoTable& albedoTable() {
  static const AlbedoTable table;  // thread-safe initialisation (C++11 statics)
  return table;
}

AlbedoRow albedoRow(float alpha) {
  float fa = clamp(std::sqrt(std::max(alpha, 0.0f)), 0.0f, 1.0f) * (kTableAlpha - 1);
  int a0 = std::min(int(fa), kTableAlpha - 2);
  return {a0, fa - a0};
}

float albedoAt(AlbedoRow r, float cosTheta) {
  const AlbedoTable& t = albedoTable();
  float fm = clamp(cosTheta, 0.0f, 1.0f) * (kTableMu - 1);
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

Vec3 Brdf::evalDiffuse(const Vec3& wo, const Vec3& wi) const { return BrdfAt(*this, wo).evalParts(wi).diffuse; }

Vec3 Brdf::eval(const Vec3& wo, const Vec3& wi) const { return BrdfAt(*this, wo).eval(wi); }

float Brdf::specularProbability(const Vec3& wo) const { return BrdfAt(*this, wo).specularProbability(); }

float Brdf::pdf(const Vec3& wo, const Vec3& wi) const { return BrdfAt(*this, wo).pdf(wi); }

std::optional<BrdfSample> Brdf::sample(const Vec3& wo, float u1, Vec2 u2) const {
  return BrdfAt(*this, wo).sample(u1, u2);
}

// ---- BrdfAt ---------------------------------------------------------------

BrdfAt::BrdfAt(const Brdf& brdf, const Vec3& w) : b_(brdf), w_(w), above_(w.z > 0) {
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
  }
  // Visible-normal sampling: pdf(wi) = G1(w) D(h) / (4 w.z).
  specPdfScale_ = ps_ / ((1 + lambdaW_) * 4 * w.z);
  pdfBound_ = (1 - ps_) * kInvPi + specPdfScale_ / (kPi * b_.ggx.ax * b_.ggx.ay);
}

BrdfAt BrdfAt::diffuseLobe() const {
  BrdfAt d = *this;
  d.specularOn_ = false;
  d.ps_ = 0;
  d.specPdfScale_ = 0;
  d.pdfBound_ = kInvPi;
  return d;
}

BrdfAt BrdfAt::specularLobe() const {
  BrdfAt s = *this;
  s.kd_ = Vec3(0.0f);
  if (!above_) return s;
  s.ps_ = 1;
  s.specPdfScale_ = 1.0f / ((1 + lambdaW_) * 4 * w_.z);
  s.pdfBound_ = s.specPdfScale_ / (kPi * b_.ggx.ax * b_.ggx.ay);
  return s;
}

BrdfAt::Parts BrdfAt::evalParts(const Vec3& wi, float* pdfOut) const {
  Parts p{Vec3(0.0f), Vec3(0.0f)};
  if (pdfOut) *pdfOut = 0;
  if (!above_ || wi.z <= 0) return p;
  const float s = b_.specularWeight, m = b_.metallic;
  if (m < 1) p.diffuse = kd_ * (1 - s * albedoAt(row_, wi.z));
  if (pdfOut) *pdfOut = (1 - ps_) * cosineHemispherePdf(wi.z);
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
  if (!above_ || wi.z <= 0) return 0;
  float pdf = (1 - ps_) * cosineHemispherePdf(wi.z);
  if (!specularOn_) return pdf;
  Vec3 h = normalize(w_ + wi);
  if (dot(w_, h) > 0) pdf += specPdfScale_ * b_.ggx.D(h);
  return pdf;
}

std::optional<BrdfSample> BrdfAt::sample(float u1, Vec2 u2) const {
  if (!above_) return std::nullopt;
  Vec3 wi;
  bool spec = u1 < ps_;
  if (spec) {
    Vec3 h = b_.ggx.sampleVisibleNormal(w_, u2);
    wi = reflect(w_, h);
  } else {
    wi = sampleCosineHemisphere(u2);
  }
  if (wi.z <= 0) return std::nullopt;
  float p = 0;
  Vec3 f = evalParts(wi, &p).total();
  if (!(p > 0) || !std::isfinite(p)) return std::nullopt;
  return BrdfSample{wi, f, p, spec};
}

// ---- Texture --------------------------------------------------------------

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

}  // namespace vsl
