// Host images: the tone mapping and exposure that need no codec, and the file functions of
// penumbra/image.hpp, which forward to the OpenImageIO module (core/image_codec.hpp).
#include "penumbra/image.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/image_codec.hpp"
#include "core/png.hpp"
#include "penumbra/error.hpp"

namespace penumbra {

namespace fs = std::filesystem;

namespace {

// What needs no codec is refused before the module is loaded (0.45 s) for it.
void checkReadable(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) badInput(path + ": no such file");
  if (fs::is_directory(path, ec)) badInput(path + ": is a directory, not an image");
}

}  // namespace

Image readImage(const std::string& path, bool linearize) {
  checkReadable(path);
  return detail::imageCodec().readImage(path, linearize);
}

ImageAttributes readImageAttributes(const std::string& path) {
  checkReadable(path);
  return detail::imageCodec().readImageAttributes(path);
}

float toneMapChannel(float v) {
  if (!(v > 0.0f)) return 0.0f;
  float t = v / (1.0f + v);  // Reinhard
  // sRGB transfer
  return t <= 0.0031308f ? 12.92f * t : 1.055f * std::pow(t, 1.0f / 2.4f) - 0.055f;
}

float autoExposure(const Image& img) {
  double logSum = 0;
  std::size_t n = 0;
  bool useAlpha = false;
  if (img.channels == 4)
    for (std::size_t i = 0; i < std::size_t(img.width) * img.height && !useAlpha; ++i)
      useAlpha = img.pixels[i * 4 + 3] > 0.5f;
  for (std::size_t i = 0; i < std::size_t(img.width) * img.height; ++i) {
    const float* p = &img.pixels[i * img.channels];
    if (useAlpha && p[3] <= 0.5f) continue;
    float y = img.channels >= 3 ? 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2] : p[0];
    if (!std::isfinite(y)) continue;
    logSum += std::log(1e-4 + std::max(0.0f, y));
    ++n;
  }
  if (n == 0) return 1.0f;
  return float(0.25 / std::exp(logSum / double(n)));
}

namespace detail {

std::string lowerExtension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

void writeBeside(const std::string& path, const std::function<void(const std::string&)>& write) {
  const fs::path target(path);
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) badInput(path + ": directory " + dir.string() + " does not exist");
  const fs::path tmp = dir / ("." + target.filename().string() + ".tmp" +
                              std::to_string(::getpid()) + lowerExtension(path));
  try {
    write(tmp.string());
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    const std::string why = ec.message();
    fs::remove(tmp, ec);
    badInput(path + ": cannot move the finished image into place (" + why + ")");
  }
}

}  // namespace detail

bool isFloatImageFormat(const std::string& path) {
  const std::string ext = detail::lowerExtension(path);
  return ext == ".exr" || ext == ".hdr" || ext == ".pfm";
}

bool canWriteImage(const std::string& path) {
  return detail::lowerExtension(path) == ".png" || detail::imageCodec().canWriteImage(path);
}

std::vector<unsigned char> toneMap(const Image& image, float exposure) {
  if (!(exposure > 0.0f)) exposure = autoExposure(image);
  std::vector<unsigned char> px(std::size_t(image.width) * image.height * 3);
  if (image.channels <= 0) return px;
  const int colour = image.channels >= 3 ? 3 : 1;
  for (std::size_t i = 0; i < std::size_t(image.width) * image.height; ++i)
    for (int c = 0; c < 3; ++c) {
      float v = image.pixels[i * image.channels + (colour == 3 ? c : 0)] * exposure;
      px[i * 3 + c] = (unsigned char)std::lround(std::clamp(toneMapChannel(v), 0.0f, 1.0f) * 255.0f);
    }
  return px;
}

void writeImage(const std::string& path, const Image& image, float exposure,
                const ImageAttributes& numbers, const ImageText& text) {
  // PNG, the CLI's default output, is written here with libpng (core/png.hpp), so that writing it
  // does not load OpenImageIO's module; every other format goes through the module. A PNG keeps
  // the text attributes only, as OpenImageIO's PNG writer does.
  if (detail::lowerExtension(path) != ".png") {
    detail::imageCodec().writeImage(path, image, exposure, numbers, text);
    return;
  }
  if (image.empty()) badInput(path + ": nothing to write (empty image)");
  const std::vector<unsigned char> rgb = toneMap(image, exposure);
  detail::writeBeside(path, [&](const std::string& tmp) {
    detail::writePng(tmp, path, image.width, image.height, rgb, text);
  });
}

std::vector<unsigned char> encodePng(const Image& image, float exposure) {
  if (image.empty()) badInput("encodePng: nothing to encode (empty image)");
  return detail::encodePngBytes(image.width, image.height, toneMap(image, exposure), {});
}

}  // namespace penumbra
