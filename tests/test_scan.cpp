// Summed-area tables (kernels/common/scan.cl via penumbra::summedAreaTable) against a plain C++
// reference: exact int64 for long/long4, double with a derived rounding bound for float/float4;
// awkward sizes, batches, tunings, bad input, and the box-filter test that motivates the
// fixed-point tables. OclgrindScan.* use small sizes so that CTest can also run them under the
// oclgrind simulator.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <cstdint>
#include <iostream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "common.hpp"
#include "penumbra/context.hpp"
#include "penumbra/error.hpp"
#include "penumbra/scan.hpp"

namespace {

using penumbra::Context;
using penumbra::ErrorKind;
using penumbra::ScanTuning;
using penumbra::ScanType;

using penumbra::test::ctx;  // the suite's one context (tests/common.hpp)

int lanes(ScanType t) { return t == ScanType::Float4 || t == ScanType::Long4 ? 4 : 1; }

const char* name(ScanType t) {
  switch (t) {
    case ScanType::Float: return "float";
    case ScanType::Float4: return "float4";
    case ScanType::Long: return "long";
    case ScanType::Long4: return "long4";
  }
  return "?";
}

struct Size {
  int w, h, batch;
};

std::string label(ScanType t, Size s) {
  std::ostringstream o;
  o << name(t) << " " << s.w << "x" << s.h << " batch " << s.batch;
  return o.str();
}

// Uploads `in` (scalars, lanes(t) per element), scans on the device, downloads.
template <class S>
std::vector<S> deviceSat(ScanType t, const std::vector<S>& in, Size s,
                         const ScanTuning& tune = {}) {
  cl::Buffer buf = ctx().upload(in, "scan test data");
  penumbra::summedAreaTable(ctx(), buf, t, s.w, s.h, s.batch, "test", tune);
  return ctx().download<S>(buf, in.size(), "scan test data");
}

// Reference SAT: rows first, then columns, accumulated in Acc (double or int64), per lane.
template <class Acc, class S, class F>
std::vector<Acc> referenceSat(const std::vector<S>& in, Size s, int L, F value) {
  std::vector<Acc> out(in.size());
  const std::size_t img = std::size_t(s.w) * s.h * L;
  for (int b = 0; b < s.batch; ++b)
    for (int y = 0; y < s.h; ++y)
      for (int x = 0; x < s.w; ++x)
        for (int l = 0; l < L; ++l) {
          std::size_t i = b * img + (std::size_t(y) * s.w + x) * L + l;
          Acc v = value(in[i]);
          if (x > 0) v += out[i - L];
          out[i] = v;
        }
  for (int b = 0; b < s.batch; ++b)
    for (int y = 1; y < s.h; ++y)
      for (std::size_t k = 0; k < std::size_t(s.w) * L; ++k) {
        std::size_t i = b * img + std::size_t(y) * s.w * L + k;
        out[i] += out[i - std::size_t(s.w) * L];
      }
  return out;
}

// Upper bound on the number of additions any input passes through on its way into one output:
// the serial run within a work-item (VPT), the up- and down-sweep over the group's totals
// (2 log2 WG), one carry per earlier tile, the column segment (SEG), the segment offsets
// (height/SEG) and a few joins. Unset knobs take the larger of the GPU and CPU defaults in
// src/core/scan.cpp (VPT 4 or 64, WG 8..256, SEG 64) and the smallest default tile (8 x 4).
// The banded method (t.bands > 0) adds serially: along its row (width), the running sum of the
// band offsets along the first row (width), one per row above within the band and one per band;
// on a device with fp64 it carries float tables' sums in double and rounds each value once: depth
// 1, plus the double sums' error, at most w h 2^-53 relative to the sum of |inputs|, which is
// w h 2^-29 in units of 2^-24.
double additionDepth(Size s, const ScanTuning& t) {
  if (t.bands > 0 && ctx().info().fp64) return 1.0 + double(s.w) * s.h * std::ldexp(1.0, -29);
  if (t.bands > 0) return 2.0 * s.w + s.h + t.bands + 8;
  const int vpt = t.valuesPerItem ? t.valuesPerItem : 64;
  const int wg = t.workGroup ? t.workGroup : 256;
  const int tile = (t.workGroup ? t.workGroup : 8) * (t.valuesPerItem ? t.valuesPerItem : 4);
  const int seg = t.segmentRows ? t.segmentRows : 64;
  return vpt + 2 * std::log2(double(wg)) + (s.w + tile - 1) / tile + seg + (s.h + seg - 1) / seg +
         8;
}

std::vector<float> randomFloats(std::size_t n, unsigned seed, float lo = -1.0f, float hi = 1.0f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> d(lo, hi);
  std::vector<float> v(n);
  for (auto& x : v) x = d(rng);
  return v;
}

std::vector<std::int64_t> randomLongs(std::size_t n, unsigned seed) {
  // |v| < 2^38: a 2048^2 table (2^22 terms) stays below 2^60, no overflow in the reference.
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<std::int64_t> d(-(std::int64_t(1) << 38), std::int64_t(1) << 38);
  std::vector<std::int64_t> v(n);
  for (auto& x : v) x = d(rng);
  return v;
}

// Float SAT vs the double reference. First-order rounding bound for any summation tree: each
// output's error is at most depth * u * (sum of |inputs|), u = 2^-24; depth from additionDepth.
void checkFloat(ScanType t, Size s, unsigned seed, const ScanTuning& tune = {}) {
  const int L = lanes(t);
  auto in = randomFloats(std::size_t(s.w) * s.h * s.batch * L, seed);
  auto got = deviceSat(t, in, s, tune);
  auto ref = referenceSat<double>(in, s, L, [](float v) { return double(v); });
  auto mag = referenceSat<double>(in, s, L, [](float v) { return std::fabs(double(v)); });
  const double k = 1.01 * additionDepth(s, tune) * std::ldexp(1.0, -24);
  std::size_t bad = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    double err = std::fabs(double(got[i]) - ref[i]);
    if (!(err <= k * mag[i]) && bad++ < 5)
      ADD_FAILURE() << label(t, s) << ": scalar " << i << " got " << got[i] << " want " << ref[i]
                    << " (tolerance " << k * mag[i] << ")";
  }
  EXPECT_EQ(bad, 0u) << label(t, s);
}

