// kernels/environment/envmap.cl against a plain C++ resampling (same sub-sample positions, double
// sums), on awkward map and face sizes, turned and not, through both the splat and the gather path;
// the splat's strips and the context's reused buffers against themselves, bit for bit. And, sharing
// no code with shared.h: texel energies of a constant map against the exact solid angles of cube
// texels, and known directions landing on known texels of the documented face layout.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>

#include "common.hpp"
#include "support/extraction_checks.hpp"
#include "environment/cubemap.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

Environment randomMap(int w, int h, unsigned seed, float rotationYDeg = 0) {
  Environment env;
  env.source = "random";
  env.equirect = Image(w, h, 3);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (float& v : env.equirect.pixels) v = u(rng) < 0.02f ? 500.0f * u(rng) : u(rng);
  env.rotationYDeg = rotationYDeg;
  return env;
}

// The reference: the kernels' algorithm in plain C++ with double accumulation.
std::vector<double> referenceCube(const Environment& env, int m, int supersample) {
  const Image& eq = env.equirect;
  const int W = eq.width, H = eq.height;
  const float shift = env.rotationColumns();
  const bool splat = W >= 4 * m;
  const double ratio = splat ? 4.0 * m / W : W / (4.0 * m);
  const int SS = std::clamp(int(std::ceil(2.0 * ratio)), 1, supersample);
  std::vector<double> e(3ull * 6 * m * m, 0.0);
  const std::size_t plane = 6ull * m * m;
  if (splat) {
    for (int t = 0; t < H; ++t)
      for (int s = 0; s < W; ++s)
        for (int j = 0; j < SS; ++j) {
          double th0 = M_PI * (t + double(j) / SS) / H, th1 = M_PI * (t + double(j + 1) / SS) / H;
          double dw = 2 * M_PI / W * (std::cos(th0) - std::cos(th1)) / SS;
          for (int i = 0; i < SS; ++i) {
            float x, y, z, uu, vv;
            pb_equirect_dir(pb_env_world_column(s, shift, W) + (i + 0.5f) / SS,
                            t + (j + 0.5f) / SS, float(W), float(H), &x, &y, &z);
            int f = pb_cube_face(x, y, z, &uu, &vv);
            int cx = std::clamp(int(std::floor((uu + 1) * 0.5f * m)), 0, m - 1);
            int cy = std::clamp(int(std::floor((vv + 1) * 0.5f * m)), 0, m - 1);
            std::size_t k = (std::size_t(f) * m + cy) * m + cx;
            for (int c = 0; c < 3; ++c) e[c * plane + k] += eq.at(s, t, c) * dw;
          }
        }
  } else {
    for (int f = 0; f < 6; ++f)
      for (int y = 0; y < m; ++y)
        for (int x = 0; x < m; ++x)
          for (int j = 0; j < SS; ++j)
            for (int i = 0; i < SS; ++i) {
              float uu = 2.0f * (x + (i + 0.5f) / SS) / m - 1, vv = 2.0f * (y + (j + 0.5f) / SS) / m - 1;
              float dx, dy, dz, s, t;
              pb_cube_dir(f, uu, vv, &dx, &dy, &dz);
              pb_dir_equirect(dx, dy, dz, float(W), float(H), &s, &t);
              int si = pb_env_column(s, shift, W), ti = std::clamp(int(std::floor(t)), 0, H - 1);
              double dw = pb_cube_texel_solid_angle(uu, vv, m * SS);
              std::size_t k = (std::size_t(f) * m + y) * m + x;
              for (int c = 0; c < 3; ++c) e[c * plane + k] += eq.at(si, ti, c) * dw;
            }
  }
  return e;
}

// The device's fixed-point cube (3 planes of 6 m^2 longs) as resampleToCube leaves it.
std::vector<cl_long> deviceCube(const Environment& env, int m, int strip = 16) {
  detail::DeviceCube c = detail::resampleToCube(ctx(), env, m, 4, strip);
  return ctx().download<cl_long>(c.energy, 3ull * 6 * m * m, "cube energy");
}

