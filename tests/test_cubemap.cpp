// kernels/envmap.cl against a plain C++ resampling (same sub-sample positions, double sums), on
// awkward map and face sizes, through both the splat and the gather path.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "common.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

Environment randomMap(int w, int h, unsigned seed) {
  Environment env;
  env.source = "random";
  env.equirect = Image(w, h, 3);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (float& v : env.equirect.pixels) v = u(rng) < 0.02f ? 500.0f * u(rng) : u(rng);
  return env;
}

// The reference: the kernels' algorithm in plain C++ with double accumulation.
std::vector<double> referenceCube(const Environment& env, int m, int supersample) {
  const Image& eq = env.equirect;
  const int W = eq.width, H = eq.height;
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
            pb_equirect_dir(s + (i + 0.5f) / SS, t + (j + 0.5f) / SS, float(W), float(H), &x, &y,
                            &z);
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
              int si = std::clamp(int(std::floor(s)), 0, W - 1), ti = std::clamp(int(std::floor(t)), 0, H - 1);
              double dw = pb_cube_texel_solid_angle(uu, vv, m * SS);
              std::size_t k = (std::size_t(f) * m + y) * m + x;
              for (int c = 0; c < 3; ++c) e[c * plane + k] += eq.at(si, ti, c) * dw;
            }
  }
  return e;
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
}

TEST(CubeMap, GatherMatchesReference) {
  compareWithReference(randomMap(1, 1, 5), 4, "1x1 -> 4");
  compareWithReference(randomMap(3, 2, 6), 7, "3x2 -> 7");
  compareWithReference(randomMap(64, 32, 7), 17, "64x32 -> 17");
  compareWithReference(randomMap(1, 40, 8), 33, "1x40 -> 33");
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
