// The two prefilters of the filtered techniques (Annen et al. 2008 §4.1, "Mipmaps vs. Summed Area Tables",
// Fig. 8): the mip pyramid (kernels/shadows/mip.cl) against a C++ reference on awkward sizes, its
// trilinear query (kernels/shadows/filter.clh) against a C++ reference and against the SAT's exact
// box on level-aligned boxes, and MSSM4 rendered with the pyramid (analytic planar penumbra,
// frame); and the filtered result against the box average computed directly over the footprint
// (its mean and its spread), for both prefilters.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "shadows/shadow_pass.hpp"
#include "common.hpp"
#include "support/planar_penumbra.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

using Texels = std::vector<cl_long4>;

// The layout filter.clh documents, computed independently of src/shadows/registry.cpp: n_k =
// ceil(S/2^k).
std::vector<int> levelSizes(int S) {
  std::vector<int> n{S};
  while (n.back() > 1) n.push_back((n.back() + 1) / 2);
  return n;
}

std::size_t referenceStride(int S) {
  std::size_t s = 0;
  for (int n : levelSizes(S)) s += std::size_t(n) * n;
  return s;
}

// Pyramid by direct summation: texel (i, j) of level k is the sum of the level-0 texels
// [i 2^k, min((i+1) 2^k, S)) x [j 2^k, min((j+1) 2^k, S)) (not built level from level, unlike
// the kernel). `maps` holds `count` images at stride referenceStride(S), level 0 filled in.
Texels referencePyramid(Texels maps, int S, int count) {
  const std::size_t stride = referenceStride(S);
  std::vector<int> n = levelSizes(S);
  for (int b = 0; b < count; ++b) {
    const cl_long4* l0 = maps.data() + b * stride;
    std::size_t off = std::size_t(S) * S;
    for (std::size_t k = 1; k < n.size(); ++k) {
      for (int j = 0; j < n[k]; ++j)
        for (int i = 0; i < n[k]; ++i) {
          cl_long4 s{};
          for (int y = j << k; y < std::min((j + 1) << k, S); ++y)
            for (int x = i << k; x < std::min((i + 1) << k, S); ++x)
              for (int c = 0; c < 4; ++c) s.s[c] += l0[std::size_t(y) * S + x].s[c];
          maps[b * stride + off + std::size_t(j) * n[k] + i] = s;
        }
      off += std::size_t(n[k]) * n[k];
    }
  }
  return maps;
}

// `count` images of random level-0 texels in [lo, hi], at stride `stride`, the rest of each image
// filled with a sentinel the build must overwrite.
Texels randomMaps(int S, int count, std::size_t stride, long long lo, long long hi,
                  unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<long long> v(lo, hi);
  Texels maps(stride * count);
  for (auto& t : maps)
    for (int c = 0; c < 4; ++c) t.s[c] = 0x5a5a5a5a5a5a5a5aLL;
  for (int b = 0; b < count; ++b)
    for (std::size_t i = 0; i < std::size_t(S) * S; ++i)
      for (int c = 0; c < 4; ++c) maps[b * stride + i].s[c] = v(rng);
  return maps;
}

cl::Buffer uploadMaps(const Texels& maps) { return ctx().upload(maps, "test maps"); }

// Builds the pyramid on the device and compares every element with the reference, exactly.
void checkPyramid(int S, int count, unsigned seed) {
  const std::size_t stride = detail::prefilterStride(Prefilter::Mip, S);
  ASSERT_EQ(stride, referenceStride(S)) << "S = " << S;
  // |values| <= 2^40: a 256^2 sum stays below 2^57
  Texels maps = randomMaps(S, count, stride, -(1LL << 40), 1LL << 40, seed);
  cl::Buffer buf = uploadMaps(maps);
  detail::prefilter(ctx(), buf, Prefilter::Mip, S, count, "test");
  Texels got = ctx().download<cl_long4>(buf, maps.size(), "test maps");
  Texels want = referencePyramid(maps, S, count);
  std::size_t bad = 0, first = want.size();
  for (std::size_t i = 0; i < want.size(); ++i)
    if (std::memcmp(&got[i], &want[i], sizeof(cl_long4)) != 0) {
      ++bad;
      first = std::min(first, i);
    }
  EXPECT_EQ(bad, 0u) << "S = " << S << ", count " << count << ": first mismatch at element "
                     << first << " (image " << first / stride << ", offset " << first % stride
                     << ")";
}

