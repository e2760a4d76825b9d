// `vsl params`: the registered parameters of the many-light methods
// (core/params.h), as a table for the terminal, or as the Markdown table
// docs/REFERENCE.md holds (--markdown; a test keeps the two equal).
#include <cstdio>
#include <string>

#include "app/cli.h"
#include "core/estimator_registry.h"
#include "core/many_light.h"
#include "core/params.h"

namespace vsl {

namespace {

struct ParamsArgs {
  bool markdown = false;
  std::string tier;  // "", "method" or "experimental"
};

int cmdParams(const ParamsArgs& a) {
  const ManyLightSettings defaults;
  if (a.markdown) {
    std::fputs(paramTableMarkdown(manyLightParams(), defaults).c_str(), stdout);
    std::fputs("\nThe estimators' parameters (`--estimator NAME`; docs/ARCHITECTURE.md, \"Adding an estimator\"):\n\n",
               stdout);
    std::fputs(paramTableMarkdown(estimatorParams(), EstimatorSettings()).c_str(), stdout);
    return 0;
  }
  for (const Param<ManyLightSettings>& p : manyLightParams().all()) {
    const bool method = p.spec.tier == ParamTier::Method;
    if ((a.tier == "method" && !method) || (a.tier == "experimental" && method)) continue;
    const std::string unit = *p.spec.unit ? std::string(" ") + p.spec.unit : "";
    std::printf("--%-18s default %-8s %-12s [%s]\n    %s; %s%s\n", p.spec.name,
                formatParamValue(p.spec, p.get(defaults)).c_str(), method ? "method" : "experimental", p.spec.appliesTo,
                p.spec.help, paramRangeText(p.spec).c_str(), unit.c_str());
  }
  return 0;
}

}  // namespace

Subcommand addParamsCommand(CLI::App& app) {
  auto args = std::make_shared<ParamsArgs>();
  CLI::App* params = app.add_subcommand(
      "params", "The many-light methods' parameters: name, default, tier, methods, meaning and range");
  params->add_flag("--markdown", args->markdown, "The table docs/REFERENCE.md holds, with the reason for each default");
  params->add_option("--tier", args->tier, "Only this tier")->check(CLI::IsMember({"method", "experimental"}));
  return {params, [args] { return cmdParams(*args); }};
}

}  // namespace vsl
