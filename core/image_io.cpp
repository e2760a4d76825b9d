#include "core/image_io.h"

#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <fcntl.h>
#include <stb_image_write.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>

namespace vsl {

namespace {

// An in-memory OpenEXR output stream: the file is encoded here first so that
// writing it to disk is one checked, atomic operation.
class MemoryOStream : public Imf::OStream {
 public:
  MemoryOStream() : Imf::OStream("memory") {}
  void write(const char c[], int n) override {
    if (pos_ + size_t(n) > data_.size()) data_.resize(pos_ + size_t(n));
    std::memcpy(data_.data() + pos_, c, size_t(n));
    pos_ += size_t(n);
  }
  uint64_t tellp() override { return pos_; }
  void seekp(uint64_t pos) override {
    pos_ = size_t(pos);
    if (pos_ > data_.size()) data_.resize(pos_);
  }
  const std::vector<char>& data() const { return data_; }

 private:
  std::vector<char> data_;
  size_t pos_ = 0;
};

constexpr int64_t kMaxExrSide = 65536;

std::string errnoText(int e) { return std::strerror(e); }

// A temporary path beside the target, unique within and across processes.
std::string temporaryPath(const std::string& path) {
  static std::atomic<uint64_t> counter{0};
  return path + ".tmp-" + std::to_string(getpid()) + "-" + std::to_string(counter.fetch_add(1));
}

// Writes all bytes to fd, retrying short writes and EINTR. Returns 0 or errno.
int writeAll(int fd, const char* p, size_t n) {
  while (n > 0) {
    ssize_t k = ::write(fd, p, n);
    if (k < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    if (k == 0) return EIO;
    p += k;
    n -= size_t(k);
  }
  return 0;
}

// Device, FIFO or socket: write through, as `cat > /dev/null` would.
Result<void> writeThrough(const std::string& path, const char* data, size_t size) {
  int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) {
    return Error(path + ": cannot open for writing (" + errnoText(errno) + ")");
  }
  int e = writeAll(fd, data, size);
  if (::close(fd) != 0 && e == 0 && errno != EINTR) e = errno;
  if (e != 0) {
    return Error(path + ": cannot write (" + errnoText(e) + ")");
  }
  return {};
}

// Temporary file, checked writes, fsync, checked close, rename, directory fsync.
Result<void> writeAndRename(const std::string& path, const char* data, size_t size) {
  std::string tmp = temporaryPath(path);
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0666);
  if (fd < 0) {
    return Error(path + ": cannot create a temporary file beside it (" + errnoText(errno) + ")");
  }
  const char* step = "cannot write";
  int e = writeAll(fd, data, size);
  auto failed = [&](const char* what) {
    e = errno;
    step = what;
  };
  if (e == 0 && ::fsync(fd) != 0) failed("cannot flush to disk");
  if (::close(fd) != 0 && e == 0 && errno != EINTR) failed("cannot close");
  if (e == 0 && ::rename(tmp.c_str(), path.c_str()) != 0) failed("cannot rename the finished file into place");
  if (e != 0) {
    ::unlink(tmp.c_str());
    return Error(path + ": " + step + " (" + errnoText(e) + "); any existing file is unchanged");
  }
  // Make the rename itself durable; a failure here loses nothing already there.
  std::string dir = std::filesystem::path(path).parent_path().string();
  int dfd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  return {};
}

}  // namespace

Result<std::string> atomicWriteTarget(const std::string& path) {
  // Devices, FIFOs and sockets (also behind links such as /dev/stdout, whose
  // /proc/self/fd/1 may name a pipe) are written through; directories refused.
  struct stat st;
  if (::stat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) return Error(path + ": is a directory");
    if (!S_ISREG(st.st_mode)) return std::string();
  }
  // A regular file or none: follow symbolic links (also dangling ones) to the
  // file to replace, and keep the links.
  std::filesystem::path target = path;
  for (int hops = 0; ::lstat(target.c_str(), &st) == 0 && S_ISLNK(st.st_mode); ++hops) {
    std::error_code ec;
    std::filesystem::path next = std::filesystem::read_symlink(target, ec);
    if (ec || hops >= 40) {
      return Error(path + ": cannot resolve the symbolic link (" + (ec ? ec.message() : "too many levels") + ")");
    }
    target = next.is_absolute() ? next : target.parent_path() / next;
  }
  return target.string();
}