void compareWithReference(const Environment& env, int m, const std::string& what) {
  Image dev = cubeMapEnergy(ctx(), env, m, 4);
  ASSERT_EQ(dev.width, m);
  ASSERT_EQ(dev.height, 6 * m);
  auto ref = referenceCube(env, m, 4);
  const std::size_t plane = 6ull * m * m;
  double devSum = 0, refSum = 0, maxRef = 0;
  for (std::size_t k = 0; k < plane; ++k)
    for (int c = 0; c < 3; ++c) {
      devSum += dev.pixels[k * 3 + c];
      refSum += ref[c * plane + k];
      maxRef = std::max(maxRef, ref[c * plane + k]);
    }
  EXPECT_NEAR(devSum / refSum, 1.0, 1e-5) << what;
  // Texel by texel: identical up to float rounding; a sub-sample whose centre lies within float
  // rounding of a texel border may land on the other side on the device (at most 0.5%).
  std::size_t off = 0;
  for (std::size_t k = 0; k < plane; ++k)
    for (int c = 0; c < 3; ++c) {
      double r = ref[c * plane + k], d = dev.pixels[k * 3 + c];
      if (std::fabs(d - r) > 1e-4 * std::max(r, 1e-3 * maxRef)) ++off;
    }
  EXPECT_LE(double(off), 0.005 * 3 * plane + 1) << what << ": " << off << " texel values differ";
}

}  // namespace

TEST(CubeMap, SplatMatchesReference) {
  compareWithReference(randomMap(64, 32, 1), 16, "64x32 -> 16");
  compareWithReference(randomMap(97, 51, 2), 3, "97x51 -> 3");
  compareWithReference(randomMap(8, 3, 3), 1, "8x3 -> 1");
  compareWithReference(randomMap(256, 128, 4), 64, "256x128 -> 64");
  // 4 sub-texels per map texel (4m / W > 1/2), a face wider than a work-group, a map width that
  // is no multiple of the splat's strip, turned by a fractional and a whole number of columns
  compareWithReference(randomMap(4, 1, 9), 1, "4x1 -> 1");
  compareWithReference(randomMap(5, 2, 10, 10.0f), 1, "5x2 turned 10 -> 1");
  compareWithReference(randomMap(67, 33, 11, 33.3f), 16, "67x33 turned 33.3 -> 16");
  compareWithReference(randomMap(401, 203, 12), 100, "401x203 -> 100");
  compareWithReference(randomMap(256, 128, 13, 90.0f), 64, "256x128 turned 90 -> 64");
}

TEST(CubeMap, GatherMatchesReference) {
  compareWithReference(randomMap(1, 1, 5), 4, "1x1 -> 4");
  compareWithReference(randomMap(3, 2, 6), 7, "3x2 -> 7");
  compareWithReference(randomMap(64, 32, 7), 17, "64x32 -> 17");
  compareWithReference(randomMap(1, 40, 8), 33, "1x40 -> 33");
  compareWithReference(randomMap(3, 1, 14), 1, "3x1 -> 1");
  compareWithReference(randomMap(31, 17, 15, 33.3f), 9, "31x17 turned 33.3 -> 9");
  compareWithReference(randomMap(101, 51, 16), 65, "101x51 -> 65");
}

// The splat merges a strip's adds in integers (kernels/environment/envmap.cl slot_add), and integer
// sums do not depend on their order: every strip width, one texel per work-item included, must give
// the same bits.
TEST(CubeMap, SplatStripsGiveIdenticalBits) {
  for (auto [w, h, m, rot] : {std::tuple{67, 33, 16, 33.3f}, std::tuple{401, 203, 100, 0.0f},
                              std::tuple{97, 51, 3, 0.0f}, std::tuple{256, 128, 64, 90.0f}}) {
    Environment env = randomMap(w, h, unsigned(w + m), rot);
    const std::vector<cl_long> one = deviceCube(env, m, 1);
    for (int strip : {2, 3, 16, w, w + 5})
      EXPECT_TRUE(deviceCube(env, m, strip) == one)
          << w << "x" << h << " -> " << m << " strip " << strip;
  }
  EXPECT_THROW(deviceCube(randomMap(8, 4, 1), 2, 0), Error);
}

// The map, cube and SAT buffers are the context's, reused by the next extraction: what a larger
// or a different earlier resample left in them must not show (the splat clears its cube, the
// gather writes every texel).
TEST(CubeMap, ReusedBuffersLeaveNoTrace) {
  const Environment small = randomMap(97, 51, 21, 12.0f), large = randomMap(401, 203, 22);
  const std::vector<cl_long> splat = deviceCube(small, 5), gather = deviceCube(small, 40);
  deviceCube(large, 100);
  deviceCube(large, 120);
  EXPECT_TRUE(deviceCube(small, 5) == splat);
  EXPECT_TRUE(deviceCube(small, 40) == gather);
  MedianCutOptions mo;
  mo.faceSize = 16;
  mo.lights = 16;
  const LightSet a = extractMedianCut(ctx(), small, mo);
  mo.faceSize = 64;
  extractMedianCut(ctx(), large, mo);
  mo.faceSize = 16;
  const LightSet b = extractMedianCut(ctx(), small, mo);
  ASSERT_EQ(a.lights.size(), b.lights.size());
  for (std::size_t i = 0; i < a.lights.size(); ++i) {
    EXPECT_EQ(a.lights[i].direction, b.lights[i].direction) << i;
    EXPECT_EQ(a.lights[i].power, b.lights[i].power) << i;
  }
}

