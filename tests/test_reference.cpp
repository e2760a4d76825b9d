// Converged references: halves, their noise estimate, files and the cache.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>

#include "core/compare.h"
#include "core/image_io.h"
#include "core/reference.h"
#include "tests/support.h"

using namespace vsl;

namespace {

std::string tempDir(const std::string& name) {
  auto d = std::filesystem::temp_directory_path() / ("vsl-test-reference-" + name + "-" + std::to_string(getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d.string();
}

vsl::Reference renderReference(const test::Loaded& l, int w, int h, int spp, uint64_t seed) {
  RenderSettings rs;
  rs.width = w;
  rs.height = h;
  rs.seed = seed;
  ReferenceRenderer rr(*l.scene, *l.accel, *l.lights, rs);
  while (rr.spp() < spp) EXPECT_TRUE(rr.step());
  return rr.result();
}

}  // namespace

// The mean of the halves is exactly the path tracer's image with the same
// sample indices: the halves split the samples, they add none.
TEST(Reference, MeanOfHalvesIsThePathTracersImage) {
  test::Loaded l = test::loadAsset("cornell-glossy", 24);
  vsl::Reference r = renderReference(l, 24, 24, 8, 3);
  RenderSettings rs;
  rs.width = 24;
  rs.height = 24;
  rs.seed = 3;
  PathTracer pt(*l.scene, *l.accel, *l.lights, rs);
  Film d(24, 24), ind(24, 24);
  PtCounters c;
  for (int s = 0; s < 8; ++s) pt.renderPass(s, d, ind, c);
  Image pi = ind.image();
  ASSERT_EQ(r.indirect.rgb.size(), pi.rgb.size());
  for (size_t i = 0; i < pi.rgb.size(); ++i) ASSERT_NEAR(r.indirect.rgb[i], pi.rgb[i], 1e-5f * (1 + pi.rgb[i])) << i;
  EXPECT_EQ(r.spp, 8);
  EXPECT_TRUE(r.hasHalves());
}

// Single passes alternate between the halves with the same sample indices
// as pairs (so the images are bit-identical), and a stopped step changes
// nothing visible but uses up its indices.
TEST(Reference, SinglePassesMatchPairsAndAStoppedStepChangesNothing) {
  test::Loaded l = test::loadAsset("cornell-glossy", 16);
  RenderSettings rs;
  rs.width = 16, rs.height = 16, rs.seed = 5;
  ReferenceRenderer pairs(*l.scene, *l.accel, *l.lights, rs), singles(*l.scene, *l.accel, *l.lights, rs);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(pairs.step());
  for (int i = 0; i < 6; ++i) ASSERT_TRUE(singles.stepPass());
  EXPECT_EQ(singles.spp(), 6);
  EXPECT_EQ(pairs.result().indirectA.rgb, singles.result().indirectA.rgb);
  EXPECT_EQ(pairs.result().indirectB.rgb, singles.result().indirectB.rgb);
  EXPECT_EQ(pairs.meanIndirect().rgb, singles.result().indirect.rgb);
  EXPECT_GT(pairs.counters().paths.load(), 0u);

  const std::atomic<bool> stop{true};
  const Image before = singles.meanIndirect();
  EXPECT_FALSE(singles.stepPass(&stop));
  EXPECT_FALSE(singles.step(&stop));
  EXPECT_EQ(singles.spp(), 6);
  EXPECT_EQ(singles.meanIndirect().rgb, before.rgb);
  // The next pass has index 9 (6, 7 and 8 were used up): half B.
  ASSERT_TRUE(singles.stepPass());
  EXPECT_EQ(singles.spp(), 7);
  EXPECT_EQ(singles.result().indirectA.rgb, pairs.result().indirectA.rgb);
  EXPECT_NE(singles.result().indirectB.rgb, pairs.result().indirectB.rgb);
}

// The halves' estimate of the reference's own relMSE against the truth,
// relMSE(A, B) / 4, agrees with what an independent second reference sees:
// relMSE(R1, R2) / 2 estimates the same quantity. Averaged over four seed
// pairs the two estimates agree within 30% (each is a mean over 32x32 pixels
// of heavy-tailed terms; measured: 0.88, halves 0.046 against 0.052).
TEST(Reference, HalvesEstimateTheNoiseAnIndependentRenderSees) {
  test::Loaded l = test::loadAsset("cornell-glossy", 32);
  double fromHalves = 0, fromPairs = 0;
  for (uint64_t k = 0; k < 4; ++k) {
    vsl::Reference r1 = renderReference(l, 32, 32, 32, 10 + 2 * k), r2 = renderReference(l, 32, 32, 32, 11 + 2 * k);
    fromHalves += (r1.indirectNoise() + r2.indirectNoise()) / 2;
    fromPairs += compareImages(r1.indirect, r2.indirect).average.relMse / 2;
  }
  ASSERT_GT(fromPairs, 0);
  EXPECT_NEAR(fromHalves / fromPairs, 1.0, 0.3) << "halves " << fromHalves / 4 << ", pairs " << fromPairs / 4;
  // And it falls with the samples (about as 1/spp).
  vsl::Reference r8 = renderReference(l, 32, 32, 8, 5), r64 = renderReference(l, 32, 32, 64, 5);
  EXPECT_LT(r64.indirectNoise(), r8.indirectNoise() / 3);
}

TEST(Reference, FileRoundTripKeepsLayersHalvesAndSamples) {
  test::Loaded l = test::loadAsset("cornell-glossy", 16);
  vsl::Reference r = renderReference(l, 16, 12, 4, 1);
  r.key = "k1";
  std::string dir = tempDir("file"), path = dir + "/ref.exr";
  Result<void> written = writeReference(path, r, "scene.gltf");
  ASSERT_TRUE(written) << written.error();
  Result<vsl::Reference> read = readReference(path, 16, 12);
  ASSERT_TRUE(read) << read.error();
  const vsl::Reference& back = *read;
  EXPECT_EQ(back.spp, 4);
  EXPECT_EQ(back.key, "k1");
  EXPECT_EQ(back.source, path);
  ASSERT_TRUE(back.hasHalves());
  EXPECT_EQ(back.indirect.rgb, r.indirect.rgb);
  EXPECT_EQ(back.indirectA.rgb, r.indirectA.rgb);
  EXPECT_EQ(back.fullB.rgb, r.fullB.rgb);
  EXPECT_DOUBLE_EQ(back.indirectNoise(), r.indirectNoise());
  // Another size is refused, naming both sizes.
  Result<vsl::Reference> other = readReference(path, 32, 12);
  EXPECT_FALSE(other);
  const std::string& err = other.error();
  EXPECT_NE(err.find("16x12"), std::string::npos) << err;
  EXPECT_NE(err.find("32x12"), std::string::npos) << err;
  std::filesystem::remove_all(dir);
}

// Another renderer's image: its indirect layer when it has one, else its
// full image (a layer `full` or the unnamed one), which is then the component
// compared; without halves the noise is unknown, never zero. A file with
// neither is refused, naming the file and its layers.
TEST(Reference, ForeignImagesAreComparedOnTheComponentTheyHold) {
  std::string dir = tempDir("foreign");
  Image img(8, 8);
  for (float& v : img.rgb) v = 0.5f;
  Result<void> w = writeExr(dir + "/rgb.exr", {{"", img}});
  ASSERT_TRUE(w) << w.error();
  Result<vsl::Reference> r = readReference(dir + "/rgb.exr", 8, 8);
  ASSERT_TRUE(r) << r.error();
  EXPECT_TRUE(r->fullOnly());
  EXPECT_EQ(r->full.rgb, img.rgb);
  EXPECT_TRUE(r->indirect.rgb.empty());
  EXPECT_LT(r->comparedNoise(), 0);
  w = writeExr(dir + "/direct.exr", {{"direct", img}});
  ASSERT_TRUE(w) << w.error();
  r = readReference(dir + "/direct.exr", 8, 8);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("direct.exr: no 'indirect' layer (it has: direct)"), std::string::npos) << r.error();
  w = writeExr(dir + "/ind.exr", {{"indirect", img}, {"direct", img}});
  ASSERT_TRUE(w) << w.error();
  r = readReference(dir + "/ind.exr", 8, 8);
  ASSERT_TRUE(r) << r.error();
  EXPECT_FALSE(r->fullOnly());
  EXPECT_FALSE(r->hasHalves());
  EXPECT_LT(r->indirectNoise(), 0);
  EXPECT_FLOAT_EQ(r->full.rgb[0], 1.0f);  // full = direct + indirect
  // A layer may be named instead, and is then the indirect one.
  r = readReference(dir + "/rgb.exr", 8, 8, "");
  ASSERT_TRUE(r) << r.error();
  EXPECT_FALSE(r->fullOnly());
  // A full-only image with halves A.full and B.full measures its noise.
  Image other = img;
  other.rgb[0] = 1.0f;
  w = writeExr(dir + "/halves.exr", {{"full", img}, {"A.full", img}, {"B.full", other}});
  ASSERT_TRUE(w) << w.error();
  r = readReference(dir + "/halves.exr", 8, 8);
  ASSERT_TRUE(r) << r.error();
  EXPECT_TRUE(r->fullOnly());
  EXPECT_GT(r->comparedNoise(), 0);
  EXPECT_DOUBLE_EQ(r->comparedNoise(), r->fullNoise());
  std::filesystem::remove_all(dir);
}

// A reference with a NaN or an infinity in its indirect layer is refused,
// naming the file and how many values: an all-NaN reference used to score
// every method's error as zero.
TEST(Reference, NonFiniteReferencesAreRefused) {
  std::string dir = tempDir("nonfinite");
  Image img(8, 8);
  for (float& v : img.rgb) v = 0.5f;
  img.rgb[5] = std::nanf("");
  img.rgb[9] = INFINITY;
  Result<void> w = writeExr(dir + "/nan.exr", {{"indirect", img}});
  ASSERT_TRUE(w) << w.error();
  Result<vsl::Reference> r = readReference(dir + "/nan.exr", 8, 8);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("nan.exr: 2 of 192 values of the 'indirect' layer are not finite"), std::string::npos)
      << r.error();
  std::filesystem::remove_all(dir);
}

