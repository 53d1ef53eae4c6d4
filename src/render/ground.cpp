// The ground's occlusion of low lights: the scene's ground, each low light's directions and the
// launch (kernels/render/ground.cl).
#include "render/ground.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string>

#include "core/device_kind.hpp"
#include "lights/sampling.hpp"
#include "scene/shadow_offset.hpp"

namespace penumbra::detail {

GroundRect groundRect(const std::optional<GroundPlane>& ground, const Bounds& bounds) {
  GroundRect g;
  if (!ground) return g;
  double size = 0;
  for (int k = 0; k < 3; ++k) size = std::max(size, double(bounds.hi[k]) - double(bounds.lo[k]));
  g.present = true;
  g.plane = *ground;
  g.eps = float(1e-5 * size);
  g.lift = shadowRayOffset(bounds.lo.data(), bounds.hi.data());
  return g;
}

void groundDirections(const std::vector<pb_light>& lights, std::vector<cl_float4>& dirs,
                      std::vector<int>& indices) {
  dirs.clear();
  indices.clear();
  constexpr int kRings = kGroundDirs / 2;
  for (int l = 0; l < int(lights.size()); ++l) {
    const pb_light& L = lights[std::size_t(l)];
    const double ca = std::clamp(double(L.dir[3]), -1.0, 1.0), sa = std::sqrt(1.0 - ca * ca);
    const std::array<float, 3> w = {L.dir[0], L.dir[1], L.dir[2]};
    if (!(w[1] < sa)) continue;  // the whole cap above the horizontal
    indices.push_back(l);
    // how far below the horizontal the cap reaches: a - elevation, at most pi/2
    const double below =
        std::min(std::acos(ca) - std::asin(std::clamp(double(w[1]), -1.0, 1.0)), M_PI / 2);
    dirs.push_back({{w[0], w[1], w[2], below >= M_PI / 2 ? 1e30f : float(std::tan(below))}});
    // the spherical Fibonacci set of the light samples, and the same turned by pi: ring by ring,
    // a pair of opposite directions
    const auto a = sphericalFibonacciCap(w, L.dir[3], kRings, 0.0f);
    const auto b = sphericalFibonacciCap(w, L.dir[3], kRings, float(M_PI));
    for (int j = 0; j < kRings; ++j)
      for (const std::array<float, 3>& d : {a[std::size_t(j)], b[std::size_t(j)]})
        dirs.push_back({{d[0], d[1], d[2], 0.0f}});
  }
}

int GroundOcclusion::run(const ShadowFrame& f, const cl::Buffer& lightMask) {
  if (!f.ground.present || f.lights.empty() || f.pixels <= 0) return 0;
  std::vector<cl_float4> dirs;
  std::vector<int> indices;
  groundDirections(f.lights, dirs, indices);
  if (indices.empty()) return 0;
  const bool same = dirs.size() == dirs_.size() &&
                    std::memcmp(dirs.data(), dirs_.data(), dirs.size() * sizeof(cl_float4)) == 0;
  if (!same || indices != indices_) {
    dirsB_ = pool_.upload("ground directions", dirs);
    indicesB_ = pool_.upload("ground lights", indices);
    dirs_ = dirs;
    indices_ = indices;
  }
  const GroundPlane& g = f.ground.plane;
  // the CPU form on CPU devices (ground.cl, ground_visibility_batch: the same bits), 64 pixels a
  // work-item (GR_GROUP)
  KernelForm k = kernelForm(f.ctx, "ground.cl", "ground_visibility", "GR_GROUP", 64,
                            std::size_t(f.pixels), "-DGR_DIRS=" + std::to_string(kGroundDirs));
  const cl_float4 rect{{g.y, g.x0, g.x1, g.z0}};
  const cl_float4 rect2{{g.z1, f.ground.eps, f.ground.lift, 0.0f}};
  f.ctx.launchWith("ground", k.kernel, cl::NDRange(k.items), cl::NullRange, f.gpos, f.gnrm,
                   f.ggeo, dirsB_, indicesB_, cl_int(indices.size()), cl_int(f.pixels), rect,
                   rect2, lightMask, f.vis);
  return int(indices.size());
}

}  // namespace penumbra::detail
