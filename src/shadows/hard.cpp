// Hard shadows: one depth test per pixel and light against the standard depth map at the light's
// centre (nearest texel, no filtering), kernels/pcss.cl's hard_visibility. The baseline that
// bounds the problem from below: what every soft technique must improve on.
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {
namespace {

class HardPass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    const int nl = int(f.lights.size());
    cl::Kernel k = f.ctx.kernel("pcss.cl", "hard_visibility");
    k.setArg(0, f.gpos);
    k.setArg(1, f.gnrm);
    k.setArg(2, f.ggeo);
    k.setArg(3, f.lightBuffer);
    k.setArg(4, f.depth);
    k.setArg(5, cl_int(f.mapSize));
    k.setArg(6, cl_int(f.pixels));
    k.setArg(7, cl_float(f.opt.mssm.depthBias));
    k.setArg(8, f.vis);
    f.ctx.launch("hard/visibility", k, cl::NDRange(f.pixels, nl));
  }
  // the standard depth map itself: one uint per texel
  std::size_t bytesPerTexel(const RenderOptions&) const override { return sizeof(cl_uint); }
};

}  // namespace

std::unique_ptr<ShadowPass> makeHardPass() { return std::make_unique<HardPass>(); }

}  // namespace penumbra::detail
