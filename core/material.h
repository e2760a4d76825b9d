// The glTF 2.0 metallic-roughness BRDF: a Lambertian diffuse lobe plus a GGX
// microfacet specular lobe with height-correlated Smith masking-shadowing and
// Schlick Fresnel (glTF 2.0 specification, Appendix B), with anisotropic
// alphas from KHR_materials_anisotropy.
//
// Conventions
// - All directions are in the local shading frame: +z is the shading normal,
//   +x the anisotropy direction. wo points toward the viewer, wi toward the
//   light; both are unit vectors.
// - eval() returns f_r (1/sr) without the cosine. pdf() is with respect to
//   solid angle around wi. sample() returns f, pdf and wi consistent with
//   eval() and pdf() (so f*cos/pdf is the usual weight).
// - Reflection only: wo or wi below the surface gives zero.
//
// One deliberate deviation from the glTF appendix. The appendix weights the
// diffuse lobe by (1 - F(v.h)), which is not energy-conserving: a smooth white
// dielectric seen at grazing angles reflects ~1.8x the incident energy. We use
// the reciprocal albedo-scaling form (Kelemen & Szirmay-Kalos 2001; Kulla &
// Conty 2017):  f_diffuse = c/pi * (1 - E(wo)) (1 - E(wi)) / (1 - E_avg),
// where E is the directional albedo of the dielectric specular lobe (F0 = 0.04),
// tabulated once. Then albedo = E(wo) + c (1 - E(wo)) <= 1 and reciprocity
// holds. For anisotropic dielectrics E is looked up at alpha = sqrt(ax*ay).
//
// Clear coat (KHR_materials_clearcoat, its README's "Implementation" and
// the glTF BRDF appendix's fresnel_coat): an isotropic dielectric GGX lobe
// (F0 = 0.04, alpha_c = clearcoatRoughness^2, its own normal) over the base,
//   f = cc f_coat(wo, wi) + (1 - cc E_c(wo)) (1 - cc E_c(wi)) f_base(wo, wi),
// cc the clearcoat factor. The coat lobe is the specular lobe above with
// F0 = 0.04 and specularWeight 1. The README attenuates the base once, by
// (1 - cc F_coat(n.v)). We attenuate it on the way in and on the way out,
// by the coat's directional albedo E_c (its Fresnel averaged over the
// microfacets, the table above at alpha_c), in the same spirit as the
// diffuse lobe's albedo scaling (Weidlich & Wilkie 2007, "Arbitrarily
// layered micro-facet surfaces", take transmission at both interfaces).
// This keeps the BRDF reciprocal, which light tracing needs (Veach 1997,
// section 5.3), and the albedo cc E_c(wo) + (1 - cc E_c(wo)) a_base <= 1
// (docs/REFERENCE.md, "Clear coat").
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/math.h"

namespace vsl {

// Smallest GGX alpha we evaluate; alpha = roughness^2 is clamped to this so
// that roughness -> 0 stays finite (D peaks at 1/(pi alpha^2) ~ 3e7).
constexpr float kMinAlpha = 1e-4f;
// Below this alpha (both axes) a lobe counts as near-specular: eye paths
// continue through such surfaces in the many-light gatherers.
constexpr float kNearSpecularAlpha = 0.01f;
// Dielectric reflectance at normal incidence (IOR 1.5), as in glTF.
constexpr float kDielectricF0 = 0.04f;

// GGX microfacet distribution with anisotropic alphas, as a triplet:
// D(h), visible-normal sampling (Heitz 2018) and its pdf.
struct GGX {
  float ax = 1, ay = 1;
  float D(const Vec3& h) const;
  float lambda(const Vec3& w) const;
  float G1(const Vec3& w) const { return 1.0f / (1.0f + lambda(w)); }
  float G2(const Vec3& wo, const Vec3& wi) const { return 1.0f / (1.0f + lambda(wo) + lambda(wi)); }
  // Samples a visible microfacet normal for wo (wo.z > 0).
  // pdf(h) = G1(wo) max(0, wo.h) D(h) / wo.z (solid angle about h).
  Vec3 sampleVisibleNormal(const Vec3& wo, Vec2 u) const { return sampleVisibleNormal(visibleNormalFrame(wo), u); }
  // What the sampling computes from wo alone: the stretched view vector vh,
  // a basis t1, t2 about it and the warp s. Many samples for one wo share it.
  struct VisibleFrame {
    Vec3 vh, t1, t2;
    float s;
  };
  VisibleFrame visibleNormalFrame(const Vec3& wo) const;
  Vec3 sampleVisibleNormal(const VisibleFrame& v, Vec2 u) const;
  float visibleNormalPdf(const Vec3& wo, const Vec3& h) const;
};

// Directional albedo of the dielectric (F0 = 0.04) GGX lobe, E(cos, alpha),
// and its cosine-weighted average E_avg(alpha). Tabulated on first use.
float dielectricSpecularAlbedo(float cosTheta, float alpha);
float dielectricSpecularAlbedoAverage(float alpha);

struct BrdfSample {
  Vec3 wi;
  Vec3 f;     // f_r(wo, wi)
  float pdf;  // solid angle
  bool specularLobe;
};

// The BRDF at one shading point, with textures already applied.
struct Brdf {
  Vec3 baseColor{1.0f};
  float metallic = 0;
  // KHR_materials_specular specularFactor: scales the dielectric Fresnel
  // (0 = a pure Lambertian dielectric, as the furnace scene uses).
  float specularWeight = 1;
  GGX ggx;
  // KHR_materials_clearcoat: the coat's weight cc in [0,1] (0: no coat),
  // its isotropic GGX (alpha_c = clearcoatRoughness^2) and its normal in
  // this BRDF's local frame (+z unless clearcoatNormalTexture or a base
  // normal map bends one of the two).
  float clearcoat = 0;
  GGX coat;
  Vec3 coatNormal{0, 0, 1};

