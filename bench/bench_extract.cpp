// Light extraction by method, on the built-in sky at 1024x512 (ambient residual left out, timed on
// its own). Device time per stage family from OpenCL profiling events, as counters in ms per
// extraction:
//   resample_ms  equirect -> cube of fixed-point energies (env/resample and its tables
//                env/resample/rows, /columns; median cut and greedy)
//   sat_ms       SAT inputs and the two summed-area tables (env/sat-inputs, env/sat/...)
//   cut_ms       the median-cut partition itself (extract/median-cut), one work-group
//   resolve_ms   regions -> lights (extract/resolve)
//   fit_ms       greedy's fit (extract/greedy), one work-group per face
//   cs_*_ms      center-surround's stages (center-surround/resample, prefix, candidates, ...)
//   device_ms    every stage together
// Kneiphof 2017 (§5) reports median cut as logarithmic in the light count with the SATs dominating.
// Three answers, each within one run of this program (the machine is shared, so ratios of
// neighbouring measurements mean more than times):
//   cut_vs_half     cut_ms at N lights over cut_ms at N/2 (same face size, median of N/2's
//                   repetitions): (rounds at N) / (rounds at N/2), 1.17-1.5, when the cut is
//                   logarithmic with a fixed cost per round; 2 when linear
//   device_vs_half  the same for the whole extraction's device time
//   cut_per_round_ms  cut_ms / (ceil(log2(lights / 6)) + 1), the number of splitting rounds: a
//                   flat column across light counts is logarithmic growth
//   sat_fraction    sat_ms / device_ms
// BM_Resample times the resample alone (cubeMapEnergy: env/resample* stages, device ms) per face
// size, beside a clEnqueueCopyBuffer of the map's own bytes in the same iteration
// (resample_vs_copy = resample_ms / copy_ms: a ratio that the machine's load moves less than ms).
// Every benchmark runs one extraction first (kernel compilation, buffer allocation) untimed.
#include <benchmark/benchmark.h>
#include <penumbra/penumbra.hpp>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <exception>
#include <map>
#include <string>
#include <utility>
#include <vector>

using namespace penumbra;

namespace {

struct Setup {
  Context ctx;
  Environment env = builtinEnvironment(1024);  // 1024x512, the center-surround size
};

Setup& setup() {
  static Setup s;
  return s;
}

bool startsWith(const std::string& s, const char* p) { return s.rfind(p, 0) == 0; }

// Runs `extract` once untimed, then per iteration; reports the stage families above.
template <class F>
void timeExtraction(benchmark::State& state, F&& extract) {
  Setup& s = setup();
  s.ctx.resetTimings();
  try {
    extract(s);  // warm-up
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());  // e.g. a size the device's limits refuse
    return;
  }
  std::map<std::string, double> sum;
  double lights = 0;
  for (auto _ : state) {
    s.ctx.resetTimings();
    LightSet set = extract(s);
    lights += double(set.lights.size());
    for (auto& [stage, ms] : s.ctx.stageTimesMs()) {
      // Other stages by their first name component (ambient_ms).
      const std::string family = startsWith(stage, "env/resample")      ? "resample_ms"
                                 : startsWith(stage, "env/sat")         ? "sat_ms"
                                 : startsWith(stage, "extract/median")  ? "cut_ms"
                                 : startsWith(stage, "extract/resolve") ? "resolve_ms"
                                 : startsWith(stage, "extract/greedy")  ? "fit_ms"
                                 : startsWith(stage, "center-surround/")
                                     ? "cs_" + stage.substr(stage.find('/') + 1) + "_ms"
                                     : stage.substr(0, stage.find('/')) + "_ms";
      sum[family] += ms;
      sum["device_ms"] += ms;
    }
  }
  const double n = double(state.iterations());
  for (auto& [family, ms] : sum) state.counters[family] = ms / n;
  state.counters["lights"] = lights / n;
  if (sum["device_ms"] > 0) state.counters["sat_fraction"] = sum["sat_ms"] / sum["device_ms"];
}

