// Image files: PNG written with libpng (core/png.hpp) against OpenImageIO's writer in the module
// (core/image_codec.hpp), byte for byte; the module's loading; the PNG writer's failures; damaged
// and mislabelled files on reading.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <png.h>
#include <zlib.h>

#include <csetjmp>
#include <cstdio>

#include "core/image_codec.hpp"
#include "core/png.hpp"
#include "penumbra/error.hpp"
#include "penumbra/image.hpp"
#include "penumbra/version.hpp"

namespace fs = std::filesystem;
using namespace penumbra;

namespace {

std::string bytesOf(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class ImageFiles : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(testing::TempDir()) /
           ("penumbra_image_files_" + std::to_string(::getpid()) + "_" +
            testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    if (!HasFailure()) fs::remove_all(dir_, ec);
  }
  fs::path dir_;
};

// A deterministic image with HDR values, negatives and NaN (tone mapping sends them to 0).
Image pattern(int w, int h, int channels) {
  Image im(w, h, channels);
  std::uint32_t s = 12345u + std::uint32_t(w * 31 + h);
  for (float& v : im.pixels) {
    s = s * 1664525u + 1013904223u;
    v = float(s >> 8) / float(1u << 24) * 4.0f - 0.5f;
  }
  if (!im.pixels.empty()) im.pixels[0] = std::numeric_limits<float>::quiet_NaN();
  return im;
}

}  // namespace

// The PNG path changed writers; the files must not change: the same IHDR, oFFs, tEXt chunks in
// name order and zlib stream as OpenImageIO's PNG writer gives, on awkward sizes and channel
// counts, with and without text and numbers (a PNG keeps the text only).
TEST_F(ImageFiles, PngMatchesOpenImageIOsWriterByteForByte) {
  const detail::ImageCodec& oiio = detail::imageCodec();
  const ImageText text = {{"penumbra:version", PENUMBRA_VERSION},
                          {"penumbra:command", "penumbra render --out \"a b.png\" ü"}};
  const ImageAttributes numbers = {{"penumbra:relative_noise", 0.0125}};
  struct Case {
    int w, h, channels;
    float exposure;
  };
  for (const Case c : {Case{1, 1, 3, 1.0f}, Case{1, 37, 3, 0.5f}, Case{37, 1, 4, 2.0f},
                       Case{33, 17, 1, 1.0f}, Case{300, 201, 3, 0.0f}}) {
    const Image im = pattern(c.w, c.h, c.channels);
    const std::string tag = std::to_string(c.w) + "x" + std::to_string(c.h) + "x" +
                            std::to_string(c.channels);
    for (bool withText : {false, true}) {
      const fs::path ours = dir_ / ("ours_" + tag + ".png");
      const fs::path theirs = dir_ / ("oiio_" + tag + ".png");
      writeImage(ours.string(), im, c.exposure, withText ? numbers : ImageAttributes{},
                 withText ? text : ImageText{});
      oiio.writeImage(theirs.string(), im, c.exposure, withText ? numbers : ImageAttributes{},
                      withText ? text : ImageText{});
      const std::string a = bytesOf(ours), b = bytesOf(theirs);
      ASSERT_FALSE(a.empty()) << tag;
      EXPECT_EQ(a.size(), b.size()) << tag << " text " << withText;
      EXPECT_TRUE(a == b) << tag << " text " << withText;
      // And it decodes to the bytes toneMap gives.
      const Image back = readImage(ours.string());
      const std::vector<unsigned char> rgb = toneMap(im, c.exposure);
      ASSERT_EQ(back.channels, 3) << tag;
      ASSERT_EQ(back.pixels.size(), rgb.size()) << tag;
      int wrong = 0;
      for (std::size_t i = 0; i < rgb.size(); ++i)
        wrong += std::lround(back.pixels[i] * 255.0f) != rgb[i];
      EXPECT_EQ(wrong, 0) << tag;
    }
  }
  // Nothing but the outputs: no temporary file left behind.
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_NE(e.path().filename().string()[0], '.') << e.path();
}

