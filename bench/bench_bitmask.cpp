// Cost of the bitmask technique (Sintorn et al. 2008; src/shadows/bitmask.cpp) against its three
// drivers:
//   BM_BitmaskSamples/N/W     built-in scene and sky, 32 median-cut lights, N light samples per
// light (128..1024), a W x (W * 9 / 16) frame. Sintorn et al. 2008 reports roughly
//                             x2 from 128 to 1024 samples.
//   BM_BitmaskTriangles/k     a k x k grid of spheres (960 triangles each) over a ground grid, one
//                             5-degree light, 256 samples, 160x90: cost against triangle count
//                             (Sintorn et al. 2008: roughly linear).
//   BM_BitmaskRadius/deg      the built-in scene under one light of half-angle deg, 256 samples,
//                             160x90: larger lights mean larger influence regions.
//   BM_BitmaskLightShape/s    one light of each shape at the same bounding cap: cap, textured cap,
//                             ellipse, textured ellipse (the cost of sample weights and frames).
// Counters: device time per stage in ms per frame (bitmask/lists/* summed as lists_ms,
// bitmask/triangles, bitmask/self, bitmask/resolve, and the frame's total), the process's CPU time
// per frame (process_cpu_ms: on a CPU device the work itself, which other processes loading the
// machine stretch in wall-clock time but not in CPU time), the scene's triangle count, and the list
// statistics of Sintorn et al. 2008 Figure 9 from Frame::stats (occupied texels, mean and max list
// length,
// view samples).
#include <benchmark/benchmark.h>
#include <penumbra/penumbra.hpp>

#include "compare_common.hpp"

#include <cmath>
#include <map>
#include <string>

using namespace penumbra;

namespace {

Context& context() {
  static Context ctx;
  return ctx;
}

LightSet oneLight(float halfAngleDeg) {
  AreaLight a;
  const float d[3] = {0.45f, 0.8f, 0.35f};
  const float l = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  a.direction = {d[0] / l, d[1] / l, d[2] / l};
  a.cosAlpha = float(std::cos(halfAngleDeg * 3.14159265358979 / 180));
  a.radiance = {1, 1, 1};
  LightSet s;
  s.lights.push_back(a);
  return s;
}

// k x k spheres of radius 0.3 on a 0.8 m pitch, resting 0.1 m above a ground grid.
Scene sphereGrid(int k) {
  Scene s = builtinScene();
  Scene out;
  for (const Mesh& m : s.meshes)
    if (m.name == "ground") out.meshes.push_back(m);
  const Mesh* sphere = nullptr;
  for (const Mesh& m : s.meshes)
    if (m.name == "sphere") sphere = &m;
  if (!sphere) return out;
  // the built-in sphere's centre and radius from its vertex bounds
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (auto& p : sphere->positions)
    for (int c = 0; c < 3; ++c) lo[c] = std::fmin(lo[c], p[c]), hi[c] = std::fmax(hi[c], p[c]);
  const float r = (hi[0] - lo[0]) / 2, scale = 0.3f / r;
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) {
      Mesh m = *sphere;
      const float cx = (i - (k - 1) / 2.0f) * 0.8f, cz = (j - (k - 1) / 2.0f) * 0.8f;
      for (auto& p : m.positions) {
        for (int c = 0; c < 3; ++c) p[c] = (p[c] - (lo[c] + hi[c]) / 2) * scale;
        p[0] += cx;
        p[1] += 0.4f;
        p[2] += cz;
      }
      out.meshes.push_back(m);
    }
  return out;
}

void run(benchmark::State& state, const Scene& scene, const LightSet& lights, int samples,
         int width) {
  Context& ctx = context();
  Environment env = builtinEnvironment();
  const int height = std::max(1, width * 9 / 16);
  Camera cam = frameCamera(scene, float(width) / float(height));
  Renderer renderer(ctx);
  RenderOptions ro;
  ro.shadows = ShadowTechnique::Bitmask;
  ro.bitmask.lightSamples = samples;
  ro.width = width;
  ro.height = height;
  ctx.resetTimings();
  renderer.render(scene, cam, lights, env, ro);  // warm-up: kernels, tables, buffers
  std::map<std::string, double> sum;
  std::vector<std::pair<std::string, double>> stats;
  double cpuMs = 0;
  for (auto _ : state) {
    ctx.resetTimings();
    const double c0 = penumbra::bench::processCpuMs();
    Frame f = renderer.render(scene, cam, lights, env, ro);
    cpuMs += penumbra::bench::processCpuMs() - c0;
    for (auto& [stage, ms] : f.timingsMs) {
      std::string key = stage.rfind("bitmask/lists/", 0) == 0 ? "bitmask/lists" : stage;
      sum[key] += ms;
    }
    stats = f.stats;
  }
  const double n = double(state.iterations());
  for (auto& [stage, ms] : sum) state.counters[stage + "_ms"] = ms / n;
  state.counters["process_cpu_ms"] = cpuMs / n;
  for (auto& [name, v] : stats) state.counters[name] = v;
  state.counters["triangles"] = double(scene.triangleCount());
}

void BM_BitmaskSamples(benchmark::State& state) {
  Context& ctx = context();
  Environment env = builtinEnvironment();
  static const LightSet lights = extractMedianCut(ctx, env, MedianCutOptions{});
  run(state, builtinScene(), lights, int(state.range(0)), int(state.range(1)));
}

void BM_BitmaskTriangles(benchmark::State& state) {
  run(state, sphereGrid(int(state.range(0))), oneLight(5), 256, 160);
}

void BM_BitmaskRadius(benchmark::State& state) {
  run(state, builtinScene(), oneLight(float(state.range(0))), 256, 160);
}

// Light shapes at one bounding cap: shape 0 a 10-degree cap, 1 the same cap with an 8 x 8
// checkered texture (per-sample weights, Sintorn et al. 2008 §4.1), 2 a 10 x 4 degree ellipse (the
// disk's
// affine image), 3 that ellipse textured. 256 samples, built-in scene, 160x90.
void BM_BitmaskLightShape(benchmark::State& state) {
  const int shape = int(state.range(0));
  LightSet set = oneLight(10);
  AreaLight& l = set.lights[0];
  if (shape >= 2)
    l = makeEllipseLight(l.direction, {0, 1, 0}, {10 * 3.14159265358979 / 180, 4 * 3.14159265358979 / 180},
                         {1, 1, 1});
  if (shape % 2 == 1) {
    LightTexture t{8, 8, {}};
    for (int j = 0; j < 8; ++j)
      for (int i = 0; i < 8; ++i)
        for (int c = 0; c < 3; ++c) t.radiance.push_back((i + j) % 2 ? 2.0f : 0.25f);
    setLightTexture(l, t);
  }
  run(state, builtinScene(), set, 256, 160);
}

}  // namespace

BENCHMARK(BM_BitmaskLightShape)->DenseRange(0, 3, 1)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_BitmaskSamples)
    ->ArgsProduct({{128, 256, 512, 1024}, {160}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);
// One light: frames of tens of ms, so more iterations for a steadier mean.
BENCHMARK(BM_BitmaskTriangles)->DenseRange(1, 6, 1)->Unit(benchmark::kMillisecond)->Iterations(10);
BENCHMARK(BM_BitmaskRadius)
    ->Arg(1)
    ->Arg(2)
    ->Arg(5)
    ->Arg(10)
    ->Arg(20)
    ->Arg(40)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(10);
BENCHMARK_MAIN();
