// Greedy fitting of square/rectangular lights (Annen et al. 2008 §4.2): the device fit against a plain C++
// copy of the algorithm and against the properties Annen et al. 2008 gives each light (a check sharing no
// code with the kernel), energy conservation, a known bright square, the lights alone against the
// map above its face means (independent quadrature, negative controls), and the issue's rotation
// and determinism requirements for the extracted light set.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "environment/cubemap.hpp"
#include "environment/greedy.hpp"
#include "common.hpp"
#include "support/extraction_checks.hpp"

using namespace penumbra;
using namespace penumbra::test;
using detail::GreedyRect;

namespace {

using i64 = std::int64_t;

// Plain C++ copy of kernels/environment/greedy.cl's greedy_fit, one face after another. `e` (3
// planes of 6*m*m) is replaced by the remaining map. Moments are in double: the device rounds each
// texel's product to an integer, so those are compared with a tolerance.
struct RefLight {
  GreedyRect r;
  std::array<double, 3> moment{};
};

std::vector<RefLight> referenceGreedy(std::vector<i64>& e, int m, float t, bool square) {
  const std::size_t plane = 6ull * m * m;
  auto lum = [&](std::size_t i) {
    return PB_LUM_FIXED(e[i], e[plane + i], e[2 * plane + i]);
  };
  auto grows = [&](i64 added, i64 held) {
    i64 total = held + added;
    return total == 0 || float(added) > t * float(total);
  };
  const int cap = int(std::min<i64>(i64(m) * m, detail::kGreedyMaxPerFace));
  std::vector<RefLight> out;
  std::vector<char> covered(plane, 0);
  for (int f = 0; f < 6; ++f) {
    const std::size_t base = std::size_t(f) * m * m;
    auto at = [&](int x, int y) { return base + std::size_t(y) * m + x; };
    i64 sum[3] = {0, 0, 0};
    for (int i = 0; i < m * m; ++i)
      for (int c = 0; c < 3; ++c) sum[c] += e[c * plane + base + i];
    i64 avg[3] = {sum[0] / (m * m), sum[1] / (m * m), sum[2] / (m * m)};
    int nCovered = 0, nLights = 0;
    while (nCovered < m * m && nLights < cap) {
      int seed = -1;
      i64 best = -1;
      for (int i = 0; i < m * m; ++i)
        if (!covered[base + i] && lum(base + i) > best) best = lum(base + i), seed = i;
      int x0 = seed % m, y0 = seed / m, x1 = x0 + 1, y1 = y0 + 1;
      i64 held = best;
      for (;;) {
        if (x0 == 0 && y0 == 0 && x1 == m && y1 == m) break;
        bool cl = x0 > 0, cr = x1 < m, ct = y0 > 0, cb = y1 < m;
        i64 sl = 0, sr = 0, st = 0, sb = 0;
        for (int y = y0; y < y1; ++y) {
          if (cl) sl += lum(at(x0 - 1, y));
          if (cr) sr += lum(at(x1, y));
        }
        for (int x = x0; x < x1; ++x) {
          if (ct) st += lum(at(x, y0 - 1));
          if (cb) sb += lum(at(x, y1));
        }
        i64 ctl = cl && ct ? lum(at(x0 - 1, y0 - 1)) : 0, ctr = cr && ct ? lum(at(x1, y0 - 1)) : 0;
        i64 cbl = cl && cb ? lum(at(x0 - 1, y1)) : 0, cbr = cr && cb ? lum(at(x1, y1)) : 0;
        bool grew = false;
        if (square) {
          i64 add[4] = {sl + st + ctl, sr + st + ctr, sl + sb + cbl, sr + sb + cbr};
          bool ok[4] = {cl && ct, cr && ct, cl && cb, cr && cb};
          int d = -1;
          for (int q = 0; q < 4; ++q)
            if (ok[q] && (d < 0 || add[q] > add[d])) d = q;
          if (d >= 0 && grows(add[d], held)) {
            held += add[d];
            if (d & 1) ++x1; else --x0;
            if (d & 2) ++y1; else --y0;
            grew = true;
          }
        } else {
          bool gl = false, gr = false;
          if (cl && grows(sl, held)) held += sl, --x0, gl = true;
          if (cr && grows(sr, held)) held += sr, ++x1, gr = true;
          if (ct) {
            i64 a = st + (gl ? ctl : 0) + (gr ? ctr : 0);
            if (grows(a, held)) held += a, --y0, grew = true;
          }
          if (cb) {
            i64 a = sb + (gl ? cbl : 0) + (gr ? cbr : 0);
            if (grows(a, held)) held += a, ++y1, grew = true;
          }
          grew = grew || gl || gr;
        }
        if (!grew) break;
      }
      RefLight L;
      L.r.face = f; L.r.x0 = x0; L.r.y0 = y0; L.r.x1 = x1; L.r.y1 = y1;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          std::size_t i = at(x, y);
          i64 d[3];
          for (int c = 0; c < 3; ++c) {
            i64 keep = std::min(e[c * plane + i], avg[c]);
            d[c] = e[c * plane + i] - keep;
            e[c * plane + i] = keep;
            L.r.removed[c] += d[c];
          }
          i64 dy = PB_LUM_FIXED(d[0], d[1], d[2]);
          L.r.removed[3] += dy;
          float dx, dyy, dz;
          pb_cube_dir(f, 2.0f * (x + 0.5f) / m - 1.0f, 2.0f * (y + 0.5f) / m - 1.0f, &dx, &dyy, &dz);
          double n = std::sqrt(double(dx) * dx + double(dyy) * dyy + double(dz) * dz);
          L.moment[0] += dy * dx / n;
          L.moment[1] += dy * dyy / n;
          L.moment[2] += dy * dz / n;
          if (!covered[i]) ++nCovered;
          covered[i] = 1;
        }
      out.push_back(L);
      ++nLights;
    }
  }
  return out;
}

