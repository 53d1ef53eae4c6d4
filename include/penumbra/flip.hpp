/// \file
/// FLIP image difference: LDR-FLIP (Andersson, Nilsson, Akenine-Möller, Oskarsson, Åström and
/// Fairchild 2020, "FLIP: A Difference Evaluator for Alternating Images") and HDR-FLIP (Andersson,
/// Nilsson, Shirley and Akenine-Möller 2021, "Visualizing Errors in Rendered High Dynamic Range
/// Images"): a per-pixel map in [0,1] of how different two images look when flipped between, and
/// its mean, for comparing renders against a ground truth.
#pragma once
#include <limits>

#include "penumbra/image.hpp"

namespace penumbra {

struct FlipOptions {
  /// The papers' default viewing setup: 0.7 m from a 0.7 m wide 3840-px screen.
  double pixelsPerDegree = 67.0;
  /// HDR-FLIP over an exposure range; false: LDR-FLIP on values clamped to [0,1].
  bool hdr = true;
  /// HDR only: exposure range; NaN = computed from the reference as the 2021 paper does
  double startExposure = std::numeric_limits<double>::quiet_NaN(),
         stopExposure = std::numeric_limits<double>::quiet_NaN();
};

struct FlipResult {
  double mean = 0;  ///< mean FLIP over the compared pixels (or all pixels without a mask)
  double startExposure = 0, stopExposure = 0;
  int exposures = 0;  ///< HDR: what was used (LDR: all three stay 0)
  Image map;          ///< per-pixel FLIP error, 1 channel, same size as the inputs
};

/// FLIP of `test` against `reference` (linear RGB, >= 3 channels, same size; channels past the third
/// are ignored, negative values count as 0). mask: optional, pixels with mask value > 0.5 (channel
/// 0) count in `mean` (all pixels of the map are always computed); a mask with no such pixel gives
/// mean 0. HDR: the LDR-FLIP of each exposure (ACES-fit tone mapping, as the 2021 paper) and the
/// per-pixel maximum over them; without a given range the start exposure maps the reference's
/// maximum luminance and the stop exposure its median luminance to 0.85 after tone mapping (when
/// the median is 0, the smallest non-zero luminance stands in; an all-black reference uses 0..0).
/// Throws Error(BadInput) naming the argument for mismatched sizes, < 3 channels, non-finite values,
/// pixelsPerDegree <= 0 or non-finite, an empty image, an infinite exposure or start > stop.
FlipResult flip(const Image& test, const Image& reference, const FlipOptions& opt = {},
                const Image* mask = nullptr);

}  // namespace penumbra