void checkLong(ScanType t, Size s, unsigned seed, const ScanTuning& tune = {}) {
  const int L = lanes(t);
  auto in = randomLongs(std::size_t(s.w) * s.h * s.batch * L, seed);
  auto got = deviceSat(t, in, s, tune);
  auto ref = referenceSat<std::int64_t>(in, s, L, [](std::int64_t v) { return v; });
  std::size_t bad = 0;
  for (std::size_t i = 0; i < got.size(); ++i)
    if (got[i] != ref[i] && bad++ < 5)
      ADD_FAILURE() << label(t, s) << ": scalar " << i << " got " << got[i] << " want " << ref[i];
  EXPECT_EQ(bad, 0u) << label(t, s);
}

void check(ScanType t, Size s, unsigned seed, const ScanTuning& tune = {}) {
  if (t == ScanType::Float || t == ScanType::Float4)
    checkFloat(t, s, seed, tune);
  else
    checkLong(t, s, seed, tune);
}

// 1x1, a column, a row, small odd, larger than a work-group in both directions, a row of several
// tiles (3001 > 1024 = the largest default tile), an odd batch.
const Size kAwkward[] = {{1, 1, 1},    {1, 1000, 1}, {1000, 1, 1}, {7, 5, 1},
                         {1023, 517, 1}, {3001, 3, 1}, {37, 29, 3}};

}  // namespace

