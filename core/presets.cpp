#include "core/presets.h"

namespace vsl {

namespace {

// The method fields a preset sets, copied from one settings to another.
void copyMethodFields(const ManyLightSettings& from, ManyLightSettings& to) {
  to.radiusScale = from.radiusScale;
  to.knn = from.knn;
  to.globalRadius = from.globalRadius;
  to.vslSamples = from.vslSamples;
  to.clippedDisk = from.clippedDisk;
  to.vslCount = from.vslCount;
  to.lobeRadius = from.lobeRadius;
  to.lobeFloor = from.lobeFloor;
  to.continueAlpha = from.continueAlpha;
  to.splitAlpha = from.splitAlpha;
  to.lobeGather = from.lobeGather;
  to.lobeGatherRays = from.lobeGatherRays;
  to.lobeGatherAlpha = from.lobeGatherAlpha;
  to.pairRoulette = from.pairRoulette;
}

// The preset's method fields, on otherwise default settings.
ManyLightSettings presetSettings(Preset p) {
  ManyLightSettings m;
  if (p == Preset::Paper) {
    m.vslCount = VslCount::Authors;
    m.lobeFloor = 0;
    m.continueAlpha = 0;
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
