// Median-cut extraction (Debevec 2005, "A median cut algorithm for light probe sampling"; Kneiphof
// 2017
// §3.1, §4.1) on the device: the map resampled to a cube (environment/cubemap.hpp), luminance and
// colour SATs (kernels/environment/envmap.cl), the cut and the regions' moments
// (kernels/environment/extract.cl); on the host the fixed-point XYZ sums become RGB and lights cut
// by a cube-face edge are merged again. Both serve median cut alone: the other extractors take RGB
// energies, and only median cut merges across faces (MedianCutOptions::mergeAcrossFaces).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "penumbra/context.hpp"
#include "core/number_text.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/extraction.hpp"
#include "penumbra/scan.hpp"
#include "common/shared.h"
#include "environment/cubemap.hpp"
#include "environment/moment_cap.hpp"
#include "lights/sampling.hpp"

namespace penumbra {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr float kDeg = float(kPi / 180.0);
}  // namespace

namespace {

// Fixed-point CIE XYZ sums (X and Z in 1/10000 units, Y in the energy's units;
// kernels/environment/envmap.cl env_sat_inputs) -> linear RGB with Rec. 709 primaries and D65 white
// (sRGB), in the energy's units. The matrix is the exact inverse of IEC 61966-2-1's RGB -> XYZ
// matrix as shared.h states it (4 decimals), adjugate over determinant of its integer form: the
// standard's printed inverse (3.2406, -1.5372, ...) is rounded and would not give back the RGB sums
// (errors ~1e-4). Integer products below 2^53 keep the adjugate and determinant exact in double.
struct XyzToRgb {
  double inv[3][3];
  XyzToRgb() {
    const double a[3][3] = {{PB_X_R_I, PB_X_G_I, PB_X_B_I},
                            {PB_LUM_R_I, PB_LUM_G_I, PB_LUM_B_I},
                            {PB_Z_R_I, PB_Z_G_I, PB_Z_B_I}};
    auto cof = [&](int i, int j) {
      int i0 = (i + 1) % 3, i1 = (i + 2) % 3, j0 = (j + 1) % 3, j1 = (j + 2) % 3;
      return a[i0][j0] * a[i1][j1] - a[i0][j1] * a[i1][j0];  // cyclic order carries the sign
    };
    double det = a[0][0] * cof(0, 0) + a[0][1] * cof(0, 1) + a[0][2] * cof(0, 2);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) inv[i][j] = cof(j, i) / det;
  }
  // x4, z4: X and Z times 10^4; y: Y summed over `texels` texels. Y was truncated to whole units
  // per texel (env_sat_inputs; kept so for the median-cut splits), which loses half a unit per
  // texel on average: put it back, or dim regions of maps whose brightest texel sets a coarse
  // fixed-point scale lose up to 1e-3 of their green (1.88 x the loss, from the inverse). Tiny
  // negatives (a channel the region lacks) are clamped to zero.
  std::array<double, 3> operator()(long long x4, long long y, long long z4, long long texels) const {
    const double yc = y > 0 ? double(y) + 0.5 * double(texels) : 0.0;
    const double v[3] = {double(x4), yc * 1e4, double(z4)};
    std::array<double, 3> rgb{};
    for (int i = 0; i < 3; ++i)
      rgb[i] = std::max(0.0, inv[i][0] * v[0] + inv[i][1] * v[1] + inv[i][2] * v[2]);
    return rgb;
  }
};