TEST(Scan, ElementBytes) {
  EXPECT_EQ(penumbra::scanElementBytes(ScanType::Float), 4u);
  EXPECT_EQ(penumbra::scanElementBytes(ScanType::Float4), 16u);
  EXPECT_EQ(penumbra::scanElementBytes(ScanType::Long), 8u);
  EXPECT_EQ(penumbra::scanElementBytes(ScanType::Long4), 32u);
}

TEST(Scan, FloatAwkwardSizes) {
  for (Size s : kAwkward) check(ScanType::Float, s, 11);
}
TEST(Scan, Float4AwkwardSizes) {
  for (Size s : kAwkward) check(ScanType::Float4, s, 12);
}
TEST(Scan, LongAwkwardSizes) {
  for (Size s : kAwkward) check(ScanType::Long, s, 13);
}
TEST(Scan, Long4AwkwardSizes) {
  for (Size s : kAwkward) check(ScanType::Long4, s, 14);
}

TEST(Scan, Float4At2048) { check(ScanType::Float4, {2048, 2048, 1}, 21); }
TEST(Scan, Long4At2048IsExact) { check(ScanType::Long4, {2048, 2048, 1}, 22); }

// The banded one-pass method (kernels/common/scan.cl) on every awkward size, with one band, a few,
// more bands than rows (clamped) and a band count that leaves the last band short; integer types
// exactly, float types within one rounding per value (fp64 devices: the sums carried in double;
// additionDepth) or the serial sum's bound. The passes forced (bands 0) on the same sizes, as the
// CPU default no longer runs them.
TEST(Scan, BandedAwkwardSizes) {
  for (int bands : {1, 2, 3, 7, 5000}) {
    SCOPED_TRACE("bands " + std::to_string(bands));
    ScanTuning tune;
    tune.bands = bands;
    for (Size s : kAwkward) {
      check(ScanType::Long4, s, 15, tune);
      check(ScanType::Long, s, 16, tune);
      check(ScanType::Float4, s, 17, tune);
      check(ScanType::Float, s, 24, tune);
    }
  }
}
TEST(Scan, PassesForcedAwkwardSizes) {
  ScanTuning passes;
  passes.bands = 0;
  for (Size s : kAwkward) {
    check(ScanType::Long4, s, 18, passes);
    check(ScanType::Long, s, 19, passes);
    check(ScanType::Float4, s, 25, passes);
    check(ScanType::Float, s, 26, passes);
  }
}

