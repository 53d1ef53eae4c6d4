// Frames by stage: built-in scene and sky, 640x360, maps at the default 384^2; MSSM4 on 32
// median-cut lights (the default frame until stop 36) and the default frame itself (BM_FrameAuto:
// 64 lights, auto). The frame's time against Embree's at equal error is bench_equal_error's.
// Each stage's device time (OpenCL profiling events) is reported as a counter in ms per frame;
// `vs_unshadowed` is the frame's time over that of the same frame without shadows, measured in
// the same run (what soft shadows cost relative to plain shading, or what bent normals cost);
// `vs_eq7` MSSM4-32's time over MSSM4 with eq. 7 alone and no contact shadows (the default before
// issue 13); `vs_no_contact` MSSM4-32's over the same frame without contact shadows (what they
// cost).
//
// Throughput of the stages that scale, for MSSM4 (README "Speed on a CPU"):
//   sat_fraction_of_copy   the moments' summed-area tables (read and written once each: 2 x the
//                          maps' bytes) over the bandwidth of a device buffer copy of the same
//                          bytes, measured in the same process;
//   visibility_Mpairs_s    pixel-light pairs a second in mssm4/visibility;
//   raster_Mtexels_s       shadow-map texels a second in shadow-maps/raster;
//   shade_Mpairs_s         pixel-light pairs a second in shade;
//   contact_maps_Mpairs_s  pixel-light pairs a second in contact-shadows/maps (contact shadows
//                          from the lights' side: every pair is screened, few are ray-tested);
//   vs_per_pixel           the frame's time over the same frame with PENUMBRA_CPU_BATCHING=off
//                          (the kernels GPUs run, one pixel per work-item), in the same run: what
//                          the CPU forms of the kernels gain (1 on a GPU, where both are the same).
#include <benchmark/benchmark.h>
#include <penumbra/penumbra.hpp>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <string>

using namespace penumbra;

