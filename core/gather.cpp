#include "core/gather.h"

#include "core/lobe_gather.h"
#include "core/path.h"
#include "core/sampling.h"
#include "core/stopwatch.h"
#include "core/vsl_sg.h"

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
  if (v.normalMapped) {
    // Emission with the geometric cosine (VslEmitter::geometricCosine): the
    // pair's cosP is then -l.ng, for VPLs as for the orientation test.
    g.n = g.ng;
    g.em.geometricCosine = true;
    g.em.ngLocal = g.em.frame.toLocal(g.ng);
  }
  g.radius = radius;
  g.alpha = g.em.f.brdf().minAlpha();
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
      lobeRays_(settings.lobeGatherRays),
      lobeAlpha_(settings.lobeGatherAlpha) {}

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

EyeSample Gatherer::eyePath(int x, int y, int width, int height, Rng& rng, GatherCounters& c,
                            const EyePathOptions& o) const {
  EyeSample es;
  es.count = 1;
  int cur = 0;  // the gather point this part of the path leads to
  Ray ray = scene_.camera.generateRay(x + rng.uniform(), y + rng.uniform(), width, height);
  Vec3 beta(1.0f);
  for (int j = 0; j < kMaxSpecularChain; ++j) {
    GatherPoint& gp = es.points[cur];
    ++c.rays;
    std::optional<Hit> hit = accel_.intersect(ray);
    // Emission after two or more scattering events is indirect; so is the
    // environment seen after them (found by hitting only, as emission is).
    if (!hit) {
      if (const Environment* env = lights_.environment(); env && j >= 2) gp.shared += beta * env->radiance(ray.d);
      return es;
    }
    SurfaceHit sh = scene_.surfaceHit(hit->triangle, hit->u, hit->v, ray.d);
    Vec3 wo = -ray.d;
    if (j >= 2) gp.shared += beta * scene_.emitted(sh, wo);
    Brdf brdf = scene_.brdf(sh);
    Vec3 woL = sh.shading.toLocal(wo);
    if (woL.z <= 0) return es;
    // A narrow clear coat splits the point as a narrow base lobe does.
    const bool narrow = brdf.hasNarrowLobe(splitAlpha_);
    const bool last = j + 1 >= kMaxSpecularChain;
    const bool continues = !last && (brdf.isNarrowMetal(continueAlpha_) || (narrow && brdf.metallic >= 1.0f));
    // Where the path does not continue, the gather point: the whole BRDF,
    // or its diffuse lobe if the specular lobe is split off (once per eye
    // sample).
    const bool split = !continues && narrow && cur + 1 < kMaxGatherPoints && !last;
    // A path traced for its shared light alone ends at a first gather point
    // that is not split: no light is shared there.
    if (!o.lobeGather && j == 0 && !continues && !split) return es;
    const BrdfAt full(brdf, woL);
    if (continues) {
      // Punctual lights reflected here are never hit by the continued ray.
      if (j >= 1) gp.shared += beta * nextEvent(full, sh, true, rng, c, o.lightSamples);
      if (!continuePath(full, sh, rng.uniform(), {rng.uniform(), rng.uniform()}, beta, ray)) return es;
      continue;
    }
    gp.rx.f = split ? full.diffuseLobe() : full;
    // Behind a specular chain, its own direct light is indirect for the
    // image (two or more scattering events).
    if (j >= 1) gp.shared += beta * nextEvent(gp.rx.f, sh, false, rng, c, o.lightSamples);
    gp.valid = true;
    gp.p = sh.p;
    gp.beta = beta;
    gp.rx.frame = sh.shading;
    gp.rx.ng = sh.ng;
    gp.pOff = offsetToLitSide(gp.p, gp.rx.ng);
    if (o.lobeGather && !split && lobeMap_ && brdf.minAlpha() < lobeAlpha_) {
      Stopwatch own;
      gp.lobe = true;
      gp.vslLobe = beta * lobeGather(full.specularLobe(), sh, o.lobeRays > 0 ? o.lobeRays : lobeRays_, rng, c);
      c.vslOwnSeconds += own.seconds();
    }
    if (!split) return es;
    // The specular lobe, sampled alone, leads to the next gather point. Its
    // direct light is the emission the continued ray hits (next-event light
    // above was for the diffuse lobe only), and punctual lights here.
    const BrdfAt specular = full.specularLobe();
    if (j >= 1) gp.shared += beta * nextEvent(specular, sh, true, rng, c, o.lightSamples);
    es.count = ++cur + 1;
    if (!continuePath(specular, sh, rng.uniform(), {rng.uniform(), rng.uniform()}, beta, ray)) return es;
  }
  return es;
}