// The float sweep with its sums in double is the more accurate table, not just a faster one: on a
// 2048 x 512 float4 image its largest error, relative to the sum of |inputs| behind each value, is
// within one rounding (2^-24, with the double sums' share), and below the passes' largest on the
// same input (their float additions run through up to ~200 levels). PoCL has fp64; a device
// without it sweeps float tables only when asked, in float, and is held to the serial bound.
TEST(Scan, FloatBandsRoundOnce) {
  const Size s{2048, 512, 1};
  const int L = 4;
  auto in = randomFloats(std::size_t(s.w) * s.h * L, 27);
  auto ref = referenceSat<double>(in, s, L, [](float v) { return double(v); });
  auto mag = referenceSat<double>(in, s, L, [](float v) { return std::fabs(double(v)); });
  auto worst = [&](const ScanTuning& tune) {
    auto got = deviceSat(ScanType::Float4, in, s, tune);
    double w = 0.0;
    for (std::size_t i = 0; i < got.size(); ++i)
      w = std::max(w, std::fabs(double(got[i]) - ref[i]) / mag[i]);
    return w;
  };
  ScanTuning banded, passes;
  banded.bands = 3;
  passes.bands = 0;
  const double b = worst(banded), p = worst(passes);
  std::printf("[ penumbra ] float4 2048x512: largest error / sum|inputs|: banded %.3g, passes "
              "%.3g (2^-24 = %.3g)\n", b, p, std::ldexp(1.0, -24));
  EXPECT_LE(b, 1.01 * additionDepth(s, banded) * std::ldexp(1.0, -24));
  if (ctx().info().fp64) EXPECT_LT(b, p);
}
// The float tables' banded form bit for bit: a host copy of its double sums, in the kernels'
// order (scan.cl: scan_band_offsets' columns four rows a step, each band's carry row, the sweep's
// running sums four rows at a time, then one), rounded to float once. Any output bit that moves
// fails here, where the tolerance of the tests above would let it through: a float sum anywhere,
// a sum lost or counted twice, a scale (the fused form's 1.0 given wrong). A different order of
// the double additions almost never moves an output bit (the rounding to float drops their last
// bits), so this pins the table the sweep must give, not the order it gets there. Inputs span
// 2^-20..2^20 with both signs, so nearly every float addition would round.
static std::vector<float> hostSweep(const std::vector<float>& in, Size s, int L, int bands) {
  const int bandRows = (s.h + bands - 1) / bands;
  const int nb = (s.h + bandRows - 1) / bandRows;
  std::vector<float> out(in.size());
  const std::size_t W = std::size_t(s.w);
  for (int b = 0; b < s.batch; ++b)
    for (int c = 0; c < L; ++c) {
      auto at = [&](int x, int y) { return (std::size_t(b) * s.h * W + std::size_t(y) * W + x) * L + c; };
      std::vector<double> run(W, 0.0);  // scan_band_offsets: the column sums above the band
      for (int band = 0; band < nb; ++band) {
        if (band > 0) {
          const int y1 = band * bandRows;
          int y = y1 - bandRows;
          for (; y + 4 <= y1; y += 4)
            for (std::size_t x = 0; x < W; ++x)
              run[x] = run[x] + double(in[at(int(x), y)]) + double(in[at(int(x), y + 1)]) +
                       double(in[at(int(x), y + 2)]) + double(in[at(int(x), y + 3)]);
          for (; y < y1; ++y)
            for (std::size_t x = 0; x < W; ++x) run[x] += double(in[at(int(x), y)]);
        }
        std::vector<double> above(W, 0.0);  // scan_band_apply_acc's carry row
        if (band > 0) {
          double acc = 0.0;
          for (std::size_t x = 0; x < W; ++x) above[x] = acc += run[x];
        }
        const int y0 = band * bandRows, y1 = std::min(s.h, y0 + bandRows);
        int y = y0;
        for (; y + 4 <= y1; y += 4) {
          double a[4] = {0, 0, 0, 0};
          for (std::size_t x = 0; x < W; ++x) {
            for (int r = 0; r < 4; ++r) a[r] += double(in[at(int(x), y + r)]);
            double sum = above[x];
            for (int r = 0; r < 4; ++r) {
              sum += a[r];
              out[at(int(x), y + r)] = float(sum);
            }
            above[x] = sum;
          }
        }
        for (; y < y1; ++y) {
          double a = 0;
          for (std::size_t x = 0; x < W; ++x) {
            a += double(in[at(int(x), y)]);
            above[x] += a;
            out[at(int(x), y)] = float(above[x]);
          }
        }
      }
    }
  return out;
}

TEST(Scan, FloatBandsAreTheirDoubleSumsBitForBit) {
  ASSERT_TRUE(ctx().info().fp64) << "the float tables' banded form sums in double on fp64 devices";
  std::mt19937 rng(53);
  for (ScanType t : {ScanType::Float, ScanType::Float4})
    for (Size s : {Size{1, 1, 1}, Size{1, 13, 1}, Size{13, 1, 1}, Size{37, 29, 2}, Size{257, 9, 1},
                   Size{64, 67, 1}})
      for (int bands : {1, 3}) {
        const int L = lanes(t);
        std::vector<float> in(std::size_t(s.w) * s.h * s.batch * L);
        for (auto& v : in)
          v = std::ldexp(float(rng() % 2000000) / 1e6f - 1.0f, int(rng() % 41) - 20);
        ScanTuning tune;
        tune.bands = bands;
        const auto got = deviceSat(t, in, s, tune);
        const auto want = hostSweep(in, s, L, bands);
        std::size_t bad = 0;
        for (std::size_t i = 0; i < got.size(); ++i)
          if (std::memcmp(&got[i], &want[i], sizeof(float)) != 0 && bad++ < 3)
            ADD_FAILURE() << label(t, s) << ", " << bands << " bands: scalar " << i << " got "
                          << got[i] << " want " << want[i];
        EXPECT_EQ(bad, 0u) << label(t, s) << ", " << bands << " bands";
      }
}

