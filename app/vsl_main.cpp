// `vsl`: the command-line front end. Subcommands, one file each:
//   render     a scene to a multi-layer EXR with the path tracer, VSL or VPL
//              (app/render.cpp, app/render_many_lights.cpp)
//   reference  a converged path-traced reference, to a file and the cache
//              (app/reference.cpp)
//   compare    error metrics and FLIP of EXRs against a reference
//              (app/compare.cpp)
//   tonemap    one EXR layer as an sRGB PNG (app/tonemap.cpp)
//   info       what the loader made of a scene (app/info.cpp)
//   sweep      error against time over a grid of methods (app/sweep.cpp)
//   bench      throughput against raw Embree occlusion (app/bench.cpp)
//   params     the methods' parameters, from the registry (app/params.cpp)
// This file holds main, the table of subcommands and the options that render
// and sweep share; app/cli.h has what the subcommands share otherwise.
// Exit codes: 0 success, 1 bad input (scene, image, I/O), 2 bad arguments.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "app/cli.h"
#include "app/finite_options.h"
#include "app/param_options.h"
#include "core/estimator.h"
#include "core/log.h"
#include "core/presets.h"

namespace vsl {

// ---- Options shared by render and sweep ---------------------------------------

namespace {

// --preset (core/presets.h). Defined before the other methods' options:
// CLI11 runs options in the order they are defined, so those, given one by
// one, override the preset's values.
void addPresetOption(CLI::App* cmd, ManyLightSettings& m) {
  cmd->add_option_function<std::string>(
         "--preset",
         [&m](const std::string& v) {
           if (std::optional<Preset> p = parsePreset(v)) applyPreset(*p, m);
         },
         "The methods' parameters: paper (VSL and clamped VPL as Hasan et al. 2009 published them, none of this "
         "project's heuristics) or default (the measured best); options given one by one override it "
         "(docs/REFERENCE.md, \"Presets\")")
      ->check(CLI::IsMember(presetNames()))
      ->default_str("default");
}

}  // namespace

void addVslOptions(CLI::App* cmd, ManyLightSettings& m, const std::vector<std::string>& skip) {
  addPresetOption(cmd, m);
  addParamOptions(cmd, manyLightParams(), m, nullptr, skip);
}

}  // namespace vsl

int main(int argc, char** argv) {
  using namespace vsl;
  CLI::App app{
      "vsl: many-light rendering of glossy scenes (render, reference, compare, tonemap, info, sweep, bench, params)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(VSL_VERSION));
  // The table of subcommands, in the order --help lists them.
  const Subcommand subcommands[] = {addRenderCommand(app),  addReferenceCommand(app), addCompareCommand(app),
                                    addTonemapCommand(app), addInfoCommand(app),      addSweepCommand(app),
                                    addBenchCommand(app),   addParamsCommand(app)};
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    CLI::App* sub = nullptr;
    for (CLI::App* s : app.get_subcommands()) sub = s;
    std::fprintf(stderr, "error: %s%s\n\n", e.what(), nearestOptionHint(sub ? *sub : app, e.what()).c_str());
    std::cerr << (sub ? sub->help() : app.help());
    return kExitBadArguments;
  }
  if (std::string bad = nonFiniteOption(app); !bad.empty()) {
    std::fprintf(stderr, "error: %s\n", bad.c_str());
    return kExitBadArguments;
  }
  for (const CLI::App* sub : app.get_subcommands()) {
    if (std::string clash = clashingOutput(*sub); !clash.empty()) {
      std::fprintf(stderr, "error: %s\n", clash.c_str());
      return kExitBadArguments;
    }
    if (std::string unwritable = unwritableOutput(*sub); !unwritable.empty()) {
      std::fprintf(stderr, "error: %s\n", unwritable.c_str());
      return kExitBadInput;
    }
  }
  log::setEchoLevel(LogLevel::Warning);
  // Every subcommand runs inside one handler: running out of memory (or any
  // other exception a library throws) is reported and exits 1, never aborts.
  try {
    for (const Subcommand& s : subcommands)
      if (*s.parser) return s.run();
  } catch (const std::bad_alloc&) {
    return fail(kExitBadInput, "out of memory (the scene, image or settings need more than this machine has)");
  } catch (const std::exception& e) {
    return fail(kExitBadInput, e.what());
  }
  return kExitBadArguments;
}
