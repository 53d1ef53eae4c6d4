// penumbra command-line interface: devices | render | reference | compare | evaluate | lights.
// A thin layer over the public API; every penumbra::Error becomes one line on stderr and exit 2.
#include <penumbra/penumbra.hpp>
#include <penumbra/evaluate.hpp>
#ifdef PENUMBRA_HAS_GL
#include <penumbra/gl/interop.hpp>
#endif

#include <algorithm>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

struct Args {
  std::map<std::string, std::string> values;  // --name value
  std::map<std::string, bool> flags;          // --name
  std::vector<std::string> positional;
};

struct OptionSpec {
  std::string name;     // without dashes
  bool takesValue;
  std::string help;
  // The library fields the option sets, as its errors name them ("RenderOptions.cssm.order";
  // src/shadows/shadow_options.hpp): an error naming one is reported with this option instead.
  std::vector<std::string> fields = {};
};

// A default as the help prints it: 6 significant digits (3e-05, 0.002, 27).
std::string num(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}
// Shortest round-trip form, as the library's JSON writes numbers.
std::string shortestNumber(double v) {
  char buf[64];
  auto res = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, res.ptr);
}
std::string sizeText(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

Args parse(int argc, char** argv, int first, const std::vector<OptionSpec>& specs,
           const std::string& command) {
  Args a;
  for (int i = first; i < argc; ++i) {
    std::string s = argv[i];
    if (s.rfind("--", 0) == 0) {
      std::string name = s.substr(2), value;
      bool inlineValue = false;
      auto eq = name.find('=');
      if (eq != std::string::npos) {
        value = name.substr(eq + 1);
        name = name.substr(0, eq);
        inlineValue = true;
      }
      const OptionSpec* spec = nullptr;
      for (auto& o : specs)
        if (o.name == name) spec = &o;
      if (!spec) badInput("penumbra " + command + ": unknown option --" + name + " (see --help)");
      if (spec->takesValue) {
        if (!inlineValue) {
          if (i + 1 >= argc) badInput("penumbra " + command + ": --" + name + " needs a value");
          value = argv[++i];
        }
        a.values[name] = value;
      } else {
        a.flags[name] = true;
      }
    } else {
      a.positional.push_back(s);
    }
  }
  return a;
}

void printHelp(const std::string& usage, const std::string& what,
               const std::vector<OptionSpec>& specs) {
  std::cout << "usage: " << usage << "\n\n" << what << "\n\noptions:\n";
  for (auto& o : specs) {
    std::string left = "  --" + o.name + (o.takesValue ? " VALUE" : "");
    std::cout << left << std::string(left.size() < 28 ? 28 - left.size() : 1, ' ') << o.help
              << "\n";
  }
}

long parseInt(const std::string& name, const std::string& text, long lo, long hi) {
  char* end = nullptr;
  errno = 0;
  long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end || errno) badInput("--" + name + ": not an integer: '" + text + "'");
  if (v < lo || v > hi)
    badInput("--" + name + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
             "], got " + text);
  return v;
}

float parseFloat(const std::string& name, const std::string& text) {
  char* end = nullptr;
  float v = std::strtof(text.c_str(), &end);
  if (text.empty() || *end || !std::isfinite(v))
    badInput("--" + name + ": not a finite number: '" + text + "'");
  return v;
}

// 0 means automatic exposure; an explicit value must be positive.
float parseExposure(const Args& a);

void parseSize(const std::string& text, int& w, int& h) {
  auto x = text.find('x');
  if (x == std::string::npos) badInput("--size must look like WIDTHxHEIGHT, got '" + text + "'");
  w = int(parseInt("size", text.substr(0, x), 1, 16384));
  h = int(parseInt("size", text.substr(x + 1), 1, 16384));
}

std::string get(const Args& a, const std::string& name, const std::string& def) {
  auto it = a.values.find(name);
  return it == a.values.end() ? def : it->second;
}
bool has(const Args& a, const std::string& name) {
  return a.values.count(name) || a.flags.count(name);
}

float parseExposure(const Args& a) {
  if (!has(a, "exposure")) return 0.0f;
  float e = parseFloat("exposure", get(a, "exposure", ""));
  if (!(e > 0)) badInput("--exposure must be > 0, got " + get(a, "exposure", ""));
  return e;
}

// Refuses an output path before any work is done: known extension, existing directory.
void checkOutput(const std::string& path, const std::vector<std::string>& exts,
                 const std::string& option) {
  std::string ext = fs::path(path).extension().string();
  for (auto& c : ext) c = char(std::tolower(c));
  bool ok = false;
  for (auto& e : exts) ok |= ext == e;
  if (!ok) {
    std::string list;
    for (auto& e : exts) list += (list.empty() ? "" : ", ") + e;
    badInput("--" + option + " " + path + ": unsupported extension '" + ext + "' (use " + list +
             ")");
  }
  fs::path dir = fs::path(path).parent_path();
  if (!dir.empty() && !fs::is_directory(dir))
    badInput("--" + option + " " + path + ": directory " + dir.string() + " does not exist");
  if (fs::is_directory(path)) badInput("--" + option + " " + path + ": is a directory");
}

// Text files are written like images: to a temporary file, then renamed into place.
void writeTextAtomic(const std::string& path, const std::string& text) {
  fs::path target(path);
  fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  fs::path tmp = dir / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()));
  {
    std::ofstream f(tmp);
    f << text;
    f.close();
    if (!f) {
      std::error_code ec;
      fs::remove(tmp, ec);
      badInput(path + ": cannot write");
    }
  }
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    badInput(path + ": cannot move into place (" + ec.message() + ")");
  }
}

// The options of a command that renders the scene; (width, height): its options' default size.
std::vector<OptionSpec> sceneOptions(int width, int height) {
  return {
      {"scene", true, "mesh file (OBJ, PLY, glTF/GLB, ...) or 'builtin' (default)"},
      {"env", true, "environment map (EXR, HDR, PFM; equirectangular) or 'builtin' (default)"},
      {"size", true, "image size WxH (default " + sizeText(width, height) + ")",
       {"RenderOptions.width", "RenderOptions.height"}},
      {"camera", true, "ex,ey,ez,tx,ty,tz[,fovy]: eye, target, vertical fov (default: framed)"},
      {"no-ground", false, "do not add a ground plane under a loaded mesh"},
      {"load-timeout", true,
       "seconds the mesh importer may take (default: 20 s + 1 s per MB of file)",
       {"LoadOptions.timeoutSeconds"}},
      {"load-memory", true,
       "MiB the mesh importer may allocate (default: 1 GiB + 64x the file, <= 3/4 of RAM)",
       {"LoadOptions.memoryLimitBytes"}},
      {"device", true, "OpenCL device: index or name substring (default $PENUMBRA_DEVICE or 0)"},
      {"help", false, "show this help"},
  };
}

