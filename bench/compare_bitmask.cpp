// The bitmask technique (Sintorn et al. 2008) measured against what issue 5 asks of it. Writes
//   OUT/bitmask.md and OUT/bitmask.json with up to three parts:
// 1. Area approximation (Ying et al. 2002) against the bitmask technique with 1024 light samples on
// the
//      same polygon lights, built-in scene at 160x90: (a) one square light from a light-set
//      "rect" (half-angles 4 and 8 degrees), (b) the 8 median-cut lights of the built-in sky as
//      polygons. Per light and geometry pixel, |V_area - V_bitmask1024| (mean, 99th percentile,
//      max), the relative RMSE of the shaded frame against the bitmask-1024 frame, and the frame
//      time, for m = 0, 1, 2, 3, 7 samples per edge. Ying et al. 2002 claims few samples suffice.
//   2. Equal error: the built-in scene and sky, 32 median-cut lights (caps), W x H (320x180 by
//      default): MSSM4, MSSM6 and the bitmask technique at 128..1024 light samples (and 128 with
// 4 and 8 jittered frames averaged, Sintorn et al. 2008 §4.3), relative RMSE against the Embree
//      reference of the same 32 lights and against the Embree environment reference, frame time.
//      Each reference is the mean of two seeds; half their difference is its own noise, which
//      the errors must stand well above (and which the table also removes in quadrature).
//   3. With --bench FILE (the --benchmark_out JSON of bench_bitmask): its cost sweeps as tables,
//      time per stage and the list statistics, with the ratios Sintorn et al. 2008 reports.
// Usage: compare_bitmask [OUT_DIR] [--size WxH] [--ref-spp N] [--part 1|2|3] [--bench FILE]
// Times: medians of 3 renders after a warm-up for MSSM and area approximation, one render after
// a warm-up for the bitmask technique (seconds per frame on a CPU device); device stage times from
// OpenCL profiling events, "total" is render()'s wall clock.
#include <CLI/CLI.hpp>
#include <penumbra/penumbra.hpp>

#include "compare_common.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

using namespace penumbra;
using penumbra::bench::renderTimed;
using penumbra::bench::shadowStageMs;
namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

namespace {

struct VisError {
  double mean = 0, p99 = 0, max = 0;
};

// |a - b| over every light and every geometry pixel (alpha of `frame` > 0.5); a and b are
// light-major visibility images of frame's size (Renderer::lastVisibility).
VisError visibilityError(const std::vector<float>& a, const std::vector<float>& b, const Image& frame) {
  const std::size_t pixels = std::size_t(frame.width) * frame.height;
  std::vector<double> d;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i)
    if (frame.pixels[(i % pixels) * 4 + 3] > 0.5f) d.push_back(std::fabs(double(a[i]) - b[i]));
  VisError e;
  if (d.empty()) return e;
  for (double x : d) e.mean += x;
  e.mean /= double(d.size());
  std::sort(d.begin(), d.end());
  e.p99 = d[std::min(d.size() - 1, std::size_t(0.99 * double(d.size())))];
  e.max = d.back();
  return e;
}

double totalMs(const Frame& f) { return f.timingsMs.empty() ? 0 : f.timingsMs.back().second; }

// A square polygon light from a light-set file's "rect" entry, unit power per steradian.
LightSet squareLight(float halfAngleDeg) {
  const Json light = {{"shape", "rect"},
                      {"direction", {0.35, 1.0, 0.25}},
                      {"up", {0, 0, 1}},
                      {"half_angles_deg", {halfAngleDeg, halfAngleDeg}},
                      {"radiance", {1, 1, 1}}};
  return lightSetFromJson(Json{{"lights", {light}}}.dump(), "compare_bitmask square light");
}

struct AreaRow {
  std::string lights, technique;
  int edgeSamples = -1;  // -1: a bitmask row
  VisError vis;
  double relFrame = 0, totalMs = 0, shadowMs = 0, cpuMs = 0;
};

struct ErrRow {
  std::string technique;
  int samples = 0, frames = 1;
  double relLights = 0, relEnv = 0, totalMs = 0, shadowMs = 0, cpuMs = 0;
};

// One run of bench_bitmask, from Google Benchmark's JSON: its name (family/args) and every
// number it reports (counters included).
struct BenchRow {
  std::string family, args;
  std::map<std::string, double> v;
};

