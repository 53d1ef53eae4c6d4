// LDR-FLIP and HDR-FLIP (penumbra::flip) against properties that follow from the papers (Andersson
// et al. 2020 and 2021): zero for identical images, 1 for the gamut's largest colour difference,
// the colour mapping's breakpoint, symmetry, growth with colour distance, features outweighing a
// uniform shift, the HDR exposure range computed by hand, HDR growth with the test's scale, tiny
// images, masks, bad input, and a cross-check against NVlabs' reference implementation.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <utility>

#include "penumbra/error.hpp"
#include "penumbra/flip.hpp"
#include "support/expect_error.hpp"

using namespace penumbra;
using penumbra::test::expectBadInput;

namespace {

Image uniform(int w, int h, float r, float g, float b) {
  Image im(w, h, 3);
  for (int i = 0; i < w * h; ++i) {
    im.pixels[i * 3 + 0] = r;
    im.pixels[i * 3 + 1] = g;
    im.pixels[i * 3 + 2] = b;
  }
  return im;
}

Image randomImage(int w, int h, unsigned seed, float lo, float hi) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  Image im(w, h, 3);
  for (float& v : im.pixels) v = u(rng);
  return im;
}

FlipOptions ldr() {
  FlipOptions o;
  o.hdr = false;
  return o;
}

