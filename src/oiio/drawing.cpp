// Colour maps, scale bars and text through OpenImageIO's ImageBufAlgo (the bodies of
// metrics/heatmap.hpp's functions of the same names, which forward here through
// core/image_codec.hpp).
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>

#include "oiio/oiio.hpp"

namespace penumbra::oiio {

using detail::ColourMap;
using detail::TextAlign;

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

Image colourMap(const std::vector<float>& values, int width, int height, const ColourMap& map) {
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
  return fromBuf(rgb);
}

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

}  // namespace penumbra::oiio
