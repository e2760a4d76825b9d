// Google Benchmark microbenchmarks for the inner loops: BRDF evaluation and
// sampling (one BRDF, or many each at its own direction), the VSL cone
// integral, and k-NN radii.
//   build/bin/vsl_microbench [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include "core/material.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/virtual_lights.h"
#include "core/vsl_integral.h"
#include "core/vsl_sg.h"

using namespace vsl;

namespace {

std::vector<Vec3> directions(size_t n, uint64_t seed) {
  Rng r(seed, 1);
  std::vector<Vec3> v(n);
  for (Vec3& w : v) w = sampleCosineHemisphere({r.uniform(), r.uniform()});
  return v;
}

void BM_BrdfEval(benchmark::State& state) {
  Brdf b = Brdf::fromGltf(Vec3(0.8f, 0.6f, 0.4f), state.range(0) / 100.0f, 0.4f, 0.5f);
  auto wo = directions(1024, 1), wi = directions(1024, 2);
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(b.eval(wo[i & 1023], wi[i & 1023]));
    ++i;
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_BrdfEval)->Arg(0)->Arg(100);

// The gather's form: one direction fixed per gather point or light.
void BM_BrdfAtEval(benchmark::State& state) {
  Brdf b = Brdf::fromGltf(Vec3(0.8f, 0.6f, 0.4f), state.range(0) / 100.0f, 0.4f, 0.5f);
  BrdfAt at(b, normalize(Vec3(0.3f, 0.1f, 1.0f)));
  auto wi = directions(1024, 2);
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(at.evalParts(wi[i & 1023]));
    ++i;
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_BrdfAtEval)->Arg(0)->Arg(100);

void BM_BrdfSample(benchmark::State& state) {
  Brdf b = Brdf::fromGltf(Vec3(0.8f), 0.0f, 0.3f, 0.0f);
  auto wo = directions(1024, 3);
  Rng r(5, 5);
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(b.sample(wo[i & 1023], r.uniform(), {r.uniform(), r.uniform()}));
    ++i;
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_BrdfSample);

// The cone integral for a narrow cone (0.6 degrees: 1 sample per strategy),
// cones of 1.1, 2.8 and 5.6 degrees (2, 4 and 7 per strategy), a 15-degree
// cone (17 per strategy) and a 29-degree one (33 per strategy), in
// the scalar reference form and the block form the gather uses.
template <bool kBlock>
void BM_VslCone(benchmark::State& state) {
  VslReceiver x;
  x.f = BrdfAt(Brdf::fromGltf(Vec3(0.8f), 0.0f, 0.5f, 0.0f), normalize(Vec3(0.3f, 0.1f, 1.0f)));
  x.frame = Frame(Vec3(0, 0, 1));
  x.ng = Vec3(0, 0, 1);
  VslEmitter p;
  p.f = BrdfAt(Brdf::fromGltf(Vec3(0.9f), 1.0f, 0.3f, 0.0f), normalize(Vec3(0.2f, 0.0f, 1.0f)));
  p.frame = Frame(Vec3(0, 0, -1));
  Vec3 toLight(0.2f, 0.1f, 1.0f);
  double radius = state.range(0) / 100.0;
  Rng r(9, 9);
  for (auto _ : state)
    benchmark::DoNotOptimize(kBlock ? vslTransferBlock(x, p, toLight, radius, {}, r)
                                    : vslTransfer(x, p, toLight, radius, {}, r));
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_VslCone<false>)->Arg(1)->Arg(2)->Arg(5)->Arg(10)->Arg(27)->Arg(50);
BENCHMARK(BM_VslCone<true>)->Arg(1)->Arg(2)->Arg(5)->Arg(10)->Arg(27)->Arg(50);

// One pair's transfer, three ways, over the same 1,024 random pairs
// (receivers and lights of mixed materials, cone half-angles 0.5-10
// degrees): the clamped VPL's (both BRDFs at the direction to the light, the
// geometry term, the clamp on luminance; what Gatherer::addVpl computes), the
// closed-form VSL's (vslTransferSg) and the quadrature's at the renderers'
// default count (vslTransferBlock). Compare items/s within one run.
struct PairSet {
  std::vector<VslReceiver> x;
  std::vector<VslEmitter> p;
  std::vector<Vec3> toLight;
  std::vector<double> radius;
};
const PairSet& benchPairs() {
  static const PairSet set = [] {
    PairSet s;
    Rng r(21, 21);
    const Brdf kinds[] = {Brdf::fromGltf(Vec3(0.7f), 0.0f, 1.0f, 0.0f), Brdf::fromGltf(Vec3(0.5f), 0.0f, 0.3f, 0.0f),
                          Brdf::fromGltf(Vec3(0.9f), 1.0f, 0.4f, 0.0f), Brdf::fromGltf(Vec3(0.9f), 1.0f, 0.3f, 0.7f)};
    for (int i = 0; i < 1024; ++i) {
      VslReceiver x;
      x.frame = Frame(Vec3(0, 0, 1));
      x.ng = Vec3(0, 0, 1);
      x.f = BrdfAt(kinds[r.uniformInt(4)], sampleCosineHemisphere({r.uniform(), r.uniform()}));
      VslEmitter p;
      const Vec3 a = sampleCosineHemisphere({r.uniform(), r.uniform()});
      p.frame = Frame(normalize(-a + Vec3(0.3f * r.uniform(), 0.3f * r.uniform(), 0)));
      p.f = BrdfAt(kinds[r.uniformInt(4)], sampleCosineHemisphere({r.uniform(), r.uniform()}));
      s.x.push_back(x);
      s.p.push_back(p);
      s.toLight.push_back(a * 2.0f);
      s.radius.push_back(2.0 * std::sin((0.5 + 9.5 * r.uniform()) * M_PI / 180.0));
    }
    return s;
  }();
  return set;
}

void BM_PairVpl(benchmark::State& state) {
  const PairSet& s = benchPairs();
  const float clamp = 10.0f;
  size_t i = 0;
  for (auto _ : state) {
    const size_t k = i++ & 1023;
    const Vec3 d = s.toLight[k];
    const float d2 = lengthSquared(d);
    const Vec3 l = d / std::sqrt(d2);
    const Vec3 lx = s.x[k].frame.toLocal(l), lp = s.p[k].frame.toLocal(-l);
    Vec3 t = s.x[k].f.eval(lx) * s.p[k].f.evalParts(lp).total() * (lx.z * lp.z / d2);
    const float y = luminance(t);
    if (y > clamp) t *= clamp / y;
    benchmark::DoNotOptimize(t);
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_PairVpl);

void BM_PairSg(benchmark::State& state) {
  const PairSet& s = benchPairs();
  size_t i = 0;
  for (auto _ : state) {
    const size_t k = i++ & 1023;
    benchmark::DoNotOptimize(vslTransferSg(s.x[k], s.p[k], s.toLight[k], s.radius[k], {}));
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_PairSg);

// The closed form on eight AVX2 lanes (vslTransferSgMany, core/vsl_sg_avx2.cpp),
// eight of the same pairs per call; items are pairs. Arg 1: the BRDFs packed
// beforehand (the gather packs a receiver once per tile and a light once per
// tile pass); 0: packed in the call.
void BM_PairSg8(benchmark::State& state) {
  const PairSet& s = benchPairs();
  if (!simdAvailable()) {
    state.SkipWithError("this CPU has no AVX2");
    return;
  }
  std::vector<float> packed(2 * 1024 * BrdfAt::kPackedFloats);
  std::vector<VslSgPair> pairs(1024);
  for (size_t k = 0; k < 1024; ++k) {
    float* px = &packed[(2 * k) * BrdfAt::kPackedFloats];
    float* pp = &packed[(2 * k + 1) * BrdfAt::kPackedFloats];
    s.x[k].f.pack(px);
    s.p[k].f.pack(pp);
    const bool pre = state.range(0) == 1;
    pairs[k] = {&s.x[k], &s.p[k], pre ? px : nullptr, pre ? pp : nullptr, s.toLight[k], float(s.radius[k])};
  }
  Vec3 out[8];
  size_t i = 0;
  for (auto _ : state) {
    vslTransferSgMany(8, &pairs[i], {}, out);
    i = (i + 8) & 1023;
    benchmark::DoNotOptimize(out[7]);
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * 8);
}
BENCHMARK(BM_PairSg8)->Arg(0)->Arg(1);

void BM_PairQuadrature(benchmark::State& state) {
  const PairSet& s = benchPairs();
  VslOptions o;
  o.count = VslCount::Lobe;
  Rng r(3, 3);
  size_t i = 0;
  for (auto _ : state) {
    const size_t k = i++ & 1023;
    benchmark::DoNotOptimize(vslTransferBlock(s.x[k], s.p[k], s.toLight[k], s.radius[k], o, r));
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_PairQuadrature);

// One lobe-gather estimate's BRDF evaluations: 31 map lights, each its own
// BRDF (metals and dielectrics, rough to narrow) at its own direction: one
// BrdfAt::evalParts after the other (0), or eight packed records to a register
// (1, BrdfAt::evalTotalsPackedAvx2, what LobeGatherMap::radiance uses).
void BM_ManyBrdfs(benchmark::State& state) {
  constexpr int kN = 31;
  Rng r(13, 13);
  std::vector<BrdfAt> brdfs;
  std::vector<float> packed(kN * BrdfAt::kPackedFloats);
  const BrdfAt* ptr[kN];
  const float* rec[kN];
  float wx[kN], wy[kN], wz[kN], f[3][kN];
  float* const out[3] = {f[0], f[1], f[2]};
  brdfs.reserve(kN);
  auto wi = directions(kN, 4), wo = directions(kN, 5);
  for (int i = 0; i < kN; ++i) {
    const float metallic = i % 3 == 0 ? 0.0f : 1.0f, roughness = 0.05f + 0.9f * r.uniform();
    brdfs.emplace_back(Brdf::fromGltf(Vec3(0.9f, 0.7f, 0.5f), metallic, roughness, i % 4 == 0 ? 0.8f : 0.0f), wo[i]);
    brdfs.back().pack(&packed[size_t(i) * BrdfAt::kPackedFloats]);
    ptr[i] = &brdfs.back();
    rec[i] = &packed[size_t(i) * BrdfAt::kPackedFloats];
    wx[i] = wi[i].x;
    wy[i] = wi[i].y;
    wz[i] = wi[i].z;
  }
  const int mode = int(state.range(0));
  if (mode > 0 && !simdAvailable()) {
    state.SkipWithError("this CPU has no AVX2");
    return;
  }
  for (auto _ : state) {
    if (mode == 0) {
      for (int i = 0; i < kN; ++i) {
        const Vec3 v = ptr[i]->evalParts(Vec3(wx[i], wy[i], wz[i])).total();
        for (int c = 0; c < 3; ++c) f[c][i] = v[c];
      }
    } else {
      BrdfAt::evalTotalsPackedAvx2(kN, rec, wx, wy, wz, false, out);
    }
    benchmark::DoNotOptimize(f[1][kN - 1]);
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * kN);
}
BENCHMARK(BM_ManyBrdfs)->Arg(0)->Arg(1);

void BM_KnnRadii(benchmark::State& state) {
  Rng r(11, 11);
  std::vector<VirtualLight> lights(size_t(state.range(0)));
  for (auto& v : lights) v.p = Vec3(r.uniform(), r.uniform(), r.uniform());
  for (auto _ : state) benchmark::DoNotOptimize(knnRadii(lights, 10, 1.0f, 1.0f, 1e-9f));
  state.SetItemsProcessed(int64_t(state.iterations()) * state.range(0));
}
BENCHMARK(BM_KnnRadii)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