// The tone mapper's input that outputs t (Andersson et al. 2021: ACES fit after a 0.6 pre-scale,
// (0.6x)(2.51(0.6x) + 0.03) / ((0.6x)(2.43(0.6x) + 0.59) + 0.14) = t), solved here by bisection
// on the written-out curve rather than by the library's quadratic formula.
double acesInverse(double t) {
  auto aces = [](double x) {
    const double v = 0.6 * x;
    return v * (2.51 * v + 0.03) / (v * (2.43 * v + 0.59) + 0.14);
  };
  double lo = 0, hi = 100;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (aces(mid) < t ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

TEST(Flip, IdenticalImagesGiveZero) {
  const Image a = randomImage(37, 23, 1, 0.0f, 1.0f);
  const FlipResult l = flip(a, a, ldr());
  EXPECT_EQ(l.mean, 0.0);
  for (float v : l.map.pixels) ASSERT_EQ(v, 0.0f);

  const Image h = randomImage(37, 23, 2, 0.0f, 20.0f);
  const FlipResult r = flip(h, h);
  EXPECT_EQ(r.mean, 0.0);
  for (float v : r.map.pixels) ASSERT_EQ(v, 0.0f);
  EXPECT_GE(r.exposures, 2);
}

// c_max is defined as the (q_c-powered) HyAB distance of green and blue (Andersson et al. 2020,
// colour pipeline), so uniform green against uniform blue (no features) maps to exactly 1.
TEST(Flip, GreenAgainstBlueIsTheMaximum) {
  const FlipResult r = flip(uniform(9, 7, 0, 1, 0), uniform(9, 7, 0, 0, 1), ldr());
  EXPECT_NEAR(r.mean, 1.0, 1e-5);
  for (float v : r.map.pixels) EXPECT_NEAR(v, 1.0, 1e-5);
}

// Black against white is not the maximum: HyAB = 100 (L* 0 vs 100, no chroma) raised to q_c lies
// above p_c c_max, so it lands on the upper segment of the colour mapping (Andersson et al. 2020,
// colour pipeline), 0.95 + 0.05 (100^0.7 - 0.4 c_max) / (0.6 c_max). c_max from the published
// CIELAB (D65) values of the sRGB primaries, green (87.73, -86.18, 83.18) and blue (32.30, 79.19,
// -107.86), with the Hunt adjustment (a, b scaled by L/100).
TEST(Flip, BlackAgainstWhiteFollowsTheColourMapping) {
  const double gL = 87.73, ga = -86.18 * gL / 100, gb = 83.18 * gL / 100;
  const double bL = 32.30, ba = 79.19 * bL / 100, bb = -107.86 * bL / 100;
  const double cmax = std::pow(std::fabs(gL - bL) + std::hypot(ga - ba, gb - bb), 0.7);
  const double d = std::pow(100.0, 0.7);
  ASSERT_GT(d, 0.4 * cmax);
  const double expected = 0.95 + 0.05 * (d - 0.4 * cmax) / (0.6 * cmax);
  const FlipResult r = flip(uniform(8, 8, 0, 0, 0), uniform(8, 8, 1, 1, 1), ldr());
  EXPECT_NEAR(r.mean, expected, 1e-3);
  EXPECT_LT(r.mean, 1.0);
  EXPECT_GT(r.mean, 0.95);
}

TEST(Flip, LdrLiesInUnitRangeAndIsSymmetric) {
  for (unsigned seed = 10; seed < 14; ++seed) {
    // Values past [0,1] are clamped by LDR-FLIP; include some to exercise that.
    const Image a = randomImage(41, 29, seed, -0.2f, 1.2f),
                b = randomImage(41, 29, seed + 100, -0.2f, 1.2f);
    const FlipResult ab = flip(a, b, ldr()), ba = flip(b, a, ldr());
    EXPECT_GT(ab.mean, 0.0);
    EXPECT_LT(ab.mean, 1.0);
    for (float v : ab.map.pixels) {
      ASSERT_GE(v, 0.0f);
      ASSERT_LE(v, 1.0f);
    }
    // HyAB and the feature differences are symmetric, so LDR-FLIP is too.
    for (std::size_t i = 0; i < ab.map.pixels.size(); ++i)
      ASSERT_NEAR(ab.map.pixels[i], ba.map.pixels[i], 1e-6);
    EXPECT_EQ(ab.startExposure, 0.0);
    EXPECT_EQ(ab.exposures, 0);
  }
}

// A uniform colour difference has no features, so FLIP is the colour error alone, a monotone map
// of the HyAB distance: it grows with the distance in every direction of colour.
TEST(Flip, ErrorGrowsWithColourDistance) {
  const Image grey = uniform(16, 16, 0.4f, 0.4f, 0.4f);
  for (int c = 0; c < 3; ++c) {
    double last = 0;
    for (float d : {0.02f, 0.05f, 0.1f, 0.2f, 0.4f}) {
      Image t = grey;
      for (int i = 0; i < 16 * 16; ++i) t.pixels[i * 3 + c] += d;
      const double m = flip(t, grey, ldr()).mean;
      EXPECT_GT(m, last) << "channel " << c << ", step " << d;
      last = m;
    }
  }
}

// Andersson et al. 2020, final error: feature differences raise the colour error towards 1
// (Delta E_c ^ (1 - Delta E_f) >= Delta E_c). Around an edge moved by one pixel, the error is
// larger than for the same total difference spread uniformly over that neighbourhood, which
// changes no feature. The comparison is over the columns within 3 pixels of the edge (a mask).
TEST(Flip, ShiftedEdgeOutweighsUniformShiftOfSameMeanDifference) {
  const int w = 32, h = 16, half = 3;
  const float lo = 0.2f, hi = 0.8f;
  Image ref(w, h, 3), shifted(w, h, 3), near(w, h, 1, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c) {
        ref.at(x, y, c) = x < w / 2 ? lo : hi;
        shifted.at(x, y, c) = x < w / 2 + 1 ? lo : hi;
      }
      if (std::abs(x - w / 2) <= half) near.at(x, y, 0) = 1.0f;
    }
  // Same mean absolute difference over the masked columns: (hi - lo) in one column of 2 half + 1.
  const float step = (hi - lo) / (2 * half + 1);
  Image uniformShift = ref;
  for (float& v : uniformShift.pixels) v += step;
  double diffShifted = 0, diffUniform = 0;
  for (int y = 0; y < h; ++y)
    for (int x = w / 2 - half; x <= w / 2 + half; ++x)
      for (int c = 0; c < 3; ++c) {
        diffShifted += std::fabs(shifted.at(x, y, c) - ref.at(x, y, c));
        diffUniform += std::fabs(uniformShift.at(x, y, c) - ref.at(x, y, c));
      }
  ASSERT_NEAR(diffShifted, diffUniform, 1e-3 * diffShifted);
  const double edge = flip(shifted, ref, ldr(), &near).mean;
  const double flat = flip(uniformShift, ref, ldr(), &near).mean;
  EXPECT_GT(edge, flat);
  EXPECT_GT(flat, 0.0);
}

// Andersson et al. 2021, HDR-FLIP: start = log2(x85 / Y_max), stop = log2(x85 / Y_median), with x85
// the tone mapper's input for 0.85, and max(2, ceil(stop - start)) exposures.
TEST(Flip, HdrExposureRangeFollowsThePaper) {
  const double x85 = acesInverse(0.85);
  {
    // Greys (luminance = value): sorted 0.25, 0.5, 1.5, 3, 50; median 1.5, maximum 50.
    const float v[5] = {3.0f, 0.25f, 50.0f, 1.5f, 0.5f};
    Image ref(5, 1, 3);
    for (int x = 0; x < 5; ++x)
      for (int c = 0; c < 3; ++c) ref.at(x, 0, c) = v[x];
    const FlipResult r = flip(ref, ref);
    const double start = std::log2(x85 / 50.0), stop = std::log2(x85 / 1.5);
    EXPECT_NEAR(r.startExposure, start, 1e-6);
    EXPECT_NEAR(r.stopExposure, stop, 1e-6);
    EXPECT_EQ(r.exposures, int(std::ceil(stop - start)));  // log2(50/1.5) = 5.06: 6
    EXPECT_EQ(r.exposures, 6);
  }
  {
    // Luminance weights: pure red 0.2126, pure green 0.7152 (Rec. 709); 3 pixels, median = red.
    Image ref(3, 1, 3, 0.0f);
    ref.at(0, 0, 0) = 1.0f;  // Y = 0.2126
    ref.at(1, 0, 1) = 1.0f;  // Y = 0.7152
    ref.at(2, 0, 0) = 0.5f;  // Y = 0.1063
    const FlipResult r = flip(ref, ref);
    EXPECT_NEAR(r.startExposure, std::log2(x85 / 0.7152), 1e-6);
    EXPECT_NEAR(r.stopExposure, std::log2(x85 / 0.2126), 1e-6);
    EXPECT_EQ(r.exposures, 2);  // log2(0.7152/0.2126) = 1.75: ceil 2
  }
  {
    // A narrow range still uses two exposures.
    const FlipResult r = flip(uniform(4, 4, 1, 1, 1), uniform(4, 4, 1, 1, 1));
    EXPECT_NEAR(r.startExposure, r.stopExposure, 1e-9);
    EXPECT_EQ(r.exposures, 2);
  }
  {
    // Given exposures are used as they are.
    FlipOptions o;
    o.startExposure = -3.0;
    o.stopExposure = 4.5;
    const FlipResult r = flip(randomImage(8, 8, 3, 0, 4), randomImage(8, 8, 4, 0, 4), o);
    EXPECT_EQ(r.startExposure, -3.0);
    EXPECT_EQ(r.stopExposure, 4.5);
    EXPECT_EQ(r.exposures, 8);
  }
  {
    // Only one given: the other comes from the reference.
    FlipOptions o;
    o.startExposure = -10.0;
    Image ref(5, 1, 3);
    const float v[5] = {3.0f, 0.25f, 50.0f, 1.5f, 0.5f};
    for (int x = 0; x < 5; ++x)
      for (int c = 0; c < 3; ++c) ref.at(x, 0, c) = v[x];
    const FlipResult r = flip(ref, ref, o);
    EXPECT_EQ(r.startExposure, -10.0);
    EXPECT_NEAR(r.stopExposure, std::log2(x85 / 1.5), 1e-6);
    EXPECT_EQ(r.exposures, int(std::ceil(r.stopExposure + 10.0)));
  }
}

// HDR-FLIP takes each pixel's maximum over the exposures, so it is at least the LDR-FLIP of any
// one of them: in particular of the first, and of a range holding just one exposure.
TEST(Flip, HdrIsTheMaximumOverExposures) {
  // Log-uniform values over 2^-4 .. 2^4: a range wide enough for several exposures.
  Image ref = randomImage(24, 18, 5, -4.0f, 4.0f), test = randomImage(24, 18, 6, -4.0f, 4.0f);
  for (Image* im : {&ref, &test})
    for (float& v : im->pixels) v = std::exp2(v);
  const FlipResult all = flip(test, ref);
  FlipOptions first;
  first.startExposure = first.stopExposure = all.startExposure;
  const FlipResult one = flip(test, ref, first);
  EXPECT_EQ(one.exposures, 2);
  ASSERT_GT(all.exposures, 2);
  for (std::size_t i = 0; i < all.map.pixels.size(); ++i)
    ASSERT_GE(all.map.pixels[i], one.map.pixels[i] - 1e-6f);
  EXPECT_GT(all.mean, one.mean);
}

TEST(Flip, HdrGrowsWithTheTestsScale) {
  const Image ref = randomImage(32, 24, 7, 0.01f, 10.0f);
  double last = 0;
  for (float s : {1.1f, 1.5f, 2.0f, 4.0f}) {
    Image t = ref;
    for (float& v : t.pixels) v *= s;
    const double m = flip(t, ref).mean;
    EXPECT_GT(m, last) << "scale " << s;
    last = m;
  }
}

// The CSF filters remove detail finer than the eye resolves (Andersson et al. 2020, colour
// pipeline): a one-pixel checkerboard against its mean grey matters less the more pixels per
// degree. The mean is taken away from the borders, farther than the widest filter's radius at 200
// ppd (28 pixels), so that the clamped borders do not count.
TEST(Flip, FineDetailMattersLessFartherAway) {
  const int n = 96, border = 32;
  Image checker(n, n, 3), grey = uniform(n, n, 0.5f, 0.5f, 0.5f), inner(n, n, 1, 0.0f);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      for (int c = 0; c < 3; ++c) checker.at(x, y, c) = (x + y) % 2 ? 0.3f : 0.7f;
      if (x >= border && x < n - border && y >= border && y < n - border) inner.at(x, y, 0) = 1.0f;
    }
  FlipOptions o = ldr();
  double last = 2;
  for (double ppd : {5.0, 20.0, 67.0, 200.0}) {
    o.pixelsPerDegree = ppd;
    const double m = flip(checker, grey, o, &inner).mean;
    EXPECT_LT(m, last) << "ppd " << ppd;
    last = m;
  }
}