// Runs the device fit on `energy` and the reference on a copy; expects identical rectangles,
// taken energies and remaining maps, and moments within the per-texel rounding.
void expectDeviceMatchesReference(const std::vector<i64>& energy, int m, float t, bool square,
                                  const std::string& what, std::size_t workGroupSize = 0) {
  cl::Buffer buf = ctx().upload(energy, "test energy");
  std::vector<GreedyRect> dev = detail::greedyFit(ctx(), buf, m, t, square, workGroupSize);
  auto devRemaining = ctx().download<i64>(buf, energy.size(), "remaining");
  std::vector<i64> ref = energy;
  std::vector<RefLight> host = referenceGreedy(ref, m, t, square);
  ASSERT_EQ(dev.size(), host.size()) << what;
  for (std::size_t i = 0; i < dev.size(); ++i) {
    const GreedyRect &a = dev[i], &b = host[i].r;
    ASSERT_EQ(a.face, b.face) << what << " light " << i;
    const std::array<int, 4> ra{a.x0, a.y0, a.x1, a.y1}, rb{b.x0, b.y0, b.x1, b.y1};
    ASSERT_EQ(ra, rb)
        << what << " light " << i << " face " << a.face;
    ASSERT_EQ(a.removed, b.removed) << what << " light " << i;
    // each texel's Y*w is rounded to an integer on the device: at most 0.5 per texel and axis,
    // plus float rounding of the product (2^-23 relative)
    double tol = 0.5 * (a.x1 - a.x0) * (a.y1 - a.y0) + 1e-6 * double(b.removed[3]) + 1;
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(double(a.moment[c]), host[i].moment[c], tol) << what << " light " << i;
  }
  EXPECT_EQ(devRemaining, ref) << what;
}

std::vector<i64> mapEnergy(const Environment& env, int m) {
  detail::DeviceCube cube = detail::resampleToCube(ctx(), env, m, 4);
  return ctx().download<i64>(cube.energy, 3ull * 6 * m * m, "cube energy");
}

// Heavy-tailed random energies: most texels dim, a few very bright, some exactly zero and some
// ties, which exercise the seed tie-break and the 0/0 growth rule. The tail is cut at 10^12 (like
// the real fixed-point energies, bounded so that a face's sums and the luminance's 10^4 x
// products fit in 64 bits; uncut, a u near 0 gave values whose sums overflowed from 97^2 faces).
std::vector<i64> randomEnergy(int m, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<i64> e(3ull * 6 * m * m);
  const std::size_t plane = 6ull * m * m;
  for (std::size_t i = 0; i < plane; ++i) {
    double r = u(rng);
    i64 base = r < 0.1 ? 0 : r < 0.2 ? 5000 : i64(std::min(std::pow(u(rng), -3.0), 1e9) * 1000);
    for (int c = 0; c < 3; ++c) e[c * plane + i] = base * (2 + c) / 3;
  }
  return e;
}

