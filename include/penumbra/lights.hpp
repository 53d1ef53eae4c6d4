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
  // Sets the power M and the radiance M / solid angle (seed 003 eqs. 16-17); set cosAlpha first.
  void setPower(const std::array<float, 3>& m);
  // Unshadowed irradiance on unit normal n (cap clipped by the horizon; shared.h).
  std::array<float, 3> irradiance(const std::array<float, 3>& n) const;
};

struct LightSet {
  std::vector<AreaLight> lights;
  int faceSize = 0;                 // cube face size used for extraction
  std::string method;               // "median-cut" | "greedy" | "center-surround" | "user"
  // Ambient residual (seed 004 §3; Ramamoorthi & Hanrahan 2001): the radiance the lights do not
  // carry, map minus the lights' caps, projected onto the 9 real spherical harmonics of order
  // <= 2, RGB. Applied unshadowed. Coefficient order: (l,m) = (0,0) (1,-1) (1,0) (1,1) (2,-2)
  // (2,-1) (2,0) (2,1) (2,2). All zero when hasAmbient is false.
  std::array<std::array<float, 3>, 9> ambientSH{};
  bool hasAmbient = false;
  std::array<double, 3> power() const;  // sum of the lights' M plus the ambient's power
  std::array<double, 3> lightsPower() const;  // sum of the lights' M only
  std::array<double, 3> ambientPower() const;  // integral of the ambient radiance over the sphere
  // Unshadowed irradiance on unit normal n: every light's cap plus the ambient's.
  std::array<double, 3> irradiance(const std::array<float, 3>& n) const;
  std::array<double, 3> ambientIrradiance(const std::array<float, 3>& n) const;
  std::string toJson() const;
};

struct MedianCutOptions {
  int lights = 32;        // number of regions/lights, >= 1 (any N, not only powers of two)
  int faceSize = 256;     // cube face resolution used for the SATs, 1..4096
  int supersample = 4;    // sub-samples per equirect texel side when splatting to the cube
  float minHalfAngleDeg = 0.0f;  // lower clamp on the extracted half-angle (0: one texel's cap)
  float maxHalfAngleDeg = 85.0f; // upper clamp: the cap model needs alpha < 90 degrees
  // Merge lights whose regions touch across a cube-face edge and whose caps overlap (angle
  // between directions < sum of half-angles) into one light with their summed moments: a source
  // cut by a face edge stays one light, with one shadow instead of two with a seam between them.
  // The light count can then end below `lights` (`lights` regions are still cut). Default true;
  // false keeps one light per median-cut region.
  bool mergeAcrossFaces = true;
  // Only compact lights are merged: those whose cap covers at most this fraction of their
  // regions' solid angle (a source brighter than its surroundings; the cap of a uniformly bright
  // region is about as large as the region, 1.05 for a square). In (0, 1], default 0.5.
  float mergeCompactness = 0.5f;
};

// Median cut on the device (seed 003 §3.1, §4.1): resample to a cube map, luminance and RGB SATs
// over the solid-angle weighted faces, split at the illuminance median along the longer edge until
// `lights` regions, then resolve each region to a light. Throws Error(BadInput) for lights < 1,
// lights > 6*faceSize^2 or a faceSize out of range.
LightSet extractMedianCut(Context& ctx, const Environment& env, const MedianCutOptions& opt = {});

// Greedy fitting of square or rectangular lights to each cube face (seed 000 §4.2, Figure 6).
struct GreedyOptions {
  float threshold = 0.02f;  // a side grows while (energy it adds) / (energy of the grown light) > t
  bool square = true;       // square lights (the paper's results); false: rectangular
  int faceSize = 64;        // cube face resolution the fit runs on, 1..1024
  int maxLights = 64;       // the strongest this many are kept; the rest goes to the ambient
  int supersample = 4;
};
LightSet extractGreedy(Context& ctx, const Environment& env, const GreedyOptions& opt = {});

// Center-surround filter bank on the sphere (seed 004 §3).
struct CenterSurroundOptions {
  int width = 512;              // working equirect resolution (width x width/2) the filters run on
  int sizes = 20;               // filter sizes, geometric from minDeg to maxDeg (outer diameter)
  float minDeg = 4.5f, maxDeg = 45.0f;
  float innerRatio = 0.75f;     // inner radius / outer radius
  float surroundWeight = -10.0f;// weight of the ring; the centre's is +1
  float candidateFraction = 0.10f;  // the brightest this fraction of texels are candidate centres
  float stopFraction = 0.02f;   // stop when a light carries less than this of the lights so far
  int maxLights = 256;
};
LightSet extractCenterSurround(Context& ctx, const Environment& env,
                               const CenterSurroundOptions& opt = {});

// Sets set.ambientSH to SH9(map) - sum of SH9(each light's uniform cap), computed on the device,
// and set.hasAmbient = true.
void addAmbientResidual(Context& ctx, const Environment& env, LightSet& set);

enum class ExtractionMethod { MedianCut, Greedy, CenterSurround };
ExtractionMethod parseExtractionMethod(const std::string& name);  // "median-cut" | "greedy" | "center-surround"
const char* toString(ExtractionMethod m);
struct ExtractOptions {
  ExtractionMethod method = ExtractionMethod::MedianCut;
  MedianCutOptions medianCut;
  GreedyOptions greedy;
  CenterSurroundOptions centerSurround;
  bool ambient = true;  // add the ambient residual (addAmbientResidual)
};
// Runs the chosen method, then the ambient residual when opt.ambient.
LightSet extractLights(Context& ctx, const Environment& env, const ExtractOptions& opt = {});

// Draws the map (tone-mapped) with each light's region(s) outlined and its centre marked; a light
// without regions (center-surround) gets its cap's outline, the circle at its half-angle.
// Writes PNG atomically.
void writeLightOverlay(const std::string& path, const Environment& env, const LightSet& lights);

}  // namespace penumbra
