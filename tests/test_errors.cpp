// One way to fail (issue 12): Result<T> for bad input, VSL_CHECK for
// invariants (printing both operands), and worker exceptions carried back to
// the caller of parallelFor instead of std::terminate.
#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>

#include "core/check.h"
#include "core/film.h"
#include "core/many_light.h"
#include "core/parallel.h"
#include "core/result.h"
#include "support.h"

using namespace vsl;

namespace {

Result<int> parse(const std::string& s) {
  if (s.empty()) return Error("count: no value given");
  return std::stoi(s);
}

Result<void> positive(int x) {
  if (x <= 0) return Error("x: must be > 0 (got " + std::to_string(x) + ")");
  return {};
}

}  // namespace

// ---- Result<T> ------------------------------------------------------------------------

TEST(Result, HoldsAValue) {
  Result<int> r = parse("42");
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(bool(r));
  EXPECT_EQ(r.value(), 42);
  EXPECT_EQ(*r, 42);
  EXPECT_EQ(r.error(), "");
  EXPECT_EQ(r.valueOr(7), 42);
}

TEST(Result, HoldsAnError) {
  Result<int> r = parse("");
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(bool(r));
  EXPECT_EQ(r.error(), "count: no value given");
  EXPECT_EQ(r.valueOr(7), 7);
  Result<std::string> f = Result<std::string>::failure("a.gltf: bad");
  EXPECT_FALSE(f);
  EXPECT_EQ(f.error(), "a.gltf: bad");
}

TEST(Result, StringValuesAndMoveOnlyValues) {
  Result<std::string> s = std::string("value, not an error");
  ASSERT_TRUE(s);
  EXPECT_EQ(s->size(), 19u);
  EXPECT_EQ(s.error(), "");
  Result<std::unique_ptr<int>> p = std::make_unique<int>(3);
  ASSERT_TRUE(p);
  std::unique_ptr<int> taken = std::move(p).value();
  EXPECT_EQ(*taken, 3);
}

TEST(Result, Void) {
  Result<void> good = positive(1);
  EXPECT_TRUE(good.ok());
  EXPECT_EQ(good.error(), "");
  Result<void> bad = positive(-2);
  EXPECT_FALSE(bad);
  EXPECT_EQ(bad.error(), "x: must be > 0 (got -2)");
  EXPECT_TRUE(Result<void>::success());
  EXPECT_EQ(Result<void>::failure("f").error(), "f");
}

TEST(ResultDeathTest, ValueOfAnErrorIsABug) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  Result<int> r = parse("");
  EXPECT_DEATH((void)r.value(), "VSL_CHECK\\(ok\\(\\)\\) failed");
}

// ---- VSL_CHECK ------------------------------------------------------------------------

TEST(CheckDeathTest, PrintsTheExpressionAndBothOperands) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  int width = 512, x = 640;
  EXPECT_DEATH(VSL_CHECK_LT(x, width), "test_errors.cpp:[0-9]+: VSL_CHECK_LT\\(x, width\\) failed: 640 vs 512");
  size_t a = 3, b = 4;
  EXPECT_DEATH(VSL_CHECK_EQ(a, b), "VSL_CHECK_EQ\\(a, b\\) failed: 3 vs 4");
  EXPECT_DEATH(VSL_CHECK_GE(-1.5, 0.25), "VSL_CHECK_GE\\(-1.5, 0.25\\) failed: -1.5 vs 0.25");
  EXPECT_DEATH(VSL_CHECK(a > b), "VSL_CHECK\\(a > b\\) failed");
}

TEST(Check, PassingChecksEvaluateOperandsOnce) {
  int calls = 0;
  auto next = [&] { return ++calls; };
  VSL_CHECK_EQ(next(), 1);
  VSL_CHECK_NE(next(), 0);
  VSL_CHECK_LE(next(), 3);
  VSL_CHECK_GT(next(), 3);
  VSL_CHECK(next() == 5);
  EXPECT_EQ(calls, 5);
#ifdef NDEBUG
  VSL_DCHECK_EQ(next(), -1);  // compiled out: neither evaluated nor checked
  EXPECT_EQ(calls, 5);
#endif
}