// cut_ms and device_ms of every repetition run so far per (face size, light count), for the
// _vs_half ratios against the median of N/2's (Google Benchmark runs a benchmark's repetitions
// before the next one, and medianCutArgs orders the light counts upwards; a median, because one
// slow repetition on the shared machine moves a mean of three by a factor of 3).
struct Runs {
  std::vector<double> cut, device;
};
std::map<std::pair<int, int>, Runs>& medianCutRuns() {
  static std::map<std::pair<int, int>, Runs> m;
  return m;
}
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void BM_MedianCut(benchmark::State& state) {
  MedianCutOptions mo;
  mo.lights = int(state.range(0));
  mo.faceSize = int(state.range(1));
  timeExtraction(state, [&](Setup& s) { return extractMedianCut(s.ctx, s.env, mo); });
  const double rounds = std::ceil(std::log2(std::max(1.0, mo.lights / 6.0))) + 1;
  state.counters["cut_per_round_ms"] = state.counters["cut_ms"] / rounds;
  Runs& mine = medianCutRuns()[{mo.faceSize, mo.lights}];
  mine.cut.push_back(state.counters["cut_ms"]);
  mine.device.push_back(state.counters["device_ms"]);
  auto half = medianCutRuns().find({mo.faceSize, mo.lights / 2});
  if (half != medianCutRuns().end() && !half->second.cut.empty()) {
    state.counters["cut_vs_half"] = state.counters["cut_ms"] / median(half->second.cut);
    state.counters["device_vs_half"] = state.counters["device_ms"] / median(half->second.device);
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) * 6 * mo.faceSize * mo.faceSize);
}

// Greedy fitting (Annen et al. 2008 §4.2) at face size range(0), squares (range(1) = 1, the
// default) or
// rectangles; `lights` is what is kept (GreedyOptions::maxLights, 64), not what was fitted.
void BM_Greedy(benchmark::State& state) {
  GreedyOptions go;
  go.faceSize = int(state.range(0));
  go.square = state.range(1) != 0;
  timeExtraction(state, [&](Setup& s) { return extractGreedy(s.ctx, s.env, go); });
  state.SetItemsProcessed(std::int64_t(state.iterations()) * 6 * go.faceSize * go.faceSize);
}

// Center-surround (Arbree et al. 2005) at working width range(0) (range(0) x range(0)/2; 1024 is
// the map's
// own size, which the issue bounds at 1 s), the default 20 filter sizes.
void BM_CenterSurround(benchmark::State& state) {
  CenterSurroundOptions co;
  co.width = int(state.range(0));
  timeExtraction(state, [&](Setup& s) { return extractCenterSurround(s.ctx, s.env, co); });
  state.SetItemsProcessed(std::int64_t(state.iterations()) * co.width * (co.width / 2));
}

// The ambient residual every method adds (SH9 of the map minus the lights, and by default the
// irradiance map: BM_AmbientMap).
void BM_AmbientResidual(benchmark::State& state) {
  const LightSet lights = extractMedianCut(setup().ctx, setup().env, MedianCutOptions{});
  timeExtraction(state, [&](Setup& s) {
    LightSet set = lights;
    addAmbientResidual(s.ctx, s.env, set);
    return set;
  });
  const Image& eq = setup().env.equirect;
  state.SetItemsProcessed(std::int64_t(state.iterations()) * eq.width * eq.height);
}

// CPU time of the whole process (every OpenCL CPU-device thread too), in ms: on the shared machine
// wall time also counts other processes' time slices.
double processCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return 1e3 * double(t.tv_sec) + 1e-6 * double(t.tv_nsec);
}

