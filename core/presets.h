// Presets of the many-light methods' parameters (docs/REFERENCE.md,
// "Presets").
//
//   paper    VSL and clamped VPL as Hašan, Křivánek, Walter and Bala
//            published them (SIGGRAPH Asia 2009): the authors' sample count
//            (1 + floor(100 theta / (pi/2)) per strategy), radii from the
//            k-th nearest light (k = 10, scale 1: the paper gives neither; the
//            values of Mitsuba's many-light fork are k = 10 and twice the
//            distance, and ours were measured, docs/REFERENCE.md), the cone
//            integral by MIS quadrature, gathering at the first hit; none of
//            this project's heuristics (no lobe floor, no continuation through
//            metals, no lobe radius, splitting, lobe gather or pair roulette)
//            and not the shader's optional clipped disk.
//   default  the measured best: ManyLightSettings' own defaults, three of
//            this project's heuristics on (lobe-aware sample count, lobe floor
//            1, continuation through metals below GGX alpha 0.02).
//
// A preset sets the method fields only (see kMethodFields in presets.cpp);
// lights, size, batches, clamping, seeds and the estimator are the user's.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/many_light.h"

namespace vsl {

enum class Preset { Default, Paper };

// "default", "paper".
const char* presetName(Preset p);
std::optional<Preset> parsePreset(const std::string& name);
std::vector<std::string> presetNames();

// Sets m's method fields to the preset's; keeps every other field.
void applyPreset(Preset p, ManyLightSettings& m);

// The preset whose method fields m has ("default" or "paper"), else
// "custom": what a table or an export calls m's VSL.
std::string matchingPreset(const ManyLightSettings& m);

}  // namespace vsl