// FILTER_BOX of each box (x0, y0, x1, y1) on image images[i], as a kernel built for `p` sees it.
std::vector<cl_float4> probe(Prefilter p, cl::Buffer& maps, int S, std::size_t stride,
                             const std::vector<cl_float4>& boxes, const std::vector<int>& images) {
  cl::Buffer b = ctx().upload(boxes, "probe boxes");
  cl::Buffer im = ctx().upload(images, "probe images");
  cl::Buffer out = ctx().buffer(boxes.size() * sizeof(cl_float4), "probe out");
  cl::Kernel k = ctx().kernel("mip.cl", "filter_box_probe", detail::prefilterOption(p));
  k.setArg(0, maps);
  k.setArg(1, cl_int(S));
  k.setArg(2, cl_ulong(stride));
  k.setArg(3, b);
  k.setArg(4, im);
  k.setArg(5, cl_int(boxes.size()));
  k.setArg(6, out);
  ctx().launch("test/probe", k, cl::NDRange(boxes.size()));
  return ctx().download<cl_float4>(out, boxes.size(), "probe out");
}

// A pyramid and a SAT of the same level-0 texels, on the device.
struct BothPrefilters {
  int S, count;
  std::size_t mipStride, satStride;
  Texels level0;  // count * S * S
  cl::Buffer mip, sat;
  Texels pyramid;  // reference pyramid, host
};

BothPrefilters buildBoth(const Texels& level0, int S, int count) {
  BothPrefilters r{S, count, detail::prefilterStride(Prefilter::Mip, S),
                   detail::prefilterStride(Prefilter::SAT, S), level0, {}, {}, {}};
  Texels mip(r.mipStride * count);
  for (int b = 0; b < count; ++b)
    std::copy_n(level0.begin() + std::size_t(b) * S * S, std::size_t(S) * S,
                mip.begin() + b * r.mipStride);
  r.pyramid = referencePyramid(mip, S, count);
  r.mip = uploadMaps(mip);
  r.sat = uploadMaps(level0);
  detail::prefilter(ctx(), r.mip, Prefilter::Mip, S, count, "test");
  detail::prefilter(ctx(), r.sat, Prefilter::SAT, S, count, "test");
  return r;
}

// The trilinear query of filter.clh in double, on the reference pyramid of image b.
std::array<double, 4> referenceQuery(const BothPrefilters& P, int b, const cl_float4& box) {
  const int S = P.S;
  std::vector<int> n = levelSizes(S);
  const int L = int(n.size());
  auto texel = [&](int k, int i, int j) {
    i = std::clamp(i, 0, n[k] - 1);
    j = std::clamp(j, 0, n[k] - 1);
    std::size_t off = 0;
    for (int q = 0; q < k; ++q) off += std::size_t(n[q]) * n[q];
    const cl_long4& t = P.pyramid[b * P.mipStride + off + std::size_t(j) * n[k] + i];
    double count = double(std::min((i + 1) << k, S) - (i << k)) *
                   double(std::min((j + 1) << k, S) - (j << k));
    std::array<double, 4> m;
    for (int c = 0; c < 4; ++c) m[c] = double(t.s[c]) / (count * PB_MOMENT_SCALE);
    return m;
  };
  auto bilinear = [&](int k, double cx, double cy) {
    double s = cx / (1 << k) - 0.5, t = cy / (1 << k) - 0.5;
    int i = int(std::floor(s)), j = int(std::floor(t));
    double a = s - i, bb = t - j;
    auto m00 = texel(k, i, j), m10 = texel(k, i + 1, j), m01 = texel(k, i, j + 1),
         m11 = texel(k, i + 1, j + 1);
    std::array<double, 4> r;
    for (int c = 0; c < 4; ++c)
      r[c] = (1 - bb) * ((1 - a) * m00[c] + a * m10[c]) + bb * ((1 - a) * m01[c] + a * m11[c]);
    return r;
  };
  // centre and side in float, as the kernel forms them (the rest is exact there or in double)
  const float cx = 0.5f * (box.s[0] + box.s[2]), cy = 0.5f * (box.s[1] + box.s[3]);
  const double w = std::max(box.s[2] - box.s[0], box.s[3] - box.s[1]);
  // lambda = k + t: k = floor(log2 w), t from filter.clh's quadratic log2 of w / 2^k in [1, 2)
  int k = 0;
  double t = 0;
  if (w > 0) {
    k = std::ilogb(w);
    double x = std::ldexp(w, -k) - 1;
    t = x * (4 - x) / 3;
  }
  if (k < 0) k = 0, t = 0;
  if (k >= L - 1) k = L - 1, t = 0;
  auto lo = bilinear(k, cx, cy);
  if (t == 0 || k + 1 >= L) return lo;
  auto hi = bilinear(k + 1, cx, cy);
  for (int c = 0; c < 4; ++c) lo[c] = (1 - t) * lo[c] + t * hi[c];
  return lo;
}

}  // namespace