TEST(Scan, BandedAt2048IsExact) {
  ScanTuning tune;
  tune.bands = 6;  // 2048 rows: five bands of 342 and a short one
  check(ScanType::Long4, {2048, 2048, 1}, 23, tune);
}

// Small integers are exact in float while the sums stay below 2^24, so the float kernels must then
// match exactly: catches indexing slips that a rounding tolerance could hide.
TEST(Scan, FloatIntegerValuesAreExact) {
  for (ScanType t : {ScanType::Float, ScanType::Float4}) {
    Size s{1023, 517, 1};
    const int L = lanes(t);
    std::mt19937 rng(31);
    std::vector<float> in(std::size_t(s.w) * s.h * L);
    for (auto& v : in) v = float(rng() % 8);  // SAT < 8 * 1023 * 517 < 2^23
    auto got = deviceSat(t, in, s);
    auto ref = referenceSat<double>(in, s, L, [](float v) { return double(v); });
    std::size_t bad = 0;
    for (std::size_t i = 0; i < got.size(); ++i)
      if (double(got[i]) != ref[i] && bad++ < 5)
        ADD_FAILURE() << label(t, s) << ": scalar " << i << " got " << got[i] << " want " << ref[i];
    EXPECT_EQ(bad, 0u);
  }
}

// Images of a batch are scanned independently: each equals its own single-image scan, and nothing
// past the batch is written (a sentinel tail in the same buffer).
TEST(Scan, BatchImagesDoNotLeak) {
  const Size s{37, 29, 3};
  const std::size_t img = std::size_t(s.w) * s.h * 4;
  auto in = randomLongs(img * s.batch, 41);
  const std::int64_t sentinel = 0x5a5a5a5a5a5a5a5aLL;
  std::vector<std::int64_t> padded = in;
  padded.resize(in.size() + 4 * 64, sentinel);
  cl::Buffer buf = ctx().upload(padded, "batch");
  penumbra::summedAreaTable(ctx(), buf, ScanType::Long4, s.w, s.h, s.batch, "test");
  auto got = ctx().download<std::int64_t>(buf, padded.size(), "batch");
  for (int b = 0; b < s.batch; ++b) {
    std::vector<std::int64_t> one(in.begin() + b * img, in.begin() + (b + 1) * img);
    auto ref = referenceSat<std::int64_t>(one, {s.w, s.h, 1}, 4, [](std::int64_t v) { return v; });
    EXPECT_TRUE(std::equal(ref.begin(), ref.end(), got.begin() + b * img)) << "image " << b;
  }
  EXPECT_TRUE(std::all_of(got.begin() + in.size(), got.end(),
                          [&](std::int64_t v) { return v == sentinel; }))
      << "the scan wrote past the batch";
}