// The splat's tables and strips and the gather with its column table on tiny maps, turned, under
// oclgrind's race and API checks (the splat's adds are atomics; each table entry and gathered
// texel has one writer).
TEST(OclgrindCubeMap, SplatTablesAndGather) {
  compareWithReference(randomMap(9, 4, 31, 37.5f), 2, "9x4 turned 37.5 -> 2");  // 4 sub-texels
  compareWithReference(randomMap(13, 5, 32), 1, "13x5 -> 1");
  compareWithReference(randomMap(5, 3, 33, 37.5f), 3, "5x3 turned 37.5 -> 3");  // gather
  Environment env = randomMap(21, 7, 34, 10.0f);
  EXPECT_TRUE(deviceCube(env, 5, 1) == deviceCube(env, 5, 4));
}

TEST(CubeMap, SplatConservesTheMapsPowerExactly) {
  Environment env = loadEnvironment(data("envmaps/courtyard.exr"));
  Image cube = cubeMapEnergy(ctx(), env, 256);
  double p[3], q[3] = {0, 0, 0};
  env.power(p);
  for (std::size_t i = 0; i < cube.pixels.size(); i += 3)
    for (int c = 0; c < 3; ++c) q[c] += cube.pixels[i + c];
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(q[c] / p[c], 1.0, 1e-5);
}

TEST(CubeMap, ConstantMapGivesConstantRadiance) {
  Environment env = loadEnvironment(data("envmaps/bad/one_pixel.exr"));
  const int m = 8;
  Image cube = cubeMapEnergy(ctx(), env, m);
  for (int f = 0; f < 6; ++f)
    for (int y = 0; y < m; ++y)
      for (int x = 0; x < m; ++x) {
        float u = 2.0f * (x + 0.5f) / m - 1, v = 2.0f * (y + 0.5f) / m - 1;
        // radiance = energy / solid angle; sub-samples make it the texel's mean, not its centre's
        float L = cube.at(x, f * m + y, 1) / pb_cube_texel_solid_angle(u, v, m);
        EXPECT_NEAR(L / env.equirect.pixels[1], 1.0, 0.02);
      }
}

TEST(CubeMap, RefusesBadFaceSize) {
  Environment env = builtinEnvironment(16);
  EXPECT_THROW(cubeMapEnergy(ctx(), env, 0), Error);
  EXPECT_THROW(cubeMapEnergy(ctx(), env, 5000), Error);
}

namespace {

// Exact solid angle of the cube-face rectangle [u0,u1] x [v0,v1] (face at distance 1), in double:
// the integral of (1 + u^2 + v^2)^(-3/2) du dv, whose antiderivative is atan(u v / sqrt(1 + u^2 +
// v^2)).
double cubeRectSolidAngle(double u0, double u1, double v0, double v1) {
  auto F = [](double u, double v) { return std::atan(u * v / std::sqrt(1 + u * u + v * v)); };
  return F(u1, v1) - F(u0, v1) - F(u1, v0) + F(u0, v0);
}

// The face layout cubeMapEnergy documents (environment.hpp: faces +X, -X, +Y, -Y, +Z, -Z; texel
// (x, y) of face f at u = 2 (x + 1/2) / m - 1, v likewise from y), written out here as each face's
// axis and the directions of growing u and v: a direction is major + u uAxis + v vAxis.
struct FaceAxes {
  xref::D3 major, uAxis, vAxis;
};
const FaceAxes kFaces[6] = {
    {{1, 0, 0}, {0, 0, -1}, {0, -1, 0}}, {{-1, 0, 0}, {0, 0, 1}, {0, -1, 0}},
    {{0, 1, 0}, {1, 0, 0}, {0, 0, 1}},   {{0, -1, 0}, {1, 0, 0}, {0, 0, -1}},
    {{0, 0, 1}, {1, 0, 0}, {0, -1, 0}},  {{0, 0, -1}, {-1, 0, 0}, {0, -1, 0}}};

}  // namespace