std::vector<OptionSpec> with(std::vector<OptionSpec> base, const std::vector<OptionSpec>& more) {
  base.insert(base.end() - 1, more.begin(), more.end());
  return base;
}

struct SceneSetup {
  Scene scene;
  Environment env;
  Camera camera;
};

// Loads a map and says on stderr what sanitizing replaced.
Environment loadEnvironmentNoting(const std::string& pathOrBuiltin) {
  Environment env = environmentFrom(pathOrBuiltin);
  if (env.sanitizedPixels > 0)
    std::cerr << "penumbra: " << env.source << ": replaced " << env.sanitizedPixels
              << " pixel(s) holding NaN/Inf (" << env.nonFiniteValues
              << " values) or negative radiance (" << env.negativeValues << " values)\n";
  return env;
}

// The camera frames the scene for a width x height image. loadEnv = false leaves s.env empty
// (render loads its own list of maps).
SceneSetup loadSetup(const Args& a, int width, int height, bool loadEnv = true) {
  SceneSetup s;
  Camera cam;
  bool haveCamera = has(a, "camera");
  if (haveCamera) cam = parseCamera(get(a, "camera", ""));
  LoadOptions lo;
  lo.addGround = !has(a, "no-ground");
  if (has(a, "load-timeout")) {
    lo.timeoutSeconds = parseFloat("load-timeout", get(a, "load-timeout", ""));
    if (!(lo.timeoutSeconds > 0)) badInput("--load-timeout must be > 0 seconds");
  }
  if (has(a, "load-memory")) {
    const float m = parseFloat("load-memory", get(a, "load-memory", ""));
    if (!(m >= 1 && m <= 1 << 24)) badInput("--load-memory must be 1..16777216 MiB");
    lo.memoryLimitBytes = static_cast<std::size_t>(m) << 20;
  }
  s.scene = sceneFrom(get(a, "scene", "builtin"), lo);
  if (loadEnv) s.env = loadEnvironmentNoting(get(a, "env", "builtin"));
  s.camera = haveCamera ? cam : frameCamera(s.scene, float(width) / float(height));
  return s;
}

// The extraction options shared by `render`, `reference` and `lights` (every method, its own
// options, the ambient residual). An option that does not belong to the chosen method is refused
// rather than silently ignored.
const std::vector<OptionSpec> kExtractSpecs = {
    {"extract", true, "median-cut (default) | greedy | center-surround"},
    {"lights", true, "median-cut: number of lights (default 32); greedy, center-surround: the most "
                     "lights kept (default 64, 256)",
     {"MedianCutOptions.lights", "GreedyOptions.maxLights"}},
    {"face-size", true, "median-cut, greedy: cube face size (default 256, 64)",
     {"MedianCutOptions.faceSize", "GreedyOptions.faceSize"}},
    {"threshold", true, "greedy: a side grows while its added energy / the light's exceeds this "
                        "(default 0.02)",
     {"GreedyOptions.threshold"}},
    {"rect", false, "greedy: rectangular lights (default square)"},
    {"stop", true, "center-surround: stop when a light carries less than this fraction of the "
                   "lights so far (default 0.02)"},
    {"sizes", true, "center-surround: filter sizes from 4.5 to 45 degrees (default 20)"},
    {"no-ambient", false, "no ambient residual (default: the residual the lights miss)"},
    {"ambient", true, "the residual as map (default: its pre-integrated irradiance map, seed 004) "
                      "| sh9 (9 spherical-harmonic coefficients only)"},
    {"ambient-size", true, "--ambient map: the irradiance map's size WxH, each 1..1024 (default "
                           "128x64)"},
    {"light-shape", true, "median-cut: cap (default) | polygon (a light from one region is that "
                          "region's exact cube-face quadrilateral)"},
    {"light-texture", true, "texture every extracted cap with NxN texels of the map's radiance "
                            "(1..64; bitmask, brute and reference weight their light samples by "
                            "it; default none)"},
};

// `--light-set FILE` (render, reference): lights a user defines (caps, polygons, rectangles;
// loadLightSet in lights.hpp) instead of lights extracted from the map. Extraction options are
// refused beside it rather than silently ignored.
const OptionSpec kLightSetSpec = {"light-set", true,
                                  "JSON light set (caps, polygons, rects, ellipses, optionally textured; see README) used instead "
                                  "of extracting lights from the map"};
bool userLightSet(const Args& a, LightSet& out) {
  if (!has(a, "light-set")) return false;
  for (const OptionSpec& o : kExtractSpecs)
    if (has(a, o.name)) badInput("--" + o.name + " extracts lights from the map; it cannot be "
                                 "combined with --light-set");
  out = loadLightSet(get(a, "light-set", ""));
  return true;
}

