// Area approximation (Ying et al. 2002, Ying, Tang, Dong, §2): a convex polygon light sampled at
// its
// vertices and along its edges, one orthographic depth map per sample direction, and per receiver
// the visible area S_e of the light estimated from the samples' point visibilities and the
// boundary's crossing points (kernels/shadows/area.cl); visibility = S_e / S_a.
//
// Lights are directional, so the polygon lives on the sphere of directions; its edges are great
// arcs. The geometry is done in the light's gnomonic plane (the tangent plane at unit distance
// along the light's centre direction c, d -> (d.ex, d.ey) / (d.c)), where great arcs are straight
// segments and the shadow boundary of a straight occluder edge is a straight line (the directions
// that graze the edge from the receiver span a plane through the origin: a great circle). So the
// paper's planar construction holds exactly there, and the samples "along an edge" are evenly
// spaced on the straight gnomonic segment, which puts them exactly on the great arc. The lit area
// itself is measured on the sphere, by the irradiance it sends the receiver (Lambert's formula,
// kernels/shadows/area.cl), not by its gnomonic area, which would weigh a light's rim (1 + tan^2
// alpha)^(-3/2) times its centre (0.95 at 10 degrees, 0.46 at 40).
//
// Cap lights (what median cut, greedy and center-surround extract) become a regular K-gon
// (AreaApproxOptions::capVertices) in the gnomonic plane, area-matched: its circumradius is
// tan(alpha) sqrt(2 pi / (K sin(2 pi / K))), so that S_a equals the cap's gnomonic disc area
// pi tan^2(alpha) (the gnomonic plane's disc is the cap). An inscribed K-gon would shrink every
// penumbra (by up to 1 - cos(pi/K), 7.6% at K = 8); the area-matched one lies within +5.4% / -2.6%
// of the circle at K = 8.
#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "penumbra/error.hpp"
#include "penumbra/lights.hpp"
#include "shadows/shadow_options.hpp"
#include "shadows/shadow_params.h"
#include "shadows/shadow_pass.hpp"
#include "core/vec3.hpp"

namespace penumbra::detail {
namespace {

constexpr int kMaxSamples = 64;  // kernels/shadows/area.cl's AREA_MAX_SAMPLES: visibilities in one
                                 // ulong

}  // namespace

void validate(const AreaApproxOptions& o) {
  checkRange("RenderOptions.areaApprox.edgeSamples", o.edgeSamples, 0, 15);
  checkRange("RenderOptions.areaApprox.capVertices", o.capVertices, 3, 16);
  checkRange("RenderOptions.areaApprox.taps", o.taps, 0, 64);
}

std::vector<std::array<float, 2>> areaLightOutline(const AreaLight* light, const pb_light& frame,
                                                   int capVertices);
std::vector<std::array<float, 2>> areaBoundarySamples(const std::vector<std::array<float, 2>>& outline,
                                                      int edgeSamples);

// The light's boundary in its gnomonic plane (axes ex, ey of `frame`, centre frame.dir):
// polygon vertices, or the area-matched K-gon of a cap; counter-clockwise in (ex, ey).
std::vector<std::array<float, 2>> areaLightOutline(const AreaLight* light, const pb_light& frame,
                                                   int capVertices) {
  V3 c = xyz(frame.dir), ex = xyz(frame.ex), ey = xyz(frame.ey);
  std::vector<std::array<float, 2>> q;
  if (light && light->shape == LightShape::Polygon && light->vertices.size() >= 3) {
    for (const V3& v : light->vertices) {
      float w = dot(v, c);
      if (!(w > 1e-3f))
        badInput("area-approx: a polygon light's vertex is 90 degrees or more from its centre");
      q.push_back({dot(v, ex) / w, dot(v, ey) / w});
    }
  } else {
    const double kPi = 3.14159265358979323846;
    const double cosA = std::clamp(double(frame.dir[3]), 1e-3, 1.0);
    const double tanA = std::sqrt(std::max(0.0, 1.0 - cosA * cosA)) / cosA;
    const int K = capVertices;
    const double R = tanA * std::sqrt(2 * kPi / (K * std::sin(2 * kPi / K)));
    for (int i = 0; i < K; ++i)
      q.push_back({float(R * std::cos(2 * kPi * i / K)), float(R * std::sin(2 * kPi * i / K))});
  }
  double area = 0;
  for (std::size_t i = 0; i < q.size(); ++i) {
    const auto& a = q[i];
    const auto& b = q[(i + 1) % q.size()];
    area += double(a[0]) * b[1] - double(a[1]) * b[0];
  }
  if (area < 0) std::reverse(q.begin(), q.end());
  return q;
}

// Boundary samples: each vertex, then `edgeSamples` evenly spaced points of its edge to the next
// vertex (straight in the gnomonic plane, hence on the great arc).
std::vector<std::array<float, 2>> areaBoundarySamples(const std::vector<std::array<float, 2>>& outline,
                                                      int edgeSamples) {
  std::vector<std::array<float, 2>> s;
  const std::size_t n = outline.size();
  for (std::size_t i = 0; i < n; ++i) {
    const auto& a = outline[i];
    const auto& b = outline[(i + 1) % n];
    for (int j = 0; j <= edgeSamples; ++j) {
      float t = float(j) / float(edgeSamples + 1);
      s.push_back({a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])});
    }
  }
  return s;
}

