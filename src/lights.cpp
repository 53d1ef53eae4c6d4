// Area lights and their extraction from an environment map (median cut on the device).
#include "penumbra/lights.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/scan.hpp"
#include "penumbra/shared.h"
#include "cubemap.hpp"

namespace penumbra {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr float kDeg = float(kPi / 180.0);
}  // namespace

float AreaLight::halfAngle() const { return std::acos(std::clamp(cosAlpha, -1.0f, 1.0f)); }
float AreaLight::solidAngle() const { return float(2.0 * kPi * (1.0 - double(cosAlpha))); }

std::array<float, 3> AreaLight::irradiance(const std::array<float, 3>& n) const {
  float cb = n[0] * direction[0] + n[1] * direction[1] + n[2] * direction[2];
  float e = pb_cap_irradiance(cosAlpha, cb);
  return {e * radiance[0], e * radiance[1], e * radiance[2]};
}

std::array<double, 3> LightSet::power() const {
  std::array<double, 3> p{0, 0, 0};
  for (auto& l : lights)
    for (int c = 0; c < 3; ++c) p[c] += l.power[c];
  return p;
}

std::array<double, 3> LightSet::irradiance(const std::array<float, 3>& n) const {
  std::array<double, 3> e{0, 0, 0};
  for (auto& l : lights) {
    auto li = l.irradiance(n);
    for (int c = 0; c < 3; ++c) e[c] += li[c];
  }
  return e;
}

std::string LightSet::toJson() const {
  std::ostringstream o;
  o.precision(9);
  o << "{\n  \"method\": \"" << method << "\",\n  \"face_size\": " << faceSize
    << ",\n  \"count\": " << lights.size() << ",\n  \"lights\": [";
  for (std::size_t i = 0; i < lights.size(); ++i) {
    auto& l = lights[i];
    o << (i ? ",\n" : "\n") << "    {\"direction\": [" << l.direction[0] << ", " << l.direction[1]
      << ", " << l.direction[2] << "], \"half_angle_deg\": " << l.halfAngle() / kDeg
      << ", \"cos_alpha\": " << l.cosAlpha << ", \"solid_angle_sr\": " << l.solidAngle()
      << ", \"radiance\": [" << l.radiance[0] << ", " << l.radiance[1] << ", " << l.radiance[2]
      << "], \"power\": [" << l.power[0] << ", " << l.power[1] << ", " << l.power[2]
      << "], \"regions\": [";
    for (std::size_t r = 0; r < l.regions.size(); ++r) {
      auto& g = l.regions[r];
      o << (r ? ", " : "") << "[" << g[0] << ", " << g[1] << ", " << g[2] << ", " << g[3] << ", "
        << g[4] << "]";
    }
    o << "]}";
  }
  o << "\n  ]\n}\n";
  return o.str();
}