Vec3 Gatherer::lobeGather(const BrdfAt& spec, const SurfaceHit& sh, int rays, Rng& rng, GatherCounters& c) const {
  // The first bounce's directions are multi-jittered over the lobe's sample
  // space: each is uniform in its own cell, and together they cover the lobe
  // evenly, which is where the lobe gather's error lies
  // (docs/notebook/2026-12-05-batch-schedule-and-multijitter.md).
  Vec2Scratch<ManyLightSettings::kMaxLobeGatherRays> scratch;
  rays = std::clamp(rays, 1, ManyLightSettings::kMaxLobeGatherRays);
  Vec2* first = scratch.data();
  multiJittered(rays, rng, first);
  Vec3 sum(0.0f);
  for (int m = 0; m < rays; ++m) {
    // Where a direction lands on a lobe narrow along both axes, the density
    // estimate takes the lights' diffuse lobes there and the path goes on
    // along that surface's specular lobe (the lights' own narrow lobes would
    // be beams there, as at a narrow receiver), adding the emission it
    // reaches and, by next-event estimation, the punctual lights that lobe
    // reflects (which the continued path never hits). Past that first
    // narrow landing, the light reflected toward the receiver is found
    // through lobes at least ManyLightSettings::kLobeGatherChainAlpha wide:
    // the next-event estimate's, and the map's lights where the continued
    // path lands. A highlight seen through two narrow lobes is otherwise a
    // rare spike (tableau, five sets: 0.284 -> 0.229 -> 0.190;
    // docs/notebook/2026-12-05-tableau-worst-sets.md).
    BrdfAt f = spec;
    SurfaceHit at = sh;
    Vec3 t(1.0f);
    for (int bounce = 0; bounce < kMaxSpecularChain; ++bounce) {
      const float u1 = rng.uniform();
      const Vec2 u2 = bounce == 0 ? first[m] : Vec2{rng.uniform(), rng.uniform()};
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
      if (!hit) {
        // The environment, past the receiver's own direct light.
        if (const Environment* env = lights_.environment(); env && bounce >= 1) {
          if (const Vec3 e = t * env->radiance(wi); isFinite(e))
            sum += e;
          else
            ++c.nonFinite;
        }
        break;
      }
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
      const bool narrow = zb.hasNarrowLobe(ManyLightSettings::kLobeGatherAlpha);
      const float minAlpha = bounce >= 1 ? ManyLightSettings::kLobeGatherChainAlpha : 0.0f;
      const Vec3 add = t * lobeMap_->radiance(z.p, dot(z.ng, wOut) >= 0 ? z.ng : -z.ng, wOut, narrow, minAlpha);
      if (isFinite(add))
        sum += add;
      else
        ++c.nonFinite;
      if (!narrow) break;
      const BrdfAt zs = BrdfAt(zb, woZ).specularLobe();
      const BrdfAt wide = BrdfAt(zb.widened(ManyLightSettings::kLobeGatherChainAlpha), woZ).specularLobe();
      if (const Vec3 ne = t * nextEvent(wide, z, true, rng, c); isFinite(ne))
        sum += ne;
      else
        ++c.nonFinite;
      f = zs;
      at = z;
    }
  }
  return sum / float(rays);
}

