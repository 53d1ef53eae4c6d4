// Internal: contact shadows (kernels/render/contact.cl), the last step of the visibility stage
// for techniques that read shadow maps.
#pragma once
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

// Sets f.vis (float [light][pixel]) to 0 wherever the ray from the pixel's surface towards the
// light's centre, f.opt.shadow.contactTexels texels of the light's map long, hits a triangle the
// G-buffer shows within 2 pixels; for the lights l with lightMask[l] != 0 (uchar per light).
// Needs f.gids, f.positions and f.triangles (the renderer's); does nothing without them (the GL
// interop) or without lights.
void contactShadows(const ShadowFrame& f, const cl::Buffer& lightMask);

// Whether contactShadows() has what it needs in f.
bool hasContactInputs(const ShadowFrame& f);

}  // namespace penumbra::detail
