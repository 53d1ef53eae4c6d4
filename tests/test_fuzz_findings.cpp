// What the fuzz targets (tests/fuzz) found, as unit tests of the refusal each finding now gets.
// The inputs that found them are replayed as they are by the sanitizer build
// (tests/data/fuzz/crashes/<target>/); these tests pin the behaviour in every build.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/error.hpp"
#include "penumbra/image.hpp"
#include "penumbra/lights.hpp"

using namespace penumbra;

namespace {

// A fuzz_envmap regression input as the loader saw it: its first byte picked the extension, the
// rest is the file, written here under a temporary name ending in `ext`. Returns the path and the
// input's size.
std::pair<std::string, std::size_t> envmapReplay(const std::string& name, const std::string& ext) {
  std::ifstream in(std::string(PENUMBRA_TEST_DATA) + "/fuzz/crashes/envmap/" + name,
                   std::ios::binary);
  const std::string input((std::istreambuf_iterator<char>(in)), {});
  const std::string path = testing::TempDir() + "/penumbra_replay_" + std::to_string(::getpid()) +
                           ext;
  std::ofstream(path, std::ios::binary) << (input.empty() ? input : input.substr(1));
  return {path, input.size()};
}

// Expects load() to refuse with one BadInput message that names `path` and holds every `part`.
template <class Load>
void expectRefused(Load&& load, const std::string& path,
                   std::initializer_list<const char*> parts) {
  try {
    load();
    ADD_FAILURE() << "accepted " << path;
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    for (const char* part : parts) EXPECT_NE(msg.find(part), std::string::npos) << msg;
  }
}

}  // namespace

// fuzz_lightset: a "regions" entry beyond int's range was converted to int (undefined behaviour,
// reported by UBSan; in practice INT_MIN, accepted). Every entry must be a whole number in
// 0..INT_MAX, and the message names the light and the field.
TEST(FuzzFindings, LightSetRegionsMustBeIntegersInRange) {
  // (1e400, beyond double's range, is refused by the JSON parser itself: test_json.cpp)
  const char* bad[] = {"8.8e99", "-1", "1.5", "\"3\"", "null", "[]"};
  for (const char* v : bad) {
    const std::string text = std::string("{\"lights\": [{\"direction\": [0, 1, 0], ") +
                             "\"half_angle_deg\": 5, \"radiance\": [1, 1, 1], " +
                             "\"regions\": [[1, 0, 0, " + v + ", 4]]}]}";
    try {
      lightSetFromJson(text, "regions.json");
      ADD_FAILURE() << "accepted a region coordinate " << v;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      const std::string msg = e.what();
      EXPECT_NE(msg.find("regions.json"), std::string::npos) << msg;
      EXPECT_NE(msg.find("\"regions\""), std::string::npos) << v << ": " << msg;
    }
  }
  // The largest accepted value still loads, as the integer it is.
  const LightSet ok = lightSetFromJson(
      "{\"lights\": [{\"direction\": [0, 1, 0], \"half_angle_deg\": 5, \"radiance\": [1, 1, 1], "
      "\"regions\": [[1, 0, 0, 2147483647, 4]]}]}",
      "regions.json");
  ASSERT_EQ(ok.lights.size(), 1u);
  ASSERT_EQ(ok.lights[0].regions.size(), 1u);
  EXPECT_EQ(ok.lights[0].regions[0][3], 2147483647);
}

// fuzz_envmap: a 1 KB EXR whose header declares a 1.7 GB string attribute ('capDate'); OpenEXR
// allocated it while parsing, 1.9 GB and 8 s before refusing. readImage now walks the header's
// attribute sizes against the file first. The fuzz input's first byte picks the extension; the
// file itself is the rest.
TEST(FuzzFindings, ExrAttributeLargerThanTheFileIsRefusedFirst) {
  const auto replay = envmapReplay("exr_1kb_needs_1.9GB", ".exr");
  const std::string path = replay.first;  // a plain variable: C++17 lambdas cannot capture bindings
  const std::size_t size = replay.second;
  ASSERT_GT(size, 100u);
  rusage before{}, after{};
  getrusage(RUSAGE_SELF, &before);
  const auto t0 = std::chrono::steady_clock::now();
  expectRefused([&] { readImage(path); }, path, {"attribute 'capDate'", "remain in the file"});
  getrusage(RUSAGE_SELF, &after);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0);
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 256 * 1024) << "KiB";
  std::remove(path.c_str());
  // A valid EXR still loads (its header walked the same way).
  EXPECT_EQ(readImage(std::string(PENUMBRA_TEST_DATA) + "/envmaps/bad/one_pixel.exr").width, 1);
}

