// Brute force: every (pixel, light) pair of the light set, gathered in
// progressive light batches of growing size (ManyLightRenderer,
// core/many_light.h; Hasan et al. 2009's VSL gather and clamped VPL, Keller
// 1997). One step is one batch, and after each step the images are an
// unbiased estimate of the all-lights image (VPL's clamping aside).
//
// Parameters: none of its own (the batches, the pair roulette and the rest
// are the many-light settings', core/params.cpp). Bias: none beyond the
// methods' own (VSL radii, the VPL clamp).
#include "core/estimator_registry.h"

namespace vsl {

namespace {

class BruteForceEstimator final : public ManyLightEstimator {
 public:
  BruteForceEstimator(const RenderContext& ctx, ManyLightRun run, const ManyLightSettings& many,
                      const std::atomic<bool>* stop)
      : ManyLightEstimator(std::move(run)),
        renderer_(ctx.scene(), ctx.accel(), ctx.lights(), run_.set, run_.radii, many, stop, &ctx.lobeGatherMaps()) {}
  const std::string& name() const override {
    static const std::string kName = "brute-force";
    return kName;
  }
  bool step(const std::atomic<bool>* stop) override {
    if (done()) return false;
    if (!renderer_.renderBatch(done_, stop)) return false;
    ++done_;
    return true;
  }
  ManyLightImages images() const override { return renderer_.images(); }
  int stepsDone() const override { return done_; }
  int stepCount() const override { return renderer_.batchCount(); }
  std::optional<double> nextStepSeconds() const override { return renderer_.nextBatchSeconds(); }
  std::optional<double> remainingSeconds() const override { return renderer_.remainingSeconds(); }
  size_t lightsProcessed() const override { return renderer_.lightsProcessed(); }
  const ManyLightStats& stats() const override { return renderer_.stats(); }
  int width() const override { return renderer_.width(); }
  int height() const override { return renderer_.height(); }
  float clampBound() const override { return renderer_.clampBound(); }

 private:
  ManyLightRenderer renderer_;  // refers into run_, constructed after it
  int done_ = 0;
};

}  // namespace

namespace plugins {
EstimatorInfo brute_force();
}

// The registration function core/estimator_registry.cpp calls (its name is
// this folder's, from core/CMakeLists.txt's vsl_estimator(brute_force)).
EstimatorInfo plugins::brute_force() {
  EstimatorInfo e;
  e.name = "brute-force";
  e.label = "brute force (batches)";
  e.help = "Every (pixel, light) pair, in progressive light batches of growing size (unbiased after each batch)";
  e.create = [](const RenderContext& ctx, ManyLightRun run, const ManyLightSettings& many, const EstimatorSettings&,
                StepProgress*, const std::atomic<bool>* stop) -> std::unique_ptr<ManyLightEstimator> {
    return std::make_unique<BruteForceEstimator>(ctx, std::move(run), many, stop);
  };
  return e;
}

}  // namespace vsl
