// Greedy fitting of square or rectangular area lights to the cube-map faces (Annen et al. 2008
// §4.2,
// Figure 6): the fit runs on the device (kernels/environment/greedy.cl, one work-group per face);
// the host turns each fitted rectangle's taken energy into a cap light and keeps the strongest.
#include "environment/greedy.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "environment/cubemap.hpp"
#include "environment/moment_cap.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/extraction.hpp"
#include "common/shared.h"

namespace penumbra {

namespace detail {

std::vector<GreedyRect> greedyFit(Context& ctx, cl::Buffer& energy, int m, float threshold,
                                  bool square, std::size_t workGroupSize) {
  const std::size_t texels = 6ull * m * m;
  const int capacity = int(std::min<std::int64_t>(std::int64_t(m) * m, kGreedyMaxPerFace));
  cl::Buffer covered = ctx.buffer(texels, "greedy covered flags");
  cl_uchar zero = 0;
  ctx.fill(covered, &zero, 1, texels, "greedy covered flags");
  // The kernel's per-face scratch: luminance (by row and by column), row and column prefix sums,
  // uncovered counts per row, the seed of each row (kernels/environment/greedy.cl, greedy_fit).
  const std::size_t prefix = 6ull * m * (m + 1);
  cl::Buffer lum = ctx.buffer(texels * sizeof(cl_long), "greedy luminance");
  cl::Buffer lumT = ctx.buffer(texels * sizeof(cl_long), "greedy luminance by column");
  cl::Buffer rowSum = ctx.buffer(prefix * sizeof(cl_long), "greedy row sums");
  cl::Buffer colSum = ctx.buffer(prefix * sizeof(cl_long), "greedy column sums");
  cl::Buffer rowOpen = ctx.buffer(prefix * sizeof(cl_int), "greedy uncovered counts");
  cl::Buffer rowBest = ctx.buffer(6ull * m * sizeof(cl_long2), "greedy row seeds");
  const std::size_t slots = 6ull * capacity;
  cl::Buffer rect = ctx.buffer(slots * sizeof(cl_int4), "greedy rectangles");
  cl::Buffer power = ctx.buffer(slots * sizeof(cl_long4), "greedy powers");
  cl::Buffer moment = ctx.buffer(slots * sizeof(cl_long4), "greedy moments");
  cl::Buffer count = ctx.buffer(6 * sizeof(cl_int), "greedy light counts");

  cl::Kernel k = ctx.kernel("greedy.cl", "greedy_fit");
  // One work-group per face. Most of the fit is serial (one work-item grows each light); the
  // work-group shares out the seed search, the removal's rows and the prefix-sum updates. On a
  // GPU 256 work-items keep those short; on a CPU a work-group's items run one after another on
  // one core and every barrier costs a pass over all of them, so there 1 is best (measured with
  // PoCL on 2 cores, face 512, square: fit 0.53-0.56 s at 1 item, 0.52-0.57 s at 4, 1.17 s at 256).
  if (workGroupSize & (workGroupSize - 1))
    badInput("greedy work-group size must be a power of two, got " + std::to_string(workGroupSize));
  const bool cpu = ctx.device().getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_CPU;
  std::size_t wg = ctx.workGroupSize(k, workGroupSize ? workGroupSize : cpu ? 1 : 256);
  const std::size_t localMem = ctx.device().getInfo<CL_DEVICE_LOCAL_MEM_SIZE>();
  auto localBytes = [&](std::size_t w) { return 2 * w * sizeof(cl_long4) + m * sizeof(cl_int) + 64; };
  while (wg > 1 && localBytes(wg) > localMem) wg /= 2;
  ctx.launchWith("extract/greedy", k, cl::NDRange(6 * wg), cl::NDRange(wg), energy, covered,
                 cl_int(m), cl_float(threshold), cl_int(square ? 1 : 0), cl_int(capacity), lum,
                 lumT, rowSum, colSum, rowOpen, rowBest, rect, power, moment, count,
                 cl::Local(2 * wg * sizeof(cl_long4)), cl::Local(m * sizeof(cl_int)));

  auto n = ctx.download<cl_int>(count, 6, "greedy light counts");
  auto r = ctx.download<cl_int4>(rect, slots, "greedy rectangles");
  auto p = ctx.download<cl_long4>(power, slots, "greedy powers");
  auto mo = ctx.download<cl_long4>(moment, slots, "greedy moments");
  std::vector<GreedyRect> out;
  for (int f = 0; f < 6; ++f)
    for (int i = 0; i < n[f]; ++i) {
      std::size_t o = std::size_t(f) * capacity + i;
      GreedyRect g;
      g.face = f;
      g.x0 = r[o].s[0]; g.y0 = r[o].s[1]; g.x1 = r[o].s[2]; g.y1 = r[o].s[3];
      for (int c = 0; c < 4; ++c) g.removed[c] = p[o].s[c];
      for (int c = 0; c < 3; ++c) g.moment[c] = mo[o].s[c];
      out.push_back(g);
    }
  return out;
}

}  // namespace detail

LightSet extractGreedy(Context& ctx, const Environment& env, const GreedyOptions& opt) {
  const int m = opt.faceSize;
  if (!(opt.threshold > 0.0f && opt.threshold < 1.0f))
    badInput("GreedyOptions.threshold must be in (0, 1), got " + std::to_string(opt.threshold));
  if (m < 1 || m > 1024) badInput("GreedyOptions.faceSize must be in [1, 1024], got " + std::to_string(m));
  if (opt.maxLights < 1 || opt.maxLights > PB_MAX_LIGHTS)
    badInput("GreedyOptions.maxLights must be in [1, " + std::to_string(PB_MAX_LIGHTS) + "], got " +
             std::to_string(opt.maxLights));

  detail::DeviceCube cube = detail::resampleToCube(ctx, env, m, opt.supersample);
  std::vector<detail::GreedyRect> rects =
      detail::greedyFit(ctx, cube.energy, m, opt.threshold, opt.square);

  // Strongest first by taken luminance (exact integers), ties by fitting order; lights that took
  // nothing (their texels held no more than the face's mean) are no lights at all.
  std::vector<int> order;
  for (int i = 0; i < int(rects.size()); ++i) {
    auto& e = rects[i].removed;
    if (e[0] > 0 || e[1] > 0 || e[2] > 0) order.push_back(i);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return rects[a].removed[3] > rects[b].removed[3]; });
  if (int(order.size()) > opt.maxLights) order.resize(opt.maxLights);

