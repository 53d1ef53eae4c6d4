// Internal: what MSSM4 and MSSM6 (src/shadows_mssm4.cpp, src/shadows_mssm6.cpp) share, the
// parameter block of kernels/moments.cl.
#pragma once
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

// Must match kernels/moments.cl's mssm_params.
struct MssmParams {
  cl_float momentBias, depthBias, slopeBias, lightSizeScale;
  cl_float maxFilter, minFilter, blockerEps;
  cl_int upperBound;
  cl_float delta1, delta2, pad0, pad1;
};

inline MssmParams mssmParams(const MSSMOptions& mo) {
  return {mo.momentBias,      mo.depthBias,       mo.slopeBias,      mo.lightSizeScale,
          mo.maxFilterTexels, mo.minFilterTexels, mo.blockerEpsilon, mo.upperBoundBlocker ? 1 : 0,
          mo.delta1,          mo.delta2,          0.0f,              0.0f};
}

// The visibility kernels' arguments, in kernels/moments.cl's order.
inline void setVisibilityArgs(cl::Kernel& k, ShadowFrame& f, cl::Buffer& maps, std::size_t stride) {
  MssmParams P = mssmParams(f.opt.mssm);
  k.setArg(0, f.gpos);
  k.setArg(1, f.gnrm);
  k.setArg(2, f.ggeo);
  k.setArg(3, f.lightBuffer);
  k.setArg(4, maps);
  k.setArg(5, cl_int(f.mapSize));
  k.setArg(6, cl_ulong(stride));
  k.setArg(7, cl_int(f.pixels));
  k.setArg(8, sizeof(P), &P);
  k.setArg(9, f.vis);
}

}  // namespace penumbra::detail
