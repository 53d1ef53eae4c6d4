// HDR-FLIP (Andersson et al. 2020, 2021): perceived difference between a test and a reference
// image. Placeholder API, replaced by the flip branch.
#pragma once
#include <limits>

#include "penumbra/image.hpp"

namespace penumbra {

struct FlipOptions {
  double pixelsPerDegree = 67.0;
  bool hdr = true;
  double startExposure = std::numeric_limits<double>::quiet_NaN(),
         stopExposure = std::numeric_limits<double>::quiet_NaN();
};

struct FlipResult {
  double mean = 0;
  double startExposure = 0, stopExposure = 0;
  int exposures = 0;
  Image map;  // 1 channel
};

// mask: channel 0 > 0.5 counts in mean.
FlipResult flip(const Image& test, const Image& reference, const FlipOptions& opt = {},
                const Image* mask = nullptr);

}  // namespace penumbra
