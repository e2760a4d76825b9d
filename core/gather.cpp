#include "core/gather.h"

namespace vsl {

GatherLight decodeGatherLight(const VirtualLight& v, float radius) {
  GatherLight g;
  g.p = v.p;
  g.Phi = v.Phi;
  g.n = decodeUnit(v.n);
  g.ng = decodeUnit(v.ng);
  g.em.frame = v.frame();
  g.em.f = BrdfAt(v.brdf(), g.em.frame.toLocal(decodeUnit(v.wi)));
  g.radius = radius;
  g.alpha = std::min(g.em.f.brdf().ggx.ax, g.em.f.brdf().ggx.ay);
  return g;
}

Gatherer::Gatherer(const Scene& scene, const Accel& accel, const LightSampler& lights,
                   const ManyLightSettings& settings, float clampBound, bool computeVsl, bool computeVpl)
    : scene_(scene),
      accel_(accel),
      lights_(lights),
      clamp_(clampBound),
      vsl_(settings.vslOptions()),
      continueAlpha_(settings.continueAlpha),
      lobeRadius_(settings.lobeRadius),
      computeVsl_(computeVsl),
      computeVpl_(computeVpl),
      seed_(settings.seed) {}

namespace {
constexpr int kMaxSpecularChain = 8;
}

GatherPoint Gatherer::eyePath(int x, int y, int width, int height, Rng& rng, GatherCounters& c) const {
  GatherPoint gp;
  Ray ray = scene_.camera.generateRay(x + rng.uniform(), y + rng.uniform(), width, height);
  Vec3 beta(1.0f);
  for (int j = 0; j < kMaxSpecularChain; ++j) {
    ++c.rays;
    std::optional<Hit> hit = accel_.intersect(ray);
    if (!hit) return gp;
    SurfaceHit sh = scene_.surfaceHit(hit->triangle, hit->u, hit->v, ray.d);
    Vec3 wo = -ray.d;
    // Emission after two or more scattering events is indirect.
    if (j >= 2) gp.shared += beta * scene_.emitted(sh, wo);
    Brdf brdf = scene_.brdf(sh);
    Vec3 woL = sh.shading.toLocal(wo);
    if (woL.z <= 0) return gp;
    if (brdf.isNarrowMetal(continueAlpha_) && j + 1 < kMaxSpecularChain) {
      auto bs = brdf.sample(woL, rng.uniform(), {rng.uniform(), rng.uniform()});
      if (!bs) return gp;
      Vec3 wi = sh.shading.toWorld(bs->wi);
      if (dot(wi, sh.ng) <= 0) return gp;
      beta *= bs->f * (bs->wi.z / bs->pdf);
      ray.o = offsetRayOrigin(sh.p, sh.ng, wi);
      ray.d = wi;
      continue;
    }
    // The gather point. Behind a specular chain, its own direct light is
    // indirect for the image (two or more scattering events).
    if (j >= 1) {
      if (auto ls = lights_.sampleLi(sh.p, rng.uniform(), {rng.uniform(), rng.uniform()})) {
        Vec3 wiL = sh.shading.toLocal(ls->wi);
        if (wiL.z > 0 && dot(ls->wi, sh.ng) > 0) {
          Ray s;
          ++c.rays;
          if (segmentRay(sh.p, sh.ng, ls->pLight, ls->nLight, s) && !accel_.occluded(s))
            gp.shared += beta * brdf.eval(woL, wiL) * ls->Li * (wiL.z / ls->pdf);
        }
      }
    }
    gp.valid = true;
    gp.p = sh.p;
    gp.beta = beta;
    gp.rx.f = BrdfAt(brdf, woL);
    gp.rx.frame = sh.shading;
    gp.rx.ng = sh.ng;
    return gp;
  }
  return gp;
}

void Gatherer::evaluate(const GatherPoint& gp, const GatherLight& L, uint64_t lightId, uint64_t pixel,
                        double acc[kGatherLayers][3], GatherCounters& c) const {
  ++c.pairs;
  Vec3 d = L.p - gp.p;
  float d2 = lengthSquared(d);
  float dist = std::sqrt(d2);
  Vec3 l = dist > 0 ? d / dist : gp.rx.frame.n;
  float cosX = dot(gp.rx.frame.n, l), cosXg = dot(gp.rx.ng, l);
  float cosP = -dot(L.n, l), cosPg = -dot(L.ng, l);
  // Both sides must face each other along the direction to the light's
  // centre, by shading and geometric normals, for VPLs and VSLs alike (as in
  // the VSL authors' shader). Without this a VSL on the back of a thin wall,
  // with the receiver inside its sphere, would light the wall's front through
  // it. The BRDFs are evaluated after the visibility test, so blocked pairs
  // never pay for them.
  if (!(d2 > 0 && cosX > 0 && cosXg > 0 && cosP > 0 && cosPg > 0)) return;
  const bool vpl = computeVpl_, vslPossible = computeVsl_;
  if (!vpl && !vslPossible) return;
  // One visibility ray feeds every estimate.
  Ray s;
  if (segmentRay(gp.p, gp.rx.ng, L.p, L.ng, s)) {
    ++c.shadowRays;
    if (accel_.occluded(s)) return;
  }
  Vec3 w = gp.beta * L.Phi;
  auto add = [&](int layer, const Vec3& T) {
    Vec3 v = w * T;
    if (!isFinite(v)) {
      ++c.nonFinite;
      return;
    }
    for (int k = 0; k < 3; ++k) acc[layer][k] += v[k];
  };
  auto clamped = [&](const Vec3& T) {
    float lum = luminance(T);
    return lum > clamp_ ? T * (clamp_ / lum) : T;
  };
  if (vpl) {
    // Transfer of the full BRDF and of diffuse-only emission.
    Vec3 fxG = gp.rx.f.eval(gp.rx.frame.toLocal(l)) * (cosX * cosP / d2);
    BrdfAt::Parts fp = L.em.f.evalParts(L.em.frame.toLocal(-l));
    Vec3 Tdiff = fxG * fp.diffuse;
    Vec3 Tfull = Tdiff + fxG * fp.specular;
    add(kVplFull, Tfull);
    add(kVplFullClamped, clamped(Tfull));
    add(kVplDiffuse, Tdiff);
    add(kVplDiffuseClamped, clamped(Tdiff));
  }
  if (vslPossible) {
    Rng prng = Rng::forItem(pixel, lightId, 3, seed_);
    float radius = lobeRadius_ > 0 ? std::max(L.radius, lobeRadius_ * dist * L.alpha) : L.radius;
    VslResult r = vslTransfer(gp.rx, L.em, d, radius, vsl_, prng);
    c.vslEvaluations += uint64_t(r.evaluations);
    add(kVslLayer, r.transfer);
  }
}

}  // namespace vsl
