// Internal: the checks render() makes on its inputs before any device work.
#pragma once
#include "penumbra/environment.hpp"
#include "penumbra/options.hpp"
#include "penumbra/scene.hpp"

namespace penumbra::detail {

// Throws Error(BadInput) naming the field and its value for any option out of range, an empty
// scene or environment, or a technique or prefilter this build does not have.
void validateFrameInputs(const Scene& scene, const Environment& env, const RenderOptions& opt);

}  // namespace penumbra::detail