Result<void> writeFileAtomically(const std::string& path, const void* data, size_t size) {
  const char* bytes = static_cast<const char*>(data);
  Result<std::string> target = atomicWriteTarget(path);
  if (!target) return Error(target.error());
  if (target->empty()) return writeThrough(path, bytes, size);
  return writeAndRename(*target, bytes, size);
}

namespace {

std::string channelName(const std::string& layer, char c) {
  return layer.empty() ? std::string(1, c) : layer + "." + c;
}

}  // namespace

Result<void> writeExr(const std::string& path, const std::vector<Layer>& layers,
                      const std::map<std::string, std::string>& attributes, bool half) {
  if (layers.empty()) {
    return Error(path + ": no layers to write");
  }
  int w = layers[0].image.width, h = layers[0].image.height;
  for (const Layer& l : layers)
    if (l.image.width != w || l.image.height != h || l.image.rgb.size() != size_t(w) * h * 3) {
      return Error(path + ": layer '" + l.name + "' has a different size");
    }
  MemoryOStream stream;
  try {
    Imf::Header header(w, h);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const auto& [k, v] : attributes) header.insert(k, Imf::StringAttribute(v));
    Imf::FrameBuffer fb;
    // 16-bit channels take 16-bit slices (OpenEXR writes no conversion).
    std::vector<std::vector<Imath::half>> halves(half ? layers.size() : 0);
    for (size_t i = 0; i < layers.size(); ++i) {
      const Layer& l = layers[i];
      // Beyond half's largest finite value (65504) a value would become
      // infinite, which no reader takes: it is clamped there.
      if (half)
        for (float v : l.image.rgb) halves[i].push_back(Imath::half(std::clamp(v, -65504.0f, 65504.0f)));
      for (int c = 0; c < 3; ++c) {
        std::string name = channelName(l.name, "RGB"[c]);
        header.channels().insert(name, Imf::Channel(half ? Imf::HALF : Imf::FLOAT));
        if (half)
          fb.insert(name, Imf::Slice(Imf::HALF, (char*)(halves[i].data() + c), sizeof(Imath::half) * 3,
                                     sizeof(Imath::half) * 3 * size_t(w)));
        else
          fb.insert(name, Imf::Slice(Imf::FLOAT, (char*)(l.image.rgb.data() + c), sizeof(float) * 3,
                                     sizeof(float) * 3 * size_t(w)));
      }
    }
    Imf::OutputFile file(stream, header);
    file.setFrameBuffer(fb);
    file.writePixels(h);
  } catch (const std::bad_alloc&) {
    return Error(path + ": out of memory while encoding the EXR");
  } catch (const std::exception& e) {
    return Error(path + ": cannot encode EXR (" + e.what() + ")");
  }
  // OutputFile's destructor finishes the file (the line offset table).
  return writeFileAtomically(path, stream.data().data(), stream.data().size());
}

