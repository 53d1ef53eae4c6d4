// Internal: the checks render() makes on its inputs before any device work.
#pragma once
#include "penumbra/environment.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/options.hpp"
#include "penumbra/scene.hpp"

namespace penumbra::detail {

// Throws Error(BadInput) naming the field ("RenderOptions.width must be in [1, 16384], got 0")
// for a frame size, map size, shared shadow setting (ShadowOptions) or bent-normal scale out of
// range, an empty scene or environment, or a technique or prefilter this build does not have.
// The technique's own options are checked by its pass (src/shadows/shadow_options.hpp).
// The scene, camera, lights and environment are checked as the file loaders check their files
// (validateScene, cameraBasis, validateLightSet, finite non-negative radiance), so that code
// handing the renderer data never gets past what a file would be refused for.
void validateFrameInputs(const Scene& scene, const Camera& camera, const LightSet& lights,
                         const Environment& env, const RenderOptions& opt);

}  // namespace penumbra::detail