ExtractOptions parseExtractOptions(const Args& a) {
  ExtractOptions eo;
  eo.method = parseExtractionMethod(get(a, "extract", "median-cut"));
  const std::string name = toString(eo.method);
  auto only = [&](const std::string& option, std::initializer_list<ExtractionMethod> methods) {
    if (!has(a, option)) return false;
    for (ExtractionMethod m : methods)
      if (m == eo.method) return true;
    std::string list;
    for (ExtractionMethod m : methods)
      list += std::string(list.empty() ? "" : " or ") + toString(m);
    badInput("--" + option + " applies to --extract " + list + ", not " + name);
  };
  using M = ExtractionMethod;
  if (only("lights", {M::MedianCut, M::Greedy, M::CenterSurround})) {
    int n = int(parseInt("lights", get(a, "lights", ""), 1, kMaxLights));
    eo.medianCut.lights = eo.greedy.maxLights = eo.centerSurround.maxLights = n;
  }
  if (only("face-size", {M::MedianCut, M::Greedy})) {
    int m = int(parseInt("face-size", get(a, "face-size", ""), 1, 4096));
    eo.medianCut.faceSize = eo.greedy.faceSize = m;
  }
  if (only("threshold", {M::Greedy})) {
    float t = parseFloat("threshold", get(a, "threshold", ""));
    if (!(t > 0 && t < 1))
      badInput("--threshold must be in (0, 1), got " + get(a, "threshold", ""));
    eo.greedy.threshold = t;
  }
  if (only("rect", {M::Greedy})) eo.greedy.square = false;
  if (only("stop", {M::CenterSurround})) {
    float f = parseFloat("stop", get(a, "stop", ""));
    if (!(f >= 0 && f < 1)) badInput("--stop must be in [0, 1), got " + get(a, "stop", ""));
    eo.centerSurround.stopFraction = f;
  }
  if (only("sizes", {M::CenterSurround}))
    eo.centerSurround.sizes = int(parseInt("sizes", get(a, "sizes", ""), 1, 256));
  if (only("light-shape", {M::MedianCut})) {
    const std::string shape = get(a, "light-shape", "");
    if (shape == "cap") eo.medianCut.shape = LightShape::Cap;
    else if (shape == "polygon") eo.medianCut.shape = LightShape::Polygon;
    else badInput("--light-shape must be cap or polygon, got '" + shape + "'");
  }
  if (has(a, "light-texture"))
    eo.lightTexture = int(parseInt("light-texture", get(a, "light-texture", ""), 1, 64));
  eo.ambient = !has(a, "no-ambient");
  if (has(a, "ambient")) eo.ambientOptions.model = parseAmbientModel(get(a, "ambient", ""));
  if (has(a, "ambient-size")) {
    if (eo.ambientOptions.model != AmbientModel::IrradianceMap)
      badInput("--ambient-size applies to --ambient map, not sh9");
    const std::string text = get(a, "ambient-size", "");
    const auto x = text.find('x');
    if (x == std::string::npos)
      badInput("--ambient-size must look like WIDTHxHEIGHT, got '" + text + "'");
    eo.ambientOptions.mapWidth = int(parseInt("ambient-size", text.substr(0, x), 1, 1024));
    eo.ambientOptions.mapHeight = int(parseInt("ambient-size", text.substr(x + 1), 1, 1024));
  }
  if (!eo.ambient && (has(a, "ambient") || has(a, "ambient-size")))
    badInput(std::string("--") + (has(a, "ambient") ? "ambient" : "ambient-size") +
             " cannot be combined with --no-ambient");
  return eo;
}

int cmdDevices(int argc, char** argv) {
  std::vector<OptionSpec> specs = {{"help", false, "show this help"}};
  Args a = parse(argc, argv, 2, specs, "devices");
  if (has(a, "help")) {
    printHelp("penumbra devices", "Lists the OpenCL devices penumbra can use, with their index.",
              specs);
    return 0;
  }
  for (auto& d : listDevices())
    std::cout << d.index << ": " << d.name << " [" << d.platform << "] " << d.version << ", "
              << (d.globalMemBytes >> 20) << " MiB (" << (d.maxAllocBytes >> 20)
              << " MiB per buffer), max work-group " << d.maxWorkGroupSize
              << (d.fp64 ? ", fp64" : "") << (d.int64Atomics ? ", int64 atomics" : "") << "\n";
  return 0;
}

// Comma-separated list, every entry non-empty.
std::vector<std::string> splitList(const std::string& option, const std::string& text) {
  std::vector<std::string> items;
  std::string cur;
  std::istringstream in(text);
  while (std::getline(in, cur, ',')) items.push_back(cur);
  if (!text.empty() && text.back() == ',') items.push_back("");
  if (items.empty()) items.push_back("");
  for (auto& i : items)
    if (i.empty()) badInput("--" + option + ": empty entry in '" + text + "'");
  return items;
}

// Frame i of an animation written to `out`: STEM_iiii.EXT, at least 4 digits.
std::string framePath(const std::string& out, int i, int frames) {
  fs::path p(out);
  int digits = std::max(4, int(std::to_string(std::max(0, frames - 1)).size()));
  std::string num = std::to_string(i);
  num = std::string(std::size_t(std::max(0, digits - int(num.size()))), '0') + num;
  return (p.parent_path() / (p.stem().string() + "_" + num + p.extension().string())).string();
}

// The technique names for --shadows, the default marked.
std::string techniqueChoices() {
  using T = ShadowTechnique;
  std::string list;
  for (T t : {T::Hard, T::PCSS, T::CSSM, T::MSSM4, T::MSSM6, T::Brute, T::Bitmask, T::BitmaskHard,
              T::AreaApprox, T::Auto, T::None})
    list += std::string(list.empty() ? "" : " | ") + toString(t) +
            (t == RenderOptions{}.shadows ? " (default)" : "");
  return list;
}

