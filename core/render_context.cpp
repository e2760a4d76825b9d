#include "core/render_context.h"

#include "core/stopwatch.h"

namespace vsl {

Result<std::unique_ptr<RenderContext>> RenderContext::load(const std::string& path, const LoadOptions& options,
                                                           const EnvironmentSettings& env) {
  Stopwatch loadClock;
  SceneResult scene = loadScene(path, options);
  if (!scene) return Error(scene.error());
  return create(std::move(scene).value(), loadClock.seconds(), env);
}

Result<std::unique_ptr<RenderContext>> RenderContext::create(std::shared_ptr<const Scene> scene, double loadSeconds,
                                                             const EnvironmentSettings& env) {
  VSL_CHECK(scene != nullptr);
  std::shared_ptr<const Environment> environment;
  if (env.any()) {
    Result<std::shared_ptr<const Environment>> made = Environment::create(env);
    if (!made) return Error(made.error());
    environment = std::move(made).value();
  }
  std::unique_ptr<RenderContext> ctx(new RenderContext());
  ctx->scene_ = std::move(scene);
  ctx->loadSeconds_ = loadSeconds;
  Stopwatch bvhClock;
  Result<std::unique_ptr<Accel>> built = Accel::build(*ctx->scene_);
  if (!built) return Error(built.error());
  ctx->accel_ = std::move(built).value();
  ctx->bvhSeconds_ = bvhClock.seconds();
  ctx->lights_ = std::make_unique<LightSampler>(*ctx->scene_, std::move(environment));
  prepareMaterialTables();  // not charged to the first timed render
  return ctx;
}

}  // namespace vsl