// Lights straddling cube faces (issue 4): a source on a face edge falls into regions of two faces
// (three at a corner), and each region becomes its own light, so its shadow is drawn twice with a
// seam between the copies. Lights whose regions share a stretch of a face edge and whose caps
// overlap (angle between directions < sum of half-angles) are joined, transitively, into one
// light whose moments are the sum of theirs: power adds, direction and extent come from the
// summed luminance moments (kernels/environment/extract.cl resolve_lights), so power and first
// moment are conserved as for any region. This runs on the host: it needs only the regions
// (downloaded anyway for the lights' outlines) and one float4 per light, at most PB_MAX_LIGHTS of
// them, and is a serial union-find over at most 24 m face-border texels: a device kernel would be
// one work-item's worth of work behind a launch and a download. The transitive closure does not
// depend on the order pairs are found in, and groups are numbered by their lowest light, so the
// result is deterministic. Lights with no luminance (black regions) are never merged: their
// fallback caps are wide and say nothing about a source.
//
// Overlapping caps alone do not tell a cut source from two pieces of a smooth sky: the cap of a
// uniformly bright square region (cos a = 2R - 1) is wider than the square, so the caps of any two
// uniform neighbours overlap, and on the test maps 32 lights became 20 and 5 became one clamped
// 85-degree cap (which then no longer conserves the first moment). So a light takes part only
// when it is compact, its cap covering at most `compactness` of its regions' solid angle: a
// source brighter than its surroundings (uniform square: cap/region = 1.05; a half-disc on a whole
// face: ~0.01). Seams matter exactly there: two wide diffuse lights cast soft, overlapping
// shadows, a cut compact source casts two sharp ones.
// Returns every light's new group, numbered densely by lowest member.
std::vector<int> mergeAcrossFaceEdges(int m, const std::vector<pb_region>& regs,
                                      const std::vector<cl_float4>& dirs,
                                      const std::vector<cl_long4>& sums, float compactness) {
  const int n = int(dirs.size());
  // Solid angle of each light's regions: rectangles [u0,u1] x [v0,v1] on faces at unit distance.
  std::vector<double> regionOmega(n, 0.0);
  for (auto& r : regs) {
    double u0 = 2.0 * r.x0 / m - 1, u1 = 2.0 * r.x1 / m - 1, v0 = 2.0 * r.y0 / m - 1,
           v1 = 2.0 * r.y1 / m - 1;
    regionOmega[r.group] += detail::frameRectSolidAngle(u0, u1, v0, v1);
  }
  auto compact = [&](int i) {
    double capOmega = 2 * kPi * (1 - double(dirs[i].s[3]));
    return sums[i].s[1] > 0 && capOmega <= compactness * regionOmega[i];
  };
  // The light owning each face-border texel, per face and side (0: x = 0, 1: x = m-1,
  // 2: y = 0, 3: y = m-1), indexed along the side.
  std::vector<int> border(std::size_t(6) * 4 * m, -1);
  auto at = [&](int face, int side, int k) -> int& { return border[(std::size_t(face) * 4 + side) * m + k]; };
  for (auto& r : regs) {
    for (int k = r.y0; k < r.y1; ++k) {
      if (r.x0 == 0) at(r.face, 0, k) = r.group;
      if (r.x1 == m) at(r.face, 1, k) = r.group;
    }
    for (int k = r.x0; k < r.x1; ++k) {
      if (r.y0 == 0) at(r.face, 2, k) = r.group;
      if (r.y1 == m) at(r.face, 3, k) = r.group;
    }
  }
  std::vector<int> parent(n);
  for (int i = 0; i < n; ++i) parent[i] = i;
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  auto overlap = [&](int a, int b) {
    if (!compact(a) || !compact(b)) return false;
    double dot = 0;
    for (int c = 0; c < 3; ++c) dot += double(dirs[a].s[c]) * dirs[b].s[c];
    double angle = std::acos(std::clamp(dot, -1.0, 1.0));
    return angle < std::acos(std::clamp(double(dirs[a].s[3]), -1.0, 1.0)) +
                       std::acos(std::clamp(double(dirs[b].s[3]), -1.0, 1.0));
  };
  // Step a quarter texel off the face across each border texel's outer edge and find the texel
  // of the neighbouring face it lands in (pb_cube_face decides which face, so no adjacency table
  // is kept by hand); the quarter texel keeps it clear of the neighbour's texel boundaries.
  const float eps = 0.5f / float(m);
  for (int face = 0; face < 6; ++face)
    for (int side = 0; side < 4; ++side)
      for (int k = 0; k < m; ++k) {
        int a = at(face, side, k);
        if (a < 0) continue;
        float c = 2.0f * (float(k) + 0.5f) / float(m) - 1.0f;  // texel centre along the side
        float u = side == 0 ? -1.0f - eps : side == 1 ? 1.0f + eps : c;
        float v = side == 2 ? -1.0f - eps : side == 3 ? 1.0f + eps : c;
        float x, y, z, u2, v2;
        pb_cube_dir(face, u, v, &x, &y, &z);
        int f2 = pb_cube_face(x, y, z, &u2, &v2);
        int x2 = std::clamp(int(std::floor((u2 + 1.0f) * 0.5f * float(m))), 0, m - 1);
        int y2 = std::clamp(int(std::floor((v2 + 1.0f) * 0.5f * float(m))), 0, m - 1);
        if (f2 == face) continue;
        int b = x2 == 0 ? at(f2, 0, y2) : x2 == m - 1 ? at(f2, 1, y2)
              : y2 == 0 ? at(f2, 2, x2) : y2 == m - 1 ? at(f2, 3, x2) : -1;
        if (b < 0) continue;
        int ra = find(a), rb = find(b);
        if (ra != rb && overlap(a, b)) parent[std::max(ra, rb)] = std::min(ra, rb);
      }
  std::vector<int> group(n), label(n, -1);
  int next = 0;
  for (int i = 0; i < n; ++i) {
    int r = find(i);
    if (label[r] < 0) label[r] = next++;
    group[i] = label[r];
  }
  return group;
}