// The options of `render`. Every default shown is read from RenderOptions; an option that sets a
// RenderOptions field names it, so that the library's errors about it name the option.
std::vector<OptionSpec> renderSpecs() {
  const RenderOptions R;
  return with(with(sceneOptions(R.width, R.height), kExtractSpecs), {
      kLightSetSpec,
      {"env-rotate", true, "turn the map by DEG about +y, counter-clockwise from above (default 0)"},
      {"frames", true, "render an animation of N frames (1..100000; see below)"},
      {"frame-time", true, "animation: seconds between frames (default 1/24)"},
      {"rotate-step", true, "animation: map rotation added per frame, DEG (default: see below)"},
      {"shadows", true, techniqueChoices(), {"RenderOptions.shadows"}},
      {"prefilter", true,
       std::string("filtered techniques' prefilter: ") +
           (R.prefilter == Prefilter::SAT ? "sat (default) | mip" : "sat | mip (default)"),
       {"RenderOptions.prefilter"}},
      {"front-back", false, "average front- and back-face depths in the shadow maps",
       {"RenderOptions.frontBackFaces"}},
      {"bent-normals", false, "bend shading at light silhouettes to black on light-back-facing triangles (seed 001 §4.3; for bitmask, bitmask-hard)",
       {"RenderOptions.bentNormals"}},
      {"bent-normals-scale", true, "bent normals: c of the blend, shading unchanged where every face around faces the light at cos >= 1/c (default " + num(R.bentNormalsScale) + ")",
       {"RenderOptions.bentNormalsScale"}},
      {"shadow-map-size", true, "shadow-map resolution per light (default " + num(R.shadowMapSize) + ")",
       {"RenderOptions.shadowMapSize"}},
      {"moment-bias", true, "MSSM moment bias (default " + num(R.mssm.momentBias) + ")",
       {"RenderOptions.mssm.momentBias"}},
      {"depth-bias", true, "depth bias of hard, pcss, mssm4, mssm6, brute, area-approx; normalized depth (default " + num(R.shadow.depthBias) + ")",
       {"RenderOptions.shadow.depthBias"}},
      {"slope-bias", true, "MSSM receiver-slope bias factor (default " + num(R.mssm.slopeBias) + ")",
       {"RenderOptions.mssm.slopeBias"}},
      {"light-size-scale", true, "scale of every light's size in the filters (default " + num(R.shadow.lightSizeScale) + ")",
       {"RenderOptions.shadow.lightSizeScale"}},
      {"max-filter", true, "largest filter width in texels (default " + num(R.shadow.maxFilterTexels) + ")",
       {"RenderOptions.shadow.maxFilterTexels"}},
      {"upper-bound", false, "MSSM4/MSSM6: upper-bound blocker depth (seed 003 eq. 19; the default)",
       {"RenderOptions.mssm.upperBoundBlocker"}},
      {"no-upper-bound", false, "MSSM4/MSSM6: the average blocker depth of seed 003 eq. 7 everywhere",
       {"RenderOptions.mssm.upperBoundBlocker"}},
      {"upper-bound-tilt", true, "MSSM4/MSSM6: eq. 19 in proportion to the receiver's tilt, full from atan(1/K) on; 0: everywhere (default " + num(R.mssm.upperBoundTilt) + ")",
       {"RenderOptions.mssm.upperBoundTilt"}},
      {"cssm-order", true, "CSSM Fourier order M (default " + num(R.cssm.order) + ")",
       {"RenderOptions.cssm.order"}},
      {"sharpen-a", true, "CSSM sharpening strength A (default " + num(R.cssm.sharpenA) + "; 0 disables)",
       {"RenderOptions.cssm.sharpenA"}},
      {"sharpen-b", true, "CSSM sharpening falloff B (default " + num(R.cssm.sharpenB) + ")",
       {"RenderOptions.cssm.sharpenB"}},
      {"pcss-blocker-taps", true, "PCSS blocker-search samples (default " + num(R.pcss.blockerTaps) + "; 0: every texel)",
       {"RenderOptions.pcss.blockerTaps"}},
      {"pcss-filter-taps", true, "PCSS filter samples (0: every texel, explicit; default " + num(R.pcss.filterTaps) + ")",
       {"RenderOptions.pcss.filterTaps"}},
      {"brute-samples", true, "brute force: point samples per light (default " + num(R.brute.samples) + ")",
       {"RenderOptions.brute.samples"}},
      {"light-samples", true, "bitmask: light samples per light, 128 | 256 | 512 | 1024 (default " + num(R.bitmask.lightSamples) + ")",
       {"RenderOptions.bitmask.lightSamples"}},
      {"accumulate", true, "bitmask: average N frames with rotated light samples (default 1)"},
      {"auto-exact", true, "auto: the most lights given exact (bitmask) visibility, the brightest and softest first (default " + num(R.autoChoice.exactLights) + "; 0: none)",
       {"RenderOptions.autoChoice.exactLights"}},
      {"auto-pcss-texels", true, "auto: PCSS for filtered lights whose filter is at most this many texels wide, MSSM4 beyond (default " + num(R.autoChoice.pcssTexels) + ")",
       {"RenderOptions.autoChoice.pcssTexels"}},
      {"area-samples", true, "area-approx: samples per polygon edge besides its vertices (default " + num(R.areaApprox.edgeSamples) + ")",
       {"RenderOptions.areaApprox.edgeSamples"}},
      {"area-cap-vertices", true, "area-approx: vertices of the polygon standing in for a cap (default " + num(R.areaApprox.capVertices) + ")",
       {"RenderOptions.areaApprox.capVertices"}},
      {"area-taps", true, "area-approx: texel reads placing a shadow edge on a segment (default " + num(R.areaApprox.taps) + "; 0: midpoint)",
       {"RenderOptions.areaApprox.taps"}},
      {"exposure", true, "PNG exposure multiplier (default: automatic, log-average to 0.25)"},
      {"out", true, "output image .png (tone-mapped) or .exr (linear; default penumbra.png)"},
      {"report", true, "write a JSON report (device, lights, timings, ...)"},
      {"gl", true, "egl | osmesa | auto: GL rasterizes the G-buffer and shadow maps and shades, OpenCL computes visibility"},
  });
}

// The RenderOptions of `render`'s options (renderSpecs), shared by render and evaluate.
RenderOptions parseRenderOptions(const Args& a) {
  RenderOptions ro;
  if (has(a, "size")) parseSize(get(a, "size", ""), ro.width, ro.height);
  if (has(a, "shadows")) ro.shadows = parseShadowTechnique(get(a, "shadows", ""));
  if (has(a, "shadow-map-size"))
    ro.shadowMapSize = int(parseInt("shadow-map-size", get(a, "shadow-map-size", ""), 1, 4096));
  if (has(a, "prefilter")) ro.prefilter = parsePrefilter(get(a, "prefilter", ""));
  if (has(a, "upper-bound") && has(a, "no-upper-bound"))
    badInput("--upper-bound and --no-upper-bound contradict each other");
  if (has(a, "no-upper-bound")) ro.mssm.upperBoundBlocker = false;
  if (has(a, "upper-bound")) ro.mssm.upperBoundBlocker = true;
  if (has(a, "upper-bound-tilt"))
    ro.mssm.upperBoundTilt = parseFloat("upper-bound-tilt", get(a, "upper-bound-tilt", ""));
  if (has(a, "cssm-order")) ro.cssm.order = int(parseInt("cssm-order", get(a, "cssm-order", ""), 1, 32));
  if (has(a, "sharpen-a")) ro.cssm.sharpenA = parseFloat("sharpen-a", get(a, "sharpen-a", ""));
  if (has(a, "sharpen-b")) ro.cssm.sharpenB = parseFloat("sharpen-b", get(a, "sharpen-b", ""));
  if (has(a, "pcss-blocker-taps"))
    ro.pcss.blockerTaps = int(parseInt("pcss-blocker-taps", get(a, "pcss-blocker-taps", ""), 0, 4096));
  if (has(a, "pcss-filter-taps"))
    ro.pcss.filterTaps = int(parseInt("pcss-filter-taps", get(a, "pcss-filter-taps", ""), 0, 4096));
  if (has(a, "brute-samples"))
    ro.brute.samples = int(parseInt("brute-samples", get(a, "brute-samples", ""), 1, 4096));
  if (has(a, "area-samples"))
    ro.areaApprox.edgeSamples = int(parseInt("area-samples", get(a, "area-samples", ""), 0, 15));
  if (has(a, "area-cap-vertices"))
    ro.areaApprox.capVertices = int(parseInt("area-cap-vertices", get(a, "area-cap-vertices", ""), 3, 16));
  if (has(a, "area-taps")) ro.areaApprox.taps = int(parseInt("area-taps", get(a, "area-taps", ""), 0, 64));
  if (has(a, "light-samples")) {
    ro.bitmask.lightSamples = int(parseInt("light-samples", get(a, "light-samples", ""), 32, 1024));
    if (ro.bitmask.lightSamples % 32) badInput("--light-samples must be a multiple of 32, got " + get(a, "light-samples", ""));
  }
  if (has(a, "auto-exact"))
    ro.autoChoice.exactLights = int(parseInt("auto-exact", get(a, "auto-exact", ""), 0, 4096));
  if (has(a, "auto-pcss-texels"))
    ro.autoChoice.pcssTexels = parseFloat("auto-pcss-texels", get(a, "auto-pcss-texels", ""));
  ro.frontBackFaces = has(a, "front-back");
  ro.bentNormals = has(a, "bent-normals");
  if (has(a, "bent-normals-scale")) {
    if (!ro.bentNormals) badInput("--bent-normals-scale needs --bent-normals");
    ro.bentNormalsScale = parseFloat("bent-normals-scale", get(a, "bent-normals-scale", ""));
  }
  if (has(a, "moment-bias")) ro.mssm.momentBias = parseFloat("moment-bias", get(a, "moment-bias", ""));
  if (has(a, "depth-bias")) ro.shadow.depthBias = parseFloat("depth-bias", get(a, "depth-bias", ""));
  if (has(a, "slope-bias")) ro.mssm.slopeBias = parseFloat("slope-bias", get(a, "slope-bias", ""));
  if (has(a, "light-size-scale"))
    ro.shadow.lightSizeScale = parseFloat("light-size-scale", get(a, "light-size-scale", ""));
  if (has(a, "max-filter")) ro.shadow.maxFilterTexels = parseFloat("max-filter", get(a, "max-filter", ""));
  return ro;
}