TEST(Prefilter, MipStrideIsTheLevelSum) {
  for (int S : {1, 2, 3, 4, 5, 17, 100, 255, 256, 257, 1024})
    EXPECT_EQ(detail::prefilterStride(Prefilter::Mip, S), referenceStride(S)) << S;
  EXPECT_EQ(detail::prefilterStride(Prefilter::Mip, 1), 1u);
  EXPECT_EQ(detail::prefilterStride(Prefilter::Mip, 3), 9u + 4u + 1u);
  // 4/3 overhead: (4 S^2 - 1) / 3 for S = 2^m, against S^2 for the SAT
  EXPECT_EQ(detail::prefilterStride(Prefilter::Mip, 1024), (4u * 1024 * 1024 - 1) / 3);
  EXPECT_EQ(detail::prefilterStride(Prefilter::SAT, 1024), 1024u * 1024);
  EXPECT_TRUE(detail::prefilterAvailable(Prefilter::Mip));
  EXPECT_EQ(parsePrefilter("mip"), Prefilter::Mip);
}

// Exact int64 equality with the direct-summation reference: 1x1 (no level to build), 2x2, odd
// sizes whose last row and column shrink at every level, sizes that take one (17: levels 1-5) and
// two (33, 256: levels 1-5, then the rest) launches of the 16x16 tile, and batches.
TEST(Prefilter, MipPyramidMatchesReferenceOnAwkwardSizes) {
  unsigned seed = 1;
  for (int S : {1, 2, 3, 5, 17, 33, 100, 256}) checkPyramid(S, 1, seed++);
  checkPyramid(3, 4, seed++);
  checkPyramid(37, 5, seed++);
  checkPyramid(64, 3, seed++);
}

// The build for every work-group tile the host may pick (16 unless the device takes fewer than
// 256 work-items; CPUs and GPUs both get 16 here): launches of log2(tile) + 1 levels, as
// src/shadows/registry.cpp runs them, bit-identical to the reference.
TEST(Prefilter, MipPyramidIsTheSameForEveryTile) {
  const int S = 37, count = 2;
  const std::size_t stride = referenceStride(S);
  Texels maps = randomMaps(S, count, stride, -(1LL << 40), 1LL << 40, 99);
  Texels want = referencePyramid(maps, S, count);
  const int L = int(levelSizes(S).size());
  for (int tile : {2, 4, 8, 16}) {
    cl::Buffer buf = uploadMaps(maps);
    cl::Kernel k = ctx().kernel("mip.cl", "mip_build", "-DMIP_TILE=" + std::to_string(tile));
    const int perLaunch = int(std::log2(tile)) + 1;
    int launches = 0;
    for (int src = 0; src < L - 1; ++launches) {
      const int depth = std::min(perLaunch, L - 1 - src);
      std::size_t n1 = std::size_t(levelSizes(S)[src + 1] + tile - 1) / tile * tile;
      k.setArg(0, buf);
      k.setArg(1, cl_int(S));
      k.setArg(2, cl_ulong(stride));
      k.setArg(3, cl_int(src));
      k.setArg(4, cl_int(depth));
      ctx().launch("test/mip", k, cl::NDRange(n1, n1, count), cl::NDRange(tile, tile, 1));
      src += depth;
    }
    Texels got = ctx().download<cl_long4>(buf, maps.size(), "test maps");
    EXPECT_EQ(0, std::memcmp(got.data(), want.data(), got.size() * sizeof(cl_long4)))
        << "tile " << tile << " (" << launches << " launches)";
  }
}

TEST(Prefilter, MipBuildRejectsEmptyInput) {
  cl::Buffer b = ctx().buffer(64, "empty");
  EXPECT_THROW(detail::prefilter(ctx(), b, Prefilter::Mip, 0, 1, "test"), Error);
  EXPECT_THROW(detail::prefilter(ctx(), b, Prefilter::Mip, 4, 0, "test"), Error);
}

