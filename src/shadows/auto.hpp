// Internal: the per-light technique choice of `auto` (src/shadows/auto.cpp), apart from its pass so
// that tests can pin the rule on hand-made lights.
#pragma once
#include <vector>

#include "penumbra/context.hpp"  // cl_float4
#include "penumbra/lights.hpp"
#include "penumbra/options.hpp"
#include "common/shared.h"

namespace penumbra::detail {

// What the rule reads of one light.
struct AutoLight {
  double power = 0;     // luminance of the light's power (irradiance at normal incidence)
  double tanAlpha = 0;  // tan of its (bounding) cap's half-angle
  double distance = 0;  // typical caster-receiver distance of its shadows on screen, world units
                        // (casterDistance); 0: it shadows nothing the camera sees
  double texel = 0;     // world size of one of its shadow-map texels
  double receiverSin = 1;  // sine of its height above the receivers on screen that face it: the
                           // median of n.w over them (casterStats); 1 when none face it
  double screenCos = 1;    // mean of max(0, n.w) over the camera's pixels (casterStats): the share
                           // of its power that reaches the surfaces on screen; 1 when not known
};

// A light as the rule sees it: its frame (ShadowFrame::lights), the light itself when known (its
// power: radiance times its solid angle; else the frame's radiance times the cap's), the frame's
// map size and the caster distance.
AutoLight autoLight(const pb_light& L, const AreaLight* light, int mapSize, double distance);

// The typical caster-receiver distance of light L's shadows on screen, world units: the median,
// over the camera pixels its hard-shadow test finds shadowed (their depth behind the map's texel
// by more than the bias and two texels, so no receiver counts as its own blocker), of that depth
// gap: the blocker distance PCSS's search estimates per pixel (Fernando 2005). map: L's S x S
// depth map (ShadowFrame::depth's encoding); gpos, gnrm: the G-buffer, `step`: every step-th
// pixel is tested. 0 when no pixel is shadowed.
double casterDistance(const pb_light& L, const cl_uint* map, int size,
                      const std::vector<cl_float4>& gpos, const std::vector<cl_float4>& gnrm,
                      float depthBias, int step = 1);

// The same in two steps, for many lights over one G-buffer: the pixels casterDistance tests
// (every step-th that sees geometry), packed once (`out` reuses its storage), then each light's
// median over them (`gaps`: scratch storage, reused). The same value as above, bit for bit.
struct CasterSample {
  float position[3], normal[3];
};
std::vector<CasterSample> casterSamples(const std::vector<cl_float4>& gpos,
                                        const std::vector<cl_float4>& gnrm, int step = 1);
void casterSamples(const std::vector<cl_float4>& gpos, const std::vector<cl_float4>& gnrm,
                   int step, std::vector<CasterSample>& out);
void casterSamples(const cl_float4* gpos, const cl_float4* gnrm, std::size_t pixels, int step,
                   std::vector<CasterSample>& out);
double casterDistance(const pb_light& L, const cl_uint* map, int size,
                      const std::vector<CasterSample>& samples, float depthBias,
                      std::vector<double>& gaps);

// casterDistance and, from the same pixels, the light's height above the receivers that face it:
// the median of n.w (the sine of the light's elevation above their tangent planes) over the
// samples whose normal n faces the light's direction w, 1 when none does or when `sines` (its
// scratch storage) is null; and the mean of max(0, n.w) over all the samples (AutoLight::
// screenCos; 1 when there are none).
struct CasterStats {
  double distance = 0, receiverSin = 1, screenCos = 1;
};
CasterStats casterStats(const pb_light& L, const cl_uint* map, int size,
                        const std::vector<CasterSample>& samples, float depthBias,
                        std::vector<double>& gaps, std::vector<double>* sines);

// The estimated penumbra width, world units: the cap's diameter 2 tan(alpha) at the caster
// distance.
double autoPenumbraWidth(const AutoLight& l);

// The light's mean irradiance on the surfaces the camera sees, relative: power times screenCos.
// The budgets of the rule (exact, then filtered) go to the lights with the most, first.
double autoScreenIrradiance(const AutoLight& l);

// A camera pixel's footprint on the scene, world units: the median distance between the
// positions of horizontally adjacent pixels that both see geometry (gpos: float4 per pixel, w = 1
// on geometry, row by row). 0 when no two such pixels exist. scratch: storage for the distances,
// kept by a caller that asks every frame (null: its own).
double pixelFootprint(const std::vector<cl_float4>& gpos, int width, int height);
double pixelFootprint(const cl_float4* gpos, int width, int height, std::vector<double>* scratch);

// Each light's technique: Bitmask (exact), Hard, PCSS or MSSM4, by the rule of AutoOptions
// (include/penumbra/options.hpp, explained in src/shadows/auto.cpp). pixel: pixelFootprint's
// value (0: unknown, texels alone decide); maxFilterTexels: ShadowOptions' clamp on the filter
// width. exactAllowed false (a frame without triangles, which the bitmask technique needs): no
// light is exact.
std::vector<ShadowTechnique> chooseShadowTechniques(const std::vector<AutoLight>& lights,
                                                    double pixel, const AutoOptions& o,
                                                    float maxFilterTexels = 27.0f,
                                                    bool exactAllowed = true);

}  // namespace penumbra::detail