  // Builds the BRDF from glTF parameters. roughness in [0,1]; anisotropy
  // strength in [0,1] stretches alpha along +x: at = mix(a, 1, s^2), ab = a.
  static Brdf fromGltf(const Vec3& baseColor, float metallic, float roughness, float anisotropy,
                       float specularWeight = 1.0f);
  // This BRDF under a clear coat of weight `clearcoat` and roughness
  // `roughness` (both clamped to [0,1]) with unit normal n (local frame,
  // n.z > 0; anything else means +z).
  Brdf withClearcoat(float weight, float roughness, const Vec3& n = Vec3(0, 0, 1)) const;
  bool hasCoat() const { return clearcoat > 0; }

  Vec3 eval(const Vec3& wo, const Vec3& wi) const;
  // The diffuse lobe alone (used by diffuse-only VPL emission).
  Vec3 evalDiffuse(const Vec3& wo, const Vec3& wi) const;
  float pdf(const Vec3& wo, const Vec3& wi) const;
  // u1 picks the lobe, u2 samples it. Empty when wo is below the surface or
  // the sampled direction is.
  std::optional<BrdfSample> sample(const Vec3& wo, float u1, Vec2 u2) const;
  // Probability that sample() picks the specular lobe.
  float specularProbability(const Vec3& wo) const;
  bool isNearSpecular() const { return isNarrowMetal(kNearSpecularAlpha); }
  // A pure metal whose lobe is narrower than alpha along both axes.
  // A coat counts as narrow too when it is narrower than alpha.
  bool isNarrowMetal(float alpha) const {
    return ggx.ax < alpha && ggx.ay < alpha && metallic >= 1.0f && (!hasCoat() || coat.ax < alpha);
  }
  // The base's specular lobe or the coat is narrower than alpha on both axes.
  bool hasNarrowLobe(float alpha) const { return std::max(ggx.ax, ggx.ay) < alpha || (hasCoat() && coat.ax < alpha); }
  // The narrowest GGX alpha of the specular lobes (base and coat).
  float minAlpha() const { return hasCoat() ? std::min({ggx.ax, ggx.ay, coat.ax}) : std::min(ggx.ax, ggx.ay); }
  // This BRDF with its GGX lobes (base and coat) at least alpha wide on each axis.
  Brdf widened(float alpha) const {
    Brdf b = *this;
    b.ggx.ax = std::max(b.ggx.ax, alpha);
    b.ggx.ay = std::max(b.ggx.ay, alpha);
    b.coat.ax = b.coat.ay = std::max(b.coat.ax, alpha);
    return b;
  }
  // Diffuse reflectance rho_d (the Lambertian part's albedo before the
  // energy-compensation factors).
  Vec3 diffuseReflectance() const { return baseColor * (1.0f - metallic); }
};

// Builds the dielectric albedo table now. It is otherwise built at its first
// use (about 0.1 s), and that would be charged to whatever timed stage came
// first (a sweep's first run, a light tracing time).
void prepareMaterialTables();

// Where the albedo table is read for one alpha (row and interpolation weight).
struct AlbedoRow {
  int a0 = 0;
  float da = 0;
};

// A BRDF with its first direction fixed: the viewer at a gather point, or the
// incoming direction at a virtual light. Every term that depends on that
// direction alone (the albedo-scaling factor, Smith's lambda, the lobe
// selection probability) is computed once, so evaluating many second
// directions (one per virtual light, per cone sample) does not repeat it.
// Brdf's eval/pdf/sample are this class with a one-off fixed direction, so
// the two always agree.
class BrdfAt {
 public:
  BrdfAt() = default;
  BrdfAt(const Brdf& brdf, const Vec3& w);