// Keys follow the scene's content, resolution and depth; the cache keeps the
// entry with the most samples.
TEST(Reference, CacheKeysAndEntries) {
  std::string dir = tempDir("cache");
  setenv("VSL_REFERENCE_CACHE", (dir + "/cache").c_str(), 1);
  test::Loaded l = test::loadAsset("cornell-glossy", 16);
  const std::string k = referenceKey(*l.scene, 16, 16, 64);
  EXPECT_EQ(k, referenceKey(*l.scene, 16, 16, 64));
  EXPECT_NE(k, referenceKey(*l.scene, 16, 17, 64));
  EXPECT_NE(k, referenceKey(*l.scene, 16, 16, 8));
  // The same scene with one more byte in its file is another scene.
  std::string copy = dir + "/cornell-glossy.gltf";
  std::filesystem::copy_file(l.scene->path, copy);
  for (const auto& e : std::filesystem::directory_iterator(std::filesystem::path(l.scene->path).parent_path()))
    if (e.path().extension() == ".bin") std::filesystem::copy_file(e.path(), dir + "/" + e.path().filename().string());
  { std::ofstream(copy, std::ios::app) << " "; }
  SceneResult other = loadScene(copy);
  ASSERT_TRUE(other) << other.error();
  EXPECT_NE(k, referenceKey(**other, 16, 16, 64));

  EXPECT_EQ(findCachedReference(k, 16, 16), nullptr);
  vsl::Reference r = renderReference(l, 16, 16, 8, 0);
  r.key = k;
  Result<std::string> written = storeCachedReference(r, l.scene->path);
  ASSERT_TRUE(written) << written.error();
  EXPECT_EQ(*written, referenceCachePath(k));
  auto found = findCachedReference(k, 16, 16);
  ASSERT_NE(found, nullptr);
  EXPECT_EQ(found->spp, 8);
  EXPECT_EQ(found->indirect.rgb, r.indirect.rgb);
  // Fewer samples never replace more.
  vsl::Reference fewer = renderReference(l, 16, 16, 2, 0);
  fewer.key = k;
  written = storeCachedReference(fewer, l.scene->path);
  ASSERT_TRUE(written) << written.error();
  EXPECT_TRUE(written->empty());
  EXPECT_EQ(findCachedReference(k, 16, 16)->spp, 8);
  unsetenv("VSL_REFERENCE_CACHE");
  std::filesystem::remove_all(dir);
}