// An independent check of the fit, sharing no code with greedy.cl or its copy above: the
// properties Annen et al. 2008 §4.2 gives every fitted light, verified on the device's output by replaying
// only the removal rule. Per face, in fitting order, each light
//   - contains the brightest texel not yet covered (its seed; ties: any of them),
//   - is a square in the square variant,
//   - cannot grow: every rim it could add (for squares the four L-shaped rims of one more row and
//     column, for rectangles each side's strip) adds at most t of what the grown light would
//     hold (the growth test; float there, double here, with a relative margin of 1e-5 for the
//     float rounding), unless it is the whole face,
//   - takes from each texel what lies above the face's mean (integer mean of the face's original
//     energies, per channel), exactly, and its luminance (2126 R + 7152 G + 722 B) / 10000 per
//     texel, exactly,
//   - has a moment no longer than its luminance (a mean of unit vectors);
// a face ends when every texel is covered or it holds its most lights; the remaining map is the
// replay's. Returns the first violation, or "" when there is none.
std::string greedyViolation(const std::vector<i64>& energy, int m, float t, bool square,
                            const std::vector<GreedyRect>& fit, const std::vector<i64>& remaining) {
  const std::size_t plane = 6ull * m * m;
  std::vector<i64> e = energy;
  std::vector<char> covered(plane, 0);
  auto lumAt = [&](std::size_t i) {
    return (2126 * e[i] + 7152 * e[plane + i] + 722 * e[2 * plane + i]) / 10000;
  };
  auto grows = [&](double added, double held) { return added > t * (held + added) * (1 + 1e-5); };
  std::size_t next = 0;
  for (int f = 0; f < 6; ++f) {
    const std::size_t base = std::size_t(f) * m * m;
    auto at = [&](int x, int y) { return base + std::size_t(y) * m + x; };
    auto sum = [&](int x0, int y0, int x1, int y1) {  // luminance over [x0,x1) x [y0,y1)
      double v = 0;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) v += double(lumAt(at(x, y)));
      return v;
    };
    i64 mean[3] = {0, 0, 0};
    for (int c = 0; c < 3; ++c) {
      for (int i = 0; i < m * m; ++i) mean[c] += energy[c * plane + base + i];
      mean[c] /= i64(m) * m;
    }
    int count = 0;
    for (; next < fit.size() && fit[next].face == f; ++next, ++count) {
      const GreedyRect& g = fit[next];
      const std::string id = "face " + std::to_string(f) + " light " + std::to_string(count) + ": ";
      if (!(g.x0 >= 0 && g.y0 >= 0 && g.x0 < g.x1 && g.y0 < g.y1 && g.x1 <= m && g.y1 <= m))
        return id + "bad rectangle";
      if (square && g.x1 - g.x0 != g.y1 - g.y0) return id + "not a square";
      i64 brightest = -1;
      for (int i = 0; i < m * m; ++i)
        if (!covered[base + i]) brightest = std::max(brightest, lumAt(base + i));
      bool seeded = false;
      for (int y = g.y0; y < g.y1; ++y)
        for (int x = g.x0; x < g.x1; ++x)
          seeded = seeded || (!covered[at(x, y)] && lumAt(at(x, y)) == brightest);
      if (!seeded) return id + "does not hold the brightest uncovered texel";
      const double held = sum(g.x0, g.y0, g.x1, g.y1);
      const bool cl = g.x0 > 0, cr = g.x1 < m, ct = g.y0 > 0, cb = g.y1 < m;
      bool more = false;
      if (square) {  // the rim towards each corner: one more column and row, corner included
        more = (cl && ct && grows(sum(g.x0 - 1, g.y0 - 1, g.x1, g.y1) - held, held)) ||
               (cr && ct && grows(sum(g.x0, g.y0 - 1, g.x1 + 1, g.y1) - held, held)) ||
               (cl && cb && grows(sum(g.x0 - 1, g.y0, g.x1, g.y1 + 1) - held, held)) ||
               (cr && cb && grows(sum(g.x0, g.y0, g.x1 + 1, g.y1 + 1) - held, held));
      } else {
        more = (cl && grows(sum(g.x0 - 1, g.y0, g.x0, g.y1), held)) ||
               (cr && grows(sum(g.x1, g.y0, g.x1 + 1, g.y1), held)) ||
               (ct && grows(sum(g.x0, g.y0 - 1, g.x1, g.y0), held)) ||
               (cb && grows(sum(g.x0, g.y1, g.x1, g.y1 + 1), held));
      }
      if (more) return id + "stopped while a rim would still grow it";
      std::array<i64, 4> removed{};
      for (int y = g.y0; y < g.y1; ++y)
        for (int x = g.x0; x < g.x1; ++x) {
          const std::size_t i = at(x, y);
          i64 d[3];
          for (int c = 0; c < 3; ++c) {
            const i64 keep = std::min(e[c * plane + i], mean[c]);
            d[c] = e[c * plane + i] - keep;
            e[c * plane + i] = keep;
            removed[c] += d[c];
          }
          removed[3] += (2126 * d[0] + 7152 * d[1] + 722 * d[2]) / 10000;
          covered[i] = 1;
        }
      if (g.removed != removed) return id + "took other energy than above the face mean";
      const double ml = std::sqrt(double(g.moment[0]) * g.moment[0] +
                                  double(g.moment[1]) * g.moment[1] + double(g.moment[2]) * g.moment[2]);
      if (ml > double(removed[3]) * (1 + 1e-6) + 0.5 * (g.x1 - g.x0) * (g.y1 - g.y0) + 1)
        return id + "moment longer than its luminance";
    }
    const int uncovered = int(std::count(covered.begin() + base, covered.begin() + base + m * m, 0));
    const int most = int(std::min<i64>(i64(m) * m, detail::kGreedyMaxPerFace));
    if (uncovered != 0 && count != most) return "face " + std::to_string(f) + ": stopped early";
  }
  if (next != fit.size()) return "lights out of face order";
  if (remaining != e) return "remaining map differs from the replay";
  return "";
}