  const Brdf& brdf() const { return b_; }
  const Vec3& w() const { return w_; }

  // This BRDF restricted to one lobe: eval, pdf and sample then see only the
  // diffuse or only the specular lobe, consistently (the two restrictions
  // sum to the full BRDF). Used to split a gather point by lobe.
  BrdfAt diffuseLobe() const;
  BrdfAt specularLobe() const;

  struct Parts {
    Vec3 diffuse, specular;
    Vec3 total() const { return diffuse + specular; }
  };
  // f_r(w, wi) split into its diffuse and specular lobes; with pdfOut, also
  // pdf(wi) (sharing the half vector and D).
  Parts evalParts(const Vec3& wi, float* pdfOut = nullptr) const;
  Vec3 eval(const Vec3& wi) const { return evalParts(wi).total(); }
  // evalParts(wi, pdf).total() for n directions at once, structure of arrays
  // (local frame): f[0..2][i] the RGB value and, with pdf, pdf[i]. The AVX2
  // form (evalTotalsAvx2, only where simdAvailable()) repeats the scalar
  // arithmetic operation for operation without fused multiply-adds, so the
  // two agree bit for bit; evalTotals picks it when the CPU has AVX2 and n >= 4.
  void evalTotals(int n, const float* wx, const float* wy, const float* wz, float* const f[3], float* pdf) const;
  void evalTotalsScalar(int n, const float* wx, const float* wy, const float* wz, float* const f[3], float* pdf) const;
  void evalTotalsAvx2(int n, const float* wx, const float* wy, const float* wz, float* const f[3], float* pdf) const;
  // evalParts(w_i) for n directions (local frame), the lobes kept apart:
  // diffuse[c][i] and specular[c][i]. The AVX2 form (call it only where
  // simdAvailable(); evalPartsMany picks it there for n >= 4) agrees with
  // evalParts bit for bit.
  void evalPartsMany(int n, const float* wx, const float* wy, const float* wz, float* const diffuse[3],
                     float* const specular[3]) const;
  void evalPartsManyAvx2(int n, const float* wx, const float* wy, const float* wz, float* const diffuse[3],
                         float* const specular[3]) const;
  // Many BRDFs, each at its own direction (local frames), in one call:
  // f[c][i] = the packed BRDF i's evalParts(w_i).total() (diffuseOnly:
  // .diffuse), the BRDFs kept packed (pack(): kPackedFloats floats each). The
  // AVX2 form reads eight at a time by transposing rows of eight floats, and
  // agrees with the scalar one bit for bit, as evalTotals does.
  // The block forms (evalTotals, evalPartsMany, sampleDirections and the
  // packed ones) run the scalar code for a coated BRDF: the AVX2 forms model
  // the base alone (docs/REFERENCE.md, "Clear coat").
  static constexpr int kPackedFloats = 24;
  void pack(float* out) const;
  static BrdfAt unpack(const float* packed);
  static void evalTotalsPacked(int n, const float* const* packed, const float* wx, const float* wy, const float* wz,
                               bool diffuseOnly, float* const f[3]);
  static void evalTotalsPackedScalar(int n, const float* const* packed, const float* wx, const float* wy,
                                     const float* wz, bool diffuseOnly, float* const f[3]);
  static void evalTotalsPackedAvx2(int n, const float* const* packed, const float* wx, const float* wy, const float* wz,
                                   bool diffuseOnly, float* const f[3]);
  // evalTotalsPacked with the lobes kept apart: diffuse[c][i] and
  // specular[c][i] are the packed BRDF i's evalParts(w_i), bit for bit (the
  // AVX2 form, where simdAvailable(), as evalTotalsPackedAvx2).
  static void evalPartsPacked(int n, const float* const* packed, const float* wx, const float* wy, const float* wz,
                              float* const diffuse[3], float* const specular[3]);
  static void evalPartsPackedScalar(int n, const float* const* packed, const float* wx, const float* wy,
                                    const float* wz, float* const diffuse[3], float* const specular[3]);
  static void evalPartsPackedAvx2(int n, const float* const* packed, const float* wx, const float* wy, const float* wz,
                                  float* const diffuse[3], float* const specular[3]);
  float pdf(const Vec3& wi) const;
  std::optional<BrdfSample> sample(float u1, Vec2 u2) const;
  // The direction half of sample(): false when wi would be below the surface.
  // sample() is this, then evalParts(wi, &pdf) and a check that the pdf is
  // positive and finite (callers that evaluate in blocks do those later).
  bool sampleDirection(float u1, Vec2 u2, Vec3& wi, bool& specular) const;
  // sampleDirection for n draws (u[0] the lobe's, u[1] and u[2] the
  // direction's uniforms): wi[0..2][i] the direction, ok[i] -1 where it
  // succeeded and 0 where not. The AVX2 form (where simdAvailable() and n >= 4)
  // repeats the scalar operations in order and gives the same bits.
  void sampleDirections(int n, const float* const u[3], float* const wi[3], int32_t* ok) const;
  void sampleDirectionsScalar(int n, const float* const u[3], float* const wi[3], int32_t* ok) const;
  void sampleDirectionsAvx2(int n, const float* const u[3], float* const wi[3], int32_t* ok) const;
  // The probability that sample() picks a specular lobe (base or coat).
  float specularProbability() const { return coat_ ? pc_ + (1 - pc_) * ps_ : ps_; }
  // The probability that sample() picks the coat's lobe (0 without one).
  float coatProbability() const { return coat_ && specularOn_ ? pc_ : 0.0f; }
  // False for a BRDF restricted to its diffuse lobe (diffuseLobe()).
  bool specularOn() const { return specularOn_; }
  // The BRDF has a clear coat (its lobe is part of the specular lobe).
  bool coated() const { return coat_; }
  // The diffuse lobe's largest value: evalParts(wi).diffuse <= kd() for every
  // wi (the lobe is kd (1 - s E(wi)), core/material.cpp).
  const Vec3& kd() const { return kd_; }
  // An upper bound of pdf(wi) over all directions wi.
  float pdfBound() const { return pdfBound_; }