TEST(CheckDeathTest, FilmAddOutsideTheFilm) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  Film film(4, 3);
  film.add(3, 2, Vec3(1.0f));
  EXPECT_DEATH(film.add(4, 0, Vec3(1.0f)), "VSL_CHECK_LT\\(x, width_\\) failed: 4 vs 4");
  EXPECT_DEATH(film.add(0, -1, Vec3(1.0f)), "VSL_CHECK_GE\\(y, 0\\) failed: -1 vs 0");
}

// Invariants that were comments: one radius per light, films of the
// renderer's size, equal spans for batched occlusion.
TEST(CheckDeathTest, RendererContracts) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  test::Loaded l = test::loadAsset("furnace", 8);
  ASSERT_TRUE(l.accel);
  ManyLightSettings s;
  s.width = s.height = 8;
  VirtualLightSet set;
  set.lights.resize(3);
  std::vector<float> radii(2, 0.1f);
  EXPECT_DEATH(ManyLightRenderer(*l.scene, *l.accel, *l.lights, set, radii, s),
               "VSL_CHECK_EQ\\(radii.size\\(\\), set.lights.size\\(\\)\\) failed: 2 vs 3");
  RenderSettings rs;
  rs.width = rs.height = 8;
  PathTracer pt(*l.scene, *l.accel, *l.lights, rs);
  Film small(4, 8), right(8, 8);
  PtCounters counters;
  EXPECT_DEATH(pt.renderPass(0, small, right, counters), "VSL_CHECK_EQ\\(direct.width\\(\\), width_\\) failed: 4 vs 8");
  std::vector<Ray> rays(2);
  std::vector<uint8_t> blocked(1);
  EXPECT_DEATH(l.accel->occluded(rays, blocked),
               "VSL_CHECK_EQ\\(blocked.size\\(\\), rays.size\\(\\)\\) failed: 1 vs 2");
}

// ---- Exceptions from parallel workers -------------------------------------------------

class ParallelExceptions : public testing::Test {
 protected:
  void SetUp() override { setThreadCount(4); }  // workers besides the caller, even on 1 core
  void TearDown() override { setThreadCount(0); }
};

TEST_F(ParallelExceptions, ReachTheCallerWithTheirMessage) {
  std::atomic<int> done{0};
  try {
    parallelFor(1000, [&](size_t i) {
      if (i == 37) throw std::runtime_error("item 37 failed");
      ++done;
    });
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "item 37 failed");
  }
  EXPECT_LT(done.load(), 1000);
  // The pool is not poisoned: the next call runs every item.
  std::atomic<int> all{0};
  parallelFor(1000, [&](size_t) { ++all; });
  EXPECT_EQ(all.load(), 1000);
}

TEST_F(ParallelExceptions, BadAllocAndTheFirstOfMany) {
  EXPECT_THROW(parallelFor(1000,
                           [](size_t i) {
                             if (i == 500) throw std::bad_alloc();
                           }),
               std::bad_alloc);
  // Every item throws: exactly one exception arrives, and items stop being claimed.
  std::atomic<int> started{0};
  EXPECT_THROW(parallelFor(100000,
                           [&](size_t) {
                             ++started;
                             throw std::logic_error("every item");
                           }),
               std::logic_error);
  EXPECT_LE(started.load(), threadCount());
}

TEST_F(ParallelExceptions, OneThreadAndTiles) {
  setThreadCount(1);  // the serial path throws straight through
  EXPECT_THROW(parallelFor(10,
                           [](size_t i) {
                             if (i == 3) throw std::runtime_error("serial");
                           }),
               std::runtime_error);
  setThreadCount(4);
  try {
    parallelForTiles(256, 256, nullptr, [](int x0, int y0, int, int) {
      if (x0 == 32 && y0 == 48) throw std::runtime_error("tile (32, 48)");
    });
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "tile (32, 48)");
  }
}

TEST_F(ParallelExceptions, TestHookFailsTheNextCallOnce) {
  failParallelForTesting(37, "injected");
  std::atomic<int> done{0};
  EXPECT_THROW(parallelFor(1000, [&](size_t) { ++done; }), std::runtime_error);
  EXPECT_LT(done.load(), 1000);
  done = 0;
  parallelFor(1000, [&](size_t) { ++done; });
  EXPECT_EQ(done.load(), 1000);
}