// Renders frames as `render` does: through the GL interop with --gl, and with --accumulate N the
// average of frames 0..N-1 of the bitmask's temporal jitter (rotated light samples). Shared by render
// and evaluate.
class FrameRenderer {
 public:
  FrameRenderer(Context& ctx, const Args& a, const RenderOptions& ro) : renderer_(ctx) {
    accumulate_ =
        has(a, "accumulate") ? int(parseInt("accumulate", get(a, "accumulate", ""), 1, 4096)) : 1;
    if (accumulate_ > 1 && ro.shadows != ShadowTechnique::Bitmask)
      badInput("--accumulate needs --shadows bitmask (the only technique with jittered samples)");
#ifdef PENUMBRA_HAS_GL
    if (has(a, "gl")) {
      if (accumulate_ > 1) badInput("--accumulate does not work with --gl");
      glContext_ = std::make_unique<gl::HeadlessContext>(gl::parseBackend(get(a, "gl", "")));
      glRenderer_ = std::make_unique<gl::GLRenderer>(ctx, glContext_->loader());
      std::cout << "penumbra: GL " << glContext_->description() << "\n";
    }
#else
    if (has(a, "gl")) badInput("--gl: this penumbra was built without GL (-DPENUMBRA_BUILD_GL=OFF)");
#endif
  }

  Frame render(const Scene& scene, const Camera& camera, const LightSet& lights,
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

 private:
  Renderer renderer_;
  int accumulate_ = 1;
#ifdef PENUMBRA_HAS_GL
  std::unique_ptr<gl::HeadlessContext> glContext_;
  std::unique_ptr<gl::GLRenderer> glRenderer_;
#endif
};

int cmdRender(int argc, char** argv) {
  const std::vector<OptionSpec> specs = renderSpecs();
  Args a = parse(argc, argv, 2, specs, "render");
  if (has(a, "help")) {
    printHelp("penumbra render [options]",
              "Renders a scene lit by an environment map: area lights extracted from the map "
              "(--extract) or given (--light-set) plus the ambient residual, soft shadows (--shadows, "
              "filtered or exact; see below), diffuse shading.\n\n"
              "Animation (--frames N): frame i (from 0) is rendered at time i * frame-time (the "
              "built-in scene's sphere bounces and its slab turns; a loaded mesh stands still), "
              "with the map turned by env-rotate + i * rotate-step degrees, and with map "
              "i mod K when --env lists K maps separated by commas (a.exr,b.exr,...). "
              "rotate-step defaults to 1 degree per frame with one map and to 0 with a list. "
              "Every frame is computed from scratch: lights extracted again on the device, "
              "shadows and shading redone; the camera is framed once, on the scene at time 0. "
              "Frame i is written to OUT's name with _iiii (4 digits, more past 9999 frames) "
              "before the extension: --out anim/f.png gives anim/f_0000.png, anim/f_0001.png, "
              "...; --report then writes a JSON array with one object per frame (frame, time_s, "
              "environment, env_rotation_deg, out, lights, stage timings).",
              specs);
    return 0;
  }
  std::string out = get(a, "out", "penumbra.png");
  checkOutput(out, {".png", ".exr"}, "out");
  if (has(a, "report")) checkOutput(get(a, "report", ""), {".json"}, "report");
  const RenderOptions ro = parseRenderOptions(a);
  float exposure = parseExposure(a);
  ExtractOptions eo = parseExtractOptions(a);
  LightSet userLights;
  const bool useLightSet = userLightSet(a, userLights);

  // Animation parameters, all checked before any work.
  const bool animate = has(a, "frames");
  const int frames = animate ? int(parseInt("frames", get(a, "frames", ""), 1, 100000)) : 1;
  const std::vector<std::string> maps = splitList("env", get(a, "env", "builtin"));
  const float rotate0 = has(a, "env-rotate") ? parseFloat("env-rotate", get(a, "env-rotate", "")) : 0.0f;
  float frameTime = 1.0f / 24.0f;
  if (has(a, "frame-time")) {
    frameTime = parseFloat("frame-time", get(a, "frame-time", ""));
    if (!(frameTime >= 0)) badInput("--frame-time must be >= 0, got " + get(a, "frame-time", ""));
  }
  float rotateStep = animate && maps.size() == 1 ? 1.0f : 0.0f;
  if (has(a, "rotate-step")) rotateStep = parseFloat("rotate-step", get(a, "rotate-step", ""));
  if (!animate)
    for (const char* o : {"frame-time", "rotate-step"})
      if (has(a, o)) badInput(std::string("--") + o + " needs --frames");

  SceneSetup s = loadSetup(a, ro.width, ro.height, false);
  const bool movingScene = get(a, "scene", "builtin") == "builtin";
  std::vector<Environment> envs;
  for (auto& m : maps) envs.push_back(loadEnvironmentNoting(m));

  Context ctx(get(a, "device", ""));
  FrameRenderer frameRenderer(ctx, a, ro);
  std::string reports;
  double totalMs = 0;
  std::size_t lastLights = 0;
  for (int i = 0; i < frames; ++i) {
    const float t = float(i) * frameTime;
    Environment& env = envs[std::size_t(i) % envs.size()];
    // Reduced to [0, 360) in double so that long animations keep their step exactly.
    env.rotationYDeg = float(std::fmod(double(rotate0) + double(i) * rotateStep, 360.0));
    if (animate && movingScene) s.scene = builtinScene(t);
    ctx.resetTimings();
    auto t0 = std::chrono::steady_clock::now();
    LightSet lights = useLightSet ? userLights : extractLights(ctx, env, eo);
    Frame f = frameRenderer.render(s.scene, s.camera, lights, env, ro);
    const double frameMs =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const std::string path = animate ? framePath(out, i, frames) : out;
    writeImage(path, f.image, exposure > 0 ? exposure : autoExposure(f.image));
    std::string json = renderReportJson(ctx.info().name, lights, env, ro, f);
    if (animate) {
      // The frame's own fields first, then the single-frame report's.
      std::ostringstream head;
      head.precision(9);
      head << "{\"frame\": " << i << ", \"time_s\": " << t << ", \"env_rotation_deg\": "
           << env.rotationYDeg << ", \"frame_ms\": " << frameMs << ", \"out\": \""
           << fs::path(path).filename().string() << "\",";
      json = head.str() + json.substr(json.find('{') + 1);
      while (!json.empty() && (json.back() == '\n' || json.back() == ' ')) json.pop_back();
      reports += (i ? ",\n" : "") + json;
    } else {
      reports = json;
    }
    totalMs += frameMs;
    lastLights = lights.lights.size();
  }
  if (has(a, "report"))
    writeTextAtomic(get(a, "report", ""), animate ? "[\n" + reports + "\n]\n" : reports);
  std::cout << "penumbra: wrote "
            << (animate ? fs::absolute(framePath(out, 0, frames)).string() + " .. (" +
                              std::to_string(frames) + " frames, "
                        : fs::absolute(out).string() + " (")
            << ro.width << "x" << ro.height << ", " << lastLights << " lights, "
            << toString(ro.shadows) << ", " << totalMs << " ms on " << ctx.info().name << ")\n";
  return 0;
}

// A relative figure as a percentage, "n/a" when not finite (a noise estimate from 1 spp).
std::string percentText(double v) {
  if (!std::isfinite(v)) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f%%", 100.0 * v);
  return buf;
}

// Progress of a long CPU job on stderr: a terminal gets one line rewritten in place; a log (not a
// terminal) gets a line per 10%, so a long run under a script still shows that it advances. The
// 100% line is written when the object goes out of scope.
class ProgressLine {
 public:
  explicit ProgressLine(std::string label) : label_(std::move(label)), tty_(isatty(2)) {}
  ~ProgressLine() {
    if (tty_) std::fprintf(stderr, "\r%s: 100%%\n", label_.c_str());
    else if (lastTenth_ < 10) std::fprintf(stderr, "%s: 100%%\n", label_.c_str());
  }
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;
  std::function<void(double)> callback() {
    return [this](double f) {
      if (tty_) {
        std::fprintf(stderr, "\r%s: %3d%%", label_.c_str(), int(f * 100));
      } else if (int(f * 10) > lastTenth_) {
        lastTenth_ = int(f * 10);
        std::fprintf(stderr, "%s: %d%%\n", label_.c_str(), lastTenth_ * 10);
      }
    };
  }

