// MSSM4: moment soft shadow mapping with four moments (seed 003 §3.2.1), kernels/moments.cl.
#include <algorithm>

#include "penumbra/scan.hpp"
#include "shadows/mssm.hpp"

namespace penumbra::detail {
namespace {

class MSSM4Pass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    Context& ctx = f.ctx;
    const int S = f.mapSize, nl = int(f.lights.size());
    const std::size_t stride = prefilterStride(f.opt.prefilter, S);
    cl::Buffer& moments = f.pool.buffer("mssm4 moments", stride * nl * sizeof(cl_long4));
    {
      cl::Kernel k = ctx.kernel("moments.cl", "depth_to_moments");
      k.setArg(0, f.depth);
      k.setArg(1, f.lightBuffer);
      k.setArg(2, cl_int(S));
      k.setArg(3, cl_ulong(stride));
      k.setArg(4, moments);
      ctx.launch("mssm4/moments", k, cl::NDRange(S, S, nl));
    }
    prefilter(ctx, moments, f.opt.prefilter, S, nl, "mssm4");
    cl::Kernel k = ctx.kernel("moments.cl", "mssm4_visibility", prefilterOption(f.opt.prefilter));
    setVisibilityArgs(k, f, moments, stride);
    ctx.launch("mssm4/visibility", k, cl::NDRange(f.pixels, nl));
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