// On a level-aligned box (x0, y0 multiples of 2^k, side 2^k) the pyramid's answer is one texel's
// exact mean, rounded once: it must equal the correctly rounded exact mean bit for bit. The SAT
// sums up to four sub-rectangles (box_runs: first/middle runs with weight 1; the other five of
// its nine have weight 0 and add exactly +0), each rounded to float, then divides by the area (OpenCL division: 2.5 ulp): within 8 ulp of the exact mean for
// the non-negative data used here (moments are non-negative), so within 8 ulp of the pyramid.
TEST(Prefilter, MipEqualsSatOnLevelAlignedBoxes) {
  for (int S : {64, 48, 37}) {  // 48 = 3 x 16: aligned boxes beside a ragged level 5; 37: odd
    const int count = 2;
    Texels level0 = randomMaps(S, count, std::size_t(S) * S, 0, 1LL << 32, 100 + S);
    BothPrefilters P = buildBoth(level0, S, count);
    std::vector<cl_float4> boxes;
    std::vector<int> images;
    std::vector<int> levels;
    for (int k = 0; (1 << k) <= S; ++k) {
      const int w = 1 << k;
      for (int b = 0; b < count; ++b)
        for (int y = 0; y + w <= S; y += w)
          for (int x = 0; x + w <= S; x += w) {
            boxes.push_back({{float(x), float(y), float(x + w), float(y + w)}});
            images.push_back(b);
            levels.push_back(k);
          }
    }
    auto mip = probe(Prefilter::Mip, P.mip, S, P.mipStride, boxes, images);
    auto sat = probe(Prefilter::SAT, P.sat, S, P.satStride, boxes, images);
    int mipExact = 0, satClose = 0;
    double worstSat = 0;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const int x0 = int(boxes[i].s[0]), y0 = int(boxes[i].s[1]), w = 1 << levels[i];
      for (int c = 0; c < 4; ++c) {
        long long sum = 0;  // exact, < 2^32 * 4^6 = 2^44
        for (int y = y0; y < y0 + w; ++y)
          for (int x = x0; x < x0 + w; ++x)
            sum += level0[std::size_t(images[i]) * S * S + std::size_t(y) * S + x].s[c];
        const float exact = float(std::ldexp(double(sum), -32 - 2 * levels[i]));
        mipExact += mip[i].s[c] == exact;
        const double tol = 8 * std::ldexp(double(exact), -24);
        satClose += std::fabs(double(sat[i].s[c]) - exact) <= tol &&
                    std::fabs(double(sat[i].s[c]) - mip[i].s[c]) <= tol;
        worstSat = std::max(worstSat, std::fabs(double(sat[i].s[c]) - exact) /
                                          std::max(double(exact), 1e-30));
      }
    }
    std::printf("[ penumbra ] S %d: %zu aligned boxes, mip exact in %d/%zu channels, "
                "SAT max relative error %.2g\n",
                S, boxes.size(), mipExact, 4 * boxes.size(), worstSat);
    EXPECT_EQ(mipExact, int(4 * boxes.size())) << "S = " << S;
    EXPECT_EQ(satClose, int(4 * boxes.size())) << "S = " << S;
  }
}

// Any box, against the C++ trilinear reference (double): random sizes from below one texel to
// wider than the map, random centres including the borders, on odd and ragged sizes. Tolerance:
// float interpolation of values in [0, 1] (a few ulp) plus the float log2 of the level fraction.
TEST(Prefilter, MipQueryMatchesReferenceOnRandomBoxes) {
  for (int S : {1, 2, 13, 64, 100}) {
    const int count = 2;
    Texels level0 = randomMaps(S, count, std::size_t(S) * S, 0, 1LL << 32, 200 + S);
    BothPrefilters P = buildBoth(level0, S, count);
    std::mt19937 rng(S);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<cl_float4> boxes;
    std::vector<int> images;
    for (int i = 0; i < 2000; ++i) {
      float w = std::exp2(u(rng) * (std::log2(float(S)) + 2.0f) - 1.5f);  // 0.35 .. 2.8 S
      float cx = u(rng) * S, cy = u(rng) * S;
      float x0 = std::max(cx - w / 2, 0.0f), x1 = std::min(cx + w / 2, float(S));
      float h = w * (0.5f + u(rng));  // not square either
      float y0 = std::max(cy - h / 2, 0.0f), y1 = std::min(cy + h / 2, float(S));
      boxes.push_back({{x0, y0, x1, y1}});
      images.push_back(i % count);
    }
    auto got = probe(Prefilter::Mip, P.mip, S, P.mipStride, boxes, images);
    double worst = 0;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      auto want = referenceQuery(P, images[i], boxes[i]);
      for (int c = 0; c < 4; ++c) worst = std::max(worst, std::fabs(got[i].s[c] - want[c]));
    }
    std::printf("[ penumbra ] S %d: mip query vs double reference, max |error| %.2g\n", S, worst);
    EXPECT_LT(worst, 2e-6) << "S = " << S;
  }
}

