// What MSSM4 and MSSM6 share (src/shadows/mssm.hpp): their options' check, the parameter block
// of kernels/moments.cl and the visibility launch, whose arguments are the same for both.
#include "shadows/mssm.hpp"

#include "shadows/option_checks.hpp"

namespace penumbra::detail {

void validate(const MSSMOptions& o) {
  if (!(o.momentBias >= 0 && o.momentBias < 1))
    badOption("RenderOptions.mssm.momentBias", "be in [0, 1)", o.momentBias);
}

mssm_params mssmParams(const MSSMOptions& mo, const ShadowOptions& shared) {
  mssm_params P{};
  P.moment_bias = mo.momentBias;
  P.depth_bias = shared.depthBias;
  P.slope_bias = mo.slopeBias;
  P.light_size_scale = shared.lightSizeScale;
  P.max_filter = shared.maxFilterTexels;
  P.min_filter = shared.minFilterTexels;
  P.blocker_eps = mo.blockerEpsilon;
  P.upper_bound = mo.upperBoundBlocker ? 1 : 0;
  P.delta1 = mo.delta1;
  P.delta2 = mo.delta2;
  return P;
}

void mssmVisibility(ShadowFrame& f, const std::string& technique, cl::Buffer& maps,
                    std::size_t stride) {
  cl::Kernel k = f.ctx.kernel("moments.cl", technique + "_visibility", prefilterOption(f.opt.prefilter));
  f.ctx.launchWith(technique + "/visibility", k, cl::NDRange(f.pixels, int(f.lights.size())),
                   cl::NullRange, f.gpos, f.gnrm, f.ggeo, f.lightBuffer, maps, cl_int(f.mapSize),
                   cl_ulong(stride), cl_int(f.pixels), mssmParams(f.opt.mssm, f.opt.shadow), f.vis);
}

}  // namespace penumbra::detail