// encodePng is the file writeImage writes (without text), in memory.
TEST_F(ImageFiles, EncodePngIsTheFileInMemory) {
  for (const Image& im : {pattern(1, 1, 3), pattern(7, 5, 4), pattern(64, 33, 1)}) {
    const fs::path file = dir_ / "e.png";
    writeImage(file.string(), im, 0.7f);
    const std::vector<unsigned char> png = encodePng(im, 0.7f);
    EXPECT_EQ(std::string(png.begin(), png.end()), bytesOf(file)) << im.width << "x" << im.height;
  }
  EXPECT_THROW(encodePng(Image(), 1.0f), Error);
}

TEST_F(ImageFiles, PngNeedsNoModuleAndRefusesWhatItCannotWrite) {
  EXPECT_TRUE(canWriteImage("x.png"));
  EXPECT_TRUE(canWriteImage("dir/x.PNG"));
  EXPECT_FALSE(canWriteImage("x.nosuchformat"));
  const Image im = pattern(4, 3, 3);
  try {
    writeImage((dir_ / "missing" / "x.png").string(), im);
    ADD_FAILURE() << "no error for a missing directory";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  try {
    writeImage((dir_ / "empty.png").string(), Image());
    ADD_FAILURE() << "no error for an empty image";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("empty image"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::is_empty(dir_));
}

// A device that takes no byte: libpng's failure (or the flush's) comes back as one BadInput
// naming the file, through the longjmp, with nothing leaked (the sanitized run checks that).
TEST_F(ImageFiles, PngWriteFailureIsReported) {
  const Image im = pattern(64, 64, 3);
  const std::vector<unsigned char> rgb = toneMap(im, 1.0f);
  try {
    detail::writePng("/dev/full", "out.png", im.width, im.height, rgb, {{"penumbra:x", "y"}});
    ADD_FAILURE() << "no error writing to /dev/full";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("out.png: writing failed (", 0), 0u) << what;
  }
  try {
    detail::writePng((dir_ / "no" / "such.png").string(), "such.png", im.width, im.height, rgb, {});
    ADD_FAILURE() << "no error for a file that cannot be opened";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("such.png: cannot open for writing"), std::string::npos)
        << e.what();
  }
}