TEST(Flip, TinyImagesWork) {
  for (auto [w, h] : {std::pair{1, 1}, std::pair{1, 7}, std::pair{9, 1}, std::pair{2, 2}}) {
    for (bool hdr : {false, true}) {
      FlipOptions o;
      o.hdr = hdr;
      const Image ref = randomImage(w, h, 8, 0, 2), test = randomImage(w, h, 9, 0, 2);
      const FlipResult r = flip(test, ref, o);
      ASSERT_EQ(r.map.width, w);
      ASSERT_EQ(r.map.height, h);
      ASSERT_EQ(r.map.channels, 1);
      for (float v : r.map.pixels) {
        EXPECT_TRUE(std::isfinite(v));
        EXPECT_GE(v, 0.0f);
        EXPECT_LE(v, 1.0f);
      }
      EXPECT_GT(r.mean, 0.0) << w << "x" << h << (hdr ? " hdr" : " ldr");
      EXPECT_EQ(flip(ref, ref, o).mean, 0.0);
    }
  }
}

// Exposures far outside float's range saturate to black or white instead of producing NaN.
TEST(Flip, ExtremeExposuresStayFinite) {
  FlipOptions o;
  // the widest range flip() accepts (128 stops): 2^120 turns 1e-30 into 1.3e6
  o.startExposure = -8;
  o.stopExposure = 120;
  Image ref = randomImage(3, 2, 23, 0, 2), test = randomImage(3, 2, 24, 0, 2);
  ref.at(0, 0, 0) = ref.at(0, 0, 1) = ref.at(0, 0, 2) = 0.0f;       // a black pixel at 2^120...
  test.at(0, 0, 0) = test.at(0, 0, 1) = test.at(0, 0, 2) = 1e-30f;  // ...against one made white
  const FlipResult r = flip(test, ref, o);
  EXPECT_GT(r.map.at(0, 0, 0), 0.5f);  // black against white at the top exposures
  EXPECT_EQ(r.exposures, 128);
  for (float v : r.map.pixels) {
    ASSERT_TRUE(std::isfinite(v));
    ASSERT_GE(v, 0.0f);
    ASSERT_LE(v, 1.0f);
  }
  EXPECT_GT(r.mean, 0.0);
  EXPECT_EQ(flip(ref, ref, o).mean, 0.0);
}

