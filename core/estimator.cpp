// Sections: [1] methods  [2] estimator settings  [3] light sets
//           [4] step progress  [5] the factory
#include "core/estimator.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/check.h"
#include "core/estimator_registry.h"

namespace vsl {

// ---- [1] Methods ------------------------------------------------------------------------

namespace {
constexpr std::pair<Method, const char*> kMethodNames[] = {
    {Method::Pt, "pt"}, {Method::Vsl, "vsl"}, {Method::Vpl, "vpl"}, {Method::All, "all"}};
}  // namespace

std::optional<Method> parseMethod(std::string_view name) {
  for (auto [m, n] : kMethodNames)
    if (name == n) return m;
  return std::nullopt;
}

const char* methodName(Method m) {
  for (auto [e, n] : kMethodNames)
    if (e == m) return n;
  return "?";
}

// ---- [2] Estimator settings ---------------------------------------------------------------

double EstimatorSettings::value(std::string_view param) const {
  const Param<EstimatorSettings>* p = estimatorParams().find(param);
  VSL_CHECK(p != nullptr);
  return p->get(*this);
}

Result<void> EstimatorSettings::validate() const {
  Result<const EstimatorInfo*> info = lookupEstimator(name);
  if (!info) return Error(info.error());
  if ((*info)->validate)
    if (Result<void> own = (*info)->validate(*this); !own) return own;
  for (const EstimatorParam& p : (*info)->params)
    if (Result<void> r = checkParamValue(p.spec, value(p.spec.name)); !r) return r;
  if (progressiveRadius && !(alpha > 0 && alpha < 1)) {
    std::ostringstream e;
    e << "progressive radius alpha: must be in (0,1) (got " << alpha << ")";
    return Error(e.str());
  }
  return {};
}

Result<void> EstimatorSettings::validateWith(const ManyLightSettings& many) const {
  const EstimatorInfo* info = findEstimator(name);
  if (info && info->validateWith) return info->validateWith(many, *this);
  return {};
}

std::string EstimatorSettings::describeParams() const {
  const EstimatorInfo* info = findEstimator(name);
  if (!info) return {};
  if (info->describe) return info->describe(*this);
  // Every other estimator's parameters are skipped.
  std::vector<std::string> skip;
  for (const Param<EstimatorSettings>& p : estimatorParams().all())
    if (estimatorOwning(p.spec.name) != info) skip.push_back(p.spec.name);
  return estimatorParams().describe(*this, skip);
}

std::string EstimatorSettings::describe() const {
  std::ostringstream s;
  s << name << describeParams();
  if (progressiveRadius) s << " --progressive-radius " << alpha;
  return s.str();
}

bool EstimatorSettings::sameEstimate(const EstimatorSettings& other) const {
  if (name != other.name || progressiveRadius != other.progressiveRadius) return false;
  if (progressiveRadius && alpha != other.alpha) return false;
  if (const EstimatorInfo* info = findEstimator(name))
    for (const EstimatorParam& p : info->params)
      if (value(p.spec.name) != other.value(p.spec.name)) return false;
  return true;
}

// ---- [3] Light sets ------------------------------------------------------------------------

LightSetSettings lightSetSettings(const ManyLightSettings& base, const EstimatorSettings& est, int k, int sets) {
  LightSetSettings out{base, est};
  const EstimatorInfo* info = findEstimator(est.name);
  if (info && info->wholeSetPerStep && sets > 1)
    out.many.directSamples = std::max(1, (base.directSamples + sets - 1) / sets);
  out.many.seed = base.seed + uint64_t(k);
  if (est.progressiveRadius) {
    const float f = progressiveRadiusFactor(k, est.alpha);
    out.many.radiusScale *= f;
    out.many.globalRadius *= f;
  }
  out.estimator.seed = out.many.seed;
  return out;
}

ManyLightRun prepareManyLights(const RenderContext& ctx, const ManyLightSettings& settings,
                               const std::atomic<bool>* stop) {
  return prepareManyLights(ctx.scene(), ctx.accel(), ctx.lights(), settings, stop);
}

// ---- [4] Step progress -----------------------------------------------------------------------

std::string StepProgress::text() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return source_ ? source_->progressText() : std::string();
}

double StepProgress::share() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return source_ ? source_->progressShare() : 0.0;
}

void StepProgress::attach(const StepProgressSource* source) {
  std::lock_guard<std::mutex> lock(mutex_);
  source_ = source;
}

void StepProgress::detach(const StepProgressSource* source) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (source_ == source) source_ = nullptr;
}

// ---- [5] The factory -------------------------------------------------------------------------

std::unique_ptr<ManyLightEstimator> makeEstimator(const RenderContext& ctx, ManyLightRun run,
                                                  const ManyLightSettings& many, const EstimatorSettings& est,
                                                  StepProgress* progress, const std::atomic<bool>* stop) {
  VSL_CHECK(many.validate().ok());
  VSL_CHECK(est.validate().ok());
  return findEstimator(est.name)->create(ctx, std::move(run), many, est, progress, stop);
}

}  // namespace vsl
