// Host images: linear float pixels, interleaved channels, row 0 at the top.
#pragma once
#include <cstddef>
#include <map>
#include <string>
#include <vector>

namespace penumbra {

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<float> pixels;  // width*height*channels

  Image() = default;
  Image(int w, int h, int c, float value = 0.0f)
      : width(w), height(h), channels(c), pixels(std::size_t(w) * h * c, value) {}
  float& at(int x, int y, int c) { return pixels[(std::size_t(y) * width + x) * channels + c]; }
  float at(int x, int y, int c) const {
    return pixels[(std::size_t(y) * width + x) * channels + c];
  }
  bool empty() const { return pixels.empty(); }
};

// Reads any image OpenImageIO understands as float. Throws Error(BadInput) naming the file and the
// problem (missing, unreadable, truncated, zero-sized). With `linearize`, an integer image (PNG,
// JPEG, 8/16-bit TIFF: display-encoded, OpenImageIO says sRGB unless the file says otherwise) is
// decoded to linear values with the sRGB transfer function (IEC 61966-2-1); float images are
// linear already and read as they are.
Image readImage(const std::string& path, bool linearize = false);

// Writes .exr (linear half/float, all channels) or .png (RGB, tone-mapped, sRGB-encoded; alpha
// dropped) atomically: the image goes to a temporary file beside the target and is renamed into
// place, so a failure never leaves a half-written file. Throws Error(BadInput) on an unknown
// extension or an unwritable path.
// exrAttributes: numbers stored in an EXR's header under their names (as doubles; a PNG drops
// them), e.g. the reference's "penumbra:relative_noise".
using ImageAttributes = std::map<std::string, double>;
void writeImage(const std::string& path, const Image& image, float exposure = 1.0f,
                const ImageAttributes& exrAttributes = {});

// The numeric header attributes of an image whose names start with "penumbra:" (empty when it has
// none). Throws Error(BadInput) as readImage does when the file cannot be opened.
ImageAttributes readImageAttributes(const std::string& path);

// Exposure that maps the log-average luminance of the image (of its alpha > 0.5 pixels when it has
// alpha and any are set) to 0.25 before tone mapping (Reinhard et al. 2002's "key").
float autoExposure(const Image& image);

// Tone mapping used for PNG, one channel at a time (the caller has applied the exposure):
// x/(1+x) (Reinhard et al. 2002), then the sRGB transfer function; 0 for x <= 0 or NaN.
float toneMapChannel(float linear);

}  // namespace penumbra