// fuzz_envmap: an 847-byte PNG (a 16x8 image's header chunks) whose second tEXt chunk declares
// 1,895,825,680 bytes; libpng allocated them before refusing: 2 GB resident and 3.6 s, over the
// fuzzer's 2 GB limit. readImage now walks the chunk lengths against the file first.
TEST(FuzzFindings, PngChunkLargerThanTheFileIsRefusedFirst) {
  const auto replay = envmapReplay("png_847b_text_chunk_declares_1.9GB", ".png");
  const std::string path = replay.first;  // a plain variable: C++17 lambdas cannot capture bindings
  const std::size_t size = replay.second;
  ASSERT_GT(size, 100u);
  rusage before{}, after{};
  getrusage(RUSAGE_SELF, &before);
  const auto t0 = std::chrono::steady_clock::now();
  expectRefused([&] { readImage(path); }, path, {"PNG chunk 'tEXt' declares 1895825680 bytes"});
  // Reading only the attributes opens the file too: the same walk comes first.
  expectRefused([&] { readImageAttributes(path); }, path,
                {"PNG chunk 'tEXt' declares 1895825680 bytes"});
  getrusage(RUSAGE_SELF, &after);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0);
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 256 * 1024) << "KiB";
  std::remove(path.c_str());
  // A valid PNG still loads (its chunks walked the same way): one written here.
  Image im(3, 2, 3);
  for (float& v : im.pixels) v = 0.5f;
  const std::string ok = testing::TempDir() + "/penumbra_ok_" + std::to_string(::getpid()) + ".png";
  writeImage(ok, im);
  EXPECT_EQ(readImage(ok).width, 3);
  std::remove(ok.c_str());
}

// fuzz_envmap: a 619-byte EXR (one_pixel.exr's header with its data window widened) declaring
// 3,276,801 x 1 float RGB pixels. OpenImageIO buffers at least 256 scanlines when it reads
// (ImageInput::read_scanlines), whatever the height: new char[10,066,332,672], over the fuzzer's
// 2 GB limit. readImage now refuses rows over 4 MiB before reading. The allocation is never
// touched in a release build, so the message, not the memory, is what this test can see.
TEST(FuzzFindings, ImageRowsTooWideForTheReaderAreRefused) {
  const auto replay = envmapReplay("exr_619b_3276801x1_needs_10GB", ".exr");
  const std::string path = replay.first;  // a plain variable: C++17 lambdas cannot capture bindings
  const std::size_t size = replay.second;
  ASSERT_EQ(size, 619u);
  expectRefused([&] { readImage(path); }, path,
                {"image rows are too wide (3276801 pixels of 12 bytes"});
  std::remove(path.c_str());
  // The limit's edge: a float RGBA row of 262,144 pixels is exactly 4 MiB and loads; one pixel
  // more is refused.
  for (int w : {262144, 262145}) {
    Image im(w, 1, 4);
    for (float& v : im.pixels) v = 0.25f;
    const std::string p = testing::TempDir() + "/penumbra_row_" + std::to_string(w) + "_" +
                          std::to_string(::getpid()) + ".exr";
    writeImage(p, im);
    if (w == 262144) {
      EXPECT_EQ(readImage(p).width, w);
    } else {
      expectRefused([&] { readImage(p); }, p, {"image rows are too wide"});
    }
    std::remove(p.c_str());
  }
}

// fuzz_envmap: a 51-byte PFM declaring 4141 x 41411 RGB floats (171 million pixels, under the
// 2^28 limit) had its 2 GB allocated before the read found no data behind the header. readImage
// now allocates the whole image only where the file could hold it (at most 4096:1 expansion);
// otherwise the pixels grow strip by strip as they are read, so this file is refused after its
// first 16 MiB strip.
TEST(FuzzFindings, PixelsTheFileCannotHoldAreNotAllocated) {
  const auto replay = envmapReplay("pfm_51b_declares_4141x41411_needs_2GB", ".pfm");
  const std::string path = replay.first;  // a plain variable: C++17 lambdas cannot capture bindings
  ASSERT_EQ(replay.second, 51u);
  rusage before{}, after{};
  getrusage(RUSAGE_SELF, &before);
  expectRefused([&] { readImage(path); }, path, {"image data is corrupt or truncated", "of 41411"});
  getrusage(RUSAGE_SELF, &after);
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 256 * 1024) << "KiB";
  std::remove(path.c_str());
  // A PFM whose data is all there still loads: 1.4 million pixels in a 16 MB file (no
  // expansion: allocated at once), read in two strips. PFM (written by hand: OpenImageIO has no
  // PFM writer) holds "PF", the size, a negative scale for little-endian, then the rows from the
  // bottom up.
  const int w = 1400, h = 1000;
  std::vector<float> pixels(std::size_t(w) * h * 3);
  for (std::size_t i = 0; i < pixels.size(); ++i) pixels[i] = float(i % 1013) / 7.0f;
  const std::string p = testing::TempDir() + "/penumbra_strips_" + std::to_string(::getpid()) +
                        ".pfm";
  {
    std::ofstream out(p, std::ios::binary);
    out << "PF\n" << w << " " << h << "\n-1.0\n";
    for (int y = h - 1; y >= 0; --y)
      out.write(reinterpret_cast<const char*>(pixels.data() + std::size_t(y) * w * 3),
                std::streamsize(std::size_t(w) * 3 * sizeof(float)));
  }
  const Image back = readImage(p);
  EXPECT_EQ(back.width, w);
  EXPECT_EQ(back.height, h);
  EXPECT_EQ(back.pixels, pixels);
  std::remove(p.c_str());
}
