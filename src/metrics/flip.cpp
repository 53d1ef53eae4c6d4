// placeholder, replaced by the flip branch: the map is |luminance difference| / (1 + reference
// luminance), clamped to [0, 1], so that callers of flip() can be written and tested now.
#include "penumbra/flip.hpp"

#include <algorithm>
#include <cmath>

#include "penumbra/error.hpp"

namespace penumbra {

FlipResult flip(const Image& test, const Image& reference, const FlipOptions&, const Image* mask) {
  if (test.width != reference.width || test.height != reference.height || test.channels < 3 ||
      reference.channels < 3)
    badInput("flip: images must be RGB(A) of one size");
  FlipResult r;
  r.map = Image(test.width, test.height, 1, 0.0f);
  double sum = 0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < r.map.pixels.size(); ++i) {
    const float* t = &test.pixels[i * test.channels];
    const float* f = &reference.pixels[i * reference.channels];
    const double lt = 0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2];
    const double lf = 0.2126 * f[0] + 0.7152 * f[1] + 0.0722 * f[2];
    const float e = float(std::clamp(std::fabs(lt - lf) / (1.0 + std::fabs(lf)), 0.0, 1.0));
    r.map.pixels[i] = e;
    if (mask && !(mask->pixels[i * mask->channels] > 0.5f)) continue;
    sum += e;
    ++count;
  }
  r.mean = count ? sum / double(count) : 0.0;
  r.exposures = 1;
  return r;
}

}  // namespace penumbra
