// The environment light (core/environment.h): its importance sampling
// (chi-square, pdf integral, pdf against the map), its files' errors, a
// closed form (a diffuse sphere in a constant environment) and light tracing
// from it against the path tracer (a room lit through a window).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "chi2.h"
#include "core/environment.h"
#include "core/image_io.h"
#include "core/many_light.h"
#include "run_vsl.h"
#include "support.h"

namespace vsl {
namespace {

using test::Loaded;
using test::MeanAccumulator;

// A W x H map: a dim gradient with a bright block (a "sun" in the map).
Image testMap(int W, int H) {
  Image m(W, H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      Vec3 c(0.1f + 0.4f * float(x) / W, 0.2f, 0.3f * float(H - y) / H);
      if (x >= W / 4 && x < W / 4 + 3 && y >= H / 4 && y < H / 4 + 2) c = Vec3(40, 30, 20);
      m.set(x, y, c);
    }
  return m;
}

std::shared_ptr<const Environment> makeEnv(const EnvironmentSettings& s, Image map) {
  auto e = Environment::create(s, std::move(map));
  EXPECT_TRUE(e) << e.error();
  return e.valueOr(nullptr);
}

// Cells aligned with the map's pixels (x = u, y = v of the lat-long map),
// two a side, so that the midpoint rule integrates the piecewise-constant
// pdf within each cell; the Jacobian is dOmega/(du dv) = 2 pi^2 sin(theta).
test::Domain latLongDomain(const Environment& env, int resX, int resY) {
  test::Domain d;
  d.name = "lat-long";
  d.resX = resX;
  d.resY = resY;
  d.wrapX = true;
  d.forward = [](double u, double v) { return Environment::uvToDirection(Vec2{float(u), float(v)}); };
  d.jacobian = [](double, double v) { return 2 * M_PI * M_PI * std::sin(M_PI * v); };
  d.backward = [&env](const Vec3& w) {
    Vec2 uv = env.directionToUv(w);
    return std::array<double, 2>{uv.x, uv.y};
  };
  return d;
}

}  // namespace

TEST(EnvironmentSampling, MapAndSkySamplingMatchesThePdfChiSquare) {
  EnvironmentSettings s;
  s.map = "generated";
  s.scale = 2;
  s.sky = Vec3(0.3f);
  auto env = makeEnv(s, testMap(32, 16));
  ASSERT_TRUE(env);
  test::Chi2Config cfg;
  cfg.samples = 150000;
  cfg.subdiv = 4;
  const test::Domain d = latLongDomain(*env, 64, 32);
  auto sample = [&](Rng& r) -> std::optional<Vec3> {
    float uPart = r.uniform();
    Vec2 u{r.uniform(), r.uniform()};
    auto es = env->sample(uPart, u);
    if (!es) return std::nullopt;
    // The sample's pdf and radiance are the ones pdf() and radiance() give.
    EXPECT_NEAR(es->pdf, env->pdf(es->w), 1e-4f * es->pdf);
    return es->w;
  };
  test::Chi2Result r = test::chi2Test(
      d, sample, [&](const Vec3& w) { return double(env->pdf(w)); }, cfg, "env_map_sky");
  EXPECT_TRUE(r.message.empty()) << r.message;
  EXPECT_GT(r.pValue, 1e-4) << "statistic " << r.statistic << " dof " << r.dof;
}

TEST(EnvironmentSampling, SunAndSkySamplingMatchesThePdfChiSquare) {
  // A sun of 22.5 degrees (a half-angle of two theta cells) about +z.
  EnvironmentSettings s;
  s.sky = Vec3(0.5f);
  s.sunDirection = Vec3(0, 0, 1);
  s.sunDiameterDeg = 22.5f;
  s.sunIrradiance = 2;
  auto env = makeEnv(s, Image());
  ASSERT_TRUE(env);
  test::Chi2Config cfg;
  cfg.samples = 100000;
  auto sample = [&](Rng& r) -> std::optional<Vec3> {
    float uPart = r.uniform();
    auto es = env->sample(uPart, {r.uniform(), r.uniform()});
    return es ? std::optional<Vec3>(es->w) : std::nullopt;
  };
  test::Chi2Result r = test::chi2Directions(
      sample, [&](const Vec3& w) { return double(env->pdf(w)); }, cfg, "env_sun_sky");
  EXPECT_TRUE(r.message.empty()) << r.message;
  EXPECT_GT(r.pValue, 1e-4) << "statistic " << r.statistic << " dof " << r.dof;
  // The sun's radiance gives the irradiance asked on a surface facing it:
  // E = L pi sin^2(alpha).
  const float alpha = 11.25f * kPi / 180;
  const Vec3 Lsun = env->radiance(Vec3(0, 0, 1)) - s.sky;
  EXPECT_NEAR(Lsun.x * kPi * std::sin(alpha) * std::sin(alpha), 2.0f, 1e-4f);
  EXPECT_EQ(env->radiance(Vec3(1, 0, 0)).x, 0.5f);
}

TEST(EnvironmentSampling, PdfIntegratesToOneAndFollowsTheMap) {
  EnvironmentSettings s;
  s.map = "generated";
  const Image map = testMap(32, 16);
  auto env = makeEnv(s, map);
  ASSERT_TRUE(env);
  // Midpoint rule on cells aligned with the pixels: exact for the pdf times
  // the Jacobian up to sin(theta)'s curvature within a cell.
  const int n = 256;
  double integral = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < 2 * n; ++i) {
      const double u = (i + 0.5) / (2 * n), v = (j + 0.5) / n;
      const Vec3 w = Environment::uvToDirection(Vec2{float(u), float(v)});
      integral += env->pdf(w) * 2 * M_PI * M_PI * std::sin(M_PI * v) / (2.0 * n * n);
    }
  EXPECT_NEAR(integral, 1.0, 2e-3);
  // At each pixel's centre the pdf is mean(RGB) / sum over pixels of
  // mean(RGB) sin(theta_c) dOmega-weights: pdf = mean(c) W H / (2 pi^2 S),
  // S = sum of mean(c) sin(theta_c).
  double S = 0;
  for (int y = 0; y < map.height; ++y)
    for (int x = 0; x < map.width; ++x) {
      const Vec3 c = map.at(x, y);
      S += (c.x + c.y + c.z) / 3 * std::sin(M_PI * (y + 0.5) / map.height);
    }
  for (int y = 0; y < map.height; ++y)
    for (int x = 0; x < map.width; ++x) {
      const Vec3 c = map.at(x, y);
      const Vec3 w = Environment::uvToDirection(Vec2{(x + 0.5f) / map.width, (y + 0.5f) / map.height});
      const double want = (c.x + c.y + c.z) / 3 * map.width * map.height / (2 * M_PI * M_PI * S);
      ASSERT_NEAR(env->pdf(w), want, 1e-4 * want) << "pixel " << x << "," << y;
      ASSERT_NEAR(env->radiance(w).x, c.x, 1e-6f) << "pixel " << x << "," << y;
    }
}

