// The pieces of the heat maps (include/penumbra/heatmap.hpp) that the error budget's maps
// (src/reference/evaluate.cpp) share: colour maps with their bar knots, colouring a field over a
// geometry mask, the scale bar under an image, and the automatic scale.
#pragma once
#include <string>
#include <vector>

#include "penumbra/image.hpp"

namespace penumbra::detail {

// A colour map over [0,1]: an OpenImageIO map by name (empty: the knots themselves), and RGB knots,
// evenly spaced over [0,1], that draw its scale bar (the named map sampled at 16 points).
struct ColourMap {
  std::string name;
  std::vector<float> knots;  // RGB triplets
};
ColourMap magmaColourMap();      // perceptual, sequential: black, purple, orange, pale yellow
ColourMap divergingColourMap();  // blue (0), white (0.5), red (1)

// values (width*height, row 0 at the top) clamped to [0,1] through the map, RGB display values;
// where `geometry` is given and its alpha (channel 3, when it has one) is <= 0.5, the neutral grey
// kHeatmapBackground instead.
Image colourMapped(const std::vector<float>& values, int width, int height, const ColourMap& map,
                   const Image* geometry);

// `rgb` (RGB display values) over a scale bar: a strip from the map's low end to its high end,
// ticks at both ends and the middle, labels `low`, `mid`, `high` when the image is at least 120
// pixels wide and OpenImageIO finds the DejaVuSans font (fonts-dejavu-core). The rows below the
// image: see scaleBarRows.
Image withScaleBar(const Image& rgb, const ColourMap& map, const std::string& low,
                   const std::string& mid, const std::string& high);
// How many rows withScaleBar adds under an image `height` rows high.
int scaleBarRows(int height);

// The 99th percentile of `magnitudes` rounded up to 1, 2 or 5 x 10^k (at least 1e-4); 0.01 when
// empty. Reorders `magnitudes`.
double roundedScale(std::vector<float>& magnitudes);

// "+5%" (signed) or "5%" for 0.05.
std::string percentLabel(double v, bool sign);

enum class TextAlign { Left, Centre, Right };
// Draws `text` (DejaVuSans, `size` pixels high) on `image` (any channel count; `colour` holds one
// value per channel) with its baseline at y, starting, centred or ending at x; `shadow` > 0 adds
// a dark halo of that radius so the text reads on any background. False (nothing drawn) when no
// font is found.
bool drawText(Image& image, int x, int y, const std::string& text, int size,
              const std::vector<float>& colour, TextAlign align = TextAlign::Left, int shadow = 0);

// The width in pixels drawText gives `text` at `size` (0 when no font is found).
int textWidth(const std::string& text, int size);

}  // namespace penumbra::detail
