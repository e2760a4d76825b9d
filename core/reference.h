// Converged references and their own noise.
//
// A reference is a path-traced image (full, direct and indirect layers) kept
// as two independent halves: half A holds the even sample indices, half B the
// odd ones, so A and B are independent estimates with the same expected
// error, and the reference is their mean.
//
// Its own noise: for independent unbiased halves, E[(A - B)^2] = 2 Var(half)
// and Var(mean) = Var(half) / 2, so the reference's expected relMSE against
// the truth is relMSE(A, B) / 4 (the same relMSE as compare.h, its
// denominator from B). A test image T independent of the reference R has
// E[relMSE(T, R)] = relMSE(T, truth) + relMSE(R, truth) to first order, so the
// studio and `vsl sweep` subtract this estimate from every error they show.
//
// Files: one multi-layer EXR with layers full, direct, indirect (the mean),
// A.full, A.direct, A.indirect, B.full, B.direct, B.indirect and attributes
// vsl.reference.spp, vsl.reference.seconds, vsl.reference.key. Another
// renderer's EXR is accepted at the right size: its `indirect` layer (or one
// named) when it has one, else its full image (a layer `full`, else the
// unnamed one), which is then the component compared (fullOnly); without
// halves its noise is unknown.
//
// Method: the path tracer (core/pathtracer.h, the default) or bidirectional
// path tracing (core/bdpt.h), which converges where light reaches the view
// through glossy reflections of small lights; the file's vsl.method says which.
//
// Cache: references are stored as CACHE/<key>.exr, the key naming the scene
// file's content, the camera, the resolution, the path depth and, for BDPT,
// the method (see referenceKey). CACHE is $VSL_REFERENCE_CACHE, else
// $XDG_CACHE_HOME/vsl-studio/references, else ~/.cache/vsl-studio/references.
#pragma once

#include "core/environment.h"

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "core/bdpt.h"
#include "core/film.h"
#include "core/pathtracer.h"
#include "core/result.h"

namespace vsl {

// The seed of references by default (`vsl reference`, the studio's
// background reference): the studio's live path tracer uses 0 and `vsl
// sweep` 1 onwards, so a reference is independent of both.
constexpr uint64_t kReferenceSeed = 7777;

// The renderer of a reference (the run parameter `reference-method`).
enum class ReferenceMethod { PathTracer = 0, Bdpt = 1 };
const char* referenceMethodName(ReferenceMethod m);  // "pt", "bdpt"

struct Reference {
  int width = 0, height = 0;
  Image full, direct, indirect;  // the mean of the halves
  // Independent halves (empty for another renderer's image).
  Image fullA, directA, indirectA, fullB, directB, indirectB;
  int spp = 0;                // samples per pixel in both halves together (0: unknown)
  double seconds = 0;         // compute time (0: unknown)
  std::string source;         // the file it came from ("" for one rendered in memory)
  std::string key;            // its cache key, when it has one
  std::string method = "pt";  // the renderer: "pt" or "bdpt" (vsl.method)
  bool hasHalves() const { return !indirectA.rgb.empty() && !indirectB.rgb.empty(); }
  // Only a full image (another renderer's): methods are compared on the full
  // component against it, not the indirect one.
  bool fullOnly() const { return indirect.rgb.empty() && !full.rgb.empty(); }
  // Expected relMSE of the indirect (full) layer against the truth:
  // relMSE(A, B) / 4; negative when unknown (no halves).
  double indirectNoise() const;
  double fullNoise() const;  // the same from the full halves; negative when unknown
  // The noise of the component compared: fullNoise() when fullOnly().
  double comparedNoise() const { return fullOnly() ? fullNoise() : indirectNoise(); }
};

// Renders a reference progressively: pass p (one sample per pixel, the path
// tracer's or BDPT's sample index p) goes to half p % 2. step() adds one pass to each
// half, stepPass() one pass to the next half in turn (the studio's live path
// tracer). A stopped step changes nothing visible: the pass renders into
// scratch films (reused, never reallocated) that replace the halves' films
// only once complete, and its indices are skipped so that no sample is ever
// reused. Not thread-safe: one thread steps it and reads it.
class ReferenceRenderer {
 public:
  ReferenceRenderer(const Scene& scene, const Accel& accel, const LightSampler& lights, const RenderSettings& settings,
                    ReferenceMethod method = ReferenceMethod::PathTracer);
  int width() const { return pt_.width(); }
  int height() const { return pt_.height(); }
  ReferenceMethod method() const { return bdpt_ ? ReferenceMethod::Bdpt : ReferenceMethod::PathTracer; }
  // Adds two samples per pixel (one per half). Returns false, changing
  // nothing visible, if *stop became true.
  bool step(const std::atomic<bool>* stop = nullptr);
  // Adds one sample per pixel to half nextPass % 2. Returns false, changing
  // nothing visible, if *stop became true.
  bool stepPass(const std::atomic<bool>* stop = nullptr);
  int spp() const { return passes_; }  // completed passes in both halves
  double seconds() const { return seconds_; }
  // Cheap: the indirect noise estimate alone (negative before both halves
  // have a sample).
  double indirectNoise() const;
  // The mean of the halves (cheaper than result()), and one half.
  Image meanDirect() const { return average(direct_[0].image(), direct_[1].image()); }
  Image meanIndirect() const { return average(indirect_[0].image(), indirect_[1].image()); }
  Image halfIndirect(int h) const { return indirect_[h].image(); }
  Image halfFull(int h) const { return sum(direct_[h].image(), indirect_[h].image()); }
  Reference result() const;
  // Path and ray counts, and contributions the path tracer rejected as non-finite.
  const PtCounters& counters() const { return counters_; }
  uint64_t rejected() const;

