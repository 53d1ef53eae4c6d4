// Internal: what MSSM4 and MSSM6 (src/shadows/mssm4.cpp, src/shadows/mssm6.cpp) share
// (src/shadows/mssm.cpp): the pass itself but for how the moments are stored, and the parameter
// block of kernels/shadows/moments.cl (shadows/shadow_params.h).
#pragma once
#include <string>
#include <utility>

#include "shadows/shadow_pass.hpp"
#include "shadows/shadow_params.h"

namespace penumbra::detail {

// kernels/shadows/moments.cl's parameters. `shared` at its defaults is enough for the
// reconstruction alone (mssm_reconstruct reads the moment bias, the blocker epsilon and the eq. 19
// clamps).
mssm_params mssmParams(const MSSMOptions& mo, const ShadowOptions& shared = ShadowOptions{});
// The block for frame f's pass: f's options, and horizon_skip where the horizon step follows
// (ShadowFrame::horizonRewrites).
mssm_params mssmParams(const ShadowFrame& f);

// MSSM4's visibility kernel on SAT-prefiltered moments: kernels/shadows/moments.cl's
// mssm4_visibility (one pixel per work-item, for GPUs) or mssm4_visibility_batch (kMssm4Group
// pixels per work-item, SIMD across the pixels that need the light with the box filters' SAT reads
// in scalar loops; CPU devices, where the first runs one work-item at a time). The two give the
// same bits.
constexpr int kMssm4Group = 64;
bool mssm4PrefersBatched(Context& ctx);
void mssm4Visibility(Context& ctx, bool batched, const cl::Buffer& gpos, const cl::Buffer& gnrm,
                     const cl::Buffer& ggeo, const cl::Buffer& lights, const cl::Buffer& sats,
                     int size, std::size_t stride, int pixels, int nlights, const mssm_params& P,
                     cl::Buffer& vis, const std::string& stage, const cl::Buffer* rows = nullptr);
// Rows 0 .. n-1 (at least one element): each light's map and visibility row are its own.
std::vector<cl_int> identityRows(int n);

// Moment soft shadow mapping (Kneiphof 2017): the lights' moments from their depth maps,
// prefiltered
// (RenderOptions::prefilter), then kernels/shadows/moments.cl's "<technique>_visibility" for every
// pixel and light. Stages "<technique>/moments", "<technique>/sat" or "/mip",
// "<technique>/visibility" (MSSM4's CPU form: "mssm4/moments+sat", src/shadows/mssm4.cpp).
class MomentPass : public ShadowPass {
 public:
  explicit MomentPass(std::string technique) : technique_(std::move(technique)) {}
  void computeVisibility(ShadowFrame& f) override;

 protected:
  // Filterable long4 images the moments of `lights` lights take.
  virtual int images(int lights) const = 0;
  // Writes them into `maps`, image i at element i * stride, as stage `stage`.
  virtual void moments(ShadowFrame& f, cl::Buffer& maps, std::size_t stride,
                       const std::string& stage) const = 0;

 private:
  std::string technique_;  // "mssm4" or "mssm6"
};

}  // namespace penumbra::detail