// A damaged PNG is refused before OpenImageIO reads it, with one message naming the file and
// nothing of libpng's own on stderr (libpng prints "libpng error: ..." when OpenImageIO's reader
// hits a truncation or a bad CRC; the loader's chunk walk and silent trial decode come first). Cut at every kind of place (inside the signature, a chunk header, a
// chunk's data, its CRC, before and inside IEND) and with one byte flipped in each chunk: a file
// cut just before IEND, or with a flipped byte in IEND's CRC, loaded before the check.
TEST_F(ImageFiles, DamagedPngIsRefusedWithOneMessage) {
  const fs::path good = dir_ / "good.png";
  writeImage(good.string(), pattern(37, 5, 3), 1.0f, {}, {{"penumbra:note", "damaged on purpose"}});
  const std::string bytes = bytesOf(good);
  // Chunk starts, from the layout: 8-byte signature, then length, type, data, CRC.
  std::vector<std::size_t> starts;
  for (std::size_t at = 8; at + 8 <= bytes.size();) {
    starts.push_back(at);
    const auto b = [&](std::size_t i) { return std::uint32_t(std::uint8_t(bytes[at + i])); };
    at += 12 + (b(0) << 24 | b(1) << 16 | b(2) << 8 | b(3));
  }
  ASSERT_GE(starts.size(), 4u);  // IHDR, oFFs, tEXt, IDAT, IEND
  ASSERT_EQ(bytes.substr(starts.back() + 4, 4), "IEND");
  const std::size_t iend = starts.back();
  const std::size_t idat = starts[starts.size() - 2];
  ASSERT_EQ(bytes.substr(idat + 4, 4), "IDAT");

  std::vector<std::pair<std::string, std::string>> damaged;  // name, bytes
  for (std::size_t cut : {std::size_t(3), std::size_t(8), std::size_t(20), std::size_t(33),
                          idat + 20, iend - 1, iend, iend + 6, bytes.size() - 1})
    damaged.emplace_back("cut_at_" + std::to_string(cut) + ".png", bytes.substr(0, cut));
  {
    // The signature's last byte changed (0A to 0D, as a text-mode transfer might): OpenImageIO's
    // check lets it through to libpng, which printed "PNG file corrupted by ASCII conversion".
    std::string ascii = bytes;
    ascii[7] = '\r';
    damaged.emplace_back("signature_byte_8_changed.png", ascii);
  }
  for (std::size_t start : starts) {
    std::string flipped = bytes;
    // A byte of the data where there is data, else of the CRC.
    const std::size_t pos = start + (start == iend ? 8 : 9);
    flipped[pos] = char(flipped[pos] ^ 0x5a);
    damaged.emplace_back("flipped_at_" + std::to_string(pos) + ".png", flipped);
  }
  {
    // A byte of the deflate data flipped and the CRC made to match (as fuzz_compare's inputs
    // are): libpng meets a bad filter byte or a broken deflate stream.
    std::string inner = bytes;
    const std::uint32_t length = std::uint32_t(std::uint8_t(bytes[idat])) << 24 |
                                 std::uint32_t(std::uint8_t(bytes[idat + 1])) << 16 |
                                 std::uint32_t(std::uint8_t(bytes[idat + 2])) << 8 |
                                 std::uint32_t(std::uint8_t(bytes[idat + 3]));
    inner[idat + 8 + length / 2] = char(inner[idat + 8 + length / 2] ^ 0x5a);
    const uLong crc = crc32(crc32(0L, Z_NULL, 0),
                            reinterpret_cast<const Bytef*>(inner.data() + idat + 4), 4 + length);
    for (int k = 0; k < 4; ++k) inner[idat + 8 + length + std::size_t(k)] = char(crc >> (24 - 8 * k));
    damaged.emplace_back("deflate_data_flipped_crc_valid.png", inner);
  }
  for (const auto& [name, content] : damaged) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << content;
    for (int attributes = 0; attributes < 2; ++attributes) {
      testing::internal::CaptureStderr();
      std::string what;
      try {
        if (attributes)
          readImageAttributes(path);
        else
          readImage(path);
      } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::BadInput) << name;
        what = e.what();
      }
      const std::string err = testing::internal::GetCapturedStderr();
      EXPECT_NE(what.find(path), std::string::npos) << name << " (attributes " << attributes
                                                    << ") was accepted or unnamed: " << what;
      // Under 8 bytes there is no signature: not a PNG at all, as OpenImageIO says.
      const bool signature = content.size() >= 8;
      EXPECT_TRUE(signature ? what.find("truncated") != std::string::npos ||
                                  what.find("corrupt") != std::string::npos ||
                                  what.find("signature is cut short or damaged") !=
                                      std::string::npos
                            : what.find("cannot read image") != std::string::npos)
          << name << ": " << what;
      EXPECT_EQ(err, "") << name << ": something besides the one message";
    }
  }
  // The undamaged file still loads.
  EXPECT_EQ(readImage(good.string()).width, 37);
}

