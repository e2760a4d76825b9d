#include "ui/param_widgets.h"

#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace vsl::ui {

namespace {

double uiMin(const ParamSpec& p) { return p.uiMin != 0 || p.uiMax != 0 ? p.uiMin : p.min; }
double uiMax(const ParamSpec& p) { return p.uiMin != 0 || p.uiMax != 0 ? p.uiMax : p.max; }

// Words whose values the slider cannot show: chosen in a combo instead.
std::vector<const ParamWord*> modeWords(const ParamSpec& p) {
  std::vector<const ParamWord*> out;
  for (const ParamWord& w : p.words)
    if (!(w.value >= uiMin(p) && w.value <= uiMax(p))) out.push_back(&w);
  return out;
}

// "[notebook](notebook/x.md)" as "docs/notebook/x.md": a tooltip has no links.
std::string plainLinks(std::string text) {
  for (size_t open = text.find('['); open != std::string::npos; open = text.find('[', open)) {
    const size_t mid = text.find("](", open), close = mid == std::string::npos ? mid : text.find(')', mid);
    if (close == std::string::npos) break;
    text.replace(open, close + 1 - open, "docs/" + text.substr(mid + 2, close - mid - 2));
  }
  return text;
}

std::string label(const ParamSpec& p) {
  std::string l = p.name;
  std::replace(l.begin(), l.end(), '-', ' ');
  return l;
}

// The slider of a number; its format shows a word inside the range.
bool numberSlider(const ParamSpec& p, const char* id, double* value) {
  const char* word = nullptr;
  for (const ParamWord& w : p.words)
    if (w.value == *value) word = w.word;
  const ImGuiSliderFlags flags = p.uiLog ? ImGuiSliderFlags_Logarithmic : ImGuiSliderFlags_None;
  if (p.kind == ParamKind::Int) {
    int v = int(std::clamp(*value, -2e9, 2e9));
    if (!ImGui::SliderInt(id, &v, int(uiMin(p)), int(uiMax(p)), word ? word : "%d", flags)) return false;
    *value = double(v);
    return true;
  }
  float v = float(*value);
  if (!ImGui::SliderFloat(id, &v, float(uiMin(p)), float(uiMax(p)), word ? word : "%.3g", flags)) return false;
  *value = double(v);
  return true;
}

// The tooltip of the last item, wrapped as the studio's others are.
void hoverTip(const std::string& tip) {
  if (!ImGui::IsItemHovered()) return;
  ImGui::BeginTooltip();
  ImGui::PushTextWrapPos(ImGui::GetFontSize() * 36.0f);
  ImGui::TextUnformatted(tip.c_str());
  ImGui::PopTextWrapPos();
  ImGui::EndTooltip();
}

// A combo of the mode words and "value"; the slider below when a value is chosen.
bool modeAndSlider(const ParamSpec& p, const std::vector<const ParamWord*>& modes, double* value, ParamMemory& memory,
                   const std::string& tip) {
  const std::string name = label(p);
  const ParamWord* current = nullptr;
  for (const ParamWord* w : modes)
    if (w->value == *value) current = w;
  if (!current) memory[p.name] = *value;
  bool changed = false;
  if (ImGui::BeginCombo(name.c_str(), current ? current->word : "value")) {
    for (const ParamWord* w : modes)
      if (ImGui::Selectable(w->word, current == w) && current != w) {
        *value = w->value;
        changed = true;
      }
    if (ImGui::Selectable("value", !current) && current) {
      auto kept = memory.find(p.name);
      const double start = std::isnan(p.uiStart) ? 0.5 * (uiMin(p) + uiMax(p)) : p.uiStart;
      *value = kept != memory.end() ? kept->second : start;
      changed = true;
    }
    ImGui::EndCombo();
  }
  hoverTip(tip);
  if (current || changed) return changed;
  const bool moved = numberSlider(p, ("##" + name).c_str(), value);
  hoverTip(tip);
  return moved;
}

}  // namespace

std::string paramTooltip(const ParamSpec& p, double defaultValue) {
  std::string t = std::string(p.help) + ".\n";
  // A heuristic's second line says where to read more (issue 49: "a 'more'
  // line for the heuristics"): the measurement behind its default, which
  // names its notebook entry, else the parameters' table.
  const bool heuristic = p.tier == ParamTier::Experimental;
  if (heuristic) t += "More: " + (*p.why ? plainLinks(p.why) : std::string("docs/REFERENCE.md#parameters")) + ".\n";
  if (p.kind != ParamKind::Flag) t += "Range: " + paramRangeText(p) + (*p.unit ? std::string(" ") + p.unit : "") + ". ";
  t += "Default: " + formatParamValue(p, defaultValue) + " (" + p.appliesTo + ", " +
       (p.tier == ParamTier::Method ? "method parameter" : "experimental heuristic") + ").\n";
  if (*p.why && !heuristic) t += "Why: " + plainLinks(p.why) + ".\n";
  return t + "Option: --" + p.name;
}

bool paramWidget(const ParamSpec& p, double* value, double defaultValue, ParamMemory& memory) {
  const std::string name = label(p), tip = paramTooltip(p, defaultValue);
  bool changed = false;
  if (p.kind == ParamKind::Flag) {
    bool on = *value != 0;
    changed = ImGui::Checkbox(name.c_str(), &on);
    if (changed) *value = on ? 1 : 0;
  } else if (p.kind == ParamKind::Choice) {
    const std::string shown = formatParamValue(p, *value);
    if (ImGui::BeginCombo(name.c_str(), shown.c_str())) {
      for (const ParamWord& w : p.words)
        if (ImGui::Selectable(w.word, w.value == *value) && w.value != *value) {
          *value = w.value;
          changed = true;
        }
      ImGui::EndCombo();
    }
  } else if (std::vector<const ParamWord*> modes = modeWords(p); !modes.empty()) {
    return modeAndSlider(p, modes, value, memory, tip);
  } else {
    changed = numberSlider(p, name.c_str(), value);
  }
  hoverTip(tip);
  return changed;
}

}  // namespace vsl::ui
