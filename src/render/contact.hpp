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

// The same rays against what the lights' maps see (ShadowOptions::contactFromMaps): for each
// light l with lightMask[l] != 0, the triangle f.mapIds names at the texel the pixel falls in,
// where f.depth's surface there is nearer the light than the pixel's tangent plane and within
// the contact length; and, where the light's centre is below the pixel's facet but above its
// shading normal's horizon, the pixel's own triangle too (kernels/render/contact.cl,
// contact_map). Does nothing without f.mapIds.
void contactFromMaps(const ShadowFrame& f, const cl::Buffer& lightMask);

// Whether contactShadows() has what it needs in f.
bool hasContactInputs(const ShadowFrame& f);

}  // namespace penumbra::detail