// A constant map gives its constant for every box, also where ragged edge texels cover fewer
// level-0 texels (their mean divides by the count they cover); a linear ramp (texel value = its
// centre's x) is reproduced exactly wherever the interpolated texels are whole and unclamped:
// texel centres sit at (i + 1/2) 2^k, so a half-texel slip would show as an offset of 2^(k-1).
TEST(Prefilter, MipReproducesConstantsAndRamps) {
  const int S = 77, count = 1;
  Texels level0(std::size_t(S) * S);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      auto& t = level0[std::size_t(y) * S + x];
      t.s[0] = (2LL * x + 1) << 23;  // (x + 1/2) 2^24
      t.s[1] = (2LL * y + 1) << 23;
      t.s[2] = 1LL << 32;  // 1
      t.s[3] = 0;
    }
  BothPrefilters P = buildBoth(level0, S, count);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<cl_float4> boxes, rampBoxes;
  for (int i = 0; i < 3000; ++i) {
    float w = std::exp2(u(rng) * 7.0f - 0.5f), h = w * (0.6f + 0.4f * u(rng));
    float cx = u(rng) * S, cy = u(rng) * S;
    cl_float4 b{{std::max(cx - w / 2, 0.0f), std::max(cy - h / 2, 0.0f),
                 std::min(cx + w / 2, float(S)), std::min(cy + h / 2, float(S))}};
    boxes.push_back(b);
    // ramp boxes: both levels' bilinear neighbours whole and unclamped along x and y
    float side = std::max(b.s[2] - b.s[0], b.s[3] - b.s[1]);
    int k = side > 1 ? int(std::floor(std::log2(side))) : 0;
    bool inside = true;
    for (int q = k; q <= k + 1; ++q) {
      float lo = 0.5f * (1 << q), hi = (std::floor(float(S) / (1 << q)) - 0.5f) * (1 << q);
      inside &= 0.5f * (b.s[0] + b.s[2]) >= lo && 0.5f * (b.s[0] + b.s[2]) <= hi &&
                0.5f * (b.s[1] + b.s[3]) >= lo && 0.5f * (b.s[1] + b.s[3]) <= hi;
    }
    if (inside) rampBoxes.push_back(b);
  }
  auto got = probe(Prefilter::Mip, P.mip, S, P.mipStride, boxes, std::vector<int>(boxes.size()));
  double worstConst = 0;
  for (auto& g : got) worstConst = std::max(worstConst, std::fabs(g.s[2] - 1.0));
  EXPECT_LT(worstConst, 1e-6);  // a few float ulp of 1
  ASSERT_GT(rampBoxes.size(), 300u);
  auto ramp =
      probe(Prefilter::Mip, P.mip, S, P.mipStride, rampBoxes, std::vector<int>(rampBoxes.size()));
  double worstRamp = 0;
  for (std::size_t i = 0; i < rampBoxes.size(); ++i) {
    const auto& b = rampBoxes[i];
    // moment value of a texel centre c (texel units): c 2^24 / 2^32
    worstRamp = std::max(worstRamp, std::fabs(ramp[i].s[0] - 0.5 * (b.s[0] + b.s[2]) / 256.0));
    worstRamp = std::max(worstRamp, std::fabs(ramp[i].s[1] - 0.5 * (b.s[1] + b.s[3]) / 256.0));
  }
  std::printf("[ penumbra ] S %d: constant max error %.2g, ramp max error %.2g texels over %zu boxes\n",
              S, worstConst, worstRamp * 256, rampBoxes.size());
  EXPECT_LT(worstRamp * 256, 1e-3);  // texels; float rounding of values up to 77 is ~1e-5
}

