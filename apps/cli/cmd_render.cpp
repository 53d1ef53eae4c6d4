// `penumbra render`: one frame or an animation (--frames), with a JSON report built from the
// library's report (nlohmann) and per-frame progress lines on stderr.
#include "options.hpp"

#include <nlohmann/json.hpp>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <vector>

namespace penumbra::cli {

namespace fs = std::filesystem;

namespace {

// A float as JSON shows it: the shortest decimal that reads back as the same float (0.1f is 0.1,
// not 0.10000000149011612), as a double.
double shortestDouble(float v) {
  char buf[32];
  const auto end = std::to_chars(buf, buf + sizeof buf, v).ptr;
  double d = v;
  std::from_chars(buf, end, d);
  return d;
}

}  // namespace

CLI::App* addRenderCommand(CLI::App& root, Registry& reg) {
  CLI::App* app = root.add_subcommand("render", "render a frame or an animation");
  app->description(
      "Renders a scene lit by an environment map: area lights extracted from the map "
      "(--extract) or given (--light-set) plus the ambient residual, soft shadows (--shadows, "
      "filtered or exact), diffuse shading.\n\nAnimation (--frames N): frame i (from 0) is "
      "rendered at time i * frame-time (the built-in scene's sphere bounces and its slab turns; "
      "a loaded mesh stands still), with the map turned by env-rotate + i * rotate-step "
      "degrees, and with map i mod K when --env lists K maps separated by commas "
      "(a.exr,b.exr,...). rotate-step defaults to 1 degree per frame with one map and to 0 with "
      "a list. Lights are extracted from each map once, on the first frame that shows it, and "
      "turned with the map after that (rotateLightSet), so that they move with it instead of "
      "jumping between median cut's cells (--extract-each-frame: extracted again from every "
      "turned map); lights a --light-set gives stay where they are. Shadows and shading are "
      "redone every frame; the camera is framed once, on the scene at time 0. Frame i is "
      "written to OUT's name with _iiii (4 digits, more past 9999 frames) before the extension: "
      "--out anim/f.png gives anim/f_0000.png, anim/f_0001.png, ...; --report then writes a "
      "JSON array with one object per frame (frame, time_s, environment, env_rotation_deg, "
      "lights_from: extracted, turned, reused (the map has not turned since it was extracted) "
      "or light-set, out, lights, stage timings). Each frame prints a line on stderr with its "
      "time and the estimated time left (--quiet: none).");
  const RenderOptions R;
  addSceneOptions(*app, reg, R.width, R.height, {"RenderOptions.width", "RenderOptions.height"},
                  true);
  addExtractOptions(*app, reg);
  addLightSetOption(*app, reg);
  reg.integer(*app, "-n,--frames", "render an animation of N frames (see above)", 1, 100000, "",
              kGroupAnimation);
  reg.real(*app, "--frame-time", "seconds between frames", Bounds::nonNegative(),
           num(1.0 / 24.0), kGroupAnimation);
  reg.real(*app, "--rotate-step", "map rotation added per frame, DEG", Bounds::any(),
           "1 with one map, 0 with a list", kGroupAnimation);
  reg.flag(*app, "--extract-each-frame", "extract the lights from every frame's turned map "
           "(default: once per map, then turned with it)", kGroupAnimation);
  addRenderOptions(*app, reg);
  reg.text(*app, "-o,--out", "FILE", "output image: .exr, .hdr, .pfm (linear), .png, .jpg, .tif, "
           "... (tone-mapped)", "penumbra.png", kGroupOutput);
  reg.text(*app, "--report", "FILE.json", "write a JSON report (version, command, inputs, "
           "device, lights, timings, options)", "", kGroupOutput);
  reg.real(*app, "--exposure", "exposure multiplier of tone-mapped outputs", Bounds::positive(),
           "automatic, log-average to 0.25", kGroupOutput);
  addQuietOption(*app, reg);
  return app;
}

int runRender(const Args& a) {
  const std::string out = a.get("out", "penumbra.png");
  // The image format is checked after the scene is loaded (below): asking whether a format other
  // than PNG can be written loads the OpenImageIO module, whose libraries start threads, and a
  // mesh is read in a forked child, which must not start while other threads may hold the
  // allocator (sanitizer runtimes do not guard fork: the child then waits forever).
  checkOutput(out, {}, "out", false);
  if (a.has("report")) checkOutput(a.get("report"), {".json"}, "report");
  const RenderOptions ro = parseRenderOptions(a);
  const float exposure = parseExposure(a);
  ExtractOptions eo = parseExtractOptions(a);
  LightSet userLights;
  const bool useLightSet = userLightSet(a, userLights);

  // Animation parameters, all checked before any work.
  const bool animate = a.has("frames");
  const int frames = animate ? int(a.integer("frames")) : 1;
  const std::vector<std::string> maps = splitList("env", a.get("env", "builtin"));
  const float rotate0 = a.has("env-rotate") ? float(a.real("env-rotate")) : 0.0f;
  const float frameTime = a.has("frame-time") ? float(a.real("frame-time")) : 1.0f / 24.0f;
  float rotateStep = animate && maps.size() == 1 ? 1.0f : 0.0f;
  if (a.has("rotate-step")) rotateStep = float(a.real("rotate-step"));
  if (!animate)
    for (const char* o : {"frame-time", "rotate-step", "extract-each-frame"})
      if (a.has(o)) badInput(std::string("--") + o + " needs --frames");
  if (useLightSet && a.has("extract-each-frame"))
    badInput("--extract-each-frame extracts lights from the map; it cannot be combined with "
             "--light-set");
  const bool extractEachFrame = a.has("extract-each-frame");

  SceneSetup s = loadSetup(a, ro.width, ro.height, false);
  checkOutput(out, {}, "out");
  const bool movingScene = a.get("scene", "builtin") == "builtin";
  std::vector<Environment> envs;
  for (auto& m : maps) envs.push_back(loadEnvironmentNoting(m));

  Context ctx(a.get("device"));
  FrameRenderer frameRenderer(ctx, a, ro);
  const ReportInfo info = reportInfo(a);
  const ImageText text = a.imageText(toString(ro.shadows));
  nlohmann::ordered_json reports = nlohmann::ordered_json::array();
  double totalMs = 0;
  std::size_t lastLights = 0;
  std::vector<std::optional<LightSet>> extracted(envs.size());
  std::vector<double> extractedAtDeg(envs.size(), 0.0);
  // Each map's own options: --lights auto chooses a count on a map's first extraction and keeps
  // it for that map's later ones (extractNoting), so every map of a list gets its own count.
  std::vector<ExtractOptions> mapOptions(envs.size(), eo);
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < frames; ++i) {
    const float t = float(i) * frameTime;
    Environment& env = envs[std::size_t(i) % envs.size()];
    // Reduced to [0, 360) in double so that long animations keep their step exactly.
    env.rotationYDeg = float(std::fmod(double(rotate0) + double(i) * rotateStep, 360.0));
    if (animate && movingScene) s.scene = builtinScene(t);
    ctx.resetTimings();
    const auto t0 = std::chrono::steady_clock::now();
    // Each map's lights: extracted on the first frame that shows it (at that frame's rotation,
    // so a single frame is what it always was), then turned with the map.
    const std::size_t mapIndex = std::size_t(i) % envs.size();
    const bool extract = !useLightSet && (extractEachFrame || !extracted[mapIndex]);
    if (extract) {
      extracted[mapIndex] = extractNoting(ctx, env, mapOptions[mapIndex], a);
      extractedAtDeg[mapIndex] = env.rotationYDeg;
    }
    // (rotateLightSet gives a whole number of turns back as it is: reported "reused")
    const double turned = double(env.rotationYDeg) - extractedAtDeg[mapIndex];
    const bool reused = !useLightSet && !extract && std::fmod(turned, 360.0) == 0.0;
    const LightSet lights = useLightSet ? userLights
                            : extract   ? *extracted[mapIndex]
                                        : rotateLightSet(*extracted[mapIndex], float(turned));
    const Frame f = frameRenderer.render(s.scene, s.camera, lights, env, ro);
    const double frameMs = secondsSince(t0) * 1e3;
    const std::string path = animate ? framePath(out, i, frames) : out;
    writeImage(path, f.image, exposure > 0 ? exposure : autoExposure(f.image), {}, text);
    auto report = nlohmann::ordered_json::parse(
        renderReportJson(ctx.info().name, lights, env, ro, f, info));
    if (i == 0) {
      // Start-up, apart from the frame: the loader before main(), then main() to the first
      // frame (options, device, scene and map); the first frame's program builds are in its
      // stage timings.
      const double loader = loaderMs();
      report["startup_ms"] = {
          {"loader", loader >= 0 ? nlohmann::ordered_json(loader) : nlohmann::ordered_json()},
          {"setup", std::chrono::duration<double, std::milli>(t0 - mainStart()).count()}};
      // The first frame's programs: made from the program cache's binaries, or compiled.
      const Context::ProgramCacheStats programs = ctx.programCacheStats();
      report["programs"] = {{"from_cache", programs.fromCache},
                            {"compiled", programs.compiled},
                            {"cache", programs.directory}};
    }
    if (animate) {
      // The frame's own fields first, then the single-frame report's.
      nlohmann::ordered_json frame = {{"frame", i},
                                      {"time_s", shortestDouble(t)},
                                      {"env_rotation_deg", shortestDouble(env.rotationYDeg)},
                                      {"lights_from", useLightSet ? "light-set"
                                                      : extract   ? "extracted"
                                                      : reused    ? "reused"
                                                                  : "turned"},
                                      {"frame_ms", frameMs},
                                      {"out", fs::path(path).filename().string()}};
      for (const auto& [key, value] : report.items()) frame[key] = value;
      reports.push_back(std::move(frame));
      if (!a.quiet()) {
        const double elapsed = secondsSince(start);
        std::fprintf(stderr, "render: frame %d/%d %s: %.0f ms, elapsed %s, ETA %s\n", i + 1,
                     frames, fs::path(path).filename().string().c_str(), frameMs,
                     durationText(elapsed).c_str(),
                     durationText(elapsed / (i + 1) * (frames - i - 1)).c_str());
      }
    } else {
      reports = report;
    }
    totalMs += frameMs;
    lastLights = lights.lights.size();
  }
  if (a.has("report"))
    writeTextAtomic(a.get("report"),
                    reports.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  std::cout << "penumbra: wrote "
            << (animate ? fs::absolute(framePath(out, 0, frames)).string() + " .. (" +
                              std::to_string(frames) + " frames, "
                        : fs::absolute(out).string() + " (")
            << ro.width << "x" << ro.height << ", " << lastLights << " lights, "
            << toString(ro.shadows) << ", " << totalMs << " ms on " << ctx.info().name << ")\n";
  return 0;
}

}  // namespace penumbra::cli
