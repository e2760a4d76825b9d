#include "core/settings.h"

#include <charconv>
#include <cmath>
#include <sstream>

#include "core/estimator.h"

namespace vsl {

const char* componentName(Component c) {
  switch (c) {
    case Component::Full:
      return "full";
    case Component::Direct:
      return "direct";
    case Component::Indirect:
      return "indirect";
  }
  return "?";
}

bool parseComponent(const std::string& s, Component* out) {
  if (s == "full")
    *out = Component::Full;
  else if (s == "direct")
    *out = Component::Direct;
  else if (s == "indirect")
    *out = Component::Indirect;
  else
    return false;
  return true;
}

bool readInt(std::string_view text, size_t& pos, int& out) {
  if (pos > text.size()) return false;
  int v = 0;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data() + pos, end, v);
  if (ec != std::errc()) return false;
  out = v;
  pos = size_t(ptr - text.data());
  return true;
}

Result<void> RenderSettings::validate() const {
  std::ostringstream e;
  if (!parseMethod(method))
    e << "method: must be pt, vsl, vpl or all (got '" << method << "')";
  else if (width < 0 || width > kMaxResolution)
    e << "width: must be in [1," << kMaxResolution << "] (got " << width << ")";
  else if (height < 0 || height > kMaxResolution)
    e << "height: must be in [1," << kMaxResolution << "] (got " << height << ")";
  else if (spp < 1 || spp > (1 << 24))
    e << "spp: must be in [1,16777216] (got " << spp << ")";
  else if (!(std::isfinite(timeLimit) && timeLimit >= 0 && timeLimit <= 1e7))
    e << "time: must be in [0,1e7] seconds (got " << timeLimit << ")";
  else if (maxDepth < 1 || maxDepth > 1024)
    e << "max-depth: must be in [1,1024] (got " << maxDepth << ")";
  else if (rrDepth < 1 || rrDepth > 1024)
    e << "rr-depth: must be in [1,1024] (got " << rrDepth << ")";
  if (std::string m = e.str(); !m.empty()) return Error(m);
  return {};
}

std::string RenderSettings::describe() const {
  std::ostringstream s;
  s << "--method " << method;
  // A size of 0 means "from the camera's aspect"; the CLI refuses --width 0
  // or --height 0, so it is left out (the string stays a command line).
  if (width > 0) s << " --width " << width;
  if (height > 0) s << " --height " << height;
  if (timeLimit > 0)
    s << " --time " << timeLimit;
  else
    s << " --spp " << spp;
  s << " --seed " << seed << " --max-depth " << maxDepth << " --component " << componentName(component);
  return s.str();
}

}  // namespace vsl