// The level choice judged by what it must achieve, not by a copy of it: the filtered result
// against the box average computed here by direct summation over the footprint. A map whose
// channels are x^2 and y^2 (texel centres, in units of the map) turns each query into the second
// moment of the filter's footprint: Q(x^2) - Q(x)^2 is its variance, to compare with the box's own
// (the direct average of x^2 less the square of the direct average of x). From the trilinear
// filter's definition (not from filter.clh): level k holds 2^k-texel block means, whose discrete
// variance is (4^k - 1)/12, and linear interpolation between block centres h = 2^k apart adds
// a (1 - a) h^2 at fraction a, h^2/6 on average over box positions. With lambda = log2 w and
// w = 2^k m, m in [1, 2), the mean footprint variance is 4^k (1/4 + 3 t / 4) ~ w^2 (1 + 3 t) / (4
// m^2), t = log2 m, against the box's w^2 / 12: a ratio of 3 at m = 1 and 2 and at most 3.8
// between. A level one too fine divides the ratio by 4 (<= 0.95), one too coarse multiplies it
// by 4 (>= 12). Bounds: mean ratio in [2, 6] for every width. Measured: 2.78 to 3.92 over widths
// 3 to 22.6 (the box's own discrete variance is a little below w^2 / 12). Negative controls: the same queries against the box of twice and of half the width must
// leave [2, 6]. The SAT prefilter must give the box average itself (coverage-weighted at
// fractional edges): ratio 1 and every mean within float rounding.
TEST(Prefilter, FootprintMatchesTheBoxAverageComputedDirectly) {
  const int S = 128;
  Texels level0(std::size_t(S) * S);
  auto X = [&](int i) { return (i + 0.5) / S; };  // texel centre in [0, 1], exact in 2^-8 steps
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      auto& t = level0[std::size_t(y) * S + x];
      t.s[0] = (long long)std::llround(X(x) * PB_MOMENT_SCALE);
      t.s[1] = (long long)std::llround(X(y) * PB_MOMENT_SCALE);
      t.s[2] = (long long)std::llround(X(x) * X(x) * PB_MOMENT_SCALE);
      t.s[3] = (long long)std::llround(X(y) * X(y) * PB_MOMENT_SCALE);
    }
  BothPrefilters P = buildBoth(level0, S, 1);
  // Coverage-weighted direct average of channel c over the continuous box [x0,x1] x [y0,y1]
  // (texel i covers [i, i + 1)).
  auto direct = [&](double x0, double y0, double x1, double y1, std::array<double, 4>& m) {
    m = {0, 0, 0, 0};
    double area = 0;
    for (int y = int(std::floor(y0)); y < int(std::ceil(y1)); ++y)
      for (int x = int(std::floor(x0)); x < int(std::ceil(x1)); ++x) {
        const double cover = (std::min(x1, x + 1.0) - std::max(x0, double(x))) *
                             (std::min(y1, y + 1.0) - std::max(y0, double(y)));
        if (cover <= 0) continue;
        area += cover;
        const double v[4] = {X(x), X(y), X(x) * X(x), X(y) * X(y)};
        for (int c = 0; c < 4; ++c) m[c] += cover * v[c];
      }
    for (double& v : m) v /= area;
  };
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (double w : {3.0, 4.0, 5.7, 8.0, 11.3, 16.0, 22.6}) {
    std::vector<cl_float4> boxes;
    for (int i = 0; i < 400; ++i) {
      // centres far enough from the border that no level's interpolation clamps (2^(k+2) texels)
      const double margin = 4 * w + 2;
      const double cx = margin + u(rng) * (S - 2 * margin), cy = margin + u(rng) * (S - 2 * margin);
      boxes.push_back({{float(cx - w / 2), float(cy - w / 2), float(cx + w / 2), float(cy + w / 2)}});
    }
    const std::vector<int> images(boxes.size(), 0);
    auto mip = probe(Prefilter::Mip, P.mip, S, P.mipStride, boxes, images);
    auto sat = probe(Prefilter::SAT, P.sat, S, P.satStride, boxes, images);
    double vMip = 0, vBox = 0, vBox2 = 0, vBoxHalf = 0, satErr = 0, satVar = 0, meanErr = 0;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const auto& b = boxes[i];
      const double cx = 0.5 * (b.s[0] + b.s[2]), cy = 0.5 * (b.s[1] + b.s[3]);
      std::array<double, 4> m, m2, mh;
      direct(b.s[0], b.s[1], b.s[2], b.s[3], m);
      direct(cx - w, cy - w, cx + w, cy + w, m2);
      direct(cx - w / 4, cy - w / 4, cx + w / 4, cy + w / 4, mh);
      for (int a = 0; a < 2; ++a) {
        vMip += mip[i].s[2 + a] - double(mip[i].s[a]) * mip[i].s[a];
        vBox += m[2 + a] - m[a] * m[a];
        vBox2 += m2[2 + a] - m2[a] * m2[a];
        vBoxHalf += mh[2 + a] - mh[a] * mh[a];
        satVar += sat[i].s[2 + a] - double(sat[i].s[a]) * sat[i].s[a];
        // the linear channels' mean over the continuous box is its centre (the direct,
        // coverage-weighted mean of the texels differs from it by O(1/w) at fractional edges)
        meanErr = std::max(meanErr, std::fabs(mip[i].s[a] * S - (a ? cy : cx)));  // texels
      }
      for (int c = 0; c < 4; ++c) satErr = std::max(satErr, std::fabs(sat[i].s[c] - m[c]));
    }
    const double ratio = vMip / vBox, ratio2 = vMip / vBox2, ratioHalf = vMip / vBoxHalf;
    std::printf("[ penumbra ] box width %.1f texels: mip footprint variance / box's %.3f (against "
                "the box twice as wide %.3f, half as wide %.3f); mip mean off by %.2e texels; SAT "
                "max |mean - direct| %.2e, variance ratio %.4f\n",
                w, ratio, ratio2, ratioHalf, meanErr, satErr, satVar / vBox);
    EXPECT_GE(ratio, 2.0) << w;
    EXPECT_LE(ratio, 6.0) << w;
    EXPECT_LT(meanErr, 1e-3) << w;  // linear channels: the box's centre, float rounding only
    EXPECT_FALSE(ratio2 >= 2.0 && ratio2 <= 6.0) << w;        // negative controls
    EXPECT_FALSE(ratioHalf >= 2.0 && ratioHalf <= 6.0) << w;
    // SAT: the exact box; float rounding of means <= 1 (measured ~1e-7)
    EXPECT_LT(satErr, 1e-5) << w;
    EXPECT_NEAR(satVar / vBox, 1.0, 0.02) << w;
  }
}

// ---- MSSM4 with the mip pyramid ----
namespace {

// tests/test_mssm.cpp's planar parallel configuration with a choice of prefilter: a half-plane
// blocker at height h over a receiver plane, one light straight down, per-pixel visibility against
// the analytic profile.
ProfileComparison planarCase(Prefilter pf, double alphaDeg, double h, int mapSize, double edgeTexels) {
  // The light's map spans the ground's 6 units (+ renderer.cpp's 1e-3 margin) in x; the blocker's
  // edge x = xe lies edgeTexels texels from the map's centre line.
  const double xe = -edgeTexels * 2 * (3 + 6e-3) / mapSize;
  PlanarPenumbra s;
  s.blockers = {{xe, h}};
  s.light = capLightAbove(alphaDeg);
  s.mapSize = mapSize;
  RenderOptions ro;
  ro.prefilter = pf;
  PlanarFrame f = renderPlanar(s, ro);
  ProfileComparison res =
      compareWithProfile(f.receivers, halfPlaneProfile(h, alphaDeg * M_PI / 180), xe);
  std::printf("[ penumbra ] MSSM4 + %s, planar alpha %.1f deg, h %.1f, map %d, edge %+.2f texels: "
              "max |V - V_analytic| = %.4f over %d pixels, RMS in the penumbra %.4f over %d\n",
              toString(pf), alphaDeg, h, mapSize, edgeTexels, res.maxError, res.samples,
              res.rmsPenumbra, res.penumbraSamples);
  return res;
}

}  // namespace

