// Directional area lights extracted from an environment map, and the extraction itself.
//
// Light model (seed 003 §4.1.3): a uniform spherical cap of half-angle alpha around `direction`
// with RGB radiance L. Its "power" M = L * 2 pi (1 - cos alpha) is the integral of the map's
// radiance over the region it replaces (seed 003 eqs. 11, 16-17), so lights conserve energy.
#pragma once
#include <array>
#include <string>
#include <vector>

namespace penumbra {

class Context;
struct Environment;

struct AreaLight {
  std::array<float, 3> direction{0, 1, 0};  // unit vector towards the light, world space
  float cosAlpha = 1.0f;                    // cosine of the half-angle
  std::array<float, 3> radiance{0, 0, 0};   // uniform radiance inside the cap
  std::array<float, 3> power{0, 0, 0};      // M = radiance * solid angle (irradiance at normal incidence / ((1+cos alpha)/2))
  // Cube-face region(s) the light came from, for overlays: face, x0, y0, x1, y1 (texels, x1/y1
  // exclusive) on a cube of faceSize.
  std::vector<std::array<int, 5>> regions;

  float halfAngle() const;
  float solidAngle() const;  // 2 pi (1 - cos alpha)
  // Unshadowed irradiance on unit normal n (cap clipped by the horizon; shared.h).
  std::array<float, 3> irradiance(const std::array<float, 3>& n) const;
};

struct LightSet {
  std::vector<AreaLight> lights;
  int faceSize = 0;                 // cube face size used for extraction
  std::string method;               // "median-cut"
  std::array<double, 3> power() const;  // sum of the lights' M
  std::array<double, 3> irradiance(const std::array<float, 3>& n) const;
  std::string toJson() const;
};

struct MedianCutOptions {
  int lights = 32;        // number of regions/lights, >= 1 (any N, not only powers of two)
  int faceSize = 256;     // cube face resolution used for the SATs, 1..4096
  int supersample = 4;    // sub-samples per equirect texel side when splatting to the cube
  float minHalfAngleDeg = 0.0f;  // lower clamp on the extracted half-angle (0: one texel's cap)
  float maxHalfAngleDeg = 85.0f; // upper clamp: the cap model needs alpha < 90 degrees
};

// Median cut on the device (seed 003 §3.1, §4.1): resample to a cube map, luminance and RGB SATs
// over the solid-angle weighted faces, split at the illuminance median along the longer edge until
// `lights` regions, then resolve each region to a light. Throws Error(BadInput) for lights < 1,
// lights > 6*faceSize^2 or a faceSize out of range.
LightSet extractMedianCut(Context& ctx, const Environment& env, const MedianCutOptions& opt = {});

// Draws the map (tone-mapped) with each light's region(s) outlined and its centre marked.
// Writes PNG atomically.
void writeLightOverlay(const std::string& path, const Environment& env, const LightSet& lights);

}  // namespace penumbra