struct DeviceFit {
  std::vector<GreedyRect> fit;
  std::vector<i64> remaining;
};
DeviceFit deviceFit(const std::vector<i64>& energy, int m, float t, bool square) {
  cl::Buffer buf = ctx().upload(energy, "test energy");
  DeviceFit d;
  d.fit = detail::greedyFit(ctx(), buf, m, t, square);
  d.remaining = ctx().download<i64>(buf, energy.size(), "remaining");
  return d;
}

const float kNormals26[26][3] = {
    {1, 0, 0},  {-1, 0, 0}, {0, 1, 0},  {0, -1, 0}, {0, 0, 1},  {0, 0, -1}, {1, 1, 0},
    {1, -1, 0}, {-1, 1, 0}, {-1, -1, 0}, {1, 0, 1}, {1, 0, -1}, {-1, 0, 1}, {-1, 0, -1},
    {0, 1, 1},  {0, 1, -1}, {0, -1, 1}, {0, -1, -1}, {1, 1, 1}, {1, 1, -1}, {1, -1, 1},
    {1, -1, -1}, {-1, 1, 1}, {-1, 1, -1}, {-1, -1, 1}, {-1, -1, -1}};

std::vector<std::string> allMaps() {
  std::vector<std::string> v;
  for (auto* p : kMaps) v.push_back(data(p));
  v.push_back("builtin");
  return v;
}

// The map turned by 90 degrees about +y: columns shifted by width/4 (exact). A direction with
// azimuth phi = atan2(x, -z) moves to phi + pi/2, i.e. (x, y, z) -> (-z, y, x).
Environment rotated90(const Environment& env) {
  Environment r = env;
  const int W = env.equirect.width, H = env.equirect.height;
  for (int t = 0; t < H; ++t)
    for (int s = 0; s < W; ++s)
      for (int c = 0; c < 3; ++c) r.equirect.at((s + W / 4) % W, t, c) = env.equirect.at(s, t, c);
  return r;
}

// What greedy's lights are meant to carry (Annen et al. 2008 §4.2): on each cube face of m^2 texels, what
// every texel holds above the face's mean, per channel (the rest stays in the map for the
// ambient). By the test's own binning of its quadrature samples (tests/support/
// extraction_checks.hpp): a sample belongs to the face of its largest |coordinate| and to the
// cell of the other two divided by it (which of them is a face's x does not matter: the cells are
// the same sets). Each sample keeps its cell's taken fraction.
xref::Target greedyTarget(const Environment& env, int m, const std::vector<xref::D3>& normals) {
  std::vector<xref::Sample> q = xref::mapSamples(env);
  std::vector<std::size_t> cell(q.size());
  std::vector<xref::D3> e(6ull * m * m, xref::D3{0, 0, 0});
  for (std::size_t i = 0; i < q.size(); ++i) {
    const xref::D3& d = q[i].dir;
    const int axis = std::fabs(d[0]) >= std::fabs(d[1]) && std::fabs(d[0]) >= std::fabs(d[2]) ? 0
                     : std::fabs(d[1]) >= std::fabs(d[2])                                    ? 1
                                                                                             : 2;
    const int face = 2 * axis + (d[axis] < 0);
    const double a = d[(axis + 1) % 3] / std::fabs(d[axis]), b = d[(axis + 2) % 3] / std::fabs(d[axis]);
    const int ca = std::clamp(int((a + 1) / 2 * m), 0, m - 1), cb = std::clamp(int((b + 1) / 2 * m), 0, m - 1);
    cell[i] = (std::size_t(face) * m + cb) * m + ca;
    for (int c = 0; c < 3; ++c) e[cell[i]][c] += q[i].energy[c];
  }
  std::vector<xref::D3> taken(e.size());
  for (int f = 0; f < 6; ++f) {
    xref::D3 mean{0, 0, 0};
    for (int k = 0; k < m * m; ++k)
      for (int c = 0; c < 3; ++c) mean[c] += e[std::size_t(f) * m * m + k][c] / (double(m) * m);
    for (int k = 0; k < m * m; ++k) {
      const std::size_t o = std::size_t(f) * m * m + k;
      for (int c = 0; c < 3; ++c)
        taken[o][c] = e[o][c] > mean[c] ? (e[o][c] - mean[c]) / e[o][c] : 0.0;
    }
  }
  for (std::size_t i = 0; i < q.size(); ++i)
    for (int c = 0; c < 3; ++c) q[i].energy[c] *= taken[cell[i]][c];
  return xref::mapTarget(q, normals);
}