 private:
  std::string label_;
  bool tty_;
  int lastTenth_ = 0;
};

// --spp, --seed, --threads of the Embree truths (reference, evaluate); minSpp: the least --spp.
std::vector<OptionSpec> samplingSpecs(const ReferenceOptions& R, int minSpp) {
  return {
      {"spp", true, "shadow-ray samples per pixel, " + std::to_string(minSpp) +
                        " to 1048576 (default " + num(R.spp) + ")",
       {"ReferenceOptions.spp"}},
      {"seed", true, "random seed (default " + std::to_string(R.seed) + ")"},
      {"threads", true, "CPU threads (default: all)", {"ReferenceOptions.threads"}},
  };
}
void parseSampling(const Args& a, ReferenceOptions& ro, int minSpp) {
  if (has(a, "spp")) ro.spp = int(parseInt("spp", get(a, "spp", ""), minSpp, 1 << 20));
  if (has(a, "seed")) ro.seed = std::uint64_t(parseInt("seed", get(a, "seed", ""), 0, 1L << 62));
  if (has(a, "threads")) ro.threads = int(parseInt("threads", get(a, "threads", ""), 0, 1024));
}

std::vector<OptionSpec> referenceSpecs() {
  const ReferenceOptions R;
  std::vector<OptionSpec> scene = sceneOptions(R.width, R.height);
  for (OptionSpec& o : scene)
    if (o.name == "size") o.fields = {"ReferenceOptions.width", "ReferenceOptions.height"};
  std::vector<OptionSpec> more = {kLightSetSpec};
  for (const OptionSpec& o : samplingSpecs(R, 1)) more.push_back(o);
  more.push_back({"exposure", true, "PNG exposure multiplier (default: automatic)"});
  more.push_back({"out", true, "output image .exr (default reference.exr) or .png"});
  return with(with(scene, kExtractSpecs), more);
}

int cmdReference(int argc, char** argv) {
  // --lights (or any extraction option) selects light-set mode: the scene is lit by the
  // extracted lights and their ambient residual instead of the map.
  const std::vector<OptionSpec> specs = referenceSpecs();
  Args a = parse(argc, argv, 2, specs, "reference");
  if (has(a, "help")) {
    printHelp("penumbra reference [options]",
              "Ray-traced ground truth (Embree): Monte Carlo direct lighting from the environment "
              "map, or from the extracted light set with --lights N.",
              specs);
    return 0;
  }
  std::string out = get(a, "out", "reference.exr");
  checkOutput(out, {".png", ".exr"}, "out");
  ReferenceOptions ro;
  if (has(a, "size")) parseSize(get(a, "size", ""), ro.width, ro.height);
  parseSampling(a, ro, 1);
  float exposure = parseExposure(a);
  bool lightMode = has(a, "lights") || has(a, "extract") || has(a, "light-shape");
  ExtractOptions eo = parseExtractOptions(a);
  LightSet userLights;
  const bool useLightSet = userLightSet(a, userLights);
  lightMode = lightMode || useLightSet;
  SceneSetup s = loadSetup(a, ro.width, ro.height);
  ReferenceImage ref;
  {
    ProgressLine progress("reference");
    ro.progress = progress.callback();
    if (lightMode) {
      Context ctx(get(a, "device", ""));
      LightSet lights = useLightSet ? userLights : extractLights(ctx, s.env, eo);
      ref = referenceLightsWithNoise(s.scene, s.camera, lights, s.env, ro);
    } else {
      ref = referenceEnvironmentWithNoise(s.scene, s.camera, s.env, ro);
    }
    ro.progress = nullptr;  // it refers to `progress`
  }
  const Image& img = ref.image;
  writeImage(out, img, exposure > 0 ? exposure : autoExposure(img),
             {{kRelativeNoiseAttribute, ref.relativeNoise}});
  std::cout << "penumbra: wrote " << fs::absolute(out).string() << " (" << ro.width << "x"
            << ro.height << ", " << ro.spp << " spp, "
            << (lightMode ? "light-set" : "environment") << " reference, relative noise "
            << percentText(ref.relativeNoise) << ")\n";
  return 0;
}

int cmdCompare(int argc, char** argv) {
  std::vector<OptionSpec> specs = {{"out", true, "also write the metrics JSON to this file"},
                                   {"help", false, "show this help"}};
  Args a = parse(argc, argv, 2, specs, "compare");
  if (has(a, "help")) {
    printHelp("penumbra compare A B [--out metrics.json]",
              "Compares image A with reference B over B's geometry pixels (alpha > 0.5): RMSE, "
              "relative RMSE (RMSE / mean of B), PSNR, max abs error, as JSON, and "
              "\"reference_noise\": B's own relative noise when B is an EXR written by "
              "`penumbra reference` (null otherwise). A relative RMSE below twice that noise is "
              "noted on stderr.",
              specs);
    return 0;
  }
  if (a.positional.size() != 2)
    badInput("penumbra compare needs two images, A and the reference B (got " +
             std::to_string(a.positional.size()) + ")");
  if (has(a, "out")) checkOutput(get(a, "out", ""), {".json"}, "out");
  Image A = readImage(a.positional[0]);
  Image B = readImage(a.positional[1]);
  const ImageMetrics m = compareImages(A, B);
  // The reference's own noise, when `penumbra reference` stored it in B's header.
  const ImageAttributes attributes = readImageAttributes(a.positional[1]);
  const auto noise = attributes.find(kRelativeNoiseAttribute);
  const bool haveNoise = noise != attributes.end() && std::isfinite(noise->second);
  std::string json = toJson(m);
  json.insert(json.rfind('}'), ", \"reference_noise\": " +
                                   (haveNoise ? shortestNumber(noise->second) : std::string("null")));
  json += "\n";
  std::cout << json;
  if (haveNoise && m.relativeRmse < 2.0 * noise->second)
    std::cerr << "penumbra: compare: relative RMSE " << percentText(m.relativeRmse)
              << " is below twice the reference's own noise (" << percentText(noise->second)
              << "): the difference is not resolved by this reference\n";
  if (has(a, "out")) writeTextAtomic(get(a, "out", ""), json);
  return 0;
}

// `render`'s options that make sense for one evaluated frame (no animation, no output image or
// report of render's own), plus the truths' and the budget's.
std::vector<OptionSpec> evaluateSpecs() {
  const EvaluateOptions E;
  std::vector<OptionSpec> specs;
  for (const OptionSpec& o : renderSpecs())
    if (o.name != "frames" && o.name != "frame-time" && o.name != "rotate-step" &&
        o.name != "out" && o.name != "report" && o.name != "exposure")
      specs.push_back(o);
  std::vector<OptionSpec> more = samplingSpecs(E.truth, 2);
  more.insert(more.end(), {
      {"truth", true, "cache directory of truths: read when present for the same scene, map, "
                      "size, camera, spp, seed and light set, written otherwise (default: none)",
       {"EvaluateOptions.cacheDir"}},
      {"out-dir", true, "write the frame (frame.exr) and the heat maps (PNG) here"},
      {"json", true, "write the budget as JSON to this file"},
  });
  return with(specs, more);
}

int cmdEvaluate(int argc, char** argv) {
  const std::vector<OptionSpec> specs = evaluateSpecs();
  Args a = parse(argc, argv, 2, specs, "evaluate");
  if (has(a, "help")) {
    printHelp("penumbra evaluate [render options] [--spp N] [--truth DIR] [--out-dir DIR] "
              "[--json FILE]",
              "The error budget of a rendered frame against Embree truths of the same scene "
              "(README, \"Error budget\"): total (frame vs environment truth), floor (exact "
              "visibility of the same lights vs environment truth), technique (frame vs that "
              "light-set truth), ambient (light-set truth with the ambient residual unshadowed vs "
              "shadowed), each as relative RMSE (divided by the environment truth's mean) and "
              "mean HDR-FLIP, over all geometry pixels and over penumbra pixels (where 2%..98% of "
              "the lights' irradiance arrives), with the noise of the truths it sits in; the "
              "cross term that makes total^2 = floor^2 + technique^2 + 2 cross; the mean signed "
              "error per RGB; the frame's warm render time.",
              specs);
    return 0;
  }
  const RenderOptions ro = parseRenderOptions(a);
  EvaluateOptions eo;
  eo.truth.width = ro.width;
  eo.truth.height = ro.height;
  // At least 2 samples: one per half, for the noise estimate.
  parseSampling(a, eo.truth, 2);
  eo.cacheDir = get(a, "truth", "");
  ExtractOptions ext = parseExtractOptions(a);
  LightSet userLights;
  const bool useLightSet = userLightSet(a, userLights);
  // The directories last among the checks, so that a refused option leaves none behind.
  for (const char* dirOption : {"truth", "out-dir"}) {
    if (!has(a, dirOption)) continue;
    const std::string dir = get(a, dirOption, "");
    std::error_code ec;
    if (dir.empty()) badInput(std::string("--") + dirOption + " needs a directory");
    fs::create_directories(dir, ec);
    if (!fs::is_directory(dir))
      badInput(std::string("--") + dirOption + " " + dir + ": cannot create the directory" +
               (ec ? " (" + ec.message() + ")" : std::string()));
  }
  if (has(a, "json")) checkOutput(get(a, "json", ""), {".json"}, "json");
  SceneSetup s = loadSetup(a, ro.width, ro.height);
  if (has(a, "env-rotate")) s.env.rotationYDeg = parseFloat("env-rotate", get(a, "env-rotate", ""));

  Context ctx(get(a, "device", ""));
  FrameRenderer frameRenderer(ctx, a, ro);
  const LightSet lights = useLightSet ? userLights : extractLights(ctx, s.env, ext);
  // Warm: the first render builds the kernels and buffers; the second is timed.
  frameRenderer.render(s.scene, s.camera, lights, s.env, ro);
  const auto t0 = std::chrono::steady_clock::now();
  const Frame frame = frameRenderer.render(s.scene, s.camera, lights, s.env, ro);
  const double frameMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

  EvaluateTruths truths;
  {
    ProgressLine progress("evaluate: truths");
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
  if (has(a, "out-dir")) {
    const std::string dir = get(a, "out-dir", "");
    writeImage((fs::path(dir) / "frame.exr").string(), frame.image);
    double scale = 0;
    const std::vector<std::string> maps = writeHeatMaps(budget, frame.image, truths, dir, &scale);
    std::cout << "heat maps (signed error scale +-" << percentText(scale) << " of the truth's mean):";
    for (const std::string& m : maps) std::cout << " " << fs::path(m).filename().string();
    std::cout << " and frame.exr in " << fs::absolute(dir).string() << "\n";
  }
  if (has(a, "json")) writeTextAtomic(get(a, "json", ""), toJson(budget));
  return 0;
}

int cmdLights(int argc, char** argv) {
  std::vector<OptionSpec> specs = {{"env", true, "environment map or 'builtin' (default)"}};
  specs.insert(specs.end(), kExtractSpecs.begin(), kExtractSpecs.end());
  specs.insert(specs.end(), {
      {"out", true, "write the light set JSON here (default: standard output)"},
      {"overlay", true, "write the map with every light outlined to this PNG"},
      {"device", true, "OpenCL device: index or name substring"},
      {"help", false, "show this help"},
  });
  Args a = parse(argc, argv, 2, specs, "lights");
  if (has(a, "help")) {
    printHelp("penumbra lights [options]",
              "Extracts area lights from an environment map and writes them as JSON: how many of the "
              "map's pixels were sanitized (\"sanitized_pixels\"), each light's "
              "direction, half-angle, radiance and power, then the ambient residual (9 RGB "
              "spherical-harmonic coefficients of radiance, \"ambient_sh\", and its power; with "
              "--ambient map, the default, also its irradiance map, \"ambient_map\").",
              specs);
    return 0;
  }
  if (has(a, "out")) checkOutput(get(a, "out", ""), {".json"}, "out");
  if (has(a, "overlay")) checkOutput(get(a, "overlay", ""), {".png"}, "overlay");
  ExtractOptions eo = parseExtractOptions(a);
  Environment env = loadEnvironmentNoting(get(a, "env", "builtin"));
  Context ctx(get(a, "device", ""));
  LightSet lights = extractLights(ctx, env, eo);
  // The count belongs to the map, not to the light set (LightSet has no field for it), so it is
  // recorded here as render's report records it; loadLightSet ignores keys it does not read.
  std::string json = lights.toJson();
  json.insert(json.find('\n') + 1,
              "  \"sanitized_pixels\": " + std::to_string(env.sanitizedPixels) + ",\n");
  // the overlay first: if it fails, no JSON is left behind either
  if (has(a, "overlay")) writeLightOverlay(get(a, "overlay", ""), env, lights);
  if (has(a, "out"))
    writeTextAtomic(get(a, "out", ""), json);
  else
    std::cout << json;
  return 0;
}

// A library error names the options field at fault ("RenderOptions.cssm.order must be in [1, 32],
// got 40", "MedianCutOptions.lights must be >= 1"); the user typed an option. Each field an option
// of render or reference sets is replaced by that option ("--cssm-order must be ..."); fields no
// option sets stay as they are.
std::string withOptionNames(std::string message) {
  auto letter = [&](std::size_t i) {
    return i < message.size() && (std::isalnum(static_cast<unsigned char>(message[i])) || message[i] == '_');
  };
  std::vector<OptionSpec> specs = renderSpecs();
  for (const OptionSpec& o : referenceSpecs()) specs.push_back(o);
  for (const OptionSpec& o : evaluateSpecs()) specs.push_back(o);
  for (const OptionSpec& o : specs)
    for (const std::string& field : o.fields)
      for (std::size_t at = message.find(field); at != std::string::npos;
           at = message.find(field, at + 1)) {
        const std::size_t end = at + field.size();
        // not a part of a longer name (RenderOptions.shadows in RenderOptions.shadowsX, .shadows.y)
        if ((at > 0 && (letter(at - 1) || message[at - 1] == '.')) || letter(end) ||
            (end < message.size() && message[end] == '.' && letter(end + 1)))
          continue;
        message.replace(at, field.size(), "--" + o.name);
      }
  return message;
}

// Error output is one line whatever the message holds (a path with a line break, a build log).
std::string oneLine(std::string s) {
  for (auto& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// Usage asked for (--help) goes to stdout; usage as the answer to a missing command is an error and
// goes to stderr, so that a script capturing stdout never takes it for a result.
void usage(std::ostream& out) {
  out << "penumbra " PENUMBRA_VERSION
               " - soft shadows from area lights and HDR environment maps (OpenCL)\n\n"
               "usage: penumbra COMMAND [options]    (penumbra COMMAND --help for details)\n\n"
               "commands:\n"
               "  devices     list OpenCL devices\n"
               "  render      render a frame or an animation (extracted lights, "
            << toString(RenderOptions{}.shadows) << " soft shadows)\n"
               "  reference   ray-traced ground truth with Embree\n"
               "  compare     error metrics of an image against a reference\n"
               "  evaluate    the error budget of a frame against Embree truths\n"
               "  lights      extract area lights from an environment map\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    usage(std::cerr);
    return 2;
  }
  std::string cmd = argv[1];
  try {
    if (cmd == "--help" || cmd == "-h" || cmd == "help") {
      usage(std::cout);
      return 0;
    }
    if (cmd == "--version") {
      std::cout << PENUMBRA_VERSION << "\n";
      return 0;
    }
    if (cmd == "devices") return cmdDevices(argc, argv);
    if (cmd == "render") return cmdRender(argc, argv);
    if (cmd == "reference") return cmdReference(argc, argv);
    if (cmd == "compare") return cmdCompare(argc, argv);
    if (cmd == "evaluate") return cmdEvaluate(argc, argv);
    if (cmd == "lights") return cmdLights(argc, argv);
    std::cerr << "penumbra: unknown command '" << oneLine(cmd) << "' (see penumbra --help)\n";
    return 2;
  } catch (const Error& e) {
    std::cerr << "penumbra: " << toString(e.kind()) << ": " << oneLine(withOptionNames(e.what()))
              << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "penumbra: internal error: " << oneLine(e.what()) << "\n";
    return 2;
  }
}
