// The default frame against the Embree reference at equal error (issue 17's criterion, measured in
// one process): built-in scene and sky, 320x180, everything else at penumbra's defaults.
//
// Truth: referenceEnvironmentWithNoise at 4096 spp, seed 11, with its own relative noise s_t (the
// RMSE of its two half-sample images over 2, over the mean: ReferenceImage::relativeNoise). It is
// cached as an EXR (noise in its header) in PENUMBRA_BENCH_CACHE, or else in this build's
// bench/cache, and made on the first run (about a minute on 2 cores). The file is named by
// truthKey (include/penumbra/evaluate.hpp), the digest `penumbra evaluate`'s cache uses: a change
// of scene, camera, map, size, spp or seed makes a new truth.
//
// A reference at N spp has noise s_t sqrt(4096 / N) of its own, independent of the truth's, so its
// error against the truth is sqrt(s_t^2 4096 / N + s_t^2). Set equal to the frame's error e:
//   N = 4096 s_t^2 / (e^2 - s_t^2)
// (no N where e <= s_t: the frame would be within the truth's noise, and the benchmark says so).
// The reference's time at N is a + b N, fitted from runs at 16 and 128 spp in this process (it
// is linear in the samples past its fixed part: scene set-up and the BVH).
//
// Counters:
//   frame_error      e, the default frame's relative RMSE against the truth
//   truth_noise      s_t
//   equal_spp        N
//   reference_ms     the reference's time at N (fitted)
//   frame_ms         the default frame, warm, extraction included (the benchmark's iterations)
//   vs_reference     reference_ms / frame_ms: how many times faster penumbra reaches that error
#include <benchmark/benchmark.h>
#include <penumbra/evaluate.hpp>
#include <penumbra/penumbra.hpp>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

using namespace penumbra;

namespace {

constexpr int kWidth = 320, kHeight = 180, kTruthSpp = 4096;
constexpr std::uint64_t kTruthSeed = 11;

std::string cacheDir() {
  const char* own = std::getenv("PENUMBRA_BENCH_CACHE");
  return own && *own ? own : PENUMBRA_BENCH_CACHE_DIR;
}

struct Truth {
  Image image;
  double noise = 0;
};

// The cached truth, or a new one written to the cache.
Truth truth(const Scene& scene, const Camera& camera, const Environment& env) {
  ReferenceOptions ro;
  ro.width = kWidth;
  ro.height = kHeight;
  ro.spp = kTruthSpp;
  ro.seed = kTruthSeed;
  const std::string path =
      cacheDir() + "/" + truthKey(scene, camera, env, nullptr, ro) + "-environment.exr";
  if (std::filesystem::exists(path)) {
    const ImageAttributes a = readImageAttributes(path);
    const auto n = a.find(kRelativeNoiseAttribute);
    if (n != a.end()) return {readImage(path), n->second};
  }
  ReferenceImage r = referenceEnvironmentWithNoise(scene, camera, env, ro);
  std::filesystem::create_directories(cacheDir());
  writeImage(path, r.image, 1.0f, {{kRelativeNoiseAttribute, r.relativeNoise}});
  return {std::move(r.image), r.relativeNoise};
}

double referenceSeconds(const Scene& scene, const Camera& camera, const Environment& env,
                        int spp) {
  ReferenceOptions ro;
  ro.width = kWidth;
  ro.height = kHeight;
  ro.spp = spp;
  ro.seed = 13;
  const auto t0 = std::chrono::steady_clock::now();
  const Image img = referenceEnvironment(scene, camera, env, ro);
  benchmark::DoNotOptimize(img.pixels.data());
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void BM_DefaultFrameVsReference(benchmark::State& state) {
  Context ctx;
  const Scene scene = builtinScene();
  const Environment env = builtinEnvironment();
  const Camera camera = frameCamera(scene, float(kWidth) / float(kHeight));
  const Truth t = truth(scene, camera, env);
  Renderer renderer(ctx);
  RenderOptions opt;
  opt.width = kWidth;
  opt.height = kHeight;
  // warm-up (kernels built or taken from the cache), and the frame whose error is measured
  const Frame first = renderer.render(scene, camera, extractLights(ctx, env), env, opt);
  const double e = compareImages(first.image, t.image).relativeRmse;
  double seconds = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const Frame f = renderer.render(scene, camera, extractLights(ctx, env), env, opt);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    benchmark::DoNotOptimize(f.image.pixels.data());
  }
  const double frameS = seconds / double(state.iterations());
  state.counters["frame_error"] = e;
  state.counters["truth_noise"] = t.noise;
  state.counters["frame_ms"] = frameS * 1e3;
  if (!(e > t.noise)) {
    state.SkipWithError("the frame's error is within the truth's own noise: no equal-error spp");
    return;
  }
  const double n = kTruthSpp * t.noise * t.noise / (e * e - t.noise * t.noise);
  const double t16 = referenceSeconds(scene, camera, env, 16);
  const double t128 = referenceSeconds(scene, camera, env, 128);
  const double perSample = (t128 - t16) / (128 - 16), fixed = t16 - 16 * perSample;
  const double refS = fixed + perSample * n;
  state.counters["equal_spp"] = n;
  state.counters["reference_ms"] = refS * 1e3;
  state.counters["vs_reference"] = refS / frameS;
}

}  // namespace

BENCHMARK(BM_DefaultFrameVsReference)->Unit(benchmark::kMillisecond)->Iterations(5);

BENCHMARK_MAIN();
