// MSSM4: moment soft shadow mapping with four moments (Kneiphof 2017 §3.2.1),
// kernels/shadows/moments.cl.
#include "core/device_kind.hpp"
#include "shadows/mssm.hpp"
#include "shadows/shadow_options.hpp"

namespace penumbra::detail {
namespace {

class MSSM4Pass : public MomentPass {
 public:
  MSSM4Pass() : MomentPass("mssm4") {}
  int images(int lights) const override { return lights; }
  // The CPU form with the SAT prefilter: the moments and their table in one sweep a map
  // (moments.cl, depth_to_moments_sat), then the batched visibility, light l's map and visibility
  // row being rows[l] (its own without them; auto's subsets give the frame's). Else the moments,
  // the prefilter and the visibility as every moment technique runs them.
  bool readsFrameRows(Context& ctx, const RenderOptions& opt) const override {
    return opt.prefilter == Prefilter::SAT && useCpuBatching(ctx);
  }
  void computeVisibility(ShadowFrame& f) override {
    if (!readsFrameRows(f.ctx, f.opt)) return MomentPass::computeVisibility(f);
    validate(f.opt.mssm);
    const int S = f.mapSize, nl = int(f.lights.size());
    const std::size_t stride = prefilterStride(Prefilter::SAT, S);
    cl::Buffer& maps = f.pool.buffer("mssm4 moments", stride * nl * sizeof(cl_long4));
    cl::Buffer rows = f.rows;
    if (!rows()) rows = f.pool.upload("mssm4 rows", identityRows(nl));
    cl::Kernel k = f.ctx.kernel("moments.cl", "depth_to_moments_sat", simdLoopOption(f.ctx));
    f.ctx.launchWith("mssm4/moments+sat", k, cl::NDRange(nl), cl::NDRange(1), f.depth,
                     f.lightBuffer, cl_int(S), cl_ulong(stride), maps, rows);
    mssm4Visibility(f.ctx, true, f.gpos, f.gnrm, f.ggeo, f.lightBuffer, maps, S, stride, f.pixels,
                    nl, mssmParams(f), f.vis, "mssm4/visibility", &rows);
  }
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
