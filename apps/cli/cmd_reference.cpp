// `penumbra reference`: the Embree ground truth of a scene, lit by the map or by a light set,
// with its relative noise and the command that made it in the image's header.
#include "options.hpp"

#include <filesystem>
#include <iostream>

namespace penumbra::cli {

namespace fs = std::filesystem;

CLI::App* addReferenceCommand(CLI::App& root, Registry& reg) {
  CLI::App* app = root.add_subcommand("reference", "ray-traced ground truth with Embree");
  app->description("Ray-traced ground truth (Embree): Monte Carlo direct lighting from the "
                   "environment map, or from the extracted light set with --lights N (or any "
                   "other extraction option, or --light-set). Progress on stderr: a bar with the "
                   "time left on a terminal, a line per 10% otherwise (--quiet: none).");
  const ReferenceOptions R;
  addSceneOptions(*app, reg, R.width, R.height,
                  {"ReferenceOptions.width", "ReferenceOptions.height"});
  addExtractOptions(*app, reg);
  addLightSetOption(*app, reg);
  addSamplingOptions(*app, reg, R, 1);
  reg.text(*app, "-o,--out", "FILE", "output image: .exr (linear, with the relative noise in its "
           "header), .png, ... (tone-mapped)", "reference.exr", kGroupOutput);
  reg.real(*app, "--exposure", "exposure multiplier of tone-mapped outputs", Bounds::positive(),
           "automatic", kGroupOutput);
  addQuietOption(*app, reg);
  return app;
}

int runReference(const Args& a) {
  const std::string out = a.get("out", "reference.exr");
  checkOutput(out, {}, "out", false);  // the format after the scene, as render does
  ReferenceOptions ro;
  if (a.has("size")) parseSize("size", a.get("size"), 16384, ro.width, ro.height);
  parseSampling(a, ro);
  const float exposure = parseExposure(a);
  // Any extraction option asks for the light-set reference (as the help says).
  bool lightMode = false;
  for (const char* o : kExtractionOptionNames) lightMode = lightMode || a.has(o);
  ExtractOptions eo = parseExtractOptions(a);
  LightSet userLights;
  const bool useLightSet = userLightSet(a, userLights);
  lightMode = lightMode || useLightSet;
  SceneSetup s = loadSetup(a, ro.width, ro.height);
  checkOutput(out, {}, "out");
  ReferenceImage ref;
  {
    Progress progress("reference", a.quiet());
    ro.progress = progress.callback();
    if (lightMode) {
      Context ctx(a.get("device"));
      const LightSet lights = useLightSet ? userLights : extractNoting(ctx, s.env, eo, a);
      ref = referenceLightsWithNoise(s.scene, s.camera, lights, s.env, ro);
    } else {
      ref = referenceEnvironmentWithNoise(s.scene, s.camera, s.env, ro);
    }
    ro.progress = nullptr;  // it refers to `progress`
  }
  const Image& img = ref.image;
  writeImage(out, img, exposure > 0 ? exposure : autoExposure(img),
             {{kRelativeNoiseAttribute, ref.relativeNoise}},
             a.imageText(lightMode ? "reference (light set)" : "reference (environment)"));
  std::cout << "penumbra: wrote " << fs::absolute(out).string() << " (" << ro.width << "x"
            << ro.height << ", " << ro.spp << " spp, "
            << (lightMode ? "light-set" : "environment") << " reference, relative noise "
            << percentText(ref.relativeNoise) << ")\n";
  return 0;
}

}  // namespace penumbra::cli