// Writes a PNG with libpng: `bits` per sample, the colour type, interlaced or not; sample s of
// pixel p is value(p, s), scaled to the bit depth.
void writePngVariant(const std::string& path, int w, int h, int bits, int colourType,
                     bool interlaced, std::vector<std::uint16_t>* samples) {
  const int channels = colourType == PNG_COLOR_TYPE_GRAY         ? 1
                       : colourType == PNG_COLOR_TYPE_GRAY_ALPHA ? 2
                       : colourType == PNG_COLOR_TYPE_RGB        ? 3
                                                                 : 4;
  const int maxValue = (1 << bits) - 1;
  samples->assign(std::size_t(w) * h * channels, 0);
  for (std::size_t i = 0; i < samples->size(); ++i)
    (*samples)[i] = std::uint16_t((i * 2654435761u >> 7) % std::size_t(maxValue + 1));
  // Rows packed as the file holds them (big-endian 16-bit, or sub-byte samples packed).
  const std::size_t rowBytes = (std::size_t(w) * channels * bits + 7) / 8;
  std::vector<unsigned char> packed(rowBytes * h, 0);
  for (int y = 0; y < h; ++y)
    for (int i = 0; i < w * channels; ++i) {
      const std::uint16_t v = (*samples)[std::size_t(y) * w * channels + i];
      unsigned char* row = packed.data() + std::size_t(y) * rowBytes;
      if (bits == 16) {
        row[2 * i] = std::uint8_t(v >> 8);
        row[2 * i + 1] = std::uint8_t(v);
      } else if (bits == 8) {
        row[i] = std::uint8_t(v);
      } else {
        const int bit = i * bits;
        row[bit / 8] |= std::uint8_t(v << (8 - bits - bit % 8));
      }
    }
  std::FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) FAIL() << "libpng failed writing " << path;
  png_init_io(png, f);
  png_set_IHDR(png, info, png_uint_32(w), png_uint_32(h), bits, colourType,
               interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  std::vector<png_bytep> rows(static_cast<std::size_t>(h));
  for (int y = 0; y < h; ++y) rows[std::size_t(y)] = packed.data() + std::size_t(y) * rowBytes;
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  std::fclose(f);
}

// The check before reading decodes every kind of PNG as OpenImageIO does: interlaced (Adam7),
// 16-bit, sub-byte grey, grey + alpha; each loads with its samples (scaled to [0, 1]) and
// nothing on stderr: the check refuses no valid file.
TEST_F(ImageFiles, PngVariantsStillLoad) {
  struct Variant {
    int bits, colourType;
    bool interlaced;
  };
  for (const Variant& v : {Variant{8, PNG_COLOR_TYPE_RGB, true}, Variant{16, PNG_COLOR_TYPE_RGB, true},
                           Variant{16, PNG_COLOR_TYPE_GRAY, false}, Variant{2, PNG_COLOR_TYPE_GRAY, true},
                           Variant{8, PNG_COLOR_TYPE_GRAY_ALPHA, true}}) {
    const std::string name = "v" + std::to_string(v.bits) + "_" + std::to_string(v.colourType) +
                             (v.interlaced ? "_adam7" : "") + ".png";
    const std::string path = (dir_ / name).string();
    std::vector<std::uint16_t> samples;
    writePngVariant(path, 13, 11, v.bits, v.colourType, v.interlaced, &samples);
    testing::internal::CaptureStderr();
    Image im;
    try {
      im = readImage(path);
    } catch (const Error& e) {
      ADD_FAILURE() << name << ": " << e.what();
    }
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "") << name;
    ASSERT_EQ(im.pixels.size(), samples.size()) << name;
    const float scale = 1.0f / float((1 << v.bits) - 1);
    // OpenImageIO hands alpha images over premultiplied (its default): grey times alpha
    const bool alpha = v.colourType == PNG_COLOR_TYPE_GRAY_ALPHA;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      float expected = float(samples[i]) * scale;
      // (it multiplies in the file's 8 bits and drops the fraction: up to one 1/255 step lower)
      const bool premultiplied = alpha && i % 2 == 0;
      if (premultiplied) expected *= float(samples[i + 1]) * scale;
      ASSERT_NEAR(im.pixels[i], expected, premultiplied ? 1.0f / 255 + 1e-6f : 1e-6f)
          << name << " sample " << i;
    }
  }
}

