// `penumbra evaluate`: the error budget of one rendered frame against Embree truths of the same
// scene (README, "Error budget"), as text, JSON and heat maps.
#include "options.hpp"

#include <penumbra/evaluate.hpp>

#include <filesystem>
#include <iostream>

namespace penumbra::cli {

namespace fs = std::filesystem;

CLI::App* addEvaluateCommand(CLI::App& root, Registry& reg) {
  CLI::App* app = root.add_subcommand("evaluate", "the error budget of a frame against Embree truths");
  app->description(
      "The error budget of a rendered frame against Embree truths of the same scene (README, "
      "\"Error budget\"): total (frame vs environment truth), floor (exact visibility of the same "
      "lights vs environment truth), technique (frame vs that light-set truth), ambient "
      "(light-set truth with the ambient residual unshadowed vs shadowed), each as relative RMSE "
      "(divided by the environment truth's mean) and mean HDR-FLIP, over all geometry pixels and "
      "over penumbra pixels (where 2%..98% of the lights' irradiance arrives), with the noise of "
      "the truths it sits in; the cross term that makes total^2 = floor^2 + technique^2 + 2 "
      "cross; the mean signed error per RGB; the frame's warm render time.");
  const RenderOptions R;
  const EvaluateOptions E;
  addSceneOptions(*app, reg, R.width, R.height, {"RenderOptions.width", "RenderOptions.height"},
                  true);
  addExtractOptions(*app, reg);
  addLightSetOption(*app, reg);
  addRenderOptions(*app, reg);
  // At least 2 samples: one per half, for the noise estimate.
  addSamplingOptions(*app, reg, E.truth, 2);
  reg.text(*app, "--truth", "DIR", "cache directory of truths: read when present for the same "
           "scene, map, size, camera, spp, seed and light set, written otherwise", "none",
           kGroupOutput, {"EvaluateOptions.cacheDir"});
  reg.text(*app, "--out-dir", "DIR", "write the frame (frame.exr) and the heat maps (PNG) here",
           "", kGroupOutput);
  reg.text(*app, "--json", "FILE.json", "write the budget as JSON to this file", "",
           kGroupOutput);
  addQuietOption(*app, reg);
  return app;
}

int runEvaluate(const Args& a) {
  const RenderOptions ro = parseRenderOptions(a);
  EvaluateOptions eo;
  eo.truth.width = ro.width;
  eo.truth.height = ro.height;
  parseSampling(a, eo.truth);
  eo.cacheDir = a.get("truth");
  ExtractOptions ext = parseExtractOptions(a);
  LightSet userLights;
  const bool useLightSet = userLightSet(a, userLights);
  // The directories last among the checks, so that a refused option leaves none behind.
  for (const char* dirOption : {"truth", "out-dir"}) {
    if (!a.has(dirOption)) continue;
    const std::string dir = a.get(dirOption);
    std::error_code ec;
    if (dir.empty()) badInput(std::string("--") + dirOption + " needs a directory");
    fs::create_directories(dir, ec);
    if (!fs::is_directory(dir))
      badInput(std::string("--") + dirOption + " " + dir + ": cannot create the directory" +
               (ec ? " (" + ec.message() + ")" : std::string()));
  }
  if (a.has("json")) checkOutput(a.get("json"), {".json"}, "json");
  SceneSetup s = loadSetup(a, ro.width, ro.height);
  if (a.has("env-rotate")) s.env.rotationYDeg = float(a.real("env-rotate"));

  Context ctx(a.get("device"));
  FrameRenderer frameRenderer(ctx, a, ro);
  const LightSet lights = useLightSet ? userLights : extractNoting(ctx, s.env, ext, a);
  // Warm: the first render builds the kernels and buffers; the second is timed.
  frameRenderer.render(s.scene, s.camera, lights, s.env, ro);
  const auto t0 = std::chrono::steady_clock::now();
  const Frame frame = frameRenderer.render(s.scene, s.camera, lights, s.env, ro);
  const double frameMs = secondsSince(t0) * 1e3;

  EvaluateTruths truths;
  {
    Progress progress("evaluate: truths", a.quiet());
    eo.truth.progress = progress.callback();
    truths = evaluateTruths(s.scene, s.camera, lights, s.env, eo);
    eo.truth.progress = nullptr;  // it refers to `progress`
  }
  ErrorBudget budget = errorBudget(frame.image, truths, eo);
  budget.frameMs = frameMs;
  budget.lights = lights.lights.size();
  budget.shadows = toString(ro.shadows);
  std::cout << toText(budget);
  if (!eo.cacheDir.empty()) {
    const char* names[3] = {"environment", "lights", "lights shadowed ambient"};
    std::cout << "truths in " << fs::absolute(eo.cacheDir).string() << ":";
    for (int i = 0; i < 3; ++i)
      std::cout << (i ? "," : "") << " " << names[i] << (truths.fromCache[i] ? " read" : " computed");
    std::cout << "\n";
  }
  if (a.has("out-dir")) {
    const std::string dir = a.get("out-dir");
    writeImage((fs::path(dir) / "frame.exr").string(), frame.image, 1.0f, {},
               a.imageText(toString(ro.shadows)));
    double scale = 0;
    const std::vector<std::string> maps = writeHeatMaps(budget, frame.image, truths, dir, &scale);
    std::cout << "heat maps (signed error scale +-" << percentText(scale) << " of the truth's mean):";
    for (const std::string& m : maps) std::cout << " " << fs::path(m).filename().string();
    std::cout << " and frame.exr in " << fs::absolute(dir).string() << "\n";
  }
  if (a.has("json")) writeTextAtomic(a.get("json"), toJson(budget));
  return 0;
}

}  // namespace penumbra::cli
