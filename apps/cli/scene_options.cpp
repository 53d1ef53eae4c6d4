// The Scene and Lights option groups (render, reference, evaluate, lights) and their translation
// into LoadOptions, Camera, ExtractOptions and user light sets. Every default shown comes from
// the library's structs (MedianCutOptions{}, GreedyOptions{}, AmbientOptions{}, ...).
#include "options.hpp"

#include <cctype>
#include <cmath>
#include <iostream>

namespace penumbra::cli {

void addSceneOptions(CLI::App& app, Registry& reg, int width, int height,
                     std::vector<std::string> sizeFields, bool rotatable) {
  reg.text(app, "--scene", "PATH", "mesh file (OBJ, PLY, glTF/GLB, ...) or 'builtin'", "builtin",
           kGroupScene);
  reg.text(app, "-e,--env", "PATH",
           "environment map (EXR, HDR, PFM; equirectangular) or 'builtin'", "builtin", kGroupScene);
  reg.text(app, "-s,--size", "WxH", "image size, each side 1..16384", sizeText(width, height),
           kGroupScene, std::move(sizeFields));
  reg.text(app, "--camera", "EX,EY,EZ,TX,TY,TZ[,FOVY]",
           "eye, target and vertical field of view in degrees", "framed on the scene",
           kGroupScene);
  reg.flag(app, "--no-ground", "do not add a ground plane under a loaded mesh", kGroupScene);
  reg.real(app, "--load-timeout", "seconds the mesh importer may take", Bounds::positive(),
           "20 s + 1 s per MB of file", kGroupScene,
           {"LoadOptions.timeoutSeconds", "LoadOptions::timeoutSeconds"});
  reg.real(app, "--load-memory", "MiB the mesh importer may allocate", {1, 1 << 24, false, false},
           "1 GiB + 64x the file, at most 3/4 of RAM", kGroupScene,
           {"LoadOptions.memoryLimitBytes"});
  reg.text(app, "-d,--device", "INDEX|NAME", "OpenCL device: index or name substring (see "
           "`penumbra devices`); also $PENUMBRA_DEVICE", "0", kGroupScene)
      ->envname("PENUMBRA_DEVICE");
  if (rotatable)
    reg.real(app, "--env-rotate", "turn the map by DEG about +y, counter-clockwise from above",
             Bounds::any(), num(Environment{}.rotationYDeg), kGroupScene,
             {"Environment.rotationYDeg"});
}

void addExtractOptions(CLI::App& app, Registry& reg) {
  const MedianCutOptions mc;
  const GreedyOptions gr;
  const CenterSurroundOptions cs;
  const AmbientOptions am;
  const ExtractOptions ex;
  reg.text(app, "--extract", "METHOD", "median-cut | greedy | center-surround",
           toString(ex.method), kGroupLights, {"ExtractOptions.method"});
  reg.text(app, "-l,--lights", "N|auto", "median-cut: number of lights (1.." +
           num(kMaxLights) + ") or auto: the fewest lights whose predicted error meets the target error; "
           "greedy, center-surround: the most lights kept (defaults " + num(gr.maxLights) + ", " +
           num(cs.maxLights) + ")", num(mc.lights), kGroupLights,
           {"MedianCutOptions.lights", "GreedyOptions.maxLights"});
  reg.real(app, "--target-error", "--lights auto: the predicted error (lightSetProbeError, "
           "relative) the light count must meet", {0, 1, true, true}, num(kAutoTargetError),
           kGroupLights, {"ExtractOptions.targetError"});
  reg.integer(app, "--max-lights", "--lights auto: the most lights it may choose", 1, kMaxLights,
              num(kAutoMaxLights), kGroupLights);
  reg.integer(app, "--face-size", "median-cut, greedy: cube face size (greedy's default " +
              num(gr.faceSize) + ")", 1, 4096, num(mc.faceSize), kGroupLights,
              {"MedianCutOptions.faceSize", "GreedyOptions.faceSize"});
  reg.real(app, "--threshold", "greedy: a side grows while its added energy / the light's "
           "exceeds this", {0, 1, true, true}, num(gr.threshold), kGroupLights,
           {"GreedyOptions.threshold"});
  reg.flag(app, "--rect", "greedy: rectangular lights (default square)", kGroupLights);
  reg.real(app, "--stop", "center-surround: stop when a light carries less than this fraction "
           "of the lights so far", {0, 1, false, true}, num(cs.stopFraction), kGroupLights);
  reg.integer(app, "--sizes", "center-surround: filter sizes from " + num(cs.minDeg) + " to " +
              num(cs.maxDeg) + " degrees", 1, 256, num(cs.sizes), kGroupLights);
  reg.flag(app, "--no-ambient", "no ambient residual (default: the residual the lights miss)",
           kGroupLights);
  reg.text(app, "--ambient", "map|sh9", "the residual as its pre-integrated irradiance map "
           "(map) or as 9 spherical-harmonic coefficients only (sh9)",
           toString(am.model), kGroupLights, {"AmbientOptions.model"});
  reg.text(app, "--ambient-size", "WxH", "--ambient map: the irradiance map's size, each 1..1024",
           sizeText(am.mapWidth, am.mapHeight), kGroupLights);
  reg.real(app, "--peak-ratio", "median-cut: texels brighter than this times the map's mean "
           "luminance become lights of their own, one per connected set (at most lights / 4), "
           "and median cut splits the rest (README \"Bright sources\"); 0: off",
           Bounds::nonNegative(), num(mc.peakRatio), kGroupLights, {"MedianCutOptions.peakRatio"});
  reg.real(app, "--peak-max-angle", "median-cut: a bright set whose cap would be wider than this "
           "half-angle, degrees, stays with median cut", {0, 90, true, true},
           num(mc.peakMaxHalfAngleDeg), kGroupLights, {"MedianCutOptions.peakMaxHalfAngleDeg"});
  reg.text(app, "--light-shape", "cap|polygon", "median-cut: a light from one region is a cap, "
           "or that region's exact cube-face quadrilateral (polygon)",
           toString(mc.shape), kGroupLights);
  reg.integer(app, "--light-texture", "texture every extracted cap with NxN texels of the map's "
              "radiance (bitmask, brute and reference weight their light samples by it)", 1, 64,
              "none", kGroupLights,
              {"ExtractOptions.lightTexture", "ExtractOptions::lightTexture"});
}

void addLightSetOption(CLI::App& app, Registry& reg) {
  reg.text(app, "--light-set", "FILE", "JSON light set (caps, polygons, rects, ellipses, "
           "optionally textured; see README) used instead of extracting lights from the map",
           "", kGroupLights);
}

void addQuietOption(CLI::App& app, Registry& reg) {
  reg.flag(app, "-q,--quiet", "no progress lines on stderr", kGroupOutput);
}

Environment loadEnvironmentNoting(const std::string& pathOrBuiltin) {
  Environment env = environmentFrom(pathOrBuiltin);
  if (env.sanitizedPixels > 0)
    std::cerr << "penumbra: " << env.source << ": replaced " << env.sanitizedPixels
              << " pixel(s) holding NaN/Inf (" << env.nonFiniteValues
              << " values) or negative radiance (" << env.negativeValues << " values)\n";
  return env;
}

SceneSetup loadSetup(const Args& a, int width, int height, bool loadEnv) {
  SceneSetup s;
  Camera cam;
  const bool haveCamera = a.has("camera");
  if (haveCamera) {
    // parseCamera names its parameter ("camera '1,2': ..."); the user typed --camera.
    try {
      cam = parseCamera(a.get("camera"));
    } catch (const Error& e) {
      if (e.kind() != ErrorKind::BadInput) throw;
      badInput(std::string("--") + e.what());
    }
  }
  LoadOptions lo;
  lo.addGround = !a.has("no-ground");
  if (a.has("load-timeout")) lo.timeoutSeconds = a.real("load-timeout");
  if (a.has("load-memory"))
    lo.memoryLimitBytes = static_cast<std::size_t>(a.real("load-memory")) << 20;
  s.scene = sceneFrom(a.get("scene", "builtin"), lo);
  if (loadEnv) s.env = loadEnvironmentNoting(a.get("env", "builtin"));
  s.camera = haveCamera ? cam : frameCamera(s.scene, float(width) / float(height));
  return s;
}

ExtractOptions parseExtractOptions(const Args& a) {
  ExtractOptions eo;
  eo.method = parseExtractionMethod(a.get("extract", toString(eo.method)));
  const std::string name = toString(eo.method);
  auto only = [&](const std::string& option, std::initializer_list<ExtractionMethod> methods) {
    if (!a.has(option)) return false;
    for (ExtractionMethod m : methods)
      if (m == eo.method) return true;
    std::string list;
    for (ExtractionMethod m : methods)
      list += std::string(list.empty() ? "" : " or ") + toString(m);
    badInput("--" + option + " applies to --extract " + list + ", not " + name);
  };
  using M = ExtractionMethod;
  const bool autoCount = a.has("lights") && a.get("lights") == "auto";
  if (autoCount) {
    if (eo.method != M::MedianCut)
      badInput("--lights auto applies to --extract median-cut, not " + name);
    eo.targetError = a.has("target-error") ? a.real("target-error") : kAutoTargetError;
    eo.medianCut.lights = a.has("max-lights") ? int(a.integer("max-lights")) : kAutoMaxLights;
  } else {
    for (const char* o : {"target-error", "max-lights"})
      if (a.has(o)) badInput(std::string("--") + o + " applies to --lights auto");
    if (only("lights", {M::MedianCut, M::Greedy, M::CenterSurround})) {
      const std::string text = a.get("lights");
      if (text.empty() || !(std::isdigit(static_cast<unsigned char>(text[0])) || text[0] == '-'))
        badInput("--lights must be a number of lights in [1, " + std::to_string(kMaxLights) +
                 "] or auto, got '" + text + "'");
      const int n = int(parseInteger("lights", text, 1, kMaxLights));
      eo.medianCut.lights = eo.greedy.maxLights = eo.centerSurround.maxLights = n;
    }
  }
  if (only("face-size", {M::MedianCut, M::Greedy}))
    eo.medianCut.faceSize = eo.greedy.faceSize = int(a.integer("face-size"));
  if (only("threshold", {M::Greedy})) eo.greedy.threshold = float(a.real("threshold"));
  if (only("rect", {M::Greedy})) eo.greedy.square = false;
  if (only("stop", {M::CenterSurround})) eo.centerSurround.stopFraction = float(a.real("stop"));
  if (only("sizes", {M::CenterSurround})) eo.centerSurround.sizes = int(a.integer("sizes"));
  if (only("peak-ratio", {M::MedianCut})) eo.medianCut.peakRatio = float(a.real("peak-ratio"));
  if (only("peak-max-angle", {M::MedianCut}))
    eo.medianCut.peakMaxHalfAngleDeg = float(a.real("peak-max-angle"));
  if (only("light-shape", {M::MedianCut})) {
    const std::string shape = a.get("light-shape");
    if (shape == "cap") eo.medianCut.shape = LightShape::Cap;
    else if (shape == "polygon") eo.medianCut.shape = LightShape::Polygon;
    else badInput("--light-shape must be cap or polygon, got '" + shape + "'");
  }
  if (a.has("light-texture")) eo.lightTexture = int(a.integer("light-texture"));
  eo.ambient = !a.has("no-ambient");
  if (a.has("ambient")) eo.ambientOptions.model = parseAmbientModel(a.get("ambient"));
  if (a.has("ambient-size")) {
    if (eo.ambientOptions.model != AmbientModel::IrradianceMap)
      badInput("--ambient-size applies to --ambient map, not sh9");
    parseSize("ambient-size", a.get("ambient-size"), 1024, eo.ambientOptions.mapWidth,
              eo.ambientOptions.mapHeight);
  }
  if (!eo.ambient && (a.has("ambient") || a.has("ambient-size")))
    badInput(std::string("--") + (a.has("ambient") ? "ambient" : "ambient-size") +
             " cannot be combined with --no-ambient");
  return eo;
}

LightSet extractNoting(Context& ctx, const Environment& env, ExtractOptions& eo, const Args& a) {
  if (eo.targetError == 0.0) return extractLights(ctx, env, eo);
  LightCountSearch search;
  LightSet set = extractToTargetError(ctx, env, eo, &search);
  if (!a.quiet()) {
    auto pct = [](double v) { return num(std::round(v * 1000.0) / 10.0) + "%"; };
    std::string tried;
    for (const LightCountTry& t : search.tried)
      tried += (tried.empty() ? "" : ", ") + std::to_string(t.asked) + ": " + pct(t.predicted);
    std::cerr << "penumbra: --lights auto: " << set.lights.size() << " lights for " << env.source
              << ", predicted error " << pct(search.predicted)
              << (search.reached ? " <= " : " > ") << "target " << pct(eo.targetError)
              << (search.reached ? "" : " (the most lights allowed; raise --max-lights)")
              << " (tried " << tried << ")\n";
  }
  eo.medianCut.lights = search.lights;
  eo.targetError = 0.0;
  return set;
}

const char* const kExtractionOptionNames[16] = {
    "extract", "lights", "target-error", "max-lights", "face-size", "threshold", "rect",
    "stop", "sizes", "no-ambient", "ambient", "ambient-size", "light-shape", "light-texture",
    "peak-ratio", "peak-max-angle"};

bool userLightSet(const Args& a, LightSet& out) {
  if (!a.has("light-set")) return false;
  for (const char* o : kExtractionOptionNames)
    if (a.has(o))
      badInput(std::string("--") + o + " extracts lights from the map; it cannot be combined "
               "with --light-set");
  out = loadLightSet(a.get("light-set"));
  return true;
}

ReportInfo reportInfo(const Args& a) {
  ReportInfo info;
  info.command = a.argv();
  const std::string scene = a.get("scene", "builtin"), env = a.get("env", "builtin");
  info.scene = scene == "builtin" ? "" : scene;
  info.environment = env == "builtin" ? "" : env;
  info.lightSet = a.get("light-set");
  return info;
}

}  // namespace penumbra::cli