// The decomposition changes only the summation order: integer tables must not change at all,
// including degenerate groups (1 work-item, 1 value per item, 1-row segments) and rows of many
// tiles.
TEST(Scan, TuningKeepsLongTablesIdentical) {
  const Size s{203, 131, 2};
  // All within the 32 KiB of local memory OpenCL 1.2 guarantees (256 x 2 long4 needs 25 KiB);
  // both column modes, and the device's defaults with each column mode forced.
  // bands 0: the passes (the CPU default for integer types is the banded method); then the banded
  // method with one band, several, and the device's choice.
  const ScanTuning tunings[] = {{1, 1, 1, 0, 0},    {2, 3, 5, 1, 0},  {4, 2, 7, 0, 0},
                                {64, 8, 64, 1, 0},  {256, 2, 200, 0, 0}, {8, 64, 64, 1, 0},
                                {0, 0, 0, 0, 0},    {0, 0, 0, 1, 0},  {0, 0, 0, -1, 1},
                                {0, 0, 0, -1, 4},   {0, 0, 0, -1, 131}, {0, 0, 0, -1, -1}};
  for (const auto& tune : tunings) {
    SCOPED_TRACE("workGroup " + std::to_string(tune.workGroup) + " valuesPerItem " +
                 std::to_string(tune.valuesPerItem) + " segmentRows " +
                 std::to_string(tune.segmentRows) + " columnLockstep " +
                 std::to_string(tune.columnLockstep) + " bands " + std::to_string(tune.bands));
    check(ScanType::Long, s, 51, tune);
    check(ScanType::Long4, s, 52, tune);
  }
}

// Why the moment and energy SATs are 64-bit fixed point (kernels/common/scan.cl): 1024^2
// moment-like values z, z^2, z^3, z^4 (z uniform in [0,1]). A box query is a difference of four
// corners; with round(v * 2^32) in long4 it reproduces the direct sum of the quantized values
// exactly for every box, while the same query on a float4 SAT of the same values is off by orders
// of magnitude more than the fixed-point table's quantization error.
TEST(Scan, BoxFilterFixedPointIsExactFloatIsNot) {
  const int W = 1024, H = 1024;
  const double scale = 4294967296.0;  // 2^32, PB_MOMENT_SCALE
  std::mt19937_64 rng(61);
  std::uniform_real_distribution<double> uz(0.0, 1.0);
  std::vector<double> m(std::size_t(W) * H * 4);
  std::vector<std::int64_t> fixed(m.size());
  std::vector<float> flt(m.size());
  for (std::size_t p = 0; p < std::size_t(W) * H; ++p) {
    double z = uz(rng), zk = 1.0;
    for (int k = 0; k < 4; ++k) {
      zk *= z;
      m[4 * p + k] = zk;
      fixed[4 * p + k] = std::llround(zk * scale);
      flt[4 * p + k] = float(zk);
    }
  }
  auto satFixed = deviceSat(ScanType::Long4, fixed, {W, H, 1});
  auto satFloat = deviceSat(ScanType::Float4, flt, {W, H, 1});

  // box(x0..x1, y0..y1) = S(x1,y1) - S(x0-1,y1) - S(x1,y0-1) + S(x0-1,y0-1), absent corners 0.
  auto box = [&](const auto& sat, int x0, int y0, int x1, int y1, int k) {
    using V = std::decay_t<decltype(sat[0])>;
    auto at = [&](int x, int y) -> V {
      return x < 0 || y < 0 ? V(0) : sat[(std::size_t(y) * W + x) * 4 + k];
    };
    return at(x1, y1) - at(x0 - 1, y1) - at(x1, y0 - 1) + at(x0 - 1, y0 - 1);
  };
  std::uniform_int_distribution<int> pos(0, W - 1);
  double fixedErr = 0, floatErr = 0;
  int queries = 0;
  for (int n : {1, 3, 27}) {
    for (int q = 0; q < 300; ++q) {
      int x0 = std::min(pos(rng), W - n), y0 = std::min(pos(rng), H - n);
      if (q == 0) x0 = y0 = 0;           // touches the top-left border
      if (q == 1) x0 = W - n, y0 = H - n;  // the far corner, where the table is largest
      const int x1 = x0 + n - 1, y1 = y0 + n - 1;
      for (int k = 0; k < 4; ++k) {
        std::int64_t directFixed = 0;
        double directFloat = 0, directTrue = 0;
        for (int y = y0; y <= y1; ++y)
          for (int x = x0; x <= x1; ++x) {
            std::size_t i = (std::size_t(y) * W + x) * 4 + k;
            directFixed += fixed[i];
            directFloat += flt[i];
            directTrue += m[i];
          }
        const std::int64_t bf = box(satFixed, x0, y0, x1, y1, k);
        ASSERT_EQ(bf, directFixed) << "fixed-point box " << n << " at " << x0 << "," << y0;
        fixedErr = std::max(fixedErr, std::fabs(double(bf) / scale - directTrue));
        const double bq = double(box(satFloat, x0, y0, x1, y1, k));
        floatErr = std::max(floatErr, std::fabs(bq - directFloat));
        ++queries;
      }
    }
  }
  std::cout << "[ box filter ] " << queries << " queries on " << W << "x" << H
            << ": max error fixed-point " << fixedErr << ", float " << floatErr << "\n";
  // Quantization alone: at most n^2 * 2^-33 for the largest box.
  EXPECT_LE(fixedErr, 27.0 * 27.0 * std::ldexp(1.0, -33) * 1.001);
  EXPECT_GT(floatErr, 1e3 * fixedErr);
  EXPECT_GT(floatErr, 1e-3);  // comparable to a 1x1 box's own value range
}

