// Contact shadows' launch (kernels/render/contact.cl).
#include "render/contact.hpp"

#include <string>

#include "core/device_kind.hpp"

namespace penumbra::detail {

bool hasContactInputs(const ShadowFrame& f) {
  return f.gids() != nullptr && f.positions() != nullptr && f.triangles() != nullptr &&
         f.triangleCount > 0 && f.width > 0 && f.height > 0 && f.mapSize > 0;
}

void contactShadows(const ShadowFrame& f, const cl::Buffer& lightMask) {
  const int nl = int(f.lights.size());
  if (nl == 0 || !hasContactInputs(f)) return;
  // the CPU form on CPU devices (contact.cl, contact_shadows_batch: the same bits), 64 pixels of
  // a row a work-item (CS_GROUP)
  KernelForm k =
      kernelForm(f.ctx, "contact.cl", "contact_shadows", "CS_GROUP", 64, std::size_t(f.width));
  f.ctx.launchWith("contact-shadows", k.kernel, cl::NDRange(k.items, std::size_t(f.height)),
                   cl::NullRange, f.gpos, f.ggeo, f.gids, f.positions, f.triangles,
                   cl_int(f.triangleCount),
                   f.lightBuffer, lightMask, cl_int(nl), cl_int(f.width), cl_int(f.height), f.vis,
                   cl_float(f.opt.shadow.contactTexels), cl_int(f.mapSize));
}

void contactFromMaps(const ShadowFrame& f, const cl::Buffer& lightMask) {
  const int nl = int(f.lights.size());
  if (nl == 0 || !hasContactInputs(f) || !f.mapIds()) return;
  // 8 x 8 tiles on CPUs (contact.cl, contact_map)
  const int tile = useCpuBatching(f.ctx) ? 8 : 1;
  cl::Kernel m = f.ctx.kernel("contact.cl", "contact_map",
                              "-DCM_TILE=" + std::to_string(tile) + simdLoopOption(f.ctx));
  f.ctx.launchWith("contact-shadows/maps", m,
                   cl::NDRange((std::size_t(f.width) + tile - 1) / tile,
                               (std::size_t(f.height) + tile - 1) / tile),
                   cl::NullRange, f.gpos, f.gnrm, f.ggeo, f.gids, f.positions, f.triangles,
                   cl_int(f.triangleCount), f.lightBuffer, lightMask, cl_int(nl), f.depth,
                   f.mapIds, cl_int(f.mapSize), cl_int(f.width), cl_int(f.height), f.vis,
                   cl_float(f.opt.shadow.contactTexels));
}

}  // namespace penumbra::detail
