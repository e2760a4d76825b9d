// The `vsl` command line as a user drives it: exit codes, files written,
// and files that real tools (exrheader) read.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>
#include <algorithm>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "core/image_io.h"
#include "core/many_light.h"
#include "core/params.h"
#include "tests/run_vsl.h"

namespace fs = std::filesystem;

namespace {

using vsl::test::Proc;

Proc run(const std::string& args) { return vsl::test::runVsl(args); }

// The comma-separated fields of one CSV line (the sweep's CSV has no quoting).
std::vector<std::string> csvFields(const std::string& line) {
  std::vector<std::string> f;
  std::stringstream ss(line);
  for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
  return f;
}

Proc shell(const std::string& cmd) {
  Proc r{-1, ""};
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) r.out.append(buf.data(), n);
  int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string scene(const char* name) { return std::string(VSL_SOURCE_DIR) + "/assets/scenes/" + name + ".gltf"; }

class Cli : public ::testing::Test {
 protected:
  fs::path dir;
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("vsl_cli_" + std::string(testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string file(const std::string& n) { return (dir / n).string(); }
  // Runs `vsl sweep` on cornell-glossy with args against a 16x16 render of it
  // (ref.exr), writing to the folder out; returns sweep.csv's header and its
  // rows' fields (empty after a failure, which is reported).
  std::vector<std::vector<std::string>> sweepCsv(const std::string& args, const std::string& out, std::string* header) {
    Proc r =
        run("render " + scene("cornell-glossy") + " --spp 16 --width 16 --height 16 --seed 0 -o " + file("ref.exr"));
    EXPECT_EQ(r.code, 0) << r.out;
    r = run("sweep " + scene("cornell-glossy") + " " + args + " --reference " + file("ref.exr") + " -o " + file(out));
    EXPECT_EQ(r.code, 0) << r.out;
    std::vector<std::vector<std::string>> rows;
    std::ifstream csv(file(out + "/sweep.csv"));
    std::getline(csv, *header);
    for (std::string line; std::getline(csv, line);) {
      rows.push_back(csvFields(line));
      EXPECT_EQ(rows.back().size(), 15u) << line;
      if (rows.back().size() != 15u) return {};
    }
    return rows;
  }
};

}  // namespace

TEST_F(Cli, BadArgumentsExitTwoWithUsage) {
  for (const char* args :
       {"", "render", "render " /* no -o */, "frobnicate", "render x.gltf -o y.exr --spp nope",
        "render x.gltf -o y.exr --method vcm", "render x.gltf -o y.exr --spp 5 --time 3", "compare onlyone.exr",
        // A negative seed (an unsigned parse would wrap it to 2^64 - 1).
        "render x.gltf -o y.exr --seed -1", "sweep x.gltf -o d --seed -2", "reference x.gltf -o y.exr --seed 1.5"}) {
    Proc r = run(args);
    EXPECT_EQ(r.code, 2) << "vsl " << args << "\n" << r.out;
    EXPECT_NE(r.out.find("Usage"), std::string::npos) << "vsl " << args << "\n" << r.out;
  }
  // Values that parse but are out of range are validated, also exit 2.
  Proc r = run("render " + scene("furnace") + " -o " + file("x.exr") + " --spp 0");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("spp: must be in"), std::string::npos) << r.out;
  r = run("render " + scene("furnace") + " -o " + file("x.exr") + " --width -5");
  EXPECT_EQ(r.code, 2) << r.out;
}

TEST_F(Cli, HelpOnEverySubcommand) {
  for (const char* sub : {"", "render ", "compare ", "info ", "bench "}) {
    Proc r = run(std::string(sub) + "--help");
    EXPECT_EQ(r.code, 0) << sub;
    EXPECT_NE(r.out.find("Usage"), std::string::npos) << sub;
  }
}

TEST_F(Cli, BadSceneExitsOneAndNamesTheFile) {
  std::ofstream(file("broken.gltf")) << "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": 7";
  Proc r = run("render " + file("broken.gltf") + " -o " + file("x.exr"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("broken.gltf"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(file("x.exr")));
  r = run("info " + file("missing.gltf"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("missing.gltf"), std::string::npos) << r.out;
}

TEST_F(Cli, RenderWritesExrPngJsonThatToolsRead) {
  Proc r = run("render " + scene("furnace") + " --spp 8 --width 16 --height 12 --seed 3 -o " + file("f.exr") +
               " --png " + file("f.png") + " --json " + file("f.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("render 100%"), std::string::npos) << "progress on stderr\n" << r.out;
  // exrheader (Debian's openexr package) must read the file.
  Proc h = shell("exrheader " + file("f.exr"));
  ASSERT_EQ(h.code, 0) << h.out;
  for (const char* ch : {"full.R", "direct.G", "indirect.B", "vsl.settings"})
    EXPECT_NE(h.out.find(ch), std::string::npos) << ch << "\n" << h.out;
  vsl::Result<std::vector<vsl::Layer>> layers = vsl::readExr(file("f.exr"));
  ASSERT_TRUE(layers) << layers.error();
  EXPECT_EQ(layers->size(), 4u);
  EXPECT_EQ((*layers)[0].image.width, 16);
  EXPECT_EQ((*layers)[0].image.height, 12);
  // PNG signature.
  std::ifstream png(file("f.png"), std::ios::binary);
  char sig[8] = {};
  png.read(sig, 8);
  EXPECT_EQ(std::string(sig + 1, 3), "PNG");
  auto j = nlohmann::json::parse(std::ifstream(file("f.json")));
  EXPECT_EQ(j["spp"], 8);
  EXPECT_EQ(j["width"], 16);
  EXPECT_EQ(j["nonFiniteRejected"], 0);
  EXPECT_GT(j["raysPerSecond"].get<double>(), 0);
  // The furnace is 2 everywhere: even 8 spp is close.
  EXPECT_NEAR(j["mean"]["full"][0].get<double>(), 2.0, 0.1);
  // No temporary files are left behind.
  for (auto& e : fs::directory_iterator(dir)) EXPECT_EQ(e.path().string().find(".tmp-"), std::string::npos) << e.path();
}

TEST_F(Cli, CompareReportsMetricsAndWritesErrorImages) {
  ASSERT_EQ(run("render " + scene("cornell-glossy") + " --spp 2 --width 16 --height 16 -o " + file("a.exr")).code, 0);
  ASSERT_EQ(
      run("render " + scene("cornell-glossy") + " --spp 2 --width 16 --height 16 --seed 9 -o " + file("b.exr")).code,
      0);
  Proc same = run("compare " + file("a.exr") + " " + file("a.exr") + " --json");
  ASSERT_EQ(same.code, 0) << same.out;
  auto j = nlohmann::json::parse(same.out);
  EXPECT_EQ(j["average"]["relMSE"], 0.0);
  EXPECT_EQ(j["average"]["rmse"], 0.0);
  Proc diff = run("compare " + file("a.exr") + " " + file("b.exr") + " --layer indirect -o " + file("e.exr") +
                  " --png " + file("e.png"));
  ASSERT_EQ(diff.code, 0) << diff.out;
  for (const char* w : {"relMSE", "RMSE", "bias", "non-finite", "eps = 0.01"})
    EXPECT_NE(diff.out.find(w), std::string::npos) << w << "\n" << diff.out;
  vsl::Result<std::vector<vsl::Layer>> layers = vsl::readExr(file("e.exr"));
  ASSERT_TRUE(layers) << layers.error();
  EXPECT_EQ(layers->size(), 5u);
  EXPECT_TRUE(fs::exists(file("e.png")));
  Proc missingLayer = run("compare " + file("a.exr") + " " + file("b.exr") + " --layer nosuch");
  EXPECT_EQ(missingLayer.code, 1);
  Proc sizes = run("render " + scene("cornell-glossy") + " --spp 1 --width 8 --height 8 -o " + file("c.exr"));
  ASSERT_EQ(sizes.code, 0);
  EXPECT_EQ(run("compare " + file("a.exr") + " " + file("c.exr")).code, 1);
}

TEST_F(Cli, FailedExportKeepsTheExistingFile) {
  ASSERT_EQ(run("render " + scene("furnace") + " --spp 1 --width 8 --height 8 -o " + file("keep.exr")).code, 0);
  auto before = fs::file_size(file("keep.exr"));
  // The PNG cannot be written (its directory does not exist): exit 1; the EXR
  // written earlier in the same run is complete, and nothing half-written remains.
  Proc r = run("render " + scene("furnace") + " --spp 1 --width 8 --height 8 -o " + file("keep.exr") + " --png " +
               file("no/such/dir/x.png"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_GT(fs::file_size(file("keep.exr")), 0u);
  (void)before;
  Proc bad = run("render " + scene("furnace") + " --spp 1 --width 8 --height 8 -o " + file("no/such/dir/y.exr"));
  EXPECT_EQ(bad.code, 1) << bad.out;
  EXPECT_NE(bad.out.find("no/such/dir/y.exr"), std::string::npos) << bad.out;
}

TEST_F(Cli, InfoListsScene) {
  Proc r = run("info " + scene("hall"));
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* w : {"triangles", "hall-metal", "spot", "stage-light", "camera", "warnings   0", "power"})
    EXPECT_NE(r.out.find(w), std::string::npos) << w << "\n" << r.out;
}

// Equal time: each run's final point is its last within the budget (--time,
// 2% slack), or its first if none is; later points are charted only.
static void expectFinalsWithinBudget(const std::vector<std::vector<std::string>>& points, double time) {
  std::map<std::string, std::vector<const std::vector<std::string>*>> runs;  // configuration and set -> points
  for (const std::vector<std::string>& f : points)
    runs[f[0] + " " + f[1] + " s " + f[2] + " set " + f[3]].push_back(&f);
  for (const auto& [run, pts] : runs) {
    size_t want = 0;
    for (size_t i = 0; i < pts.size(); ++i)
      if (std::stod((*pts[i])[5]) <= time * 1.02) want = i;
    for (size_t i = 0; i < pts.size(); ++i)
      EXPECT_EQ((*pts[i])[10], i == want ? "1" : "0")
          << run << " step " << (*pts[i])[4] << " at " << (*pts[i])[5] << " s, budget " << time << " s";
  }
}

// A run does not start a step it predicts to end past the budget: such a
// step's point could not be final. sweep.json holds each point's prediction
// of the next step's end (brute force: the estimator's cost model; passes: as
// long as the last). Every step started was predicted within the budget; a
// run that stopped was predicted past it, or had done all its batches
// (brute force: --batches); passes predict their own length (the CSV's six
// significant digits of seconds aside: the points are read back from it),
// which checks that the prediction is the one they acted on.
static void expectNoStepStartedPastBudget(const std::string& sweepJson, double time, int batches) {
  std::ifstream in(sweepJson);
  ASSERT_TRUE(in) << sweepJson;
  const nlohmann::json js = nlohmann::json::parse(in);
  std::map<std::string, std::vector<const nlohmann::json*>> runs;  // configuration and set -> its points, in order
  for (const nlohmann::json& p : js.at("points")) {
    const std::string method = p.at("method");
    if (method == "pt" || method.find("-sets") != std::string::npos) continue;
    runs[method + " " + std::to_string(int(p.at("lights"))) + " set " + std::to_string(int(p.at("set")))].push_back(&p);
  }
  ASSERT_FALSE(runs.empty());
  const double budget = time * 1.02;
  for (const auto& [run, pts] : runs) {
    const bool passes = run.find("mrcs") != std::string::npos;
    for (size_t k = 0; k < pts.size(); ++k) {
      const nlohmann::json& p = *pts[k];
      ASSERT_EQ(int(p.at("step")), int(k) + 1) << run;
      ASSERT_TRUE(p.at("nextStepPredictedEnd").is_number()) << run << " step " << k + 1;
      const double predicted = p.at("nextStepPredictedEnd"), end = p.at("seconds");
      EXPECT_GT(predicted, end) << run << " step " << k + 1;
      if (k + 1 < pts.size()) {
        EXPECT_LE(predicted, budget) << run << ": step " << k + 2 << " started at " << end << " s, predicted to end at "
                                     << predicted << " s";
      } else if (passes || int(p.at("step")) < batches) {
        EXPECT_GT(predicted, budget) << run << ": stopped at step " << k + 1 << " (" << end
                                     << " s) though the next was predicted to end at " << predicted << " s";
      }
      if (passes) {
        const double before = k == 0 ? 0.0 : double(pts[k - 1]->at("seconds"));
        EXPECT_NEAR(predicted, 2 * end - before, 2e-5 * predicted) << run << " step " << k + 1;
      }
    }
  }
}

// The sweep's vsl-sg and vsl-quadrature are VSL with the closed-form and the
// quadrature cone integral on the same light sets as vsl (core/vsl_sg.h),
// which follows --vsl-integral (the closed form by default): with every pair
// in closed form (--vsl-sg-max-angle 90; at 300 lights most cones are wider
// than the default 5 degrees and would take the quadrature) the closed
// form's indirect mean on each set is within 10% of the quadrature's, and
// not the same image; vsl is vsl-sg's image.
TEST_F(Cli, SweepVslSgFollowsVslOnTheSameLightSets) {
  std::string header;
  std::map<std::string, double> mean;  // method and set -> the final mean
  for (const std::vector<std::string>& f :
       sweepCsv("--methods vsl,vsl-sg,vsl-quadrature --lights 300 --time 100 --batches 1 --sets 2 "
                "--vsl-sg-max-angle 90",
                "sweep-sg", &header))
    if (f[10] == "1") mean[f[0] + " " + f[3]] = std::stod(f[8]);
  ASSERT_EQ(mean.size(), 6u);
  for (const char* set : {"0", "1"}) {
    const double q = mean[std::string("vsl-quadrature ") + set], sg = mean[std::string("vsl-sg ") + set];
    EXPECT_NEAR(sg / q, 1.0, 0.10) << "set " << set;
    EXPECT_NE(sg, q) << "set " << set;
    EXPECT_EQ(mean[std::string("vsl ") + set], sg) << "set " << set << ": vsl takes the default, the closed form";
  }
}

// vsl-sets and vpl-sets average --batches independent light sets (the studio's
// passes): every run records exactly that many steps, the last one final,
// however short the time budget (--time caps the other methods).
TEST_F(Cli, SweepSetsMethodsStopAfterBatchesLightSets) {
  std::string header;
  std::map<std::string, std::vector<int>> steps;  // method and set -> steps recorded
  for (const std::vector<std::string>& f :
       sweepCsv("--methods vpl-sets,vsl-sets --lights 40 --time 0.01 --batches 3 --sets 2", "sweep-sets", &header)) {
    std::vector<int>& s = steps[f[0] + " " + f[3]];
    s.push_back(std::stoi(f[4]));
    EXPECT_EQ(f[10], s.back() == 3 ? "1" : "0") << "only the third light set's mean is final: " << f[0] << " " << f[3];
  }
  ASSERT_EQ(steps.size(), 4u);
  for (const auto& [run, s] : steps) EXPECT_EQ(s, (std::vector<int>{1, 2, 3})) << run;
}

// A batch or an MRCS pass that ends well past the budget is charted, but the
// run's result is its last point within the budget: methods are compared at
// equal time.
TEST_F(Cli, SweepFinalsAreAtEqualTime) {
  std::string header;
  const std::vector<std::vector<std::string>> points = sweepCsv(
      "--methods pt,vsl,vsl-mrcs --lights 3000 --batches 4 --mrcs 20,40 --time 0.05 --sets 2", "sweep-eq", &header);
  ASSERT_FALSE(points.empty());
  expectFinalsWithinBudget(points, 0.05);
  expectNoStepStartedPastBudget(file("sweep-eq/sweep.json"), 0.05, 4);
  // Many short steps: brute force in 32 batches, MRCS passes of a few rows.
  const std::vector<std::vector<std::string>> many = sweepCsv(
      "--methods vpl,vsl-mrcs --lights 2000 --batches 32 --mrcs 4,8 --time 0.1 --sets 2", "sweep-eq-many", &header);
  ASSERT_FALSE(many.empty());
  expectFinalsWithinBudget(many, 0.1);
  expectNoStepStartedPastBudget(file("sweep-eq-many/sweep.json"), 0.1, 32);
  // The check above needs a few steps per run; how many fit in the budget
  // depends on the machine (sanitizer builds are slower), so it is only said.
  std::map<std::string, int> steps;
  for (const std::vector<std::string>& f : many) steps[f[0] + " set " + f[3]]++;
  for (const auto& [run, n] : steps) std::printf("%s: %d steps in the budget\n", run.c_str(), n);
  // Each configuration's first final image is written to look at: its
  // relMSE against the reference is the CSV's.
  for (const auto& [name, method, lights] : {std::tuple<std::string, std::string, std::string>{"pt", "pt", "0"},
                                             {"vsl-N3000-s1", "vsl", "3000"},
                                             {"vsl-mrcs-N3000-s1", "vsl-mrcs", "3000"}}) {
    const std::string exr = file("sweep-eq/finals/" + name + ".exr");
    EXPECT_TRUE(std::filesystem::exists(file("sweep-eq/finals/" + name + ".png"))) << name;
    Proc c = run("compare " + exr + " " + file("ref.exr") + " --layer indirect --json --no-flip");
    ASSERT_EQ(c.code, 0) << name << ": " << c.out;
    const double rel = nlohmann::json::parse(c.out.substr(c.out.find('{')))["average"]["relMSE"];
    int found = 0;
    for (const std::vector<std::string>& f : points)
      if (f[0] == method && f[1] == lights && f[3] == "0" && f[10] == "1") {
        EXPECT_NEAR(rel, std::stod(f[6]), 1e-4 * std::stod(f[6])) << name;
        ++found;
      }
    EXPECT_EQ(found, 1) << name;
  }
  EXPECT_TRUE(std::filesystem::exists(file("sweep-eq/finals/reference.png")));
  // A directory that cannot take the images fails the sweep before it runs
  // (exit 1, nothing rendered).
  std::filesystem::create_directories(file("sweep-ro"));
  std::ofstream(file("sweep-ro/finals")) << "a file where the directory would go";
  Proc r = run("sweep " + scene("cornell-glossy") + " --methods vpl --lights 40 --time 0.05 --sets 1 --reference " +
               file("ref.exr") + " -o " + file("sweep-ro"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("finals"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(file("sweep-ro/summary.csv")));
  // Two configurations with one name are refused (exit 2).
  for (const char* grid : {"--lights 40,40", "--lights 40 --radius-scale 0.5,0.50"}) {
    Proc d = run("sweep " + scene("cornell-glossy") + " --methods vsl " + grid + " --time 0.05 --sets 1 --reference " +
                 file("ref.exr") + " -o " + file("sweep-dup"));
    EXPECT_EQ(d.code, 2) << grid << ": " << d.out;
    EXPECT_NE(d.out.find("distinct"), std::string::npos) << d.out;
  }
}

// --vary NAME=V1,V2 makes any registered parameter a grid axis: one sweep
// per value, each recording the value in its settings, and vary.csv joining
// their summaries. A misspelt name, a bad value or a parameter the methods
// do not use is refused (exit 2).
TEST_F(Cli, SweepVariesAnyRegisteredParameter) {
  std::string header;
  sweepCsv("--methods vpl --lights 10 --time 0.05 --sets 1", "unused", &header);  // writes ref.exr
  const std::string base = "sweep " + scene("cornell-glossy") + " --methods vsl --lights 40 --time 0.05 --sets 1 " +
                           "--reference " + file("ref.exr") + " -o " + file("vary");
  Proc r = run(base + " --vary lobe-floor=0,2.5");
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream csv(file("vary/vary.csv"));
  std::vector<std::string> lines;
  for (std::string line; std::getline(csv, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0].rfind("lobe-floor,method,lights,", 0), 0u) << lines[0];
  EXPECT_EQ(lines[1].rfind("0,vsl,40,", 0), 0u) << lines[1];
  EXPECT_EQ(lines[2].rfind("2.5,vsl,40,", 0), 0u) << lines[2];
  for (const char* value : {"0", "2.5"}) {
    std::ifstream json(file(std::string("vary/lobe-floor=") + value + "/sweep.json"));
    const std::string text((std::istreambuf_iterator<char>(json)), {});
    EXPECT_NE(text.find(std::string("--lobe-floor ") + value + " "), std::string::npos) << value;
  }
  for (auto [vary, want] :
       std::vector<std::pair<std::string, std::string>>{{"lobe-flor=0,1", "did you mean 'lobe-floor'?"},
                                                        {"lobe-floor=0,-1", "lobe-floor: must be in [0,100]"},
                                                        {"lobe-floor=1,1", "given twice"},
                                                        {"lights=10,20", "has its own option"},
                                                        {"lobe-floor", "NAME=V1,V2"}}) {
    Proc bad = run(base + " --vary " + vary);
    EXPECT_EQ(bad.code, 2) << vary << ": " << bad.out;
    EXPECT_NE(bad.out.find(want), std::string::npos) << vary << ": " << bad.out;
  }
  Proc unused = run("sweep " + scene("cornell-glossy") + " --methods vpl --reference " + file("ref.exr") + " -o " +
                    file("vary2") + " --vary lobe-floor=0,1");
  EXPECT_EQ(unused.code, 2) << unused.out;
  EXPECT_NE(unused.out.find("only VPL is rendered"), std::string::npos) << unused.out;
}

TEST_F(Cli, SweepWritesTablesAndPlots) {
  std::string header, line;
  const std::vector<std::vector<std::string>> points = sweepCsv(
      "--methods pt,vpl,vsl,vsl-mrcs --lights 40,80 --radius-scale 1 --time 0.2 --mrcs 20,10 --batches 2 --sets 3",
      "sweep", &header);
  EXPECT_EQ(header,
            "method,lights,radius_scale,set,step,seconds,relmse,rmse,mean,worst1_share,final,relmse_minus_ref_noise,"
            "flip_ldr,bias2,variance");
  std::map<std::string, int> finals;
  // Final relMSE per configuration, one per independent light set.
  std::map<std::string, std::vector<double>> finalRel;
  for (const std::vector<std::string>& f : points) {
    const std::string row = f[0] + " " + f[1] + " set " + f[3] + " step " + f[4];
    double worst = std::stod(f[9]);
    EXPECT_TRUE(worst >= 0.01 - 1e-9 && worst <= 1) << "the worst 1% hold at least 1% of the error: " << row;
    if (f[10] == "1") {
      finals[f[0]]++;
      finalRel[f[0] + " " + f[1]].push_back(std::stod(f[6]));
    }
    EXPECT_EQ(f[6], f[11]) << "without --reference-b nothing is subtracted: " << row;
  }
  expectFinalsWithinBudget(points, 0.2);
  EXPECT_EQ(finals["pt"], 3);
  EXPECT_EQ(finals["vpl"], 6);
  EXPECT_EQ(finals["vsl"], 6);
  EXPECT_EQ(finals["vsl-mrcs"], 6);
  // The summary holds the median of each configuration's three finals.
  std::ifstream sum(file("sweep/summary.csv"));
  std::getline(sum, line);
  EXPECT_EQ(line.rfind("method,lights,radius_scale,sets,seconds_median,relmse_median,relmse_q1,relmse_q3", 0), 0u);
  int rows = 0;
  while (std::getline(sum, line)) {
    std::vector<std::string> f = csvFields(line);
    ASSERT_EQ(f.size(), 15u) << line;
    EXPECT_EQ(f[3], "3");
    std::vector<double> v = finalRel[f[0] + " " + f[1]];
    ASSERT_EQ(v.size(), 3u) << line;
    std::sort(v.begin(), v.end());
    EXPECT_NEAR(std::stod(f[5]), v[1], 1e-4 * v[1]) << line;
    EXPECT_LE(std::stod(f[6]), std::stod(f[5]));
    EXPECT_GE(std::stod(f[7]), std::stod(f[5]));
    ++rows;
  }
  EXPECT_EQ(rows, 7);  // pt; vpl, vsl and vsl-mrcs at two light counts
  auto j = nlohmann::json::parse(std::ifstream(file("sweep/sweep.json")));
  EXPECT_FALSE(j["pareto"]["vsl"].empty());
  EXPECT_EQ(j["summary"].size(), 7u);
  for (const char* png : {"sweep/error_vs_time.png", "sweep/pareto.png"}) {
    Proc s = shell(std::string(VSL_BINARY_DIR) + "/bin/png_stats " + file(png) + " 5");
    EXPECT_EQ(s.code, 0) << png << ": " << s.out;
  }
  // A reference without an indirect layer is refused.
  ASSERT_EQ(run("compare " + file("ref.exr") + " " + file("ref.exr") + " -o " + file("err.exr")).code, 0);
  EXPECT_EQ(run("sweep " + scene("cornell-glossy") + " --reference " + file("err.exr") + " -o " + file("s2")).code, 1);
  // A second reference measures the first one's noise: relMSE(B, A) / 2 is
  // reported and subtracted.
  ASSERT_EQ(
      run("render " + scene("cornell-glossy") + " --spp 16 --width 16 --height 16 --seed 9 -o " + file("refB.exr"))
          .code,
      0);
  Proc c = run("compare " + file("refB.exr") + " " + file("ref.exr") + " --layer indirect --json");
  ASSERT_EQ(c.code, 0) << c.out;
  double ab = nlohmann::json::parse(c.out.substr(c.out.find('{')))["average"]["relMSE"];
  ASSERT_GT(ab, 0);
  Proc r = run("sweep " + scene("cornell-glossy") + " --methods pt --time 0.1 --reference " + file("ref.exr") +
               " --reference-b " + file("refB.exr") + " -o " + file("sweepB"));
  ASSERT_EQ(r.code, 0) << r.out;
  auto jb = nlohmann::json::parse(std::ifstream(file("sweepB/sweep.json")));
  EXPECT_NEAR(double(jb["referenceNoiseRelMSE"]), ab / 2, 1e-9 * ab);
  std::ifstream csvB(file("sweepB/sweep.csv"));
  std::getline(csvB, line);
  while (std::getline(csvB, line)) {
    std::vector<std::string> f = csvFields(line);
    ASSERT_EQ(f.size(), 15u);
    EXPECT_NEAR(std::stod(f[11]), std::stod(f[6]) - ab / 2, 1e-5 * std::stod(f[6]) + 1e-9) << line;
  }
  // A second reference of another size is refused.
  ASSERT_EQ(
      run("render " + scene("cornell-glossy") + " --spp 1 --width 8 --height 8 --seed 9 -o " + file("small.exr")).code,
      0);
  EXPECT_EQ(run("sweep " + scene("cornell-glossy") + " --methods pt --time 0.1 --reference " + file("ref.exr") +
                " --reference-b " + file("small.exr") + " -o " + file("sweepC"))
                .code,
            1);
  // A malformed --mrcs is refused before any work.
  EXPECT_EQ(run("sweep " + scene("cornell-glossy") + " --methods vsl-mrcs --mrcs 10 --reference " + file("ref.exr") +
                " -o " + file("s3"))
                .code,
            2);
}

// ---- Hardening (issue 12) -------------------------------------------------------

namespace {

// A noisy EXR: its PNG does not compress below a few kilobytes.
void writeNoiseExr(const std::string& path, int w, int h, uint32_t seed = 12345) {
  vsl::Image img(w, h);
  uint32_t x = seed;
  for (float& v : img.rgb) {
    x = x * 1664525u + 1013904223u;
    v = float(x >> 8) * 0x1p-24f;
  }
  vsl::Result<void> written = vsl::writeExr(path, {{"", img}});
  ASSERT_TRUE(written) << written.error();
}

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

}  // namespace

// Defect 1: on a full disk (injected: an 8 KiB file-size limit, SIGXFSZ
// ignored, so writes fail with EFBIG as they would with ENOSPC) tonemap and
// compare exit 1 with the reason and leave the good PNG as it was.
TEST_F(Cli, FullDiskKeepsTheGoodPngAndExitsOne) {
  writeNoiseExr(file("a.exr"), 96, 96);
  writeNoiseExr(file("b.exr"), 96, 96, 777);
  std::ofstream(file("good.png")) << "good";
  std::string limit = "bash -c 'ulimit -f 8; trap \"\" XFSZ; exec " + std::string(VSL_BINARY_DIR) + "/bin/vsl ";
  Proc r = shell(limit + "tonemap " + file("a.exr") + " -o " + file("good.png") + "'");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find(file("good.png")), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("File too large"), std::string::npos) << r.out;
  EXPECT_EQ(slurp(file("good.png")), "good");
  r = shell(limit + "compare " + file("a.exr") + " " + file("b.exr") + " --png " + file("good.png") + "'");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_EQ(slurp(file("good.png")), "good");
  r = shell(limit + "compare " + file("a.exr") + " " + file("b.exr") + " -o " + file("good.png") + "'");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_EQ(slurp(file("good.png")), "good");
  size_t n = 0;
  for ([[maybe_unused]] auto& e : fs::directory_iterator(dir)) ++n;
  EXPECT_EQ(n, 3u) << "temporary files left behind";
  // /dev/full fails every write with ENOSPC.
  r = run("tonemap " + file("a.exr") + " -o /dev/full");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("No space left on device"), std::string::npos) << r.out;
}

// Defect 8: -o /dev/null writes through and leaves the device in place.
TEST_F(Cli, DeviceOutputsAreWrittenThrough) {
  writeNoiseExr(file("a.exr"), 8, 8);
  Proc r = run("tonemap " + file("a.exr") + " -o /dev/null");
  EXPECT_EQ(r.code, 0) << r.out;
  r = run("render " + scene("furnace") + " --spp 1 --width 8 --height 8 -o /dev/null --json /dev/null");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  EXPECT_TRUE(fs::exists("/dev/null"));
  // /dev/stdout into a pipe (/proc/self/fd/1 names "pipe:[N]", not a path).
  r = shell("bash -c 'set -o pipefail; " + std::string(VSL_BINARY_DIR) + "/bin/vsl tonemap " + file("a.exr") +
            " -o /dev/stdout 2>/dev/null | od -c | sed -n 1p'");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("P   N   G"), std::string::npos) << r.out;
}

namespace {

// The furnace scene with its JSON changed by edit, written into dir.
std::string editedFurnace(const fs::path& dir, const std::string& name,
                          const std::function<void(nlohmann::json&)>& edit) {
  auto j = nlohmann::json::parse(std::ifstream(scene("furnace")));
  edit(j);
  std::string path = (dir / name).string();
  std::ofstream(path) << j.dump();
  return path;
}

}  // namespace

// Defect 3: aspectRatio is range-checked (exit 1), and a size derived from it
// must stay within the resolution cap (exit 2, a bad argument).
// An output folder the user cannot write to is found before the render (exit
// 1), but the check follows what the writer does: devices are written through
// (-o /dev/null), and a link's file is replaced beside its target (a link in a
// read-only folder to a writable one is fine). Run as an unprivileged user:
// root passes every permission check, so as root the binary runs as nobody.
TEST_F(Cli, UnwritableOutputFolderIsFoundFirst) {
  std::string as;
  if (::geteuid() == 0) {
    if (shell("command -v setpriv").code != 0) GTEST_SKIP() << "running as root without setpriv";
    as = "setpriv --reuid=65534 --regid=65534 --clear-groups ";
  }
  const std::string vsl =
      as + std::string(VSL_BINARY_DIR) + "/bin/vsl render " + scene("furnace") + " --spp 1 --width 8";
  fs::create_directories(file("rw"));
  fs::create_directories(file("ro"));
  fs::permissions(file("rw"), fs::perms::all);
  fs::create_symlink("../rw/out.png", file("ro/link.png"));
  fs::permissions(file("ro"), fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read |
                                  fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec);
  Proc r = shell(vsl + " -o " + file("ro/new.exr"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("the folder " + file("ro") + " is not writable"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("render "), std::string::npos) << "rendered first: " << r.out;
  r = shell(vsl + " -o /dev/null --json /dev/null");
  EXPECT_EQ(r.code, 0) << r.out;
  r = shell(vsl + " -o " + file("rw/a.exr") + " --png " + file("ro/link.png"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(file("rw/out.png")));
  fs::permissions(file("ro"), fs::perms::owner_all);
}

TEST_F(Cli, AspectRatioCannotBypassTheResolutionCap) {
  std::string tiny =
      editedFurnace(dir, "tiny.gltf", [](auto& j) { j["cameras"][0]["perspective"]["aspectRatio"] = 1e-5; });
  Proc r = run("render " + tiny + " --spp 1 -o " + file("x.exr"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("aspectRatio must be in [0.03125,32] (got 1e-05)"), std::string::npos) << r.out;
  std::string tall =
      editedFurnace(dir, "tall.gltf", [](auto& j) { j["cameras"][0]["perspective"]["aspectRatio"] = 1.0 / 32; });
  r = run("render " + tall + " --width 16384 --spp 1 -o " + file("x.exr"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("16384x524288, over the limit of 16384"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(file("x.exr")));
}

// Defect 4: a camera far outside what Embree takes exits 1, no abort.
TEST_F(Cli, FarCameraExitsOne) {
  std::string far = editedFurnace(dir, "far.gltf", [](auto& j) {
    for (auto& n : j["nodes"])
      if (n.contains("camera")) n["translation"] = {0, 0, 2e18};
  });
  Proc r = run("render " + far + " --spp 1 --width 8 --height 8 -o " + file("x.exr"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("far.gltf: node"), std::string::npos) << r.out;
}

// Defect 5: running out of memory is reported (exit 1), never an abort.
TEST_F(Cli, OutOfMemoryIsReported) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "sanitizers reserve more address space than the limit allows";
#else
  Proc r = shell("bash -c 'ulimit -v 2000000; exec " + std::string(VSL_BINARY_DIR) + "/bin/vsl render " +
                 scene("furnace") + " --width 16384 --height 16384 --spp 1 -o " + file("x.exr") + "'");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("out of memory"), std::string::npos) << r.out;
#endif
}

// Defect 6: no reads outside the scene's folder, and nothing told about them.
TEST_F(Cli, UrisOutsideTheScenesFolderAreRefused) {
  std::string shadow =
      editedFurnace(dir, "shadow.gltf", [](auto& j) { j["buffers"][0]["uri"] = "../../../etc/shadow"; });
  Proc r = run("info " + shadow);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("points outside the scene's folder (refused)"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("requestedBytes"), std::string::npos) << r.out;
  Proc zero = run("info /dev/zero");
  EXPECT_EQ(zero.code, 1) << zero.out;
  EXPECT_NE(zero.out.find("not a regular file"), std::string::npos) << zero.out;
}

// Defect 9: --time shorter than one pass still renders one sample per pixel.
TEST_F(Cli, TinyTimeBudgetStillRendersOnePass) {
  Proc r = run("render " + scene("furnace") + " --time 1e-9 --width 8 --height 8 -o " + file("t.exr") + " --json " +
               file("t.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  auto j = nlohmann::json::parse(std::ifstream(file("t.json")));
  EXPECT_EQ(j["spp"], 1);
  EXPECT_GT(j["mean"]["full"][0].get<double>(), 0.5);
}

// --estimator chooses a registered estimator (issue 47): a misspelt name is
// refused with the nearest one, an estimator's option given for another
// estimator names both, and an estimator's parameters given one by one
// choose it and render what its shorthand renders, byte for byte.
TEST_F(Cli, EstimatorOptionChoosesARegisteredEstimator) {
  const std::string common = "render " + scene("cornell-glossy") + " --method all --lights 200 --width 16 --seed 2";
  Proc r = run(common + " --estimator mrc -o " + file("e0.exr"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("unknown estimator 'mrc' (did you mean 'mrcs'?"), std::string::npos) << r.out;
  for (const char* other : {"--mrcs-rows 10", "--mrcs 10,20", "--mrcs-spread"}) {
    r = run(common + " --estimator brute-force " + other + " -o " + file("e1.exr"));
    EXPECT_EQ(r.code, 2) << other << ": " << r.out;
    EXPECT_NE(r.out.find("an option of estimator mrcs, but --estimator is brute-force"), std::string::npos)
        << other << ": " << r.out;
  }
  r = run(common + " --mrcs-rows 0 -o " + file("e2.exr"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--mrcs-rows"), std::string::npos) << r.out;
  r = run(common + " --mrcs-rows 10 --mrcs-clusters 20 -o " + file("e3.exr") + " --json " + file("e3.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  auto j = nlohmann::json::parse(std::ifstream(file("e3.json")));
  EXPECT_EQ(j["estimator"], "mrcs") << "chosen by its parameters";
  EXPECT_EQ(j["estimatorParameters"]["mrcsRows"], 10);
  EXPECT_EQ(j["estimatorParameters"]["mrcsClusters"], 20);
  EXPECT_EQ(j["estimatorParameters"]["mrcsSpread"], false);
  r = run(common + " --estimator mrcs --mrcs 10,20 -o " + file("e4.exr"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(slurp(file("e3.exr")), slurp(file("e4.exr"))) << "the same render, the same describe()";
  // A parameter given one by one overrides the shorthand's.
  r = run(common + " --mrcs 99,20 --mrcs-rows 10 -o " + file("e5.exr"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(slurp(file("e3.exr")), slurp(file("e5.exr")));
  r = run(common + " --estimator brute-force -o " + file("e6.exr") + " --json " + file("e6.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(file("e6.json")))["estimator"], "brute-force");
  r = run("render --help");
  for (const char* option : {"--estimator", "--mrcs-rows", "--mrcs-clusters", "--mrcs-mix", "--mrcs-spread"})
    EXPECT_NE(r.out.find(option), std::string::npos) << option;
}

// The render JSON times parsing and the BVH build apart (seconds.load,
// seconds.bvh) and names the estimator, its parameters and its statistics;
// MRCS's are its settings and the rows and clusters it used (capped at the pixels and the lights, with a
// warning). The means are of the layers the render computed: MRCS renders no
// VPL variant and counts no shadow ray or VSL draw, and those are left out or
// null, not 0; nor does a VSL-only render have a VPL mean.
TEST_F(Cli, RenderJsonSeparatesLoadAndBvhAndNamesTheEstimator) {
  const std::string common = "render " + scene("cornell-glossy") + " --method all --lights 200 --width 16 --seed 2";
  Proc r = run(common + " -o " + file("b.exr") + " --json " + file("b.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  auto j = nlohmann::json::parse(std::ifstream(file("b.json")));
  EXPECT_EQ(j["estimator"], "brute-force");
  EXPECT_GT(j["seconds"]["load"].get<double>(), 0);
  EXPECT_GT(j["seconds"]["bvh"].get<double>(), 0);
  EXPECT_FALSE(j.contains("mrcs"));
  EXPECT_TRUE(j["estimatorParameters"].empty()) << "brute force has no parameters of its own";
  EXPECT_TRUE(j["estimatorStats"].empty());
  for (const char* layer : {"direct", "vslIndirect", "vplIndirect", "vplUnclampedIndirect", "vplDiffuseIndirect",
                            "lostToClamping", "lostToDiffuse"})
    EXPECT_TRUE(j["mean"].contains(layer)) << layer;
  EXPECT_GT(j["shadowRays"].get<double>(), 0);
  EXPECT_GT(j["vslEvaluations"].get<double>(), 0);
  r = run(common + " --mrcs 10,20 -o " + file("m.exr") + " --json " + file("m.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  j = nlohmann::json::parse(std::ifstream(file("m.json")));
  EXPECT_EQ(j["estimator"], "mrcs");
  EXPECT_EQ(j["estimatorParameters"]["mrcsRows"], 10);
  EXPECT_EQ(j["estimatorParameters"]["mrcsClusters"], 20);
  EXPECT_EQ(j["estimatorStats"]["rowsUsed"], 10);
  EXPECT_EQ(j["estimatorStats"]["clustersUsed"], 20);
  EXPECT_EQ(j["batches"], 1);
  EXPECT_EQ(j["mean"].size(), 3u) << j["mean"].dump();
  for (const char* layer : {"direct", "vslIndirect", "vplIndirect"}) EXPECT_TRUE(j["mean"].contains(layer)) << layer;
  EXPECT_TRUE(j["shadowRays"].is_null());
  EXPECT_TRUE(j["vslEvaluations"].is_null());
  EXPECT_EQ(r.out.find("warning"), std::string::npos) << r.out;
  // 1,000 rows for 16 x 16 pixels and more clusters than lights.
  r = run(common + " --mrcs 1000,5000 -o " + file("m2.exr") + " --json " + file("m2.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  j = nlohmann::json::parse(std::ifstream(file("m2.json")));
  EXPECT_EQ(j["estimatorParameters"]["mrcsRows"], 1000);
  EXPECT_EQ(j["estimatorStats"]["rowsUsed"], 256);
  EXPECT_EQ(j["estimatorStats"]["clustersUsed"], j["lights"]);
  EXPECT_NE(r.out.find("warning: 1000 MRCS rows for 256 pixels: 256 used"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("warning: 5000 MRCS clusters for " + j["lights"].dump() + " lights"), std::string::npos)
      << r.out;
  r = run("render " + scene("cornell-glossy") + " --method vsl --lights 200 --width 16 -o " + file("v.exr") +
          " --json " + file("v.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  j = nlohmann::json::parse(std::ifstream(file("v.json")));
  EXPECT_EQ(j["mean"].size(), 2u) << j["mean"].dump();
  EXPECT_TRUE(j["mean"].contains("vslIndirect"));
  r = run("render " + scene("furnace") + " --spp 2 --width 8 -o " + file("p.exr") + " --json " + file("p.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  j = nlohmann::json::parse(std::ifstream(file("p.json")));
  EXPECT_GT(j["seconds"]["bvh"].get<double>(), 0);
  // The path tracer's recorded settings are a command line that renders the
  // same image (its height, from the camera, was "--height 0", refused).
  const std::string settings = j["settings"];
  EXPECT_EQ(settings.find("--height"), std::string::npos) << settings;
  r = run("render " + scene("furnace") + " " + settings + " -o " + file("p2.exr"));
  ASSERT_EQ(r.code, 0) << settings << "\n" << r.out;
  std::ifstream a(file("p.exr"), std::ios::binary), b(file("p2.exr"), std::ios::binary);
  EXPECT_TRUE(std::equal(std::istreambuf_iterator<char>(a), {}, std::istreambuf_iterator<char>(b), {}))
      << "the same settings give another image";
}

// VSL's automatic sample count: the lobe-aware one by default, the authors'
// with --vsl-count authors (more integrand evaluations on cornell-glossy's broad
// lobes, the same light set), shares with --vsl-count shares (fewer), recorded
// in the settings; anything else exits 2.
// The settings string can be pasted back: no size of 0 ("the scene's").
// --preset paper is the paper's parameters given one by one (docs/REFERENCE.md,
// "Presets"): the same bytes, and the JSON names the preset; an option given
// with it overrides it, in either order (the settings are then "custom"); an
// unknown name is a bad argument.
TEST_F(Cli, PaperPresetIsItsSettingsOneByOne) {
  const std::string common = "render " + scene("kitchen") + " --method all --width 24 --lights 400 --seed 2";
  auto render = [&](const std::string& extra, const std::string& name) {
    Proc r = run(common + extra + " -o " + file(name + ".exr") + " --json " + file(name + ".json"));
    EXPECT_EQ(r.code, 0) << r.out;
    return nlohmann::json::parse(std::ifstream(file(name + ".json")));
  };
  const nlohmann::json preset = render(" --preset paper", "preset");
  const nlohmann::json byHand =
      render(" --vsl-integral quadrature --vsl-count authors --lobe-floor 0 --continue-alpha 0", "by-hand");
  const nlohmann::json plain = render("", "plain");
  EXPECT_EQ(preset["preset"], "paper");
  EXPECT_EQ(byHand["preset"], "paper");
  EXPECT_EQ(plain["preset"], "default");
  EXPECT_EQ(preset["settings"], byHand["settings"]);
  std::ifstream a(file("preset.exr"), std::ios::binary), b(file("by-hand.exr"), std::ios::binary);
  const std::string bytesA((std::istreambuf_iterator<char>(a)), {}), bytesB((std::istreambuf_iterator<char>(b)), {});
  ASSERT_FALSE(bytesA.empty());
  EXPECT_TRUE(bytesA == bytesB) << "--preset paper and its settings one by one render different files";
  for (const char* extra : {" --preset paper --lobe-floor 0.5", " --lobe-floor 0.5 --preset paper"}) {
    const nlohmann::json j = render(extra, "override");
    EXPECT_EQ(j["preset"], "custom") << extra;
    EXPECT_NE(j["settings"].get<std::string>().find("--vsl-count authors --lobe-floor 0.5 --continue-alpha 0"),
              std::string::npos)
        << extra << ": " << j["settings"];
  }
  Proc bad = run(common + " --preset nonsense -o " + file("bad.exr"));
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_NE(bad.out.find("--preset: nonsense not in {default,paper}"), std::string::npos) << bad.out;
}

TEST_F(Cli, VslCountIsChosenAndRecorded) {
  const std::string common =
      "render " + scene("cornell-glossy") + " --method vsl --width 16 --batches 1 --direct-samples 1 --seed 4";
  auto settingsOf = [&](const std::string& extra, const std::string& name, const char* lights = "10000") {
    Proc r =
        run(common + " --lights " + lights + extra + " -o " + file(name + ".exr") + " --json " + file(name + ".json"));
    EXPECT_EQ(r.code, 0) << r.out;
    return nlohmann::json::parse(std::ifstream(file(name + ".json")));
  };
  auto lobe = settingsOf("", "lobe"), authors = settingsOf(" --vsl-count authors", "authors");
  const std::string s = lobe["settings"];
  EXPECT_NE(s.find("--vsl-count lobe"), std::string::npos) << s;
  EXPECT_EQ(s.find("--height"), std::string::npos) << s;
  EXPECT_NE(authors["settings"].get<std::string>().find("--vsl-count authors"), std::string::npos);
  EXPECT_EQ(lobe["lights"], authors["lights"]);
  EXPECT_LT(lobe["vslEvaluations"].get<double>(), 0.9 * authors["vslEvaluations"].get<double>());
  // --vsl-count shares: fewer evaluations than the lobe-aware count where the
  // cones are wide (500 lights: 1.2 M against 2.2 M).
  auto lobe500 = settingsOf("", "lobe500", "500"), shares = settingsOf(" --vsl-count shares", "shares", "500");
  EXPECT_NE(shares["settings"].get<std::string>().find("--vsl-count shares"), std::string::npos) << shares["settings"];
  EXPECT_EQ(shares["lights"], lobe500["lights"]);
  EXPECT_LT(shares["vslEvaluations"].get<double>(), 0.75 * lobe500["vslEvaluations"].get<double>());
  // A fixed count replaces the automatic one, and the sweep takes it too.
  auto two = settingsOf(" --vsl-samples 2", "two");
  EXPECT_NE(two["settings"].get<std::string>().find("--vsl-samples 2"), std::string::npos) << two["settings"];
  EXPECT_EQ(two["lights"], lobe["lights"]);
  EXPECT_LT(two["vslEvaluations"].get<double>(), 0.9 * lobe["vslEvaluations"].get<double>());
  ASSERT_EQ(run("render " + scene("cornell-glossy") + " --spp 4 --width 16 --height 16 -o " + file("ref.exr")).code, 0);
  ASSERT_EQ(
      run("sweep " + scene("cornell-glossy") + " --methods vsl --lights 40 --sets 1 --time 0.05 --vsl-samples 3 " +
          "--reference " + file("ref.exr") + " -o " + file("sw"))
          .code,
      0);
  auto sw = nlohmann::json::parse(std::ifstream(file("sw/sweep.json")));
  EXPECT_NE(sw["settings"].get<std::string>().find("--vsl-samples 3"), std::string::npos) << sw["settings"];
  Proc r = run(common + " --vsl-count fast -o " + file("bad.exr"));
  EXPECT_NE(r.out.find("shares"), std::string::npos) << "the valid choices: " << r.out;
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--vsl-count"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(file("bad.exr")));
}

// vsl-studio refuses a bad estimator on its command line before opening
// anything: exit 2 and the setting's valid range.
TEST_F(Cli, StudioRefusesBadEstimatorFlags) {
  const std::string studio = std::string(VSL_BINARY_DIR) + "/bin/vsl-studio";
  if (!fs::exists(studio)) GTEST_SKIP() << "built without the UI";
  for (auto [args, want] : std::vector<std::pair<std::string, std::string>>{
           {"--mrcs 0,5", "mrcs rows: must be in [1,100000]"},
           {"--mrcs 10,0", "mrcs clusters"},
           {"--mrcs 10", "--mrcs must be ROWS,CLUSTERS"},
           {"--mrcs 10,20,x", "--mrcs must be ROWS,CLUSTERS"},
           {"--progressive-radius 1.5", "--progressive-radius: must be in (0,0.99] or off"}}) {
    Proc r = shell(studio + " --headless " + args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(want), std::string::npos) << args << "\n" << r.out;
  }
}

// Numbers out of range are refused, never wrapped round or read as "the
// default": a width or a time of zero, MRCS sizes and shard indices beyond
// an int, and a scene beside --merge (which would be ignored). Exit 2, the
// reason named, nothing written.
TEST_F(Cli, OutOfRangeNumbersAreBadArguments) {
  const std::string cg = scene("cornell-glossy");
  for (auto [args, want] : std::vector<std::pair<std::string, std::string>>{
           {"render " + cg + " --width 0 -o " + file("oor.exr"), "--width"},
           {"render " + cg + " --height 0 -o " + file("oor.exr"), "--height"},
           {"render " + cg + " --time 0 -o " + file("oor.exr"), "--time"},
           {"reference " + cg + " --time 0 --no-cache -o " + file("oor.exr"), "--time"},
           {"reference " + cg + " --width 0 --no-cache -o " + file("oor.exr"), "--width"},
           {"render " + cg + " --method vsl --mrcs 4294967297,10 -o " + file("oor.exr"), "--mrcs must be"},
           {"render " + cg + " --method vsl --mrcs 10,-4294967295 -o " + file("oor.exr"), "--mrcs must be"},
           {"sweep " + cg + " --shard 4294967297/2 -o " + file("oor-sweep"), "--shard must be I/N"},
           {"sweep " + cg + " --shard 1/2x -o " + file("oor-sweep"), "--shard must be I/N"},
           {"sweep " + cg + " --merge " + file("oor-a") + " -o " + file("oor-sweep"), "takes no scene"},
           {"render " + cg + " --method vsl --vsl-samples 0 -o " + file("oor.exr"),
            "--vsl-samples: must be in [1,4096] or auto"},
           {"render " + cg + " --method vsl --vsl-samples 4097 -o " + file("oor.exr"),
            "--vsl-samples: must be in [1,4096] or auto"},
           {"render " + cg + " --method vsl --vsl-samples 3x -o " + file("oor.exr"),
            "--vsl-samples: must be in [1,4096] or auto"},
           {"sweep " + cg + " --vsl-samples -1 -o " + file("oor-sweep"),
            "--vsl-samples: must be in [1,4096] or auto"}}) {
    Proc r = run(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(want), std::string::npos) << args << "\n" << r.out;
  }
  EXPECT_FALSE(fs::exists(file("oor.exr")));
  EXPECT_FALSE(fs::exists(file("oor-sweep")));
}

// A reference (or second reference) rendered from another scene is refused by
// the sweep (exit 1, both keys named) instead of measuring every method against the wrong image;
// one of the same scene is taken.
TEST_F(Cli, SweepRefusesAReferenceOfAnotherScene) {
  ASSERT_EQ(
      run("reference " + scene("furnace") + " --width 8 --height 8 --spp 2 --no-cache -o " + file("fref.exr")).code, 0);
  Proc r = run("sweep " + scene("cornell-glossy") + " --methods vpl --lights 20 --sets 1 --time 0.1 --reference " +
               file("fref.exr") + " -o " + file("other-sweep"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("rendered from another scene or camera"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("furnace-"), std::string::npos) << r.out;
  r = run("sweep " + scene("furnace") + " --methods vpl --lights 20 --sets 1 --time 0.1 --reference " +
          file("fref.exr") + " -o " + file("same-sweep"));
  EXPECT_EQ(r.code, 0) << r.out;
  // The second reference, which measures the first one's noise, too.
  ASSERT_EQ(
      run("reference " + scene("cornell-glossy") + " --width 8 --height 8 --spp 2 --no-cache -o " + file("cref.exr"))
          .code,
      0);
  r = run("sweep " + scene("furnace") + " --methods vpl --lights 20 --sets 1 --time 0.1 --reference " +
          file("fref.exr") + " --reference-b " + file("cref.exr") + " -o " + file("other-b-sweep"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find(file("cref.exr") + ": rendered from another scene or camera"), std::string::npos) << r.out;
}

// The lobe gather works with either estimator: a render records it in the
// EXR's settings (beside MRCS's), and an absurd count is refused.
TEST_F(Cli, LobeGatherWorksWithEitherEstimatorAndIsRecorded) {
  const std::string render = "render " + scene("cornell-glossy") + " --method vsl --lights 50 --width 8 --batches 1 " +
                             "--direct-samples 1 --lobe-gather 2000 ";
  Proc r = run(render + "--mrcs 8,16 -o " + file("lg-mrcs.exr"));
  ASSERT_EQ(r.code, 0) << r.out;
  Proc hm = shell("exrheader " + file("lg-mrcs.exr"));
  EXPECT_NE(hm.out.find("--lobe-gather 2000"), std::string::npos) << hm.out;
  EXPECT_NE(hm.out.find("vsl.estimator (type string): \"mrcs --mrcs 8,16,"), std::string::npos) << hm.out;
  r = run(render + "--lobe-gather-rays 3 -o " + file("lg.exr"));
  ASSERT_EQ(r.code, 0) << r.out;
  Proc h = shell("exrheader " + file("lg.exr"));
  EXPECT_NE(h.out.find("--lobe-gather 2000 --lobe-gather-rays 3"), std::string::npos) << h.out;
  r = run(render + "--lobe-gather-rays 0 -o " + file("lg0.exr"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--lobe-gather-rays"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(file("lg0.exr")));
  r = run(render + "--lobe-gather-alpha 0.15 -o " + file("lga.exr"));
  ASSERT_EQ(r.code, 0) << r.out;
  Proc ha = shell("exrheader " + file("lga.exr"));
  EXPECT_NE(ha.out.find("--lobe-gather-alpha 0.15"), std::string::npos) << ha.out;
  for (const char* bad : {"0", "2", "nan"}) {
    r = run(render + "--lobe-gather-alpha " + bad + " -o " + file("lga0.exr"));
    EXPECT_EQ(r.code, 2) << bad << ": " << r.out;
    EXPECT_NE(r.out.find("--lobe-gather-alpha"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(file("lga0.exr")));
  }
}

// With --method pt (the default) the many-light options would do nothing:
// they are refused, each named, before any work (exit 2); the path tracer's
// own options still run.
TEST_F(Cli, ManyLightOptionsWithThePathTracerAreBadArguments) {
  const std::string base = "render " + scene("cornell-glossy") + " --width 8 --spp 1 -o " + file("mlpt.exr");
  for (auto [args, want] : std::vector<std::pair<std::string, std::string>>{
           {base + " --lights 100", "--lights: for the many-light methods, but --method is pt"},
           {base + " --method pt --lobe-gather 1000 --batches 4",
            "--batches, --lobe-gather: for the many-light methods, but --method is pt"},
           {base + " --mrcs 10,20 --clamp off", "--clamp, --mrcs: for the many-light methods"}}) {
    Proc r = run(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(want), std::string::npos) << args << "\n" << r.out;
    EXPECT_NE(r.out.find("give --method vsl, vpl or all"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(file("mlpt.exr"))) << args;
  }
  Proc ok = run(base + " --seed 2 --max-depth 4 --component indirect --exposure 1 --camera main --png " +
                file("mlpt.png") + " --json " + file("mlpt.json"));
  EXPECT_EQ(ok.code, 0) << ok.out;
  EXPECT_TRUE(fs::exists(file("mlpt.exr")));
}

// NaN and infinity pass CLI11's range checks; every floating-point option of
// vsl and vsl-studio refuses them (exit 2, the option named) before any work,
// lists item by item, while finite values still run.
TEST_F(Cli, NonFiniteNumbersAreBadArguments) {
  const std::string render = "render " + scene("cornell-glossy") + " --method vpl --lights 20 --width 8 --batches 1 " +
                             "--direct-samples 1 -o " + file("nf.exr");
  for (auto [args, want] : std::vector<std::pair<std::string, std::string>>{
           {render + " --exposure nan", "--exposure: must be a finite number (got 'nan')"},
           {render + " --exposure -inf", "--exposure: must be a finite number (got '-inf')"},
           {render + " --split-alpha nan", "--split-alpha: must be a finite number"},
           {render + " --lobe-floor nan", "--lobe-floor: must be a finite number"},
           {render + " --pair-roulette nan", "--pair-roulette: must be a finite number"},
           // Not a number problem, but refused the same way: MRCS does not play the roulette.
           {render + " --mrcs 10,20 --pair-roulette 1", "--pair-roulette: brute force only"},
           {"sweep " + scene("cornell-glossy") + " --methods vpl-mrcs --pair-roulette 1 -o " + file("nf-sweep"),
            "--pair-roulette: brute force only, not with MRCS (method vpl-mrcs)"},
           {render + " --radius-scale 1e999", "--radius-scale: must be a finite number (got '1e999')"},
           {"sweep " + scene("cornell-glossy") + " --radius-scale 1,nan -o " + file("nf-sweep"),
            "--radius-scale: must be a finite number (got 'nan')"}}) {
    Proc r = run(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(want), std::string::npos) << args << "\n" << r.out;
  }
  EXPECT_FALSE(fs::exists(file("nf.exr")));
  EXPECT_FALSE(fs::exists(file("nf-sweep")));
  Proc ok = run(render + " --exposure -1.5");
  EXPECT_EQ(ok.code, 0) << ok.out;
  const std::string studio = std::string(VSL_BINARY_DIR) + "/bin/vsl-studio";
  if (!fs::exists(studio)) GTEST_SKIP() << "built without the UI";
  for (const char* args : {"--after nan", "--split-alpha nan", "--lobe-floor nan", "--progressive-radius nan"}) {
    Proc r = shell(studio + " --headless " + args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find("must be a finite number"), std::string::npos) << args << "\n" << r.out;
  }
}

// An output that is one of the command's inputs, or another of its outputs, is
// refused before any work (exit 2, both named) and the input is left as it was:
// tonemap or compare over their own EXRs, a render over its scene, --png over -o.
TEST_F(Cli, OutputsNeverOverwriteInputs) {
  fs::copy_file(scene("furnace"), file("fz.gltf"), fs::copy_options::overwrite_existing);
  Proc r = run("render " + file("fz.gltf") + " --spp 1 --width 8 -o " + file("s1.exr"));
  ASSERT_EQ(r.code, 0) << r.out;
  fs::copy_file(file("s1.exr"), file("s2.exr"), fs::copy_options::overwrite_existing);
  const auto exrSize = fs::file_size(file("s1.exr")), sceneSize = fs::file_size(file("fz.gltf"));
  for (auto [args, want] : std::vector<std::pair<std::string, std::string>>{
           {"tonemap " + file("s1.exr") + " -o " + file("s1.exr"), "is also the input"},
           {"compare " + file("s1.exr") + " " + file("s2.exr") + " -o " + file("s1.exr"), "is also the input"},
           {"compare " + file("s1.exr") + " " + file("s2.exr") + " --flip-exr " + dir.string() + "/./s2.exr",
            "is also the input"},
           {"render " + file("fz.gltf") + " --spp 1 --width 8 -o " + file("fz.gltf"), "is also the input"},
           {"compare " + file("s1.exr") + " " + file("s2.exr") + " --flip-png " + file("m.png") + " --flip-exr " +
                file("m-hdr.png"),
            "--flip-png's HDR map " + file("m-hdr.png") + " is also --flip-exr"},
           {"render " + file("fz.gltf") + " --spp 1 --width 8 -o " + file("same.exr") + " --png " + file("same.exr"),
            "--png " + file("same.exr") + " is also --output"},
       }) {
    r = run(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(want), std::string::npos) << args << "\n" << r.out;
  }
  EXPECT_EQ(fs::file_size(file("s1.exr")), exrSize);
  EXPECT_EQ(fs::file_size(file("s2.exr")), exrSize);
  EXPECT_EQ(fs::file_size(file("fz.gltf")), sceneSize);
  EXPECT_FALSE(fs::exists(file("same.exr")));
  EXPECT_FALSE(fs::exists(file("m.png")));
  EXPECT_FALSE(fs::exists(file("m-hdr.png")));
  // An output in a folder that does not exist, or that is a folder: an I/O
  // failure (exit 1), found before the render instead of after it.
  for (auto [args, want] : std::vector<std::pair<std::string, std::string>>{
           {"render " + file("fz.gltf") + " --spp 1 --width 8 -o " + file("same.exr") + " --png " + file("no/x.png"),
            "the folder " + file("no") + " does not exist"},
           {"render " + file("fz.gltf") + " --spp 1 --width 8 -o " + dir.string(), "is a folder, not a file"}}) {
    r = run(args);
    EXPECT_EQ(r.code, 1) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(want), std::string::npos) << args << "\n" << r.out;
  }
  EXPECT_FALSE(fs::exists(file("same.exr")));
  // The files a scene reads are inputs too: its external buffers and images
  // (URIs decoded and resolved as the loader does), and an empty path is no
  // output at all (exit 2, before any work).
  fs::create_directories(file("ext"));
  std::ofstream(file("ext/tri.bin")) << std::string(36, '\0');
  std::ofstream(file("ext/tex.png")) << "not read here";
  std::ofstream(file("ext/ext.gltf"))
      << R"({"asset":{"version":"2.0"},"buffers":[{"uri":"tri%2Ebin","byteLength":36}],)"
      << R"("images":[{"uri":"sub/../tex.png"}],"bufferViews":[{"buffer":0,"byteLength":36}],)"
      << R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],)"
      << R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]})";
  for (auto [args, want] : std::vector<std::pair<std::string, std::string>>{
           {"render " + file("ext/ext.gltf") + " --spp 1 --width 8 -o " + file("ext/tri.bin"),
            "which the scene " + file("ext/ext.gltf") + " reads"},
           {"render " + file("ext/ext.gltf") + " --spp 1 --width 8 -o " + file("x.exr") + " --png " +
                file("ext/../ext/tex.png"),
            "tex.png, which the scene"},
           {"render " + file("ext/ext.gltf") + " --spp 1 --width 8 -o " + file("x.exr") + " --json ''",
            "--json is an empty path"}}) {
    r = run(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(want), std::string::npos) << args << "\n" << r.out;
  }
  EXPECT_EQ(fs::file_size(file("ext/tri.bin")), 36u);
  EXPECT_EQ(fs::file_size(file("ext/tex.png")), 13u);
  EXPECT_FALSE(fs::exists(file("x.exr")));
}

// docs/REFERENCE.md's parameter table is the registry's (`vsl params
// --markdown`, between the markers): a parameter added or changed without
// regenerating it fails here.
TEST_F(Cli, ReferenceParameterTableIsTheRegistrys) {
  Proc r = run("params --markdown");
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream in(std::string(VSL_SOURCE_DIR) + "/docs/REFERENCE.md");
  const std::string doc((std::istreambuf_iterator<char>(in)), {});
  const std::string begin = "<!-- params:begin (vsl params --markdown) -->\n", end = "<!-- params:end -->";
  const size_t b = doc.find(begin), e = doc.find(end);
  ASSERT_NE(b, std::string::npos) << "docs/REFERENCE.md has no generated parameter table";
  ASSERT_NE(e, std::string::npos);
  EXPECT_EQ(doc.substr(b + begin.size(), e - b - begin.size()), r.out)
      << "regenerate it: build/bin/vsl params --markdown";
  for (const vsl::Param<vsl::ManyLightSettings>& p : vsl::manyLightParams().all())
    EXPECT_NE(r.out.find(std::string("`--") + p.spec.name + "`"), std::string::npos) << p.spec.name;
}

// A misspelt option is refused with the nearest one named (exit 2).
TEST_F(Cli, UnknownOptionNamesTheNearest) {
  for (auto [args, want] :
       std::vector<std::pair<std::string, std::string>>{{"--lobe-flor 1", "did you mean --lobe-floor?"},
                                                        {"--pair-rolette 1", "did you mean --pair-roulette?"},
                                                        {"--vsl-sampels 3", "did you mean --vsl-samples?"}}) {
    Proc r = run("render " + scene("furnace") + " --method vsl " + args + " -o " + file("typo.exr"));
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(want), std::string::npos) << args << "\n" << r.out;
  }
  EXPECT_FALSE(fs::exists(file("typo.exr")));
}

// A parameter the render would not use is an error (pbrt's ReportUnused):
// VSL's with only VPL rendered, VPL's with only VSL, and one whose switch is
// off or at another value (exit 2, nothing written).
TEST_F(Cli, UnusedParametersAreBadArguments) {
  const std::string base = "render " + scene("furnace") + " --width 8 --lights 20 -o " + file("unused.exr");
  for (auto [args, want] : std::vector<std::pair<std::string, std::string>>{
           {" --method vpl --lobe-floor 0.5", "--lobe-floor: for VSL, but only VPL is rendered"},
           {" --method vpl --knn 4", "--knn: for VSL, but only VPL is rendered"},
           {" --method vsl --clamp off", "--clamp: for VPL, but only VSL is rendered"},
           {" --method vsl --lobe-gather-rays 8", "--lobe-gather-rays: has no effect while lobe-gather is off"},
           {" --method vsl-quadrature --vsl-sg-max-angle 10",
            "--vsl-sg-max-angle: has no effect while vsl-integral is not sg"}}) {
    Proc r = run(base + args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(want), std::string::npos) << args << "\n" << r.out;
    EXPECT_FALSE(fs::exists(file("unused.exr"))) << args;
  }
  Proc ok =
      run(base + " --method all --lobe-floor 0.5 --clamp off --vsl-sg-max-angle 10 --batches 1 --direct-samples 1");
  EXPECT_EQ(ok.code, 0) << ok.out;
}