TEST(EnvironmentFiles, BadFilesAndSettingsSayWhy) {
  const auto dir = test::scratchDir("vsl_env_files");
  EnvironmentSettings s;
  s.map = (dir / "missing.exr").string();
  auto missing = Environment::create(s);
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().find("missing.exr"), std::string::npos) << missing.error();
  s.map = (dir / "text.exr").string();
  std::ofstream(s.map) << "not an image";
  auto text = Environment::create(s);
  ASSERT_FALSE(text);
  EXPECT_NE(text.error().find("text.exr"), std::string::npos) << text.error();
  // A non-finite pixel, and a map that emits nothing.
  Image nan(4, 2);
  nan.set(1, 1, Vec3(NAN, 0, 0));
  s.map = (dir / "nan.exr").string();
  ASSERT_TRUE(writeExr(s.map, {{"", nan}}));
  auto bad = Environment::create(s);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().find("nan.exr: pixel (1, 1) is not finite"), std::string::npos) << bad.error();
  s.map = (dir / "black.exr").string();
  ASSERT_TRUE(writeExr(s.map, {{"", Image(4, 2)}}));
  auto black = Environment::create(s);
  ASSERT_FALSE(black);
  EXPECT_NE(black.error().find("emits nothing"), std::string::npos) << black.error();
  EnvironmentSettings sun;
  sun.sunDirection = Vec3(0, 1, 0);
  sun.sunIrradiance = 1;
  sun.sunDiameterDeg = 120;
  EXPECT_FALSE(sun.validate());
  EXPECT_EQ(EnvironmentSettings().describe(), "none");
  EXPECT_EQ(EnvironmentSettings().options(), "");
  EnvironmentSettings all;
  all.map = "it's.exr";
  all.scale = 2;
  all.sky = Vec3(0.5f);
  all.sunDirection = Vec3(0, 1, 0);
  all.sunDiameterDeg = 2;
  EXPECT_EQ(all.options(), " --env 'it'\\''s.exr' --env-scale 2 --sky 0.5,0.5,0.5 --sun 0,1,0 --sun-diameter 2");
}

