// Pictures: error heat maps (heatmap.hpp: where the error is hottest, the scale bar, the grey
// background, refused inputs) and the light overlay's labels (extraction.hpp lightOverlay).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/extraction.hpp"
#include "penumbra/heatmap.hpp"
#include "penumbra/image.hpp"
#include "penumbra/lights.hpp"
#include "common/shared.h"
#include "support/expect_error.hpp"

namespace {

using namespace penumbra;
using penumbra::test::expectBadInput;
namespace fs = std::filesystem;

constexpr int kW = 160, kH = 80;
// Columns left of this are background (alpha 0) in the reference.
constexpr int kBackgroundColumns = 20;
// The block that differs: 40 x 40 of the 140 x 80 geometry pixels (about 14%, above the 99th
// percentile's 1%, so the automatic scale is the block's own error rounded up).
constexpr int kBlockX = 100, kBlockY = 20, kBlock = 40;

Image referenceImage() {
  Image im(kW, kH, 4, 1.0f);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kBackgroundColumns; ++x) {
      im.at(x, y, 3) = 0.0f;
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = 7.0f;  // whatever the map shows there
    }
  return im;
}

bool inBlock(int x, int y) {
  return x >= kBlockX && x < kBlockX + kBlock && y >= kBlockY && y < kBlockY + kBlock;
}

// The reference with the block's RGB set to `value` (its luminance too: grey).
Image testImage(float value) {
  Image im = referenceImage();
  for (int y = kBlockY; y < kBlockY + kBlock; ++y)
    for (int x = kBlockX; x < kBlockX + kBlock; ++x)
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = value;
  return im;
}

double lum(const Image& im, int x, int y) {
  return PB_LUM_R * im.at(x, y, 0) + PB_LUM_G * im.at(x, y, 1) + PB_LUM_B * im.at(x, y, 2);
}

bool sameColour(const Image& a, int ax, int ay, const Image& b, int bx, int by) {
  for (int c = 0; c < 3; ++c)
    if (a.at(ax, ay, c) != b.at(bx, by, c)) return false;
  return true;
}

// Equal up to float rounding in the colour map's interpolation.
bool nearColour(const Image& a, int ax, int ay, const Image& b, int bx, int by) {
  for (int c = 0; c < 3; ++c)
    if (std::fabs(a.at(ax, ay, c) - b.at(bx, by, c)) > 0.01f) return false;
  return true;
}

// A row of the scale bar's colour strip: just under the image and its 2-row gap.
int barRow(const Heatmap& h) { return h.imageHeight + 3; }

TEST(Heatmap, HottestColourWhereTheDifferenceIs) {
  // The block is 30% brighter; mean luminance of the reference is 1: error 0.3 there, 0 elsewhere.
  const Heatmap h = errorHeatmap(testImage(1.3f), referenceImage());
  // 0.3 rounded up to 1, 2 or 5 x 10^k is 0.5.
  EXPECT_DOUBLE_EQ(h.scale, 0.5);
  ASSERT_EQ(h.image.width, kW);
  ASSERT_EQ(h.imageHeight, kH);
  ASSERT_EQ(h.image.channels, 3);
  // Inside the block: the hottest pixel of the picture; elsewhere on the geometry: the bar's low end.
  double hottest = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = kBackgroundColumns; x < kW; ++x) hottest = std::max(hottest, lum(h.image, x, y));
  int wrong = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = kBackgroundColumns; x < kW; ++x) {
      if (inBlock(x, y))
        wrong += lum(h.image, x, y) != hottest;
      else
        wrong += !sameColour(h.image, x, y, h.image, 0, barRow(h));
    }
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(hottest, lum(h.image, 0, barRow(h)) + 0.2);
  // At scale 0.3 the block reaches the top of the colour map: the bar's right end.
  HeatmapOptions tight;
  tight.scale = 0.3;
  const Heatmap t = errorHeatmap(testImage(1.3f), referenceImage(), tight);
  EXPECT_EQ(t.scale, 0.3);
  EXPECT_TRUE(nearColour(t.image, kBlockX + 5, kBlockY + 5, t.image, kW - 1, barRow(t)));
  EXPECT_FALSE(nearColour(h.image, kBlockX + 5, kBlockY + 5, h.image, kW - 1, barRow(h)));
}

