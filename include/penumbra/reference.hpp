/// \file
/// Ground truth on the CPU with Embree 3: per pixel Monte Carlo direct lighting of the same diffuse
/// scene, shadow rays traced exactly. Two modes: the full environment map (importance sampled), or
/// the extracted light set (each cap sampled uniformly), which isolates a shadow technique's error
/// from the extraction's.
#pragma once
#include <cstdint>
#include <functional>
#include <string>

#include "penumbra/image.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/scene.hpp"

namespace penumbra {

struct Environment;

struct ReferenceOptions {
  int width = 640, height = 360;
  int spp = 256;                 ///< shadow-ray samples per pixel
  std::uint64_t seed = 1;        ///< same seed, same image (independent of thread count)
  int threads = 0;               ///< 0: all hardware threads
  bool environmentBackground = true;
  /// referenceLights only: shadow the ambient residual with traced visibility instead of adding it
  /// unshadowed (see referenceLights). Isolates the residual's missing shadows as an error source.
  bool shadowAmbient = false;
  /// Progress and cancellation; either may be empty. Both are called from the calling thread
  /// only, never concurrently, at every poll: once before any work, after each finished row and
  /// at least every 100 ms while the work goes on (between pixels: a pixel at thousands of samples
  /// takes milliseconds).
  /// At each poll `progress` gets the fraction of pixels done (0..1, non-decreasing; the same
  /// value may come again when no pixel finished since the last poll), then `cancel` is asked
  /// whether to stop (true: stop). A finished render calls progress(1.0) once at the end, without
  /// asking `cancel`. On a stop the workers finish the pixel they are on and the call throws
  /// Error(ErrorKind::Cancelled, "reference: cancelled after X% (N of M pixels)"); an exception
  /// thrown by either callback stops the render the same way and is rethrown as it is. Either way
  /// the call returns within about a pixel's time, and nothing is returned. The callbacks never
  /// change the pixels: a finished render is the same, bit for bit, with or without them.
  std::function<void(double)> progress;
  std::function<bool()> cancel;
};

/// A reference with an estimate of its own Monte Carlo noise. Every pixel's samples are split by
/// sample index into two halves (even: A, odd: B), each an estimate of the same pixel on its own,
/// with image = (halfA + halfB) / 2 up to float rounding and the clamp of a negative ambient sum
/// (applied to each of the three). The image is the one the plain functions return, sample for
/// sample (the halves only split the sums). For independent halves, the noise of their mean is
/// RMSE(A - B) / 2; relativeNoise divides it by the full image's mean over the same values, as
/// compareImages normalises (geometry pixels, RGB). NaN when spp < 2 (no second half).
struct ReferenceImage {
  Image image;                      ///< RGBA, as referenceEnvironment / referenceLights return
  Image halfA, halfB;               ///< RGBA, the even and odd sample halves (alpha as image)
  double relativeNoise = 0;
  /// Light-set mode only (empty otherwise), 1 channel: the fraction of the lights' unshadowed
  /// irradiance (luminance) that reaches the point, estimated from the same light samples as the
  /// image (ratio of their shadowed to unshadowed sums: exactly 1 where no sample is blocked,
  /// exactly 0 where all are). Background and unlit pixels hold 1.
  Image visibility;
};

/// The relative noise of the mean of two independent half estimates over the pixels where full's
/// alpha > 0.5 (all if it has no alpha): RMSE(A - B) / 2 / mean(full), RGB. NaN if no pixel counts;
/// throws Error(BadInput) on mismatched sizes.
double relativeNoiseOfHalves(const Image& halfA, const Image& halfB, const Image& full);

/// Lit by the environment map: multiple importance sampling of the map (luminance x texel solid
/// angle) and of the cosine lobe, balance heuristic. Output RGBA like Renderer (alpha = geometry).
Image referenceEnvironment(const Scene& scene, const Camera& camera, const Environment& env,
                           const ReferenceOptions& opt);
/// The same image (identical pixels), with its halves and noise.
ReferenceImage referenceEnvironmentWithNoise(const Scene& scene, const Camera& camera,
                                             const Environment& env, const ReferenceOptions& opt);

/// Lit by the light set: a light picked in proportion to its unshadowed irradiance at the point,
/// then a uniform direction in its cap. The set's ambient residual (LightSet::ambientSH, when
/// hasAmbient) is added unshadowed, exactly as the renderer adds it, so both see the same light
/// set and differ only by visibility.
///
/// With opt.shadowAmbient the residual is shadowed instead: from the unshadowed ambient irradiance
/// E_amb(n) (exactly what the renderer adds) the estimator subtracts the part of the residual's SH9
/// radiance L_res(w) = sum_k ambientSH[k] Y_k(w) that traced rays find blocked,
///   E = E_amb(n) - integral of L_res(w) (1 - V(w)) max(0, n.w) dw,
/// with opt.spp cosine-distributed directions (pdf cos / pi, so each blocked sample adds
/// pi L_res(w)), drawn after the light samples so the light samples stay those of the unshadowed
/// run. Unoccluded points get E_amb(n) exactly; with the SH9 ambient model (no irradiance map) E is
/// the SH9 radiance's shadowed irradiance. `env` only supplies the background (it may be empty when
/// opt.environmentBackground is false).
///
/// Both throw Error(BadInput) naming the parameter for width/height outside 1..16384, spp < 1,
/// threads < 0, a scene without triangles (or with bad indices / non-finite vertices), an empty map.
/// Pixels: one primary ray through each pixel centre (cameraRayDirection), so geometry coverage
/// matches the device rasterizer; no anti-aliasing.
Image referenceLights(const Scene& scene, const Camera& camera, const LightSet& lights,
                      const Environment& env, const ReferenceOptions& opt);
/// The same image (identical pixels), with its halves, noise and the lights' visibility.
ReferenceImage referenceLightsWithNoise(const Scene& scene, const Camera& camera,
                                        const LightSet& lights, const Environment& env,
                                        const ReferenceOptions& opt);

/// The EXR header attribute in which `penumbra reference` stores ReferenceImage::relativeNoise
/// (writeImage's attributes; readImageAttributes reads it back).
inline constexpr const char* kRelativeNoiseAttribute = "penumbra:relative_noise";

struct ImageMetrics {
  double rmse = 0, relativeRmse = 0, psnr = 0, maxAbsError = 0;
  std::size_t pixels = 0;  ///< pixels compared (reference alpha > 0.5)
};

/// A vs reference B over the pixels where B's alpha is > 0.5 (or all pixels if B has no alpha):
/// RMSE over pixels and RGB channels, relative RMSE = RMSE / mean(B), PSNR = 20 log10(max(B)/RMSE),
/// max abs error. Throws Error(BadInput) on mismatched sizes.
/// Also throws Error(BadInput) when no pixel is compared ("no geometry pixels to compare"), when an
/// image has fewer than 3 channels, or when a compared RGB value of A or B is NaN/Inf ("image A
/// contains non-finite values"). Identical images give psnr = +inf; mean(B) = 0 gives relative
/// RMSE 0 (if RMSE = 0) or +inf.
ImageMetrics compareImages(const Image& a, const Image& b);
/// {"rmse": ..., "relative_rmse": ..., "psnr": ..., "max_abs_error": ..., "pixels": N}; numbers in
/// shortest round-trip form, non-finite values (e.g. the infinite PSNR of identical images) as null.
std::string toJson(const ImageMetrics& m);

}  // namespace penumbra
