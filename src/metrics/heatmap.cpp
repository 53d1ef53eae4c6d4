// Error heat maps (include/penumbra/heatmap.hpp) and their shared pieces (metrics/heatmap.hpp):
// OpenImageIO's colour maps and text rendering, a scale bar under each image, the automatic scale,
// and writing display images (already encoded, so not tone-mapped again) atomically.
#include "metrics/heatmap.hpp"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "penumbra/error.hpp"
#include "penumbra/heatmap.hpp"
#include "common/shared.h"

namespace penumbra {
namespace detail {
namespace {

namespace IBA = OIIO::ImageBufAlgo;

OIIO::ImageBuf toBuf(const Image& im) {
  OIIO::ImageBuf buf(OIIO::ImageSpec(im.width, im.height, im.channels, OIIO::TypeDesc::FLOAT));
  buf.set_pixels(buf.roi(), OIIO::TypeDesc::FLOAT, im.pixels.data());
  return buf;
}

Image fromBuf(const OIIO::ImageBuf& buf) {
  const OIIO::ImageSpec& spec = buf.spec();
  Image im(spec.width, spec.height, spec.nchannels);
  buf.get_pixels(buf.roi(), OIIO::TypeDesc::FLOAT, im.pixels.data());
  return im;
}

bool isGeometry(const Image* geometry, std::size_t i) {
  return !geometry || geometry->channels < 4 || geometry->pixels[i * geometry->channels + 3] > 0.5f;
}

}  // namespace

ColourMap magmaColourMap() {
  ColourMap map{"magma", std::vector<float>(16 * 3)};
  OIIO::ImageBuf unit(OIIO::ImageSpec(16, 1, 1, OIIO::TypeDesc::FLOAT));
  for (int x = 0; x < 16; ++x) {
    const float v = float(x) / 15.0f;
    unit.setpixel(x, 0, &v);
  }
  const OIIO::ImageBuf magma = IBA::color_map(unit, 0, "magma");
  for (int x = 0; x < 16; ++x) magma.getpixel(x, 0, &map.knots[std::size_t(x) * 3]);
  return map;
}

ColourMap divergingColourMap() {
  return {"", {0.02f, 0.19f, 0.75f, 1, 1, 1, 0.85f, 0.05f, 0.05f}};
}

Image colourMapped(const std::vector<float>& values, int width, int height, const ColourMap& map,
                   const Image* geometry) {
  OIIO::ImageBuf v(OIIO::ImageSpec(width, height, 1, OIIO::TypeDesc::FLOAT));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float t = std::clamp(values[std::size_t(y) * width + x], 0.0f, 1.0f);
      v.setpixel(x, y, &t);
    }
  const int nknots = int(map.knots.size() / 3);
  OIIO::ImageBuf rgb = map.name.empty()
                           ? IBA::color_map(v, 0, nknots, 3, {map.knots.data(), long(nknots) * 3})
                           : IBA::color_map(v, 0, map.name);
  Image out = fromBuf(rgb);
  for (std::size_t i = 0; i < std::size_t(width) * height; ++i)
    if (!isGeometry(geometry, i))
      for (int c = 0; c < 3; ++c) out.pixels[i * 3 + c] = kHeatmapBackground;
  return out;
}

int scaleBarRows(int height) { return 2 + std::max(6, height / 16) + 16; }

Image withScaleBar(const Image& rgb, const ColourMap& map, const std::string& low,
                   const std::string& mid, const std::string& high) {
  const int W = rgb.width, H = rgb.height;
  const int bar = std::max(6, H / 16), labels = 16, pad = 2;
  OIIO::ImageBuf ramp(OIIO::ImageSpec(W, 1, 1, OIIO::TypeDesc::FLOAT));
  for (int x = 0; x < W; ++x) {
    const float v = W > 1 ? float(x) / float(W - 1) : 0.5f;
    ramp.setpixel(x, 0, &v);
  }
  const int nknots = int(map.knots.size() / 3);
  OIIO::ImageBuf rampRgb = IBA::color_map(ramp, 0, nknots, 3, {map.knots.data(), long(nknots) * 3});
  OIIO::ImageBuf out(OIIO::ImageSpec(W, H + pad + bar + labels, 3, OIIO::TypeDesc::FLOAT));
  const float black[3] = {0, 0, 0};
  IBA::fill(out, {black, 3});
  IBA::paste(out, 0, 0, 0, 0, toBuf(rgb));
  float px[3];
  for (int y = 0; y < bar; ++y)
    for (int x = 0; x < W; ++x) {
      rampRgb.getpixel(x, 0, px);
      out.setpixel(x, H + pad + y, px);
    }
  const float white[3] = {1, 1, 1};
  for (int x : {0, W / 2, W - 1})
    for (int y = H + pad + bar; y < H + pad + bar + 3; ++y) out.setpixel(x, y, white);
  const int ty = H + pad + bar + labels - 2;
  // Labels only where a font is installed (fonts-dejavu-core); the ticks carry the scale without.
  if (W >= 120 && IBA::render_text(out, 1, ty, low, 11, "DejaVuSans", {white, 3})) {
    IBA::render_text(out, W / 2, ty, mid, 11, "DejaVuSans", {white, 3},
                     IBA::TextAlignX::Center);
    IBA::render_text(out, W - 2, ty, high, 11, "DejaVuSans", {white, 3}, IBA::TextAlignX::Right);
  }
  return fromBuf(out);
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
  char s[32];
  std::snprintf(s, sizeof s, sign ? "%+g%%" : "%g%%", 100.0 * v);
  return s;
}

bool drawText(Image& image, int x, int y, const std::string& text, int size,
              const std::vector<float>& colour, TextAlign align, int shadow) {
  // Wraps the pixels in place: OpenImageIO draws straight into them.
  OIIO::ImageBuf buf(OIIO::ImageSpec(image.width, image.height, image.channels, OIIO::TypeDesc::FLOAT),
                     image.pixels.data());
  const auto alignX = align == TextAlign::Left     ? IBA::TextAlignX::Left
                      : align == TextAlign::Centre ? IBA::TextAlignX::Center
                                                   : IBA::TextAlignX::Right;
  return IBA::render_text(buf, x, y, text, size, "DejaVuSans",
                          {colour.data(), long(colour.size())}, alignX,
                          IBA::TextAlignY::Baseline, shadow);
}

int textWidth(const std::string& text, int size) {
  const OIIO::ROI box = IBA::text_size(text, size, "DejaVuSans");
  return box.defined() ? box.width() : 0;
}

}  // namespace detail

namespace {

namespace fs = std::filesystem;

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
  if (!canWriteImage(path))
    badInput(path + ": unsupported output format (no OpenImageIO writer for its extension)");
  if (display.empty()) badInput(path + ": nothing to write (empty image)");
  const fs::path target(path);
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) badInput(path + ": directory " + dir.string() + " does not exist");
  // Beside the target, then renamed into place, as writeImage does.
  const fs::path tmp = dir / ("." + target.filename().string() + ".tmp" +
                              std::to_string(::getpid()) + target.extension().string());
  OIIO::ImageBuf buf = detail::toBuf(display);
  if (!buf.write(tmp.string(), isFloatImageFormat(path) ? OIIO::TypeDesc::FLOAT
                                                         : OIIO::TypeDesc::UINT8)) {
    const std::string why = buf.geterror();
    fs::remove(tmp, ec);
    badInput(path + ": writing failed (" + why + ")");
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    const std::string why = ec.message();
    fs::remove(tmp, ec);
    badInput(path + ": cannot move the finished image into place (" + why + ")");
  }
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
