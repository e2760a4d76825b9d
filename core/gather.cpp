#include "core/gather.h"

#include "core/lobe_gather.h"
#include "core/path.h"
#include "core/stopwatch.h"

namespace vsl {

GatherLight decodeGatherLight(const VirtualLight& v, float radius) {
  GatherLight g;
  g.p = v.p;
  g.Phi = v.Phi;
  g.n = decodeUnit(v.n);
  g.ng = decodeUnit(v.ng);
  g.pOff = offsetToLitSide(g.p, g.ng);
  g.em.frame = v.frame();
  g.em.f = BrdfAt(v.brdf(), g.em.frame.toLocal(decodeUnit(v.wi)));
  g.radius = radius;
  g.alpha = std::min(g.em.f.brdf().ggx.ax, g.em.f.brdf().ggx.ay);
  return g;
}

Gatherer::Gatherer(const Scene& scene, const Accel& accel, const LightSampler& lights,
                   const ManyLightSettings& settings, float clampBound, bool computeVsl, bool computeVpl,
                   const LobeGatherMap* lobeMap)
    : scene_(scene),
      accel_(accel),
      lights_(lights),
      clamp_(clampBound),
      vsl_(settings.vslOptions()),
      continueAlpha_(settings.continueAlpha),
      splitAlpha_(settings.splitAlpha),
      lobeRadius_(settings.lobeRadius),
      lobeFloor_(settings.lobeFloor),
      computeVsl_(computeVsl),
      computeVpl_(computeVpl),
      seed_(settings.seed),
      lobeMap_(computeVsl ? lobeMap : nullptr),
      lobeRays_(settings.lobeGatherRays) {}

namespace {
constexpr int kMaxSpecularChain = 8;
}  // namespace

Vec3 directLight(const PathTracer& direct, int x, int y, int sBegin, int sEnd, GatherCounters& c) {
  Vec3 sum(0.0f);
  for (int s = sBegin; s < sEnd; ++s) {
    Vec3 Ld, Lind;
    direct.samplePixel(x, y, s, Ld, Lind, c.rays, c.nonFinite);
    sum += Ld;
  }
  return sum / float(sEnd - sBegin);
}

EyeSample Gatherer::eyePath(int x, int y, int width, int height, Rng& rng, GatherCounters& c) const {
  EyeSample es;
  es.count = 1;
  int cur = 0;  // the gather point this part of the path leads to
  Ray ray = scene_.camera.generateRay(x + rng.uniform(), y + rng.uniform(), width, height);
  Vec3 beta(1.0f);
  for (int j = 0; j < kMaxSpecularChain; ++j) {
    GatherPoint& gp = es.points[cur];
    ++c.rays;
    std::optional<Hit> hit = accel_.intersect(ray);
    if (!hit) return es;
    SurfaceHit sh = scene_.surfaceHit(hit->triangle, hit->u, hit->v, ray.d);
    Vec3 wo = -ray.d;
    // Emission after two or more scattering events is indirect.
    if (j >= 2) gp.shared += beta * scene_.emitted(sh, wo);
    Brdf brdf = scene_.brdf(sh);
    Vec3 woL = sh.shading.toLocal(wo);
    if (woL.z <= 0) return es;
    const bool narrow = std::max(brdf.ggx.ax, brdf.ggx.ay) < splitAlpha_;
    const bool last = j + 1 >= kMaxSpecularChain;
    const BrdfAt full(brdf, woL);
    if (!last && (brdf.isNarrowMetal(continueAlpha_) || (narrow && brdf.metallic >= 1.0f))) {
      // Punctual lights reflected here are never hit by the continued ray.
      if (j >= 1) gp.shared += beta * nextEvent(full, sh, true, rng, c);
      if (!continuePath(full, sh, rng.uniform(), {rng.uniform(), rng.uniform()}, beta, ray)) return es;
      continue;
    }
    // The gather point: the whole BRDF, or its diffuse lobe if the specular
    // lobe is split off (once per eye sample).
    const bool split = narrow && cur + 1 < kMaxGatherPoints && !last;
    gp.rx.f = split ? full.diffuseLobe() : full;
    // Behind a specular chain, its own direct light is indirect for the
    // image (two or more scattering events).
    if (j >= 1) gp.shared += beta * nextEvent(gp.rx.f, sh, false, rng, c);
    gp.valid = true;
    gp.p = sh.p;
    gp.beta = beta;
    gp.rx.frame = sh.shading;
    gp.rx.ng = sh.ng;
    gp.pOff = offsetToLitSide(gp.p, gp.rx.ng);
    if (!split && lobeMap_ && std::min(brdf.ggx.ax, brdf.ggx.ay) < ManyLightSettings::kLobeGatherAlpha) {
      Stopwatch own;
      gp.lobe = true;
      gp.vslLobe = beta * lobeGather(full.specularLobe(), sh, rng, c);
      c.vslOwnSeconds += own.seconds();
    }
    if (!split) return es;
    // The specular lobe, sampled alone, leads to the next gather point. Its
    // direct light is the emission the continued ray hits (next-event light
    // above was for the diffuse lobe only), and punctual lights here.
    const BrdfAt specular = full.specularLobe();
    if (j >= 1) gp.shared += beta * nextEvent(specular, sh, true, rng, c);
    es.count = ++cur + 1;
    if (!continuePath(specular, sh, rng.uniform(), {rng.uniform(), rng.uniform()}, beta, ray)) return es;
  }
  return es;
}

Vec3 Gatherer::lobeGather(const BrdfAt& spec, const SurfaceHit& sh, Rng& rng, GatherCounters& c) const {
  Vec3 sum(0.0f);
  for (int m = 0; m < lobeRays_; ++m) {
    // Where a direction lands on a lobe narrow along both axes, the density
    // estimate takes the lights' diffuse lobes there and the path goes on
    // along that surface's specular lobe (the lights' own narrow lobes would
    // be beams there, as at a narrow receiver), adding the emission it
    // reaches and, by next-event estimation, the punctual lights that lobe
    // reflects (which the continued path never hits). A highlight seen
    // through two narrow lobes is a rare spike that way; with eight
    // directions it took one tableau light set from 0.42 to 7.4 and was left
    // out, with 128 it costs nothing measurable (docs/VSL-QUALITY.md,
    // "Session 31").
    BrdfAt f = spec;
    SurfaceHit at = sh;
    Vec3 t(1.0f);
    for (int bounce = 0; bounce < kMaxSpecularChain; ++bounce) {
      const float u1 = rng.uniform();
      const Vec2 u2{rng.uniform(), rng.uniform()};
      std::optional<BrdfSample> bs = f.sample(u1, u2);
      if (!bs) break;
      const Vec3 wi = at.shading.toWorld(bs->wi);
      if (dot(wi, at.ng) <= 0) break;
      t *= bs->f * (bs->wi.z / bs->pdf);
      Ray ray;
      ray.o = offsetRayOrigin(at.p, at.ng, wi);
      ray.d = wi;
      ++c.rays;
      std::optional<Hit> hit = accel_.intersect(ray);
      if (!hit) break;
      const SurfaceHit z = scene_.surfaceHit(hit->triangle, hit->u, hit->v, ray.d);
      const Vec3 wOut = -wi;
      // Emission reached straight from the receiver is its direct light.
      if (const Vec3 e = t * scene_.emitted(z, wOut); bounce >= 1 && isFinite(e))
        sum += e;
      else if (bounce >= 1)
        ++c.nonFinite;
      const Brdf zb = scene_.brdf(z);
      const Vec3 woZ = z.shading.toLocal(wOut);
      if (woZ.z <= 0) break;
      const bool narrow = std::max(zb.ggx.ax, zb.ggx.ay) < ManyLightSettings::kLobeGatherAlpha;
      const Vec3 add = t * lobeMap_->radiance(z.p, dot(z.ng, wOut) >= 0 ? z.ng : -z.ng, wOut, narrow);
      if (isFinite(add))
        sum += add;
      else
        ++c.nonFinite;
      if (!narrow) break;
      const BrdfAt zs = BrdfAt(zb, woZ).specularLobe();
      if (const Vec3 ne = t * nextEvent(zs, z, true, rng, c); isFinite(ne))
        sum += ne;
      else
        ++c.nonFinite;
      f = zs;
      at = z;
    }
  }
  return sum / float(lobeRays_);
}

Vec3 Gatherer::nextEvent(const BrdfAt& f, const SurfaceHit& sh, bool deltaOnly, Rng& rng, GatherCounters& c) const {
  Vec3 sum(0.0f);
  for (int k = 0; k < kSharedLightSamples; ++k) {
    auto ls = lights_.sampleLi(sh.p, rng.uniform(), {rng.uniform(), rng.uniform()});
    if (!ls || (deltaOnly && !ls->delta)) continue;
    Vec3 wiL = sh.shading.toLocal(ls->wi);
    if (!(wiL.z > 0 && dot(ls->wi, sh.ng) > 0)) continue;
    Ray s;
    ++c.rays;
    if (!segmentRay(sh.p, sh.ng, ls->pLight, ls->nLight, s) || accel_.occluded(s)) continue;
    sum += f.eval(wiL) * ls->Li * (wiL.z / ls->pdf);
  }
  return sum / float(kSharedLightSamples);
}

void Gatherer::evaluate(const GatherPoint& gp, const GatherLight& L, uint64_t lightId, uint64_t pixel,
                        double acc[kGatherLayers][3], GatherCounters& c) const {
  PairGeometry g;
  if (connect(gp, L, g, c)) addConnected(gp, L, g, lightId, pixel, acc, c);
}

bool Gatherer::orient(const GatherPoint& gp, const GatherLight& L, PairGeometry& g, Ray& ray, bool& needsRay,
                      GatherCounters& c) const {
  ++c.pairs;
  g.d = L.p - gp.p;
  g.d2 = lengthSquared(g.d);
  g.dist = std::sqrt(g.d2);
  g.l = g.dist > 0 ? g.d / g.dist : gp.rx.frame.n;
  g.cosX = dot(gp.rx.frame.n, g.l);
  g.cosP = -dot(L.n, g.l);
  float cosXg = dot(gp.rx.ng, g.l), cosPg = -dot(L.ng, g.l);
  // Both sides must face each other along the direction to the light's
  // centre, by shading and geometric normals, for VPLs and VSLs alike (as in
  // the VSL authors' shader). Without this a VSL on the back of a thin wall,
  // with the receiver inside its sphere, would light the wall's front through
  // it. The BRDFs are evaluated after the visibility test, so blocked pairs
  // never pay for them.
  if (!(g.d2 > 0 && g.cosX > 0 && cosXg > 0 && g.cosP > 0 && cosPg > 0)) return false;
  if (!computeVpl_ && !computeVsl_) return false;
  // One visibility ray feeds every estimate: segmentRay with both ends'
  // offsets precomputed (the same values).
  needsRay = segmentRayBetween(gp.pOff, L.pOff, ray);
  if (needsRay) ++c.shadowRays;
  return true;
}

bool Gatherer::connect(const GatherPoint& gp, const GatherLight& L, PairGeometry& g, GatherCounters& c) const {
  Ray s;
  bool needsRay = false;
  if (!orient(gp, L, g, s, needsRay, c)) return false;
  return !(needsRay && accel_.occluded(s));
}

void Gatherer::connectMany(std::span<const GatherPoint* const> gps, const GatherLight& L, PairGeometry* geo,
                           uint8_t* visible, ConnectScratch& scratch, GatherCounters& c,
                           std::span<const uint8_t> known) const {
  if (!known.empty()) {
    VSL_CHECK_EQ(known.size(), gps.size());
    // The pairs and rays were counted when known[] was traced.
    GatherCounters uncounted;
    Ray unused;
    for (size_t i = 0; i < gps.size(); ++i) {
      bool needsRay = false;
      visible[i] = known[i] && gps[i] && orient(*gps[i], L, geo[i], unused, needsRay, uncounted);
    }
    return;
  }
  scratch.rays.resize(gps.size());
  scratch.rayOf.resize(gps.size());
  size_t nRays = 0;
  for (size_t i = 0; i < gps.size(); ++i) {
    bool needsRay = false;
    visible[i] = gps[i] && orient(*gps[i], L, geo[i], scratch.rays[nRays], needsRay, c);
    if (visible[i] && needsRay) scratch.rayOf[nRays++] = uint32_t(i);
  }
  if (nRays == 0) return;
  scratch.blocked.resize(nRays);
  accel_.occluded(std::span<const Ray>(scratch.rays.data(), nRays), std::span<uint8_t>(scratch.blocked.data(), nRays));
  for (size_t r = 0; r < nRays; ++r)
    if (scratch.blocked[r]) visible[scratch.rayOf[r]] = 0;
}

namespace {

void addLayer(double acc[kGatherLayers][3], int layer, const Vec3& v, GatherCounters& c) {
  if (!isFinite(v)) {
    ++c.nonFinite;
    return;
  }
  for (int k = 0; k < 3; ++k) acc[layer][k] += v[k];
}

}  // namespace

void Gatherer::addVpl(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, double acc[kGatherLayers][3],
                      GatherCounters& c) const {
  if (!computeVpl_) return;
  auto clamped = [&](const Vec3& T) {
    float lum = luminance(T);
    return lum > clamp_ ? T * (clamp_ / lum) : T;
  };
  // Transfer of the full BRDF and of diffuse-only emission.
  const Vec3 w = gp.beta * L.Phi;
  Vec3 fxG = gp.rx.f.eval(gp.rx.frame.toLocal(g.l)) * (g.cosX * g.cosP / g.d2);
  BrdfAt::Parts fp = L.em.f.evalParts(L.em.frame.toLocal(-g.l));
  Vec3 Tdiff = fxG * fp.diffuse;
  Vec3 Tfull = Tdiff + fxG * fp.specular;
  addLayer(acc, kVplFull, w * Tfull, c);
  addLayer(acc, kVplFullClamped, w * clamped(Tfull), c);
  addLayer(acc, kVplDiffuse, w * Tdiff, c);
  addLayer(acc, kVplDiffuseClamped, w * clamped(Tdiff), c);
}

void Gatherer::addVsl(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, uint64_t lightId,
                      uint64_t pixel, double acc[kGatherLayers][3], GatherCounters& c) const {
  if (!computeVsl_) return;
  // At a lobe-gathered point the light set lights the diffuse lobe only
  // (none on a metal).
  std::optional<VslReceiver> diffuse;
  if (gp.lobe) {
    if (gp.rx.f.brdf().metallic >= 1.0f) return;
    diffuse = gp.rx;
    diffuse->f = gp.rx.f.diffuseLobe();
  }
  const VslReceiver& rx = diffuse ? *diffuse : gp.rx;
  Rng prng = Rng::forItem(pixel, lightId, 3, seed_);
  // Where the lobe floor applies, the light's sphere is wider too
  // (kVslLobeFloorRadiusScale).
  const bool floorApplies = lobeFloor_ > 0 && vslLobeFloorApplies(rx, L.em);
  const float lightRadius = floorApplies ? L.radius * kVslLobeFloorRadiusScale : L.radius;
  float radius = lobeRadius_ > 0 ? std::max(lightRadius, lobeRadius_ * g.dist * L.alpha) : lightRadius;
  // The floor follows the light's own radius, not the lobe-aware one (which
  // does not shrink with the light count), so that it vanishes as r does.
  VslEmitter floored;
  const bool useFloor = floorApplies && vslWidenLobe(L.em, lightRadius, g.dist, lobeFloor_, floored);
  VslResult r = vslTransferBlock(rx, useFloor ? floored : L.em, g.d, radius, vsl_, prng);
  c.vslEvaluations += uint64_t(r.evaluations);
  addLayer(acc, kVslLayer, gp.beta * L.Phi * r.transfer, c);
}

}  // namespace vsl
