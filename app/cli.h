// What the `vsl` subcommands share: the subcommand table's entry type, one
// way to report an error and pick the exit code, the progress bar, scene
// loading, the options that render and sweep both take, and small image
// helpers. Each subcommand lives in its own file (app/<name>.cpp) and
// registers its options with its add*Command function; vsl_main.cpp holds
// the table of them.
// Exit codes: 0 success, 1 bad input (scene, image, I/O), 2 bad arguments.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/film.h"
#include "core/image_io.h"
#include "core/many_light.h"
#include "core/scene.h"
#include "core/stopwatch.h"

namespace vsl {

constexpr int kExitBadInput = 1;      // a scene, image or file that cannot be used
constexpr int kExitBadArguments = 2;  // a command line that cannot be used

// ---- The subcommand table ---------------------------------------------------

// One subcommand: its parser (options bound to state it owns) and what runs
// it once the command line is parsed; run returns the exit code.
struct Subcommand {
  CLI::App* parser = nullptr;
  std::function<int()> run;
};

Subcommand addRenderCommand(CLI::App& app);     // app/render.cpp
Subcommand addReferenceCommand(CLI::App& app);  // app/reference.cpp
Subcommand addCompareCommand(CLI::App& app);    // app/compare.cpp
Subcommand addTonemapCommand(CLI::App& app);    // app/tonemap.cpp
Subcommand addInfoCommand(CLI::App& app);       // app/info.cpp
Subcommand addSweepCommand(CLI::App& app);      // app/sweep.cpp
Subcommand addBenchCommand(CLI::App& app);      // app/bench.cpp
Subcommand addParamsCommand(CLI::App& app);     // app/params.cpp

// ---- Errors -------------------------------------------------------------------

// Prints "error: MESSAGE" on stderr and returns exitCode, so that a failing
// step reads `return fail(kExitBadInput, r.error());`.
int fail(int exitCode, const std::string& message);
// The same with a printf-style message.
[[gnu::format(printf, 2, 3)]] int failf(int exitCode, const char* format, ...);

// ---- Inputs and outputs ---------------------------------------------------------

// A file the command would write that is one of its inputs or another of its
// outputs (the same file by device and inode where both exist, by normalised
// path otherwise), as "-o a.exr is also the input a.exr"; empty if none. A bad
// argument (exit 2). Outputs are the parsed subcommand's --output, --png,
// --json, --flip-exr and --flip-png (with its HDR map, flipHdrPngPath); inputs
// its positionals, --reference, --reference-b and --merge, and the buffers and
// images a positional .gltf or .glb reads (sceneReferencedFiles). An empty
// output path is refused here too.
std::string clashingOutput(const CLI::App& subcommand);
// Where `vsl compare --flip-png PATH` writes the HDR-FLIP map: PATH without
// ".png", then "-hdr.png".
std::string flipHdrPngPath(const std::string& flipPng);
// An output file whose folder does not exist or is not writable, or that is a
// folder, found before any work rather than after a long render; empty if none.
// An I/O failure (exit 1).
std::string unwritableOutput(const CLI::App& subcommand);

// ---- Shared options (defined in vsl_main.cpp) ---------------------------------

// --preset, then an option per parameter of the many-light methods
// (core/params.h) but those in skip; shared by render and sweep.
void addVslOptions(CLI::App* cmd, ManyLightSettings& m, const std::vector<std::string>& skip = {});

// ---- Progress, scenes, images ------------------------------------------------

// A progress bar on stderr: redrawn in place on a terminal (at most every
// 0.1 s), one line per 10% otherwise (logs stay readable).
class Progress {
 public:
  explicit Progress(const char* label);
  // fraction in [0, 1] (clamped); detail follows the percentage.
  void update(double fraction, const std::string& detail);
  // Ends the line on a terminal.
  void finish();

 private:
  const char* label_;
  bool tty_;
  bool drawn_ = false;
  Stopwatch sinceDraw_;
  int lastDecile_ = -1;
};

// Loads a scene with the named camera (empty: the first perspective camera)
// and prints its warnings; null after printing the error.
std::shared_ptr<const Scene> loadOrReport(const std::string& path, const std::string& camera);

// The layer called name; without an explicit name (explicitName false) and no
// such layer, the "full" layer. Null when there is neither.
const Image* findLayer(const std::vector<Layer>& layers, const std::string& name, bool explicitName);

// Per-channel mean of an image.
Vec3 imageMean(const Image& img);
// a + b, pixel by pixel (same size).
Image addImages(const Image& a, const Image& b);
// The value a fraction q in [0, 1] of the way through the values sorted
// ascending, rounding the rank down (no interpolation); 0 when there are none.
float percentile(std::vector<float> values, double q);

}  // namespace vsl
