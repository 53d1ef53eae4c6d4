// Thread safety (issue 14, README "Thread safety"): four threads share one Context for light
// extraction and rendering, with one shared Renderer and with a Renderer per thread; every result
// must equal the one computed by a single thread. The concurrent runs use a Context of their own,
// made fresh for each test, so that its program cache, scratch buffers and event list start empty
// and are filled while the threads race for them.
#include <gtest/gtest.h>

#include <atomic>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

constexpr int kThreads = 4;

// Runs body(thread, iteration) on kThreads threads, `iterations` times each, the threads released
// together. body returns "" or a description of what went wrong; thrown errors count as failures.
// Returns every failure, so that one assertion names them all.
std::vector<std::string> runConcurrently(int iterations,
                                         const std::function<std::string(int, int)>& body) {
  std::atomic<int> waiting{kThreads};
  std::mutex m;
  std::vector<std::string> failures;
  auto note = [&](const std::string& s) {
    std::lock_guard<std::mutex> lock(m);
    failures.push_back(s);
  };
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      waiting.fetch_sub(1);
      while (waiting.load() > 0) std::this_thread::yield();
      for (int i = 0; i < iterations; ++i) {
        try {
          std::string f = body(t, i);
          if (!f.empty()) note("thread " + std::to_string(t) + ", iteration " + std::to_string(i) +
                               ": " + f);
        } catch (const std::exception& e) {
          note("thread " + std::to_string(t) + " threw: " + e.what());
        }
      }
    });
  for (auto& th : threads) th.join();
  return failures;
}

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size() && i < 8; ++i) s += v[i] + "\n";
  if (v.size() > 8) s += "... and " + std::to_string(v.size() - 8) + " more\n";
  return s;
}

// Job j at thread t, iteration i: on even iterations every thread runs the same job (the same map
// or frame at once), on odd ones each runs a different one.
int jobFor(int t, int i, int jobs) { return (i + (i % 2 ? t : 0)) % jobs; }

std::vector<Environment> maps() {
  std::vector<Environment> envs{builtinEnvironment(256)};
  for (const char* m : kMaps) envs.push_back(loadEnvironment(data(m)));
  return envs;
}

}  // namespace

// Median cut with the ambient residual, greedy fitting and center-surround, over four maps:
// the light sets extracted by four threads at once from one Context equal, number for number
// (LightSet::toJson writes 9 significant digits, which round-trips every float field), those one
// thread extracts. The extraction is deterministic: its sums are fixed-point integers (Kneiphof
// 2017
// §4.1), so equality is exact rather than to a tolerance.
TEST(Threads, ExtractionFromSharedContextEqualsSingleThreaded) {
  const std::vector<Environment> envs = maps();
  std::vector<ExtractOptions> methods(3);
  methods[0].medianCut.faceSize = 64;
  methods[0].medianCut.lights = 16;
  methods[1].method = ExtractionMethod::Greedy;
  methods[1].ambient = false;
  methods[2].method = ExtractionMethod::CenterSurround;
  methods[2].centerSurround.width = 128;
  methods[2].ambient = false;
  struct Job {
    const Environment* env;
    const ExtractOptions* opt;
    std::string expected;
  };
  std::vector<Job> jobs;
  for (const auto& e : envs)
    for (const auto& o : methods) jobs.push_back({&e, &o, extractLights(ctx(), e, o).toJson()});
  // The single-threaded result is repeatable, so a difference below is the threads' doing.
  ASSERT_EQ(extractLights(ctx(), *jobs[0].env, *jobs[0].opt).toJson(), jobs[0].expected);

  Context shared;
  const int n = int(jobs.size());
  auto failures = runConcurrently(n, [&](int t, int i) -> std::string {
    const Job& j = jobs[jobFor(t, i, n)];
    const std::string got = extractLights(shared, *j.env, *j.opt).toJson();
    return got == j.expected ? "" : "light set differs for " + j.env->source;
  });
  EXPECT_TRUE(failures.empty()) << joined(failures);
}

// The public cube-map resampling (the other user of the context's scratch buffers) from four
// threads: every cube equals the single-threaded one bit for bit.
TEST(Threads, CubeMapEnergyFromSharedContextEqualsSingleThreaded) {
  const std::vector<Environment> envs = maps();
  std::vector<std::vector<float>> expected;
  for (const auto& e : envs) expected.push_back(cubeMapEnergy(ctx(), e, 32).pixels);
  Context shared;
  const int n = int(envs.size());
  auto failures = runConcurrently(4 * n, [&](int t, int i) -> std::string {
    const int j = jobFor(t, i, n);
    return cubeMapEnergy(shared, envs[j], 32).pixels == expected[j]
               ? ""
               : "cube map differs for " + envs[j].source;
  });
  EXPECT_TRUE(failures.empty()) << joined(failures);
}

namespace {

// Frames at 64x36 of a ground with two blockers above it (six triangles: the bitmask's list
// building costs about 1.5 s a frame on the 3,176-triangle built-in scene here): two techniques
// (MSSM4, the default; the bitmask, whose per-frame lists are the renderer's largest state) x two
// light sets x two cameras.
struct FrameJob {
  RenderOptions opt;
  const LightSet* lights;
  Camera camera;
  std::vector<float> expected;
};

struct FrameJobs {
  Scene scene;
  Environment env = builtinEnvironment(128);
  std::vector<LightSet> lightSets;
  std::vector<FrameJob> jobs;

