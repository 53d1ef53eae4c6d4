// Percentage-closer soft shadows (Fernando 2005), Kneiphof 2017 eqs. 4-6 computed by sampling the
// standard depth map explicitly: kernels/shadows/pcss.cl's pcss_visibility. No prefilter: the price
// is a shading cost that grows with the filter's area in texels (every texel of the box by default,
// PCSSOptions::filterTaps = 0; Kneiphof 2017 §6.2), where the filtered techniques pay a constant.
#include "shadows/shadow_options.hpp"
#include "shadows/shadow_params.h"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

void validate(const PCSSOptions& o) {
  checkRange("RenderOptions.pcss.blockerTaps", o.blockerTaps, 0, 4096);  // 0: every texel
  checkRange("RenderOptions.pcss.filterTaps", o.filterTaps, 0, 4096);
}

namespace {

class PCSSPass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    const PCSSOptions& po = f.opt.pcss;
    validate(po);
    const ShadowOptions& so = f.opt.shadow;
    pcss_params P{};
    P.depth_bias = so.depthBias;
    setFilterLimits(P, so);
    P.blocker_taps = po.blockerTaps;
    P.filter_taps = po.filterTaps;
    P.receiver_plane = po.receiverPlaneBias ? 1 : 0;
    cl::Kernel k = f.ctx.kernel("pcss.cl", "pcss_visibility");
    f.ctx.launchWith("pcss/visibility", k, cl::NDRange(f.pixels, int(f.lights.size())),
                     cl::NullRange, f.gpos, f.gnrm, f.ggeo, f.lightBuffer, f.depth,
                     cl_int(f.mapSize), cl_int(f.pixels), P, f.vis);
  }
  // the standard depth map itself: one uint per texel
  std::size_t bytesPerTexel(const RenderOptions&) const override { return sizeof(cl_uint); }
};

}  // namespace

std::unique_ptr<ShadowPass> makePCSSPass() { return std::make_unique<PCSSPass>(); }

}  // namespace penumbra::detail