// A reference shipped with the source (assets/references/<key>.exr, here a
// folder of the test's) is found by its key beside the cache: the one with
// more samples wins, and it names its file. Written in 16-bit channels, it
// reads back within half's precision.
TEST(Reference, ShippedReferencesAreFoundByKey) {
  std::string dir = tempDir("shipped");
  setenv("VSL_REFERENCE_CACHE", (dir + "/cache").c_str(), 1);
  setenv("VSL_SHIPPED_REFERENCES", (dir + "/shipped").c_str(), 1);
  test::Loaded l = test::loadAsset("cornell-glossy", 16);
  const std::string k = referenceKey(*l.scene, 16, 16, 64);
  vsl::Reference shipped = renderReference(l, 16, 16, 8, 0);
  shipped.key = k;
  std::filesystem::create_directories(dir + "/shipped");
  const std::string path = dir + "/shipped/" + k + ".exr";
  ASSERT_TRUE(writeReference(path, shipped, l.scene->path, /*half=*/true));
  auto found = findCachedReference(k, 16, 16);
  ASSERT_NE(found, nullptr);
  EXPECT_EQ(found->source, path);
  EXPECT_EQ(found->spp, 8);
  for (size_t i = 0; i < shipped.indirect.rgb.size(); ++i)
    EXPECT_NEAR(found->indirect.rgb[i], shipped.indirect.rgb[i], 1e-3f * std::abs(shipped.indirect.rgb[i]) + 1e-7f);
  // A cache entry with more samples wins; one with fewer does not.
  vsl::Reference cached = renderReference(l, 16, 16, 4, 0);
  cached.key = k;
  ASSERT_TRUE(storeCachedReference(cached, l.scene->path));
  EXPECT_EQ(findCachedReference(k, 16, 16)->source, path);
  vsl::Reference more = renderReference(l, 16, 16, 16, 0);
  more.key = k;
  ASSERT_TRUE(storeCachedReference(more, l.scene->path));
  EXPECT_EQ(findCachedReference(k, 16, 16)->spp, 16);
  // VSL_SHIPPED_REFERENCES empty: none shipped (what the tests run with).
  setenv("VSL_SHIPPED_REFERENCES", "", 1);
  std::filesystem::remove_all(dir + "/cache");
  EXPECT_EQ(findCachedReference(k, 16, 16), nullptr);
  unsetenv("VSL_SHIPPED_REFERENCES");
  unsetenv("VSL_REFERENCE_CACHE");
  std::filesystem::remove_all(dir);
}
