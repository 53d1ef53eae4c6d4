// Image files through OpenImageIO: reading and atomic writing (the bodies of
// penumbra/image.hpp's and penumbra/heatmap.hpp's functions of the same names, which forward here
// through core/image_codec.hpp).
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "core/image_codec.hpp"
#include "core/png.hpp"
#include "oiio/oiio.hpp"
#include "penumbra/error.hpp"

namespace penumbra::oiio {

namespace fs = std::filesystem;
using detail::lowerExtension;
using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

namespace {

// The most bytes a row of an image may hold as floats (readImage says why).
constexpr std::int64_t kMaxRowBytes = std::int64_t(4) << 20;

// What an OpenEXR header declares, checked against the file before OpenEXR reads it: OpenEXR
// allocates each attribute's declared size while it parses the header, so a 1 KB file declaring
// a string of gigabytes cost 1.9 GB and 8 s before it was refused (found by fuzz_envmap). The
// layout (OpenEXR file format: magic 20000630, a 4-byte version, then per header attributes of
// name\0 type\0 int32 size and value, an empty name ending each header; multi-part files add an
// empty header after the last) is walked without reading any value.
void checkExrDeclarations(const std::string& path, std::uintmax_t fileBytes) {
  std::ifstream in(path, std::ios::binary);
  unsigned char head[8] = {};
  in.read(reinterpret_cast<char*>(head), 8);
  if (in.gcount() < 8 || head[0] != 0x76 || head[1] != 0x2f || head[2] != 0x31 || head[3] != 0x01)
    return;  // not an OpenEXR file
  const bool multipart = (head[5] & 0x10) != 0;
  std::uintmax_t at = 8;
  const auto readName = [&](std::string& out) {
    out.clear();
    for (char c; in.get(c);) {
      ++at;
      if (c == '\0') return true;
      if (out.size() >= 255) return false;  // names are at most 255 bytes (31 in old files)
      out += c;
    }
    return false;
  };
  for (int part = 0;; ++part) {
    std::string name, type;
    int attributes = 0;
    for (;; ++attributes) {
      if (!readName(name)) badInput(path + ": the EXR header is cut short or malformed");
      if (name.empty()) break;
      if (!readName(type)) badInput(path + ": the EXR header is cut short or malformed");
      unsigned char sz[4];
      in.read(reinterpret_cast<char*>(sz), 4);
      if (in.gcount() < 4) badInput(path + ": the EXR header is cut short");
      at += 4;
      const std::uint32_t size = std::uint32_t(sz[0]) | std::uint32_t(sz[1]) << 8 |
                                 std::uint32_t(sz[2]) << 16 | std::uint32_t(sz[3]) << 24;
      if (size > fileBytes - std::min(at, fileBytes))
        badInput(path + ": EXR header attribute '" + name + "' (" + type + ") declares " +
                 std::to_string(size) + " bytes but only " +
                 std::to_string(fileBytes - std::min(at, fileBytes)) + " remain in the file");
      at += size;
      in.seekg(static_cast<std::streamoff>(at));
    }
    // A single-part file has one header; a multi-part one ends with an empty header.
    if (!multipart || attributes == 0 || part > 4096) return;
  }
}

// The same for PNG: libpng allocates each text chunk's declared length before it reads it, so an
// 847-byte file whose tEXt chunk declares 1.9 GB took 2 GB and 3.6 s before it was refused (found
// by fuzz_envmap). The layout (PNG specification §5.3: the 8-byte signature, then chunks of a
// big-endian uint32 length, a 4-byte type, the data and a CRC, ending with IEND) is walked
// without reading any data; a chunk longer than the rest of the file, and a file that ends
// before IEND, are refused. Then libpng decodes the file once with penumbra's own silent error
// handler (core/png.hpp, pngDecodeProblem), which judges the content: every chunk's CRC, the
// deflate stream, the filter bytes. OpenImageIO leaves libpng's default error handler in place,
// which prints "libpng error: ..." on stderr, so a truncated, bit-flipped or otherwise corrupt
// PNG gave two messages instead of one, and one with a bad CRC in IEND or an ancillary chunk
// loaded without a word (found by hand, then by fuzz_compare once the fuzz targets fixed up
// CRCs). The price of one message is a second decode of every PNG read.
void checkPngDeclarations(const std::string& path, std::uintmax_t fileBytes) {
  std::ifstream in(path, std::ios::binary);
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
  unsigned char head[8] = {};
  in.read(reinterpret_cast<char*>(head), 8);
  // A file that starts as a PNG but whose signature's last bytes differ (a text-mode transfer's
  // line-ending conversion changes them) gets past OpenImageIO's check and makes libpng print
  // its own line (found by fuzz_compare), so it is refused here.
  if (in.gcount() >= 4 && std::equal(head, head + 4, kSignature) &&
      (in.gcount() < 8 || !std::equal(head, head + 8, kSignature)))
    badInput(path + ": PNG signature is cut short or damaged (its bytes 5 to 8 must be 0D 0A 1A "
                    "0A; a text-mode transfer changes them)");
  if (in.gcount() < 8 || !std::equal(head, head + 8, kSignature)) return;  // not a PNG file
  std::uintmax_t at = 8;
  for (int chunks = 0; chunks < (1 << 20); ++chunks) {
    unsigned char c[8];
    in.seekg(static_cast<std::streamoff>(at));
    in.read(reinterpret_cast<char*>(c), 8);
    if (in.gcount() < 8)
      badInput(path + ": PNG file ends at byte " + std::to_string(at + std::uintmax_t(in.gcount())) +
               ", before its IEND chunk (truncated or corrupt)");
    const std::uint32_t length = std::uint32_t(c[0]) << 24 | std::uint32_t(c[1]) << 16 |
                                 std::uint32_t(c[2]) << 8 | std::uint32_t(c[3]);
    std::string type;
    for (int k = 4; k < 8; ++k)
      type += (c[k] >= 0x20 && c[k] < 0x7f) ? char(c[k]) : '?';
    const std::uintmax_t left = fileBytes - std::min(at + 12, fileBytes);
    if (length > left)
      badInput(path + ": PNG chunk '" + type + "' declares " + std::to_string(length) +
               " bytes but only " + std::to_string(left) +
               " remain in the file (truncated or corrupt)");
    if (at + 12 > fileBytes)
      badInput(path + ": PNG file ends at byte " + std::to_string(fileBytes) + ", inside chunk '" +
               type + "' (truncated)");
    if (type == "IEND") {
      // The chunks are whole; their content is libpng's to judge, here without its stderr line.
      const std::string problem = detail::pngDecodeProblem(path, kMaxRowBytes);
      if (!problem.empty()) badInput(path + ": PNG file is corrupt (" + problem + ")");
      return;
    }
    at += 12 + std::uintmax_t(length);
  }
  badInput(path + ": PNG file has over " + std::to_string(1 << 20) + " chunks");
}

// Both walks above, before OpenImageIO opens the file (its readers allocate while parsing).
void checkDeclarations(const std::string& path) {
  std::error_code ec;
  const std::uintmax_t fileBytes = fs::file_size(path, ec);
  if (ec) return;  // OpenImageIO's open reports the file's own problem
  checkExrDeclarations(path, fileBytes);
  checkPngDeclarations(path, fileBytes);
}

// The pixels of `in` into img.pixels, read in strips of rows and held only as they arrive where
// the file is too small to hold them. A header can declare any size: a 51-byte PFM declaring
// 4141 x 41411 RGB floats had its 2 GB allocated before the read found the file empty (found by
// fuzz_envmap). Where the declared pixels (as floats) are at most kMaxExpansion times the file's
// size, which covers every compression OpenImageIO reads from real files (deflate, at most about
// 1032:1, is the strongest general one), the whole image is allocated at once as before; beyond
// that it grows with each strip read, so a file whose data is missing is refused after its
// first strip instead.
void readPixels(const std::string& path, ImageInput& in, Image& img) {
  const ImageSpec& spec = in.spec();
  constexpr std::uintmax_t kMaxExpansion = 4096;
  const std::size_t rowFloats = std::size_t(spec.width) * std::size_t(spec.nchannels);
  const std::size_t total = rowFloats * std::size_t(spec.height);
  std::error_code ec;
  const std::uintmax_t fileBytes = fs::file_size(path, ec);
  const bool plausible = !ec && std::uintmax_t(total) * sizeof(float) / kMaxExpansion <= fileBytes;
  // Strips of whole tiles for a tiled file (read_tiles needs tile-aligned rows), else of rows;
  // about 16 MiB of floats each.
  const int tileRows = spec.tile_width > 0 ? std::max(spec.tile_height, 1) : 1;
  const std::size_t stripBytes = std::size_t(16) << 20;
  const int rowsPerStrip =
      tileRows * int(std::max<std::size_t>(1, stripBytes / (rowFloats * sizeof(float) * tileRows)));
  img.pixels.clear();
  if (plausible) img.pixels.reserve(total);
  for (int y = 0; y < spec.height; y += rowsPerStrip) {
    const int y1 = std::min(spec.height, y + rowsPerStrip);
    img.pixels.resize(std::size_t(y1) * rowFloats);
    float* dst = img.pixels.data() + std::size_t(y) * rowFloats;
    const bool ok =
        spec.tile_width > 0
            ? in.read_tiles(0, 0, spec.x, spec.x + spec.width, spec.y + y, spec.y + y1, spec.z,
                            spec.z + std::max(spec.depth, 1), 0, spec.nchannels, TypeDesc::FLOAT,
                            dst)
            : in.read_scanlines(0, 0, spec.y + y, spec.y + y1, spec.z, 0, spec.nchannels,
                                TypeDesc::FLOAT, dst);
    if (!ok) {
      std::string err = in.geterror();
      std::replace(err.begin(), err.end(), '\n', ' ');
      if (err.empty())
        err = "rows " + std::to_string(y) + " to " + std::to_string(y1 - 1) + " of " +
              std::to_string(spec.height) + " could not be read";
      badInput(path + ": image data is corrupt or truncated (" + err + ")");
    }
  }
}

}  // namespace

// The path was checked by libpenumbra (core/image.cpp) before it loaded this module.
Image readImage(const std::string& path, bool linearize) {
  checkDeclarations(path);
  auto in = ImageInput::open(path);
  if (!in) {
    std::string err = OIIO::geterror();
    if (err.empty()) err = "not a readable image";
    std::replace(err.begin(), err.end(), '\n', ' ');
    badInput(path + ": cannot read image (" + err + ")");
  }
  const ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
    badInput(path + ": image has no pixels (" + std::to_string(spec.width) + "x" +
             std::to_string(spec.height) + ")");
  if (std::int64_t(spec.width) * spec.height > (std::int64_t(1) << 28))
    badInput(path + ": image is too large (" + std::to_string(spec.width) + "x" +
             std::to_string(spec.height) + ")");
  // OpenImageIO reads a scanline file that needs any conversion through a buffer of at least
  // 256 scanlines (its "read_chunk"), whatever the image's height: a very wide image costs 256
  // of its rows at once. A 619-byte EXR declaring 3,276,801 x 1 float RGB pixels asked for 10 GB
  // (found by fuzz_envmap). Rows are held to kMaxRowBytes (256 of them: 1 GiB).
  const std::int64_t rowBytes = std::int64_t(spec.width) * std::int64_t(spec.pixel_bytes(true));
  if (rowBytes > kMaxRowBytes)
    badInput(path + ": image rows are too wide (" + std::to_string(spec.width) + " pixels of " +
             std::to_string(spec.pixel_bytes(true)) + " bytes: " + std::to_string(rowBytes) +
             " bytes per row, at most " + std::to_string(kMaxRowBytes) + ")");
  Image img;
  img.width = spec.width;
  img.height = spec.height;
  img.channels = spec.nchannels;
  readPixels(path, *in, img);
  const std::string space = spec.get_string_attribute("oiio:ColorSpace");
  const bool integer = !spec.format.is_floating_point();
  if (linearize && integer && (space.empty() || space == "sRGB")) {
    // The alpha channel (if any) is not colour: left as stored.
    const int colour = std::min(spec.nchannels, spec.alpha_channel >= 0 ? spec.alpha_channel : 3);
    for (std::size_t p = 0; p < img.pixels.size(); p += std::size_t(spec.nchannels))
      for (int c = 0; c < colour; ++c) {
        float& v = img.pixels[p + std::size_t(c)];
        v = v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
      }
  }
  in->close();
  return img;
}

ImageAttributes readImageAttributes(const std::string& path) {
  checkDeclarations(path);
  auto in = ImageInput::open(path);
  if (!in) badInput(path + ": cannot read image (" + OIIO::geterror() + ")");
  ImageAttributes out;
  for (const OIIO::ParamValue& p : in->spec().extra_attribs) {
    const std::string name = p.name().string();
    if (name.rfind("penumbra:", 0) != 0 || p.nvalues() != 1) continue;
    if (p.type() == TypeDesc::DOUBLE) out[name] = *static_cast<const double*>(p.data());
    else if (p.type() == TypeDesc::FLOAT) out[name] = *static_cast<const float*>(p.data());
  }
  in->close();
  return out;
}

bool canWriteImage(const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext.size() < 2) return false;
  // ImageOutput::create only looks the extension up in OpenImageIO's plugin table; nothing is
  // opened or created on disk.
  auto out = ImageOutput::create(ext.substr(1));
  OIIO::geterror();  // a failed lookup leaves a message behind; clear it
  return bool(out);
}

