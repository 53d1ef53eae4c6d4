// The ground's occlusion of low lights: the scene's ground, each low light's directions and the
// launch (kernels/render/ground.cl).
#include "render/ground.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

namespace penumbra::detail {

GroundRect groundRect(const std::optional<GroundPlane>& ground, const Bounds& bounds) {
  GroundRect g;
  if (!ground) return g;
  double size = 0;
  for (int k = 0; k < 3; ++k) size = std::max(size, double(bounds.hi[k]) - double(bounds.lo[k]));
  g.present = true;
  g.y = ground->y;
  g.x0 = ground->x0;
  g.x1 = ground->x1;
  g.z0 = ground->z0;
  g.z1 = ground->z1;
  g.eps = float(1e-5 * size);
  return g;
}

void groundDirections(const std::vector<pb_light>& lights, std::vector<cl_float4>& dirs,
                      std::vector<int>& indices) {
  dirs.clear();
  indices.clear();
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int l = 0; l < int(lights.size()); ++l) {
    const pb_light& L = lights[std::size_t(l)];
    const double ca = std::clamp(double(L.dir[3]), -1.0, 1.0), sa = std::sqrt(1.0 - ca * ca);
    const double w[3] = {L.dir[0], L.dir[1], L.dir[2]};
    if (!(w[1] < sa)) continue;  // the whole cap above the horizontal
    // an orthonormal frame (u, v, w): u = (1, 0, 0) x w, or (0, 1, 0) x w where w is near x
    const bool nearX = std::fabs(w[0]) >= 0.9;
    double u[3] = {nearX ? w[2] : 0.0, nearX ? 0.0 : -w[2], nearX ? -w[0] : w[1]};
    const double ul = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (double& c : u) c /= ul;
    const double v[3] = {w[1] * u[2] - w[2] * u[1], w[2] * u[0] - w[0] * u[2],
                         w[0] * u[1] - w[1] * u[0]};
    indices.push_back(l);
    // how far below the horizontal the cap reaches: a - elevation, at most pi/2
    const double below = std::min(std::acos(ca) - std::asin(std::clamp(w[1], -1.0, 1.0)), M_PI / 2);
    dirs.push_back({{float(w[0]), float(w[1]), float(w[2]),
                     below >= M_PI / 2 ? 1e30f : float(std::tan(below))}});
    for (int i = 0; i < kGroundDirs; ++i) {
      const int j = i / 2;  // ring j holds a pair of opposite directions
      const double ct = 1.0 - (1.0 - ca) * (j + 0.5) / (kGroundDirs / 2);
      const double st = std::sqrt(std::max(0.0, 1.0 - ct * ct));
      const double phi = golden * j + (i % 2) * M_PI, cp = std::cos(phi) * st,
                   sp = std::sin(phi) * st;
      cl_float4 d;
      for (int k = 0; k < 3; ++k) d.s[k] = float(ct * w[k] + cp * u[k] + sp * v[k]);
      d.s[3] = 0.0f;
      dirs.push_back(d);
    }
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
  const GroundRect& g = f.ground;
  cl::Kernel k =
      f.ctx.kernel("ground.cl", "ground_visibility", "-DGR_DIRS=" + std::to_string(kGroundDirs));
  const cl_float4 rect{{g.y, g.x0, g.x1, g.z0}};
  const cl_float2 rect2{{g.z1, g.eps}};
  f.ctx.launchWith("ground", k, cl::NDRange(std::size_t(f.pixels)), cl::NullRange, f.gpos, f.gnrm,
                   dirsB_, indicesB_, cl_int(indices.size()), cl_int(f.pixels), rect, rect2,
                   lightMask, f.vis);
  return int(indices.size());
}

}  // namespace penumbra::detail
