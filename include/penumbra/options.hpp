/// \file
/// What a frame is rendered with: the shadow technique, its options, the image and map sizes.
/// Every field states its unit, range and default. Renderer::render() checks the frame's fields
/// and the shared shadow settings (ShadowOptions) before any device work; the technique in use
/// checks its own struct when it runs (`src/shadows/<technique>.cpp`). Errors name the field
/// ("RenderOptions.cssm.order must be in [1, 32], got 40"); the CLI and the Python module turn it
/// into their option or attribute name.
#pragma once
#include <cstddef>
#include <string>

namespace penumbra {

enum class ShadowTechnique {
  None,   // no shadows (every light fully visible)
  Hard,   // one shadow map at the light's centre, one depth test
  PCSS,   // percentage-closer soft shadows by explicit sampling (Fernando 2005)
  CSSM,   // convolution soft shadow maps, Fourier basis (Annen et al. 2008)
  MSSM4,  // moment soft shadow mapping, 4 moments (Kneiphof 2017 §3.2.1)
  MSSM6,  // 6 moments (Kneiphof 2017 §4.2.1)
  Brute,  // K point-sample shadow maps per area light, averaged (Annen et al. 2008 Fig. 11d)
  Bitmask,      // sample-based visibility: view-sample lists + light-sample bitmasks (Sintorn et al. 2008 §4)
  BitmaskHard,  // alias-free hard shadows from the light's centre (Sintorn et al. 2008 §3)
  AreaApprox,   // polygon lights sampled along their edges, visible-area estimate (Ying et al. 2002)
  Auto,         // per light: hard, PCSS, MSSM4 or exact (bitmask) visibility (AutoOptions)
};
/// "none" | "hard" | "pcss" | "cssm" | "mssm4" | "mssm6" | "brute" | "bitmask" | "bitmask-hard" |
/// "area-approx" | "auto"
ShadowTechnique parseShadowTechnique(const std::string& name);
const char* toString(ShadowTechnique t);

/// How the filtered techniques (CSSM, MSSM4, MSSM6) prefilter their maps (Annen et al. 2008 Fig. 8).
enum class Prefilter { SAT, Mip };
Prefilter parsePrefilter(const std::string& name);  // "sat" | "mip"
const char* toString(Prefilter p);

/// Settings every shadow-map technique shares: the receiver's depth bias and the light-size
/// filter limits. Distances are in shadow-map texels or normalized light-space depth (0 at the
/// map's near plane, 1 at its far plane). Validated once per frame, whatever the technique.
struct ShadowOptions {
  float depthBias = 0.002f;     ///< normalized depth subtracted from the receiver's depth: hard,
                                ///< pcss, mssm4, mssm6, brute, area-approx. Not CSSM (cssm.depthBias)
                                ///< nor the bitmask techniques (no bias). Default 0.002
  float lightSizeScale = 1.0f;  ///< multiplies every light's angular size for the filter widths:
                                ///< pcss, cssm, mssm4, mssm6. Finite, >= 0; default 1
  float maxFilterTexels = 27.0f;///< largest filter width, texels: pcss, cssm, mssm4, mssm6. >=
                                ///< minFilterTexels; default 27 (Kneiphof 2017 §6.2 used 27 at 256^2)
  float minFilterTexels = 1.0f; ///< smallest filter width, texels. > 0; default 1
  /// Contact shadows (kernels/render/contact.cl): for every technique that reads depth maps with a
  /// bias (all but bitmask and bitmask-hard, and not auto's exact lights), a pixel's visibility
  /// of a light becomes 0 when the ray from its surface towards the light's
  /// centre hits, within contactTexels of the light's map texels, one of the triangles the camera
  /// sees within 2 pixels of it. They catch the occluders a map cannot resolve (closer to the
  /// receiver than a texel plus the depth bias: a hoof on the ground, the strands of a tuft).
  /// Needs the renderer's triangles: the GL interop, which receives textures only, has none.
  /// Measured against the two-seed Embree truth, 320x180, built-in / courtyard + Wuson /
  /// interior + spider / studio + Wuson, MSSM4 relative RMSE with 256² maps (the default then):
  /// off 3.41/4.99/3.66/8.32%, on 3.16/4.29/3.63/6.17% (bench/results/accuracy.md). Default on
  bool contactShadows = true;
  /// Contact shadows from the lights' side (kernels/render/contact.cl, contact_map): the same
  /// rays also test the triangle each light's map sees at the pixel, where that surface is nearer
  /// the light than the pixel's tangent plane and within contactTexels texels of it (occluders
  /// the camera does not see: a sheet lying on another, a caster off screen), and, where the
  /// light's centre is below the pixel's facet while its shading normal sees it (the shadow
  /// terminator of smooth-shaded meshes), the pixel's own triangle. The maps are then drawn with
  /// triangle ids, 4 more bytes per texel per light. Needs contactShadows; off with
  /// frontBackFaces (whose texels hold no one surface). Measured against the 8192-spp Embree
  /// truths, 320x180, built-in / courtyard + Wuson / interior + spider / studio + Wuson, default
  /// frame relative RMSE: off 1.37/2.58/1.53/2.84%, on 1.37/2.53/1.52/2.46%
  /// (bench/results/accuracy.md, "Contact shadows from the lights' side"). Default on.
  bool contactFromMaps = true;
  float contactTexels = 8.0f;   ///< contact rays' length in texels of each light's map. Finite,
                                ///< > 0; default 8 (at 256² maps, 2 texels: 3.17/4.36/3.63/6.16%;
                                ///< 16: 3.16/4.26/3.63/6.17%)
  /// Lights on the horizon (kernels/render/horizon.cl): for every technique whose visibility comes
  /// from depth maps (as contactShadows), a light whose cap straddles a pixel's horizon with its
  /// axis below it takes the mean visibility, at that pixel, of the lights whose axis is above the
  /// horizon and within twice its half-angle of the lit part's middle (1 with none). Its own map
  /// looks from below the receiver's surface and sees nothing but that surface. Measured against
  /// the 8192-spp Embree truths, 320x180, built-in / courtyard + Wuson / interior + spider /
  /// studio + Wuson, MSSM4 relative RMSE: off 2.94/3.72/2.98/5.63%, on 2.92/3.67/2.98/5.46%
  /// (bench/results/accuracy.md). Default on
  bool horizonVisibility = true;
  /// The ground's occlusion of low lights (kernels/render/ground.cl): for every technique whose
  /// visibility comes from depth maps, a light whose cap reaches below the horizontal loses, at a
  /// pixel above the scene's ground (the mesh named "ground", flat and horizontal), the
  /// cosine-weighted share of the cap whose rays hit the ground; a map, looking along the axis,
  /// sees the ground edge-on or from below and cannot. The GL interop takes the ground from its
  /// caller (gl::Interop::shade). README, "The ground and low lights". Default on
  bool groundVisibility = true;
};

/// Moment soft shadow mapping with 4 moments (Kneiphof 2017 §3.2.1) and 6 (§4.2.1): what MSSM4 and
/// MSSM6 alone read. Depths are normalized (0 at the map's near plane, 1 at its far plane).
struct MSSMOptions {
  float momentBias = 3e-5f;     ///< blend of the filtered moments towards those of the uniform
                                ///< distribution (kernels/shadows/moments.cl). Larger: more light
                                ///< leaking. MSSM6 uses the same value: its float solve (Chebyshev
                                ///< basis) is within 0.01 of a long-double one at 3e-5, 0.02 at 1e-5.
                                ///< In [0, 1); default 3e-5
  float slopeBias = 0.0f;       ///< extra depth bias: this times the filter radius times the
                                ///< receiver's depth slope. Off by default: it hides real blockers
                                ///< near tilted receivers; measured relative RMSE vs Embree over the
                                ///< built-in scene, Wuson/courtyard and spider/interior: mean 6.2% at
                                ///< 0, 6.4% at 0.5, 8.6% at 1.5 (README, "Measuring"). Default 0
  float blockerEpsilon = 1e-3f; ///< epsilon of Kneiphof 2017 eq. 7 (pulls z_avg towards the receiver).
                                ///< Default 1e-3
  /// Upper-bound blocker depth (Kneiphof 2017 §4.2.2, eq. 19), MSSM4 and MSSM6: the reconstruction's
  /// atom at the receiver's depth counts as a blocker, its weight clamped to [delta1, delta2];
  /// shadows harden rather than soften under complex depth. On by default, in proportion to the
  /// receiver's tilt (upperBoundTilt): a receiver tilted against the light darkens itself under
  /// eq. 7 (its own depths in front of it read as blockers), while on a receiver facing the light
  /// eq. 7 is exact and eq. 19 narrows the penumbra (kernels/shadows/moments.cl). Measured
  /// relative RMSE vs the two-seed Embree truth, 320x180, built-in / courtyard + Wuson / interior +
  /// spider / studio + Wuson: off 4.20/6.77/4.10/10.84%, published eq. 19 (tilt 0)
  /// 3.32/4.65/3.52/8.23%, tilt 2 3.25/4.64/3.44/8.08% (bench/results/accuracy.md).
  bool upperBoundBlocker = true;
  /// Eq. 19's delta2 is scaled by min(1, upperBoundTilt * tan(theta)), theta between the
  /// receiver's geometric normal and the light: a receiver facing the light keeps eq. 7, one tilted
  /// by atan(1/upperBoundTilt) or more gets eq. 19 in full. 0: eq. 19 as published, on every
  /// receiver. Finite, >= 0; default 2 (27 degrees)
  float upperBoundTilt = 2.0f;
  float delta1 = 1e-3f;         ///< lower clamp; >= blockerEpsilon keeps z_avg >= eq. 7's, and the
                                ///< denominator of eq. 19 away from 0. Default 1e-3
  float delta2 = 0.5f;          ///< upper clamp. 0.5, not 0.1: frame errors above fall with it up to
                                ///< ~0.5 and are flat beyond (0.1: 4.5/7.6/5.5% MSSM4, 4.6/8.2/5.6%
                                ///< MSSM6). Default 0.5
  /// MSSM4: the filter box is centred where the cosine-weighted light casts the shadow. A pixel
  /// receives light from the cap's directions weighted by their cosine with its normal (the
  /// shading's clipped-cap irradiance does), so the part of the cap towards the normal counts
  /// more and the part near the pixel's horizon less; the map's box, centred on the cap's axis,
  /// weighs the whole cap alike. The box moves by the blockers' distance times the weighted
  /// cap's centroid offset (kernels/shadows/moments.cl, mssm_centroid_offset), to first order.
  /// Default on (README, "The cosine-weighted light")
  bool cosineCentroid = true;
  /// MSSM4: light-leak reduction. The moments give an upper bound on the filtered visibility
  /// (Kneiphof 2017 §3.2: lit surfaces are never shadowed, shadowed ones can leak); the visibility
  /// v becomes clamp((v - r) / (1 - r), 0, 1), as Lauritzen (2007, GPU Gems 3 ch. 8) does for
  /// variance shadow maps, never below the moments' lower bound, with r = leakReduction scaled by
  /// how far the filter box's depths are from two values (one blocker over one receiver keeps its
  /// exact profile). In [0, 1); 0: off. Default 0.1; measured with cosineCentroid in README, "The
  /// cosine-weighted light" (each alone is mixed)
  float leakReduction = 0.1f;
};

/// Convolution soft shadow maps (Annen et al. 2008 §3). 4M + 1 values per texel (CSM 2M, CSM-Z 2M,
/// z) in
/// M + 1 long4 groups. Depths are normalized (0 at the map's near plane, 1 at its far plane).
/// Measured relative RMSE of the default frame (160x90, 32 lights, 256^2) against the Embree
/// environment reference, defaults otherwise: M = 4 4.8%, M = 8 4.7%, M = 16 4.8% (MSSM4 4.9%).
struct CSSMOptions {
  int order = 4;                ///< Fourier order M: terms k = 1..M, c_k = pi (2k - 1) (appendix).
                                ///< In [1, 32]; default 4
  float sharpenA = 30.0f;       ///< adaptive sharpening p = 1 + A exp(-B (d - z_avg)) (eq. 9); 0:
                                ///< off. Finite, >= 0; default 30
  float sharpenB = 80.0f;       ///< per unit of normalized depth. It should match the depth over
                                ///< which the series leaks, ~1/(2M). Default frame, A = 30: B = 10
                                ///< 12.7% (M=4); B = 80 4.8/4.7/4.8% (M = 4/8/16; M = 16 is best at
                                ///< B = 160, 4.75%); sharpening off 5.0/4.8/4.8%. Finite, >= 0;
                                ///< default 80
  /// Ringing suppression (§3.3): the scale that puts the series' ripple outside [0,1] is derived
  /// from M (src/shadows/cssm.cpp); this is the visibility test's shift along depth, as a fraction
  /// of the series' rise t0 (0.064 at M = 4, 0.016 at M = 16, in units of kappa-scaled depth).
  /// 0 (default): the receiver's own depth maps to 0 at the centre of the rise, so a tilted
  /// receiver's own texels cancel by the series' odd symmetry and contact shadows start within t0;
  /// surfaces behind the receiver then weigh about -1.1 in the filter. 1: the symmetric map of
  /// Annen et al. 2008 Fig. 3c (surfaces behind weigh ~0, but tilted receivers shadow themselves and
  /// the
  /// contact zone is 2 t0). Default frame: 4.8% at 0, 5.4% at 0.5, 6.8% at 1 (M = 4). In [0, 1];
  /// default 0.
  float ringingOffset = 0.0f;
  /// Attenuation alpha of the series' terms, sigma_k = exp(-alpha (k/M)^2) (Annen et al. 2007),
  /// applied alike to CSM and CSM-Z: less ripple, slower rise. 0: the plain series of Annen et al.
  /// 2008
  /// eq. 10. Default frame: 4.8/5.2/6.2% at 0/0.5/1 (M = 4), 4.8/4.7/4.7% (M = 16). In [0, 8];
  /// default 0.
  float damping = 0.0f;
  /// Subtracted from the receiver's depth (normalized depth units), in place of the shared
  /// ShadowOptions::depthBias. CSSM needs none for planar receivers (above); a bias moves the
  /// receiver onto the steepest part of the series, which brightens every penumbra by 2 M scale
  /// kappa bias (0.03 at M = 4, 0.14 at M = 16 for a bias of 0.002). Finite; default 0.
  float depthBias = 0.0f;
  /// Blocker search only: this times the search radius times the receiver's depth slope is added
  /// to the search's depth offset (as MSSMOptions::slopeBias). Finite; default 0: 0.5 and 1
  /// measured worse on the default frame.
  float slopeBias = 0.0f;
  /// Device memory for the prefiltered basis images; lights are processed in batches that fit, at
  /// least one light per batch. Bytes, any; default 256 MiB.
  std::size_t maxBasisBytes = std::size_t(256) << 20;
};

/// Percentage-closer soft shadows (Fernando 2005; Kneiphof 2017 eqs. 4-6 by explicit sampling).
struct PCSSOptions {
  /// The search and filter boxes are the shared ones (ShadowOptions: lightSizeScale,
  /// min/maxFilterTexels, depthBias).
  int blockerTaps = 16;         ///< samples of the blocker search (eq. 4): a g x g grid over the
                                ///< box, g = round(sqrt(n)) (16: 4x4); 0: every texel of the box.
                                ///< In [0, 4096]; default 16
  int filterTaps = 0;           ///< samples of the percentage-closer filter (eq. 6). 0 (default):
                                ///< every texel of the box, weighted by its coverage: the explicit
                                ///< convolution of Kneiphof 2017 §6.2, cost proportional to the box's
                                ///< area in texels. n > 0: a g x g grid, g = round(sqrt(n)), of 2x2
                                ///< bilinear PCF taps: fixed cost, the box merely spreads the taps.
                                ///< In [0, 4096]
  bool receiverPlaneBias = true;///< compare each texel with the receiver's tangent plane at that
                                ///< texel (from the geometric normal) instead of the receiver's
                                ///< depth: tilted surfaces do not shadow themselves inside wide
                                ///< filters, up to a light grazing them (the plane's slope is not
                                ///< clamped for PCSS). Hard and brute force always do so (one
                                ///< texel away; slope clamped at tan 84 deg). Default true
};

/// Brute force: K point lights spread over each area light's cap, one hard shadow map each.
struct BruteOptions {
  int samples = 64;             ///< K per light, in [1, 4096]: directions uniform in solid angle over
                                ///< the cap (spherical Fibonacci), visibility weighted by max(0,
                                ///< n.w_k) (irradiance). Ignores shadow.lightSizeScale (no filter).
                                ///< Default 64
  std::size_t batchBytes = std::size_t(256) << 20;  ///< device bytes of sample depth maps held at
                                // once (default 256 MiB, at least one map): maps are rasterized
                                // and tested in batches of this size
};

/// Sample-based visibility (Sintorn et al. 2008): view samples in light-space lists, each caster
/// triangle
/// tested against the list texels it can shadow, one bit per light sample (src/shadows/bitmask.cpp).
struct BitmaskOptions {
  int lightSamples = 256;       ///< light samples per light: 128, 256, 512 or 1024 (any multiple of
                                ///< 32 in [32, 1024] works; bitmask only, the hard variant uses the
                                ///< light's centre). Default 256
  int listSize = 0;             ///< light-space list grid side in texels, at most 4096; 0 (default)
                                ///< or less: shadowMapSize for bitmask-hard, min(shadowMapSize, 64)
                                ///< for bitmask
  std::size_t maskBytes = std::size_t(256) << 20;  ///< device bytes of bitmasks held at once
                                ///< (default 256 MiB, at least one light): lights go in batches
  int jitter = 0;               ///< temporal jitter (Sintorn et al. 2008 §4.3): frame j > 0 turns the light
                                ///< samples by 2 pi frac(j / golden ratio) about the light's axis;
                                ///< averaging frames 0..N-1 (`render --accumulate N`) converges
                                ///< to the light's integral. >= 0; default 0: unrotated
};

/// Area approximation (Ying et al. 2002, src/shadows/area.cpp): the light's boundary sampled at its
/// vertices and along its edges, one depth map per sample, visibility = estimated visible area /
/// light area. Caps become a regular polygon of the same (gnomonic) area.
struct AreaApproxOptions {
  int edgeSamples = 1;          ///< samples per edge besides its vertices, in [0, 15]; a light has
                                ///< vertices x (edgeSamples + 1) <= 64 samples (depth maps).
                                ///< Default 1
  int capVertices = 8;          ///< vertices of the polygon standing in for a cap light, in [3, 16];
                                ///< default 8
  int taps = 4;                 ///< texel reads that place the shadow boundary on a segment whose
                                ///< ends disagree (Heidrich's linear-light visibility); 0: midpoint.
                                ///< In [0, 64]; default 4
  std::size_t batchBytes = std::size_t(256) << 20;  ///< device bytes of sample depth maps at once
                                // (whole lights per batch, at least one light)
};

/// Per-light technique choice (`auto`, src/shadows/auto.cpp explains the rule). Each light's
/// penumbra width is estimated as 2 tan(alpha) times the median caster-receiver distance of the
/// pixels its map shadows, and compared with a camera pixel's footprint and a shadow-map texel's.
/// Lights are ranked by the irradiance they bring to the surfaces on screen (power times the mean
/// of max(0, n.w) over the camera's pixels: "brightest on screen"). The brightest get exact
/// sampled visibility (the bitmask technique, with RenderOptions::bitmask), up to exactLights of
/// them; of the rest, a penumbra under a pixel or texel gets hard shadows, a filtered one PCSS
/// (RenderOptions::pcss) or, past pcssTexels, MSSM4 (RenderOptions::mssm), up to filteredLights
/// of them (the brightest on screen first; the others hard).
struct AutoOptions {
  int exactLights = 0;          ///< budget: the most lights given exact visibility, by far the most
                                ///< costly technique (320x180, 2-core CPU: one light 0.3 to 7 s,
                                ///< growing with its size). In [0, 4096]; 0: none (default; the
                                ///< GL interop takes only 0)
  float hardPixels = 1.0f;      ///< a penumbra narrower than this many camera pixels or shadow-map
                                ///< texels (the coarser) gets hard shadows. Finite, >= 0; default 1
  float pcssTexels = 0.0f;      ///< PCSS while the filter it would use (the penumbra in texels,
                                ///< clamped to shadow.maxFilterTexels) is at most this wide (cost
                                ///< ~ width^2 texel reads), MSSM4 beyond (constant cost per pixel).
                                ///< Default 0: every filtered light gets MSSM4, which measures better
                                ///< than PCSS since MSSM's eq. 19 by tilt (bench/results/accuracy.md:
                                ///< auto 3.19/4.38/3.06/7.48% with MSSM4, 3.65/4.42/3.20/8.88% with
                                ///< PCSS); PCSS costs about as much at the default clamp (2-core CPU).
                                ///< With every light filtered (filteredLights -1), 12 texels and
                                ///< the elevation cut below measure best (README, "Within 1.15x of
                                ///< the floor"). Finite, >= 0
  float pcssMinElevationDeg = 8.0f;  ///< PCSS only for a light at least this many degrees above
                                ///< the receivers on screen that face it (the median of n.w over
                                ///< them); nearer their planes the light goes to MSSM4. A light
                                ///< whose cap crosses the receivers' plane does worse with PCSS
                                ///< (measured: studio 2.570% with the cut, 2.601% without,
                                ///< bench/results/accuracy.md). In [0, 90]; default 8
  /// A compact bright source gets exact visibility too, past exactLights: a light carrying at least
  /// exactShare of all the lights' power whose cap is at most exactHalfAngleDeg wide. Such a light
  /// (a sun, which MedianCutOptions::peakRatio makes one light) casts the frame's strongest shadow,
  /// sharp enough that a filter blurs it and hard shadows cut its penumbra, and exact visibility of
  /// a small cap is cheap: each caster triangle walks only the few list texels its narrow
  /// influence region covers (bench/results/accuracy.md, "Bright sources apart"). exactShare in
  /// [0, 1], 0: off; exactHalfAngleDeg in [0, 90].
  float exactShare = 0.1f;
  float exactHalfAngleDeg = 5.0f;
  int filteredLights = 24;      ///< budget: the most lights given a filtered technique (PCSS or
                                ///< MSSM4), the brightest on screen first (ranked by power alone
                                ///< until stop 45, the budget went to lights under the ground's
                                ///< horizon; bench/results/accuracy.md, "The filtered budget by
                                ///< irradiance on screen"); the other lights that would be
                                ///< filtered get hard shadows (the dim ones, whose share of the
                                ///< error is small: with 64 lights, the 16 brightest filtered
                                ///< measure within 0.1-0.35% of all 64 filtered (relative RMSE),
                                ///< for 0.7x their time; bench/results/accuracy.md, "Light count
                                ///< against technique"). In [-1, 4096]; -1: no limit; 0: none
                                ///< filtered. Default 24: with the default 64 lights, the
                                ///< cheapest budget of that table within issue 13's median 3.0% and
                                ///< worst 4.5% (README, "The default frame")
};

struct RenderOptions {
  int width = 640, height = 360;  ///< image size, pixels, each in [1, 16384]; default 640 x 360
  /// Square shadow map per light, texels, in [1, 4096]; default 384. Measured (MSSM4, 32 lights,
  /// 320x180, relative RMSE against the two-seed Embree truth, built-in / courtyard + Wuson /
  /// interior + spider / studio + Wuson; bench/results/accuracy.md): 256: 3.16/4.29/3.63/6.17%,
  /// 384: 3.12/4.16/3.23/5.95%, 512: 3.20/4.09/3.03/5.86%; the 640x360 frame costs 1.15x (384)
  /// and 1.26x (512) the 256 frame, the moments 2.25x and 4x the memory. 384 is the first size
  /// within 1.3x of the exact-visibility floor on every scene.
  int shadowMapSize = 384;
  /// Default Auto (with autoChoice's defaults: the 24 brightest lights on screen MSSM4, the rest
  /// hard; README, "The default frame")
  ShadowTechnique shadows = ShadowTechnique::Auto;
  Prefilter prefilter = Prefilter::SAT;              ///< CSSM, MSSM4, MSSM6; default SAT
  /// Depth maps average the front- and back-facing surfaces' depths (Kneiphof 2017 §4.2.3) instead
  /// of
  /// keeping the nearest surface; for closed casters, it removes the need for a depth bias.
  /// Default off.
  bool frontBackFaces = false;
  ShadowOptions shadow;         ///< shared by the shadow-map techniques (bias, light size, filters)
  MSSMOptions mssm;             ///< MSSM4 and MSSM6
  CSSMOptions cssm;
  PCSSOptions pcss;
  BruteOptions brute;
  BitmaskOptions bitmask;
  AreaApproxOptions areaApprox;
  AutoOptions autoChoice;       ///< `auto` (the name `auto` is a C++ keyword)
  bool environmentBackground = true;  ///< show the environment behind the geometry (alpha stays 0);
                                      ///< default on
  /// Bent normals at light silhouettes (Sintorn et al. 2008 §4.3; kernels/render/bent.cl,
  /// kernels/render/shade.cl). Exact shadows (bitmask, bitmask-hard) black out every
  /// light-back-facing triangle while the interpolated normal still sees the light, a hard edge
  /// along the light's silhouette on smooth meshes. On: each light's shading blends from normal
  /// shading (where every face around the triangle's vertices faces the light's centre at cos >=
  /// 1/bentNormalsScale) to black on light-back-facing triangles, continuously, never brighter than
  /// without. A shading change, so every technique takes it; meant for the bitmask ones. Not in the
  /// GL path (refused). Default off.
  bool bentNormals = false;
  /// c of Sintorn et al. 2008 §4.3's blend a = min(1, max(c I_bend, 0)): shading is unchanged where
  /// I_bend
  /// >= 1/c and fades to black over I_bend in (0, 1/c). Larger: a narrower, steeper fade. Default 3
  /// (the paper: "c := 3 works well"); finite and > 0.
  float bentNormalsScale = 3.0f;
};

}  // namespace penumbra
