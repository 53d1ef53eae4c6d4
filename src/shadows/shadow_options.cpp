// The error form of the option checks (shadow_options.hpp), and the check of the settings every
// shadow-map technique shares (ShadowOptions).
#include "shadows/shadow_options.hpp"

#include <cmath>
#include <locale>
#include <sstream>

#include "penumbra/error.hpp"

namespace penumbra::detail {
namespace {

// 6 significant digits: 3e-05, 0.002, 40.
std::string show(double v) {
  std::ostringstream o;
  o.imbue(std::locale::classic());  // "0.002", not "0,002", whatever the global locale
  o << v;
  return o.str();
}

}  // namespace

void badOption(const std::string& field, const std::string& rule, double value) {
  badInput(field + " must " + rule + ", got " + show(value));
}

void checkRange(const std::string& field, long long value, long long lo, long long hi) {
  if (value < lo || value > hi)
    badInput(field + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
             "], got " + std::to_string(value));
}

void validate(const ShadowOptions& o) {
  if (!(o.lightSizeScale >= 0) || !std::isfinite(o.lightSizeScale))
    badOption("RenderOptions.shadow.lightSizeScale", "be finite and >= 0", o.lightSizeScale);
  if (!(o.minFilterTexels > 0))
    badOption("RenderOptions.shadow.minFilterTexels", "be > 0", o.minFilterTexels);
  if (!(o.maxFilterTexels >= o.minFilterTexels))
    badOption("RenderOptions.shadow.maxFilterTexels",
              "be >= RenderOptions.shadow.minFilterTexels (" + show(o.minFilterTexels) + ")",
              o.maxFilterTexels);
  if (!(o.contactTexels > 0) || !std::isfinite(o.contactTexels))
    badOption("RenderOptions.shadow.contactTexels", "be finite and > 0", o.contactTexels);
}

}  // namespace penumbra::detail
