// Internal: what the bitmask technique (src/shadows/bitmask.cpp) shares with its tests and
// benchmarks: its light samples, a capture of one frame's lists and masks, and exact Embree
// shadow rays for explicit directions (src/reference/reference_samples.cpp) to check them against.
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "penumbra/lights.hpp"
#include "penumbra/scene.hpp"
#include "common/shared.h"
#include "lights/sampling.hpp"  // fibonacciDiskPoint: point k of that set, in double

namespace penumbra::detail {

// Light sample k of n on the unit disk: a Fibonacci spiral, uniform in area (radius
// sqrt((k + 1/2) / n), golden-angle turns). Every light uses the same set, scaled by its
// tan(alpha), so one look-up table serves all lights.
// rotation: every sample turned by that angle about the centre (jittered frames, Sintorn et al.
// 2008 §4.3).
std::vector<std::array<float, 2>> bitmaskDiskSamples(int n, double rotation = 0.0);

// The rotation of jittered frame j (BitmaskOptions::jitter): 0 for j <= 0, else
// 2 pi frac(j / golden ratio), in [0, 2 pi).
double bitmaskJitterAngle(int jitter);

// World direction of the light sample at disk point (u, v) of light L with the given tan(alpha)
// (pb_list_grid::tan_alpha): normalize(dir + tan(alpha) (u ex + v ey)).
std::array<float, 3> bitmaskSampleDirection(const pb_light& L, float tanAlpha, float u, float v);

// A light's sampling frame in the bitmask technique (kernels/shadows/bitmask.cl `frames`): two unit
// axes e1, e2 orthogonal to the light's direction, each with a scale f in (0, 1] of tan(alpha).
// Disk point (u, v) is the direction normalize(dir + tan(alpha) (f1 u e1 + f2 v e2)). Caps and
// polygons: the light frame's ex, ey and f = 1 (the bounding cap's disk); an ellipse light: its
// axes and f = tan(half-angle) / tan(alpha), the disk's affine image (Sintorn et al. 2008 §4.1: "a
// virtual
// scaling of the entire scene allows us to reestablish a spherical light source").
struct BitmaskFrame {
  std::array<float, 4> e1, e2;  // xyz: axis, w: f
};
BitmaskFrame bitmaskFrame(const pb_light& L, const AreaLight* light);
std::array<float, 3> bitmaskSampleDirection(const pb_light& L, float tanAlpha,
                                            const BitmaskFrame& fr, float u, float v);

// List statistics of one frame (Sintorn et al. 2008 Figure 9), over all lights.
struct BitmaskStats {
  std::int64_t viewSamples = 0;     // (pixel, light) pairs in the lists
  std::int64_t occupiedTexels = 0;  // texels with a non-empty list, summed over lights
  std::int64_t texels = 0;          // all list texels, summed over lights
  double meanList = 0;              // mean length of the non-empty lists
  int maxList = 0;                  // longest list
};

// What one frame of the pass computed, downloaded when a capture is installed.
struct BitmaskCapture {
  bool hard = false;
  int pixels = 0, words = 0;                   // words: mask words per view sample (hard: 1)
  std::vector<pb_light> lights;                // light frames as the kernels saw them
  std::vector<pb_list_grid> grids;             // per light
  std::vector<std::array<float, 2>> disk;      // light samples (hard: the centre only)
  std::vector<BitmaskFrame> frames;            // per light: its sampling frame
  std::vector<float> weights;                  // [light][sample]: the sample's weight (resolve)
  std::vector<int> slot;                       // [light][pixel]: index in its list, -1: no sample
  std::vector<int> counts;                     // [light][texel]: list lengths
  std::vector<std::uint32_t> masks;            // [light][pixel][word]: bit k set = sample blocked
  std::vector<std::array<float, 4>> gpos, ggeo, gnrm;  // the G-buffer
  std::vector<std::uint32_t> gids;             // camera triangle id per pixel
  BitmaskStats stats;
};

// Per mesh (index = the triangle's 4th component): +1 if the mesh is closed and wound outward
// (counter-clockwise seen from outside), -1 if closed and wound inward, 0 if open. Closed: with
// vertices welded by exact position, every directed edge appears once and its reverse once (each
// edge shared by exactly two consistently wound triangles), no triangle degenerate, and a
// non-zero signed volume, whose sign gives the winding. Such meshes cast from their
// light-back-facing triangles only (Sintorn et al. 2008 §3.3).
std::vector<int> meshOrientation(const std::vector<std::array<float, 3>>& positions,
                                 const std::vector<std::array<int, 4>>& triangles, int meshes);

// Installs a capture filled by every later bitmask frame (nullptr: none). Not thread-safe; for
// tests and benchmarks.
void setBitmaskCapture(BitmaskCapture* capture);

// Exact occlusion of rays from explicit origins along explicit directions by the scene's
// triangles (Embree 3, robust mode): the ground truth for per-(view sample, light sample) pairs.
// occluded() is safe to call from several threads at once.
class SampleTracer {
 public:
  explicit SampleTracer(const Scene& scene);
  ~SampleTracer();
  SampleTracer(const SampleTracer&) = delete;
  SampleTracer& operator=(const SampleTracer&) = delete;
  bool occluded(const std::array<float, 3>& origin, const std::array<float, 3>& dir,
                float tnear = 0.0f) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra::detail
