/// \file
/// Light extraction: area lights found in an environment map by one of three methods (median cut,
/// greedy rectangles, a center-surround filter bank), each conserving the map's energy, then
/// optionally textured and completed by the ambient residual (extractLights); and an overlay that
/// draws what was found on the map.
#pragma once
#include <string>
#include <vector>

#include "penumbra/ambient.hpp"
#include "penumbra/image.hpp"
#include "penumbra/lights.hpp"

namespace penumbra {

class Context;
struct Environment;

struct MedianCutOptions {
  int lights = 64;        ///< number of regions/lights, >= 1 (any N, not only powers of two);
                          ///< default 64 (README, "The default frame")
  int faceSize = 256;     ///< cube face resolution used for the SATs, 1..4096
  int supersample = 4;    ///< sub-samples per equirect texel side when splatting to the cube
  float minHalfAngleDeg = 0.0f;  ///< lower clamp on the extracted half-angle (0: one texel's cap)
  float maxHalfAngleDeg = 85.0f; ///< upper clamp: the cap model needs alpha < 90 degrees
  /// Merge lights whose regions touch across a cube-face edge and whose caps overlap (angle
  /// between directions < sum of half-angles) into one light with their summed moments: a source
  /// cut by a face edge stays one light, with one shadow instead of two with a seam between them.
  /// The light count can then end below `lights` (`lights` regions are still cut). Default true;
  /// false keeps one light per median-cut region.
  bool mergeAcrossFaces = true;
  /// Only compact lights are merged: those whose cap covers at most this fraction of their
  /// regions' solid angle (a source brighter than its surroundings; the cap of a uniformly bright
  /// region is about as large as the region, 1.05 for a square). In (0, 1], default 0.5.
  float mergeCompactness = 0.5f;
  /// Shape of the extracted lights. Cap: Kneiphof's (2017) disc of the region's moments. Polygon: a
  /// light
  /// made from a single region is that region's exact shape, the convex spherical quadrilateral
  /// whose edges are the region's (great circles, since a cube face is a gnomonic projection),
  /// with radiance = region power / region solid angle (exact power). Lights merged from several
  /// regions (across face edges, or whole faces when fewer than 6 lights are asked for) stay caps:
  /// their union is not one convex polygon.
  /// Measured (tests/test_polygon_lights.cpp): the polygon is exact where the map is uniform over
  /// each region, but median-cut regions are not (they are cut at the energy median, so a bright
  /// source shares its region with darker texels), and a uniform polygon moves the region's first
  /// moment to the polygon's centroid, which the cap keeps. On the test maps the polygon shape's
  /// irradiance error on issue 4's 26 normals is 3-9x the cap's (see the test's report); the cap
  /// is the default for that reason.
  LightShape shape = LightShape::Cap;
  /// Bright sources apart: texels brighter than peakRatio times the map's mean luminance are
  /// grouped into connected sets, and the brightest sets (at most lights / 4, each with at least
  /// 1 / lights of the map's luminance and at most peakMaxHalfAngleDeg wide) become one cap each,
  /// resolved from their own texels, with no regions; median cut splits the rest of the map into
  /// the other lights (README, "Bright sources"). Median cut alone cuts such a source (a sun) into
  /// several lights and leaves slivers of it in the neighbouring sky regions, whose wide caps then
  /// cast its sharp shadow as a soft one (bench/results/accuracy.md, "Bright sources apart").
  /// Finite, >= 0; default 100; 0: off. Below 4 lights, where median cut cuts whole faces, it
  /// never applies.
  float peakRatio = 100.0f;
  /// Bright sources apart: a set whose cap would be wider than this (degrees) stays with median
  /// cut (a wide source casts soft shadows, which the filtered techniques handle, and its exact
  /// visibility is costly; on studio.exr + Wuson a 5.8-degree softbox left to median cut measured
  /// 3.05% against 3.34% as a light of its own). In (0, 90); default 5, AutoOptions'
  /// exactHalfAngleDeg, so that every light separated is exact under `auto`.
  float peakMaxHalfAngleDeg = 5.0f;
};

/// Median cut on the device (Kneiphof 2017 §3.1, §4.1): resample to a cube map, luminance and RGB
/// SATs
/// over the solid-angle weighted faces, split at the illuminance median along the longer edge until
/// `lights` regions, then resolve each region to a light. Throws Error(BadInput) for lights < 1,
/// lights > 6*faceSize^2 or a faceSize out of range.
LightSet extractMedianCut(Context& ctx, const Environment& env, const MedianCutOptions& opt = {});

/// Greedy fitting of square or rectangular lights to each cube face (Annen et al. 2008 §4.2, Figure
/// 6).
struct GreedyOptions {
  float threshold = 0.02f;  ///< a side grows while (energy it adds) / (energy of the grown light) > t
  bool square = true;       ///< square lights (the paper's results); false: rectangular
  int faceSize = 64;        ///< cube face resolution the fit runs on, 1..1024
  int maxLights = 64;       ///< the strongest this many are kept; the rest goes to the ambient
  int supersample = 4;
};
LightSet extractGreedy(Context& ctx, const Environment& env, const GreedyOptions& opt = {});

/// Center-surround filter bank on the sphere (Arbree et al. 2005 §3).
struct CenterSurroundOptions {
  int width = 512;              ///< working equirect resolution (width x width/2) the filters run on
  int sizes = 20;               ///< filter sizes, geometric from minDeg to maxDeg (outer diameter)
  float minDeg = 4.5f, maxDeg = 45.0f;
  float innerRatio = 0.75f;     ///< inner radius / outer radius
  float surroundWeight = -10.0f;///< weight of the ring; the centre's is +1
  float candidateFraction = 0.10f;  ///< the brightest this fraction of texels are candidate centres
  float stopFraction = 0.02f;   ///< stop when a light carries less than this of the lights so far
  int maxLights = 256;
};
LightSet extractCenterSurround(Context& ctx, const Environment& env,
                               const CenterSurroundOptions& opt = {});

enum class ExtractionMethod { MedianCut, Greedy, CenterSurround };
ExtractionMethod parseExtractionMethod(const std::string& name);  // "median-cut" | "greedy" | "center-surround"
const char* toString(ExtractionMethod m);
struct ExtractOptions {
  ExtractionMethod method = ExtractionMethod::MedianCut;
  MedianCutOptions medianCut;
  GreedyOptions greedy;
  CenterSurroundOptions centerSurround;
  bool ambient = true;  ///< add the ambient residual (addAmbientResidual)
  AmbientOptions ambientOptions;  ///< its representation (default: the irradiance map, 128 x 64)
  /// Texture every extracted cap with lightTexture x lightTexture texels of the map's radiance
  /// (textureLightsFromMap; power kept), so that the sample-based techniques (bitmask, brute
  /// force, the light-set reference) weight each light sample by the map. 0 (default): none;
  /// else in [1, 64].
  int lightTexture = 0;
  /// > 0: choose the median-cut light count to this predicted error (extractToTargetError), with
  /// medianCut.lights as the most lights tried. 0 (default): extract medianCut.lights.
  double targetError = 0.0;
};
/// Runs the chosen method, then the light textures when opt.lightTexture > 0, then the ambient
/// residual when opt.ambient; with opt.targetError > 0, extractToTargetError.
LightSet extractLights(Context& ctx, const Environment& env, const ExtractOptions& opt = {});

/// A cheap prediction of the error a light set leaves under occlusion, with exact visibility of
/// its lights (the "floor" of `penumbra evaluate`): on 64 receiver normals, each with 32 cones
/// blocking part of its upper hemisphere (16 axes, half-angles 20 and 45 degrees), the luminance
/// irradiance that passes from the lights (32 samples each) plus the ambient residual (unshadowed,
/// as the renderer shades it) against what passes from the map (at most 128 x 64 bins); the RMS
/// of the differences over the mean of the map's. Unoccluded, the lights plus the residual match
/// the map by construction, so only occlusion shows what a light count gets wrong. Relative, >= 0;
/// 30-120 ms on this project's 2-core CPU. bench/results/light_count.md compares it with the
/// measured floor.
double lightSetProbeError(const Environment& env, const LightSet& set);

/// What extractToTargetError tried: each count asked for, the lights it gave (median cut's merges
/// can give fewer) and its prediction.
struct LightCountTry {
  int asked = 0;
  int lights = 0;
  double predicted = 0.0;
};
struct LightCountSearch {
  int lights = 0;           ///< the count chosen (regions asked of median cut)
  double predicted = 0.0;   ///< its lightSetProbeError
  bool reached = false;     ///< false: even opt.medianCut.lights lights miss the target
  std::vector<LightCountTry> tried;
};
/// The smallest median-cut light count, up to opt.medianCut.lights, whose lightSetProbeError is at
/// most opt.targetError: 4, 8, 16, ... until one meets it, then bisection down to an eighth of the
/// count. Extracts as extractLights does (textures, ambient) at each count tried. Throws
/// Error(BadInput) for another method or a target that is not a finite number > 0.
LightSet extractToTargetError(Context& ctx, const Environment& env, const ExtractOptions& opt,
                              LightCountSearch* search = nullptr);

/// The map (tone-mapped, automatic exposure) with each light's region(s) outlined and its centre
/// marked; a light without regions (center-surround) gets its cap's outline, the circle at its
/// half-angle. With `labels`, each centre is labelled "i  p%": the light's index in the set and its
/// share of the set's power (luminance of AreaLight::power), in DejaVuSans (fonts-dejavu-core; no
/// labels when the font is missing). Small maps are enlarged (nearest texel) to at least 1024
/// pixels wide. A display image: RGB, values k/255 in [0,1], the bytes writeLightOverlay writes.
Image lightOverlay(const Environment& env, const LightSet& lights, bool labels = true);
/// lightOverlay with labels, written atomically (PNG usually; any 8-bit format writeImage takes).
void writeLightOverlay(const std::string& path, const Environment& env, const LightSet& lights);

}  // namespace penumbra