// ---- Rendering ----------------------------------------------------------------------

namespace {

void addTriangle(Scene& s, Vec3 a, Vec3 b, Vec3 c, uint32_t material) {
  const uint32_t base = uint32_t(s.positions.size());
  for (Vec3 p : {a, b, c}) {
    s.positions.push_back(p);
    s.normals.push_back(Vec3(0.0f));  // flat: the geometric normal shades
    s.tangents.push_back(Vec3(0.0f));
    s.tangentSigns.push_back(1);
    s.uvs.push_back({0, 0});
    s.boundsMin = min(s.boundsMin, p);
    s.boundsMax = max(s.boundsMax, p);
  }
  s.indices.insert(s.indices.end(), {base, base + 1, base + 2});
  s.triMaterial.push_back(material);
}

// A flat-shaded unit sphere (a convex polyhedron) of Lambertian albedo a,
// seen from +z.
std::shared_ptr<Scene> sphereScene(float a) {
  auto s = std::make_shared<Scene>();
  s->materials = {test::testMaterial("sphere", Vec3(a), 0, 1, 0), test::testMaterial("default", Vec3(0.8f), 0)};
  const int rings = 12, segs = 24;
  auto at = [&](int i, int j) {
    const float th = kPi * i / rings, ph = 2 * kPi * j / segs;
    return Vec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
  };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segs; ++j) {
      // Counter-clockwise seen from outside.
      if (i > 0) addTriangle(*s, at(i, j), at(i, j + 1), at(i + 1, j), 0);
      if (i + 1 < rings) addTriangle(*s, at(i, j + 1), at(i + 1, j + 1), at(i + 1, j), 0);
    }
  s->camera.position = Vec3(0, 0, 4);
  s->camera.yfov = 0.6f;
  s->camera.aspect = 1;
  s->cameraFromFile = true;
  return s;
}

// Whether the ray through film position (x, y) passes within radius of the origin.
bool nearOrigin(const Camera& cam, float x, float y, int w, int h, float radius) {
  Ray r = cam.generateRay(x, y, w, h);
  const float t = -dot(r.o, r.d);
  return lengthSquared(r.o + r.d * t) < radius * radius;
}

// Checks the path tracer's image of the sphere in env: a L on the sphere
// (every pixel whose corners all hit it) and L elsewhere (every pixel whose
// corners pass 1.2 from the centre), z-tests over pixels' means.
void checkSphereInConstantLight(const Loaded& l, float a, float L, const char* label) {
  RenderSettings rs;
  rs.width = l.width;
  rs.height = l.height;
  rs.seed = 3;
  PathTracer pt(*l.scene, *l.accel, *l.lights, rs);
  MeanAccumulator onSphere, behind;
  uint64_t rays = 0, nonFinite = 0;
  const int spp = 16;
  for (int y = 0; y < l.height; ++y)
    for (int x = 0; x < l.width; ++x) {
      bool hitAll = true, clearAll = true;
      for (auto [cx, cy] : {std::pair{0, 0}, {1, 0}, {0, 1}, {1, 1}}) {
        Ray r = l.scene->camera.generateRay(float(x + cx), float(y + cy), l.width, l.height);
        hitAll = hitAll && l.accel->intersect(r).has_value();
        clearAll = clearAll && !nearOrigin(l.scene->camera, float(x + cx), float(y + cy), l.width, l.height, 1.2f);
      }
      if (!hitAll && !clearAll) continue;
      double sum = 0;
      for (int k = 0; k < spp; ++k) {
        Vec3 Ld, Li;
        pt.samplePixel(x, y, k, Ld, Li, rays, nonFinite);
        // A convex sphere never sees itself: no indirect light.
        EXPECT_EQ(Li.x, 0.0f);
        sum += Ld.x;
      }
      (hitAll ? onSphere : behind).add(sum / spp);
    }
  EXPECT_EQ(nonFinite, 0u);
  ASSERT_GT(onSphere.n, 100u);
  ASSERT_GT(behind.n, 100u);
  const double se = onSphere.standardError();
  std::printf("%s: sphere %.5f +- %.5f (closed form %.5f) over %zu pixels; behind %.6f (closed form %.5f)\n", label,
              onSphere.mean(), se, double(a * L), onSphere.n, behind.mean(), double(L));
  EXPECT_LT(std::abs(onSphere.mean() - a * L), 4 * se + 1e-6) << label;
  EXPECT_NEAR(behind.mean(), L, 1e-6) << label;
  EXPECT_LT(behind.standardError(), 1e-7) << label;
}

}  // namespace