 private:
  Brdf b_;
  Vec3 w_{0, 0, 1};
  Vec3 kd_{0.0f};  // diffuse lobe divided by (1 - s E(wi))
  float lambdaW_ = 0, ps_ = 0, specPdfScale_ = 0, pdfBound_ = 0;
  AlbedoRow row_;
  bool above_ = false;      // w.z > 0
  bool specularOn_ = true;  // false: restricted to the diffuse lobe
  // The clear coat (Brdf::clearcoat > 0): w in the coat's frame, its lambda,
  // the albedo row at alpha_c, the base's transmission 1 - cc E_c(w), the
  // lobe weights (the coat's albedo cc E_c(w) and the base's, times the
  // transmission) and pc_, the probability that sample() picks the coat.
  bool coat_ = false, coatTilted_ = false;
  Frame coatFrame_;
  Vec3 wc_{0, 0, 1};
  float lambdaWc_ = 0, coatT_ = 1, coatW_ = 0, baseSpecW_ = 0, baseDiffW_ = 0, pc_ = 0, coatPdfScale_ = 0;
  AlbedoRow rowC_;
  // Which restriction made this (pack() keeps it for a coated BRDF).
  int8_t restricted_ = 0;  // 0 whole, 1 diffuseLobe(), 2 specularLobe()