void writeImage(const std::string& path, const Image& image, float exposure,
                const ImageAttributes& numbers, const ImageText& text) {
  const std::string ext = lowerExtension(path);
  if (!canWriteImage(path))
    badInput(path + ": unsupported output format '" + ext +
             "' (no OpenImageIO writer for it; use e.g. .exr, .png, .jpg, .tif or .hdr)");
  if (image.empty()) badInput(path + ": nothing to write (empty image)");
  const bool linear = isFloatImageFormat(path);
  detail::writeBeside(path, [&](const std::string& tmp) {
    auto out = ImageOutput::create(tmp);
    if (!out) badInput(path + ": cannot create writer (" + OIIO::geterror() + ")");
    // .hdr holds RGB only; other float formats keep every channel.
    const int channels =
        linear ? (ext == ".hdr" || ext == ".pfm" ? std::min(image.channels, 3) : image.channels) : 3;
    ImageSpec spec(image.width, image.height, channels, linear ? TypeDesc::FLOAT : TypeDesc::UINT8);
    if (linear && channels == 4) spec.alpha_channel = 3;
    if (ext == ".exr") spec.attribute("compression", "zip");
    // OpenImageIO stamps the current time into the header (capDate) unless the spec holds a
    // DateTime; an empty one writes no time, so two identical runs give byte-identical files.
    spec.attribute("DateTime", "");
    for (const auto& [name, value] : numbers) spec.attribute(name, TypeDesc::DOUBLE, &value);
    for (const auto& [name, value] : text) spec.attribute(name, value);
    bool ok = out->open(tmp, spec);
    if (ok && linear) {
      if (channels == image.channels) {
        ok = out->write_image(TypeDesc::FLOAT, image.pixels.data());
      } else {
        std::vector<float> px(std::size_t(image.width) * image.height * channels);
        for (std::size_t i = 0; i < std::size_t(image.width) * image.height; ++i)
          for (int c = 0; c < channels; ++c) px[i * channels + c] = image.pixels[i * image.channels + c];
        ok = out->write_image(TypeDesc::FLOAT, px.data());
      }
    } else if (ok) {
      std::vector<unsigned char> px = toneMap(image, exposure);
      ok = out->write_image(TypeDesc::UINT8, px.data());
    }
    ok = ok && out->close();
    if (!ok) badInput(path + ": writing failed (" + out->geterror() + ")");
  });
}

void writeDisplayImage(const std::string& path, const Image& display) {
  if (!canWriteImage(path))
    badInput(path + ": unsupported output format (no OpenImageIO writer for its extension)");
  if (display.empty()) badInput(path + ": nothing to write (empty image)");
  detail::writeBeside(path, [&](const std::string& tmp) {
    OIIO::ImageBuf buf(ImageSpec(display.width, display.height, display.channels, TypeDesc::FLOAT));
    buf.set_pixels(buf.roi(), TypeDesc::FLOAT, display.pixels.data());
    if (!buf.write(tmp, isFloatImageFormat(path) ? TypeDesc::FLOAT : TypeDesc::UINT8))
      badInput(path + ": writing failed (" + buf.geterror() + ")");
  });
}

}  // namespace penumbra::oiio