 private:
  bool renderPasses(int count, const std::atomic<bool>* stop);
  PathTracer pt_;
  std::unique_ptr<BdptRenderer> bdpt_;  // set for ReferenceMethod::Bdpt
  Film direct_[2], indirect_[2];
  Film scratchDirect_[2], scratchIndirect_[2];  // a step in progress, by its half
  PtCounters counters_;
  int passes_ = 0, nextPass_ = 0;
  double seconds_ = 0;
};

// The cache key: scene file name, a 64-bit FNV-1a hash over the scene file's
// bytes and the loaded geometry and textures (which covers external buffers
// and images), the camera's name and pose, the resolution and the path depth:
// "NAME-HASH-WxH-dD"; a BDPT reference's key ends in "-bdpt". An environment
// light (core/environment.h) other than none adds its description and its
// map file's bytes to the hash; without one the key is what it always was.
std::string referenceKey(const Scene& scene, int width, int height, int maxDepth, const EnvironmentSettings& env = {},
                         ReferenceMethod method = ReferenceMethod::PathTracer);
// Success unless ref carries a key (vsl reference writes one) whose scene
// hash differs from scene's: then an error naming path, both keys and the
// fix. A reference without a key (another renderer's EXR) cannot be checked.
// env: the environment the scene is lit by (none by default), as referenceKey.
Result<void> checkReferenceScene(const Reference& ref, const Scene& scene, const std::string& path,
                                 const EnvironmentSettings& env = {});
std::string referenceCacheDir();
std::string referenceCachePath(const std::string& key);

// Writes a reference with its halves and attributes (atomically); half:
// 16-bit channels (writeExr).
Result<void> writeReference(const std::string& path, const Reference& ref, const std::string& scenePath,
                            bool half = false);
// Reads any EXR as a reference of width x height (0: any size): the
// `indirect` layer (or the layer named indirectLayer), full and direct
// optional (a missing full is direct + indirect when both exist). Without an
// `indirect` layer (the default name only), a full image is read as a
// fullOnly() reference. Errors name the file and the problem (another size,
// no usable layer, non-finite values).
Result<Reference> readReference(const std::string& path, int width, int height,
                                const std::string& indirectLayer = "indirect");
// The references shipped with the source (assets/references/<key>.exr, made
// by scripts/make_references.sh; docs/REFERENCE.md, "References"), or
// $VSL_SHIPPED_REFERENCES when set ("": none; the tests set it so).
std::string shippedReferenceDir();
// The reference for this key with the more samples of the cache's and the
// shipped one (source says which file), if either exists and reads; null
// otherwise.
std::unique_ptr<Reference> findCachedReference(const std::string& key, int width, int height);
// The reference of this scene and size under either method's key
// (findCachedReference for each): the one with the lower own noise, the
// preferred method's when only it has halves or on a tie; null when neither
// exists. A BDPT reference found for a path-traced key's user (or the
// reverse) is as good a reference: both converge to the same image.
std::unique_ptr<Reference> findCachedReferenceAnyMethod(const Scene& scene, int width, int height, int maxDepth,
                                                        const EnvironmentSettings& env, ReferenceMethod preferred);
// Stores ref in the cache unless an entry with at least as many samples is
// already there. Returns the path written ("" if kept the existing one); an
// error on I/O failure.
Result<std::string> storeCachedReference(const Reference& ref, const std::string& scenePath, bool half = false);

}  // namespace vsl
