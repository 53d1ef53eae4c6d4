// Lights on the horizon: each light's candidate sources and the launch (kernels/render/horizon.cl).
#include "render/horizon.hpp"

#include <algorithm>
#include <cmath>

#include "core/device_kind.hpp"

namespace penumbra::detail {

namespace {
constexpr int kGroup = 64;  // pixels per work-item of the CPU form (HZ_GROUP)
}  // namespace

void horizonCandidates(const std::vector<pb_light>& lights, std::vector<int>& offsets,
                       std::vector<int>& indices) {
  const int nl = int(lights.size());
  offsets.assign(std::size_t(nl) + 1, 0);
  indices.clear();
  for (int l = 0; l < nl; ++l) {
    const pb_light& L = lights[std::size_t(l)];
    const double ca = std::clamp(double(L.dir[3]), -1.0, 1.0);
    // The lens's middle is within a of the axis and a source within 2a of it: 3a, with 0.01 rad
    // to spare for the kernel's float rounding (the kernel's own test decides).
    const double reach = std::min(3.0 * std::acos(ca) + 0.01, M_PI);
    const double cosReach = std::cos(reach);
    for (int k = 0; k < nl; ++k) {
      if (k == l) continue;
      const pb_light& K = lights[std::size_t(k)];
      const double d = double(L.dir[0]) * K.dir[0] + double(L.dir[1]) * K.dir[1] +
                       double(L.dir[2]) * K.dir[2];
      if (reach >= M_PI || d > cosReach) indices.push_back(k);
    }
    offsets[std::size_t(l) + 1] = int(indices.size());
  }
}

void Horizon::run(const ShadowFrame& f, const cl::Buffer& lightMask) {
  const int nl = int(f.lights.size());
  if (nl == 0 || f.pixels <= 0) return;
  std::vector<int> offsets, indices;
  horizonCandidates(f.lights, offsets, indices);
  if (indices.empty()) indices.push_back(0);  // a buffer is never empty; no offset reaches it
  if (offsets != offsets_ || indices != indices_) {
    offsetsB_ = pool_.upload("horizon candidate offsets", offsets);
    indicesB_ = pool_.upload("horizon candidates", indices);
    offsets_ = offsets;
    indices_ = indices;
  }
  KernelForm k = kernelForm(f.ctx, "horizon.cl", "horizon_visibility", "HZ_GROUP", kGroup,
                            std::size_t(f.pixels));
  f.ctx.launchWith("horizon", k.kernel, cl::NDRange(k.items), cl::NullRange, f.gpos, f.gnrm,
                   f.lightBuffer, lightMask, cl_int(nl), cl_int(f.pixels), offsetsB_, indicesB_,
                   f.vis);
}

}  // namespace penumbra::detail
