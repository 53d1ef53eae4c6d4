// MSSM4: moment soft shadow mapping with four moments (seed 003 §3.2.1), kernels/moments.cl.
#include <algorithm>

#include "shadows/mssm.hpp"
#include "shadows/option_checks.hpp"

namespace penumbra::detail {
namespace {

class MSSM4Pass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    validate(f.opt.mssm);
    Context& ctx = f.ctx;
    const int S = f.mapSize, nl = int(f.lights.size());
    const std::size_t stride = prefilterStride(f.opt.prefilter, S);
    cl::Buffer& moments = f.pool.buffer("mssm4 moments", stride * nl * sizeof(cl_long4));
    cl::Kernel k = ctx.kernel("moments.cl", "depth_to_moments");
    ctx.launchWith("mssm4/moments", k, cl::NDRange(S, S, nl), cl::NullRange, f.depth,
                   f.lightBuffer, cl_int(S), cl_ulong(stride), moments);
    prefilter(ctx, moments, f.opt.prefilter, S, nl, "mssm4");
    mssmVisibility(f, "mssm4", moments, stride);
  }
  std::size_t bytesPerTexel(const RenderOptions& opt) const override {
    // one long4 per texel, times the prefilter's overhead (measured on a 1024^2 map)
    const std::size_t bytes = prefilterStride(opt.prefilter, 1024) * sizeof(cl_long4);
    return (bytes + 512 * 1024) / (1024 * 1024);  // rounded to the nearest byte
  }
};

}  // namespace

std::unique_ptr<ShadowPass> makeMSSM4Pass() { return std::make_unique<MSSM4Pass>(); }

}  // namespace penumbra::detail