TEST(Flip, AllBlackReferenceIsHandled) {
  const Image black = uniform(6, 4, 0, 0, 0);
  const FlipResult same = flip(black, black);
  EXPECT_EQ(same.mean, 0.0);
  EXPECT_EQ(same.exposures, 2);
  const FlipResult lit = flip(uniform(6, 4, 1, 1, 1), black);
  EXPECT_GT(lit.mean, 0.5);
  // A mostly black reference: the median is 0, the dimmest lit pixel stands in.
  Image sparse = black;
  sparse.at(0, 0, 0) = sparse.at(0, 0, 1) = sparse.at(0, 0, 2) = 4.0f;
  sparse.at(1, 0, 0) = sparse.at(1, 0, 1) = sparse.at(1, 0, 2) = 0.5f;
  const FlipResult r = flip(black, sparse);
  EXPECT_NEAR(r.stopExposure - r.startExposure, 3.0, 1e-6);  // log2(4 / 0.5)
}

TEST(Flip, MaskSelectsThePixelsOfTheMean) {
  const Image ref = randomImage(20, 10, 11, 0, 3), test = randomImage(20, 10, 12, 0, 3);
  Image mask(20, 10, 2, 0.0f);
  double sum = 0;
  int n = 0;
  const FlipResult full = flip(test, ref);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 20; ++x)
      if ((x * 3 + y) % 4 == 0) {
        mask.at(x, y, 0) = 1.0f;
        sum += full.map.at(x, y, 0);
        ++n;
      } else {
        mask.at(x, y, 1) = 1.0f;  // only channel 0 counts
      }
  const FlipResult masked = flip(test, ref, {}, &mask);
  EXPECT_NEAR(masked.mean, sum / n, 1e-9);
  EXPECT_EQ(masked.map.pixels, full.map.pixels);
  EXPECT_EQ(masked.startExposure, full.startExposure);
  const Image none(20, 10, 1, 0.0f);
  EXPECT_EQ(flip(test, ref, {}, &none).mean, 0.0);
}

