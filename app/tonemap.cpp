// `vsl tonemap IN.exr -o OUT.png`: one EXR layer as a tone-mapped sRGB PNG
// (linear x 2^exposure, clamped, sRGB).
#include <cstdio>

#include "app/cli.h"
#include "core/image_io.h"

namespace vsl {

namespace {

struct TonemapArgs {
  std::string in, layer, out;
  float exposure = 0;
};

int cmdTonemap(const TonemapArgs& a) {
  Result<std::vector<Layer>> layers = readExr(a.in);
  if (!layers) return fail(kExitBadInput, layers.error());
  const Image* img = findLayer(*layers, a.layer, !a.layer.empty());
  if (!img) return failf(kExitBadInput, "%s: no layer '%s'", a.in.c_str(), a.layer.c_str());
  if (Result<void> written = writePng(a.out, *img, a.exposure); !written) return fail(kExitBadInput, written.error());
  std::fprintf(stderr, "wrote %s\n", a.out.c_str());
  return 0;
}

}  // namespace

Subcommand addTonemapCommand(CLI::App& app) {
  auto args = std::make_shared<TonemapArgs>();
  CLI::App* tonemap = app.add_subcommand("tonemap", "Write one EXR layer as a tone-mapped sRGB PNG");
  tonemap->add_option("input", args->in, "EXR file")->required();
  tonemap->add_option("--layer", args->layer, "Layer name (default: the default layer)");
  tonemap->add_option("-o,--output", args->out, "Output PNG")->required();
  tonemap->add_option("--exposure", args->exposure, "Exposure in stops")->default_str("0");
  return {tonemap, [args] { return cmdTonemap(*args); }};
}

}  // namespace vsl