  const double inv = 1.0 / cube.scale;
  const float cosMax = std::cos(85.0f * float(M_PI / 180.0));
  LightSet set;
  set.faceSize = m;
  set.method = "greedy";
  for (int i : order) {
    const detail::GreedyRect& g = rects[i];
    // Texel centre of the rectangle nearest the face centre: the largest texel it holds, whose
    // cap is the narrowest the light may have.
    auto coord = [&](int t) { return 2.0f * (t + 0.5f) / m - 1.0f; };
    float uc = std::clamp(0.0f, coord(g.x0), coord(g.x1 - 1));
    float vc = std::clamp(0.0f, coord(g.y0), coord(g.y1 - 1));
    const float texelDw = pb_cube_texel_solid_angle(uc, vc, m);
    const float cosMinCap = 1.0f - texelDw / float(2.0 * M_PI);

    AreaLight l;
    // Direction and extent from the luminance moments of the taken energy, as for median cut.
    float cosA;
    if (!detail::capFromMoments(double(g.removed[3]), double(g.moment[0]), double(g.moment[1]),
                                double(g.moment[2]), l.direction, cosA)) {
      float cx = 0.5f * (coord(g.x0) + coord(g.x1 - 1)), cy = 0.5f * (coord(g.y0) + coord(g.y1 - 1));
      float x, y, z;
      pb_cube_dir(g.face, cx, cy, &x, &y, &z);
      float n = std::sqrt(x * x + y * y + z * z);
      l.direction = {x / n, y / n, z / n};
      cosA = cosMinCap;
    }
    l.cosAlpha = std::clamp(cosA, cosMax, cosMinCap);
    l.setPower({float(double(g.removed[0]) * inv), float(double(g.removed[1]) * inv),
                float(double(g.removed[2]) * inv)});
    l.regions.push_back({g.face, g.x0, g.y0, g.x1, g.y1});
    set.lights.push_back(l);
  }
  return set;
}

}  // namespace penumbra
