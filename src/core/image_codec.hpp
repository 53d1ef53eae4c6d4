// The OpenImageIO half of penumbra's image I/O: a module of its own (libpenumbra_oiio.so.*, built
// from src/oiio/, installed beside libpenumbra) that libpenumbra loads with dlopen the first time
// an image is read, written (but for PNG: core/png.hpp) or drawn on. OpenImageIO brings about
// 260 shared libraries (OpenCV, ffmpeg, GDAL, ...) whose loading and relocation took 0.45 s of
// every process, `penumbra --version` and `penumbra devices` included; now only the processes
// that touch an image pay it.
// Loading it on a thread of its own would not hide it: dlopen holds one process-wide lock, and
// PoCL dlopens every kernel library it builds, so the two would only take turns.
//
// Both sides are built from the same tree, so the table passes C++ types and exceptions
// (penumbra::Error, whose type information lives in libpenumbra, which the module links).
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "metrics/heatmap.hpp"
#include "penumbra/image.hpp"
#include "penumbra/version.hpp"

namespace penumbra::detail {

// Raised whenever the table's layout or meaning changes; the loader refuses a module built with
// another value or another PENUMBRA_VERSION.
inline constexpr int kImageCodecAbi = 1;

// The file name the loader looks for in the directory libpenumbra was loaded from:
// libpenumbra_oiio.so.<version>, so that two versions installed side by side keep their own.
inline const std::string kImageCodecFile = std::string("libpenumbra_oiio.so.") + PENUMBRA_VERSION;

// The symbol the module exports (extern "C"): returns its table.
inline constexpr const char* kImageCodecSymbol = "penumbra_image_codec";

struct ImageCodec {
  int abi;
  const char* version;  // PENUMBRA_VERSION the module was built with
  // The public functions of penumbra/image.hpp and penumbra/heatmap.hpp with the same names (PNG
  // files are libpenumbra's own: core/png.hpp).
  Image (*readImage)(const std::string& path, bool linearize);
  ImageAttributes (*readImageAttributes)(const std::string& path);
  bool (*canWriteImage)(const std::string& path);
  void (*writeImage)(const std::string& path, const Image& image, float exposure,
                     const ImageAttributes& numbers, const ImageText& text);
  void (*writeDisplayImage)(const std::string& path, const Image& display);
  // metrics/heatmap.hpp's functions of the same names; colourMap is colourMapped without the
  // geometry mask, which libpenumbra applies.
  ColourMap (*magmaColourMap)();
  Image (*colourMap)(const std::vector<float>& values, int width, int height, const ColourMap& map);
  Image (*withScaleBar)(const Image& rgb, const ColourMap& map, const std::string& low,
                        const std::string& mid, const std::string& high);
  bool (*drawText)(Image& image, int x, int y, const std::string& text, int size,
                   const std::vector<float>& colour, TextAlign align, int shadow);
  int (*textWidth)(const std::string& text, int size);
};

// The module's table, loaded on the first call (thread-safe). Throws Error(Internal) naming the module's path and
// what went wrong when it is missing, unloadable or from another build.
const ImageCodec& imageCodec();

// Has `write` write a temporary file beside `path` (same directory, hidden name, same extension),
// then renames it into place: a crash or an error never leaves a half-written file. The temporary
// file is removed when `write` throws, and the exception goes on. Throws Error(BadInput) when the
// directory does not exist or the rename fails. Defined in core/image.cpp.
void writeBeside(const std::string& path, const std::function<void(const std::string& tmp)>& write);

// The extension of `path`, dot included, in lower case ("" when it has none); defined in
// core/image.cpp.
std::string lowerExtension(const std::string& path);

}  // namespace penumbra::detail
