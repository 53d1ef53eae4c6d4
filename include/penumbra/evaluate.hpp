/// \file
/// The error budget of a rendered frame (`penumbra evaluate`): where every percent of its error
/// against the Embree environment truth comes from. Three truths of the same scene, camera and
/// size: the environment map (referenceEnvironment, G), the frame's own light set with exact
/// visibility and the ambient residual as the renderer shades it (referenceLights, L), and the same
/// with the residual shadowed (ReferenceOptions::shadowAmbient, S). With the frame F:
///   total e_T = F - G,  floor e_F = L - G,  technique e_Q = F - L,  ambient e_A = L - S,
/// so e_T = e_F + e_Q exactly, and total^2 = floor^2 + technique^2 + 2 cross with
/// cross = <e_F, e_Q>. Every figure is over the same pixels and divided by the same number, the
/// environment truth's mean over them, so the parts add up exactly (technique therefore differs
/// from `compare F L`, which divides by L's mean, by the ratio of the two means).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "penumbra/flip.hpp"
#include "penumbra/image.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/reference.hpp"
#include "penumbra/scene.hpp"

namespace penumbra {

struct Environment;

struct EvaluateOptions {
  ReferenceOptions truth = defaultTruth();  ///< size, spp, seed, threads of the three truths
  /// Directory of cached truths (empty: none). A truth is read from there when a file for the same
  /// key (truthKey) exists, and written there otherwise; the directory is created when missing.
  std::string cacheDir;
  /// Penumbra pixels: geometry pixels where the light-set truth's visibility
  /// (ReferenceImage::visibility: the fraction of the lights' unshadowed irradiance that arrives)
  /// is strictly between these two.
  double penumbraLow = 0.02, penumbraHigh = 0.98;
  FlipOptions flip;
  static ReferenceOptions defaultTruth() {
    ReferenceOptions r;
    r.spp = 4096;
    r.environmentBackground = false;
    return r;
  }
};

struct EvaluateTruths {
  ReferenceImage environment, lights, lightsShadowedAmbient;
  bool fromCache[3] = {false, false, false};  ///< in the order above
};

/// A hex digest of everything a truth depends on: the scene's geometry and albedo, the camera, the
/// size, spp and seed, the map's pixels and rotation, and (lights non-null) the light set's JSON and
/// shadowAmbient. Files in the cache are named by it.
std::string truthKey(const Scene& scene, const Camera& camera, const Environment& env,
                     const LightSet* lights, const ReferenceOptions& opt);

/// The three truths, from the cache where present. Throws Error(BadInput) naming
/// "EvaluateOptions.cacheDir" when the directory cannot be created or a file not written.
EvaluateTruths evaluateTruths(const Scene& scene, const Camera& camera, const LightSet& lights,
                              const Environment& env, const EvaluateOptions& opt);

/// One line of the budget. Relative figures divide by the environment truth's mean over the same
/// pixels; NaN where no pixel counts (e.g. no penumbra).
struct BudgetLine {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  double relativeRmse = kNaN, relativeRmsePenumbra = kNaN;
  double flip = kNaN, flipPenumbra = kNaN;  ///< mean HDR-FLIP over the pixels
  /// The truths' noise in this error image: RMSE of the difference of its half-sample versions / 2
  /// (the frame is deterministic, so only the truths' halves differ), same normalisation.
  double noise = kNaN, noisePenumbra = kNaN;
  bool belowNoise() const { return relativeRmse < 2.0 * noise; }
  /// The figure with the truths' noise taken out: the noise is independent of the error it
  /// measures, so the expected squared figure is error^2 + noise^2; sqrt(max(0, rmse^2 - noise^2)).
  double withoutNoise() const { return std::sqrt(std::max(0.0, relativeRmse * relativeRmse - noise * noise)); }
  double withoutNoisePenumbra() const {
    return std::sqrt(std::max(0.0, relativeRmsePenumbra * relativeRmsePenumbra -
                                       noisePenumbra * noisePenumbra));
  }
  bool belowNoisePenumbra() const { return relativeRmsePenumbra < 2.0 * noisePenumbra; }
};

struct ErrorBudget {
  BudgetLine total, floor, technique, ambient;
  /// cross = mean of e_floor * e_technique over pixels and RGB / mean(G)^2, so that
  /// total^2 = floor^2 + technique^2 + 2 cross (whole frame, and over the penumbra).
  double cross = 0, crossPenumbra = BudgetLine::kNaN;
  /// The truths' own relative noise (ReferenceImage::relativeNoise): G, L, S.
  double noiseEnvironment = 0, noiseLights = 0, noiseShadowedAmbient = 0;
  /// Mean signed error per RGB as a fraction of the truth's mean in that channel (negative: darker
  /// than the truth): total against G, technique against L.
  std::array<double, 3> biasTotal{}, biasTechnique{};
  /// biasTechnique over the pixels where the light-set truth is lit (at least penumbraHigh of the
  /// lights' irradiance arrives), and how many: a technique that shadows what nothing occludes
  /// shows here (README, "Lights on the horizon").
  std::array<double, 3> biasTechniqueLit{};
  std::size_t litPixels = 0;
  std::size_t geometryPixels = 0, penumbraPixels = 0;
  double penumbraLow = 0, penumbraHigh = 0;  ///< EvaluateOptions' bounds, as used
  double truthMean = 0, truthMeanPenumbra = BudgetLine::kNaN;  ///< mean of G (RGB) over the pixels
  /// Filled by the caller (the frame is rendered outside): warm render time, lights, technique.
  double frameMs = BudgetLine::kNaN;
  std::size_t lights = 0;
  std::string shadows;  ///< the technique's name (toString(ShadowTechnique))
  int spp = 0;
  std::uint64_t seed = 0;
  Image penumbraMask;                     ///< 1 channel, 1 on penumbra pixels
  Image flipTotalMap, flipTechniqueMap;   ///< FlipResult::map of total and technique
};

/// The budget of `frame` (RGBA, alpha = geometry; the truths' size). Throws Error(BadInput) on a
/// size mismatch or when the environment truth has no geometry pixel.
ErrorBudget errorBudget(const Image& frame, const EvaluateTruths& truths,
                        const EvaluateOptions& opt);

/// {"shadows" (the technique's name), "lights", "frame_ms", "spp", "seed", "pixels", "penumbra_pixels",
///  "total" | "floor" | "technique" | "ambient": {"relative_rmse", "relative_rmse_penumbra", "flip",
///  "flip_penumbra", "noise", "noise_penumbra", "relative_rmse_without_noise",
///  "relative_rmse_penumbra_without_noise", "below_noise", "below_noise_penumbra"},
///  "cross", "cross_penumbra", "sum_check": {"total_sq", "parts_sq"}, "truth_noise":
///  {"environment", "lights", "lights_shadowed_ambient"}, "bias_total", "bias_technique"};
/// non-finite numbers as null.
std::string toJson(const ErrorBudget& b);
/// The budget as the table `penumbra evaluate` prints.
std::string toText(const ErrorBudget& b);

/// Heat maps in `dir` (which must exist), PNG, each with a colour scale bar under the image:
/// error-total.png, error-floor.png, error-technique.png (signed luminance error relative to the
/// truth's mean: blue darker than the truth, white none, red brighter; the bar spans -s..+s with s
/// the 99th percentile of |error| rounded up to 1, 2 or 5 x 10^k, labelled when a font is found)
/// and flip-total.png, flip-technique.png (the FLIP map through the magma colour map, 0..1).
/// Returns the paths written; the signed scale is reported in `scale`.
std::vector<std::string> writeHeatMaps(const ErrorBudget& b, const Image& frame,
                                       const EvaluateTruths& truths, const std::string& dir,
                                       double* scale = nullptr);

}  // namespace penumbra