TEST(Flip, ExtraChannelsAreIgnored) {
  const Image ref = randomImage(12, 9, 13, 0, 2), test = randomImage(12, 9, 14, 0, 2);
  Image ref4(12, 9, 4), test4(12, 9, 4);
  for (int i = 0; i < 12 * 9; ++i)
    for (int c = 0; c < 4; ++c) {
      ref4.pixels[i * 4 + c] = c < 3 ? ref.pixels[i * 3 + c] : 0.25f;
      test4.pixels[i * 4 + c] = c < 3 ? test.pixels[i * 3 + c] : 1.0f;
    }
  EXPECT_EQ(flip(test4, ref4).map.pixels, flip(test, ref).map.pixels);
}

TEST(Flip, BadInputNamesTheArgument) {
  const Image a = randomImage(8, 6, 15, 0, 1), b = randomImage(8, 6, 16, 0, 1);
  // both sizes named, each with its argument (the message holds both words either way)
  expectBadInput([&] { flip(randomImage(7, 6, 1, 0, 1), b); }, "reference");
  expectBadInput([&] { flip(randomImage(7, 6, 1, 0, 1), b); }, "test is 7x6 but reference is 8x6");
  expectBadInput([&] { flip(a, randomImage(8, 5, 1, 0, 1)); }, "test");
  expectBadInput([&] { flip(a, randomImage(8, 5, 1, 0, 1)); }, "test is 8x6 but reference is 8x5");
  expectBadInput([&] { flip(Image(8, 6, 2), b); }, "test");
  expectBadInput([&] { flip(a, Image(8, 6, 1)); }, "reference");
  expectBadInput([&] { flip(Image(), b); }, "test");
  expectBadInput([&] { flip(a, Image()); }, "reference");
  Image nan = b;
  nan.at(3, 2, 1) = std::numeric_limits<float>::quiet_NaN();
  expectBadInput([&] { flip(a, nan); }, "reference");
  Image inf = a;
  inf.at(0, 5, 2) = std::numeric_limits<float>::infinity();
  expectBadInput([&] { flip(inf, b); }, "test");
  for (double ppd : {0.0, -3.0, 1001.0, std::numeric_limits<double>::infinity(),
                     std::numeric_limits<double>::quiet_NaN()}) {
    FlipOptions o;
    o.pixelsPerDegree = ppd;
    expectBadInput([&] { flip(a, b, o); }, "pixelsPerDegree");
  }
  FlipOptions backwards;
  backwards.startExposure = 2;
  backwards.stopExposure = 1;
  expectBadInput([&] { flip(a, b, backwards); }, "startExposure");
  FlipOptions infinite;
  infinite.stopExposure = std::numeric_limits<double>::infinity();
  expectBadInput([&] { flip(a, b, infinite); }, "stopExposure");
  // a range of more than 128 stops would take one LDR-FLIP per stop: refused, not run
  FlipOptions wide;
  wide.startExposure = -1e6;
  wide.stopExposure = 0;
  expectBadInput([&] { flip(a, b, wide); }, "startExposure..stopExposure");
  const Image wrongMask(4, 6, 1, 1.0f);
  expectBadInput([&] { flip(a, b, {}, &wrongMask); }, "mask");
}

