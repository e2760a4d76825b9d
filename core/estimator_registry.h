// The registry of many-light estimators (docs/ARCHITECTURE.md, "Adding an
// estimator"). Each estimator is a plug-in in its own folder,
// core/estimators/NAME/, that returns an EstimatorInfo: its name, its help,
// its parameters (ParamSpecs, core/params.h, named "NAME-..."), what it
// refuses of the many-light settings, and how to make it. The front ends
// (vsl render, vsl sweep, vsl-studio) list, describe and make estimators
// through this table only; nothing else switches on which estimator it is.
// Models: Nori's NORI_REGISTER_CLASS, Mitsuba 3's add_plugin.
//
// How a plug-in gets here: core/CMakeLists.txt's one line
// vsl_estimator(FOLDER) compiles the folder's .cpp files into vsl_core and
// writes FOLDER into the generated estimator_list.inc, from which
// estimator_registry.cpp declares and calls vsl::plugins::FOLDER(). The
// call is explicit on purpose: a static registering object in a static
// library is dropped by the linker when nothing references its object file.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/estimator.h"
#include "core/memory_budget.h"
#include "core/params.h"

namespace vsl {

// A parameter of an estimator: its declaration and its default. Its name is
// prefixed by the estimator's ("mrcs-rows").
struct EstimatorParam {
  ParamSpec spec;
  double defaultValue = 0;
};

struct EstimatorInfo {
  std::string name;   // "mrcs": --estimator, JSON, describe()
  std::string label;  // the studio's combo: "MRCS (row-column sampling)"
  std::string help;   // one line
  std::vector<EstimatorParam> params;
  // A light set is one step, its direct light included (MRCS): a progressive
  // run's sets share the direct samples (lightSetSettings), a step is long
  // (its progress is shown and its report logged per set), and a lobe gather
  // is traced within the step rather than when the estimator is made.
  bool wholeSetPerStep = false;
  // Its choices for one method read the other's settings (stochastic
  // lightcuts: the draws that VSL and VPL share come from a tree holding
  // the VSL radii, shaped by which methods are computed), so a change to
  // one method's parameters changes the other's pictures too: the studio
  // restarts both (Session, "one-method restarts"; docs/ARCHITECTURE.md on
  // appliesTo).
  bool methodsShareChoices = false;
  // Renders the VPL variants (unclamped, diffuse-only) and the lost-energy
  // layers; if not, only direct, VSL and clamped VPL (the others stay black).
  bool vplVariants = true;
  // Counts it does not keep (ManyLightStats::shadowRays and vslEvaluations
  // stay 0), said in render's JSON; "" if it keeps them.
  std::string countsNotKept;
  // Optional shorthand option for several parameters at once ("mrcs":
  // --mrcs ROWS,CLUSTERS[,MIX]) and its parser, which sets the name and the
  // values or says what the text must be.
  std::string shorthand, shorthandHelp;
  std::function<Result<void>(const std::string& text, EstimatorSettings& out)> parseShorthand;
  // Optional: the parameters as options when not each " --name value"
  // (describeParams; MRCS prints its shorthand).
  std::function<std::string(const EstimatorSettings&)> describe;
  // Optional checks beyond the parameters' ranges, and of the many-light
  // settings (EstimatorSettings::validate and validateWith).
  std::function<Result<void>(const EstimatorSettings&)> validate;
  std::function<Result<void>(const ManyLightSettings&, const EstimatorSettings&)> validateWith;
  // Optional: what it holds beyond brute force's buffers at `pixels` pixels
  // (the studio's memory check, Session::checkMemory).
  std::function<ExtraMemory(const EstimatorSettings&, uint64_t pixels)> memory;
  // Makes the estimator (see makeEstimator, estimator.h).
  std::function<std::unique_ptr<ManyLightEstimator>(const RenderContext&, ManyLightRun, const ManyLightSettings&,
                                                    const EstimatorSettings&, StepProgress*, const std::atomic<bool>*)>
      create;
};

// Every registered estimator, in core/CMakeLists.txt's order (the first is
// the default, brute force).
const std::vector<EstimatorInfo>& estimators();
// The estimator of that name; nullptr if none.
const EstimatorInfo* findEstimator(std::string_view name);
// The estimator, or "unknown estimator 'x' (did you mean 'mrcs'?; one of
// brute-force, mrcs)".
Result<const EstimatorInfo*> lookupEstimator(std::string_view name);
// The estimator whose parameter (or shorthand) this is; nullptr if none.
const EstimatorInfo* estimatorOwning(std::string_view paramName);
// Every registered estimator's parameters, for addParamOptions, the studio's
// widgets, the last session and the docs table.
const ParamTable<EstimatorSettings>& estimatorParams();
// The chosen estimator's extra memory (none when it has no hook).
ExtraMemory estimatorMemory(const EstimatorSettings& est, uint64_t pixels);

}  // namespace vsl