// Google Benchmark's --benchmark_out JSON: {"context": ..., "benchmarks": [{"name": ..., numbers
// and counters}, ...]}; every numeric field of a BM_ run is kept.
std::vector<BenchRow> readBenchJson(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error(ErrorKind::BadInput, "--bench: cannot read " + path);
  Json doc;
  try {
    doc = Json::parse(f);
  } catch (const Json::exception& e) {
    throw Error(ErrorKind::BadInput, "--bench: " + path + ": " + e.what());
  }
  std::vector<BenchRow> rows;
  const auto list = doc.find("benchmarks");
  if (doc.is_object() && list != doc.end() && list->is_array())
    for (const Json& b : *list) {
      const auto nameIt = b.find("name");
      if (!b.is_object() || nameIt == b.end() || !nameIt->is_string()) continue;
      std::string name = nameIt->get<std::string>();
      if (name.find("BM_") == std::string::npos) continue;
      name = name.substr(0, name.find("/iterations:"));
      BenchRow r;
      r.family = name.substr(0, name.find('/'));
      r.args = name.find('/') == std::string::npos ? "" : name.substr(name.find('/') + 1);
      for (const auto& [key, value] : b.items())
        if (value.is_number()) r.v[key] = value.get<double>();
      rows.push_back(r);
    }
  if (rows.empty()) throw Error(ErrorKind::BadInput, "--bench: no benchmarks in " + path);
  return rows;
}

double benchShadowMs(const BenchRow& r) {
  double ms = 0;
  for (auto& [k, v] : r.v)
    if (k.rfind("bitmask/", 0) == 0 && k.size() > 3 && k.compare(k.size() - 3, 3, "_ms") == 0) ms += v;
  return ms;
}

double get(const BenchRow& r, const std::string& k) {
  auto it = r.v.find(k);
  return it == r.v.end() ? 0 : it->second;
}

std::string benchMarkdown(const std::vector<BenchRow>& rows, const std::string& path) {
  std::ostringstream md;
  md << "## 3. Cost sweeps (bench/bench_bitmask.cpp)\n\n"
        "From `"
     << fs::path(path).filename().string()
     << "` (`bench_bitmask --benchmark_out=...`): device time per stage in ms per frame "
        "(mean of the iterations after a warm-up; lists: every bitmask/lists/* stage), the shadow "
        "stages' sum, render()'s wall clock, and the list statistics of Sintorn et al. 2008 Figure 9 (list grid "
        "texels occupied by at least one view sample, mean list length over occupied texels, max). "
        "CPU ms: the process's CPU time per frame (all threads; other load on the machine stretches the "
        "wall-clock and device times, not this). CPU ratio: against the first row of each sweep. Sintorn et al. 2008: cost roughly x2 from 128 to 1024 "
        "samples, roughly linear in the triangle count, linear in the light's radius.\n";
  const char* titles[][3] = {
      {"BM_BitmaskSamples", "samples / width", "light samples, frame width (32 median-cut lights, built-in scene and sky)"},
      {"BM_BitmaskTriangles", "k", "a k x k grid of spheres over the ground (one 5-degree light, 256 samples, 160x90)"},
      {"BM_BitmaskRadius", "half-angle deg", "the light's half-angle (built-in scene, one light, 256 samples, 160x90)"}};
  for (auto& [family, column, title] : titles) {
    std::vector<const BenchRow*> fam;
    for (const BenchRow& r : rows)
      if (r.family == family) fam.push_back(&r);
    if (fam.empty()) continue;
    md << "\n### " << family << ": " << title << "\n\n| " << column
       << " | triangles | lists ms | triangles ms | self ms | resolve ms | shadow ms | frame ms | CPU ms | CPU ratio | occupied texels | mean list | max list | view samples |\n"
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
    const double c0 = get(*fam[0], "process_cpu_ms");
    for (const BenchRow* r : fam) {
      char buf[512];
      const double lt = get(*r, "list_texels");
      std::snprintf(buf, sizeof buf,
                    "| %s | %.0f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.2f | %.0f (%.0f%%) | %.1f | %.0f | %.0f |\n",
                    r->args.c_str(), get(*r, "triangles"), get(*r, "bitmask/lists_ms"),
                    get(*r, "bitmask/triangles_ms"), get(*r, "bitmask/self_ms"), get(*r, "bitmask/resolve_ms"),
                    benchShadowMs(*r), get(*r, "total_ms"), get(*r, "process_cpu_ms"),
                    get(*r, "process_cpu_ms") / std::max(1e-9, c0), get(*r, "occupied_texels"),
                    lt > 0 ? 100 * get(*r, "occupied_texels") / lt : 0.0, get(*r, "mean_list_length"),
                    get(*r, "max_list_length"), get(*r, "view_samples"));
      md << buf;
    }
    if (std::string(family) == "BM_BitmaskTriangles" && fam.size() >= 3) {
      // Least-squares line CPU ms = a + b * triangles: how linear the cost is (Sintorn et al. 2008
      // Fig. 11).
      double n = double(fam.size()), sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
      for (const BenchRow* r : fam) {
        double x = get(*r, "triangles") / 1000, y = get(*r, "process_cpu_ms");
        sx += x, sy += y, sxx += x * x, sxy += x * y, syy += y * y;
      }
      double b = (n * sxy - sx * sy) / (n * sxx - sx * sx), a = (sy - b * sx) / n;
      double r = (n * sxy - sx * sy) / std::sqrt((n * sxx - sx * sx) * (n * syy - sy * sy));
      char buf[256];
      std::snprintf(buf, sizeof buf,
                    "\nLeast-squares line: CPU ms = %.1f + %.2f per 1000 triangles, R^2 = %.4f.\n", a, b, r * r);
      md << buf;
    }
  }
  return md.str();
}