Result<std::vector<Layer>> readExr(const std::string& path, std::map<std::string, std::string>* attributes) {
  std::vector<Layer> layers;
  if (attributes) attributes->clear();
  // Only regular files: a FIFO would block and /dev/zero never ends.
  struct stat st;
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    return Error(path + (S_ISDIR(st.st_mode) ? ": is a directory" : ": not a regular file (a FIFO, device or socket)"));
  }
  try {
    Imf::InputFile file(path.c_str());
    const Imf::Header& header = file.header();
    Imath::Box2i dw = header.dataWindow();
    int64_t w64 = int64_t(dw.max.x) - dw.min.x + 1, h64 = int64_t(dw.max.y) - dw.min.y + 1;
    if (w64 <= 0 || h64 <= 0 || w64 > kMaxExrSide || h64 > kMaxExrSide) {
      return Error(path + ": data window " + std::to_string(w64) + "x" + std::to_string(h64) + " is outside [1," +
                   std::to_string(kMaxExrSide) + "] per side");
    }
    int w = int(w64), h = int(h64);
    if (attributes)
      for (auto it = header.begin(); it != header.end(); ++it)
        if (const auto* a = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
          (*attributes)[it.name()] = a->value();
    // Layers: the prefixes of channels ending in .R (or R alone).
    std::vector<std::string> names;
    for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
      std::string n = it.name();
      if (n == "R")
        names.push_back("");
      else if (n.size() > 2 && n.compare(n.size() - 2, 2, ".R") == 0)
        names.push_back(n.substr(0, n.size() - 2));
    }
    if (names.empty()) {
      return Error(path + ": no RGB layer (no channel named R or *.R)");
    }
    // Estimate memory before allocating: a patched header must not exhaust it.
    std::error_code ec;
    uint64_t fileBytes = std::filesystem::file_size(path, ec);
    if (ec) fileBytes = 0;
    uint64_t need = uint64_t(w) * uint64_t(h) * 12 * names.size();
    uint64_t plausible = std::max<uint64_t>(uint64_t(16) << 20, fileBytes * 4096);
    if (need > plausible) {
      return Error(path + ": data window " + std::to_string(w) + "x" + std::to_string(h) + " with " +
                   std::to_string(names.size()) + " layer(s) would need " + std::to_string(need >> 20) +
                   " MiB, implausible for a file of " + std::to_string(fileBytes) + " bytes (corrupt header?)");
    }
    Imf::FrameBuffer fb;
    layers.resize(names.size());
    for (size_t i = 0; i < names.size(); ++i) {
      layers[i].name = names[i];
      layers[i].image = Image(w, h);
      char* base = (char*)layers[i].image.rgb.data() - (size_t(dw.min.x) + size_t(dw.min.y) * w) * sizeof(float) * 3;
      for (int c = 0; c < 3; ++c)
        fb.insert(channelName(names[i], "RGB"[c]), Imf::Slice(Imf::FLOAT, base + c * sizeof(float), sizeof(float) * 3,
                                                              sizeof(float) * 3 * size_t(w), 1, 1, 0.0));
    }
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return layers;
  } catch (const std::bad_alloc&) {
    return Error(path + ": out of memory while reading the EXR");
  } catch (const std::exception& e) {
    return Error(path + ": cannot read EXR (" + e.what() + ")");
  }
}

uint8_t toSrgb8(float v) {
  if (!(v > 0)) return 0;  // also maps NaN to black
  if (v >= 1) return 255;
  float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1 / 2.4f) - 0.055f;
  return uint8_t(std::lround(s * 255.0f));
}

Result<void> writePng8(const std::string& path, int width, int height, int channels,
                       const std::vector<uint8_t>& pixels) {
  if (width <= 0 || height <= 0 || channels < 1 || channels > 4 ||
      pixels.size() != size_t(width) * size_t(height) * size_t(channels)) {
    return Error(path + ": cannot write PNG (no pixels, or pixel count does not match " + std::to_string(width) + "x" +
                 std::to_string(height) + ")");
  }
  // Encode in memory: stbi_write_png() ignores fwrite/fclose errors.
  std::vector<char> png;
  auto append = [](void* context, void* data, int size) {
    auto* out = static_cast<std::vector<char>*>(context);
    out->insert(out->end(), static_cast<char*>(data), static_cast<char*>(data) + size);
  };
  if (stbi_write_png_to_func(append, &png, width, height, channels, pixels.data(), width * channels) == 0 ||
      png.empty()) {
    return Error(path + ": cannot encode PNG (" + std::to_string(width) + "x" + std::to_string(height) + ")");
  }
  return writeFileAtomically(path, png.data(), png.size());
}

Result<void> writePngRgb8(const std::string& path, int width, int height, const std::vector<uint8_t>& rgb) {
  return writePng8(path, width, height, 3, rgb);
}

Result<void> writePng(const std::string& path, const Image& image, float exposure) {
  std::vector<uint8_t> px(image.rgb.size());
  float scale = std::exp2(exposure);
  for (size_t i = 0; i < px.size(); ++i) px[i] = toSrgb8(image.rgb[i] * scale);
  return writePngRgb8(path, image.width, image.height, px);
}

Result<void> writeTextFile(const std::string& path, const std::string& text) {
  return writeFileAtomically(path, text.data(), text.size());
}

}  // namespace vsl