LightSet extractMedianCut(Context& ctx, const Environment& env, const MedianCutOptions& opt) {
  const int m = opt.faceSize;
  if (m < 1 || m > 4096)
    badInput("--face-size must be in [1, 4096], got " + std::to_string(m));
  if (opt.lights < 1) badInput("--lights must be >= 1, got " + std::to_string(opt.lights));
  if (opt.lights > PB_MAX_LIGHTS)
    badInput("--lights must be <= " + std::to_string(PB_MAX_LIGHTS) + ", got " +
             std::to_string(opt.lights));
  if (std::int64_t(opt.lights) > 6LL * m * m)
    badInput("--lights " + std::to_string(opt.lights) + " exceeds the " +
             std::to_string(6LL * m * m) + " texels of a " + std::to_string(m) + "^2 cube map");
  if (!(opt.maxHalfAngleDeg > 0 && opt.maxHalfAngleDeg < 90))
    badInput("max half-angle must be in (0, 90) degrees");

  detail::DeviceCube cube = detail::resampleToCube(ctx, env, m, opt.supersample);
  const double scale = cube.scale;
  const std::size_t cubeTexels = 6ull * m * m;
  cl::Buffer& energy = cube.energy;
  cl::Buffer lum = ctx.buffer(cubeTexels * sizeof(cl_long4), "luminance SAT");
  cl::Buffer rgb = ctx.buffer(cubeTexels * sizeof(cl_long4), "colour SAT");
  {
    cl::Kernel k = ctx.kernel("envmap.cl", "env_sat_inputs");
    k.setArg(0, energy);
    k.setArg(1, cl_int(m));
    k.setArg(2, lum);
    k.setArg(3, rgb);
    ctx.launch("env/sat-inputs", k, cl::NDRange(m, m, 6));
  }
  summedAreaTable(ctx, lum, ScanType::Long4, m, m, 6, "env/sat");
  summedAreaTable(ctx, rgb, ScanType::Long4, m, m, 6, "env/sat");

  const int target = opt.lights;
  const int maxRegions = std::max(6, target);
  cl::Buffer regions = ctx.buffer(maxRegions * sizeof(pb_region), "median-cut regions");
  cl::Buffer count = ctx.buffer(sizeof(cl_int), "median-cut region count");
  {
    cl::Kernel k = ctx.kernel("extract.cl", "median_cut");
    std::size_t wg = ctx.workGroupSize(k, 256);
    k.setArg(0, lum);
    k.setArg(1, cl_int(m));
    k.setArg(2, cl_int(target));
    k.setArg(3, regions);
    k.setArg(4, count);
    k.setArg(5, cl::Local(sizeof(cl_float) * maxRegions));
    ctx.launch("extract/median-cut", k, cl::NDRange(wg), cl::NDRange(wg));
  }
  int regionCount = ctx.download<cl_int>(count, 1, "region count")[0];
  const int lightCount = target < 6 ? target : regionCount;
  cl::Buffer dirs = ctx.buffer(lightCount * sizeof(cl_float4), "light directions");
  cl::Buffer powers = ctx.buffer(lightCount * sizeof(cl_float4), "light powers");
  {
    cl::Kernel k = ctx.kernel("extract.cl", "resolve_lights");
    std::size_t wg = ctx.workGroupSize(k, 64);
    std::size_t global = (lightCount + wg - 1) / wg * wg;
    k.setArg(0, lum);
    k.setArg(1, rgb);
    k.setArg(2, cl_int(m));
    k.setArg(3, regions);
    k.setArg(4, cl_int(regionCount));
    k.setArg(5, cl_int(lightCount));
    k.setArg(6, cl_float(1.0 / scale));
    k.setArg(7, cl_float(std::cos(opt.maxHalfAngleDeg * kDeg)));
    k.setArg(8, cl_float(opt.minHalfAngleDeg * kDeg));
    k.setArg(9, dirs);
    k.setArg(10, powers);
    ctx.launch("extract/resolve", k, cl::NDRange(global), cl::NDRange(wg));
  }
  auto regs = ctx.download<pb_region>(regions, regionCount, "regions");
  auto d = ctx.download<cl_float4>(dirs, lightCount, "light directions");
  auto p = ctx.download<cl_float4>(powers, lightCount, "light powers");

  LightSet set;
  set.faceSize = m;
  set.method = "median-cut";
  for (int i = 0; i < lightCount; ++i) {
    AreaLight l;
    l.direction = {d[i].s[0], d[i].s[1], d[i].s[2]};
    l.cosAlpha = d[i].s[3];
    l.power = {p[i].s[0], p[i].s[1], p[i].s[2]};
    float omega = l.solidAngle();
    for (int c = 0; c < 3; ++c) l.radiance[c] = omega > 0 ? l.power[c] / omega : 0.0f;
    for (auto& r : regs)
      if (r.group == i) l.regions.push_back({r.face, r.x0, r.y0, r.x1, r.y1});
    set.lights.push_back(l);
  }
  return set;
}

void writeLightOverlay(const std::string& path, const Environment& env, const LightSet& set) {
  // Small maps are enlarged (nearest texel) so the outlines stay legible.
  const int k = std::max(1, (1024 + env.equirect.width - 1) / env.equirect.width);
  Image img(env.equirect.width * k, env.equirect.height * k, 3);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = env.equirect.at(x / k, y / k, c);
  const int W = img.width, H = img.height;
  auto mark = [&](float x, float y, float z, const float col[3]) {
    float s, t;
    pb_dir_equirect(x, y, z, float(W), float(H), &s, &t);
    int si = std::clamp(int(s), 0, W - 1), ti = std::clamp(int(t), 0, H - 1);
    for (int c = 0; c < 3; ++c) img.at(si, ti, c) = col[c];
  };
  // Display values: outlines must stay visible after tone mapping whatever the map's range.
  const float outline[3] = {1e4f, 0.0f, 1e4f}, centre[3] = {1e4f, 1e4f, 0.0f};
  const int m = std::max(1, set.faceSize);
  for (auto& l : set.lights) {
    for (auto& r : l.regions) {
      // walk the region's border on the cube face, densely enough to be continuous on the map
      int steps = 4 * std::max(W, m);
      for (int side = 0; side < 4; ++side)
        for (int i = 0; i <= steps; ++i) {
          float f = float(i) / steps;
          float px, py;
          switch (side) {
            case 0: px = r[1] + f * (r[3] - r[1]); py = r[2]; break;
            case 1: px = r[1] + f * (r[3] - r[1]); py = r[4]; break;
            case 2: px = r[1]; py = r[2] + f * (r[4] - r[2]); break;
            default: px = r[3]; py = r[2] + f * (r[4] - r[2]); break;
          }
          float x, y, z;
          pb_cube_dir(r[0], 2.0f * px / m - 1.0f, 2.0f * py / m - 1.0f, &x, &y, &z);
          mark(x, y, z, outline);
        }
    }
    // centre: a small cross
    for (int k = -3; k <= 3; ++k) {
      float s, t;
      pb_dir_equirect(l.direction[0], l.direction[1], l.direction[2], float(W), float(H), &s, &t);
      int si = std::clamp(int(s) + k, 0, W - 1), ti = std::clamp(int(t), 0, H - 1);
      for (int c = 0; c < 3; ++c) img.at(si, ti, c) = centre[c];
      si = std::clamp(int(s), 0, W - 1);
      ti = std::clamp(int(t) + k, 0, H - 1);
      for (int c = 0; c < 3; ++c) img.at(si, ti, c) = centre[c];
    }
  }
  writeImage(path, img, autoExposure(env.equirect));
}

}  // namespace penumbra