double lumOf(const std::array<float, 3>& p) { return PB_LUM_R * p[0] + PB_LUM_G * p[1] + PB_LUM_B * p[2]; }

}  // namespace

TEST(GreedyKernel, MatchesHostReferenceOnAwkwardSizes) {
  // Faces of 1 texel up to 97 (odd, more rows and columns than a work-group of 32 or 64 has
  // items), at the device's own work-group size (1 on a CPU) and at 32 and 256: the work-group
  // shares out rows and columns, which must change nothing.
  Environment sky = builtinEnvironment(256);
  for (int m : {1, 3, 17, 64, 97})
    for (bool square : {true, false})
      for (std::size_t wg : {0, 32, 256}) {
        std::string what = "m " + std::to_string(m) + (square ? " square" : " rect") + " wg " +
                           std::to_string(wg);
        expectDeviceMatchesReference(mapEnergy(sky, m), m, 0.02f, square, what + " sky", wg);
        expectDeviceMatchesReference(randomEnergy(m, 7 + m), m, 0.02f, square, what + " random",
                                     wg);
      }
  // a larger threshold: many small lights
  expectDeviceMatchesReference(randomEnergy(17, 3), 17, 0.3f, true, "t 0.3 square");
  expectDeviceMatchesReference(randomEnergy(17, 3), 17, 0.3f, false, "t 0.3 rect");
}

TEST(GreedyKernel, ConservesEnergyExactlyAndCoversEveryTexel) {
  for (bool square : {true, false}) {
    const int m = 32;
    std::vector<i64> e = mapEnergy(loadEnvironment(data("envmaps/courtyard.exr")), m);
    cl::Buffer buf = ctx().upload(e, "energy");
    auto lights = detail::greedyFit(ctx(), buf, m, 0.02f, square);
    auto rest = ctx().download<i64>(buf, e.size(), "remaining");
    const std::size_t plane = 6ull * m * m;
    std::array<i64, 3> orig{}, left{}, taken{};
    for (int c = 0; c < 3; ++c)
      for (std::size_t i = 0; i < plane; ++i) {
        orig[c] += e[c * plane + i];
        left[c] += rest[c * plane + i];
        EXPECT_LE(rest[c * plane + i], e[c * plane + i]);  // removal never adds
        EXPECT_GE(rest[c * plane + i], 0);
      }
    std::vector<char> cov(plane, 0);
    for (auto& l : lights) {
      for (int c = 0; c < 3; ++c) taken[c] += l.removed[c];
      for (int y = l.y0; y < l.y1; ++y)
        for (int x = l.x0; x < l.x1; ++x) cov[(std::size_t(l.face) * m + y) * m + x] = 1;
    }
    for (int c = 0; c < 3; ++c) EXPECT_EQ(taken[c] + left[c], orig[c]) << "channel " << c;
    EXPECT_EQ(std::count(cov.begin(), cov.end(), 1), std::ptrdiff_t(plane));
    // the lights take most of a sunny courtyard's energy above the face means
    EXPECT_GT(double(taken[1]), 0.2 * double(orig[1]));
  }
}

TEST(GreedyKernel, BrightSquareBecomesOneLightCoveringIt) {
  // Face 2 (+Y) dim and uniform, with a bright 8x8 block at x 20..27, y 30..37. The first light
  // starts in the block, grows over it (every rim of the block adds more than 2%), and stops at
  // its border (a rim of 17 dim texels adds 17e3 against 64e6 held: 0.03%).
  for (bool square : {true, false}) {
    const int m = 64;
    const std::size_t plane = 6ull * m * m;
    std::vector<i64> e(3 * plane, 1000);
    for (int y = 30; y < 38; ++y)
      for (int x = 20; x < 28; ++x)
        for (int c = 0; c < 3; ++c) e[c * plane + (2ull * m + y) * m + x] = 1000000;
    cl::Buffer buf = ctx().upload(e, "energy");
    auto lights = detail::greedyFit(ctx(), buf, m, 0.02f, square);
    const GreedyRect* first = nullptr;
    for (auto& l : lights)
      if (l.face == 2) { first = &l; break; }
    ASSERT_NE(first, nullptr);
    EXPECT_EQ(first->x0, 20);
    EXPECT_EQ(first->y0, 30);
    EXPECT_EQ(first->x1, 28);
    EXPECT_EQ(first->y1, 38);
    // face mean: (64 * 1e6 + (4096 - 64) * 1e3) / 4096 = 16607 (integer division); the light
    // takes what the block holds above it
    const i64 mean = (64 * 1000000LL + (4096 - 64) * 1000LL) / 4096;
    EXPECT_EQ(first->removed[0], 64 * (1000000 - mean));
  }
}

