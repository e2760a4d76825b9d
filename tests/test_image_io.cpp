// Output files on a full disk, special targets and hostile EXR headers.
// A full disk is injected without mount: RLIMIT_FSIZE (with SIGXFSZ ignored)
// makes every write past the limit fail with EFBIG, exactly where a full
// disk would fail with ENOSPC; /dev/full fails every write with ENOSPC.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include "core/image_io.h"
#include "core/rng.h"

using namespace vsl;
namespace fs = std::filesystem;

namespace {

class ImageIo : public ::testing::Test {
 protected:
  fs::path dir;
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("vsl_image_io_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string file(const std::string& n) { return (dir / n).string(); }
};

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// An image of noise: it does not compress, so its files are large.
Image noise(int w, int h) {
  Image img(w, h);
  Rng rng = Rng::forItem(1, 2, 3, 4);
  for (float& v : img.rgb) v = rng.uniform();
  return img;
}

// Every write past `bytes` fails with EFBIG while this object lives.
struct FileSizeLimit {
  rlimit old{};
  void (*oldHandler)(int);
  explicit FileSizeLimit(rlim_t bytes) {
    oldHandler = std::signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &old);
    rlimit r = old;
    r.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &r);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &old);
    std::signal(SIGXFSZ, oldHandler);
  }
};

size_t entries(const fs::path& d) {
  size_t n = 0;
  for ([[maybe_unused]] auto& e : fs::directory_iterator(d)) ++n;
  return n;
}

}  // namespace

// Defect 1: a write that fails part-way (full disk) must leave the old file as
// it was, report the path and the reason, and leave no temporary file behind.
TEST_F(ImageIo, FullDiskKeepsTheExistingFileForEveryFormat) {
  Image img = noise(128, 128);  // ~50 KB PNG, ~150 KB EXR
  std::string bigText(200000, 'x');
  struct Case {
    const char* name;
    std::function<bool(const std::string&, std::string*)> write;
  };
  std::vector<Case> cases = {
      {"good.png", [&](const std::string& p, std::string* e) { return writePng(p, img, 0, e); }},
      {"good.exr",
       [&](const std::string& p, std::string* e) {
         return writeExr(p, {{"", img}}, e);
       }},
      {"good.json", [&](const std::string& p, std::string* e) { return writeTextFile(p, bigText, e); }},
      {"good.csv", [&](const std::string& p, std::string* e) { return writeTextFile(p, bigText, e); }},
  };
  for (const Case& c : cases) {
    std::string path = file(c.name);
    std::ofstream(path) << "the good file";
    std::string err;
    bool ok;
    {
      FileSizeLimit limit(4096);
      ok = c.write(path, &err);
    }
    EXPECT_FALSE(ok) << c.name;
    EXPECT_NE(err.find(path), std::string::npos) << err;
    EXPECT_NE(err.find("File too large"), std::string::npos) << err;
    EXPECT_EQ(err.find("Success"), std::string::npos) << err;
    EXPECT_EQ(slurp(path), "the good file") << c.name;
    EXPECT_EQ(entries(dir), 1u) << c.name << ": a temporary file was left behind";
    fs::remove(path);
    // Without the limit the same write succeeds.
    ASSERT_TRUE(c.write(path, &err)) << err;
    EXPECT_GT(fs::file_size(path), 4096u);
    fs::remove(path);
  }
}