  FrameJobs() {
    scene.meshes = {planarQuad("ground", -2, 2, -2, 2, 0),
                     planarQuad("low", -0.8f, 0.2f, -0.5f, 0.5f, 0.4f),
                     planarQuad("high", 0.1f, 0.9f, -0.9f, 0.1f, 0.9f)};    MedianCutOptions mc;
    mc.faceSize = 32;
    for (int n : {4, 8}) {
      mc.lights = n;
      lightSets.push_back(extractMedianCut(ctx(), env, mc));
    }
    Camera near = frameCamera(scene, 64.0f / 36.0f), far = near;
    for (int k = 0; k < 3; ++k) far.eye[k] = far.target[k] + 1.5f * (far.eye[k] - far.target[k]);
    for (ShadowTechnique s : {ShadowTechnique::MSSM4, ShadowTechnique::Bitmask})
      for (const LightSet& l : lightSets)
        for (const Camera& c : {near, far}) {
          FrameJob j;
          j.opt.width = 64;
          j.opt.height = 36;
          j.opt.shadowMapSize = 64;
          j.opt.shadows = s;
          j.lights = &l;
          j.camera = c;
          jobs.push_back(j);
        }
    // One thread, one renderer, in job order.
    Renderer r(ctx());
    for (auto& j : jobs) j.expected = r.render(scene, j.camera, *j.lights, env, j.opt).image.pixels;
  }

  std::string check(Renderer& r, int job) const {
    const FrameJob& j = jobs[job];
    const Frame f = r.render(scene, j.camera, *j.lights, env, j.opt);
    return f.image.pixels == j.expected
               ? ""
               : std::string("frame differs: ") + toString(j.opt.shadows) + ", " +
                     std::to_string(j.lights->lights.size()) + " lights";
  }
};

const FrameJobs& frameJobs() {
  static const FrameJobs jobs;
  return jobs;
}

}  // namespace

// The frames are deterministic on one thread: rendered again, in reverse order and by another
// renderer, each equals its first rendering bit for bit (so the comparisons below can be exact).
// And they show what is compared: shadows (the frame without them differs) that depend on the
// technique.
TEST(Threads, FramesAreRepeatableOnOneThread) {
  const FrameJobs& fj = frameJobs();
  Renderer r(ctx());
  for (int j = int(fj.jobs.size()) - 1; j >= 0; --j) EXPECT_EQ(fj.check(r, j), "") << "job " << j;
  const FrameJob& first = fj.jobs[0];
  RenderOptions none = first.opt;
  none.shadows = ShadowTechnique::None;
  EXPECT_NE(r.render(fj.scene, first.camera, *first.lights, fj.env, none).image.pixels,
            first.expected);
  ASSERT_EQ(fj.jobs[4].opt.shadows, ShadowTechnique::Bitmask);
  EXPECT_NE(fj.jobs[4].expected, first.expected);
}

// One Renderer used by four threads at once: render() serializes them, and each gets exactly the
// frame it would get alone.
TEST(Threads, SharedRendererEqualsSingleThreaded) {
  const FrameJobs& fj = frameJobs();
  Context shared;
  Renderer r(shared);
  const int n = int(fj.jobs.size());
  auto failures = runConcurrently(n, [&](int t, int i) { return fj.check(r, jobFor(t, i, n)); });
  EXPECT_TRUE(failures.empty()) << joined(failures);
}

// A Renderer per thread, all four on one Context: the frames run concurrently and each equals the
// single-threaded one.
TEST(Threads, RendererPerThreadOnSharedContextEqualsSingleThreaded) {
  const FrameJobs& fj = frameJobs();
  Context shared;
  std::vector<std::unique_ptr<Renderer>> renderers;
  for (int t = 0; t < kThreads; ++t) renderers.push_back(std::make_unique<Renderer>(shared));
  const int n = int(fj.jobs.size());
  auto failures = runConcurrently(
      n, [&](int t, int i) { return fj.check(*renderers[t], jobFor(t, i, n)); });
  EXPECT_TRUE(failures.empty()) << joined(failures);
}

// The event list under four launching threads, past Context::kEventBound so that launches fold
// events while others append, with stageTimesMs() read meanwhile: the list stays bounded and every
// stage is reported, in the order of its first launch.
TEST(Threads, StageTimingsUnderConcurrentLaunches) {
  Context shared;
  std::vector<cl_uint> v(4, PB_DEPTH_EMPTY);
  cl::Buffer front = shared.upload(v, "front"), back = shared.upload(v, "back");
  const int per = int(Context::kEventBound / kThreads) + 200;
  std::atomic<std::size_t> most{0};
  auto failures = runConcurrently(1, [&](int t, int) -> std::string {
    cl::Kernel k = shared.kernel("raster.cl", "combine_front_back");  // a kernel per thread
    const std::string stage = "threads/" + std::to_string(t);
    for (int i = 0; i < per; ++i) {
      shared.launchWith(stage, k, cl::NDRange(4), cl::NullRange, front, back, cl_int(4));
      std::size_t held = shared.heldEvents(), seen = most.load();
      while (held > seen && !most.compare_exchange_weak(seen, held)) {
      }
      if (t == 0 && i % 50 == 0) shared.stageTimesMs();  // reads the list others append to
    }
    return "";
  });
  EXPECT_TRUE(failures.empty()) << joined(failures);
  EXPECT_LE(most.load(), Context::kEventBound);
  const auto times = shared.stageTimesMs();
  ASSERT_EQ(times.size(), std::size_t(kThreads));
  for (const auto& [name, ms] : times) {
    EXPECT_EQ(name.rfind("threads/", 0), 0u) << name;
    EXPECT_GE(ms, 0.0) << name;
  }
}
