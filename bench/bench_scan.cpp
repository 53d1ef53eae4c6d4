// Summed-area table throughput against the device's own copy bandwidth, measured in the same run.
// A minimal SAT reads and writes each element once, so it is counted as 2 x image bytes, the same
// traffic as a clEnqueueCopyBuffer of the image; fraction_of_copy_bw = SAT bytes/s / copy bytes/s
// says how close the launches come to that bound. Times are device time from profiling events
// (the sum of the stage kernels' durations), reported through UseManualTime.
//
// Cases: square images of 256^2 to 2048^2, one at a time, and the renderer's own batch (32 shadow
// maps of 256^2, long4 moments). Each runs with the device's default method (on CPUs the banded
// sweep; for float4 with its sums in double, on devices with fp64) and, as "passes", with the row
// and column passes forced, the baseline the banded method is measured against in the same run.
//
//   ./bench/bench_scan [--benchmark_filter=...]   (PENUMBRA_DEVICE picks the device)
#include <benchmark/benchmark.h>

#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/context.hpp"
#include "penumbra/scan.hpp"

namespace {

using penumbra::Context;
using penumbra::ScanType;

std::unique_ptr<Context> g_ctx;
std::map<std::size_t, double> g_copyBytesPerSec;  // image bytes -> copy bandwidth (read + write)

double eventSeconds(const cl::Event& ev) {
  ev.wait();
  auto t0 = ev.getProfilingInfo<CL_PROFILING_COMMAND_START>();
  auto t1 = ev.getProfilingInfo<CL_PROFILING_COMMAND_END>();
  return double(t1 - t0) * 1e-9;
}

double copySeconds(const cl::Buffer& src, cl::Buffer& dst, std::size_t bytes) {
  cl::Event ev;
  g_ctx->queue().enqueueCopyBuffer(src, dst, 0, 0, bytes, nullptr, &ev);
  return eventSeconds(ev);
}

cl::Buffer zeroed(std::size_t bytes, const char* what) {
  cl::Buffer b = g_ctx->buffer(bytes, what);
  const cl_int zero = 0;
  g_ctx->fill(b, &zero, sizeof zero, bytes, what);
  return b;
}

// Copy bandwidth for `bytes`, measured before any benchmark runs so that the SAT benchmarks have
// a bound in the same process even when a filter leaves BM_Copy out.
double measureCopy(std::size_t bytes) {
  cl::Buffer src = zeroed(bytes, "copy source"), dst = zeroed(bytes, "copy destination");
  copySeconds(src, dst, bytes);  // warm-up: first-touch allocation on the device
  double total = 0;
  int reps = 0;
  while (reps < 5 || (total < 0.3 && reps < 200)) {
    total += copySeconds(src, dst, bytes);
    ++reps;
  }
  return 2.0 * double(bytes) * reps / total;
}

// Registered just before the SAT benchmarks of the same size, so it runs first and its figure
// (rather than the quicker one taken at start-up) is the one they divide by.
void BM_Copy(benchmark::State& state, std::size_t bytes) {
  cl::Buffer src = zeroed(bytes, "copy source"), dst = zeroed(bytes, "copy destination");
  copySeconds(src, dst, bytes);
  double total = 0;
  for (auto _ : state) {
    double s = copySeconds(src, dst, bytes);
    state.SetIterationTime(s);
    total += s;
  }
  const double moved = 2.0 * double(bytes) * double(state.iterations());
  state.SetBytesProcessed(int64_t(moved));
  state.counters["GBps"] = total > 0 ? moved / total * 1e-9 : 0;
  if (total > 0) g_copyBytesPerSec[bytes] = moved / total;
}

void BM_Sat(benchmark::State& state, ScanType type, int n, int batch, bool passes) {
  const std::size_t bytes = std::size_t(n) * n * batch * penumbra::scanElementBytes(type);
  penumbra::ScanTuning tune;
  if (passes) tune.bands = 0;
  // Zeros stay zeros under repeated in-place scans: no overflow or infinities between iterations.
  cl::Buffer data = zeroed(bytes, "sat bench image");
  penumbra::summedAreaTable(*g_ctx, data, type, n, n, batch, "sat", tune);  // warm-up: builds
  g_ctx->finish();
  double total = 0;
  for (auto _ : state) {
    g_ctx->resetTimings();
    penumbra::summedAreaTable(*g_ctx, data, type, n, n, batch, "sat", tune);
    double s = 0;
    for (auto& [stage, ms] : g_ctx->stageTimesMs()) s += ms * 1e-3;
    state.SetIterationTime(s);
    total += s;
  }
  g_ctx->resetTimings();
  const double moved = 2.0 * double(bytes) * double(state.iterations());
  state.SetBytesProcessed(int64_t(moved));
  state.counters["GBps"] = total > 0 ? moved / total * 1e-9 : 0;
  state.counters["fraction_of_copy_bw"] = total > 0 ? moved / total / g_copyBytesPerSec[bytes] : 0;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  try {
    g_ctx = std::make_unique<Context>();
    std::fprintf(stderr, "device: %s (%s)\n", g_ctx->info().name.c_str(),
                 g_ctx->info().platform.c_str());
    struct Case {
      ScanType type;
      const char* name;
      int n, batch;
    };
    const Case cases[] = {{ScanType::Float4, "float4", 256, 1},  {ScanType::Float4, "float4", 1024, 1},
                          {ScanType::Float4, "float4", 2048, 1}, {ScanType::Long4, "long4", 256, 1},
                          {ScanType::Long4, "long4", 1024, 1},   {ScanType::Long4, "long4", 2048, 1},
                          {ScanType::Long4, "long4", 256, 32}};
    for (const Case& c : cases) {
      std::size_t bytes = std::size_t(c.n) * c.n * c.batch * penumbra::scanElementBytes(c.type);
      if (!g_copyBytesPerSec.count(bytes)) {
        g_copyBytesPerSec[bytes] = measureCopy(bytes);
        benchmark::RegisterBenchmark(("BM_Copy/" + std::to_string(bytes >> 10) + "KiB").c_str(),
                                     BM_Copy, bytes)
            ->UseManualTime()
            ->Unit(benchmark::kMillisecond);
      }
      for (bool passes : {false, true}) {
        std::string name = std::string("BM_Sat/") + c.name + "/" + std::to_string(c.n);
        if (c.batch > 1) name += "x" + std::to_string(c.batch);
        if (passes) name += "/passes";
        benchmark::RegisterBenchmark(name.c_str(), BM_Sat, c.type, c.n, c.batch, passes)
            ->UseManualTime()
            ->Unit(benchmark::kMillisecond);
      }
    }
    benchmark::RunSpecifiedBenchmarks();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_scan: %s\n", e.what());
    return 1;
  }
  benchmark::Shutdown();
  return 0;
}