Vec3 Gatherer::sharedLight(const EyeSample& first, int paths, int x, int y, int width, int height, uint64_t pass,
                           GatherCounters& c) const {
  if (paths <= 1) return first.shared();
  paths = std::min(paths, kMaxSharedEyePaths);
  auto finite = [&](const Vec3& v) {
    if (isFinite(v)) return v;
    ++c.nonFinite;
    return Vec3(0.0f);
  };
  Vec3 sum = finite(first.shared());
  EyePathOptions o = eyePathOptions(paths);
  o.lobeGather = false;
  const uint64_t pixel = uint64_t(y) * uint64_t(width) + uint64_t(x);
  for (int e = 1; e < paths; ++e) {
    Rng rng = Rng::forItem(pixel, (pass << 8) | uint64_t(e), 6, seed_);
    sum += finite(eyePath(x, y, width, height, rng, c, o).shared());
  }
  return sum / float(paths);
}

Vec3 Gatherer::nextEvent(const BrdfAt& f, const SurfaceHit& sh, bool deltaOnly, Rng& rng, GatherCounters& c,
                         int samples) const {
  Vec3 sum(0.0f);
  for (int k = 0; k < samples; ++k) {
    auto ls = lights_.sampleLi(sh.p, rng.uniform(), {rng.uniform(), rng.uniform()});
    if (!ls || (deltaOnly && !ls->delta)) continue;
    Vec3 wiL = sh.shading.toLocal(ls->wi);
    if (!(wiL.z > 0 && dot(ls->wi, sh.ng) > 0)) continue;
    Ray s;
    ++c.rays;
    if (!segmentRay(sh.p, sh.ng, ls->pLight, ls->nLight, s) || accel_.occluded(s)) continue;
    sum += f.eval(wiL) * ls->Li * (wiL.z / ls->pdf);
  }
  return sum / float(samples);
}

void Gatherer::evaluate(const GatherPoint& gp, const GatherLight& L, uint64_t lightId, uint64_t pixel,
                        double acc[kGatherLayers][3], GatherCounters& c) const {
  PairGeometry g;
  if (connect(gp, L, g, c)) addConnected(gp, L, g, lightId, pixel, acc, c);
}

bool Gatherer::facing(const GatherPoint& gp, const Vec3& p, const Vec3& n, const Vec3& ng, PairGeometry& g) {
  g.weight = 1;
  g.d = p - gp.p;
  g.d2 = lengthSquared(g.d);
  g.dist = std::sqrt(g.d2);
  g.l = g.dist > 0 ? g.d / g.dist : gp.rx.frame.n;
  g.cosX = dot(gp.rx.frame.n, g.l);
  g.cosP = -dot(n, g.l);
  float cosXg = dot(gp.rx.ng, g.l), cosPg = -dot(ng, g.l);
  // Both sides must face each other along the direction to the light's
  // centre, by shading and geometric normals, for VPLs and VSLs alike (as in
  // the VSL authors' shader). Without this a VSL on the back of a thin wall,
  // with the receiver inside its sphere, would light the wall's front through
  // it. The BRDFs are evaluated after the visibility test, so blocked pairs
  // never pay for them.
  return g.d2 > 0 && g.cosX > 0 && cosXg > 0 && g.cosP > 0 && cosPg > 0;
}

bool Gatherer::facing(const GatherPoint& gp, const VirtualLight& v) {
  const Vec3 ng = decodeUnit(v.ng);
  PairGeometry g;
  return facing(gp, v.p, v.normalMapped ? ng : decodeUnit(v.n), ng, g);
}

