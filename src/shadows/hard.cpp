// Hard shadows: one depth test per pixel and light against the standard depth map at the light's
// centre (nearest texel, no filtering), kernels/shadows/pcss.cl's hard_visibility. The baseline
// that bounds the problem from below: what every soft technique must improve on.
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {
namespace {

class HardPass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    const int nl = int(f.lights.size());
    cl::Kernel k = f.ctx.kernel("pcss.cl", "hard_visibility");
    f.ctx.launchWith("hard/visibility", k, cl::NDRange(f.pixels, nl), cl::NullRange, f.gpos,
                     f.gnrm, f.ggeo, f.lightBuffer, f.depth, cl_int(f.mapSize), cl_int(f.pixels),
                     cl_float(f.opt.shadow.depthBias), f.vis);
  }
  // the standard depth map itself: one uint per texel
  std::size_t bytesPerTexel(const RenderOptions&) const override { return sizeof(cl_uint); }
};

}  // namespace

std::unique_ptr<ShadowPass> makeHardPass() { return std::make_unique<HardPass>(); }

}  // namespace penumbra::detail