TEST(EnvironmentRender, DiffuseSphereInConstantSkyIsAlbedoTimesSky) {
  // Closed form: every point of a convex Lambertian body of albedo a in a
  // uniform environment L sees L over its whole hemisphere, so it reflects
  // integral (a/pi) L cos = a L; the environment seen past it is L.
  EnvironmentSettings sky;
  sky.sky = Vec3(1.5f);
  const Loaded l = test::loadedFrom(RenderContext::create(sphereScene(0.6f), 0, sky), 32);
  ASSERT_TRUE(l.context);
  checkSphereInConstantLight(l, 0.6f, 1.5f, "constant sky");
}

TEST(EnvironmentRender, DiffuseSphereInConstantMapIsAlbedoTimesMap) {
  // The same through an EXR map of constant value (importance sampling of
  // the map, MIS against the BRDF, the file read), at scale 3: L = 1.5.
  const auto dir = test::scratchDir("vsl_env_sphere");
  Image map(16, 8);
  for (float& v : map.rgb) v = 0.5f;
  EnvironmentSettings s;
  s.map = (dir / "constant.exr").string();
  s.scale = 3;
  ASSERT_TRUE(writeExr(s.map, {{"", map}}));
  const Loaded l = test::loadedFrom(RenderContext::create(sphereScene(0.6f), 0, s), 32);
  ASSERT_TRUE(l.context);
  checkSphereInConstantLight(l, 0.6f, 1.5f, "constant map");
}

namespace {

// A closed white room, 2 x 2 x 2, whose +x wall has a 1 x 1 window; a sky
// and a sun outside shine in through it. The camera looks at the middle of
// the back wall (z = -1), away from the corners where unclamped VPLs spike.
std::shared_ptr<Scene> windowRoom() {
  auto s = std::make_shared<Scene>();
  s->materials = {test::testMaterial("white", Vec3(0.7f), 0, 1, 0), test::testMaterial("default", Vec3(0.8f), 0)};
  using test::addQuad;
  addQuad(*s, Vec3(-1, 0, -1), Vec3(0, 0, 2), Vec3(2, 0, 0), 0);  // floor, +y
  addQuad(*s, Vec3(-1, 2, -1), Vec3(2, 0, 0), Vec3(0, 0, 2), 0);  // ceiling, -y
  addQuad(*s, Vec3(-1, 0, -1), Vec3(0, 2, 0), Vec3(0, 0, 2), 0);  // x = -1, +x
  addQuad(*s, Vec3(-1, 0, -1), Vec3(2, 0, 0), Vec3(0, 2, 0), 0);  // z = -1, +z
  addQuad(*s, Vec3(-1, 0, 1), Vec3(0, 2, 0), Vec3(2, 0, 0), 0);   // z = 1, -z
  // x = 1, facing -x, around the window y in [0.6, 1.6], z in [-0.5, 0.5].
  addQuad(*s, Vec3(1, 0, -1), Vec3(0, 0, 2), Vec3(0, 0.6f, 0), 0);
  addQuad(*s, Vec3(1, 1.6f, -1), Vec3(0, 0, 2), Vec3(0, 0.4f, 0), 0);
  addQuad(*s, Vec3(1, 0.6f, -1), Vec3(0, 0, 0.5f), Vec3(0, 1, 0), 0);
  addQuad(*s, Vec3(1, 0.6f, 0.5f), Vec3(0, 0, 0.5f), Vec3(0, 1, 0), 0);
  s->camera.position = Vec3(0.2f, 1.1f, 0.8f);
  s->camera.forward = normalize(Vec3(-0.2f, -0.1f, -1));
  s->camera.right = normalize(cross(s->camera.forward, Vec3(0, 1, 0)));
  s->camera.up = cross(s->camera.right, s->camera.forward);
  s->camera.yfov = 0.5f;
  s->camera.aspect = 1;
  s->cameraFromFile = true;
  return s;
}

}  // namespace