namespace {

class AreaApproxPass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    const AreaApproxOptions& ao = f.opt.areaApprox;
    validate(ao);
    const int nl = int(f.lights.size()), S = f.mapSize;

    std::vector<pb_light> frames;
    std::vector<cl_float2> q;
    std::vector<area_range> ranges;
    for (int l = 0; l < nl; ++l) {
      const AreaLight* al =
          f.areaLights && std::size_t(l) < f.areaLights->size() ? &(*f.areaLights)[l] : nullptr;
      auto outline = areaLightOutline(al, f.lights[l], ao.capVertices);
      auto samples = areaBoundarySamples(outline, ao.edgeSamples);
      if (int(samples.size()) > kMaxSamples)
        badInput("area-approx: light " + std::to_string(l) + " has " + std::to_string(outline.size()) +
                 " vertices x " + std::to_string(ao.edgeSamples + 1) + " samples per edge = " +
                 std::to_string(samples.size()) + " boundary samples, more than " +
                 std::to_string(kMaxSamples) + "; lower RenderOptions.areaApprox.edgeSamples");
      ranges.push_back({cl_int(frames.size()), cl_int(samples.size())});
      V3 c = xyz(f.lights[l].dir), ex = xyz(f.lights[l].ex), ey = xyz(f.lights[l].ey);
      for (const auto& s : samples) {
        V3 d;
        for (int a = 0; a < 3; ++a) d[a] = c[a] + s[0] * ex[a] + s[1] * ey[a];
        frames.push_back(sampleFrame(f.lights[l], normalize(d)));
        q.push_back(cl_float2{{s[0], s[1]}});
      }
    }
    cl::Buffer& frameBuf = f.pool.upload("area-approx sample lights", frames);
    cl::Buffer& qBuf = f.pool.upload("area-approx gnomonic samples", q);
    cl::Buffer& rangeBuf = f.pool.upload("area-approx ranges", ranges);

    // Whole lights per batch (a receiver needs all of a light's maps at once), at least one.
    const std::size_t mapBytes = std::size_t(S) * S * sizeof(cl_uint) * (f.opt.frontBackFaces ? 2 : 1);
    const std::size_t fit = std::max<std::size_t>(1, ao.batchBytes / mapBytes);
    std::size_t most = 0;
    cl::Kernel k = f.ctx.kernel("area.cl", "area_visibility");
    for (int l0 = 0; l0 < nl;) {
      int l1 = l0 + 1;
      while (l1 < nl && std::size_t(ranges[l1].first + ranges[l1].count - ranges[l0].first) <= fit) ++l1;
      const int base = ranges[l0].first, count = ranges[l1 - 1].first + ranges[l1 - 1].count - base;
      most = std::max(most, std::size_t(count));
      std::vector<pb_view> views;
      for (int i = base; i < base + count; ++i) views.push_back(orthoView(frames[i], S));
      cl::Buffer& maps =
          f.pool.buffer("area-approx sample maps", std::max(most, std::size_t(count)) * S * S * sizeof(cl_uint));
      f.rasterizeDepth(views, maps, "area-approx");
      f.ctx.launchWith("area-approx/visibility", k, cl::NDRange(f.pixels, l1 - l0), cl::NullRange,
                       f.gpos, f.gnrm, f.ggeo, f.lightBuffer, frameBuf, qBuf, rangeBuf, maps,
                       cl_int(S), cl_int(base), cl_int(l0), cl_int(f.pixels),
                       cl_float(f.opt.shadow.depthBias), cl_int(ao.taps), f.vis);
      l0 = l1;
    }
    heldBytesPerTexel_ = nl ? double(most) * mapBytes / (double(S) * S * nl) : 0;
  }
  bool usesShadowMaps() const override { return false; }
  std::size_t bytesPerTexel(const RenderOptions& opt) const override {
    if (heldBytesPerTexel_ > 0) return std::size_t(std::ceil(heldBytesPerTexel_));
    return std::size_t(opt.areaApprox.capVertices) * (opt.areaApprox.edgeSamples + 1) * sizeof(cl_uint);
  }

 private:
  double heldBytesPerTexel_ = 0;
};

}  // namespace

std::unique_ptr<ShadowPass> makeAreaApproxPass() { return std::make_unique<AreaApproxPass>(); }

}  // namespace penumbra::detail