namespace {

struct Setup {
  Context ctx;
  Scene scene = builtinScene();
  Environment env = builtinEnvironment();
  Camera camera = frameCamera(scene, 640.0f / 360.0f);
};

Setup& setup() {
  static Setup s;
  return s;
}

double unshadowedMs = 0;
// The default frame with the CPU forms off (PENUMBRA_CPU_BATCHING=off), measured before it.
double perPixelMs = 0;

// Bytes a second of a device buffer copy of `bytes` (read + write), best of 5, profiled.
double copyBytesPerSec(Context& ctx, std::size_t bytes) {
  cl::Buffer a = ctx.buffer(bytes, "bench copy a"), b = ctx.buffer(bytes, "bench copy b");
  const cl_uchar zero = 0;
  ctx.fill(a, &zero, 1, bytes, "bench copy a");
  ctx.fill(b, &zero, 1, bytes, "bench copy b");
  double best = 0;
  for (int i = 0; i < 6; ++i) {  // the first is a warm-up (first touch of the pages)
    cl::Event ev;
    ctx.queue().enqueueCopyBuffer(a, b, 0, 0, bytes, nullptr, &ev);
    ev.wait();
    const double s = (ev.getProfilingInfo<CL_PROFILING_COMMAND_END>() -
                      ev.getProfilingInfo<CL_PROFILING_COMMAND_START>()) * 1e-9;
    if (i > 0 && s > 0) best = std::max(best, 2.0 * double(bytes) / s);
  }
  return best;
}
// The default frame with Kneiphof's (2017) eq. 7 alone and no contact shadows (MSSM4's default
// until issue 13), measured first: the default frame's and auto's `vs_eq7` is their time over it,
// in the same run.
double eq7Ms = 0;
// The default frame without contact shadows, measured before it (`vs_no_contact`).
double noContactMs = 0;

// The default shadow-map size (RenderOptions): the benchmarks of "the default frame" use it.
const int kMap = RenderOptions{}.shadowMapSize;

void runFrames(benchmark::State& state, ShadowTechnique technique, int lights, int mapSize,
               bool bentNormals = false, bool eq7 = false, bool perPixel = false,
               bool contact = true) {
  Setup& s = setup();
  Renderer renderer(s.ctx);
  RenderOptions ro;
  ro.shadows = technique;
  ro.shadowMapSize = mapSize;
  ro.bentNormals = bentNormals;
  if (eq7) ro.mssm.upperBoundBlocker = false;
  ro.shadow.contactShadows = contact && !eq7;
  MedianCutOptions mc;
  mc.lights = lights;
  // warm-up: kernels are compiled on first use
  s.ctx.resetTimings();
  renderer.render(s.scene, s.camera, extractMedianCut(s.ctx, s.env, mc), s.env, ro);
  std::map<std::string, double> sum;
  double frameMs = 0;
  for (auto _ : state) {
    s.ctx.resetTimings();
    LightSet set = extractMedianCut(s.ctx, s.env, mc);
    Frame f = renderer.render(s.scene, s.camera, set, s.env, ro);
    for (auto& [stage, ms] : f.timingsMs) sum[stage] += ms;
    frameMs += f.timingsMs.back().second;
  }
  double n = double(state.iterations());
  // Group the SAT passes: one counter per stage family keeps the table readable.
  for (auto& [stage, ms] : sum) state.counters[stage + "_ms"] = ms / n;
  state.SetItemsProcessed(std::int64_t(state.iterations()) * 640 * 360);
  const bool baseline = technique == ShadowTechnique::None && !bentNormals;
  if (baseline) unshadowedMs = frameMs / n;
  if (!baseline && unshadowedMs > 0)
    state.counters["vs_unshadowed"] = (frameMs / n) / unshadowedMs;
  if (eq7) eq7Ms = frameMs / n;
  else if (eq7Ms > 0 && lights == 32 && mapSize == kMap && !perPixel && contact)
    state.counters["vs_eq7"] = (frameMs / n) / eq7Ms;
  if (perPixel) perPixelMs = frameMs / n;
  if (!contact) noContactMs = frameMs / n;
  if (technique != ShadowTechnique::MSSM4 || eq7 || !contact) return;
  if (!perPixel && noContactMs > 0 && lights == 32 && mapSize == kMap)
    state.counters["vs_no_contact"] = (frameMs / n) / noContactMs;
  if (!perPixel && perPixelMs > 0 && lights == 32 && mapSize == kMap)
    state.counters["vs_per_pixel"] = (frameMs / n) / perPixelMs;
  auto stageMs = [&](const std::string& prefix) {
    double ms = 0;
    for (auto& [stage, t] : sum)
      if (stage.compare(0, prefix.size(), prefix) == 0) ms += t;
    return ms / n;
  };
  const double pairs = 640.0 * 360.0 * lights;
  const std::size_t mapBytes = std::size_t(lights) * mapSize * mapSize * 32;  // long4 moments
  static std::map<std::size_t, double> copyBw;
  if (!copyBw.count(mapBytes)) copyBw[mapBytes] = copyBytesPerSec(s.ctx, mapBytes);
  const double satMs = stageMs("mssm4/sat");
  if (satMs > 0 && copyBw[mapBytes] > 0)
    state.counters["sat_fraction_of_copy"] = 2.0 * mapBytes / (satMs * 1e-3) / copyBw[mapBytes];
  if (stageMs("mssm4/visibility") > 0)
    state.counters["visibility_Mpairs_s"] = pairs / (stageMs("mssm4/visibility") * 1e3);
  if (stageMs("shadow-maps/raster") > 0)
    state.counters["raster_Mtexels_s"] =
        double(lights) * mapSize * mapSize / (stageMs("shadow-maps/raster") * 1e3);
  if (stageMs("shade") > 0) state.counters["shade_Mpairs_s"] = pairs / (stageMs("shade") * 1e3);
  if (stageMs("contact-shadows/maps") > 0)
    state.counters["contact_maps_Mpairs_s"] = pairs / (stageMs("contact-shadows/maps") * 1e3);
}

// PENUMBRA_CPU_BATCHING=off for the scope; the caller's value (or its absence) after.
struct CpuBatchingOff {
  CpuBatchingOff() {
    const char* v = std::getenv("PENUMBRA_CPU_BATCHING");
    had = v != nullptr;
    if (had) old = v;
    setenv("PENUMBRA_CPU_BATCHING", "off", 1);
  }
  ~CpuBatchingOff() {
    if (had)
      setenv("PENUMBRA_CPU_BATCHING", old.c_str(), 1);
    else
      unsetenv("PENUMBRA_CPU_BATCHING");
  }
  bool had = false;
  std::string old;
};

void BM_FrameUnshadowed(benchmark::State& state) {
  runFrames(state, ShadowTechnique::None, 32, kMap);
}
// The unshadowed frame with bent normals (Sintorn et al. 2008 §4.3): vs_unshadowed is what the
// option costs
// on top of the cheapest frame (its stages: bent-normals/vertices, bent-normals/pixels, and a
// slower shade).
void BM_FrameUnshadowedBentNormals(benchmark::State& state) {
  runFrames(state, ShadowTechnique::None, 32, kMap, true);
}
void BM_FrameMSSM4Eq7(benchmark::State& state) {
  runFrames(state, ShadowTechnique::MSSM4, 32, kMap, false, true);
}
// The default frame: 64 lights, auto at its defaults (the 24 brightest MSSM4, the rest hard).
void BM_FrameAuto(benchmark::State& state) {
  runFrames(state, ShadowTechnique::Auto, 64, kMap);
}
void BM_FrameMSSM4PerPixel(benchmark::State& state) {
  CpuBatchingOff off;
  runFrames(state, ShadowTechnique::MSSM4, 32, kMap, false, false, true);
}
void BM_FrameMSSM4NoContact(benchmark::State& state) {
  runFrames(state, ShadowTechnique::MSSM4, 32, kMap, false, false, false, false);
}
void BM_FrameMSSM4(benchmark::State& state) {
  runFrames(state, ShadowTechnique::MSSM4, int(state.range(0)), int(state.range(1)));
}

}  // namespace

BENCHMARK(BM_FrameUnshadowed)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_FrameUnshadowedBentNormals)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_FrameMSSM4Eq7)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_FrameAuto)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_FrameMSSM4PerPixel)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_FrameMSSM4NoContact)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_FrameMSSM4)
    ->Args({32, 384})  // the default map size (kMap)
    ->Args({32, 256})
    ->Args({32, 512})
    ->Args({16, 384})
    ->Args({64, 384})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK_MAIN();
