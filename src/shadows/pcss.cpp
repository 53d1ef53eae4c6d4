// Percentage-closer soft shadows (Fernando 2005), seed 003 eqs. 4-6 computed by sampling the
// standard depth map explicitly: kernels/pcss.cl's pcss_visibility. No prefilter: the price is a
// shading cost that grows with the filter's area in texels (every texel of the box by default,
// PCSSOptions::filterTaps = 0; seed 003 §6.2), where the filtered techniques pay a constant.
#include <string>

#include "penumbra/error.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {
namespace {

// Must match kernels/pcss.cl's pcss_params.
struct PcssParams {
  cl_float depthBias, lightSizeScale, maxFilter, minFilter;
  cl_int blockerTaps, filterTaps, receiverPlane, pad;
};

constexpr int kMaxTaps = 4096;

class PCSSPass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    const PCSSOptions& po = f.opt.pcss;
    if (po.blockerTaps < 0 || po.blockerTaps > kMaxTaps)
      badInput("PCSS blocker taps must be in [0, 4096] (0: every texel), got " +
               std::to_string(po.blockerTaps));
    if (po.filterTaps < 0 || po.filterTaps > kMaxTaps)
      badInput("PCSS filter taps must be in [0, 4096] (0: every texel), got " +
               std::to_string(po.filterTaps));
    const MSSMOptions& mo = f.opt.mssm;
    PcssParams P{mo.depthBias,      mo.lightSizeScale, mo.maxFilterTexels,
                 mo.minFilterTexels, po.blockerTaps,   po.filterTaps,
                 po.receiverPlaneBias ? 1 : 0, 0};
    cl::Kernel k = f.ctx.kernel("pcss.cl", "pcss_visibility");
    k.setArg(0, f.gpos);
    k.setArg(1, f.gnrm);
    k.setArg(2, f.ggeo);
    k.setArg(3, f.lightBuffer);
    k.setArg(4, f.depth);
    k.setArg(5, cl_int(f.mapSize));
    k.setArg(6, cl_int(f.pixels));
    k.setArg(7, sizeof(P), &P);
    k.setArg(8, f.vis);
    f.ctx.launch("pcss/visibility", k, cl::NDRange(f.pixels, int(f.lights.size())));
  }
  // the standard depth map itself: one uint per texel
  std::size_t bytesPerTexel(const RenderOptions&) const override { return sizeof(cl_uint); }
};

}  // namespace

std::unique_ptr<ShadowPass> makePCSSPass() { return std::make_unique<PCSSPass>(); }

}  // namespace penumbra::detail
