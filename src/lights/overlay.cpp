// The light overlay (extraction.hpp writeLightOverlay): the map, tone-mapped, with every light's
// cube-face regions outlined (or its cap's circle when it has none), its centre marked and
// labelled with its index and share of the set's power, for looking at what an extraction found.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "penumbra/environment.hpp"
#include "penumbra/extraction.hpp"
#include "penumbra/image.hpp"
#include "common/shared.h"
#include "core/vec3.hpp"
#include "metrics/heatmap.hpp"

namespace penumbra {

namespace {

constexpr double kPi = 3.14159265358979323846;

// The overlay in linear values, and the exposure it is shown with.
Image linearOverlay(const Environment& rotated, const LightSet& set, bool labels, float& exposure) {
  // Drawn in world directions, like the lights: the map with its rotation baked in.
  const Environment env = rotated.withRotationApplied();
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
    if (l.regions.empty()) {
      // No cube regions (center-surround, user lights): the cap's own outline, the circle at the
      // half-angle around the direction, walked densely enough to be continuous on the map.
      if (detail::length(l.direction) > 0) {
        const detail::V3 d = detail::normalize(l.direction);
        // any unit t1 perpendicular to d, then t2 = d x t1
        const bool nearX = std::fabs(d[0]) >= 0.9f;
        float a[3] = {nearX ? 0.0f : 1.0f, nearX ? 1.0f : 0.0f, 0.0f};
        float dot = a[0] * d[0] + a[1] * d[1];
        const detail::V3 t1 =
            detail::normalize(detail::V3{a[0] - dot * d[0], a[1] - dot * d[1], -dot * d[2]});
        const detail::V3 t2 = detail::cross(d, t1);
        float ca = std::clamp(l.cosAlpha, -1.0f, 1.0f), sa = std::sqrt(1.0f - ca * ca);
        int steps = 8 * W;
        for (int i = 0; i < steps; ++i) {
          float ph = 2.0f * float(kPi) * float(i) / float(steps);
          float cp = std::cos(ph) * sa, sp = std::sin(ph) * sa;
          mark(ca * d[0] + cp * t1[0] + sp * t2[0], ca * d[1] + cp * t1[1] + sp * t2[1],
               ca * d[2] + cp * t1[2] + sp * t2[2], outline);
        }
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
  exposure = autoExposure(env.equirect);
  if (labels) {
    // "index  share of the set's power (luminance)" beside each centre, drawn after every outline
    // so no outline crosses a label.
    auto lum = [](const std::array<float, 3>& p) {
      return PB_LUM_R * p[0] + PB_LUM_G * p[1] + PB_LUM_B * p[2];
    };
    double total = 0;
    for (const auto& l : set.lights) total += std::max(0.0, double(lum(l.power)));
    const int size = std::clamp(W / 64, 12, 24);
    // White after tone mapping (x / (1 + x) of 20 is 0.95) yet not so bright that the text's
    // anti-aliased edges clip to white too.
    const std::vector<float> white(3, 20.0f / exposure);
    std::vector<std::array<int, 3>> placed;  // labels drawn: left, baseline, width
    for (std::size_t i = 0; i < set.lights.size(); ++i) {
      const AreaLight& l = set.lights[i];
      float s, t;
      pb_dir_equirect(l.direction[0], l.direction[1], l.direction[2], float(W), float(H), &s, &t);
      char text[64];
      std::snprintf(text, sizeof text, "%zu  %.3g%%", i,
                    total > 0 ? 100.0 * std::max(0.0, double(lum(l.power))) / total : 0.0);
      // Right of the cross, or left of it near the map's right edge; above it, or below near the
      // top; moved down a line at a time while it would overlap a label already drawn.
      const int width = detail::textWidth(text, size);
      const bool leftSide = float(W) - s < float(width + 8);
      const int x0 = leftSide ? int(s) - 6 - width : int(s) + 6;
      int y = t < float(size + 6) ? int(t) + size + 4 : int(t) - 5;
      auto overlaps = [&](const std::array<int, 3>& b) {
        return x0 < b[0] + b[2] && b[0] < x0 + width && y - size < b[1] && b[1] - size < y;
      };
      while (y < H && std::any_of(placed.begin(), placed.end(), overlaps)) y += size + 2;
      placed.push_back({x0, y, width});
      // A dark box under the text: white on a bright sky would not read.
      for (int yy = std::max(0, y - size); yy < std::min(H, y + size / 3); ++yy)
        for (int xx = std::max(0, x0 - 2); xx < std::min(W, x0 + width + 2); ++xx)
          for (int c = 0; c < 3; ++c) img.at(xx, yy, c) = 0.0f;
      detail::drawText(img, x0, y, text, size, white, detail::TextAlign::Left);
    }
  }
  return img;
}

}  // namespace

Image lightOverlay(const Environment& env, const LightSet& lights, bool labels) {
  float exposure = 1;
  const Image linear = linearOverlay(env, lights, labels, exposure);
  const std::vector<unsigned char> bytes = toneMap(linear, exposure);
  Image out(linear.width, linear.height, 3);
  for (std::size_t i = 0; i < bytes.size(); ++i) out.pixels[i] = float(bytes[i]) / 255.0f;
  return out;
}

void writeLightOverlay(const std::string& path, const Environment& env, const LightSet& lights) {
  float exposure = 1;
  const Image linear = linearOverlay(env, lights, true, exposure);
  writeImage(path, linear, exposure);
}

}  // namespace penumbra