  // sampleDirection past its w.z > 0 test, the visible-normal frame given.
  bool sampleDirectionIn(const GGX::VisibleFrame& v, float u1, Vec2 u2, Vec3& wi, bool& specular) const;
  // The coated BRDF's forms of the above (core/material.cpp, "[Clear coat]").
  void initCoat();
  void setLobeProbabilities();
  Parts evalPartsCoated(const Vec3& wi, float* pdfOut) const;
  bool sampleDirectionCoated(float u1, Vec2 u2, Vec3& wi, bool& specular) const;
  Vec3 toCoat(const Vec3& v) const { return coatTilted_ ? coatFrame_.toLocal(v) : v; }
};

// An RGBA image in [0,1] (as stored, not yet linearised).
struct Texture {
  std::string name;
  int width = 0, height = 0;
  std::vector<float> rgba;  // width*height*4
  // Bilinear lookup with repeat wrapping. sRGB-encoded channels (RGB only)
  // are decoded to linear when srgb is true.
  void lookup(Vec2 uv, bool srgb, float out[4]) const;
};

// KHR_texture_transform on one texture slot (the extension's README): the UV
// set the slot reads, then uv' = T R S (u, v, 1) with T the offset, S the
// scale and R a rotation of the UVs counter-clockwise by `rotation` radians
// (the README's GLSL matrices, which are column-major):
//   u' = sx cos(r) u - sy sin(r) v + ox,  v' = sx sin(r) u + sy cos(r) v + oy.
// The default is the identity on TEXCOORD_0, applied as no operation at all.
class TextureTransform {
 public:
  static TextureTransform make(Vec2 offset, float rotation, Vec2 scale, int texCoord);
  Vec2 offset() const { return offset_; }
  float rotation() const { return rotation_; }  // radians
  Vec2 scale() const { return scale_; }
  int texCoord() const { return texCoord_; }  // 0: TEXCOORD_0, 1: TEXCOORD_1 (Scene::uvs1)
  // True when apply() returns its argument unchanged.
  bool isIdentity() const { return identity_; }
  Vec2 apply(Vec2 uv) const {
    if (identity_) return uv;
    return {m_[0] * uv.x + m_[1] * uv.y + offset_.x, m_[2] * uv.x + m_[3] * uv.y + offset_.y};
  }

 private:
  Vec2 offset_{0, 0}, scale_{1, 1};
  float rotation_ = 0;
  int texCoord_ = 0;
  float m_[4] = {1, 0, 0, 1};  // R S, row-major
  bool identity_ = true;
};

// glTF alphaMode (glTF 2.0 specification, 3.9.4 "Alpha Coverage"). Opaque
// ignores alpha; Mask keeps a surface point where alpha >= alphaCutoff; Blend
// is rendered as stochastic opacity, kept with probability alpha
// (docs/REFERENCE.md, "Alpha: MASK and BLEND").
enum class AlphaMode { Opaque, Mask, Blend };

struct Material {
  std::string name;
  Vec3 baseColor{1.0f};
  float alpha = 1;  // baseColorFactor's fourth component
  AlphaMode alphaMode = AlphaMode::Opaque;
  float alphaCutoff = 0.5f;  // Mask only
  float metallic = 1.0f;
  float roughness = 1.0f;
  Vec3 emission{0.0f};  // emissiveFactor x KHR_materials_emissive_strength (radiance)
  float anisotropyStrength = 0;
  float anisotropyRotation = 0;  // radians, counter-clockwise from the tangent
  float specularWeight = 1;      // KHR_materials_specular specularFactor
  bool doubleSided = false;
  int baseColorTexture = -1, metallicRoughnessTexture = -1, emissiveTexture = -1;
  int anisotropyTexture = -1;
  // glTF normalTexture: a tangent-space normal map (RGB = (n + 1) / 2, +y up
  // in the image) and its `scale`, which multiplies the map's x and y
  // (glTF 2.0 specification, 3.9.3 "Additional Textures"). Sampled through
  // Scene::normalMapTexel only, so a per-slot texture transform can be
  // applied there.
  int normalTexture = -1;
  float normalScale = 1;
  // KHR_materials_clearcoat (its README): the coat's weight (factor x the
  // R channel of clearcoatTexture), its roughness (factor x the G channel of
  // clearcoatRoughnessTexture) and its own normal map (clearcoatNormalTexture
  // with its scale; without one the coat follows the interpolated normal,
  // not the base's normal map).
  float clearcoat = 0, clearcoatRoughness = 0;
  int clearcoatTexture = -1, clearcoatRoughnessTexture = -1, clearcoatNormalTexture = -1;
  float clearcoatNormalScale = 1;
  // Per texture slot: which UV set it reads and its KHR_texture_transform.
  TextureTransform baseColorTransform, metallicRoughnessTransform, emissiveTransform, anisotropyTransform,
      normalTransform, clearcoatTransform, clearcoatRoughnessTransform, clearcoatNormalTransform;

  bool isEmissive() const { return maxComponent(emission) > 0; }
  // Mask or Blend: rays may pass through the surface (Accel's filter).
  bool hasAlpha() const { return alphaMode != AlphaMode::Opaque; }
};

}  // namespace vsl
