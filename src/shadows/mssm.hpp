// Internal: what MSSM4 and MSSM6 (src/shadows/mssm4.cpp, src/shadows/mssm6.cpp) share: the
// parameter block of kernels/moments.cl (shadows/shadow_params.h) and its visibility launch
// (src/shadows/mssm.cpp).
#pragma once
#include <string>

#include "shadows/shadow_pass.hpp"
#include "shadows/shadow_params.h"

namespace penumbra::detail {

// kernels/moments.cl's parameters. `shared` at its defaults is enough for the reconstruction
// alone (mssm_reconstruct reads the moment bias, the blocker epsilon and the eq. 19 clamps).
mssm_params mssmParams(const MSSMOptions& mo, const ShadowOptions& shared = ShadowOptions{});

// Runs kernels/moments.cl's "<technique>_visibility" (technique "mssm4"
// or "mssm6") on the prefiltered moment images `maps` (one every `stride` long4) for every pixel
// and light, as stage "<technique>/visibility".
void mssmVisibility(ShadowFrame& f, const std::string& technique, cl::Buffer& maps,
                    std::size_t stride);

}  // namespace penumbra::detail