// Cross-check against NVlabs/flip's C++ reference (src/cpp/FLIP.h, commit 1eb247c, run with
// PPD = 67 through FLIP::evaluate's float-array overload on these same synthetic images; the
// means printed there: LDR 0.1181430, HDR 0.1336705 with start -2.8383818, stop 0.0235603 and 3
// exposures). The small tolerance covers float rounding and the sRGB matrices' last digits.
TEST(Flip, MatchesTheReferenceImplementation) {
  auto refv = [](int x, int y, int c) { return float((x * 7 + y * 13 + c * 5) % 17) / 16.0f; };
  auto testv = [&](int x, int y, int c) {
    return x < 12 ? float((x * 7 + y * 13 + c * 5 + 3) % 17) / 16.0f : refv(x, y, c);
  };
  const int w = 24, h = 16;
  Image ref(w, h, 3), test(w, h, 3), refH(w, h, 3), testH(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        ref.at(x, y, c) = refv(x, y, c);
        test.at(x, y, c) = testv(x, y, c);
        refH.at(x, y, c) = 0.02f * std::exp2(10.0f * refv(x, y, c));
        testH.at(x, y, c) = 0.02f * std::exp2(10.0f * testv(x, y, c));
      }
  EXPECT_NEAR(flip(test, ref, ldr()).mean, 0.1181430, 2e-5);
  const FlipResult r = flip(testH, refH);
  EXPECT_NEAR(r.mean, 0.1336705, 2e-5);
  EXPECT_NEAR(r.startExposure, -2.8383818, 1e-5);
  EXPECT_NEAR(r.stopExposure, 0.0235603, 1e-5);
  EXPECT_EQ(r.exposures, 3);
}

