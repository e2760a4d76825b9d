// What the `vsl` subcommands share (cli.h): errors, progress, scene loading
// and small image helpers.
#include "app/cli.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <filesystem>

namespace vsl {

int fail(int exitCode, const std::string& message) {
  std::fprintf(stderr, "error: %s\n", message.c_str());
  return exitCode;
}

int failf(int exitCode, const char* format, ...) {
  va_list args;
  va_start(args, format);
  std::fprintf(stderr, "error: ");
  std::vfprintf(stderr, format, args);
  std::fprintf(stderr, "\n");
  va_end(args);
  return exitCode;
}

Progress::Progress(const char* label) : label_(label), tty_(isatty(STDERR_FILENO)) {}

void Progress::update(double fraction, const std::string& detail) {
  fraction = std::min(std::max(fraction, 0.0), 1.0);
  if (tty_) {
    if (drawn_ && fraction < 1 && sinceDraw_.seconds() < 0.1) return;
    drawn_ = true;
    sinceDraw_.reset();
    int filled = int(fraction * 30);
    std::fprintf(stderr, "\r%s [%s%s] %3d%% %s   ", label_, std::string(filled, '#').c_str(),
                 std::string(30 - filled, ' ').c_str(), int(fraction * 100), detail.c_str());
  } else {
    int decile = int(fraction * 10);
    if (decile <= lastDecile_) return;
    lastDecile_ = decile;
    std::fprintf(stderr, "%s %3d%% %s\n", label_, decile * 10, detail.c_str());
  }
  std::fflush(stderr);
}

void Progress::finish() {
  if (tty_) std::fprintf(stderr, "\n");
}

std::shared_ptr<const Scene> loadOrReport(const std::string& path, const std::string& camera) {
  LoadOptions opts;
  opts.cameraName = camera;
  SceneResult r = loadScene(path, opts);
  if (!r) {
    fail(kExitBadInput, r.error());
    return nullptr;
  }
  for (const std::string& w : (*r)->warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  return *r;
}

const Image* findLayer(const std::vector<Layer>& layers, const std::string& name, bool explicitName) {
  for (const Layer& l : layers)
    if (l.name == name) return &l.image;
  if (!explicitName)  // no default layer: fall back to "full"
    for (const Layer& l : layers)
      if (l.name == "full") return &l.image;
  return nullptr;
}

Vec3 imageMean(const Image& img) {
  double s[3] = {0, 0, 0};
  for (size_t i = 0; i < img.rgb.size(); ++i) s[i % 3] += img.rgb[i];
  double n = std::max<size_t>(1, img.rgb.size() / 3);
  return {float(s[0] / n), float(s[1] / n), float(s[2] / n)};
}

Image addImages(const Image& a, const Image& b) {
  Image sum(a.width, a.height);
  for (size_t i = 0; i < sum.rgb.size(); ++i) sum.rgb[i] = a.rgb[i] + b.rgb[i];
  return sum;
}

float percentile(std::vector<float> values, double q) {
  if (values.empty()) return 0;
  // The k-th smallest value is what sorting would put at k.
  const size_t k = size_t(q * double(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(k), values.end());
  return values[k];
}

namespace {

bool hasExtension(const std::string& path, const char* ext) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e == ext;
}

bool sameFile(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code ea, eb;
  if (fs::exists(a, ea) && fs::exists(b, eb)) return fs::equivalent(a, b, ea) && !ea;
  return fs::weakly_canonical(a, ea) == fs::weakly_canonical(b, eb);
}

struct NamedPath {
  std::string option, path;
};

// The parsed subcommand's output and input paths (see clashingOutput), and,
// if scenes is given, the positional inputs that are glTF scenes.
void namedPaths(const CLI::App& subcommand, std::vector<NamedPath>* inputs, std::vector<NamedPath>* outputs,
                std::vector<std::string>* scenes = nullptr) {
  for (const CLI::Option* o : subcommand.get_options()) {
    if (o->count() == 0) continue;
    const std::string name = o->get_name();
    const bool output =
        name == "--output" || name == "--png" || name == "--json" || name == "--flip-exr" || name == "--flip-png";
    const bool input = o->get_positional() || name == "--reference" || name == "--reference-b" || name == "--merge";
    for (const std::string& path : o->results()) {
      if (output) outputs->push_back({name, path});  // an empty one too: clashingOutput refuses it
      if (path.empty()) continue;
      if (name == "--flip-png") outputs->push_back({"--flip-png's HDR map", flipHdrPngPath(path)});
      if (input) inputs->push_back({name, path});
      if (scenes && o->get_positional() && (hasExtension(path, ".gltf") || hasExtension(path, ".glb")))
        scenes->push_back(path);
    }
  }
}

}  // namespace

std::string flipHdrPngPath(const std::string& flipPng) {
  const bool png = flipPng.size() > 4 && flipPng.compare(flipPng.size() - 4, 4, ".png") == 0;
  return (png ? flipPng.substr(0, flipPng.size() - 4) : flipPng) + "-hdr.png";
}

std::string clashingOutput(const CLI::App& subcommand) {
  std::vector<NamedPath> inputs, outputs;
  std::vector<std::string> scenes;
  namedPaths(subcommand, &inputs, &outputs, &scenes);
  // A scene's buffers and images are inputs too (read only where there is
  // an output to check).
  if (!outputs.empty())
    for (const std::string& scene : scenes)
      for (const std::string& f : sceneReferencedFiles(scene)) inputs.push_back({"scene " + scene, f});
  for (size_t i = 0; i < outputs.size(); ++i) {
    if (outputs[i].path.empty()) return outputs[i].option + " is an empty path";
    for (const NamedPath& in : inputs) {
      if (!sameFile(outputs[i].path, in.path)) continue;
      if (in.option.rfind("scene ", 0) == 0)  // a buffer or image the scene reads
        return outputs[i].option + " " + outputs[i].path + " is " + in.path + ", which the " + in.option +
               " reads (it would be overwritten)";
      return outputs[i].option + " " + outputs[i].path + " is also the input " + in.path + " (it would be overwritten)";
    }
    for (size_t j = 0; j < i; ++j)
      if (sameFile(outputs[i].path, outputs[j].path))
        return outputs[i].option + " " + outputs[i].path + " is also " + outputs[j].option + " " + outputs[j].path;
  }
  return {};
}

std::string unwritableOutput(const CLI::App& subcommand) {
  namespace fs = std::filesystem;
  std::vector<NamedPath> inputs, outputs;
  namedPaths(subcommand, &inputs, &outputs);
  const bool outputIsFolder = subcommand.get_name() == "sweep";  // created with its parents
  for (const NamedPath& out : outputs) {
    if (outputIsFolder && out.option == "--output") continue;
    std::error_code ec;
    if (fs::is_directory(out.path, ec)) return out.option + " " + out.path + " is a folder, not a file";
    // A file (or a new one) is written beside the file its links lead to and
    // renamed into place: that folder must exist and take it. Devices, FIFOs
    // and sockets are written through.
    Result<std::string> target = atomicWriteTarget(out.path);
    if (!target) return out.option + " " + target.error();
    if (target->empty()) continue;
    const fs::path to(*target), toParent = to.parent_path().empty() ? "." : to.parent_path();
    if (!fs::is_directory(toParent, ec))
      return out.option + " " + out.path + ": the folder " + toParent.string() + " does not exist";
    if (::access(toParent.c_str(), W_OK) != 0)
      return out.option + " " + out.path + ": the folder " + toParent.string() + " is not writable (" +
             std::strerror(errno) + ")";
  }
  return {};
}

}  // namespace vsl