// readImage reads in strips of about 16 MiB (rows, or rows of tiles); an image of several strips,
// scanline and tiled (tiles that do not divide the size), holds exactly what OpenImageIO's
// whole-image read gives. So does a constant image in DWAB, which packs its 25 MB of floats in
// about 2 KB: over the 4096:1 expansion up to which the whole image is allocated at once, so its
// pixels grow strip by strip as they are read.
TEST_F(ImageFiles, StripReadsMatchTheWholeImageRead) {
  const Image varied = pattern(1501, 1499, 4);  // 24,016-byte rows: 698 rows a strip, 3 strips
  Image constant(2048, 1024, 3);
  for (std::size_t i = 0; i < constant.pixels.size(); ++i) constant.pixels[i] = 0.25f * (1 + i % 3);
  for (int tile : {0, 64, -1}) {
    const Image& im = tile >= 0 ? varied : constant;
    const std::string path = (dir_ / ("strips_" + std::to_string(tile) + ".exr")).string();
    OIIO::ImageSpec spec(im.width, im.height, im.channels, OIIO::TypeDesc::FLOAT);
    if (tile > 0) spec.tile_width = spec.tile_height = tile;
    if (tile < 0) spec.attribute("compression", "dwab");
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out && out->open(path, spec)) << path;
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, im.pixels.data())) << path;
    out->close();
    if (tile < 0)
      ASSERT_GT(im.pixels.size() * sizeof(float), fs::file_size(path) * 4096) << path;
    auto in = OIIO::ImageInput::open(path);
    ASSERT_TRUE(in) << path;
    ASSERT_EQ(in->spec().tile_width, std::max(tile, 0)) << path;
    std::vector<float> whole(im.pixels.size());
    ASSERT_TRUE(in->read_image(0, 0, 0, im.channels, OIIO::TypeDesc::FLOAT, whole.data()));
    in->close();
    const Image read = readImage(path);
    ASSERT_EQ(read.pixels.size(), whole.size());
    EXPECT_EQ(std::memcmp(read.pixels.data(), whole.data(), whole.size() * sizeof(float)), 0)
        << path;
  }
}

// A file is read by what it holds, not by its name: a PNG named .exr and an EXR named .png load
// with the pixels they hold.
TEST_F(ImageFiles, MislabelledFilesLoadByContent) {
  const Image im = pattern(9, 4, 3);
  writeImage((dir_ / "a.png").string(), im);
  writeImage((dir_ / "b.exr").string(), im);
  fs::copy_file(dir_ / "a.png", dir_ / "a_is_png.exr");
  fs::copy_file(dir_ / "b.exr", dir_ / "b_is_exr.png");
  EXPECT_EQ(readImage((dir_ / "a_is_png.exr").string()).pixels,
            readImage((dir_ / "a.png").string()).pixels);
  const Image exr = readImage((dir_ / "b_is_exr.png").string());
  const Image exrNamedRight = readImage((dir_ / "b.exr").string());
  ASSERT_EQ(exr.pixels.size(), im.pixels.size());
  ASSERT_EQ(exrNamedRight.pixels.size(), im.pixels.size());
  // The EXR keeps the floats, which the PNG could not; pixel 0 is the NaN.
  EXPECT_TRUE(std::isnan(exr.pixels[0]));
  for (std::size_t i = 1; i < im.pixels.size(); ++i) {
    ASSERT_EQ(exr.pixels[i], im.pixels[i]) << i;
    ASSERT_EQ(exrNamedRight.pixels[i], im.pixels[i]) << i;
  }
}

// The module comes from this build: its table says so, and a second call returns the same one.
TEST(ImageModule, LoadsOnceFromBesideLibpenumbra) {
  const detail::ImageCodec& a = detail::imageCodec();
  EXPECT_EQ(a.abi, detail::kImageCodecAbi);
  EXPECT_STREQ(a.version, PENUMBRA_VERSION);
  EXPECT_EQ(&a, &detail::imageCodec());
}
