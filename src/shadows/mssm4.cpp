// MSSM4: moment soft shadow mapping with four moments (Kneiphof 2017 §3.2.1),
// kernels/shadows/moments.cl.
#include "core/device_kind.hpp"
#include "shadows/mssm.hpp"

namespace penumbra::detail {
namespace {

class MSSM4Pass : public MomentPass {
 public:
  MSSM4Pass() : MomentPass("mssm4") {}
  int images(int lights) const override { return lights; }
  // one long4 image per light: b1..b4 (kernels/shadows/moments.cl, depth_to_moments)
  void moments(ShadowFrame& f, cl::Buffer& maps, std::size_t stride,
               const std::string& stage) const override {
    const int S = f.mapSize;
    if (useCpuBatching(f.ctx)) {
      cl::Kernel k = f.ctx.kernel("moments.cl", "depth_to_moments_rows", simdLoopOption(f.ctx));
      f.ctx.launchWith(stage, k, cl::NDRange(S, int(f.lights.size())), cl::NullRange, f.depth,
                       f.lightBuffer, cl_int(S), cl_ulong(stride), maps);
      return;
    }
    cl::Kernel k = f.ctx.kernel("moments.cl", "depth_to_moments");
    f.ctx.launchWith(stage, k, cl::NDRange(S, S, int(f.lights.size())), cl::NullRange, f.depth,
                     f.lightBuffer, cl_int(S), cl_ulong(stride), maps);
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
