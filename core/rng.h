// Deterministic random numbers. Every stream is seeded from the tuple that
// identifies the work item (pixel, sample index, pass, user seed), so any pixel
// sample can be replayed alone, on any thread, in any order.
#pragma once

#include <cstdint>

#include "core/math.h"

namespace vsl {

// 64-bit finaliser (MurmurHash3 fmix64): a good avalanche for seeding.
inline uint64_t mix64(uint64_t v) {
  v ^= v >> 33;
  v *= 0xff51afd7ed558ccdULL;
  v ^= v >> 33;
  v *= 0xc4ceb9fe1a85ec53ULL;
  v ^= v >> 33;
  return v;
}

inline uint64_t hashCombine(uint64_t a, uint64_t b) { return mix64(a ^ (mix64(b) + 0x9e3779b97f4a7c15ULL)); }

// PCG32's multiplier M, and k of its steps in one: state' = mul state +
// inc add, with mul = M^k and add = 1 + M + ... + M^(k-1) (Rng::uniforms).
constexpr uint64_t kPcgMultiplier = 6364136223846793005ULL;
struct PcgJump {
  uint64_t mul, add;
};
constexpr PcgJump pcgJump(int k) {
  PcgJump j{1, 0};
  for (int i = 0; i < k; ++i) j = {j.mul * kPcgMultiplier, j.add * kPcgMultiplier + 1};
  return j;
}

// PCG32 (O'Neill 2014): 64-bit state, 32-bit output, selectable stream.
class Rng {
 public:
  Rng() : Rng(0, 0) {}
  Rng(uint64_t seed, uint64_t stream) { setSequence(seed, stream); }

  // Seed from (a, b, c, d): typically (pixel, sample, pass, seed).
  static Rng forItem(uint64_t a, uint64_t b, uint64_t c, uint64_t d) {
    uint64_t h = hashCombine(hashCombine(hashCombine(mix64(d), c), b), a);
    return Rng(h, mix64(h + 1));
  }

  void setSequence(uint64_t seed, uint64_t stream) {
    state_ = 0;
    inc_ = (stream << 1u) | 1u;
    next();
    state_ += seed;
    next();
  }

  uint32_t next() {
    uint64_t old = state_;
    state_ = old * kMul + inc_;
    return output(old);
  }

  // Uniform in [0, 1): 24 random mantissa bits, never returns 1.
  float uniform() { return toUniform(next()); }
  // n uniforms, the ones n calls of uniform() would give, in that order, and
  // the generator left where they would leave it. The state k steps on is
  // M^k s + inc a_k (pcgJump(k)), so chains a step apart, each striding k steps,
  // make them without waiting on one multiply after the other: four chains
  // (uniformsScalar) or eight in AVX2 lanes (uniformsAvx2, where
  // simdAvailable(); the same numbers).
  void uniforms(float* out, int n) {
    if (n >= 16 && simdAvailable())
      uniformsAvx2(out, n);
    else
      uniformsScalar(out, n);
  }
  void uniformsScalar(float* out, int n) {
    int i = 0;
    if (n >= 8) {
      constexpr PcgJump k4 = pcgJump(4);
      const uint64_t inc4 = inc_ * k4.add;
      uint64_t s0 = state_, s1 = s0 * kMul + inc_, s2 = s1 * kMul + inc_, s3 = s2 * kMul + inc_;
      for (; i + 4 <= n; i += 4) {
        out[i] = toUniform(output(s0));
        out[i + 1] = toUniform(output(s1));
        out[i + 2] = toUniform(output(s2));
        out[i + 3] = toUniform(output(s3));
        s0 = s0 * k4.mul + inc4;
        s1 = s1 * k4.mul + inc4;
        s2 = s2 * k4.mul + inc4;
        s3 = s3 * k4.mul + inc4;
      }
      state_ = s0;
    }
    for (; i < n; ++i) out[i] = uniform();
  }
  // The same with eight chains in AVX2 lanes (the 64-bit products from
  // 32-bit ones): only where simdAvailable().
  void uniformsAvx2(float* out, int n);
  double uniformDouble() { return double((uint64_t(next()) << 21) ^ next()) * 0x1p-53; }
  // Uniform integer in [0, n) for n > 0.
  uint32_t uniformInt(uint32_t n) { return uint32_t((uint64_t(next()) * n) >> 32); }

 private:
  static constexpr uint64_t kMul = kPcgMultiplier;
  static uint32_t output(uint64_t old) {
    uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = uint32_t(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31));
  }
  static float toUniform(uint32_t v) { return float(v >> 8) * 0x1p-24f; }
  uint64_t state_ = 0, inc_ = 1;
};

}  // namespace vsl
