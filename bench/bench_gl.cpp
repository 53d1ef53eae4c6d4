// `render --gl` against the OpenCL-only path, by stage: the default frame (built-in scene and sky,
// 64 median-cut lights, auto (24 MSSM4, 40 hard) at 384^2, 640x360) rendered by Renderer and
// by gl::GLRenderer (GL rasterizes the G-buffer and shadow maps and shades, OpenCL computes
// visibility) on an EGL (range 0) or OSMesa (range 1) headless context. Counters: ms per frame by stage (OpenCL device
// time for OpenCL stages, wall clock with glFinish for gl/* and interop/*); `host_copy_ms` is the
// host-copy path's cost per frame (interop/upload + interop/download), `vs_opencl` the frame's
// time over the OpenCL-only frame's measured in the same run. Without a display, run it with
// EGL_PLATFORM=surfaceless.
#include <benchmark/benchmark.h>
#include <penumbra/penumbra.hpp>

#include <map>

#ifdef PENUMBRA_HAS_GL
#include <penumbra/gl/interop.hpp>

using namespace penumbra;

namespace {

struct Setup {
  Context ctx;
  Scene scene = builtinScene();
  Environment env = builtinEnvironment();
  Camera camera = frameCamera(scene, 640.0f / 360.0f);
  LightSet lights = extractLights(ctx, env, {});
};

Setup& setup() {
  static Setup s;
  return s;
}

double openclMs = 0;

template <class R>
void runFrames(benchmark::State& state, R& renderer) {
  Setup& s = setup();
  RenderOptions ro;  // the default frame: 640x360, auto (24 of the lights MSSM4), 384^2
  s.ctx.resetTimings();
  renderer.render(s.scene, s.camera, s.lights, s.env, ro);  // warm-up: kernels, GL variants
  std::map<std::string, double> sum;
  for (auto _ : state) {
    s.ctx.resetTimings();
    Frame f = renderer.render(s.scene, s.camera, s.lights, s.env, ro);
    for (auto& [stage, ms] : f.timingsMs) sum[stage] += ms;
  }
  double n = double(state.iterations());
  for (auto& [stage, ms] : sum) state.counters[stage + "_ms"] = ms / n;
  if (sum.count("interop/upload"))
    state.counters["host_copy_ms"] = (sum["interop/upload"] + sum["interop/download"]) / n;
  double total = sum["total"] / n;
  if (!sum.count("gl/shade")) openclMs = total;
  else if (openclMs > 0) state.counters["vs_opencl"] = total / openclMs;
}

void BM_FrameOpenCL(benchmark::State& state) {
  Renderer r(setup().ctx);
  runFrames(state, r);
}

void BM_FrameGL(benchmark::State& state) {
  gl::HeadlessContext glc(state.range(0) == 0 ? gl::Backend::EGL : gl::Backend::OSMesa);
  gl::GLRenderer r(setup().ctx, glc.loader());
  runFrames(state, r);
}

}  // namespace

BENCHMARK(BM_FrameOpenCL)->Unit(benchmark::kMillisecond)->Iterations(5);
BENCHMARK(BM_FrameGL)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(5);
#endif
BENCHMARK_MAIN();
