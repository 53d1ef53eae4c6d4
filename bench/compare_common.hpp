// Helpers shared by the comparison programs (compare_techniques, compare_bitmask).
#pragma once
#include <penumbra/penumbra.hpp>

#include <algorithm>
#include <ctime>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::bench {

inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

// Device time of the stages that belong to shadowing (everything but extraction, G-buffer, shade).
inline double shadowStageMs(const std::vector<std::pair<std::string, double>>& t) {
  double ms = 0;
  for (auto& [name, v] : t) {
    if (name == "total" || name.rfind("env/", 0) == 0 || name.rfind("extract/", 0) == 0 ||
        name.rfind("gbuffer/", 0) == 0 || name == "shade")
      continue;
    ms += v;
  }
  return ms;
}

// CPU time of every thread of this process, ms. On a CPU device (PoCL runs its work-groups on
// threads of this process) it is the frame's work itself, which other processes loading the
// machine stretch in wall-clock time but not in CPU time.
inline double processCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

// One warm-up render (kernels compile on first use; skipped when warmUp is false), then `runs`
// renders; the returned frame is the last one with every stage time (and "total") replaced by its
// median over the runs; *cpuMs (when given) gets the median process CPU time per render.
inline Frame renderTimed(Context& ctx, Renderer& renderer, const Scene& scene, const Camera& cam,
                         const LightSet& lights, const Environment& env, const RenderOptions& ro,
                         int runs, bool warmUp = true, double* cpuMs = nullptr) {
  if (warmUp) renderer.render(scene, cam, lights, env, ro);
  Frame f;
  std::map<std::string, std::vector<double>> stageRuns;
  std::vector<double> cpu;
  for (int run = 0; run < runs; ++run) {
    ctx.resetTimings();
    const double c0 = processCpuMs();
    f = renderer.render(scene, cam, lights, env, ro);
    cpu.push_back(processCpuMs() - c0);
    for (auto& [name, v] : f.timingsMs) stageRuns[name].push_back(v);
  }
  if (cpuMs) *cpuMs = median(cpu);
  for (auto& [name, v] : f.timingsMs) v = median(stageRuns[name]);
  return f;
}

}  // namespace penumbra::bench