TEST(Greedy, BrightDiscOnMapGivesStrongestLightAtIt) {
  // A dim map with a bright disc of radius 4 degrees near the +Z face's centre: the strongest
  // light points at the disc (within 1 degree: its square is about the disc's bounding square,
  // in which the disc sits centrally) and carries the disc's energy above the face's mean. It
  // misses at most: the face mean left in each covered texel (about 30 texels x 1/4096 of the
  // face's energy, 0.7%), and the disc's rim texels beyond the final square, which the growth
  // test refused because a rim held under t = 2% of the light (one refused rim, plus the texels
  // on the opposite side of the same order): 5% in all. It never holds more than the disc.
  Environment env;
  env.source = "disc";
  env.equirect = Image(1024, 512, 3, 0.05f);
  const double dir[3] = {0.1, 0.15, 0.983};
  const double len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  const double cosR = std::cos(4.0 * M_PI / 180);
  double discPower = 0;
  for (int t = 0; t < 512; ++t)
    for (int s = 0; s < 1024; ++s) {
      float x, y, z;
      pb_equirect_dir(s + 0.5f, t + 0.5f, 1024, 512, &x, &y, &z);
      if ((x * dir[0] + y * dir[1] + z * dir[2]) / len > cosR) {
        for (int c = 0; c < 3; ++c) env.equirect.at(s, t, c) = 500.0f;
        discPower += 500.0 * env.texelSolidAngle(t);
      }
    }
  LightSet set = extractGreedy(ctx(), env, {});
  ASSERT_FALSE(set.lights.empty());
  const AreaLight& l = set.lights[0];  // strongest first
  double c = (l.direction[0] * dir[0] + l.direction[1] * dir[1] + l.direction[2] * dir[2]) / len;
  EXPECT_GT(c, std::cos(1.0 * M_PI / 180));
  EXPECT_NEAR(l.power[1] / discPower, 1.0, 0.05);
  EXPECT_LE(l.power[1], discPower * 1.001);  // fixed-point and resampling rounding
  EXPECT_EQ(l.regions.size(), 1u);
  EXPECT_EQ(l.regions[0][0], 4);  // +Z face
}

// The fit against properties it must have, by a check that shares no code with greedy.cl
// (greedyViolation), on random energies with ties and zeros and on the sky, both variants; and
// negative controls, fits made wrong by hand, which the check must refuse.
TEST(GreedyKernel, FitHasTheGreedyPropertiesIndependentOfTheKernel) {
  Environment sky = builtinEnvironment(256);
  for (int m : {3, 17, 32})
    for (bool square : {true, false})
      for (float t : {0.02f, 0.3f}) {
        const std::string what = "m " + std::to_string(m) + (square ? " square" : " rect") +
                                 " t " + std::to_string(t);
        for (const auto& energy : {randomEnergy(m, 40 + m), mapEnergy(sky, m)}) {
          const DeviceFit d = deviceFit(energy, m, t, square);
          EXPECT_EQ(greedyViolation(energy, m, t, square, d.fit, d.remaining), "") << what;
        }
      }
  // Controls on one real fit: each wrong fit must be refused.
  const int m = 17;
  const std::vector<i64> energy = randomEnergy(m, 57);
  const DeviceFit d = deviceFit(energy, m, 0.02f, true);
  ASSERT_GE(d.fit.size(), 3u);
  auto refused = [&](std::vector<GreedyRect> fit, const char* what) {
    const std::string v = greedyViolation(energy, m, 0.02f, true, fit, d.remaining);
    std::printf("[ control ] %s: %s\n", what, v.c_str());
    EXPECT_NE(v, "") << what;
  };
  std::vector<GreedyRect> f(d.fit.begin() + 1, d.fit.end());
  refused(f, "first light dropped");
  f = d.fit;
  std::swap(f[0], f[1]);
  refused(f, "first two lights swapped");
  f = d.fit;
  for (auto& g : f)
    if (g.x1 - g.x0 > 1) {
      --g.x1, --g.y1;  // a square one texel smaller
      break;
    }
  refused(f, "a square shrunk by a texel");
  f = d.fit;
  f[0].removed[1] /= 2;
  refused(f, "half the green taken");
  f = d.fit;
  f[0].x0 = f[0].x1 - 1, f[0].y0 = f[0].y1 - 1;
  refused(f, "first light its seed texel only");
}