// Bounds. The pyramid answers a box of side w = 2^(k+t) with the bilinear interpolation of the
// means of aligned cells of 2^k and 2^(k+1) texels, blended by t, not with the box itself. Model
// (1D, a straight edge at phase phi of a cell, lit fraction vs the w-box ramp; max over positions,
// phases and t, evaluated numerically): with phi = 0 (the edge on a cell boundary of every level,
// as the planar scene puts it at the map's centre line) each level is the exact ramp of its cell
// width and only the blend of a narrower and a wider ramp is off, by <= 0.074; with phi = 1/2 the
// neighbouring cell's mean still carries half the edge where the box would read 0 or 1: error
// phi (1 - phi) = 1/4 at integer levels (the aliasing of Annen et al. 2008 Fig. 8), and RMS 1/(4 sqrt 3) =
// 0.144 across the ramp. On top comes what the SAT itself shows in the same scene (test_mssm.cpp's
// 0.05 for the edge on the texel grid: disc vs equal-area square 0.023, moment bias, texels; with
// the edge 2/3 texel off the grid the depth map moves it by up to half a texel, and the SAT's
// narrow case measures 0.073 = 0.5 texel / 6.6-texel ramp). Hence: edge on the grid, max 0.074 +
// 0.05 < 0.125; edge at 128/3 texels (phase 1/3 or 2/3 at every level), max 0.25 + 0.075 < 0.33 and
// RMS over the penumbra 0.144 + 0.05 < 0.20. Measured (printed): 0.042 / 0.048 on the grid;
// 0.19 / 0.20 max and 0.13 / 0.14 RMS off it (SAT: 0.073 / 0.044 max, 0.047 / 0.023 RMS).
TEST(PrefilterMSSM4, MipNarrowPenumbraMatchesAnalyticProfile) {
  ProfileComparison onGrid = planarCase(Prefilter::Mip, 5.0, 1.0, 256, 0.0);
  EXPECT_GT(onGrid.samples, 5000);
  EXPECT_GT(onGrid.penumbraSamples, 100);
  EXPECT_LT(onGrid.maxError, 0.125);
  ProfileComparison off = planarCase(Prefilter::Mip, 5.0, 1.0, 256, 128.0 / 3);
  EXPECT_GT(off.penumbraSamples, 80);
  EXPECT_LT(off.maxError, 0.33);
  EXPECT_LT(off.rmsPenumbra, 0.20);
}

TEST(PrefilterMSSM4, MipWidePenumbraMatchesAnalyticProfile) {
  ProfileComparison onGrid = planarCase(Prefilter::Mip, 15.0, 1.0, 256, 0.0);
  EXPECT_GT(onGrid.penumbraSamples, 500);
  EXPECT_LT(onGrid.maxError, 0.125);
  ProfileComparison off = planarCase(Prefilter::Mip, 15.0, 1.0, 256, 128.0 / 3);
  EXPECT_GT(off.penumbraSamples, 250);
  EXPECT_LT(off.maxError, 0.33);
  EXPECT_LT(off.rmsPenumbra, 0.20);
}

