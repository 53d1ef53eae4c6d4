// Environment maps: loading, sanitizing, solid angles, bad files.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "common.hpp"

using namespace penumbra;
using penumbra::test::data;

TEST(Environment, CubeSolidAnglesSumToFourPi) {
  // DESIGN.md: dw = 4/m^2 (1+u^2+v^2)^(-3/2); six faces sum to 4 pi (to 1e-5 relative at m=256).
  for (int m : {64, 256, 512}) {
    double sum = 0;
    for (int f = 0; f < 6; ++f)
      for (int y = 0; y < m; ++y)
        for (int x = 0; x < m; ++x)
          sum += pb_cube_texel_solid_angle(2.0f * (x + 0.5f) / m - 1.0f,
                                           2.0f * (y + 0.5f) / m - 1.0f, m);
    EXPECT_NEAR(sum / (4 * M_PI), 1.0, m >= 256 ? 1e-5 : 1e-4) << "m=" << m;
  }
}

TEST(Environment, CubeFaceMappingRoundTrips) {
  for (int f = 0; f < 6; ++f)
    for (float u : {-0.9f, -0.2f, 0.0f, 0.55f, 0.99f})
      for (float v : {-0.95f, 0.1f, 0.7f}) {
        float x, y, z, u2, v2;
        pb_cube_dir(f, u, v, &x, &y, &z);
        int f2 = pb_cube_face(x, y, z, &u2, &v2);
        EXPECT_EQ(f2, f);
        EXPECT_NEAR(u2, u, 1e-6);
        EXPECT_NEAR(v2, v, 1e-6);
      }
}

TEST(Environment, EquirectMappingRoundTrips) {
  for (float s : {0.5f, 100.25f, 511.5f})
    for (float t : {0.5f, 64.0f, 200.75f}) {
      float x, y, z, s2, t2;
      pb_equirect_dir(s, t, 512, 256, &x, &y, &z);
      pb_dir_equirect(x, y, z, 512, 256, &s2, &t2);
      EXPECT_NEAR(s2, s, 1e-3);
      EXPECT_NEAR(t2, t, 1e-3);
    }
}

TEST(Environment, EquirectSolidAnglesSumToFourPi) {
  Environment env = loadEnvironment(data("envmaps/studio.exr"));
  double sum = 0;
  for (int t = 0; t < env.equirect.height; ++t) sum += env.texelSolidAngle(t) * env.equirect.width;
  EXPECT_NEAR(sum, 4 * M_PI, 1e-9);
}

TEST(Environment, LoadsExrHdrAndAgrees) {
  Environment exr = loadEnvironment(data("envmaps/courtyard.exr"));
  Environment hdr = loadEnvironment(data("envmaps/courtyard.hdr"));
  ASSERT_EQ(exr.equirect.width, 1024);
  ASSERT_EQ(exr.equirect.height, 512);
  ASSERT_EQ(hdr.equirect.width, 1024);
  double pe[3], ph[3];
  exr.power(pe);
  hdr.power(ph);
  // RGBE keeps 8 bits of mantissa per pixel: the integrals agree to well under 1%.
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(ph[c] / pe[c], 1.0, 0.01);
  // Real captures hold slightly negative pixels (README of the data): they are clamped, counted.
  EXPECT_GT(exr.negativeValues, 0);
  EXPECT_EQ(exr.nonFiniteValues, 0);
}

TEST(Environment, PfmLoads) {
  // Write a small PFM by hand (little-endian, bottom-to-top rows) and read it back.
  // Named by process: two runs at once (two checkouts, CI beside a developer) must not share it.
  std::string path = testing::TempDir() + "/pb_test_" + std::to_string(::getpid()) + ".pfm";
  {
    FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_TRUE(f);
    std::fprintf(f, "PF\n4 2\n-1.0\n");
    for (int i = 0; i < 8; ++i) {
      float rgb[3] = {float(i), 2.0f * i, 0.5f};
      std::fwrite(rgb, 4, 3, f);
    }
    std::fclose(f);
  }
  Environment env = loadEnvironment(path);
  std::remove(path.c_str());
  EXPECT_EQ(env.equirect.width, 4);
  EXPECT_EQ(env.equirect.height, 2);
  double sum = 0;
  for (float v : env.equirect.pixels) sum += v;
  EXPECT_NEAR(sum, (0 + 1 + 2 + 3 + 4 + 5 + 6 + 7) * 3.0 + 8 * 0.5, 1e-4);
}

TEST(Environment, SanitizesNanInfNegative) {
  Environment env = loadEnvironment(data("envmaps/bad/nan_inf_negative.exr"));
  EXPECT_EQ(env.equirect.width, 64);
  EXPECT_EQ(env.equirect.height, 32);
  EXPECT_GT(env.sanitizedPixels, 0);
  EXPECT_GT(env.nonFiniteValues, 0);
  EXPECT_GT(env.negativeValues, 0);
  for (float v : env.equirect.pixels) {
    ASSERT_TRUE(std::isfinite(v));
    ASSERT_GE(v, 0.0f);
  }
}

TEST(Environment, OnePixelMapIsAConstantSky) {
  Environment env = loadEnvironment(data("envmaps/bad/one_pixel.exr"));
  ASSERT_EQ(env.equirect.width, 1);
  ASSERT_EQ(env.equirect.height, 1);
  double p[3];
  env.power(p);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(p[c], 4 * M_PI * env.equirect.pixels[c], 1e-6);
}

TEST(Environment, BadFilesNameFileAndProblem) {
  for (const char* rel : {"envmaps/bad/truncated.exr", "envmaps/bad/not_an_image.exr",
                          "envmaps/does_not_exist.exr"}) {
    std::string path = data(rel);
    try {
      loadEnvironment(path);
      FAIL() << rel << " was accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput) << rel;
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
}

TEST(Environment, BuiltinSkyHasASunAndIsDeterministic) {
  Environment a = builtinEnvironment(), b = builtinEnvironment();
  EXPECT_EQ(a.equirect.pixels, b.equirect.pixels);
  float mx = 0;
  for (float v : a.equirect.pixels) mx = std::max(mx, v);
  EXPECT_GT(mx, 100.0f);  // the sun
  double p[3];
  a.power(p);
  EXPECT_GT(p[0], 5.0);
}