// Bright sources apart (MedianCutOptions::peakRatio). Median cut gives every region the same
// energy, so a small source far brighter than the sky around it (a sun) is cut into several
// lights, and the regions bordering it take slivers of its disc together with wide stretches of
// sky: their caps then spread a sliver's power, which the sky's truth casts as the source's sharp
// shadow, over tens of degrees. Here the texels brighter than `ratio` times the map's mean
// luminance are grouped into connected sets (8-neighbours, the map wrapping around in longitude),
// the brightest sets (at most maxLights, and only those carrying at least minShare of the map's
// luminance, whose cap is at most maxHalfAngleDeg wide: a set dimmer than one median-cut light's
// share would be cut no further by median cut, and as a light of its own it takes one from the
// rest of the map; a wide set is a soft source, which median cut's regions represent well) each
// become one cap resolved from its own texels with the formulas of resolve_lights
// (kernels/environment/extract.cl: luminance-weighted mean direction, cos a = 2R - 1, power the
// exact colour integral), and `base` is the map with those texels set to 0, for median cut to
// split into the remaining lights. Every texel's energy is in exactly one of the two, so the light
// set's power is the map's as before.
struct PeakSplit {
  Environment base;
  std::vector<AreaLight> lights;
};

PeakSplit separatePeaks(const Environment& env, float ratio, int maxLights, double minShare,
                        float maxHalfAngleDeg) {
  PeakSplit out;
  const Image& img = env.equirect;
  const int W = img.width, H = img.height;
  if (!(ratio > 0) || maxLights < 1 || W < 1 || H < 1) return out;
  std::vector<double> dw(H);
  for (int t = 0; t < H; ++t) dw[t] = env.texelSolidAngle(t);
  auto lum = [&](int s, int t) {
    return PB_LUM_R * img.at(s, t, 0) + PB_LUM_G * img.at(s, t, 1) + PB_LUM_B * img.at(s, t, 2);
  };
  double total = 0;
  for (int t = 0; t < H; ++t)
    for (int s = 0; s < W; ++s) total += double(lum(s, t)) * dw[t];
  const double threshold = double(ratio) * total / (4 * kPi);
  if (!(threshold > 0)) return out;
  // Connected sets of bright texels, flood-filled in scan order (deterministic).
  std::vector<bool> seen(std::size_t(W) * H, false);
  struct Set {
    double lum = 0, rgb[3] = {0, 0, 0}, dir[3] = {0, 0, 0}, maxDw = 0;
    std::vector<std::size_t> texels;
  };
  std::vector<Set> sets;
  const float shift = env.rotationColumns();
  std::vector<std::size_t> stack;
  for (int t0 = 0; t0 < H; ++t0)
    for (int s0 = 0; s0 < W; ++s0) {
      const std::size_t i0 = std::size_t(t0) * W + s0;
      if (seen[i0] || !(lum(s0, t0) > threshold)) continue;
      Set set;
      seen[i0] = true;
      stack.assign(1, i0);
      while (!stack.empty()) {
        const std::size_t i = stack.back();
        stack.pop_back();
        set.texels.push_back(i);
        const int s = int(i % W), t = int(i / W);
        const double L = double(lum(s, t)) * dw[t];
        set.lum += L;
        for (int c = 0; c < 3; ++c) set.rgb[c] += double(img.at(s, t, c)) * dw[t];
        float x, y, z;  // the texel centre's world direction, the map's rotation applied
        pb_equirect_dir(pb_env_world_column(s, shift, W) + 0.5f, float(t) + 0.5f, float(W),
                        float(H), &x, &y, &z);
        set.dir[0] += L * x;
        set.dir[1] += L * y;
        set.dir[2] += L * z;
        set.maxDw = std::max(set.maxDw, dw[t]);
        for (int dt = -1; dt <= 1; ++dt)
          for (int ds = -1; ds <= 1; ++ds) {
            const int t2 = t + dt;
            if (t2 < 0 || t2 >= H) continue;
            const int s2 = (s + ds + W) % W;
            const std::size_t j = std::size_t(t2) * W + s2;
            if (seen[j] || !(lum(s2, t2) > threshold)) continue;
            seen[j] = true;
            stack.push_back(j);
          }
      }
      sets.push_back(std::move(set));
    }
  if (sets.empty()) return out;
  // Each set's cap (sets whose directions cancel have none); no cap narrower than its largest
  // texel's (2 pi (1 - cos a) = dw), as resolve_lights. Sets wider than maxHalfAngleDeg, or dimmer
  // than minShare, stay in the map.
  const float cosMax = std::cos(maxHalfAngleDeg * kDeg);
  std::vector<AreaLight> caps(sets.size());
  std::vector<int> order;
  for (std::size_t k = 0; k < sets.size(); ++k) {
    const Set& set = sets[k];
    float cosA;
    if (!detail::capFromMoments(set.lum, set.dir[0], set.dir[1], set.dir[2], caps[k].direction,
                                cosA))
      continue;
    caps[k].cosAlpha = std::min(cosA, float(1.0 - set.maxDw / (2 * kPi)));
    if (caps[k].cosAlpha >= cosMax && set.lum >= minShare * total) order.push_back(int(k));
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return sets[a].lum > sets[b].lum; });
  if (int(order.size()) > maxLights) order.resize(std::size_t(maxLights));
  if (order.empty()) return out;
  out.base = env;
  for (int k : order) {
    const Set& set = sets[std::size_t(k)];
    AreaLight& l = caps[std::size_t(k)];
    l.setPower({float(set.rgb[0]), float(set.rgb[1]), float(set.rgb[2])});
    out.lights.push_back(l);
    for (std::size_t i : set.texels)
      for (int c = 0; c < 3; ++c)
        out.base.equirect.pixels[i * std::size_t(img.channels) + std::size_t(c)] = 0.0f;
  }
  return out;
}

}  // namespace

