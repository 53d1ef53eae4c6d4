// Image files: PNG written with libpng (core/png.hpp) against OpenImageIO's writer in the module
// (core/image_codec.hpp), byte for byte; the module's loading; the PNG writer's failures; damaged
// and mislabelled files on reading.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

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

// A damaged PNG is refused before libpng sees it, with one message naming the file and nothing
// of libpng's own on stderr (libpng prints "libpng error: ..." when OpenImageIO's reader hits a
// truncation or a bad CRC). Cut at every kind of place (inside the signature, a chunk header, a
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
  for (std::size_t start : starts) {
    std::string flipped = bytes;
    // A byte of the data where there is data, else of the CRC.
    const std::size_t pos = start + (start == iend ? 8 : 9);
    flipped[pos] = char(flipped[pos] ^ 0x5a);
    damaged.emplace_back("flipped_at_" + std::to_string(pos) + ".png", flipped);
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
                                  what.find("CRC") != std::string::npos
                            : what.find("cannot read image") != std::string::npos)
          << name << ": " << what;
      EXPECT_EQ(err, "") << name << ": something besides the one message";
    }
  }
  // The undamaged file still loads.
  EXPECT_EQ(readImage(good.string()).width, 37);
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