TEST(Scan, BadInputThrows) {
  cl::Buffer buf = ctx().buffer(1024, "bad input test");
  auto expectBad = [&](auto&& call, const std::string& mention) {
    try {
      call();
      ADD_FAILURE() << "no exception; expected one mentioning " << mention;
    } catch (const penumbra::Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput) << e.what();
      EXPECT_NE(std::string(e.what()).find(mention), std::string::npos) << e.what();
    }
  };
  auto sat = [&](ScanType t, int w, int h, int b, ScanTuning tune = {}) {
    return [&, t, w, h, b, tune] { penumbra::summedAreaTable(ctx(), buf, t, w, h, b, "t", tune); };
  };
  expectBad(sat(ScanType::Float, 0, 4, 1), "width");
  expectBad(sat(ScanType::Float, 4, 0, 1), "height");
  expectBad(sat(ScanType::Float, 4, -3, 1), "-3");
  expectBad(sat(ScanType::Float, 4, 4, 0), "batch");
  expectBad(sat(ScanType::Float, 1 << 30, 1 << 30, 1 << 30), "overflow");
  expectBad(sat(ScanType::Float, (1 << 30) + 1, 1, 1), "width");
  // 1024 bytes hold 256 floats but only 32 long4s: the type/size mismatch is named.
  expectBad(sat(ScanType::Float, 17, 16, 1), "1024 bytes");
  expectBad(sat(ScanType::Long4, 16, 16, 1), "needs 8192");
  expectBad(sat(static_cast<ScanType>(7), 4, 4, 1), "ScanType");
  expectBad(sat(ScanType::Float, 4, 4, 1, {3, 0, 0}), "power of two");
  expectBad(sat(ScanType::Float, 4, 4, 1, {0, -1, 0}), "tuning");
  expectBad(sat(ScanType::Float, 4, 4, 1, {0, 0, 0, 2}), "columnLockstep");
  expectBad(sat(ScanType::Long, 4, 4, 1, {0, 0, 0, -1, -2}), "bands -2");
  expectBad(sat(ScanType::Float, 4, 4, 1, {1 << 20, 0, 0}), "work-group limit");
  cl::Buffer null;
  EXPECT_THROW(penumbra::summedAreaTable(ctx(), null, ScanType::Float, 1, 1), penumbra::Error);
  // The valid call on the same buffer still works.
  EXPECT_NO_THROW(penumbra::summedAreaTable(ctx(), buf, ScanType::Float, 16, 16, 1));
}

