// The light count to an error target (extraction.hpp lightSetProbeError, ExtractOptions::
// targetError): a cheap prediction of the error a light set's exact visibility leaves against its
// map under occlusion, and the search for the smallest median-cut count that meets a target.
//
// Why probes: the lights plus the ambient residual reproduce the map's unshadowed irradiance on
// every normal (the residual is defined as what the caps miss, so the irradiance error on the
// sphere of normals is near zero at any count). What a light count gets wrong appears only once
// something blocks part of the sky: the caps stand in for regions of a different shape, and the
// residual is shaded unshadowed. So the predictor blocks the sky with cones and compares what
// passes.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "common/shared.h"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/extraction.hpp"
#include "core/number_text.hpp"

namespace penumbra {

namespace {

using V3 = std::array<double, 3>;

double lum(const double rgb[3]) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }
double dot(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Point i of n on the unit sphere (spherical Fibonacci), deterministic.
V3 fibonacci(int i, int n) {
  const double golden = 3.14159265358979323846 * (3.0 - std::sqrt(5.0));
  const double y = 1.0 - (2.0 * i + 1.0) / n;
  const double r = std::sqrt(std::max(0.0, 1.0 - y * y));
  return {r * std::cos(golden * i), y, r * std::sin(golden * i)};
}

// A direction with its radiant energy (luminance x solid angle).
struct Ray {
  V3 dir;
  double energy;
};

// The map as at most 128 x 64 bins, each at its energy-weighted mean direction (a sun keeps its
// place inside its bin), the rotation applied.
std::vector<Ray> mapRays(const Environment& env) {
  const int W = env.equirect.width, H = env.equirect.height;
  const int bw = std::min(W, 128), bh = std::min(H, 64);
  std::vector<double> e(size_t(bw) * bh, 0.0);
  std::vector<V3> d(size_t(bw) * bh, V3{0, 0, 0});
  const float shift = env.rotationColumns();
  for (int t = 0; t < H; ++t) {
    const double dw = env.texelSolidAngle(t);
    for (int s = 0; s < W; ++s) {
      const double rgb[3] = {env.equirect.at(s, t, 0), env.equirect.at(s, t, 1),
                             env.equirect.at(s, t, 2)};
      const double en = lum(rgb) * dw;
      float x, y, z;
      pb_equirect_dir(pb_env_world_column(s, shift, W) + 0.5f, t + 0.5f, float(W), float(H), &x,
                      &y, &z);
      const size_t b = size_t(t * bh / H) * bw + size_t(s * bw / W);
      e[b] += en;
      // Weighted by energy plus a little solid angle, so a black bin still has a direction.
      const double w = en + 1e-12 * dw;
      d[b][0] += w * x, d[b][1] += w * y, d[b][2] += w * z;
    }
  }
  std::vector<Ray> rays;
  rays.reserve(e.size());
  for (size_t b = 0; b < e.size(); ++b) {
    const double len = std::sqrt(dot(d[b], d[b]));
    if (e[b] <= 0 || len <= 0) continue;
    rays.push_back({{d[b][0] / len, d[b][1] / len, d[b][2] / len}, e[b]});
  }
  return rays;
}

// Each light as 32 samples (lightSamples: its shape, and its texture when it has one), the
// samples' energies summing to the light's power.
std::vector<Ray> lightRays(const LightSet& set) {
  std::vector<Ray> rays;
  for (const AreaLight& l : set.lights) {
    const double p[3] = {l.power[0], l.power[1], l.power[2]};
    const std::vector<LightSample> s = lightSamples(l, 32);
    double sum = 0;
    for (const LightSample& x : s) sum += x.weight;
    if (sum <= 0) continue;
    for (const LightSample& x : s)
      rays.push_back({{x.dir[0], x.dir[1], x.dir[2]}, lum(p) * x.weight / sum});
  }
  return rays;
}

// Irradiance on normal n from the rays outside the blocking cone (axis c, cosine cosC).
double passed(const std::vector<Ray>& rays, const V3& n, const V3& c, double cosC) {
  double sum = 0;
  for (const Ray& r : rays) {
    const double cn = dot(r.dir, n);
    if (cn <= 0 || dot(r.dir, c) > cosC) continue;
    sum += r.energy * cn;
  }
  return sum;
}

// lightSetProbeError with the map's rays given (the search bins the map once).
double probeError(const std::vector<Ray>& mapR, const LightSet& set) {
  const std::vector<Ray> lightR = lightRays(set);
  // 64 receiver normals; per normal 16 cone axes spread over its upper hemisphere (the sphere's
  // Fibonacci points folded into it) at two sizes, 20 and 45 degrees half-angle: small blockers
  // (a limb, a leg) and large ones (a body, a wall's corner) seen from the receiver.
  const int normals = 64, axes = 16;
  const double cosSizes[2] = {std::cos(20.0 * 3.14159265358979323846 / 180.0),
                              std::cos(45.0 * 3.14159265358979323846 / 180.0)};
  double sumSq = 0, sumTruth = 0;
  long count = 0;
  for (int i = 0; i < normals; ++i) {
    const V3 n = fibonacci(i, normals);
    const std::array<double, 3> amb = set.ambientIrradiance(
        {float(n[0]), float(n[1]), float(n[2])});
    const double ambient = lum(amb.data());
    for (int k = 0; k < axes; ++k) {
      V3 c = fibonacci(k, axes);
      if (dot(c, n) < 0) c = {-c[0], -c[1], -c[2]};
      for (double cosC : cosSizes) {
        const double truth = passed(mapR, n, c, cosC);
        const double model = passed(lightR, n, c, cosC) + ambient;
        sumSq += (model - truth) * (model - truth);
        sumTruth += truth;
        ++count;
      }
    }
  }
  if (sumTruth <= 0) return 0.0;  // a black map: nothing to get wrong
  return std::sqrt(sumSq / double(count)) / (sumTruth / double(count));
}

void checkMap(const Environment& env) {
  if (env.equirect.width <= 0 || env.equirect.height <= 0)
    badInput("lightSetProbeError: the environment map is empty");
}

}  // namespace

double lightSetProbeError(const Environment& env, const LightSet& set) {
  checkMap(env);
  return probeError(mapRays(env), set);
}

LightSet extractToTargetError(Context& ctx, const Environment& env, const ExtractOptions& opt,
                              LightCountSearch* search) {
  if (opt.method != ExtractionMethod::MedianCut)
    badInput(std::string("ExtractOptions.targetError: the light count is chosen for median-cut "
                         "only, not ") + toString(opt.method));
  if (!(opt.targetError > 0) || !std::isfinite(opt.targetError))
    badInput("ExtractOptions.targetError must be a finite number > 0, got " +
             detail::numberText(opt.targetError));
  if (opt.medianCut.lights < 1) badInput("MedianCutOptions.lights (the most lights) must be >= 1");
  // Median cut cannot cut more regions than the cube has texels: the search stops there.
  const std::int64_t m = opt.medianCut.faceSize;
  const int most = int(std::min<std::int64_t>(opt.medianCut.lights, std::max<std::int64_t>(1, 6 * m * m)));
  checkMap(env);
  const std::vector<Ray> mapR = mapRays(env);
  LightCountSearch s;
  ExtractOptions o = opt;
  o.targetError = 0;
  LightSet best;
  auto attempt = [&](int n) {
    o.medianCut.lights = n;
    LightSet set = extractLights(ctx, env, o);
    const double e = probeError(mapR, set);
    s.tried.push_back(LightCountTry{n, int(set.lights.size()), e});
    return std::make_pair(std::move(set), e);
  };
  // Doubling from 4 lights until the prediction meets the target, then halving the interval
  // between the last count that missed and the first that met (the prediction falls with the
  // count in every map measured, though not strictly; the search takes the first count it finds).
  int lo = 0, n = std::min(4, most);
  for (;;) {
    auto [set, e] = attempt(n);
    if (e <= opt.targetError) {
      best = std::move(set);
      s.predicted = e;
      s.reached = true;
      break;
    }
    if (n == most) {
      best = std::move(set);
      s.predicted = e;
      s.reached = false;
      break;
    }
    lo = n;
    n = std::min(2 * n, most);
  }
  int hi = n;
  while (s.reached && hi - lo > std::max(1, hi / 8)) {
    const int mid = (lo + hi) / 2;
    auto [set, e] = attempt(mid);
    if (e <= opt.targetError) {
      hi = mid;
      best = std::move(set);
      s.predicted = e;
    } else {
      lo = mid;
    }
  }
  s.lights = hi;
  if (search) *search = s;
  return best;
}

}  // namespace penumbra