LightSet extractMedianCut(Context& ctx, const Environment& env, const MedianCutOptions& opt) {
  const int m = opt.faceSize;
  if (m < 1 || m > 4096)
    badInput("MedianCutOptions.faceSize must be in [1, 4096], got " + std::to_string(m));
  if (opt.lights < 1) badInput("MedianCutOptions.lights must be >= 1, got " + std::to_string(opt.lights));
  if (opt.lights > PB_MAX_LIGHTS)
    badInput("MedianCutOptions.lights must be <= " + std::to_string(PB_MAX_LIGHTS) + ", got " +
             std::to_string(opt.lights));
  if (std::int64_t(opt.lights) > 6LL * m * m)
    badInput("MedianCutOptions.lights " + std::to_string(opt.lights) + " exceeds the " +
             std::to_string(6LL * m * m) + " texels of a " + std::to_string(m) + "^2 cube map");
  if (!(opt.maxHalfAngleDeg > 0 && opt.maxHalfAngleDeg < 90))
    badInput("MedianCutOptions.maxHalfAngleDeg must be in (0, 90)");
  if (!(opt.mergeCompactness > 0 && opt.mergeCompactness <= 1))
    badInput("mergeCompactness must be in (0, 1], got " + detail::numberText(opt.mergeCompactness));

  if (!(opt.peakRatio >= 0) || !std::isfinite(opt.peakRatio))
    badInput("MedianCutOptions.peakRatio must be finite and >= 0, got " +
             detail::numberText(opt.peakRatio));
  if (!(opt.peakMaxHalfAngleDeg > 0 && opt.peakMaxHalfAngleDeg < 90))
    badInput("MedianCutOptions.peakMaxHalfAngleDeg must be in (0, 90), got " +
             detail::numberText(opt.peakMaxHalfAngleDeg));
  // At most a quarter of the lights go to bright sources (none below 4 lights, where median cut
  // cuts whole faces), each with at least one light's share of the map.
  PeakSplit peaks = separatePeaks(env, opt.peakRatio, opt.lights / 4, 1.0 / opt.lights,
                                  opt.peakMaxHalfAngleDeg);
  if (!peaks.lights.empty()) {
    MedianCutOptions rest = opt;
    rest.lights = opt.lights - int(peaks.lights.size());
    rest.peakRatio = 0;
    LightSet set = extractMedianCut(ctx, peaks.base, rest);
    for (AreaLight& l : peaks.lights) set.lights.push_back(std::move(l));
    return set;
  }

  detail::DeviceCube cube = detail::resampleToCube(ctx, env, m, opt.supersample);
  const double scale = cube.scale;
  const std::size_t cubeTexels = 6ull * m * m;
  cl::Buffer& energy = cube.energy;
  // Colour as CIE XYZ (Kneiphof 2017 §5): the luminance SAT's Y is shared, X and Z of two faces
  // share
  // a long4 (kernels/environment/envmap.cl env_sat_inputs): 9 long4 images to scan instead of 12.
  // Context scratch buffers: kept across extractions (an animation runs one per frame).
  Context::ScratchLease lumLease = ctx.scratch("luminance SAT", cubeTexels * sizeof(cl_long4));
  Context::ScratchLease xzLease =
      ctx.scratch("colour (X, Z) SAT", cubeTexels / 2 * sizeof(cl_long4));
  cl::Buffer &lum = lumLease.buffer(), &xz = xzLease.buffer();
  {
    cl::Kernel k = ctx.kernel("envmap.cl", "env_sat_inputs");
    ctx.launchWith("env/sat-inputs", k, cl::NDRange(m, m, 6), cl::NullRange, energy, cl_int(m),
                   lum, xz);
  }
  summedAreaTable(ctx, lum, ScanType::Long4, m, m, 6, "env/sat");
  summedAreaTable(ctx, xz, ScanType::Long4, m, m, 3, "env/sat");

  const int target = opt.lights;
  const int maxRegions = std::max(6, target);
  cl::Buffer regions = ctx.buffer(maxRegions * sizeof(pb_region), "median-cut regions");
  cl::Buffer count = ctx.buffer(sizeof(cl_int), "median-cut region count");
  {
    cl::Kernel k = ctx.kernel("extract.cl", "median_cut");
    std::size_t wg = ctx.workGroupSize(k, 256);
    ctx.launchWith("extract/median-cut", k, cl::NDRange(wg), cl::NDRange(wg), lum, cl_int(m),
                   cl_int(target), regions, count, cl::Local(sizeof(cl_float) * maxRegions));
  }
  int regionCount = ctx.download<cl_int>(count, 1, "region count")[0];
  int lightCount = target < 6 ? target : regionCount;
  const std::size_t lightSlots = std::max(6, target);  // enough for every later light count
  cl::Buffer dirs = ctx.buffer(lightSlots * sizeof(cl_float4), "light directions");
  cl::Buffer sums = ctx.buffer(lightSlots * sizeof(cl_long4), "light XYZ sums");
  auto resolve = [&](int lights) {
    cl::Kernel k = ctx.kernel("extract.cl", "resolve_lights");
    std::size_t wg = ctx.workGroupSize(k, 64);
    std::size_t global = (lights + wg - 1) / wg * wg;
    ctx.launchWith("extract/resolve", k, cl::NDRange(global), cl::NDRange(wg), lum, xz, cl_int(m),
                   regions, cl_int(regionCount), cl_int(lights),
                   cl_float(std::cos(opt.maxHalfAngleDeg * kDeg)),
                   cl_float(opt.minHalfAngleDeg * kDeg), dirs, sums);
  };
  resolve(lightCount);
  auto regs = ctx.download<pb_region>(regions, regionCount, "regions");
  auto d = ctx.download<cl_float4>(dirs, lightCount, "light directions");
  auto xyz = ctx.download<cl_long4>(sums, lightCount, "light XYZ sums");
  if (opt.mergeAcrossFaces) {
    std::vector<int> group = mergeAcrossFaceEdges(m, regs, d, xyz, opt.mergeCompactness);
    int merged = group.empty() ? lightCount : *std::max_element(group.begin(), group.end()) + 1;
    if (merged < lightCount) {
      // Same regions, fewer groups: resolve again, the merged lights' moments summed exactly
      // from the SATs.
      for (auto& r : regs) r.group = group[r.group];
      ctx.write(regions, regs.data(), regs.size() * sizeof(pb_region), "merged regions");
      lightCount = merged;
      resolve(lightCount);
      d = ctx.download<cl_float4>(dirs, lightCount, "light directions");
      xyz = ctx.download<cl_long4>(sums, lightCount, "light XYZ sums");
    }
  }

  LightSet set;
  set.faceSize = m;
  set.method = "median-cut";
  const XyzToRgb toRgb;
  for (int i = 0; i < lightCount; ++i) {
    AreaLight l;
    l.direction = {d[i].s[0], d[i].s[1], d[i].s[2]};
    l.cosAlpha = d[i].s[3];
    auto rgb = toRgb(xyz[i].s[0], xyz[i].s[1], xyz[i].s[2], xyz[i].s[3]);
    l.setPower({float(rgb[0] / scale), float(rgb[1] / scale), float(rgb[2] / scale)});
    for (auto& r : regs)
      if (r.group == i) l.regions.push_back({r.face, r.x0, r.y0, r.x1, r.y1});
    if (opt.shape == LightShape::Polygon && l.regions.size() == 1) {
      // The region's own shape (MedianCutOptions::shape): its four corners on the cube face. The
      // power stays the region's integral (exact, from the SATs); the radiance spreads it over the
      // polygon's solid angle, which is the exact sum of the region's texel solid angles.
      const auto& g = l.regions[0];
      std::vector<std::array<float, 3>> corners;
      const int cx[4] = {g[1], g[3], g[3], g[1]}, cy[4] = {g[2], g[2], g[4], g[4]};
      for (int k = 0; k < 4; ++k) {
        float x, y, z;
        pb_cube_dir(g[0], 2.0f * cx[k] / m - 1.0f, 2.0f * cy[k] / m - 1.0f, &x, &y, &z);
        const float len = std::sqrt(x * x + y * y + z * z);
        corners.push_back({x / len, y / len, z / len});
      }
      AreaLight p = makePolygonLight(corners, {0, 0, 0});
      p.regions = l.regions;
      p.setPower(l.power);
      l = p;
    }
    set.lights.push_back(l);
  }
  return set;
}

}  // namespace penumbra