// A second cross-check against the same reference implementation (as above: NVlabs/flip
// src/cpp/FLIP.h, commit 1eb247c, FLIP::evaluate's float-array overload): odd sizes, one taller
// than the implementation's bands of rows, a wider luminance range (5 exposures, start -3.8005354,
// stop 0.9713961) and two viewing distances; the means printed there are in the table.
TEST(Flip, MatchesTheReferenceImplementationAtOtherSizesAndDistances) {
  auto refv = [](int x, int y, int c) { return float((x * 5 + y * 11 + c * 3) % 13) / 12.0f; };
  auto testv = [&](int x, int y, int c) {
    return (x + y) % 3 == 0 ? refv(x, y, c) * 0.8f : refv(x, y, c);
  };
  const struct {
    int w, h;
    double ppd, ldr, hdr;
  } expected[] = {{37, 23, 20.0, 0.1563606, 0.4510136},
                  {37, 23, 67.0, 0.1400169, 0.4364364},
                  {29, 157, 20.0, 0.1548507, 0.4483036},
                  {29, 157, 67.0, 0.1379634, 0.4342222}};
  for (const auto& e : expected) {
    Image ref(e.w, e.h, 3), test(e.w, e.h, 3), refH(e.w, e.h, 3), testH(e.w, e.h, 3);
    for (int y = 0; y < e.h; ++y)
      for (int x = 0; x < e.w; ++x)
        for (int c = 0; c < 3; ++c) {
          const float a = refv(x, y, c), b = testv(x, y, c);
          ref.at(x, y, c) = a;
          test.at(x, y, c) = b;
          refH.at(x, y, c) = 0.01f * std::exp2(12.0f * a * a);
          testH.at(x, y, c) = 0.01f * std::exp2(12.0f * b * b);
        }
    FlipOptions o = ldr();
    o.pixelsPerDegree = e.ppd;
    EXPECT_NEAR(flip(test, ref, o).mean, e.ldr, 2e-5)
        << e.w << "x" << e.h << ", " << e.ppd << " ppd";
    o.hdr = true;
    const FlipResult r = flip(testH, refH, o);
    EXPECT_NEAR(r.mean, e.hdr, 2e-5) << e.w << "x" << e.h << ", " << e.ppd << " ppd";
    EXPECT_NEAR(r.startExposure, -3.8005354, 1e-5);
    EXPECT_NEAR(r.stopExposure, 0.9713961, 1e-5);
    EXPECT_EQ(r.exposures, 5);
  }
}

// Every filter is the same along x and y and the feature magnitudes are rotation-free, so the
// map of transposed images is the transposed map (up to float rounding: the passes' order swaps).
// A tall and a wide image also cut differently into the implementation's bands of rows.
TEST(Flip, TransposedImagesGiveTheTransposedMap) {
  const int w = 150, h = 41;
  Image ref = randomImage(w, h, 21, -3.0f, 3.0f), test = randomImage(w, h, 22, -3.0f, 3.0f);
  for (Image* im : {&ref, &test})
    for (float& v : im->pixels) v = std::exp2(v);
  auto transpose = [](const Image& im) {
    Image t(im.height, im.width, im.channels);
    for (int y = 0; y < im.height; ++y)
      for (int x = 0; x < im.width; ++x)
        for (int c = 0; c < im.channels; ++c) t.at(y, x, c) = im.at(x, y, c);
    return t;
  };
  const FlipResult a = flip(test, ref), b = flip(transpose(test), transpose(ref));
  EXPECT_EQ(a.exposures, b.exposures);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      ASSERT_NEAR(a.map.at(x, y, 0), b.map.at(y, x, 0), 1e-4) << x << ", " << y;
  EXPECT_NEAR(a.mean, b.mean, 1e-6);
}