namespace {

constexpr double kIssue4IrradianceBound = 0.02;
constexpr double kGreedyLightsRegressionBound = 0.12;

// Greedy's lights alone against what they are meant to carry (greedyTarget: the map above each
// face's mean, the test's own binning and quadrature), at the defaults but keeping every light
// (maxLights = PB_MAX_LIGHTS; 19-24 lights are found on the test maps, so none is dropped at the
// default 64 either). Power: the lights carry the taken energy, so the difference is the two
// binnings' (the device's fixed point and float directions vs the test's double): issue 4's 1%,
// measured 0.000%. Irradiance on the 26 normals, as a fraction of the whole map's irradiance
// there (the target is near zero on normals facing away from every light): issue 4's 2% is not
// met (KnownGap below): the squares' caps differ from the squares where they straddle a normal's
// horizon, and a square holding a gradient puts its cap off the square's centre. Measured worst
// luminance 9.9% courtyard, 6.3% interior, 4.7% builtin, 0.85% studio (means 2.0/0.5/0.4/0.1%);
// RegressionBound 12% (the 9.9% + 2.1 points). Negative controls, asserted to fail it: no lights
// 73-96%, directions negated 149-652%, power halved 37-48% (and 50% in power).
// Replaces "lights + SH9 ambient within 8% / 30% of the map", which an empty set passes too.
double greedyLightsWorst(const std::vector<Environment>& envs, bool controls) {
  double worst = 0;
  for (const Environment& env : envs) {
    GreedyOptions o;
    o.maxLights = PB_MAX_LIGHTS;
    const LightSet set = extractGreedy(ctx(), env, o);
    EXPECT_LT(set.lights.size(), std::size_t(PB_MAX_LIGHTS)) << env.source << ": lights dropped";
    const xref::Target t = greedyTarget(env, o.faceSize, xref::testNormals());
    const xref::Target map = xref::mapTarget(xref::mapSamples(env), xref::testNormals());
    const xref::LightsError e = xref::lightsError(set, t, &map);
    worst = std::max(worst, e.worstLum);
    std::printf("[ measured ] greedy %s (%zu lights) alone vs the map above its face means: power "
                "%.3f%%, irradiance on 26 normals worst luminance %.2f%% (mean %.2f%%), any "
                "channel %.2f%%\n",
                env.source.c_str(), set.lights.size(), 100 * e.power, 100 * e.worstLum,
                100 * e.meanLum, 100 * e.worstRgb);
    EXPECT_LT(e.power, 0.01) << env.source;
    if (!controls) continue;
    const xref::LightsError c[3] = {xref::lightsError(xref::withoutLights(set), t, &map),
                                    xref::lightsError(xref::negated(set), t, &map),
                                    xref::lightsError(xref::halved(set), t, &map)};
    std::printf("[ control ] greedy %s: no lights / negated / halved: worst luminance "
                "%.1f%% / %.1f%% / %.1f%%, power %.1f%% / %.1f%% / %.1f%%\n",
                env.source.c_str(), 100 * c[0].worstLum, 100 * c[1].worstLum, 100 * c[2].worstLum,
                100 * c[0].power, 100 * c[1].power, 100 * c[2].power);
    for (auto& k : c) EXPECT_GT(k.worstLum, kGreedyLightsRegressionBound) << env.source;
  }
  return worst;
}

}  // namespace

TEST(Greedy, RegressionBoundLightsCarryTheMapAboveItsFaceMeans) {
  std::vector<Environment> envs;
  for (const std::string& path : allMaps()) envs.push_back(environmentFrom(path));
  EXPECT_LT(greedyLightsWorst(envs, true), kGreedyLightsRegressionBound);
}

// Issue 4's 2% for greedy's lights: not met (above; courtyard, the worst map, alone here: measured
// 9.9%). Fails the day it is met: then assert the 2% above.
TEST(Greedy, LightsKnownGapToIssue4Bound) {
  EXPECT_GT(greedyLightsWorst({loadEnvironment(data("envmaps/courtyard.exr"))}, false),
            kIssue4IrradianceBound);
}