TEST_F(ImageIo, WrittenPngAndExrReadBack) {
  Image img = noise(16, 8);
  std::string err;
  ASSERT_TRUE(writeExr(file("a.exr"), {{"", img}, {"x", img}}, &err)) << err;
  std::vector<Layer> layers;
  ASSERT_TRUE(readExr(file("a.exr"), layers, &err)) << err;
  ASSERT_EQ(layers.size(), 2u);
  EXPECT_EQ(layers[0].image.rgb, img.rgb);
  ASSERT_TRUE(writePng(file("a.png"), img, 0, &err)) << err;
  std::string png = slurp(file("a.png"));
  ASSERT_GT(png.size(), 20u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  EXPECT_NE(png.find("IEND"), std::string::npos);
}

// Defect 8: device nodes are written through, never replaced; /dev/full
// reports its error.
TEST_F(ImageIo, DevicesAreWrittenThroughNotReplaced) {
  std::string err;
  Image img = noise(8, 8);
  ASSERT_TRUE(writePng("/dev/null", img, 0, &err)) << err;
  ASSERT_TRUE(writeTextFile("/dev/null", "x", &err)) << err;
  struct stat st;
  ASSERT_EQ(stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode)) << "/dev/null was replaced";
  EXPECT_FALSE(writePng("/dev/full", img, 0, &err));
  EXPECT_NE(err.find("/dev/full"), std::string::npos) << err;
  EXPECT_NE(err.find("No space left on device"), std::string::npos) << err;
  ASSERT_EQ(stat("/dev/full", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
}

// Defect 8: a symlink stays a link; the file it names gets the new contents.
TEST_F(ImageIo, SymlinksAreFollowedAndKept) {
  std::ofstream(file("real.json")) << "old";
  fs::create_symlink(file("real.json"), file("link.json"));
  std::string err;
  ASSERT_TRUE(writeTextFile(file("link.json"), "new", &err)) << err;
  EXPECT_TRUE(fs::is_symlink(file("link.json")));
  EXPECT_EQ(slurp(file("real.json")), "new");
  // A dangling link creates the file it names.
  fs::create_symlink(file("absent.json"), file("dangling.json"));
  ASSERT_TRUE(writeTextFile(file("dangling.json"), "made", &err)) << err;
  EXPECT_TRUE(fs::is_symlink(file("dangling.json")));
  EXPECT_EQ(slurp(file("absent.json")), "made");
}

TEST_F(ImageIo, DirectoriesAndMissingFoldersAreRefusedWithAReason) {
  std::string err;
  fs::create_directories(file("sub"));
  EXPECT_FALSE(writeTextFile(file("sub"), "x", &err));
  EXPECT_NE(err.find("is a directory"), std::string::npos) << err;
  EXPECT_TRUE(fs::is_directory(file("sub")));
  EXPECT_FALSE(writePng(file("no/such/dir/x.png"), noise(4, 4), 0, &err));
  EXPECT_NE(err.find("No such file or directory"), std::string::npos) << err;
}

// Defect 5: a data window patched to 32768x32768 in a small file is refused
// before anything is allocated.
TEST_F(ImageIo, PatchedExrDataWindowIsRefusedBeforeAllocation) {
  std::string err;
  // Large enough that OpenEXR can read a line offset table for 32768 lines.
  Image img = noise(64, 64);
  ASSERT_TRUE(writeExr(file("a.exr"), {{"", img}, {"b", img}, {"c", img}}, &err)) << err;
  std::string bytes = slurp(file("a.exr"));
  const std::string key("dataWindow\0box2i\0", 17);
  size_t at = bytes.find(key);
  ASSERT_NE(at, std::string::npos);
  int32_t box[4] = {0, 0, 32767, 32767};
  std::memcpy(&bytes[at + key.size() + 4], box, sizeof box);
  std::ofstream(file("patched.exr"), std::ios::binary) << bytes;
  std::vector<Layer> layers;
  EXPECT_FALSE(readExr(file("patched.exr"), layers, &err));
  EXPECT_NE(err.find("patched.exr"), std::string::npos) << err;
  EXPECT_NE(err.find("data window 32768x32768"), std::string::npos) << err;
  EXPECT_TRUE(layers.empty());
  // Negative and overflowing windows.
  int32_t bad[4] = {INT32_MIN, 0, INT32_MAX, 15};
  std::memcpy(&bytes[at + key.size() + 4], bad, sizeof bad);
  std::ofstream(file("overflow.exr"), std::ios::binary) << bytes;
  EXPECT_FALSE(readExr(file("overflow.exr"), layers, &err));
  EXPECT_NE(err.find("data window"), std::string::npos) << err;
}

// Reading: only regular files (a FIFO would block).
TEST_F(ImageIo, ReadingRefusesSpecialFiles) {
  std::vector<Layer> layers;
  std::string err;
  EXPECT_FALSE(readExr("/dev/zero", layers, &err));
  EXPECT_NE(err.find("/dev/zero: not a regular file"), std::string::npos) << err;
  ASSERT_EQ(mkfifo(file("fifo.exr").c_str(), 0600), 0);
  EXPECT_FALSE(readExr(file("fifo.exr"), layers, &err));
  EXPECT_NE(err.find("not a regular file"), std::string::npos) << err;
  EXPECT_FALSE(readExr(dir.string(), layers, &err));
  EXPECT_NE(err.find("is a directory"), std::string::npos) << err;
}
