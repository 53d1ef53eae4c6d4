// The Shadows and Advanced option groups (render, evaluate), the Embree truths' Sampling group
// (reference, evaluate), and their translation into RenderOptions / ReferenceOptions. Every
// option that sets a RenderOptions field names it, so that the library's errors about the field
// name the option; every default shown is read from RenderOptions{} / ReferenceOptions{}.
#include "options.hpp"

#include <iostream>

namespace penumbra::cli {

namespace {

// The technique names for --shadows.
std::string techniqueChoices() {
  using T = ShadowTechnique;
  std::string list;
  for (T t : {T::Hard, T::PCSS, T::CSSM, T::MSSM4, T::MSSM6, T::Brute, T::Bitmask, T::BitmaskHard,
              T::AreaApprox, T::Auto, T::None})
    list += std::string(list.empty() ? "" : " | ") + toString(t);
  return list;
}

}  // namespace

void addRenderOptions(CLI::App& app, Registry& reg) {
  const RenderOptions R;
  const std::string S = kGroupShadows, A = kGroupAdvanced;
  const Bounds any = Bounds::any();
  reg.text(app, "--shadows", "TECHNIQUE", techniqueChoices(), toString(R.shadows), S,
           {"RenderOptions.shadows"});
  reg.text(app, "--prefilter", "sat|mip", "filtered techniques' prefilter", toString(R.prefilter),
           S, {"RenderOptions.prefilter"});
  reg.integer(app, "--shadow-map-size", "shadow-map resolution per light", 1, 4096,
              num(R.shadowMapSize), S, {"RenderOptions.shadowMapSize"});
  reg.flag(app, "--front-back", "average front- and back-face depths in the shadow maps", S,
           {"RenderOptions.frontBackFaces"});
  reg.flag(app, "--bent-normals", "bend shading at light silhouettes to black on "
           "light-back-facing triangles (for bitmask, bitmask-hard; README \"Bent normals\")", S,
           {"RenderOptions.bentNormals"});
  reg.real(app, "--bent-normals-scale", "bent normals: c of the blend, shading unchanged where "
           "every face around faces the light at cos >= 1/c", any, num(R.bentNormalsScale), S,
           {"RenderOptions.bentNormalsScale"});
  reg.real(app, "--depth-bias", "depth bias of hard, pcss, mssm4, mssm6, brute, area-approx; "
           "normalized depth", any, num(R.shadow.depthBias), S, {"RenderOptions.shadow.depthBias"});
  reg.real(app, "--slope-bias", "MSSM receiver-slope bias factor", any, num(R.mssm.slopeBias), S,
           {"RenderOptions.mssm.slopeBias"});
  reg.real(app, "--moment-bias", "MSSM moment bias", any, num(R.mssm.momentBias), S,
           {"RenderOptions.mssm.momentBias"});
  reg.real(app, "--light-size-scale", "scale of every light's size in the filters", any,
           num(R.shadow.lightSizeScale), S, {"RenderOptions.shadow.lightSizeScale"});
  reg.real(app, "--max-filter", "largest filter width in texels", any,
           num(R.shadow.maxFilterTexels), S, {"RenderOptions.shadow.maxFilterTexels"});
  reg.flag(app, "--no-contact-shadows", "no contact shadows (exact rays towards each light "
           "against the triangles seen around the pixel, for techniques that read shadow maps; "
           "README \"Contact shadows\"); on by default", S, {"RenderOptions.shadow.contactShadows"});
  reg.flag(app, "--no-contact-maps", "contact shadows test only the triangles the camera sees, "
           "not those each light's map sees at the pixel (README \"Contact shadows\"); on by "
           "default", S, {"RenderOptions.shadow.contactFromMaps"});
  reg.real(app, "--contact-texels", "contact shadows: ray length in texels of each light's map",
           any, num(R.shadow.contactTexels), S, {"RenderOptions.shadow.contactTexels"});
  reg.flag(app, "--no-horizon-visibility", "lights whose centre is below a pixel's horizon keep "
           "their own map's visibility there (README \"Lights on the horizon\"); by default they "
           "take that of the lights above the horizon near their lit part", S,
           {"RenderOptions.shadow.horizonVisibility"});
  reg.flag(app, "--no-ground-visibility", "lights that reach below the horizontal keep their "
           "own map's visibility above the ground (README \"The ground and low lights\"); by "
           "default the part of each such light that the ground hides is taken off", S,
           {"RenderOptions.shadow.groundVisibility"});
  const std::string upper = R.mssm.upperBoundBlocker ? " (the default)" : "";
  reg.flag(app, "--upper-bound", "MSSM4/MSSM6: the upper-bound blocker depth (README, "
           "\"How it works\")" + (R.mssm.upperBoundBlocker ? upper : ""), S,
           {"RenderOptions.mssm.upperBoundBlocker"});
  reg.flag(app, "--no-upper-bound", "MSSM4/MSSM6: the average blocker depth everywhere" +
           (R.mssm.upperBoundBlocker ? std::string() : std::string(" (the default)")), S,
           {"RenderOptions.mssm.upperBoundBlocker"});
  reg.real(app, "--upper-bound-tilt", "MSSM4/MSSM6: the upper bound in proportion to the "
           "receiver's tilt, full from atan(1/K) on; 0: everywhere", any,
           num(R.mssm.upperBoundTilt), S, {"RenderOptions.mssm.upperBoundTilt"});
  reg.flag(app, "--no-cosine-centroid", "MSSM4: centre the filter on the light's axis, not on "
           "its cosine-weighted centroid (README, \"The cosine-weighted light\")", S,
           {"RenderOptions.mssm.cosineCentroid"});
  reg.real(app, "--leak-reduction", "MSSM4: visibility v becomes (v - X) / (1 - X), clamped; "
           "0: off (README, \"The cosine-weighted light\")", Bounds{0.0, 1.0, false, true},
           num(R.mssm.leakReduction), S, {"RenderOptions.mssm.leakReduction"});

  reg.integer(app, "--cssm-order", "CSSM Fourier order M", 1, 32, num(R.cssm.order), A,
              {"RenderOptions.cssm.order"});
  reg.real(app, "--sharpen-a", "CSSM sharpening strength A; 0 disables", any,
           num(R.cssm.sharpenA), A, {"RenderOptions.cssm.sharpenA"});
  reg.real(app, "--sharpen-b", "CSSM sharpening falloff B", any, num(R.cssm.sharpenB), A,
           {"RenderOptions.cssm.sharpenB"});
  reg.integer(app, "--pcss-blocker-taps", "PCSS blocker-search samples; 0: every texel", 0, 4096,
              num(R.pcss.blockerTaps), A, {"RenderOptions.pcss.blockerTaps"});
  reg.integer(app, "--pcss-filter-taps", "PCSS filter samples; 0: every texel", 0, 4096,
              num(R.pcss.filterTaps), A, {"RenderOptions.pcss.filterTaps"});
  reg.integer(app, "--brute-samples", "brute force: point samples per light", 1, 4096,
              num(R.brute.samples), A, {"RenderOptions.brute.samples"});
  reg.integer(app, "--light-samples", "bitmask: light samples per light, a multiple of 32 "
              "(128 | 256 | 512 | 1024)", 32, 1024, num(R.bitmask.lightSamples), A,
              {"RenderOptions.bitmask.lightSamples"});
  reg.integer(app, "--accumulate", "bitmask: average N frames with rotated light samples", 1,
              4096, "1", A);
  reg.integer(app, "--auto-exact", "auto: the most lights given exact (bitmask) visibility, the "
              "brightest on screen first; 0: none", 0, 4096, num(R.autoChoice.exactLights), A,
              {"RenderOptions.autoChoice.exactLights"});
  reg.real(app, "--auto-exact-share", "auto: exact (bitmask) visibility also for every light "
           "carrying at least this share of the lights' power on a cap no wider than the exact "
           "angle; 0: none", {0, 1, false, false},
           num(R.autoChoice.exactShare), A, {"RenderOptions.autoChoice.exactShare"});
  reg.real(app, "--auto-exact-angle", "auto: the exact angle, the widest cap half-angle (degrees) "
           "the exact share applies to", {0, 90, false, false},
           num(R.autoChoice.exactHalfAngleDeg), A, {"RenderOptions.autoChoice.exactHalfAngleDeg"});
  reg.integer(app, "--auto-filtered", "auto: the most lights given a filtered technique, the "
              "brightest on screen first, the others hard; -1: no limit", -1, 4096,
              num(R.autoChoice.filteredLights), A, {"RenderOptions.autoChoice.filteredLights"});
  reg.real(app, "--auto-pcss-texels", "auto: PCSS for filtered lights whose filter is at most "
           "this many texels wide, MSSM4 beyond", any, num(R.autoChoice.pcssTexels), A,
           {"RenderOptions.autoChoice.pcssTexels"});
  reg.real(app, "--auto-pcss-elevation", "auto: PCSS only for lights at least this many degrees "
           "above the receivers facing them (their median), MSSM4 nearer",
           {0, 90, false, false}, num(R.autoChoice.pcssMinElevationDeg), A,
           {"RenderOptions.autoChoice.pcssMinElevationDeg"});
  reg.integer(app, "--area-samples", "area-approx: samples per polygon edge besides its "
              "vertices", 0, 15, num(R.areaApprox.edgeSamples), A,
              {"RenderOptions.areaApprox.edgeSamples"});
  reg.integer(app, "--area-cap-vertices", "area-approx: vertices of the polygon standing in for "
              "a cap", 3, 16, num(R.areaApprox.capVertices), A,
              {"RenderOptions.areaApprox.capVertices"});
  reg.integer(app, "--area-taps", "area-approx: texel reads placing a shadow edge on a segment; "
              "0: midpoint", 0, 64, num(R.areaApprox.taps), A, {"RenderOptions.areaApprox.taps"});
  reg.text(app, "--gl", "egl|osmesa|auto", "GL rasterizes the G-buffer and shadow maps and "
           "shades, OpenCL computes visibility", "off", A, {"gl::Backend"});
}

RenderOptions parseRenderOptions(const Args& a) {
  RenderOptions ro;
  if (a.has("size")) parseSize("size", a.get("size"), 16384, ro.width, ro.height);
  if (a.has("shadows")) ro.shadows = parseShadowTechnique(a.get("shadows"));
  if (a.has("shadow-map-size")) ro.shadowMapSize = int(a.integer("shadow-map-size"));
  if (a.has("prefilter")) ro.prefilter = parsePrefilter(a.get("prefilter"));
  if (a.has("upper-bound") && a.has("no-upper-bound"))
    badInput("--upper-bound and --no-upper-bound contradict each other");
  if (a.has("no-upper-bound")) ro.mssm.upperBoundBlocker = false;
  if (a.has("upper-bound")) ro.mssm.upperBoundBlocker = true;
  if (a.has("upper-bound-tilt")) ro.mssm.upperBoundTilt = float(a.real("upper-bound-tilt"));
  if (a.has("no-cosine-centroid")) ro.mssm.cosineCentroid = false;
  if (a.has("leak-reduction")) ro.mssm.leakReduction = float(a.real("leak-reduction"));
  if (a.has("cssm-order")) ro.cssm.order = int(a.integer("cssm-order"));
  if (a.has("sharpen-a")) ro.cssm.sharpenA = float(a.real("sharpen-a"));
  if (a.has("sharpen-b")) ro.cssm.sharpenB = float(a.real("sharpen-b"));
  if (a.has("pcss-blocker-taps")) ro.pcss.blockerTaps = int(a.integer("pcss-blocker-taps"));
  if (a.has("pcss-filter-taps")) ro.pcss.filterTaps = int(a.integer("pcss-filter-taps"));
  if (a.has("brute-samples")) ro.brute.samples = int(a.integer("brute-samples"));
  if (a.has("area-samples")) ro.areaApprox.edgeSamples = int(a.integer("area-samples"));
  if (a.has("area-cap-vertices")) ro.areaApprox.capVertices = int(a.integer("area-cap-vertices"));
  if (a.has("area-taps")) ro.areaApprox.taps = int(a.integer("area-taps"));
  if (a.has("light-samples")) {
    ro.bitmask.lightSamples = int(a.integer("light-samples"));
    if (ro.bitmask.lightSamples % 32)
      badInput("--light-samples must be a multiple of 32, got " + a.get("light-samples"));
  }
  if (a.has("auto-exact")) ro.autoChoice.exactLights = int(a.integer("auto-exact"));
  if (a.has("auto-pcss-texels")) ro.autoChoice.pcssTexels = float(a.real("auto-pcss-texels"));
  if (a.has("auto-pcss-elevation"))
    ro.autoChoice.pcssMinElevationDeg = float(a.real("auto-pcss-elevation"));
  if (a.has("auto-filtered")) ro.autoChoice.filteredLights = int(a.integer("auto-filtered"));
  if (a.has("auto-exact-share")) ro.autoChoice.exactShare = float(a.real("auto-exact-share"));
  if (a.has("auto-exact-angle"))
    ro.autoChoice.exactHalfAngleDeg = float(a.real("auto-exact-angle"));
  ro.frontBackFaces = a.has("front-back");
  ro.bentNormals = a.has("bent-normals");
  if (a.has("bent-normals-scale")) {
    if (!ro.bentNormals) badInput("--bent-normals-scale needs --bent-normals");
    ro.bentNormalsScale = float(a.real("bent-normals-scale"));
  }
  if (a.has("moment-bias")) ro.mssm.momentBias = float(a.real("moment-bias"));
  if (a.has("depth-bias")) ro.shadow.depthBias = float(a.real("depth-bias"));
  if (a.has("slope-bias")) ro.mssm.slopeBias = float(a.real("slope-bias"));
  if (a.has("light-size-scale")) ro.shadow.lightSizeScale = float(a.real("light-size-scale"));
  if (a.has("max-filter")) ro.shadow.maxFilterTexels = float(a.real("max-filter"));
  if (a.has("no-contact-shadows")) {
    if (a.has("contact-texels")) badInput("--contact-texels needs contact shadows (drop --no-contact-shadows)");
    if (a.has("no-contact-maps")) badInput("--no-contact-maps needs contact shadows (drop --no-contact-shadows)");
    ro.shadow.contactShadows = false;
  }
  if (a.has("no-contact-maps")) ro.shadow.contactFromMaps = false;
  if (a.has("contact-texels")) ro.shadow.contactTexels = float(a.real("contact-texels"));
  if (a.has("no-horizon-visibility")) ro.shadow.horizonVisibility = false;
  if (a.has("no-ground-visibility")) ro.shadow.groundVisibility = false;
  // The GL path hands OpenCL textures only, no triangles to cast contact rays against (README,
  // "Contact shadows"): off, so that the report says what the frame had.
  if (a.has("gl")) {
    if (a.has("contact-texels")) badInput("--contact-texels does not work with --gl (no triangles on the OpenCL side)");
    if (a.has("no-contact-maps")) badInput("--no-contact-maps does not work with --gl (no contact shadows there)");
    ro.shadow.contactShadows = false;
  }
  return ro;
}

void addSamplingOptions(CLI::App& app, Registry& reg, const ReferenceOptions& R, int minSpp) {
  reg.integer(app, "--spp", "shadow-ray samples per pixel", minSpp, 1 << 20, num(R.spp),
              kGroupSampling, {"ReferenceOptions.spp"});
  reg.integer(app, "--seed", "random seed", 0, 1LL << 62, std::to_string(R.seed),
              kGroupSampling);
  reg.integer(app, "-j,--threads", "CPU threads; 0: all", 0, 1024,
              R.threads == 0 ? "all" : num(R.threads), kGroupSampling,
              {"ReferenceOptions.threads"});
}

void parseSampling(const Args& a, ReferenceOptions& ro) {
  if (a.has("spp")) ro.spp = int(a.integer("spp"));
  if (a.has("seed")) ro.seed = std::uint64_t(a.integer("seed"));
  if (a.has("threads")) ro.threads = int(a.integer("threads"));
}

float parseExposure(const Args& a) { return a.has("exposure") ? float(a.real("exposure")) : 0.0f; }

FrameRenderer::FrameRenderer(Context& ctx, const Args& a, const RenderOptions& ro)
    : renderer_(ctx) {
  accumulate_ = a.has("accumulate") ? int(a.integer("accumulate")) : 1;
  if (accumulate_ > 1 && ro.shadows != ShadowTechnique::Bitmask)
    badInput("--accumulate needs --shadows bitmask (the only technique with jittered samples)");
#ifdef PENUMBRA_HAS_GL
  if (a.has("gl")) {
    if (accumulate_ > 1) badInput("--accumulate does not work with --gl");
    glContext_ = std::make_unique<gl::HeadlessContext>(gl::parseBackend(a.get("gl")));
    glRenderer_ = std::make_unique<gl::GLRenderer>(ctx, glContext_->loader());
    std::cout << "penumbra: GL " << glContext_->description() << "\n";
  }
#else
  if (a.has("gl")) badInput("--gl: this penumbra was built without GL (-DPENUMBRA_BUILD_GL=OFF)");
#endif
}

Frame FrameRenderer::render(const Scene& scene, const Camera& camera, const LightSet& lights,
                            const Environment& env, const RenderOptions& ro) {
#ifdef PENUMBRA_HAS_GL
  if (glRenderer_) return glRenderer_->render(scene, camera, lights, env, ro);
#endif
  Frame f = renderer_.render(scene, camera, lights, env, ro);
  if (accumulate_ > 1) {
    double totalRender = f.timingsMs.back().second;
    for (int k = 1; k < accumulate_; ++k) {
      RenderOptions rk = ro;
      rk.bitmask.jitter = k;
      Frame g = renderer_.render(scene, camera, lights, env, rk);
      for (std::size_t p = 0; p < f.image.pixels.size(); ++p) f.image.pixels[p] += g.image.pixels[p];
      totalRender += g.timingsMs.back().second;
      f.timingsMs = g.timingsMs;  // stage times add up since resetTimings()
    }
    for (float& v : f.image.pixels) v /= float(accumulate_);
    f.timingsMs.back().second = totalRender;
  }
  return f;
}

}  // namespace penumbra::cli
