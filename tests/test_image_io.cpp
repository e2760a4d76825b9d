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
#include "support.h"

using namespace vsl;
namespace fs = std::filesystem;

namespace {

class ImageIo : public ::testing::Test {
 protected:
  fs::path dir;
  void SetUp() override {
    dir = vsl::test::scratchDir("vsl_image_io_" +
                                std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string file(const std::string& n) { return (dir / n).string(); }
};

using vsl::test::slurp;

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
    std::function<Result<void>(const std::string&)> write;
  };
  std::vector<Case> cases = {
      {"good.png", [&](const std::string& p) { return writePng(p, img, 0); }},
      {"good.exr",
       [&](const std::string& p) {
         return writeExr(p, {{"", img}});
       }},
      {"good.json", [&](const std::string& p) { return writeTextFile(p, bigText); }},
      {"good.csv", [&](const std::string& p) { return writeTextFile(p, bigText); }},
  };
  for (const Case& c : cases) {
    std::string path = file(c.name);
    std::ofstream(path) << "the good file";
    Result<void> written;
    {
      FileSizeLimit limit(4096);
      written = c.write(path);
    }
    EXPECT_FALSE(written) << c.name;
    const std::string& err = written.error();
    EXPECT_NE(err.find(path), std::string::npos) << err;
    EXPECT_NE(err.find("File too large"), std::string::npos) << err;
    EXPECT_EQ(err.find("Success"), std::string::npos) << err;
    EXPECT_EQ(slurp(path), "the good file") << c.name;
    EXPECT_EQ(entries(dir), 1u) << c.name << ": a temporary file was left behind";
    fs::remove(path);
    // Without the limit the same write succeeds.
    Result<void> again = c.write(path);
    ASSERT_TRUE(again) << again.error();
    EXPECT_GT(fs::file_size(path), 4096u);
    fs::remove(path);
  }
}

TEST_F(ImageIo, WrittenPngAndExrReadBack) {
  Image img = noise(16, 8);
  Result<void> w = writeExr(file("a.exr"), {{"", img}, {"x", img}});
  ASSERT_TRUE(w) << w.error();
  Result<std::vector<Layer>> layers = readExr(file("a.exr"));
  ASSERT_TRUE(layers) << layers.error();
  ASSERT_EQ(layers->size(), 2u);
  EXPECT_EQ((*layers)[0].image.rgb, img.rgb);
  w = writePng(file("a.png"), img, 0);
  ASSERT_TRUE(w) << w.error();
  std::string png = slurp(file("a.png"));
  ASSERT_GT(png.size(), 20u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  EXPECT_NE(png.find("IEND"), std::string::npos);
}

// Defect 8: device nodes are written through, never replaced; /dev/full
// reports its error.
TEST_F(ImageIo, DevicesAreWrittenThroughNotReplaced) {
  Image img = noise(8, 8);
  Result<void> w = writePng("/dev/null", img, 0);
  ASSERT_TRUE(w) << w.error();
  w = writeTextFile("/dev/null", "x");
  ASSERT_TRUE(w) << w.error();
  struct stat st;
  ASSERT_EQ(stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode)) << "/dev/null was replaced";
  w = writePng("/dev/full", img, 0);
  EXPECT_FALSE(w);
  const std::string& err = w.error();
  EXPECT_NE(err.find("/dev/full"), std::string::npos) << err;
  EXPECT_NE(err.find("No space left on device"), std::string::npos) << err;
  ASSERT_EQ(stat("/dev/full", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
}

// Defect 8: a symlink stays a link; the file it names gets the new contents.
TEST_F(ImageIo, SymlinksAreFollowedAndKept) {
  std::ofstream(file("real.json")) << "old";
  fs::create_symlink(file("real.json"), file("link.json"));
  Result<void> w = writeTextFile(file("link.json"), "new");
  ASSERT_TRUE(w) << w.error();
  EXPECT_TRUE(fs::is_symlink(file("link.json")));
  EXPECT_EQ(slurp(file("real.json")), "new");
  // A dangling link creates the file it names.
  fs::create_symlink(file("absent.json"), file("dangling.json"));
  w = writeTextFile(file("dangling.json"), "made");
  ASSERT_TRUE(w) << w.error();
  EXPECT_TRUE(fs::is_symlink(file("dangling.json")));
  EXPECT_EQ(slurp(file("absent.json")), "made");
}

TEST_F(ImageIo, DirectoriesAndMissingFoldersAreRefusedWithAReason) {
  fs::create_directories(file("sub"));
  Result<void> w = writeTextFile(file("sub"), "x");
  EXPECT_FALSE(w);
  EXPECT_NE(w.error().find("is a directory"), std::string::npos) << w.error();
  EXPECT_TRUE(fs::is_directory(file("sub")));
  w = writePng(file("no/such/dir/x.png"), noise(4, 4), 0);
  EXPECT_FALSE(w);
  EXPECT_NE(w.error().find("No such file or directory"), std::string::npos) << w.error();
  // The message names the path.
  EXPECT_EQ(writeTextFile(file("sub"), "x").error(), file("sub") + ": is a directory");
}

// Defect 5: a data window patched to 32768x32768 in a small file is refused
// before anything is allocated.
TEST_F(ImageIo, PatchedExrDataWindowIsRefusedBeforeAllocation) {
  // Large enough that OpenEXR can read a line offset table for 32768 lines.
  Image img = noise(64, 64);
  Result<void> w = writeExr(file("a.exr"), {{"", img}, {"b", img}, {"c", img}});
  ASSERT_TRUE(w) << w.error();
  std::string bytes = slurp(file("a.exr"));
  const std::string key("dataWindow\0box2i\0", 17);
  size_t at = bytes.find(key);
  ASSERT_NE(at, std::string::npos);
  int32_t box[4] = {0, 0, 32767, 32767};
  std::memcpy(&bytes[at + key.size() + 4], box, sizeof box);
  std::ofstream(file("patched.exr"), std::ios::binary) << bytes;
  Result<std::vector<Layer>> r = readExr(file("patched.exr"));
  EXPECT_FALSE(r);
  EXPECT_NE(r.error().find("patched.exr"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("data window 32768x32768"), std::string::npos) << r.error();
  // Negative and overflowing windows.
  int32_t bad[4] = {INT32_MIN, 0, INT32_MAX, 15};
  std::memcpy(&bytes[at + key.size() + 4], bad, sizeof bad);
  std::ofstream(file("overflow.exr"), std::ios::binary) << bytes;
  r = readExr(file("overflow.exr"));
  EXPECT_FALSE(r);
  EXPECT_NE(r.error().find("data window"), std::string::npos) << r.error();
}

// Reading: only regular files (a FIFO would block).
TEST_F(ImageIo, ReadingRefusesSpecialFiles) {
  Result<std::vector<Layer>> r = readExr("/dev/zero");
  EXPECT_FALSE(r);
  EXPECT_NE(r.error().find("/dev/zero: not a regular file"), std::string::npos) << r.error();
  ASSERT_EQ(mkfifo(file("fifo.exr").c_str(), 0600), 0);
  r = readExr(file("fifo.exr"));
  EXPECT_FALSE(r);
  EXPECT_NE(r.error().find("not a regular file"), std::string::npos) << r.error();
  r = readExr(dir.string());
  EXPECT_FALSE(r);
  EXPECT_NE(r.error().find("is a directory"), std::string::npos) << r.error();
}
