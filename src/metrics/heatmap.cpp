// Error heat maps (include/penumbra/heatmap.hpp) and their shared pieces (metrics/heatmap.hpp):
// colour maps, a scale bar under each image, text, the automatic scale, and writing display images
// (already encoded, so not tone-mapped again). What draws or writes pixels is OpenImageIO's, in
// the module core/image_codec.hpp loads; what decides them is here.
#include "metrics/heatmap.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "core/image_codec.hpp"
#include "penumbra/error.hpp"
#include "penumbra/heatmap.hpp"
#include "common/shared.h"

namespace penumbra {
namespace detail {
namespace {

bool isGeometry(const Image* geometry, std::size_t i) {
  return !geometry || geometry->channels < 4 || geometry->pixels[i * geometry->channels + 3] > 0.5f;
}

}  // namespace

ColourMap magmaColourMap() { return imageCodec().magmaColourMap(); }

ColourMap divergingColourMap() {
  return {"", {0.02f, 0.19f, 0.75f, 1, 1, 1, 0.85f, 0.05f, 0.05f}};
}

Image colourMapped(const std::vector<float>& values, int width, int height, const ColourMap& map,
                   const Image* geometry) {
  Image out = imageCodec().colourMap(values, width, height, map);
  for (std::size_t i = 0; i < std::size_t(width) * height; ++i)
    if (!isGeometry(geometry, i))
      for (int c = 0; c < 3; ++c) out.pixels[i * 3 + c] = kHeatmapBackground;
  return out;
}

int scaleBarRows(int height) { return 2 + std::max(6, height / 16) + 16; }

Image withScaleBar(const Image& rgb, const ColourMap& map, const std::string& low,
                   const std::string& mid, const std::string& high) {
  return imageCodec().withScaleBar(rgb, map, low, mid, high);
}

double roundedScale(std::vector<float>& mags) {
  if (mags.empty()) return 0.01;
  const std::size_t at = std::min(mags.size() - 1, std::size_t(0.99 * double(mags.size())));
  std::nth_element(mags.begin(), mags.begin() + std::ptrdiff_t(at), mags.end());
  const double p = std::max(1e-4, double(mags[at]));
  const double decade = std::pow(10.0, std::floor(std::log10(p)));
  return p <= decade ? decade : p <= 2 * decade ? 2 * decade : p <= 5 * decade ? 5 * decade : 10 * decade;
}

std::string percentLabel(double v, bool sign) {
  // to_chars ignores the locale (snprintf's %g would write "2,5%" under a German one)
  char s[32];
  auto r = std::to_chars(s, s + sizeof s, 100.0 * v, std::chars_format::general, 6);
  std::string text(s, r.ptr);
  return (sign && v >= 0 ? "+" : "") + text + "%";
}

bool drawText(Image& image, int x, int y, const std::string& text, int size,
              const std::vector<float>& colour, TextAlign align, int shadow) {
  return imageCodec().drawText(image, x, y, text, size, colour, align, shadow);
}

int textWidth(const std::string& text, int size) { return imageCodec().textWidth(text, size); }

}  // namespace detail

namespace {

void checkInput(const Image& im, const char* name) {
  if (im.empty() || im.width < 1 || im.height < 1)
    badInput(std::string("errorHeatmap: ") + name + " is empty");
  if (im.channels < 3)
    badInput(std::string("errorHeatmap: ") + name + " has " + std::to_string(im.channels) +
             " channel(s), needs RGB");
  if (im.pixels.size() != std::size_t(im.width) * im.height * im.channels)
    badInput(std::string("errorHeatmap: ") + name + " has a pixel count that does not match its size");
}

double luminance(const Image& im, std::size_t i) {
  const float* p = &im.pixels[i * im.channels];
  return PB_LUM_R * p[0] + PB_LUM_G * p[1] + PB_LUM_B * p[2];
}

}  // namespace

Heatmap errorHeatmap(const Image& test, const Image& reference, const HeatmapOptions& opt) {
  checkInput(test, "test");
  checkInput(reference, "reference");
  if (test.width != reference.width || test.height != reference.height)
    badInput("errorHeatmap: test is " + std::to_string(test.width) + "x" +
             std::to_string(test.height) + ", reference is " + std::to_string(reference.width) +
             "x" + std::to_string(reference.height) + " (the sizes must match)");
  if (!std::isfinite(opt.scale) || opt.scale < 0)
    badInput("HeatmapOptions.scale must be finite and >= 0 (0: automatic), got " +
             std::to_string(opt.scale));
  const int W = reference.width, H = reference.height;
  const std::size_t n = std::size_t(W) * H;
  Heatmap result;
  result.imageHeight = H;
  Image rgb;
  detail::ColourMap map;
  std::string low, mid, high;
  if (opt.metric == HeatmapMetric::Flip) {
    const FlipResult f = flip(test, reference, opt.flip);
    map = detail::magmaColourMap();
    rgb = detail::colourMapped(f.map.pixels, W, H, map, &reference);
    result.scale = 1;
    low = "0", mid = "FLIP 0.5", high = "1";
  } else {
    const bool isSigned = opt.metric == HeatmapMetric::SignedRelativeError;
    double sum = 0;
    std::size_t count = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!detail::isGeometry(&reference, i)) continue;
      for (const Image* im : {&test, &reference})
        for (int c = 0; c < 3; ++c)
          if (!std::isfinite(im->pixels[i * im->channels + c]))
            badInput(std::string("errorHeatmap: ") + (im == &test ? "test" : "reference") +
                     " contains non-finite values");
      sum += luminance(reference, i);
      ++count;
    }
    if (count == 0) badInput("errorHeatmap: the reference has no geometry pixel (alpha > 0.5)");
    const double mean = sum / double(count);
    if (!(mean > 0))
      badInput("errorHeatmap: the reference's mean luminance over its geometry is not positive, so "
               "there is nothing to be relative to");
    std::vector<float> error(n, 0.0f), mags;
    mags.reserve(count);
    for (std::size_t i = 0; i < n; ++i) {
      if (!detail::isGeometry(&reference, i)) continue;
      error[i] = float((luminance(test, i) - luminance(reference, i)) / mean);
      mags.push_back(std::fabs(error[i]));
    }
    const double s = opt.scale > 0 ? opt.scale : detail::roundedScale(mags);
    result.scale = s;
    for (float& e : error) e = isSigned ? float(0.5 + 0.5 * e / s) : float(std::fabs(e) / s);
    map = isSigned ? detail::divergingColourMap() : detail::magmaColourMap();
    rgb = detail::colourMapped(error, W, H, map, &reference);
    if (isSigned) {
      low = detail::percentLabel(-s, true), mid = "0", high = detail::percentLabel(s, true);
    } else {
      low = "0", mid = "error " + detail::percentLabel(s / 2, false),
      high = detail::percentLabel(s, false);
    }
  }
  result.image = opt.scaleBar ? detail::withScaleBar(rgb, map, low, mid, high) : std::move(rgb);
  return result;
}

void writeDisplayImage(const std::string& path, const Image& display) {
  detail::imageCodec().writeDisplayImage(path, display);
}

double writeHeatmap(const std::string& path, const Image& test, const Image& reference,
                    const HeatmapOptions& opt) {
  if (!canWriteImage(path))
    badInput(path + ": unsupported output format (no OpenImageIO writer for its extension)");
  const Heatmap h = errorHeatmap(test, reference, opt);
  writeDisplayImage(path, h.image);
  return h.scale;
}

}  // namespace penumbra
