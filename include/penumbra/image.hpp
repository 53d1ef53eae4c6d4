/// \file
/// Host images: linear float pixels, interleaved channels, row 0 at the top.
#pragma once
#include <cstddef>
#include <map>
#include <string>
#include <vector>

namespace penumbra {

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<float> pixels;  ///< width*height*channels

  Image() = default;
  Image(int w, int h, int c, float value = 0.0f)
      : width(w), height(h), channels(c), pixels(std::size_t(w) * h * c, value) {}
  float& at(int x, int y, int c) { return pixels[(std::size_t(y) * width + x) * channels + c]; }
  float at(int x, int y, int c) const {
    return pixels[(std::size_t(y) * width + x) * channels + c];
  }
  bool empty() const { return pixels.empty(); }
};

/// Reads any image OpenImageIO understands as float. Throws Error(BadInput) naming the file and the
/// problem (missing, unreadable, truncated, zero-sized; a PNG's chunks are walked and the file
/// decoded once on trial first, so a cut file or a failed CRC gets that message alone). The format is the file's content, not its
/// extension. With `linearize`, an integer image (PNG,
/// JPEG, 8/16-bit TIFF: display-encoded, OpenImageIO says sRGB unless the file says otherwise) is
/// decoded to linear values with the sRGB transfer function (IEC 61966-2-1); float images are
/// linear already and read as they are.
Image readImage(const std::string& path, bool linearize = false);

/// Writes any format OpenImageIO has a writer for, chosen by the extension, atomically: the image
/// goes to a temporary file beside the target and is renamed into place, so a failure never leaves
/// a half-written file. Float formats (.exr, .hdr, .pfm) get the linear pixels, all channels;
/// every other format (.png, .jpg, .tif, .tga, .bmp, ...) gets 8-bit RGB through toneMap (alpha
/// dropped). Throws Error(BadInput) on an extension without a writer or an unwritable path.
/// numbers / text: header attributes stored under their names (as doubles / strings) where the
/// format has a header for them (EXR, TIFF, ...; a PNG keeps the text ones), e.g. the reference's
/// "penumbra:relative_noise" or "penumbra:version".
using ImageAttributes = std::map<std::string, double>;
using ImageText = std::map<std::string, std::string>;
void writeImage(const std::string& path, const Image& image, float exposure = 1.0f,
                const ImageAttributes& numbers = {}, const ImageText& text = {});

/// The bytes of the PNG file writeImage(path.png, image, exposure) would write (8-bit RGB through
/// toneMap, no header attributes), for a notebook or a network rather than a file. Throws
/// Error(BadInput) on an empty image.
std::vector<unsigned char> encodePng(const Image& image, float exposure = 1.0f);

/// Writing a PNG (writeImage, encodePng) is libpenumbra's own, through libpng. Every other file
/// function here (readImage of any format, writeImage of any other, canWriteImage of any other,
/// readImageAttributes) and the heat maps reach OpenImageIO through a module of libpenumbra's
/// own, libpenumbra_oiio.so.VERSION (penumbra's version), installed beside it and loaded the
/// first time one of them needs it: OpenImageIO loads about 260 shared libraries, which took about 0.45 s of every
/// process that linked it. A module that cannot be loaded is reported by that call as
/// Error(Internal), naming the file.

/// True when writeImage can write `path`'s format (an OpenImageIO writer exists for its extension).
bool canWriteImage(const std::string& path);

/// True when writeImage stores `path`'s format as linear floats (.exr, .hdr, .pfm), false when it
/// tone-maps to 8 bits.
bool isFloatImageFormat(const std::string& path);

/// The display image writeImage puts in an 8-bit file: width*height*3 bytes, row 0 at the top,
/// each channel multiplied by `exposure`, then toneMapChannel, then rounded to 0..255. A one- or
/// two-channel image is shown as grey (its first channel). exposure <= 0 means autoExposure(image).
std::vector<unsigned char> toneMap(const Image& image, float exposure);

/// The numeric header attributes of an image whose names start with "penumbra:" (empty when it has
/// none). Throws Error(BadInput) as readImage does when the file cannot be opened.
ImageAttributes readImageAttributes(const std::string& path);

/// Exposure that maps the log-average luminance of the image (of its alpha > 0.5 pixels when it has
/// alpha and any are set) to 0.25 before tone mapping (Reinhard et al. 2002's "key").
float autoExposure(const Image& image);

/// Tone mapping used for PNG, one channel at a time (the caller has applied the exposure):
/// x/(1+x) (Reinhard et al. 2002), then the sRGB transfer function; 0 for x <= 0 or NaN.
float toneMapChannel(float linear);

}  // namespace penumbra