Json benchJsonOut(const std::vector<BenchRow>& rows) {
  Json list = Json::array();
  for (const BenchRow& r : rows) {
    Json j = {{"family", r.family}, {"args", r.args}, {"shadow_ms", benchShadowMs(r)}};
    for (const auto& [k, v] : r.v) j[k] = v;
    list.push_back(j);
  }
  return list;
}

// One part's JSON, {name: value}, to OUT/bitmask_parts/<file>; bitmask.json merges them.
void writePart(const fs::path& file, const std::string& name, const Json& value) {
  std::ofstream(file) << Json{{name, value}}.dump(2) << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  fs::path out = "compare-out";
  int W = 320, H = 180, refSpp = 1024, part = 0;
  std::string size = "320x180", benchJson;
  CLI::App app{"Bitmask visibility against area approximation and equal-error timing (issue 6)",
               "compare_bitmask"};
  app.add_option("out_dir", out, "where bitmask.md and bitmask.json go")->capture_default_str();
  app.add_option("--size", size, "frame of part 2 (part 1 is always 160x90)")
      ->capture_default_str();
  app.add_option("--ref-spp", refSpp, "samples per pixel of each Embree reference of part 2")
      ->check(CLI::Range(1, 1 << 20))->capture_default_str();
  app.add_option("--part", part,
                 "only part 1 (area approximation vs bitmask), 2 (equal error) or 3 (--bench)")
      ->check(CLI::IsMember({1, 2, 3}));
  app.add_option("--bench", benchJson, "bench_bitmask's --benchmark_out JSON: add its cost tables "
                                       "(part 3)")->check(CLI::ExistingFile);
  try {
    app.parse(argc, argv);
    char x = 0, rest = 0;
    if (std::sscanf(size.c_str(), "%d%c%d%c", &W, &x, &H, &rest) != 3 || x != 'x' || W < 1 ||
        H < 1 || W > 4096 || H > 4096)
      throw CLI::ValidationError("--size", "must be WxH with each side in 1..4096, got " + size);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "compare_bitmask: " << e.what() << " (--help lists the options)\n";
    return 2;
  }
  fs::create_directories(out);

  Context ctx;
  Renderer renderer(ctx);
  Scene scene = builtinScene();
  Environment env = environmentFrom("builtin");

  // ---- Part 1: area approximation against bitmask 1024 on the same polygon lights.
  std::vector<AreaRow> areaRows;
  const std::vector<int> edgeSamples = {0, 1, 2, 3, 7};
  const int aw = 160, ah = 90;
  if (part == 0 || part == 1) {
    Camera cam = frameCamera(scene, float(aw) / ah);
    MedianCutOptions mc;
    mc.lights = 8;
    mc.shape = LightShape::Polygon;
    // Lights merged across cube-face edges stay caps (MedianCutOptions::shape); unmerged, all 8
    // are the regions' exact quadrilaterals, so both techniques see the same polygons.
    mc.mergeAcrossFaces = false;
    std::vector<std::pair<std::string, LightSet>> cases = {
        {"one square light, half-angles 4 deg", squareLight(4)},
        {"one square light, half-angles 8 deg", squareLight(8)},
        {"8 median-cut polygon lights", extractMedianCut(ctx, env, mc)}};
    for (auto& [name, lights] : cases) {
      for (const AreaLight& l : lights.lights)
        if (l.shape != LightShape::Polygon) {
          std::cerr << "compare_bitmask: " << name << " holds a cap light\n";
          return 1;
        }
      RenderOptions ro;
      ro.width = aw;
      ro.height = ah;
      ro.shadows = ShadowTechnique::Bitmask;
      ro.bitmask.lightSamples = 1024;
      double cpu = 0;
      Frame ref = renderTimed(ctx, renderer, scene, cam, lights, env, ro, 1, true, &cpu);
      std::vector<float> refVis = renderer.lastVisibility();
      std::fprintf(stderr, "compare_bitmask: %s: bitmask 1024 %.0f ms\n", name.c_str(), totalMs(ref));
      auto add = [&](const std::string& technique, int m, const Frame& f) {
        AreaRow r;
        r.lights = name;
        r.technique = technique;
        r.edgeSamples = m;
        r.vis = visibilityError(renderer.lastVisibility(), refVis, ref.image);
        r.relFrame = compareImages(f.image, ref.image).relativeRmse;
        r.totalMs = totalMs(f);
        r.shadowMs = shadowStageMs(f.timingsMs);
        r.cpuMs = cpu;
        areaRows.push_back(r);
        std::fprintf(stderr, "  %-12s m=%2d: mean |dV| %.4f, p99 %.3f, max %.3f, frame rel RMSE %.4f, %.1f ms\n",
                     technique.c_str(), m, r.vis.mean, r.vis.p99, r.vis.max, r.relFrame, r.totalMs);
      };
      add("bitmask 1024 (the reference)", -1, ref);
      // The bitmask technique's own sampling error at fewer samples, for scale.
      for (int n : {128, 256}) {
        ro.bitmask.lightSamples = n;
        add("bitmask " + std::to_string(n), -1, renderTimed(ctx, renderer, scene, cam, lights, env, ro, 1, true, &cpu));
      }
      ro.shadows = ShadowTechnique::AreaApprox;
      for (int m : edgeSamples) {
        ro.areaApprox.edgeSamples = m;
        add("area-approx", m, renderTimed(ctx, renderer, scene, cam, lights, env, ro, 3, true, &cpu));
      }
    }
  }

  // ---- Part 2: equal error against the Embree references.
  std::vector<ErrRow> errRows;
  double noiseLights = 0, noiseEnv = 0;
  double refLightsMs = 0, refEnvMs = 0;
  if (part == 0 || part == 2) {
    Camera cam = frameCamera(scene, float(W) / H);
    LightSet lights = extractMedianCut(ctx, env, MedianCutOptions{});
    ReferenceOptions rf;
    rf.width = W;
    rf.height = H;
    rf.spp = refSpp;
    auto timed = [](double& ms, auto&& fn) {
      auto t0 = std::chrono::steady_clock::now();
      Image img = fn();
      ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      return img;
    };
    std::cerr << "compare_bitmask: Embree references, " << refSpp << " spp, " << W << "x" << H << "\n";
    // Each reference is the mean of two seeds' images. Two independent estimates differ by
    // sqrt(2) times the noise of one, and their mean has 1/sqrt(2) of it: its noise is half
    // their difference.
    auto twoSeeds = [&](double& ms, double& noise, auto&& render) {
      rf.seed = 1;
      Image a = timed(ms, [&] { return render(); });
      rf.seed = 2;
      Image b = render();
      noise = compareImages(b, a).relativeRmse / 2;
      for (std::size_t i = 0; i < a.pixels.size(); ++i) a.pixels[i] = (a.pixels[i] + b.pixels[i]) / 2;
      return a;
    };
    Image refLights = twoSeeds(refLightsMs, noiseLights, [&] { return referenceLights(scene, cam, lights, env, rf); });
    Image refEnv = twoSeeds(refEnvMs, noiseEnv, [&] { return referenceEnvironment(scene, cam, env, rf); });
    std::fprintf(stderr, "  reference noise (rel. RMSE of the two seeds' mean): lights %.4f, environment %.4f\n",
                 noiseLights, noiseEnv);
    double cpu = 0;
    auto add = [&](const std::string& technique, int samples, int frames, const Frame& f) {
      ErrRow r;
      r.technique = technique;
      r.samples = samples;
      r.frames = frames;
      r.relLights = compareImages(f.image, refLights).relativeRmse;
      r.relEnv = compareImages(f.image, refEnv).relativeRmse;
      r.totalMs = totalMs(f);
      r.shadowMs = shadowStageMs(f.timingsMs);
      r.cpuMs = cpu;
      errRows.push_back(r);
      std::fprintf(stderr, "  %-8s samples %4d frames %d: rel RMSE lights %.4f env %.4f, %.0f ms (shadows %.0f)\n",
                   technique.c_str(), samples, frames, r.relLights, r.relEnv, r.totalMs, r.shadowMs);
    };
    RenderOptions ro;
    ro.width = W;
    ro.height = H;
    for (ShadowTechnique t : {ShadowTechnique::MSSM4, ShadowTechnique::MSSM6}) {
      ro.shadows = t;
      add(toString(t), 0, 1, renderTimed(ctx, renderer, scene, cam, lights, env, ro, 3, true, &cpu));
    }
    ro.shadows = ShadowTechnique::Bitmask;
    for (int n : {128, 256, 512, 1024}) {
      ro.bitmask.lightSamples = n;
      add("bitmask", n, 1, renderTimed(ctx, renderer, scene, cam, lights, env, ro, 1, n == 128, &cpu));
    }
    // Temporal jitter (Sintorn et al. 2008 §4.3), as `render --accumulate N`: frames 0..N-1
    // averaged.
    ro.bitmask.lightSamples = 128;
    for (int frames : {4, 8}) {
      Frame sum;
      double ms = 0, shadow = 0, cpuSum = 0;
      for (int j = 0; j < frames; ++j) {
        ro.bitmask.jitter = j;
        ctx.resetTimings();
        const double c0 = penumbra::bench::processCpuMs();
        Frame f = renderer.render(scene, cam, lights, env, ro);
        cpuSum += penumbra::bench::processCpuMs() - c0;
        ms += totalMs(f);
        shadow += shadowStageMs(f.timingsMs);
        if (j == 0) sum = f;
        else
          for (std::size_t p = 0; p < sum.image.pixels.size(); ++p) sum.image.pixels[p] += f.image.pixels[p];
      }
      for (float& v : sum.image.pixels) v /= float(frames);
      ro.bitmask.jitter = 0;
      ErrRow r;
      r.technique = "bitmask";
      r.samples = 128;
      r.frames = frames;
      r.relLights = compareImages(sum.image, refLights).relativeRmse;
      r.relEnv = compareImages(sum.image, refEnv).relativeRmse;
      r.totalMs = ms;
      r.shadowMs = shadow;
      r.cpuMs = cpuSum;
      errRows.push_back(r);
      std::fprintf(stderr, "  bitmask  samples  128 frames %d: rel RMSE lights %.4f env %.4f, %.0f ms\n", frames,
                   r.relLights, r.relEnv, r.totalMs);
    }
  }

  // ---- Part 3: the cost sweeps of bench_bitmask, from its JSON.
  std::vector<BenchRow> bench;
  if ((part == 0 || part == 3) && !benchJson.empty()) {
    try {
      bench = readBenchJson(benchJson);
    } catch (const Error& e) {
      std::cerr << "compare_bitmask: " << e.what() << "\n";
      return 2;
    }
  }

  // ---- Output: each part's section goes to OUT/bitmask_parts/<n>.md and .json (part 2: one per
  // frame size), and bitmask.md and bitmask.json are assembled from every section there, so that
  // the parts can be run apart.
  const fs::path parts = out / "bitmask_parts";
  fs::create_directories(parts);
  char buf[4096];
  if (!areaRows.empty()) {
    std::ostringstream md;
    Json js = {{"width", aw}, {"height", ah}, {"rows", Json::array()}};
    for (const AreaRow& r : areaRows)
      js["rows"].push_back({{"lights", r.lights},
                            {"technique", r.technique},
                            {"edge_samples", r.edgeSamples},
                            {"mean_abs_dv", r.vis.mean},
                            {"p99_abs_dv", r.vis.p99},
                            {"max_abs_dv", r.vis.max},
                            {"relative_rmse_frame", r.relFrame},
                            {"total_ms", r.totalMs},
                            {"shadow_ms", r.shadowMs},
                            {"process_cpu_ms", r.cpuMs}});
    md << "## 1. Area approximation (Ying et al. 2002) against the bitmask technique with 1024 light samples\n\n"
          "Built-in scene and sky, "
       << aw << "x" << ah
       << ", the same polygon lights for both (the square: a light-set \"rect\" towards (0.35, 1, 0.25); "
          "the 8 median-cut regions' exact quadrilaterals, `--light-shape polygon`, not merged across "
          "face edges). |dV|: per light and geometry pixel, the technique's visibility minus the "
          "bitmask-1024 one. Frame: relative RMSE of the shaded frame against the bitmask-1024 frame. "
          "The bitmask rows at 128 and 256 samples give the scale of the bitmask technique's own "
          "sampling error. Frame time: render()'s wall clock, median of 3 (bitmask: 1); CPU ms: this "
          "process's CPU time per frame (all threads), the measure that other load on the machine does "
          "not stretch.\n\n"
          "| lights | technique | samples per edge | mean abs(dV) | 99th pct abs(dV) | max abs(dV) | frame rel. RMSE | frame ms | shadow ms | CPU ms |\n"
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
    for (const AreaRow& r : areaRows) {
      std::snprintf(buf, sizeof buf, "| %s | %s | %s | %.4f | %.3f | %.3f | %.4f | %.0f | %.0f | %.0f |\n",
                    r.lights.c_str(), r.technique.c_str(),
                    r.edgeSamples < 0 ? "-" : std::to_string(r.edgeSamples).c_str(), r.vis.mean, r.vis.p99, r.vis.max,
                    r.relFrame, r.totalMs, r.shadowMs, r.cpuMs);
      md << buf;
    }
    std::ofstream(parts / "1.md") << md.str();
    writePart(parts / "1.json", "area_approx_vs_bitmask1024", js);
  }
  if (!errRows.empty()) {
    std::ostringstream md;
    Json js = {{"width", W},
               {"height", H},
               {"reference_spp", refSpp},
               {"reference_noise_lights", noiseLights},
               {"reference_noise_env", noiseEnv},
               {"reference_lights_ms", refLightsMs},
               {"reference_env_ms", refEnvMs},
               {"rows", Json::array()}};
    for (const ErrRow& r : errRows)
      js["rows"].push_back({{"technique", r.technique},
                            {"light_samples", r.samples},
                            {"frames", r.frames},
                            {"relative_rmse_lights", r.relLights},
                            {"relative_rmse_env", r.relEnv},
                            {"total_ms", r.totalMs},
                            {"shadow_ms", r.shadowMs},
                            {"process_cpu_ms", r.cpuMs}});
    const ErrRow* m6 = nullptr;
    for (const ErrRow& r : errRows)
      if (r.technique == "mssm6") m6 = &r;
    std::snprintf(buf, sizeof buf,
                  "## 2. Equal error: the bitmask technique against MSSM (%dx%d, built-in scene and sky, 32 median-cut lights)\n\n"
                  "Relative RMSE against the Embree reference of the same 32 lights and against the Embree "
                  "environment reference, each the mean of two seeds at %d spp; the reference's own noise "
                  "(relative RMSE of the two seeds' difference / 2): %.4f (lights), %.4f (environment). "
                  "Noise-removed: sqrt(error^2 - noise^2), the error against a noiseless reference (the "
                  "noise is independent of the technique's error). Embree took %.1f s (lights) and %.1f s "
                  "(environment) per seed. Frame time: render()'s wall clock (MSSM: median of 3; bitmask: "
                  "one frame; jittered: the sum over its frames). Shadow ms: device time of the shadow stages. CPU "
                  "ms: this process's CPU time per frame (all threads), which other load on the machine does "
                  "not stretch: the cost ratios use it.\n\n",
                  W, H, refSpp, noiseLights, noiseEnv, refLightsMs / 1000, refEnvMs / 1000);
    md << buf;
    md << "| technique | light samples | frames | rel. RMSE vs lights | noise-removed | rel. RMSE vs env | noise-removed | frame ms | shadow ms | CPU ms | CPU ms / MSSM6's |\n"
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
    auto denoised = [](double e, double noise) { return std::sqrt(std::max(0.0, e * e - noise * noise)); };
    for (const ErrRow& r : errRows) {
      std::snprintf(buf, sizeof buf, "| %s | %s | %d | %.4f | %.4f | %.4f | %.4f | %.0f | %.0f | %.0f | %.1f |\n",
                    r.technique.c_str(), r.samples ? std::to_string(r.samples).c_str() : "-", r.frames, r.relLights,
                    denoised(r.relLights, noiseLights), r.relEnv, denoised(r.relEnv, noiseEnv), r.totalMs,
                    r.shadowMs, r.cpuMs, m6 ? r.cpuMs / std::max(1e-9, m6->cpuMs) : 0.0);
      md << buf;
    }
    if (m6) {
      // The cheapest bitmask configuration at or below MSSM6's error against the same lights, and
      // the lowest bitmask error.
      const ErrRow *reach = nullptr, *best = nullptr;
      for (const ErrRow& r : errRows) {
        if (r.technique != "bitmask") continue;
        if (r.relLights <= m6->relLights && (!reach || r.cpuMs < reach->cpuMs)) reach = &r;
        if (!best || r.relLights < best->relLights) best = &r;
      }
      std::snprintf(buf, sizeof buf, "\nAgainst the same 32 lights, MSSM6's error is %.4f at %.0f CPU ms. ",
                    m6->relLights, m6->cpuMs);
      md << buf;
      if (reach)
        std::snprintf(buf, sizeof buf,
                      "The cheapest bitmask configuration at or below it is %d samples x %d frame(s): %.4f at "
                      "%.0f CPU ms (%.1fx MSSM6's). ",
                      reach->samples, reach->frames, reach->relLights, reach->cpuMs, reach->cpuMs / m6->cpuMs);
      else
        std::snprintf(buf, sizeof buf, "No bitmask configuration measured reaches it. ");
      md << buf;
      if (best) {
        std::snprintf(buf, sizeof buf,
                      "The lowest bitmask error is %.4f (%d samples x %d frame(s), %.0f CPU ms): %.2fx MSSM6's, "
                      "%.1fx the reference's own noise.\n",
                      best->relLights, best->samples, best->frames, best->cpuMs, best->relLights / m6->relLights,
                      best->relLights / std::max(1e-12, noiseLights));
        md << buf;
      }
    }
    const std::string size = std::to_string(W) + "x" + std::to_string(H);
    std::ofstream(parts / ("2_" + size + ".md")) << md.str();
    writePart(parts / ("2_" + size + ".json"), "equal_error_" + size, js);
  }
  if (!bench.empty()) {
    std::ofstream(parts / "3.md") << benchMarkdown(bench, benchJson);
    writePart(parts / "3.json", "cost", benchJsonOut(bench));
  }
  std::ofstream md(out / "bitmask.md");
  md << "# The bitmask technique (Sintorn et al. 2008): area approximation, equal error, cost\n\n"
        "Written by `compare_bitmask` (bench/compare_bitmask.cpp); see its header for the method.\n";
  Json js = Json::object();
  std::vector<std::string> sections;  // "1", "2_<W>x<H>" (one per frame size run), "3"
  for (const auto& e : fs::directory_iterator(parts))
    if (e.path().extension() == ".md") sections.push_back(e.path().stem().string());
  std::sort(sections.begin(), sections.end());
  for (const std::string& n : sections) {
    std::ifstream mf(parts / (n + ".md")), jf(parts / (n + ".json"));
    if (!mf || !jf) continue;
    try {
      js.update(Json::parse(jf));
    } catch (const Json::exception& e) {
      std::cerr << "compare_bitmask: " << (parts / (n + ".json")).string() << ": " << e.what()
                << " (a part from an older compare_bitmask? run that part again)\n";
      return 1;
    }
    md << "\n" << mf.rdbuf();
  }
  std::ofstream(out / "bitmask.json") << js.dump(2) << "\n";
  std::cerr << "compare_bitmask: wrote " << fs::absolute(out / "bitmask.md").string() << "\n";
  return 0;
}