// The ambient as Arbree et al.'s (2005) pre-integrated irradiance map
// (kernels/environment/irradiance.cl) at a
// table of range(0) x range(0)/2, on median cut's 32 lights: map_ms is the map's kernels
// (ambient/map-*), split into prefix_ms (the rows' running sums), normals_ms, widths_ms, bands_ms
// (the runs' sums per normal) and table_ms (bands in order, minus the lights), process_cpu_ms the
// whole call's process CPU time (all threads; steady state, the warm-up call left out); sh_ms the
// SH projection every model also runs, and map_to_sh their ratio in the same run.
void BM_AmbientMap(benchmark::State& state) {
  const LightSet lights = extractMedianCut(setup().ctx, setup().env, MedianCutOptions{});
  AmbientOptions ao;
  ao.mapWidth = int(state.range(0));
  ao.mapHeight = int(state.range(0) / 2);
  double mapMs = 0, shMs = 0;
  std::map<std::string, double> kernelMs;
  double cpuMs = 0;
  bool warm = false;
  timeExtraction(state, [&](Setup& s) {
    LightSet set = lights;
    const double cpu0 = processCpuMs();
    addAmbientResidual(s.ctx, s.env, set, ao);
    // not the warm-up call: each kernel's first launch pays the device compiler
    if (!std::exchange(warm, true)) return set;
    cpuMs += processCpuMs() - cpu0;
    for (auto& [stage, ms] : s.ctx.stageTimesMs()) {
      if (startsWith(stage, "ambient/map")) {
        mapMs += ms;
        kernelMs[stage.substr(std::string("ambient/map-").size()) + "_ms"] += ms;
      }
      if (startsWith(stage, "ambient/sh")) shMs += ms;
    }
    return set;
  });
  const double n = double(state.iterations());
  state.counters["map_ms"] = mapMs / n;
  for (auto& [name, ms] : kernelMs) state.counters[name] = ms / n;
  state.counters["sh_ms"] = shMs / n;
  state.counters["process_cpu_ms"] = cpuMs / n;
  if (shMs > 0) state.counters["map_to_sh"] = mapMs / shMs;
  state.SetItemsProcessed(std::int64_t(state.iterations()) * ao.mapWidth * ao.mapHeight);
}

// Equirect -> cube alone at face range(0): splat up to 256 for this 1024-wide map, gather at 512.
void BM_Resample(benchmark::State& state) {
  Setup& s = setup();
  const int m = int(state.range(0));
  const std::vector<float>& px = s.env.equirect.pixels;
  const std::size_t bytes = px.size() * sizeof(float);
  cl::Buffer src = s.ctx.upload(px, "copy source"), dst = s.ctx.buffer(bytes, "copy destination");
  s.ctx.queue().enqueueCopyBuffer(src, dst, 0, 0, bytes);  // first touch of dst
  cubeMapEnergy(s.ctx, s.env, m);                          // warm-up: compilation, buffers
  double resample = 0, copy = 0;
  for (auto _ : state) {
    s.ctx.resetTimings();
    cubeMapEnergy(s.ctx, s.env, m);
    for (auto& [stage, ms] : s.ctx.stageTimesMs())
      if (startsWith(stage, "env/resample")) resample += ms;
    cl::Event ev;
    s.ctx.queue().enqueueCopyBuffer(src, dst, 0, 0, bytes, nullptr, &ev);
    ev.wait();
    copy += double(ev.getProfilingInfo<CL_PROFILING_COMMAND_END>() -
                   ev.getProfilingInfo<CL_PROFILING_COMMAND_START>()) * 1e-6;
  }
  const double n = double(state.iterations());
  state.counters["resample_ms"] = resample / n;
  state.counters["copy_ms"] = copy / n;
  if (copy > 0) state.counters["resample_vs_copy"] = resample / copy;
  state.SetItemsProcessed(std::int64_t(state.iterations()) * 6 * m * m);
}

void medianCutArgs(benchmark::internal::Benchmark* b) {
  b->ArgNames({"lights", "face"});
  for (int face : {64, 128, 256, 512})
    for (int lights : {8, 16, 32, 64, 128, 256}) b->Args({lights, face});
}

}  // namespace

BENCHMARK(BM_Resample)
    ->ArgName("face")
    ->Arg(64)
    ->Arg(128)
    ->Arg(256)
    ->Arg(512)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(5);
BENCHMARK(BM_MedianCut)->Apply(medianCutArgs)->UseRealTime()->Unit(benchmark::kMillisecond)->Iterations(5);
BENCHMARK(BM_Greedy)
    ->ArgsProduct({{64, 128, 256, 512}, {1, 0}})
    ->ArgNames({"face", "square"})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK(BM_CenterSurround)->Arg(512)->Arg(1024)->UseRealTime()->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_AmbientResidual)->UseRealTime()->Unit(benchmark::kMillisecond)->Iterations(5);
BENCHMARK(BM_AmbientMap)->Arg(32)->Arg(64)->Arg(96)->Arg(128)->Arg(256)->UseRealTime()
    ->Unit(benchmark::kMillisecond)->Iterations(5);
BENCHMARK_MAIN();
