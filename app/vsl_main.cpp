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
#include "core/estimator.h"
#include "core/log.h"
#include "core/presets.h"

namespace vsl {

// ---- Options shared by render and sweep ---------------------------------------

namespace {
std::vector<std::string> vslCountNames() {
  std::vector<std::string> names;
  for (VslCount c : kVslCounts) names.push_back(vslCountName(c));
  return names;
}

// --vsl-samples: "auto" (0) or a count in [1, 4096]; false for anything else.
bool parseVslSamples(const std::string& v, int& out) {
  if (v == "auto") {
    out = 0;
    return true;
  }
  char* end = nullptr;
  const long n = std::strtol(v.c_str(), &end, 10);
  if (end == v.c_str() || *end != 0 || n < 1 || n > 4096) return false;
  out = int(n);
  return true;
}

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

void addVslOptions(CLI::App* cmd, ManyLightSettings& m) {
  addPresetOption(cmd, m);
  cmd->add_option_function<std::string>(
         "--vsl-samples", [&m](const std::string& v) { parseVslSamples(v, m.vslSamples); },
         "VSL cone-integral samples per strategy: auto (see --vsl-count) or N in [1, 4096]")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            int n = 0;
            return parseVslSamples(v, n) ? std::string() : "must be 'auto' or in [1,4096] (got '" + v + "')";
          },
          "auto|N"))
      ->default_str("auto");
  cmd->add_flag("--clipped-disk", m.clippedDisk,
                "VSL: spread the flux over the part of the disk on the receiver's side of its tangent plane");
  // The automatic count: the lobe-aware one by default (the same error as the
  // authors' count on the four bundled scenes in 20-30% less time where lobes
  // are broad; docs/REFERENCE.md "Project heuristics"), the authors' count unchanged,
  // or shares (faster still, not the default: docs/notebook/2026-12-02-light-sets-and-vsl-counts.md).
  cmd->add_option_function<std::string>(
         "--vsl-count",
         [&m](const std::string& v) {
           if (std::optional<VslCount> c = parseVslCount(v)) m.vslCount = *c;
         },
         "VSL's automatic sample count: lobe (the authors' count, scaled down where both BRDF lobes are broad "
         "compared with the cone), authors (1 + floor(100 theta / (pi/2)) per strategy), or shares (the lobe "
         "count, with fewer samples for a strategy that fits the cone badly: a BRDF lobe broader than the cone, the "
         "cone where a lobe is narrower); all unbiased")
      ->check(CLI::IsMember(vslCountNames()))
      ->default_str(vslCountName(ManyLightSettings().vslCount));
  cmd->add_option("--continue-alpha", m.continueAlpha,
                  "Eye paths continue through pure metals with GGX alpha below this instead of gathering there")
      ->default_str(defaultText(ManyLightSettings().continueAlpha))
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--split-alpha", m.splitAlpha,
                  "Gather points whose specular lobe is narrower than this (GGX alpha, on both axes) gather "
                  "their diffuse lobe and continue the eye path with the specular lobe; 0 = off")
      ->default_str(defaultText(ManyLightSettings().splitAlpha))
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--lobe-gather", m.lobeGather,
                  "VSL: at receivers narrower than GGX alpha 0.05 along either axis (near-mirrors, brushed metals), "
                  "the specular lobe is gathered by sampling it, the radiance where each direction lands estimated "
                  "from the " +
                      std::to_string(ManyLightSettings::kLobeGatherK) +
                      " nearest lights of a second light set of this many lights (brute force or MRCS); 0 = off")
      ->default_str("0")
      ->check(CLI::Range(0u, 50000000u));
  cmd->add_option("--lobe-gather-rays", m.lobeGatherRays,
                  "VSL lobe gather: directions per gather point (brute force: the first of several batches takes an "
                  "eighth, at least one, and the others share the rest)")
      ->default_str(defaultText(ManyLightSettings::kDefaultLobeGatherRays))
      ->check(CLI::Range(1, ManyLightSettings::kMaxLobeGatherRays));
  cmd->add_option("--lobe-gather-alpha", m.lobeGatherAlpha,
                  "VSL lobe gather: receivers whose specular lobe is narrower than this GGX alpha along either axis "
                  "are lobe-gathered (0.15 also takes glossy metals such as hall's walls)")
      ->default_str(defaultText(ManyLightSettings::kLobeGatherAlpha))
      ->check(CLI::Range(ManyLightSettings::kMinLobeGatherAlpha, 1.0f));
  cmd->add_option("--pair-roulette", m.pairRoulette,
                  "Pair roulette (VSL and VPL): a pair whose contribution, estimated before its shadow ray, is "
                  "below K x the mean pair's (earlier batches) is gathered with probability estimate / (K x mean) "
                  "and weighted by its inverse (unbiased; fewer rays and samples); 0 = off")
      ->default_str("0")
      ->check(CLI::Range(0.0, 100.0));
  cmd->add_option("--lobe-radius", m.lobeRadius,
                  "VSL: radius at least F x distance x the light's GGX alpha (cone as wide as its lobe); 0 = off")
      ->default_str("0")
      ->check(CLI::Range(0.0, 100.0));
  cmd->add_option("--lobe-floor", m.lobeFloor,
                  "VSL: each metal light's GGX alpha at least F x the cone's half-angle (radians), so a narrow "
                  "light seen through a wider cone lights the receiver as a sphere, not a beam (not for dielectric "
                  "lights, not at receivers whose lobe is narrower than alpha 0.05); where it applies, the light's "
                  "sphere is 1.5x wider too; 0 = off")
      ->default_str(defaultText(ManyLightSettings::kDefaultLobeFloor))
      ->check(CLI::Range(0.0, 100.0));
}

bool parseMrcsSpec(const std::string& spec, MrcsSettings& out) {
  if (parseMrcsText(spec, out) && out.validate()) return true;
  failf(kExitBadArguments, "--mrcs must be ROWS,CLUSTERS with positive integers, optionally ,MIX in [0,1] (got '%s')",
        spec.c_str());
  return false;
}

}  // namespace vsl

int main(int argc, char** argv) {
  using namespace vsl;
  CLI::App app{"vsl: many-light rendering of glossy scenes (render, reference, compare, tonemap, info, sweep, bench)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(VSL_VERSION));
  // The table of subcommands, in the order --help lists them.
  const Subcommand subcommands[] = {addRenderCommand(app),  addReferenceCommand(app), addCompareCommand(app),
                                    addTonemapCommand(app), addInfoCommand(app),      addSweepCommand(app),
                                    addBenchCommand(app)};
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "error: %s\n\n", e.what());
    CLI::App* sub = nullptr;
    for (CLI::App* s : app.get_subcommands()) sub = s;
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