TEST(EnvironmentRender, LightTracedVplsThroughAWindowAgreeWithThePathTracer) {
  // Virtual lights traced from the environment (a disk over the bounding
  // sphere, core/lights.cpp) land where sky and sun enter the window;
  // their unclamped indirect light against the path tracer's indirect
  // image, z-test over independent light sets.
  EnvironmentSettings env;
  env.sky = Vec3(0.8f);
  env.sunDirection = Vec3(1, 0.7f, 0.3f);
  env.sunDiameterDeg = 2;
  env.sunIrradiance = 4;
  const Loaded l = test::loadedFrom(RenderContext::create(windowRoom(), 0, env), 8);
  ASSERT_TRUE(l.context);
  const test::Reference ref = test::ptIndirect(l, l.width, l.height, 512, 61);
  ManyLightSettings base;
  base.lights = 2000;
  base.directSamples = 1;
  const double z = test::unclampedVplZ(l, ref, base, 800, "window room");
  EXPECT_GT(ref.mean, 0.01);
  EXPECT_LT(std::abs(z), 4.0);
}

// ---- The command line ----------------------------------------------------------------

TEST(EnvironmentCli, LightsASceneWithoutLightsAndSaysWhyItCannot) {
  const auto dir = test::scratchDir("vsl_env_cli");
  const std::string scene = (dir / "dark.gltf").string(), out = (dir / "out.exr").string();
  test::writeNoEmitterTriangle(scene);
  const std::string base = "render " + scene + " --width 8 --height 8 --spp 4 -o " + out;
  // A constant sky: the triangle (albedo 0.8 x its Lambertian lobe) and the
  // sky past it: the mean lies between a L and L.
  test::Proc sky = test::runVsl(base + " --sky 0.5 --json " + (dir / "sky.json").string());
  ASSERT_EQ(sky.code, 0) << sky.out;
  Result<std::vector<Layer>> img = readExr(out);
  ASSERT_TRUE(img) << img.error();
  EXPECT_NEAR(test::channelMean(img->front().image), 0.45, 0.06);  // between a L = 0.4 and L = 0.5
  EXPECT_NE(test::slurp(dir / "sky.json").find("\"environment\": \"sky 0.5,0.5,0.5\""), std::string::npos);
  // Bad values are bad arguments (2), naming the option.
  for (const char* bad : {"--sky 1,2", "--sky red", "--sun 0,0,0", "--sun 1,2", "--sun-diameter 0", "--env-scale -1"}) {
    test::Proc p = test::runVsl(base + " " + bad);
    EXPECT_EQ(p.code, 2) << bad << ": " << p.out;
    EXPECT_NE(p.out.find(std::string(bad).substr(0, std::string(bad).find(' '))), std::string::npos) << p.out;
  }
  // A file that cannot be used is bad input (1), naming the file.
  test::Proc missing = test::runVsl(base + " --env " + (dir / "nope.exr").string());
  EXPECT_EQ(missing.code, 1) << missing.out;
  EXPECT_NE(missing.out.find("nope.exr"), std::string::npos) << missing.out;
  // The many-light methods trace their virtual lights from it.
  test::Proc vpl = test::runVsl(base + " --method vpl --lights 200 --sun 0,1,0.2 --sun-diameter 5");
  EXPECT_EQ(vpl.code, 0) << vpl.out;
}

}  // namespace vsl