TEST(Greedy, Rotating90DegreesRotatesTheLights) {
  // Square lights (the default, the paper's choice): the fit only compares rims of equal shape,
  // so a quarter turn of the map, which maps cube texels onto cube texels, turns the fitted
  // squares with it. Lights are matched by the direction of their square's centre (a bright
  // light and a later, dimmer square grown over it can point within a degree of each other, so
  // matching by light direction alone could pair the wrong two), then compared: direction within
  // 1 degree, power within 1%.
  auto centre = [](const AreaLight& l, int m) {
    auto& r = l.regions.at(0);
    float x, y, z;
    pb_cube_dir(r[0], float(r[1] + r[3]) / m - 1.0f, float(r[2] + r[4]) / m - 1.0f, &x, &y, &z);
    float n = std::sqrt(x * x + y * y + z * z);
    return std::array<float, 3>{x / n, y / n, z / n};
  };
  auto area = [](const AreaLight& l) {
    auto& r = l.regions.at(0);
    return (r[3] - r[1]) * (r[4] - r[2]);
  };
  for (const std::string& path : allMaps()) {
    Environment env = environmentFrom(path);
    ASSERT_EQ(env.equirect.width % 4, 0) << path;
    LightSet a = extractGreedy(ctx(), env, {});
    LightSet b = extractGreedy(ctx(), rotated90(env), {});
    ASSERT_EQ(a.lights.size(), b.lights.size()) << path;
    for (auto& la : a.lights) {
      auto ca = centre(la, a.faceSize);
      std::array<float, 3> rc = {-ca[2], ca[1], ca[0]};
      const AreaLight* best = nullptr;
      double bestCos = -2;
      for (auto& lb : b.lights) {
        if (area(lb) != area(la)) continue;
        auto cb = centre(lb, b.faceSize);
        double c = rc[0] * cb[0] + rc[1] * cb[1] + rc[2] * cb[2];
        if (c > bestCos) bestCos = c, best = &lb;
      }
      ASSERT_NE(best, nullptr) << path;
      std::array<float, 3> r = {-la.direction[2], la.direction[1], la.direction[0]};
      double c = r[0] * best->direction[0] + r[1] * best->direction[1] + r[2] * best->direction[2];
      EXPECT_LT(std::acos(std::min(1.0, c)) * 180 / M_PI, 1.0) << path;
      EXPECT_NEAR(lumOf(best->power) / lumOf(la.power), 1.0, 0.01) << path;
    }
  }
}

TEST(Greedy, SameInputSameLightsBitForBit) {
  Environment env = loadEnvironment(data("envmaps/studio.exr"));
  for (bool square : {true, false}) {
    GreedyOptions o;
    o.square = square;
    EXPECT_EQ(extractGreedy(ctx(), env, o).toJson(), extractGreedy(ctx(), env, o).toJson());
  }
}

TEST(Greedy, RefusesBadOptions) {
  Environment env = builtinEnvironment(64);
  auto expectBad = [&](GreedyOptions o) {
    try {
      extractGreedy(ctx(), env, o);
      ADD_FAILURE() << "accepted bad options";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput) << e.what();
    }
  };
  GreedyOptions o;
  o.threshold = 0; expectBad(o);
  o.threshold = 1; expectBad(o);
  o.threshold = NAN; expectBad(o);
  o = {}; o.faceSize = 0; expectBad(o);
  o = {}; o.faceSize = 1025; expectBad(o);
  o = {}; o.maxLights = 0; expectBad(o);
}

TEST(Greedy, DeviceTime) {
  // Not a bound (the machine is shared): records the device time per stage for the report.
  ctx().resetTimings();
  for (const std::string& path : allMaps()) {
    Environment env = environmentFrom(path);
    for (int m : {64, 128}) {
      GreedyOptions o;
      o.faceSize = m;
      ctx().resetTimings();
      LightSet s = extractGreedy(ctx(), env, o);
      for (auto& [stage, ms] : ctx().stageTimesMs())
        std::printf("greedy %s m=%d lights=%zu %s %.2f ms\n", path.c_str(), m, s.lights.size(),
                    stage.c_str(), ms);
      EXPECT_FALSE(s.lights.empty());
    }
  }
}

TEST(OclgrindGreedy, TinyMap) {
  // m = 3 with ties and zeros, both variants, against the reference; m = 5 with a work-group of
  // 4, so rows and columns are shared out and some items get two (the race checks see the
  // barriers and the column flags at work).
  expectDeviceMatchesReference(randomEnergy(3, 11), 3, 0.02f, true, "oclgrind square");
  expectDeviceMatchesReference(randomEnergy(3, 11), 3, 0.1f, false, "oclgrind rect");
  expectDeviceMatchesReference(randomEnergy(5, 13), 5, 0.1f, true, "oclgrind square wg 4", 4);
  expectDeviceMatchesReference(randomEnergy(5, 13), 5, 0.1f, false, "oclgrind rect wg 4", 4);
}