// The default scene with both prefilters: finite, deterministic, the pyramid's frame close to the
// SAT's but not identical (the option reaches the kernels), and 4/3 the shadow-map memory.
TEST(PrefilterMSSM4, MipFrameIsFiniteDeterministicAndCloseToSat) {
  Scene scene = builtinScene();
  Environment env = builtinEnvironment(64);
  MedianCutOptions mc;
  mc.lights = 8;
  mc.faceSize = 32;
  // Median cut's lights alone and no exact light: the frame the bounds below were measured on,
  // and shadow-map memory that is the moment maps' alone (an exact light adds the bitmask
  // technique's lists to it).
  mc.peakRatio = 0;
  LightSet set = extractMedianCut(ctx(), env, mc);
  RenderOptions ro;
  ro.width = 96;
  ro.height = 54;
  ro.shadowMapSize = 128;
  ro.autoChoice.exactShare = 0;
  // The filter stays on the light's axis (no cosine centroid), as when the bounds below were
  // measured. With the centroid this frame loses most of its shadow (mean 0.118 -> 0.027: false
  // self-shadowing under 8 wide caps, README "The cosine-weighted light"), and on what is left
  // the pyramid differs more (mean |dV| 0.020 = 0.75 of the shadow, the mip's shadow 1.19x the
  // SAT's): the prefilters are compared here, the centroid with the mip is an open question.
  ro.mssm.cosineCentroid = false;
  Renderer r(ctx());
  Camera cam = frameCamera(scene, 96.0f / 54.0f);
  Frame sat = r.render(scene, cam, set, env, ro);
  auto visSat = r.lastVisibility();
  ro.prefilter = Prefilter::Mip;
  Frame mip = r.render(scene, cam, set, env, ro);
  auto visMip = r.lastVisibility();
  Frame again = r.render(scene, cam, set, env, ro);
  EXPECT_EQ(mip.image.pixels, again.image.pixels);
  for (float v : mip.image.pixels) ASSERT_TRUE(std::isfinite(v));
  ASSERT_EQ(visMip.size(), visSat.size());
  double diff = 0, shadowed = 0;
  for (std::size_t i = 0; i < visMip.size(); ++i) {
    ASSERT_TRUE(visMip[i] >= 0.0f && visMip[i] <= 1.0f) << i;
    diff += std::fabs(visMip[i] - visSat[i]);
    shadowed += 1.0 - visSat[i];
  }
  double shadowedMip = 0;
  for (float v : visMip) shadowedMip += 1.0 - v;
  diff /= visMip.size();
  shadowed /= visMip.size();
  shadowedMip /= visMip.size();
  std::printf("[ penumbra ] default scene, 8 lights, 128^2: mean shadow SAT %.4f, mip %.4f, mean "
              "|V_mip - V_sat| %.4f\n", shadowed, shadowedMip, diff);
  // The same shadows, blurred: the pyramid's footprint reaches up to 3x the box (bilinear over
  // cells up to twice its width), so the small shadows that 27-texel filters cover on 128^2 maps
  // lose depth (measured: shadow 0.77 of the SAT's, mean |dV| 0.38 of the mean shadow); a pass
  // that lost the shadows would have |dV| = shadow, one that ignored the option |dV| = 0.
  EXPECT_GT(diff, 1e-3);
  EXPECT_LT(diff, 0.5 * shadowed);
  EXPECT_GT(shadowedMip, 0.6 * shadowed);
  EXPECT_LT(shadowedMip, 1.2 * shadowed);
  // the pyramid's 4/3 (MSSM4 reports whole bytes per texel: 32 for the SAT, 42.67 rounded)
  const double ratio = double(mip.shadowMapBytes) / double(sat.shadowMapBytes);
  EXPECT_GE(ratio, 42.0 / 32);
  EXPECT_LE(ratio, 43.0 / 32);
}

// The pyramid build, its query (both prefilters' probe) and a whole MSSM4 frame with the pyramid
// on tiny inputs; CTest runs it under oclgrind (invalid accesses, races, barrier divergence).
TEST(OclgrindMip, TinyPyramidQueryAndFrame) {
  checkPyramid(3, 2, 11);
  checkPyramid(33, 1, 12);  // two launches of the 16x16 tile: levels 1-5, then level 6
  {
    const int S = 9, count = 2;
    Texels level0 = randomMaps(S, count, std::size_t(S) * S, 0, 1LL << 32, 13);
    BothPrefilters P = buildBoth(level0, S, count);
    std::vector<cl_float4> boxes = {{{0, 0, 9, 9}},   {{0, 0, 1, 1}},     {{2, 4, 4, 6}},
                                    {{0.3f, 8.2f, 1.4f, 9}}, {{4, 4, 4, 4}}, {{5.5f, 1, 9, 7}}};
    std::vector<int> images = {0, 1, 0, 1, 0, 1};
    auto mip = probe(Prefilter::Mip, P.mip, S, P.mipStride, boxes, images);
    auto sat = probe(Prefilter::SAT, P.sat, S, P.satStride, boxes, images);
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      auto want = referenceQuery(P, images[i], boxes[i]);
      for (int c = 0; c < 4; ++c) {
        EXPECT_NEAR(mip[i].s[c], want[c], 2e-6) << i;
        // the SAT divides by the area: the empty box {4,4,4,4} is the pyramid's case only
        if (boxes[i].s[2] > boxes[i].s[0]) EXPECT_TRUE(std::isfinite(sat[i].s[c])) << i;
      }
    }
    EXPECT_EQ(mip[1].s[0], sat[1].s[0]);  // one texel: both exact
  }
  Scene scene = builtinScene();
  Environment env = builtinEnvironment(16);
  MedianCutOptions mc;
  mc.lights = 3;
  mc.faceSize = 4;
  mc.supersample = 2;
  LightSet set = extractMedianCut(ctx(), env, mc);
  RenderOptions ro;
  ro.width = 12;
  ro.height = 7;
  ro.shadowMapSize = 8;
  ro.prefilter = Prefilter::Mip;
  Renderer r(ctx());
  Frame f = r.render(scene, frameCamera(scene, 12.0f / 7.0f), set, env, ro);
  for (float v : f.image.pixels) ASSERT_TRUE(std::isfinite(v));
}