TEST(Scan, StageNames) {
  ctx().resetTimings();
  cl::Buffer buf = ctx().upload(std::vector<float>(8 * 200, 1.0f), "stage test");
  ScanTuning passes;
  passes.bands = 0;  // the passes (a CPU's default is the banded method)
  penumbra::summedAreaTable(ctx(), buf, ScanType::Float, 8, 200, 1, "env/sat", passes);
  std::vector<std::string> names;
  for (auto& [stage, ms] : ctx().stageTimesMs()) names.push_back(stage);
  EXPECT_EQ(names, (std::vector<std::string>{"env/sat/rows", "env/sat/cols/segments",
                                             "env/sat/cols/offsets", "env/sat/cols"}));
  // The banded method: one band is one sweep; more add the bands' offsets (one launch).
  for (int bands : {1, 3}) {
    ctx().resetTimings();
    ScanTuning tune;
    tune.bands = bands;
    cl::Buffer lb = ctx().upload(std::vector<std::int64_t>(8 * 200, 1), "stage test");
    penumbra::summedAreaTable(ctx(), lb, ScanType::Long, 8, 200, 1, "mssm4/sat", tune);
    names.clear();
    for (auto& [stage, ms] : ctx().stageTimesMs()) names.push_back(stage);
    if (bands == 1)
      EXPECT_EQ(names, (std::vector<std::string>{"mssm4/sat/bands"}));
    else
      EXPECT_EQ(names, (std::vector<std::string>{"mssm4/sat/bands/offsets", "mssm4/sat/bands"}));
  }
  ctx().resetTimings();
}

// Small cases for the simulator (also part of the normal run): every type, a batch, a width that
// is not a multiple of anything, and explicit tunings with tiles of 8 and segments of 4 rows so
// that the tile carry and the segment offsets are exercised under race/bounds checking, in both
// column modes. (The simulator calls itself a GPU, so the defaults there are the GPU table's;
// OclgrindScan.CpuKnobs checks the CPU table's.)
TEST(OclgrindScan, Float) {
  check(ScanType::Float, {5, 3, 2}, 71);
  check(ScanType::Float, {33, 17, 1}, 72);
}
TEST(OclgrindScan, Float4) {
  check(ScanType::Float4, {5, 3, 2}, 73);
  check(ScanType::Float4, {33, 17, 1}, 74);
}
TEST(OclgrindScan, Long) {
  check(ScanType::Long, {5, 3, 2}, 75);
  check(ScanType::Long, {33, 17, 1}, 76);
}
TEST(OclgrindScan, Long4) {
  check(ScanType::Long4, {5, 3, 2}, 77);
  check(ScanType::Long4, {33, 17, 1}, 78);
}
TEST(OclgrindScan, ManyTilesAndSegments) {
  for (int lockstep : {0, 1}) {
    const ScanTuning tune{4, 2, 4, lockstep, 0};
    check(ScanType::Float, {33, 17, 2}, 79, tune);
    check(ScanType::Long4, {33, 17, 2}, 80, tune);
  }
}
// The banded method under the simulator: one band (the one-pass sweep) and three (the bands'
// offsets in column strips, then sweeps from them), a batch, integer and float (on a device with
// fp64, the float sweep's double sums; 13 rows: its four-row steps and the rows left over, in one
// band and in bands of 5).
TEST(OclgrindScan, Banded) {
  for (int bands : {1, 3}) {
    ScanTuning tune;
    tune.bands = bands;
    check(ScanType::Long4, {5, 7, 2}, 83, tune);
    check(ScanType::Long, {33, 17, 1}, 84, tune);
    check(ScanType::Float, {33, 17, 2}, 85, tune);
    check(ScanType::Float4, {9, 13, 2}, 86, tune);
  }
}
TEST(OclgrindScan, CpuKnobs) {
  const ScanTuning cpu{8, 64, 64, 1, 0};
  check(ScanType::Float4, {5, 3, 2}, 81, cpu);
  check(ScanType::Long, {33, 70, 1}, 82, cpu);
}
