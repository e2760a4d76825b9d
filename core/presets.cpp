#include "core/presets.h"

#include "core/params.h"

namespace vsl {

namespace {

// The method fields a preset sets: the registry's parameters marked
// ParamSpec::preset.
void copyMethodFields(const ManyLightSettings& from, ManyLightSettings& to) {
  for (const Param<ManyLightSettings>& p : manyLightParams().all())
    if (p.spec.preset) p.set(to, p.get(from));
}

// The preset's method fields, on otherwise default settings.
ManyLightSettings presetSettings(Preset p) {
  ManyLightSettings m;
  if (p == Preset::Paper) {
    m.vslCount = VslCount::Authors;
    m.lobeFloor = 0;
    m.continueAlpha = 0;
    m.vslIntegral = VslIntegral::Quadrature;
  }
  return m;
}

}  // namespace

const char* presetName(Preset p) { return p == Preset::Paper ? "paper" : "default"; }

std::optional<Preset> parsePreset(const std::string& name) {
  for (Preset p : {Preset::Default, Preset::Paper})
    if (name == presetName(p)) return p;
  return std::nullopt;
}

std::vector<std::string> presetNames() { return {presetName(Preset::Default), presetName(Preset::Paper)}; }

void applyPreset(Preset p, ManyLightSettings& m) { copyMethodFields(presetSettings(p), m); }

std::string matchingPreset(const ManyLightSettings& m) {
  for (Preset p : {Preset::Default, Preset::Paper}) {
    ManyLightSettings withPreset = m;
    applyPreset(p, withPreset);
    if (withPreset.describe() == m.describe()) return presetName(p);
  }
  return "custom";
}

}  // namespace vsl