bool Gatherer::orient(const GatherPoint& gp, const GatherLight& L, PairGeometry& g, Ray& ray, bool& needsRay,
                      GatherCounters& c) const {
  ++c.pairs;
  if (!facing(gp, L.p, L.n, L.ng, g)) return false;
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
                           uint8_t* visible, ConnectScratch& scratch, GatherCounters& c, std::span<const uint8_t> known,
                           const PairRoulette* roulette) const {
  const bool play = roulette && roulette->threshold > 0 && std::isfinite(roulette->threshold) &&
                    (computeVsl_ || computeVpl_) && known.empty();
  if (!known.empty()) {
    VSL_CHECK_EQ(known.size(), gps.size());
    // The pairs and rays were counted when known[] was traced.
    GatherCounters uncounted;
    Ray unused;
    for (size_t i = 0; i < gps.size(); ++i) {
      bool needsRay = false;
      visible[i] = known[i] && gps[i] && orient(*gps[i], L, geo[i], unused, needsRay, uncounted);
      geo[i].weight = 1;
    }
    return;
  }
  scratch.rays.resize(gps.size());
  scratch.rayOf.resize(gps.size());
  size_t nRays = 0;
  for (size_t i = 0; i < gps.size(); ++i) {
    bool needsRay = false;
    visible[i] = gps[i] && orient(*gps[i], L, geo[i], scratch.rays[nRays], needsRay, c);
    geo[i].weight = 1;
    if (visible[i] && roulette) ++c.rouletteOffered;
    if (visible[i] && play) {
      const float e = pairEstimate(*gps[i], L, geo[i]);
      // An estimate of exactly zero means a zero contribution (the VSL
      // estimate is zero only where every BRDF value it takes is, channel by
      // channel, or VSL gathers nothing there): dropped. A probability that
      // underflows keeps the pair unweighted (not played).
      const double q = double(e) / double(roulette->threshold);
      if (e == 0 || (q > 0 && q < 1)) {
        Rng rr = Rng::forItem(roulette->streams[i], roulette->lightId, 5, seed_);
        if (e > 0 && rr.uniformDouble() < q) {
          geo[i].weight = float(1.0 / q);
        } else {
          // Dropped: no ray, nothing gathered.
          ++c.rouletteDropped;
          if (needsRay) --c.shadowRays;
          visible[i] = 0;
          continue;
        }
      }
    }
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
  addVpl(gp, L, g, gp.rx.f.eval(gp.rx.frame.toLocal(g.l)), L.em.f.evalParts(L.em.frame.toLocal(-g.l)), acc, c);
}

void Gatherer::addVpl(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, const Vec3& fx,
                      const BrdfAt::Parts& fp, double acc[kGatherLayers][3], GatherCounters& c) const {
  if (!computeVpl_) return;
  auto clamped = [&](const Vec3& T) {
    float lum = luminance(T);
    return lum > clamp_ ? T * (clamp_ / lum) : T;
  };
  // Transfer of the full BRDF and of diffuse-only emission.
  const Vec3 w = gp.beta * L.Phi * g.weight;
  Vec3 fxG = fx * (g.cosX * g.cosP / g.d2);
  Vec3 Tdiff = fxG * fp.diffuse;
  Vec3 Tfull = Tdiff + fxG * fp.specular;
  addLayer(acc, kVplFull, w * Tfull, c);
  addLayer(acc, kVplFullClamped, w * clamped(Tfull), c);
  addLayer(acc, kVplDiffuse, w * Tdiff, c);
  addLayer(acc, kVplDiffuseClamped, w * clamped(Tdiff), c);
}

void Gatherer::packReceivers(std::span<const GatherPoint* const> pts, std::vector<float>& packed) const {
  packed.clear();
  if (!computeVpl_) return;
  packed.assign(pts.size() * BrdfAt::kPackedFloats, 0.0f);
  for (size_t i = 0; i < pts.size(); ++i)
    if (pts[i]) pts[i]->rx.f.pack(&packed[i * BrdfAt::kPackedFloats]);
}

void Gatherer::vplBrdfs(std::span<const GatherPoint* const> pts, const float* packed, const uint32_t* list, size_t n,
                        const GatherLight& L, const PairGeometry* geo, VplBrdfs& out) const {
  for (auto& v : out.f_) v.resize(n);
  for (auto& v : out.dirs_) v.resize(n);
  out.packed_.resize(n);
  for (size_t v = 0; v < n; ++v) {
    const uint32_t i = list[v];
    const Vec3 wx = pts[i]->rx.frame.toLocal(geo[i].l), wp = L.em.frame.toLocal(-geo[i].l);
    for (int k = 0; k < 3; ++k) {
      out.dirs_[k][v] = wx[k];
      out.dirs_[3 + k][v] = wp[k];
    }
    out.packed_[v] = packed + size_t(i) * BrdfAt::kPackedFloats;
  }
  float* const fx[3] = {out.f_[0].data(), out.f_[1].data(), out.f_[2].data()};
  float* const diffuse[3] = {out.f_[3].data(), out.f_[4].data(), out.f_[5].data()};
  float* const specular[3] = {out.f_[6].data(), out.f_[7].data(), out.f_[8].data()};
  BrdfAt::evalTotalsPacked(int(n), out.packed_.data(), out.dirs_[0].data(), out.dirs_[1].data(), out.dirs_[2].data(),
                           false, fx);
  L.em.f.evalPartsMany(int(n), out.dirs_[3].data(), out.dirs_[4].data(), out.dirs_[5].data(), diffuse, specular);
}

bool Gatherer::vslPair(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, VslPair& out) const {
  // At a lobe-gathered point the light set lights the diffuse lobe only
  // (none on a metal).
  out.rx = &gp.rx;
  if (gp.lobe) {
    if (gp.rx.f.brdf().metallic >= 1.0f) return false;
    out.ownRx.frame = gp.rx.frame;
    out.ownRx.ng = gp.rx.ng;
    out.ownRx.f = gp.rx.f.diffuseLobe();
    out.rx = &out.ownRx;
  }
  // Where the lobe floor applies, the light's sphere is wider too
  // (kVslLobeFloorRadiusScale).
  const bool floorApplies = lobeFloor_ > 0 && vslLobeFloorApplies(*out.rx, L.em);
  const float lightRadius = floorApplies ? L.radius * kVslLobeFloorRadiusScale : L.radius;
  out.radius = lobeRadius_ > 0 ? std::max(lightRadius, lobeRadius_ * g.dist * L.alpha) : lightRadius;
  // The floor follows the light's own radius, not the lobe-aware one (which
  // does not shrink with the light count), so that it vanishes as r does.
  const bool widened = floorApplies && vslWidenLobe(L.em, lightRadius, g.dist, lobeFloor_, out.ownEm);
  out.em = widened ? &out.ownEm : &L.em;
  return true;
}

bool Gatherer::vslTakesSg(const VslPair& pr, const PairGeometry& g) const {
  // The closed form models the base's lobes alone: a pair with a clear coat
  // at either end takes the quadrature (core/vsl_sg.h).
  return vslUsesSg(vsl_, pr.radius, g.dist) && !pr.rx->f.coated() && !pr.em->f.coated();
}

void Gatherer::addVsl(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, uint64_t lightId,
                      uint64_t pixel, double acc[kGatherLayers][3], GatherCounters& c) const {
  if (!computeVsl_) return;
  VslPair pr;
  if (!vslPair(gp, L, g, pr)) return;
  VslResult r;
  if (vslTakesSg(pr, g)) {
    r = vslTransferSg(*pr.rx, *pr.em, g.d, pr.radius, vsl_);
  } else {
    Rng prng = Rng::forItem(pixel, lightId, 3, seed_);
    r = vslTransferBlock(*pr.rx, *pr.em, g.d, pr.radius, vsl_, prng);
  }
  addVslResult(gp, L, g, r, acc, c);
}

Vec3 Gatherer::vslAlong(const GatherPoint& gp, const GatherLight& L, const Vec3& l, PairGeometry& g,
                        GatherCounters& c) const {
  if (!computeVsl_) return Vec3(0.0f);
  ++c.pairs;
  VslPair pr;
  if (!facing(gp, L.p, L.n, L.ng, g) || !vslPair(gp, L, g, pr)) return Vec3(0.0f);
  const Vec3 v = vslIntegrand(*pr.rx, *pr.em, g.d, pr.radius, vsl_, l);
  if (isBlack(v)) return Vec3(0.0f);
  // connect()'s shadow ray, counted where it is traced.
  Ray s;
  if (segmentRayBetween(gp.pOff, L.pOff, s)) {
    ++c.shadowRays;
    if (accel_.occluded(s)) return Vec3(0.0f);
  }
  return gp.beta * L.Phi * v;
}

namespace {
// The direction in the cone around the unit axis a (1 - cos of its
// half-angle omc) nearest the unit direction m.
Vec3 nearestInCone(const Vec3& a, double omc, const Vec3& m) {
  const float am = dot(a, m);
  if (1.0 - double(am) <= omc) return m;
  Vec3 u = m - a * am;
  const float len = length(u);
  if (!(len > 0)) return a;  // m opposite a: every rim direction is as near
  u = u / len;
  const double cosT = 1.0 - std::min(omc, 1.0), sinT = std::sqrt(std::max(0.0, omc * (2.0 - omc)));
  return normalize(a * float(cosT) + u * float(sinT));
}
}  // namespace

double Gatherer::vslConeMass(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g) const {
  VslPair pr;
  if (!computeVsl_ || !vslPair(gp, L, g, pr)) return 0;
  const double omc = vslConeOneMinusCos(pr.radius, g.dist);
  const BrdfAt& f = pr.rx->f;
  const Vec3 wo = f.w();
  const Vec3 mirror = pr.rx->frame.toWorld(Vec3(-wo.x, -wo.y, wo.z));
  const float pdf = f.pdf(pr.rx->frame.toLocal(nearestInCone(g.l, omc, mirror)));
  const double solidAngle = 2.0 * M_PI * omc, mass = double(pdf) * solidAngle;
  // Where the light's own lobe is narrower than the cone (its pdf could put
  // more than kVslStrategyMass of its samples there), the integrand varies
  // over the cone with that lobe, which the receiver's samples do not
  // follow (the quadrature samples it): their share shrinks in proportion.
  const double massP = double(pr.em->f.pdfBound()) * solidAngle;
  const double share = massP > kVslStrategyMass ? kVslStrategyMass / massP : 1.0;
  return std::isfinite(mass * share) ? std::clamp(mass * share, 0.0, 1.0) : 0.0;
}

float Gatherer::vslRadiusScaleBound() const {
  if (lobeRadius_ > 0) return kInf;
  return lobeFloor_ > 0 ? kVslLobeFloorRadiusScale : 1.0f;
}

void Gatherer::addVslResult(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, const VslResult& r,
                            double acc[kGatherLayers][3], GatherCounters& c) const {
  c.vslEvaluations += uint64_t(r.evaluations);
  const Vec3 v = gp.beta * L.Phi * r.transfer;
  addLayer(acc, kVslLayer, g.weight == 1 ? v : v * g.weight, c);
}

namespace {
// v.size() at least n, its first elements kept.
template <typename T>
void growTo(std::vector<T>& v, size_t n) {
  if (v.size() < n) v.resize(n);
}
}  // namespace

void Gatherer::packVslReceivers(std::span<const GatherPoint* const> pts, std::vector<float>& packed) const {
  packed.clear();
  if (!computeVsl_ || vsl_.integral != VslIntegral::Sg) return;
  packed.assign(pts.size() * BrdfAt::kPackedFloats, 0.0f);
  for (size_t i = 0; i < pts.size(); ++i)
    if (pts[i]) (pts[i]->lobe ? pts[i]->rx.f.diffuseLobe() : pts[i]->rx.f).pack(&packed[i * BrdfAt::kPackedFloats]);
}

void Gatherer::vslPrepare(std::span<const GatherPoint* const> pts, const float* packedRx, const uint32_t* list,
                          size_t n, const GatherLight& L, const PairGeometry* geo, VslBlock& b) const {
  if (!computeVsl_) return;
  constexpr size_t kP = BrdfAt::kPackedFloats;
  // The buffers only grow: a resize down and up again would construct the
  // pairs anew (each holds two BRDFs) for every light.
  growTo(b.pairs_, n);
  growTo(b.kind_, n);
  std::fill_n(b.kind_.begin(), n, uint8_t(0));
  growTo(b.sgOf_, n);
  growTo(b.sg_, n);
  // Record 0: the light's BRDF; then two per closed-form pair (the receiver
  // and, where the floor widened it, the light). Under the quadrature no
  // pair is in closed form: nothing to pack.
  const bool sg = vsl_.integral == VslIntegral::Sg;
  if (sg) growTo(b.packed_, (2 * n + 1) * kP);
  if (sg) L.em.f.pack(b.packed_.data());
  size_t nsg = 0;
  for (size_t v = 0; v < n; ++v) {
    const uint32_t i = list[v];
    VslPair& pr = b.pairs_[v];
    if (!vslPair(*pts[i], L, geo[i], pr)) continue;
    if (!vslTakesSg(pr, geo[i])) {
      b.kind_[v] = 2;
      continue;
    }
    b.kind_[v] = 1;
    b.sgOf_[v] = uint32_t(nsg);
    float* rec = b.packed_.data() + (2 * nsg + 1) * kP;
    const float* rx = packedRx ? packedRx + size_t(i) * kP : rec;
    if (!packedRx) pr.rx->f.pack(rec);
    const float* em = b.packed_.data();
    if (pr.em != &L.em) {
      pr.em->f.pack(rec + kP);
      em = rec + kP;
    }
    b.sg_[nsg++] = {pr.rx, pr.em, rx, em, geo[i].d, pr.radius};
  }
  growTo(b.transfer_, nsg);
  vslTransferSgMany(int(nsg), b.sg_.data(), vsl_, b.transfer_.data());
}

void Gatherer::addVslPrepared(const VslBlock& b, size_t v, const GatherPoint& gp, const GatherLight& L,
                              const PairGeometry& g, uint64_t lightId, uint64_t pixel, double acc[kGatherLayers][3],
                              GatherCounters& c) const {
  if (!computeVsl_ || b.kind_[v] == 0) return;
  VslResult r;
  if (b.kind_[v] == 1) {
    r.transfer = b.transfer_[b.sgOf_[v]];
  } else {
    const VslPair& pr = b.pairs_[v];
    Rng prng = Rng::forItem(pixel, lightId, 3, seed_);
    r = vslTransferBlock(*pr.rx, *pr.em, g.d, pr.radius, vsl_, prng);
  }
  addVslResult(gp, L, g, r, acc, c);
}

namespace {

// The direction inside the cone (unit axis a, cos and sin of its half-angle)
// closest to the unit direction v.
Vec3 closestInCone(const Vec3& a, float cosT, float sinT, const Vec3& v) {
  const float c = dot(a, v);
  if (c >= cosT) return v;
  Vec3 perp = v - a * c;
  const float pl = length(perp);
  if (!(pl > 1e-7f)) return a;  // v opposite the axis: any rim direction is as close
  return a * cosT + perp * (sinT / pl);
}

// The largest cosine with a normal over the cone, given the cosine at its axis.
float largestCosine(float cosAxis, float cosT, float sinT) {
  const float sinAxis = std::sqrt(std::max(0.0f, 1.0f - cosAxis * cosAxis));
  // cos(max(0, phi - theta)) with phi the axis's angle to the normal.
  return cosAxis >= cosT ? 1.0f : std::min(1.0f, cosAxis * cosT + sinAxis * sinT);
}

}  // namespace

float Gatherer::pairEstimate(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g) const {
  float e = computeVsl_ ? vslBound(gp, L, g) : 0.0f;
  if (computeVpl_) {
    const Vec3 fx = gp.rx.f.eval(gp.rx.frame.toLocal(g.l)), fp = L.em.f.eval(L.em.frame.toLocal(-g.l));
    const float v = luminance(gp.beta * L.Phi * fx * fp) * (g.cosX * g.cosP / g.d2);
    e = std::max(e, std::isfinite(v) ? v : std::numeric_limits<float>::infinity());
  }
  return e;
}

float Gatherer::vslBound(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g) const {
  VslPair pr;
  if (!vslPair(gp, L, g, pr)) return 0;
  const double omc = vslConeOneMinusCos(pr.radius, g.dist);
  const float cosT = float(1.0 - omc), sinT = float(std::sqrt(std::max(0.0, omc * (2.0 - omc))));
  // Each lobe's peak: the receiver's mirror direction of wo; the light's
  // mirror direction of its incoming light, seen from x along its reverse.
  const Vec3 wo = pr.rx->f.w(), we = pr.em->f.w();
  const Vec3 peakX = pr.rx->frame.toWorld(Vec3(-wo.x, -wo.y, wo.z));
  const Vec3 peakP = -pr.em->frame.toWorld(Vec3(-we.x, -we.y, we.z));
  const Vec3 lx = closestInCone(g.l, cosT, sinT, peakX), lp = closestInCone(g.l, cosT, sinT, peakP);
  const Vec3 lxL = pr.rx->frame.toLocal(lx), lpL = pr.em->frame.toLocal(-lp);
  // Below a side's surface the BRDF is zero: take it at the cone's axis,
  // and at the hemisphere's edge if that is below too (a grazing cone).
  auto evalUp = [](const BrdfAt& f, Vec3 wl, const Vec3& axisL) {
    if (!(wl.z > 1e-4f)) wl = axisL;
    if (!(wl.z > 1e-4f)) wl = normalize(Vec3(wl.x, wl.y, 1e-3f));
    return f.eval(wl);
  };
  // Channel by channel (the luminance of a product of colours is not the
  // product of their luminances: a red light on a gold wall).
  // An anisotropic lobe's largest value over the cone need not lie nearest
  // its peak by angle: D is at most the isotropic D of the wider axis times
  // (wider / narrower alpha), so that ratio stands in for the search.
  auto anisotropy = [](const BrdfAt& f) {
    const GGX& a = f.brdf().ggx;
    return f.specularOn() ? std::max(a.ax, a.ay) / std::max(std::min(a.ax, a.ay), 1e-6f) : 1.0f;
  };
  const Vec3 fx = evalUp(pr.rx->f, lxL, pr.rx->frame.toLocal(g.l)) * anisotropy(pr.rx->f);
  const Vec3 fp = evalUp(pr.em->f, lpL, pr.em->frame.toLocal(-g.l)) * anisotropy(pr.em->f);
  const float cx = largestCosine(g.cosX, cosT, sinT), cp = largestCosine(g.cosP, cosT, sinT);
  const double area =
      vsl_.clippedDisk ? vslClippedDiskArea(pr.radius, dot(g.d, pr.rx->ng)) : M_PI * double(pr.radius) * pr.radius;
  if (!(area > 0)) return std::numeric_limits<float>::infinity();
  const double solid = 2.0 * M_PI * omc;
  const double b = double(luminance(gp.beta * L.Phi * fx * fp)) * cx * cp * solid / area;
  return std::isfinite(b) ? float(b) : std::numeric_limits<float>::infinity();
}

}  // namespace vsl