TEST(Heatmap, ScaleBarUnderTheImage) {
  const Heatmap h = errorHeatmap(testImage(1.3f), referenceImage());
  ASSERT_GT(h.image.height, kH + 6);
  // The strip runs from the map's dark end to its light end, left to right.
  double previous = -1;
  for (int x = 0; x < kW; x += 8) {
    const double l = lum(h.image, x, barRow(h));
    EXPECT_GE(l, previous - 1e-6) << x;
    previous = l;
  }
  EXPECT_GT(lum(h.image, kW - 1, barRow(h)), lum(h.image, 0, barRow(h)) + 0.5);
  // The labels (160 pixels is wide enough for them): some white text in the bottom rows.
  int white = 0;
  for (int y = h.image.height - 14; y < h.image.height; ++y)
    for (int x = 0; x < kW; ++x) white += lum(h.image, x, y) > 0.9;
  EXPECT_GT(white, 10);
  // Without the bar: just the image.
  HeatmapOptions bare;
  bare.scaleBar = false;
  const Heatmap b = errorHeatmap(testImage(1.3f), referenceImage(), bare);
  EXPECT_EQ(b.image.height, kH);
  EXPECT_EQ(b.imageHeight, kH);
  for (int x = 0; x < kW; ++x) EXPECT_TRUE(sameColour(b.image, x, kH - 1, h.image, x, kH - 1));
}

TEST(Heatmap, BackgroundIsNeutralGrey) {
  for (HeatmapMetric metric :
       {HeatmapMetric::RelativeError, HeatmapMetric::SignedRelativeError, HeatmapMetric::Flip}) {
    HeatmapOptions o;
    o.metric = metric;
    const Heatmap h = errorHeatmap(testImage(1.3f), referenceImage(), o);
    int notGrey = 0, grey = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        bool isGrey = true;
        for (int c = 0; c < 3; ++c) isGrey = isGrey && h.image.at(x, y, c) == kHeatmapBackground;
        if (x < kBackgroundColumns)
          notGrey += !isGrey;
        else
          grey += isGrey;
      }
    EXPECT_EQ(notGrey, 0) << int(metric);
    EXPECT_EQ(grey, 0) << int(metric);
  }
}

TEST(Heatmap, SignedAndFlipMetrics) {
  HeatmapOptions o;
  o.metric = HeatmapMetric::SignedRelativeError;
  const Image ref = referenceImage();
  const Heatmap brighter = errorHeatmap(testImage(1.3f), ref, o);
  const Heatmap darker = errorHeatmap(testImage(0.7f), ref, o);
  const int x = kBlockX + 5, y = kBlockY + 5;
  EXPECT_GT(brighter.image.at(x, y, 0), brighter.image.at(x, y, 2) + 0.3);  // red
  EXPECT_GT(darker.image.at(x, y, 2), darker.image.at(x, y, 0) + 0.3);      // blue
  // No error: the bar's middle (white), not either end.
  EXPECT_GT(lum(brighter.image, 30, 5), 0.9);
  o.metric = HeatmapMetric::Flip;
  const Heatmap same = errorHeatmap(ref, ref, o);
  const Heatmap differs = errorHeatmap(testImage(0.2f), ref, o);
  EXPECT_EQ(same.scale, 1.0);
  EXPECT_TRUE(sameColour(same.image, x, y, same.image, 0, barRow(same)));
  EXPECT_GT(lum(differs.image, x, y), lum(same.image, x, y) + 0.2);
}

