// What MSSM4 and MSSM6 share (src/shadows/mssm.hpp): their options' check, the parameter block
// of kernels/shadows/moments.cl, and the pass but for the moments' layout.
#include "shadows/mssm.hpp"

#include <cmath>
#include <numeric>

#include "core/device_kind.hpp"
#include "shadows/shadow_options.hpp"

namespace penumbra::detail {

void validate(const MSSMOptions& o) {
  if (!(o.momentBias >= 0 && o.momentBias < 1))
    badOption("RenderOptions.mssm.momentBias", "be in [0, 1)", o.momentBias);
  if (!(o.upperBoundTilt >= 0 && std::isfinite(o.upperBoundTilt)))
    badOption("RenderOptions.mssm.upperBoundTilt", "be finite and >= 0", o.upperBoundTilt);
  if (!(o.leakReduction >= 0 && o.leakReduction < 1))
    badOption("RenderOptions.mssm.leakReduction", "be in [0, 1)", o.leakReduction);
}

mssm_params mssmParams(const MSSMOptions& mo, const ShadowOptions& shared) {
  mssm_params P{};
  P.moment_bias = mo.momentBias;
  P.depth_bias = shared.depthBias;
  P.slope_bias = mo.slopeBias;
  setFilterLimits(P, shared);
  P.blocker_eps = mo.blockerEpsilon;
  P.upper_bound = mo.upperBoundBlocker ? 1 : 0;
  P.delta1 = mo.delta1;
  P.delta2 = mo.delta2;
  P.upper_bound_tilt = mo.upperBoundTilt;
  P.leak_reduction = mo.leakReduction;
  P.cosine_centroid = mo.cosineCentroid ? 1 : 0;
  return P;
}

mssm_params mssmParams(const ShadowFrame& f) {
  mssm_params P = mssmParams(f.opt.mssm, f.opt.shadow);
  P.horizon_skip = f.horizonRewrites ? 1 : 0;
  return P;
}

bool mssm4PrefersBatched(Context& ctx) { return useCpuBatching(ctx); }

std::vector<cl_int> identityRows(int n) {
  std::vector<cl_int> rows(static_cast<std::size_t>(std::max(n, 1)));
  std::iota(rows.begin(), rows.end(), 0);
  return rows;
}

void mssm4Visibility(Context& ctx, bool batched, const cl::Buffer& gpos, const cl::Buffer& gnrm,
                     const cl::Buffer& ggeo, const cl::Buffer& lights, const cl::Buffer& sats,
                     int size, std::size_t stride, int pixels, int nlights, const mssm_params& P,
                     cl::Buffer& vis, const std::string& stage, const cl::Buffer* rows) {
  const std::string sat = prefilterOption(Prefilter::SAT);
  if (batched) {
    cl::Kernel k = ctx.kernel("moments.cl", "mssm4_visibility_batch",
                              sat + cpuFormOptions(ctx, "VIS_GROUP", kMssm4Group));
    const std::size_t groups = cpuFormItems(std::size_t(pixels), kMssm4Group);
    cl::Buffer identity;
    if (!rows) identity = ctx.upload(identityRows(nlights), stage + " rows");  // light l: row l
    ctx.launchWith(stage, k, cl::NDRange(groups, nlights), cl::NullRange, gpos, gnrm, ggeo,
                   lights, sats, cl_int(size), cl_ulong(stride), cl_int(pixels), P, vis,
                   rows ? *rows : identity);
    return;
  }
  if (rows) throw Error(ErrorKind::Internal, stage + ": only the batched kernel takes light rows");
  cl::Kernel k = ctx.kernel("moments.cl", "mssm4_visibility", sat);
  ctx.launchWith(stage, k, cl::NDRange(pixels, nlights), cl::NullRange, gpos, gnrm, ggeo, lights,
                 sats, cl_int(size), cl_ulong(stride), cl_int(pixels), P, vis);
}

void MomentPass::computeVisibility(ShadowFrame& f) {
  validate(f.opt.mssm);
  Context& ctx = f.ctx;
  const int S = f.mapSize, nl = int(f.lights.size()), n = images(nl);
  const std::size_t stride = prefilterStride(f.opt.prefilter, S);
  cl::Buffer& maps = f.pool.buffer(technique_ + " moments", stride * n * sizeof(cl_long4));
  moments(f, maps, stride, technique_ + "/moments");
  prefilter(ctx, maps, f.opt.prefilter, S, n, technique_);
  if (technique_ == "mssm4" && f.opt.prefilter == Prefilter::SAT) {
    mssm4Visibility(ctx, mssm4PrefersBatched(ctx), f.gpos, f.gnrm, f.ggeo, f.lightBuffer, maps, S,
                    stride, f.pixels, nl, mssmParams(f), f.vis, technique_ + "/visibility");
    return;
  }
  cl::Kernel k = ctx.kernel("moments.cl", technique_ + "_visibility", prefilterOption(f.opt.prefilter));
  ctx.launchWith(technique_ + "/visibility", k, cl::NDRange(f.pixels, nl), cl::NullRange, f.gpos,
                 f.gnrm, f.ggeo, f.lightBuffer, maps, cl_int(S), cl_ulong(stride),
                 cl_int(f.pixels), mssmParams(f), f.vis);
}

}  // namespace penumbra::detail
