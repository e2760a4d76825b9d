// `vsl params`: the registered parameters of the many-light methods
// (core/params.h), as a table for the terminal, or as the Markdown table
// docs/REFERENCE.md holds (--markdown; a test keeps the two equal).
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "app/cli.h"
#include "app/sweep.h"
#include "core/estimator_registry.h"
#include "core/many_light.h"
#include "core/params.h"
#include "core/session.h"
#include "core/settings.h"

namespace vsl {

namespace {

struct ParamsArgs {
  bool markdown = false;
  std::string tier;  // "", "method" or "experimental"
};

// The default of each run parameter in each command that has it: "8
// (studio), 5 (sweep)".
std::vector<std::string> runDefaults() {
  const StudioSettings studio;
  const SweepArgs sweep;
  const auto both = [](const ParamSpec& p, double studioValue, double sweepValue) {
    return formatParamValue(p, studioValue) + " (studio), " + formatParamValue(p, sweepValue) + " (sweep)";
  };
  std::vector<std::string> out;
  for (const ParamSpec& p : runParams()) {
    const std::string_view name = p.name;
    if (name == "light-sets")
      out.push_back(both(p, studio.lightSets, sweep.sets));
    else if (name == "progressive-radius")
      out.push_back(both(p, 0, sweep.alpha));
    else
      out.push_back(formatParamValue(p, 0));
  }
  return out;
}

void printMarkdown() {
  std::fputs(paramTableMarkdown(manyLightParams(), ManyLightSettings()).c_str(), stdout);
  std::fputs("\nThe estimators' parameters (`--estimator NAME`; docs/ARCHITECTURE.md, \"Adding an estimator\"):\n\n",
             stdout);
  std::fputs(paramTableMarkdown(estimatorParams(), EstimatorSettings()).c_str(), stdout);
  std::fputs("\nThe path tracer's parameters (`vsl render --method pt`; `vsl reference` starts at 1024 spp):\n\n",
             stdout);
  std::fputs(paramTableMarkdown(pathTracerParams(), RenderSettings()).c_str(), stdout);
  std::fputs("\nHow long and how often the methods run (each command shows its own default):\n\n", stdout);
  std::fputs(paramTableMarkdown(runParams(), runDefaults()).c_str(), stdout);
}

void printLine(const ParamSpec& p, const std::string& value) {
  const std::string unit = *p.unit ? std::string(" ") + p.unit : "";
  std::printf("--%-20s default %-8s %-12s [%s]\n    %s; %s%s\n", p.name, value.c_str(),
              p.tier == ParamTier::Method ? "method" : "experimental", p.appliesTo, p.help, paramRangeText(p).c_str(),
              unit.c_str());
}

int cmdParams(const ParamsArgs& a) {
  if (a.markdown) {
    printMarkdown();
    return 0;
  }
  const bool method = a.tier != "experimental", experimental = a.tier != "method";
  const ManyLightSettings defaults;
  for (const Param<ManyLightSettings>& p : manyLightParams().all())
    if (p.spec.tier == ParamTier::Method ? method : experimental)
      printLine(p.spec, formatParamValue(p.spec, p.get(defaults)));
  if (!method) return 0;
  const RenderSettings pt;
  for (const Param<RenderSettings>& p : pathTracerParams().all())
    printLine(p.spec, formatParamValue(p.spec, p.get(pt)));
  const std::vector<std::string> run = runDefaults();
  for (size_t i = 0; i < runParams().size(); ++i) printLine(runParams()[i], run[i]);
  return 0;
}

}  // namespace

Subcommand addParamsCommand(CLI::App& app) {
  auto args = std::make_shared<ParamsArgs>();
  CLI::App* params =
      app.add_subcommand("params",
                         "Every registered parameter: the many-light methods', the path tracer's and the runs'; name, "
                         "default, tier, methods, meaning and range");
  params->add_flag("--markdown", args->markdown, "The table docs/REFERENCE.md holds, with the reason for each default");
  params->add_option("--tier", args->tier, "Only this tier")->check(CLI::IsMember({"method", "experimental"}));
  return {params, [args] { return cmdParams(*args); }};
}

}  // namespace vsl