TEST(Heatmap, RefusesBadInput) {
  const Image ref = referenceImage();
  expectBadInput([&] { errorHeatmap(Image(16, 8, 4, 1.0f), ref); },
                 {"test is 16x8", "reference is 160x80"});
  expectBadInput([&] { errorHeatmap(ref, Image(16, 8, 3, 1.0f)); },
                 {"test is 160x80", "reference is 16x8"});
  expectBadInput([&] { errorHeatmap(Image(kW, kH, 1, 1.0f), ref); }, {"test", "channel"});
  expectBadInput([&] { errorHeatmap(Image(), ref); }, {"test is empty"});
  HeatmapOptions o;
  o.scale = -1;
  expectBadInput([&] { errorHeatmap(ref, ref, o); }, {"HeatmapOptions.scale"});
  Image nan = testImage(1.0f);
  nan.at(kBlockX, kBlockY, 1) = std::nanf("");
  expectBadInput([&] { errorHeatmap(nan, ref); }, {"test", "non-finite"});
  expectBadInput([&] { errorHeatmap(ref, Image(kW, kH, 3, 0.0f)); }, {"mean luminance"});
  expectBadInput([&] { errorHeatmap(ref, Image(kW, kH, 4, 0.0f)); }, {"no geometry pixel"});
  const fs::path dir = fs::temp_directory_path() / ("penumbra_heatmap_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  expectBadInput([&] { writeHeatmap((dir / "diff.xyz").string(), ref, ref); }, {"diff.xyz"});
  expectBadInput([&] { writeHeatmap((dir / "no/such/diff.png").string(), ref, ref); },
                 {"does not exist"});
  fs::remove_all(dir);
}

TEST(Heatmap, WrittenAsShown) {
  const fs::path dir = fs::temp_directory_path() / ("penumbra_heatmap_w" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "diff.png").string();
  const double scale = writeHeatmap(path, testImage(1.3f), referenceImage());
  const Heatmap h = errorHeatmap(testImage(1.3f), referenceImage());
  EXPECT_EQ(scale, h.scale);
  const Image back = readImage(path);
  ASSERT_EQ(back.width, h.image.width);
  ASSERT_EQ(back.height, h.image.height);
  ASSERT_GE(back.channels, 3);
  double worst = 0;
  for (int y = 0; y < back.height; ++y)
    for (int x = 0; x < back.width; ++x)
      for (int c = 0; c < 3; ++c)
        worst = std::max(worst, double(std::fabs(back.at(x, y, c) - h.image.at(x, y, c))));
  EXPECT_LE(worst, 0.5 / 255 + 1e-6);  // 8 bits, rounded: no tone mapping on the way
  fs::remove_all(dir);
}

// Two caps on a dim map: labels beside each centre, nothing else changed.
TEST(LightOverlay, LabelsBesideEachLight) {
  Environment env;
  env.source = "test";
  env.equirect = Image(128, 64, 3, 0.1f);
  LightSet set;
  for (const auto& [dir, power] : {std::pair{std::array<float, 3>{0.6f, 0.6f, 0.529f}, 3.0f},
                                   std::pair{std::array<float, 3>{-0.5f, 0.3f, -0.812f}, 1.0f}}) {
    AreaLight l;
    l.direction = dir;
    l.cosAlpha = std::cos(0.1f);
    l.setPower({power, power, power});
    set.lights.push_back(l);
  }
  const Image plain = lightOverlay(env, set, false), labelled = lightOverlay(env, set, true);
  ASSERT_EQ(labelled.width, plain.width);
  ASSERT_EQ(labelled.height, plain.height);
  EXPECT_GE(labelled.width, 1024);
  const int W = labelled.width, H = labelled.height;
  std::vector<std::array<float, 2>> centres;
  for (const AreaLight& l : set.lights) {
    float s, t;
    pb_dir_equirect(l.direction[0], l.direction[1], l.direction[2], float(W), float(H), &s, &t);
    centres.push_back({s, t});
  }
  std::vector<int> near(centres.size(), 0);
  int far = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      bool differs = false;
      for (int c = 0; c < 3; ++c) differs = differs || labelled.at(x, y, c) != plain.at(x, y, c);
      if (!differs) continue;
      bool counted = false;
      for (std::size_t i = 0; i < centres.size(); ++i)
        if (std::hypot(x - centres[i][0], y - centres[i][1]) < 120) {
          ++near[i];
          counted = true;
        }
      far += !counted;
    }
  for (std::size_t i = 0; i < near.size(); ++i) EXPECT_GT(near[i], 50) << "light " << i;
  EXPECT_EQ(far, 0);
  // The file holds the labelled overlay, byte for byte.
  const fs::path dir = fs::temp_directory_path() / ("penumbra_overlay_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  writeLightOverlay((dir / "overlay.png").string(), env, set);
  const Image back = readImage((dir / "overlay.png").string());
  ASSERT_EQ(back.width, W);
  ASSERT_EQ(back.height, H);
  int mismatched = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < 3; ++c)
        mismatched += std::lround(back.at(x, y, c) * 255) != std::lround(labelled.at(x, y, c) * 255);
  EXPECT_EQ(mismatched, 0);
  fs::remove_all(dir);
}

}  // namespace
