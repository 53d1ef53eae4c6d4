/// \file
/// Error heat maps: a test image's per-pixel error against a reference, through a perceptual colour
/// map, drawn over the reference's geometry (background grey) with a labelled colour scale bar
/// under the image, for looking at where a technique goes wrong rather than reading one number.
#pragma once
#include <string>

#include "penumbra/flip.hpp"
#include "penumbra/image.hpp"

namespace penumbra {

enum class HeatmapMetric {
  /// |lum(test) - lum(reference)| / mean lum(reference), the mean over the geometry pixels (as
  /// compareImages normalises its relative RMSE): magma, 0 (black) .. scale (pale yellow).
  RelativeError,
  /// (lum(test) - lum(reference)) / mean lum(reference): a diverging map, blue where the test is
  /// darker, white where equal, red where brighter; the bar spans -scale .. +scale.
  SignedRelativeError,
  /// The per-pixel FLIP map (flip.hpp, with HeatmapOptions::flip): magma over 0 .. 1.
  Flip,
};

struct HeatmapOptions {
  HeatmapMetric metric = HeatmapMetric::RelativeError;
  /// Relative metrics: the colour scale's top (0.05 = 5% of the reference's mean); 0 = automatic:
  /// the 99th percentile of |error| over the geometry pixels, rounded up to 1, 2 or 5 x 10^k (at
  /// least 1e-4). Ignored by Flip (always 0 .. 1). Must be finite and >= 0.
  double scale = 0;
  /// A colour scale bar under the image (ticks at both ends and the middle; labelled with the
  /// values when the image is at least 120 pixels wide and the DejaVuSans font is installed).
  bool scaleBar = true;
  FlipOptions flip;  ///< Flip only
};

/// The heat map as a display image: RGB, values in [0,1] already display-encoded (write them as
/// they are, no tone mapping), `reference.width` wide and `reference.height` high plus the bar
/// (HeatmapResult::imageHeight rows of image, then the bar). Geometry pixels are those where the
/// reference's alpha (channel 3) is > 0.5, or every pixel when it has no alpha; the others are the
/// neutral grey kHeatmapBackground.
struct Heatmap {
  Image image;
  int imageHeight = 0;  ///< rows of `image` that show the error; the rows below hold the scale bar
  double scale = 0;     ///< the scale used: the bar's top (relative metrics) or 1 (Flip)
};

/// Display value (each of R, G, B) of a pixel outside the reference's geometry.
inline constexpr float kHeatmapBackground = 0.25f;

/// Throws Error(BadInput) when the sizes differ (naming both, "test is WxH, reference is WxH"),
/// when an image is empty or has fewer than 3 channels, holds non-finite values, when
/// opt.scale is negative or non-finite, or (relative metrics) when the reference's mean luminance
/// over its geometry is zero or it has no geometry pixel.
Heatmap errorHeatmap(const Image& test, const Image& reference, const HeatmapOptions& opt = {});

/// errorHeatmap written to `path` (any 8-bit format OpenImageIO writes, by extension: .png, .jpg,
/// ...; a float format such as .exr gets the same display values as floats), atomically as
/// writeImage does. Returns the scale used. Throws as errorHeatmap does, and Error(BadInput) for an
/// extension without a writer or an unwritable path.
double writeHeatmap(const std::string& path, const Image& test, const Image& reference,
                    const HeatmapOptions& opt = {});

/// Writes a display image (RGB values in [0,1], as Heatmap::image) without tone mapping: 8 bits
/// per channel, or floats for a float format. Throws Error(BadInput) as writeImage does.
void writeDisplayImage(const std::string& path, const Image& display);

}  // namespace penumbra
