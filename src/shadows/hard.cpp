// Hard shadows: one depth test per pixel and light against the standard depth map at the light's
// centre (nearest texel, no filtering), kernels/shadows/pcss.cl's hard_visibility. The baseline
// that bounds the problem from below: what every soft technique must improve on.
#include "shadows/hard.hpp"

#include "core/device_kind.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

void hardVisibility(Context& ctx, bool batched, const cl::Buffer& gpos, const cl::Buffer& gnrm,
                    const cl::Buffer& ggeo, const cl::Buffer& lights, const cl::Buffer& depth,
                    int size, int pixels, int nlights, float depthBias, cl::Buffer& vis) {
  if (batched) {
    cl::Kernel k = ctx.kernel("pcss.cl", "hard_visibility_batch",
                              cpuFormOptions(ctx, "HARD_GROUP", kHardGroup));
    const std::size_t groups = cpuFormItems(std::size_t(pixels), kHardGroup);
    ctx.launchWith("hard/visibility", k, cl::NDRange(groups), cl::NullRange, gpos, gnrm, ggeo,
                   lights, cl_int(nlights), depth, cl_int(size), cl_int(pixels),
                   cl_float(depthBias), vis);
    return;
  }
  cl::Kernel k = ctx.kernel("pcss.cl", "hard_visibility");
  ctx.launchWith("hard/visibility", k, cl::NDRange(pixels, nlights), cl::NullRange, gpos, gnrm,
                 ggeo, lights, depth, cl_int(size), cl_int(pixels), cl_float(depthBias), vis);
}

namespace {

class HardPass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    hardVisibility(f.ctx, useCpuBatching(f.ctx), f.gpos, f.gnrm, f.ggeo, f.lightBuffer, f.depth,
                   f.mapSize, f.pixels, int(f.lights.size()), f.opt.shadow.depthBias, f.vis);
  }
  // the standard depth map itself: one uint per texel
  std::size_t bytesPerTexel(const RenderOptions&) const override { return sizeof(cl_uint); }
};

}  // namespace

std::unique_ptr<ShadowPass> makeHardPass() { return std::make_unique<HardPass>(); }

}  // namespace penumbra::detail
