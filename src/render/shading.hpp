// Internal: the shading stage (kernels/render/shade.cl): the G-buffer lit by every light through
// its visibility, the ambient residual unshadowed, optionally with bent normals, and the
// environment behind the background.
#pragma once
#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/options.hpp"
#include "render/bent_normals.hpp"
#include "render/rasterizer.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

// What the shade kernel reads besides the options and the light set.
struct ShadeInputs {
  const DeviceGBuffer& gbuffer;
  const cl::Buffer& lights;       // pb_light per light of the light set
  const cl::Buffer& visibility;   // float [light][pixel] (src/render/visibility.hpp)
  const cl::Buffer& camera;       // one pb_view
  const cl::Buffer& environment;  // the equirect pixels (DeviceScene::environment)
  const BentBuffers& bent;        // read only when opt.bentNormals and there are lights
};

// Shades `width` x `height` pixels into a pool buffer (float4 RGBA per pixel) and returns it.
// Stage "shade".
cl::Buffer shade(Context& ctx, BufferPool& pool, const ShadeInputs& in, const LightSet& lightSet,
                 const Environment& env, const RenderOptions& opt);

}  // namespace penumbra::detail
