// Internal: hard shadows' visibility kernels (src/shadows/hard.cpp), apart from the pass so that
// tests can run both forms on the same inputs.
#pragma once
#include "penumbra/context.hpp"

namespace penumbra::detail {

// kernels/shadows/pcss.cl's hard_visibility (one pixel per work-item, for GPUs) or
// hard_visibility_batch (kHardGroup pixels and every light per work-item, SIMD across the pixels;
// CPU devices, where the first runs one work-item at a time). The two give the same bits.
// vis: float [light][pixel], 1 lit, 0 shadowed; depth: per light size x size uint
// (ShadowFrame::depth).
constexpr int kHardGroup = 64;
void hardVisibility(Context& ctx, bool batched, const cl::Buffer& gpos, const cl::Buffer& gnrm,
                    const cl::Buffer& ggeo, const cl::Buffer& lights, const cl::Buffer& depth,
                    int size, int pixels, int nlights, float depthBias, cl::Buffer& vis);

}  // namespace penumbra::detail