// A constant map of radiance 1 resampled to the cube: every texel's energy is its solid angle,
// against the exact double-precision solid angle of the texel's rectangle, and the faces sum to
// 4 pi. Splat (map wider than 4 faces) and gather (narrower), each with one sub-sample here (the
// resampling sub-samples only as finely as the two grids' ratio needs, ceil(2 ratio) = 1).
// Splat, 512x256 -> 8: each map texel goes whole to the cube texel of its centre, so a cube texel
// is off by the map texels its border cuts; measured worst 4.7% (near the poles, where a row's
// texels are wedges reaching across a border), bound 6%; the sum is exact (measured -3.5e-8,
// bound 1e-5). Gather, 8x4 -> 16: each cube texel weighted by its centre's solid-angle density
// (midpoint rule, error ~ (2/m)^2 / 24 x the density's curvature); measured worst 0.38% per
// texel, sum +0.096%; bounds 0.5% and 0.2%. A wrong weighting (uniform per texel, or the density
// without its (1 + u^2 + v^2)^(-3/2)) would be off by up to 5x between centre and corner texels.
TEST(CubeMap, ConstantMapTexelsHoldTheirExactSolidAngles) {
  struct Case {
    int w, h, m;
    double texelBound, sumBound;
  };
  for (const Case& k : {Case{512, 256, 8, 0.06, 1e-5}, Case{8, 4, 16, 0.005, 0.002}}) {
    Environment env;
    env.source = "constant";
    env.equirect = Image(k.w, k.h, 3, 1.0f);
    const int m = k.m;
    Image cube = cubeMapEnergy(ctx(), env, m, 4);
    double sum = 0, worst = 0;
    for (int f = 0; f < 6; ++f)
      for (int y = 0; y < m; ++y)
        for (int x = 0; x < m; ++x) {
          const double want = cubeRectSolidAngle(2.0 * x / m - 1, 2.0 * (x + 1) / m - 1,
                                                 2.0 * y / m - 1, 2.0 * (y + 1) / m - 1);
          const double got = cube.at(x, f * m + y, 1);
          sum += got;
          worst = std::max(worst, std::fabs(got / want - 1));
          EXPECT_NEAR(got / want, 1.0, k.texelBound) << k.w << "x" << k.h << " face " << f << " texel " << x << "," << y;
        }
    std::printf("[ measured ] constant %dx%d -> %d: worst texel energy vs exact solid angle %.2g, "
                "sum / 4 pi - 1 = %.2g\n", k.w, k.h, m, worst, sum / (4 * M_PI) - 1);
    EXPECT_NEAR(sum / (4 * M_PI), 1.0, k.sumBound);
  }
}

// A black map with a small bright disc (radius 2 degrees, well inside a 14-degree texel) centred
// on a texel centre of each face, at two texels placed asymmetrically, (1, 6) and (5, 2) on an
// 8 x 8 face: the disc's energy lands on that texel of that face, as the documented layout
// (kFaces, written here from environment.hpp / shared.h's comment table, not its code) places it.
// A face swapped or an axis flipped moves it to another texel. The disc is painted with the test's
// own equirect convention (xref::equirectDir).
TEST(CubeMap, KnownDirectionsLandOnKnownTexels) {
  const int m = 8, W = 512, H = 256;
  const double cosR = std::cos(2.0 * M_PI / 180);
  for (int f = 0; f < 6; ++f)
    for (auto [tx, ty] : {std::pair{1, 6}, std::pair{5, 2}}) {
      const double u = 2.0 * (tx + 0.5) / m - 1, v = 2.0 * (ty + 0.5) / m - 1;
      xref::D3 d;
      for (int i = 0; i < 3; ++i) d[i] = kFaces[f].major[i] + u * kFaces[f].uAxis[i] + v * kFaces[f].vAxis[i];
      const double len = std::sqrt(xref::dot3(d, d));
      for (double& c : d) c /= len;
      Environment env;
      env.source = "disc";
      env.equirect = Image(W, H, 3, 0.0f);
      for (int t = 0; t < H; ++t)
        for (int s = 0; s < W; ++s)
          if (xref::dot3(xref::equirectDir(s + 0.5, t + 0.5, W, H), d) >= cosR)
            for (int c = 0; c < 3; ++c) env.equirect.at(s, t, c) = 1.0f;
      Image cube = cubeMapEnergy(ctx(), env, m, 4);
      double total = 0;
      for (float e : cube.pixels) total += e;
      const double there = cube.at(tx, f * m + ty, 0) + cube.at(tx, f * m + ty, 1) + cube.at(tx, f * m + ty, 2);
      EXPECT_GT(there, 0.999 * total) << "face " << f << " texel " << tx << "," << ty;
    }
}
