// Environment maps on the host: loading, sanitizing, the built-in sky, and integrals used by tests
// and the reference. The device-side cube map lives in cubemap.cpp / kernels/environment/envmap.cl.
#include "penumbra/environment.hpp"
#include "core/number_text.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "penumbra/error.hpp"
#include "common/shared.h"

namespace penumbra {

namespace {

// Keeps RGB, replaces non-finite values by 0 and clamps negative radiance to 0, counting both.
Environment sanitize(Image raw, const std::string& source) {
  Environment env;
  env.source = source;
  env.equirect = Image(raw.width, raw.height, 3);
  for (std::size_t i = 0; i < std::size_t(raw.width) * raw.height; ++i) {
    bool fixed = false;
    for (int c = 0; c < 3; ++c) {
      float v = raw.pixels[i * raw.channels + std::min(c, raw.channels - 1)];
      if (!std::isfinite(v)) {
        v = 0.0f;
        ++env.nonFiniteValues;
        fixed = true;
      } else if (v < 0.0f) {
        v = 0.0f;
        ++env.negativeValues;
        fixed = true;
      }
      env.equirect.pixels[i * 3 + c] = v;
    }
    if (fixed) ++env.sanitizedPixels;
  }
  return env;
}

}  // namespace

Environment loadEnvironment(const std::string& path) {
  // An LDR image (PNG, JPEG) is accepted and decoded to linear radiance; it has no range above
  // 1, so its brightest light is clipped and its shadows are weaker than the scene's real ones.
  Image raw = readImage(path, true);
  if (raw.channels < 1) badInput(path + ": image has no channels");
  return sanitize(std::move(raw), path);
}

Environment builtinEnvironment(int width) {
  if (width < 4) badInput("builtin environment width must be >= 4, got " + std::to_string(width));
  int height = width / 2;
  Image img(width, height, 3);
  // Sun: elevation 50 degrees, azimuth towards +x/-z, angular radius 2.5 degrees (a hazy sun, so
  // the default frame shows penumbrae); a bright patch near the horizon; blue sky; dim ground.
  const float deg = 3.14159265f / 180.0f;
  auto dirOf = [&](float elev, float azim) {
    return std::array<float, 3>{std::cos(elev) * std::sin(azim), std::sin(elev),
                                -std::cos(elev) * std::cos(azim)};
  };
  auto sun = dirOf(50 * deg, 35 * deg);
  auto patch = dirOf(8 * deg, -120 * deg);
  const float sunCos = std::cos(2.5f * deg), patchCos = std::cos(12.0f * deg);
  // Supersampled so the sun's energy does not depend on how its disc falls on the texel grid.
  const int ss = 4;
  for (int t = 0; t < height; ++t)
    for (int s = 0; s < width; ++s) {
      float acc[3] = {0, 0, 0};
      for (int j = 0; j < ss; ++j)
        for (int i = 0; i < ss; ++i) {
          float x, y, z;
          pb_equirect_dir(s + (i + 0.5f) / ss, t + (j + 0.5f) / ss, float(width), float(height),
                          &x, &y, &z);
          float L[3];
          if (y >= 0) {
            float h = 1.0f - y;  // brighter, whiter towards the horizon
            L[0] = 0.35f + 0.55f * h;
            L[1] = 0.55f + 0.45f * h;
            L[2] = 1.00f + 0.20f * h;
          } else {
            L[0] = 0.22f;
            L[1] = 0.20f;
            L[2] = 0.17f;
          }
          if (x * sun[0] + y * sun[1] + z * sun[2] > sunCos) {
            L[0] = 900.0f;
            L[1] = 820.0f;
            L[2] = 700.0f;
          } else if (x * patch[0] + y * patch[1] + z * patch[2] > patchCos) {
            L[0] += 6.0f;
            L[1] += 5.0f;
            L[2] += 4.0f;
          }
          for (int c = 0; c < 3; ++c) acc[c] += L[c];
        }
      for (int c = 0; c < 3; ++c) img.at(s, t, c) = acc[c] / (ss * ss);
    }
  Environment env = sanitize(std::move(img), "builtin");
  return env;
}

Environment environmentFrom(const std::string& p) {
  return p == "builtin" ? builtinEnvironment() : loadEnvironment(p);
}

void Environment::lookup(float x, float y, float z, float rgb[3]) const {
  float s, t;
  pb_dir_equirect(x, y, z, float(equirect.width), float(equirect.height), &s, &t);
  int si = pb_env_column(s, rotationColumns(), equirect.width);
  int ti = std::clamp(int(std::floor(t)), 0, equirect.height - 1);
  for (int c = 0; c < 3; ++c) rgb[c] = equirect.at(si, ti, c);
}

float Environment::rotationColumns() const {
  if (!std::isfinite(rotationYDeg))
    badInput("environment rotation must be finite, got " + detail::numberText(rotationYDeg));
  // Reduced in double so that whole turns give exactly 0 and 90 degrees exactly width / 4.
  double turns = std::fmod(double(rotationYDeg), 360.0) / 360.0;
  if (turns < 0) turns += 1.0;
  float shift = float(turns * equirect.width);
  return shift >= float(equirect.width) ? 0.0f : shift;
}

Environment Environment::withRotationApplied() const {
  Environment out = *this;
  out.rotationYDeg = 0.0f;
  const float shift = rotationColumns();
  const int W = equirect.width;
  // Nearest column at each world column's centre, as lookup() reads it.
  for (int s = 0; s < W; ++s) {
    const int c = pb_env_column(s + 0.5f, shift, W);
    for (int t = 0; t < equirect.height; ++t)
      for (int k = 0; k < 3; ++k) out.equirect.at(s, t, k) = equirect.at(c, t, k);
  }
  return out;
}

double Environment::texelSolidAngle(int row) const {
  const double pi = 3.14159265358979323846;
  double t0 = pi * row / equirect.height, t1 = pi * (row + 1) / equirect.height;
  return 2.0 * pi / equirect.width * (std::cos(t0) - std::cos(t1));
}

void Environment::power(double rgb[3]) const {
  // Invariant under the rotation: it only moves texels along their row.
  rgb[0] = rgb[1] = rgb[2] = 0;
  for (int t = 0; t < equirect.height; ++t) {
    double dw = texelSolidAngle(t);
    for (int s = 0; s < equirect.width; ++s)
      for (int c = 0; c < 3; ++c) rgb[c] += equirect.at(s, t, c) * dw;
  }
}

void Environment::irradiance(const float n[3], double rgb[3]) const {
  // Each texel integrated with 4x4 sub-samples of the cosine so the horizon is resolved.
  rgb[0] = rgb[1] = rgb[2] = 0;
  const int ss = 4;
  const double pi = 3.14159265358979323846;
  const float shift = rotationColumns();
  for (int t = 0; t < equirect.height; ++t)
    for (int j = 0; j < ss; ++j) {
      double t0 = pi * (t + double(j) / ss) / equirect.height;
      double t1 = pi * (t + double(j + 1) / ss) / equirect.height;
      double dw = 2.0 * pi / (equirect.width * ss) * (std::cos(t0) - std::cos(t1));
      for (int s = 0; s < equirect.width; ++s) {
        double cosv = 0;
        for (int i = 0; i < ss; ++i) {
          float x, y, z;
          // Texel s of the map lies at world column pb_env_world_column (the rotation).
          pb_equirect_dir(pb_env_world_column(s, shift, equirect.width) + (i + 0.5f) / ss,
                          t + (j + 0.5f) / ss, float(equirect.width),
                          float(equirect.height), &x, &y, &z);
          cosv += std::max(0.0f, x * n[0] + y * n[1] + z * n[2]);
        }
        for (int c = 0; c < 3; ++c) rgb[c] += equirect.at(s, t, c) * cosv * dw;
      }
    }
}

}  // namespace penumbra
