// kernels/render/raster.cl against Embree: the device camera G-buffer covers exactly the pixels
// whose primary ray hits geometry in the reference (same rays, scene.hpp's cameraRayDirection), on
// awkward image sizes. And against a reference that shares no code with the rasterizer: the
// depth of known triangles at each texel's centre (orthographic light views, the shadow maps'
// path) and the world position at each pixel's centre (a perspective camera G-buffer), both
// solved in double precision here from the pb_view definition (kernels/common/shared.h), with a
// negative control for each (a plane moved by 1e-3, texel corners instead of centres).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <tuple>
#include <vector>

#include "common.hpp"
#include "core/device_kind.hpp"
#include "render/device_scene.hpp"
#include "render/rasterizer.hpp"
#include "support/scoped_env.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

void expectSameCoverage(const Scene& scene, int w, int h) {
  Environment env = builtinEnvironment(16);
  Camera cam = frameCamera(scene, float(w) / h);
  LightSet none;
  RenderOptions ro;
  ro.width = w;
  ro.height = h;
  ro.shadows = ShadowTechnique::None;
  Renderer r(ctx());
  Frame f = r.render(scene, cam, none, env, ro);
  ReferenceOptions rf;
  rf.width = w;
  rf.height = h;
  rf.spp = 1;
  Image ref = referenceLights(scene, cam, none, env, rf);
  int differ = 0, geometry = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      bool a = f.image.at(x, y, 3) > 0.5f, b = ref.at(x, y, 3) > 0.5f;
      differ += a != b;
      geometry += b;
    }
  // Both cast the same rays; they may disagree only where a ray grazes a silhouette within float
  // rounding (Moller-Trumbore here, Embree's watertight test there).
  EXPECT_LE(differ, std::max(0, (w * h) / 1000)) << w << "x" << h << ": " << differ
                                                   << " pixels differ of " << geometry;
}

}  // namespace

TEST(Raster, CoverageMatchesEmbreeOnAwkwardSizes) {
  Scene scene = builtinScene();
  for (auto [w, h] : {std::pair{1, 1}, {1, 37}, {37, 1}, {33, 17}, {161, 91}, {640, 360}})
    expectSameCoverage(scene, w, h);
}

TEST(Raster, CoverageMatchesEmbreeOnLoadedMeshes) {
  expectSameCoverage(loadScene(data("meshes/good/spider.obj")), 200, 120);
  expectSameCoverage(loadScene(data("meshes/good/WusonOBJ.obj"), {false}), 200, 120);
}

namespace {

using dvec::D3;
using dvec::cross;
using dvec::dot;
using dvec::unitD;
D3 sub(D3 a, D3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
D3 add(D3 a, D3 b, double s) { return {a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]}; }

// Two tilted triangles, the second partly in front of the first as seen from above and from the
// camera below: each texel takes the nearer.
struct Tri {
  D3 a, b, c;
};
const std::vector<Tri> kTris = {
    {{-1.1, 0.2, -0.9}, {1.2, 0.9, -1.0}, {-0.2, -0.4, 1.3}},
    {{-0.3, 1.2, -0.2}, {0.8, 0.7, 0.1}, {0.1, 1.5, 0.9}},
};

Scene triScene(double shiftY = 0) {
  Scene s;
  for (std::size_t i = 0; i < kTris.size(); ++i) {
    Mesh m;
    m.name = "tri" + std::to_string(i);
    for (const D3& p : {kTris[i].a, kTris[i].b, kTris[i].c})
      m.positions.push_back({float(p[0]), float(p[1] + shiftY), float(p[2])});
    m.triangles = {{0, 1, 2}};
    s.meshes.push_back(m);
  }
  return s;
}

// Nearest hit of the ray o + t d (t > 0) with the triangles, in double: the plane's t, then the
// point's barycentrics from signed areas (not Moller-Trumbore). `margin` is the smallest
// barycentric of the winning hit, or of the nearest miss's (so near-edge texels can be skipped).
double nearestHit(D3 o, D3 d, double shiftY, double* margin) {
  double best = INFINITY;
  *margin = INFINITY;
  for (const Tri& t0 : kTris) {
    const Tri t = {add(t0.a, {0, 1, 0}, shiftY), add(t0.b, {0, 1, 0}, shiftY),
                   add(t0.c, {0, 1, 0}, shiftY)};
    const D3 n = cross(sub(t.b, t.a), sub(t.c, t.a));
    const double nd = dot(n, d);
    if (nd == 0) continue;
    const double tt = dot(n, sub(t.a, o)) / nd;
    if (tt <= 0) continue;
    const D3 p = add(o, d, tt);
    const double nn = dot(n, n);
    const double w0 = dot(cross(sub(t.b, p), sub(t.c, p)), n) / nn;
    const double w1 = dot(cross(sub(t.c, p), sub(t.a, p)), n) / nn;
    const double w2 = 1 - w0 - w1;
    const double m = std::min({w0, w1, w2});
    *margin = std::min(*margin, std::fabs(m));
    if (m >= 0 && tt < best) best = tt;
  }
  return best;
}

// The orthographic view of a light: near-plane centre `origin`, looking along `fwd`, half-extent
// `half`, S x S texels (pb_view's definition: texel (x, y) is the ray from origin + sx half right
// + sy half up, sx = 2 (x + 1/2) / S - 1, sy = 1 - 2 (y + 1/2) / S, along forward).
struct View {
  D3 origin, fwd, right, up;
  double halfW, halfH;
  int w, h;
  bool ortho;
  pb_view pb() const {
    pb_view v{};
    for (int k = 0; k < 3; ++k) {
      v.origin[k] = float(origin[k]);
      v.forward[k] = float(fwd[k]);
      v.right[k] = float(right[k]);
      v.up[k] = float(up[k]);
    }
    v.right[3] = float(halfW);
    v.up[3] = float(halfH);
    v.width = w;
    v.height = h;
    v.ortho = ortho ? 1 : 0;
    return v;
  }
  // The reference ray through continuous texel coordinates (px, py).
  void ray(double px, double py, D3* o, D3* d) const {
    const double sx = 2 * px / w - 1, sy = 1 - 2 * py / h;
    if (ortho) {
      *o = add(add(origin, right, sx * halfW), up, sy * halfH);
      *d = fwd;
    } else {
      *o = origin;
      *d = unitD(add(add(fwd, right, sx * halfW), up, sy * halfH));
    }
  }
};

View makeView(D3 eye, D3 target, D3 upHint, double halfW, double halfH, int w, int h, bool ortho) {
  View v;
  v.origin = eye;
  v.fwd = unitD(sub(target, eye));
  v.right = unitD(cross(v.fwd, upHint));
  v.up = cross(v.right, v.fwd);
  v.halfW = halfW;
  v.halfH = halfH;
  v.w = w;
  v.h = h;
  v.ortho = ortho;
  return v;
}

struct DepthFit {
  double maxErr = 0;
  int hits = 0, coverageWrong = 0, compared = 0;
};

// Texels whose centre lies within kEdge (barycentric) of a triangle's edge are skipped: there the
// float kernel may fall either way.
constexpr double kEdge = 1e-4;

DepthFit compareDepths(const std::vector<float>& t, const View& v, double shiftY, double offset) {
  DepthFit f;
  for (int y = 0; y < v.h; ++y)
    for (int x = 0; x < v.w; ++x) {
      D3 o, d;
      v.ray(x + offset, y + offset, &o, &d);
      double margin;
      const double ref = nearestHit(o, d, shiftY, &margin);
      if (margin < kEdge) continue;
      ++f.compared;
      const float got = t[std::size_t(y) * v.w + x];
      if (std::isinf(ref) || std::isinf(got)) {
        f.coverageWrong += std::isinf(ref) != std::isinf(got);
        continue;
      }
      ++f.hits;
      f.maxErr = std::max(f.maxErr, std::fabs(got - ref));
    }
  return f;
}

// The rasterizer on the test's own scene and views: depth maps for orthographic views (the
// shadow maps' path, ShadowFrame::depth's encoding: the float's bits, PB_DEPTH_EMPTY = +inf where
// nothing).
struct RasterStage {
  detail::DeviceScene scene{ctx()};
  detail::BufferPool pool{ctx()};
  detail::Rasterizer raster{ctx(), pool};
  RasterStage(const Scene& s, int mapSize) {
    scene.update(s);
    raster.setFrame(scene, mapSize, false);
  }
};

std::vector<float> depthMap(const Scene& scene, const View& v) {
  RasterStage st(scene, v.w);
  detail::Rasterizer& r = st.raster;
  cl::Buffer out = ctx().buffer(std::size_t(v.w) * v.h * 4, "test depth map");
  r.depthMaps({v.pb()}, out, "test");
  std::vector<cl_uint> bits = ctx().download<cl_uint>(out, std::size_t(v.w) * v.h, "test depth map");
  std::vector<float> t(bits.size());
  for (std::size_t i = 0; i < bits.size(); ++i) std::memcpy(&t[i], &bits[i], 4);  // +inf if empty
  return t;
}

// Distance from the view's origin to the G-buffer position along the reference ray (inf where the
// G-buffer has no geometry).
std::vector<float> gbufferDistances(const Scene& scene, const View& v) {
  RasterStage st(scene, 1);
  detail::Rasterizer& r = st.raster;
  cl::Buffer cam = ctx().upload(std::vector<pb_view>{v.pb()}, "test camera view");
  const detail::DeviceGBuffer g = r.gbuffer(cam, v.w, v.h, 0.0f);
  const std::size_t n = std::size_t(v.w) * v.h;
  std::vector<cl_float4> p = ctx().download<cl_float4>(g.position, n, "test positions");
  std::vector<float> t(n);
  for (int y = 0; y < v.h; ++y)
    for (int x = 0; x < v.w; ++x) {
      const cl_float4& q = p[std::size_t(y) * v.w + x];
      D3 o, d;
      v.ray(x + 0.5, y + 0.5, &o, &d);
      // the distance to the stored point, signed along the ray
      t[std::size_t(y) * v.w + x] =
          q.s[3] == 0 ? INFINITY : float(dot(sub({q.s[0], q.s[1], q.s[2]}, o), d));
    }
  return t;
}

}  // namespace

// Orthographic depth maps of two tilted triangles (the nearer wins) on awkward sizes, a light
// looking down obliquely. Measured: max |t - t_double| 9.4e-7 (t ~ 3, float rounding), no coverage
// difference away from edges. Bound 1e-4 (200x). Negative controls: the same maps against the
// scene raised by 1e-3, and against texel corners instead of centres (a depth slope of ~0.5 per
// unit over texels of >= 0.03 at S <= 33 moves depth by >= 0.007), must exceed it.
TEST(Raster, DepthMapsMatchDoublePrecisionPlanesAtTexelCentres) {
  const Scene scene = triScene();
  for (int S : {1, 7, 33, 130}) {
    SCOPED_TRACE("S = " + std::to_string(S));
    const View v = makeView({0.9, 3.0, 0.6}, {0, 0.4, 0.1}, {0, 0, 1}, 1.6, 1.6, S, S, true);
    const std::vector<float> t = depthMap(scene, v);
    const DepthFit f = compareDepths(t, v, 0, 0.5);
    const DepthFit raised = compareDepths(t, v, 1e-3, 0.5);
    const DepthFit corners = compareDepths(t, v, 0, 0.0);
    std::printf("[ raster   ] ortho %dx%d: %d texels compared, %d hits, max |t - t_double| %.2e, "
                "coverage wrong %d; raised 1e-3: %.2e; corners: %.2e (%d wrong)\n",
                S, S, f.compared, f.hits, f.maxErr, f.coverageWrong, raised.maxErr,
                corners.maxErr, corners.coverageWrong);
    EXPECT_EQ(f.coverageWrong, 0);
    EXPECT_LT(f.maxErr, 1e-4);
    if (S > 1) EXPECT_GT(f.hits, S * S / 6);  // the triangles cover ~23% of the view
    if (f.hits > 0) EXPECT_GT(raised.maxErr, 1e-4);
    if (S > 1) EXPECT_TRUE(corners.maxErr > 1e-4 || corners.coverageWrong > 0);
  }
}

// The perspective camera G-buffer's positions on awkward sizes (1x1, 1xN, Nx1, odd): their
// distance along the test's own ray through each pixel centre against the double-precision hit.
// Measured: max 1.2e-6 (distances ~3). Bound 1e-4; the raised scene must exceed it.
TEST(Raster, GBufferPositionsMatchDoublePrecisionHits) {
  const Scene scene = triScene();
  for (auto [w, h] : {std::pair{1, 1}, {1, 37}, {37, 1}, {61, 23}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    const double ty = std::tan(25 * M_PI / 180);
    View v = makeView({1.5, 2.6, 2.2}, {0.05, 0.4, 0.05}, {0, 1, 0}, ty * w / h, ty, w, h, false);
    const std::vector<float> t = gbufferDistances(scene, v);
    const DepthFit f = compareDepths(t, v, 0, 0.5);
    const DepthFit raised = compareDepths(t, v, 1e-3, 0.5);
    std::printf("[ raster   ] camera %dx%d: %d pixels compared, %d hits, max |t - t_double| %.2e, "
                "coverage wrong %d; raised 1e-3: %.2e\n",
                w, h, f.compared, f.hits, f.maxErr, f.coverageWrong, raised.maxErr);
    EXPECT_EQ(f.coverageWrong, 0);
    EXPECT_LT(f.maxErr, 1e-4);
    EXPECT_GE(f.hits, 1);
    if (f.hits > 0) EXPECT_GT(raised.maxErr, 1e-4);
  }
}

// Where shadow tests start (src/scene/shadow_offset.hpp): the G-buffer's position is the hit moved
// by the offset along the camera-facing geometric normal, which the G-buffer also stores; nothing
// else moves. Two frames of the tilted pair, offset 0 and 1e-3.
TEST(Raster, GBufferPositionsSitTheShadowOffsetOffTheSurface) {
  const Scene scene = triScene();
  const int w = 61, h = 23;
  const double ty = std::tan(25 * M_PI / 180);
  View v = makeView({1.5, 2.6, 2.2}, {0.05, 0.4, 0.05}, {0, 1, 0}, ty * w / h, ty, w, h, false);
  RasterStage st(scene, 1);
  cl::Buffer cam = ctx().upload(std::vector<pb_view>{v.pb()}, "test camera view");
  const std::size_t n = std::size_t(w) * h;
  std::vector<cl_float4> p[2], g[2];
  for (int k = 0; k < 2; ++k) {
    const detail::DeviceGBuffer gb = st.raster.gbuffer(cam, w, h, k == 0 ? 0.0f : 1e-3f);
    p[k] = ctx().download<cl_float4>(gb.position, n, "test positions");
    g[k] = ctx().download<cl_float4>(gb.geometricNormal, n, "test geometric normals");
  }
  int hits = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t i = std::size_t(y) * w + x;
      ASSERT_EQ(p[0][i].s[3], p[1][i].s[3]) << x << "," << y;
      for (int c = 0; c < 3; ++c) ASSERT_EQ(g[0][i].s[c], g[1][i].s[c]) << x << "," << y;
      if (p[0][i].s[3] == 0) {
        for (int c = 0; c < 3; ++c) ASSERT_EQ(p[0][i].s[c], p[1][i].s[c]) << x << "," << y;
        continue;
      }
      ++hits;
      D3 o, d;
      v.ray(x + 0.5, y + 0.5, &o, &d);
      double towards = 0;
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(p[1][i].s[c] - p[0][i].s[c], 1e-3 * g[0][i].s[c], 1e-6) << x << "," << y;
        towards += g[0][i].s[c] * d[c];
      }
      EXPECT_LE(towards, 0.0) << x << "," << y;  // the normal faces the camera: lifted towards it
    }
  EXPECT_GT(hits, 100);
}

namespace {

// Depth of `nv` views (vb, n texels in all) by raster_views, the CPU form with one work-item per
// view, with face culling `cull`; with `ids`, the triangle ids kept with the depth too (the
// shadow maps of contact shadows from the lights' side). clear: the kernel empties the maps
// itself (as the renderer runs it), on buffers filled with a pattern that no map holds;
// otherwise they are filled empty first.
std::vector<cl_uint> rasterViews(const detail::DeviceScene& ds, const cl::Buffer& vb, int nv,
                                 std::size_t n, int cull, std::vector<cl_uint>* ids = nullptr,
                                 bool clear = false) {
  cl::Kernel k = ctx().kernel("raster.cl", "raster_views",
                              "-DRASTER_ROW_SIMD" + detail::simdLoopOption(ctx()));
  cl::Buffer d = ctx().buffer(n * 4, "test depth"), id = ctx().buffer(n * 4, "test ids");
  const cl_uint junk = 0x00000007u;  // a tiny positive depth and a small id: nearer than any hit
  const cl_uint emptyDepth = clear ? junk : PB_DEPTH_EMPTY, emptyId = clear ? junk : PB_ID_EMPTY;
  ctx().fill(d, &emptyDepth, 4, n * 4, "test depth");
  ctx().fill(id, &emptyId, 4, n * 4, "test ids");
  ctx().launchWith("test/raster", k, cl::NDRange(nv), cl::NDRange(1), ds.positionBuffer(),
                   ds.triangleBuffer(), cl_int(ds.triangleCount()), vb, cl_int(nv), d,
                   cl_int(cull), id, cl_int(ids ? 1 : 0), cl_int(clear ? 1 : 0));
  if (ids) *ids = ctx().download<cl_uint>(id, n, "test ids");
  return ctx().download<cl_uint>(d, n, "test depth");
}

}  // namespace

// The rasterizer's row spans (raster.cl, outline_row_span) skip only pixels the ray test would
// have missed: depth and triangle-id passes equal, bit for bit, those of the same kernel built to
// test each triangle's whole bounding box (-DRASTER_FULL_BOX), for the built-in scene's 2,600
// triangles and the tilted pair, in orthographic light views of awkward sizes seen along several
// directions and in perspective cameras (one inside the scene, whose triangles cross the near
// plane and keep the box). The same for the CPU form of orthographic rows (-DRASTER_ROW_SIMD: SIMD
// ray tests, then the atomics), whose scalar operations round as the vector ones do on PoCL; on
// another driver (oclgrind: a different library rounding of dot() and cross()) its depths may
// differ in the last bits, and there they are compared to 1e-6 relative.
TEST(Raster, RowSpansChangeNoPixel) {
  const bool pocl =
      ctx().info().platform.find("Portable Computing Language") != std::string::npos;
  struct Case {
    Scene scene;
    std::vector<View> views;
  };
  std::vector<Case> cases;
  {
    Case c{builtinScene(0.4f), {}};
    for (int S : {1, 37, 130, 256})
      for (D3 eye : {D3{3.0, 6.0, 2.0}, D3{-5.0, 1.0, 0.5}, D3{0.1, 8.0, 0.1}})
        c.views.push_back(makeView(eye, {0, 0, 0}, {0, 1, 0}, 4.0, 4.0, S, S, true));
    const double ty = std::tan(30 * M_PI / 180);
    c.views.push_back(makeView({4.0, 2.5, 5.0}, {0, 0.5, 0}, {0, 1, 0}, ty * 97 / 41, ty, 97, 41,
                               false));
    c.views.push_back(makeView({1.5, 0.6, 0.7}, {0, 0.5, 0}, {0, 1, 0}, ty * 64 / 48, ty, 64, 48,
                               false));  // from inside the sphere: clipped triangles
    cases.push_back(c);
  }
  {
    Case c{triScene(), {}};
    for (int S : {7, 33}) c.views.push_back(makeView({0.3, 3.0, 0.4}, {0, 0, 0}, {0, 1, 0}, 1.6,
                                                     1.6, S, S, true));
    cases.push_back(c);
  }
  std::size_t compared = 0, covered = 0;
  for (const Case& c : cases) {
    detail::DeviceScene ds(ctx());
    ds.update(c.scene);
    const int ntris = ds.triangleCount();
    for (const View& v : c.views) {
      const std::size_t n = std::size_t(v.w) * v.h;
      cl::Buffer vb = ctx().upload(std::vector<pb_view>{v.pb()}, "test view");
      std::vector<cl_uint> depth[3], ids[3];
      for (int full : {0, 1, 2}) {
        const std::string options[3] = {"", "-DRASTER_FULL_BOX",
                                         "-DRASTER_ROW_SIMD" + detail::simdLoopOption(ctx())};
        cl::Kernel k = ctx().kernel("raster.cl", "raster_triangles", options[full]);
        cl::Buffer d = ctx().buffer(n * 4, "test depth"), id = ctx().buffer(n * 4, "test ids");
        const cl_uint emptyDepth = PB_DEPTH_EMPTY, emptyId = PB_ID_EMPTY;
        ctx().fill(d, &emptyDepth, 4, n * 4, "test depth");
        ctx().fill(id, &emptyId, 4, n * 4, "test ids");
        for (int pass : {0, 1})
          ctx().launchWith("test/raster", k, cl::NDRange(ntris, 3, 1), cl::NullRange,
                           ds.positionBuffer(), ds.triangleBuffer(), cl_int(ntris), vb, cl_int(3),
                           cl_int(pass), d, id, cl_int(0));
        depth[full] = ctx().download<cl_uint>(d, n, "test depth");
        ids[full] = ctx().download<cl_uint>(id, n, "test ids");
      }
      // raster_views (one work-item per view, plain loads and stores): the depths of
      // -DRASTER_ROW_SIMD's raster_triangles, bit for bit on any driver (the same ray tests)
      const std::vector<cl_uint> owned = rasterViews(ds, vb, 1, n, 0);
      SCOPED_TRACE(std::to_string(v.w) + "x" + std::to_string(v.h) + (v.ortho ? " ortho" : " camera"));
      EXPECT_EQ(owned, depth[2]) << "raster_views";
      // raster_views keeping ids with the depth (one pass, SIMD rows for orthographic views):
      // the same depths, and the ids of the two-pass kernels (the least index at the nearest
      // depth) wherever its depth is theirs to the bit
      std::vector<cl_uint> ownedIds, clearedIds;
      EXPECT_EQ(rasterViews(ds, vb, 1, n, 0, &ownedIds), depth[2]) << "raster_views with ids";
      // the same, with the kernel emptying the maps it draws (the renderer's way)
      EXPECT_EQ(rasterViews(ds, vb, 1, n, 0, nullptr, true), depth[2]) << "raster_views, clear";
      EXPECT_EQ(rasterViews(ds, vb, 1, n, 0, &clearedIds, true), depth[2])
          << "raster_views with ids, clear";
      EXPECT_EQ(clearedIds, ownedIds) << "raster_views with ids, clear";
      std::size_t idMismatch = 0, idCompared = 0;
      for (std::size_t i = 0; i < n; ++i)
        if (owned[i] == depth[1][i]) {
          ++idCompared;
          idMismatch += ownedIds[i] != ids[1][i];
        }
      EXPECT_EQ(idMismatch, 0u) << "raster_views with ids";
      if (pocl) EXPECT_EQ(idCompared, n);
      EXPECT_EQ(depth[0], depth[1]);
      EXPECT_EQ(ids[0], ids[1]);
      if (pocl) {
        EXPECT_EQ(depth[2], depth[1]) << "RASTER_ROW_SIMD";
        EXPECT_EQ(ids[2], ids[1]) << "RASTER_ROW_SIMD";
      } else {
        // elsewhere: depths within 1e-6 relative, and at most 0.1% of the pixels otherwise (an
        // edge pixel hit or missed). The ids must agree where the depths are the same bits. Where
        // they differ in the last bits the id may be missing: the id pass runs the per-pixel loop,
        // whose t then does not equal the SIMD loop's stored depth. Only the camera's view gets
        // ids in a frame, and it is a perspective view, which never takes the SIMD loop.
        std::size_t off = 0;
        for (std::size_t i = 0; i < n; ++i) {
          float a, b;
          std::memcpy(&a, &depth[2][i], 4);
          std::memcpy(&b, &depth[1][i], 4);
          const bool sameBits = depth[2][i] == depth[1][i];
          const bool close = sameBits || std::fabs(a - b) <= 1e-6f * std::fabs(b);
          off += !close || (sameBits && ids[2][i] != ids[1][i]);
        }
        EXPECT_LE(off, n / 1000) << "RASTER_ROW_SIMD";
      }
      compared += n;
      for (cl_uint x : depth[1]) covered += x != PB_DEPTH_EMPTY;
    }
  }
  std::printf("[ raster   ] row spans against whole boxes: %zu pixels compared, %zu covered\n",
              compared, covered);
  EXPECT_GT(covered, compared / 4);  // the views see the scenes
}

namespace {

// Depth maps of `views` (all S x S) through raster_triangles (the atomics; 3 row stripes) and
// through raster_views (a work-item per view), both as CPU forms, with face culling `cull`.
// At least minCovered texels must be covered.
void expectViewsKernelMatches(const Scene& scene, const std::vector<View>& views, int cull,
                              std::size_t minCovered) {
  detail::DeviceScene ds(ctx());
  ds.update(scene);
  const int ntris = ds.triangleCount(), nv = int(views.size());
  std::vector<pb_view> pv;
  for (const View& v : views) pv.push_back(v.pb());
  cl::Buffer vb = ctx().upload(pv, "test views");
  const std::size_t n = std::size_t(views[0].w) * views[0].h * nv;
  std::vector<cl_uint> out[2];
  {
    cl::Kernel k = ctx().kernel("raster.cl", "raster_triangles",
                                "-DRASTER_ROW_SIMD" + detail::simdLoopOption(ctx()));
    cl::Buffer d = ctx().buffer(n * 4, "test depth");
    const cl_uint emptyDepth = PB_DEPTH_EMPTY;
    ctx().fill(d, &emptyDepth, 4, n * 4, "test depth");
    ctx().launchWith("test/raster", k, cl::NDRange(ntris, 3, nv), cl::NullRange,
                     ds.positionBuffer(), ds.triangleBuffer(), cl_int(ntris), vb, cl_int(3),
                     cl_int(0), d, d, cl_int(cull));
    out[0] = ctx().download<cl_uint>(d, n, "test depth");
  }
  out[1] = rasterViews(ds, vb, nv, n, cull, nullptr, true);
  std::size_t covered = 0, differ = 0;
  for (std::size_t i = 0; i < n; ++i) {
    covered += out[0][i] != PB_DEPTH_EMPTY;
    if (out[0][i] != out[1][i] && differ++ < 5)
      ADD_FAILURE() << "view " << i / (n / nv) << " texel " << i % (n / nv) << ": "
                    << out[1][i] << " vs atomics " << out[0][i] << " (cull " << cull << ")";
  }
  EXPECT_EQ(differ, 0u);
  EXPECT_GE(covered, minCovered) << "cull " << cull;  // the views see the scene
}

std::vector<View> lightViews(int S) {
  std::vector<View> v;
  for (D3 eye : {D3{3.0, 6.0, 2.0}, D3{-5.0, 1.0, 0.5}, D3{0.1, 8.0, 0.1}, D3{2.0, 3.0, -4.0},
                 D3{-1.0, 5.0, -1.0}})
    v.push_back(makeView(eye, {0, 0, 0}, {0, 1, 0}, 4.0, 4.0, S, S, true));
  return v;
}

}  // namespace

// The CPU form that gives each light view one writer (raster_views, no atomics) keeps the same
// nearest depths as the atomics of raster_triangles: five views of an odd 37^2 and of 130^2 (rows
// longer than the 16-pixel SIMD loop) at once, every face, front faces, back faces.
TEST(Raster, ViewsKernelMatchesTheAtomics) {
  const Scene scene = builtinScene(0.4f);
  for (int S : {37, 130})
    for (int cull : {0, 1, 2})  // the back faces cover less: the ground has none seen from above
      expectViewsKernelMatches(scene, lightViews(S), cull, std::size_t(5 * S * S) / (cull == 2 ? 20 : 4));
}

// The same on the simulator, small: races (there must be none: each view has one writer).
TEST(OclgrindRaster, ViewsKernel) { expectViewsKernelMatches(triScene(), lightViews(9), 0, 10); }

namespace {

// The camera's depth and triangle ids for `scene` seen through v, with the CPU forms of the
// kernels on (raster_bands: one writer per band of rows, one pass) or off (raster_triangles' two
// passes of atomics), through Rasterizer::gbuffer.
struct CameraBuffers {
  std::vector<cl_uint> depth, ids;
  std::vector<cl_float4> planes[4];  // position, shading normal, geometric normal, albedo
  // with the CPU forms: the same planes from gbuffer_resolve_batch with every pixel sent to its
  // fallback (GB_LOW above every squared length: gbuffer_pixel resolves each pixel again)
  std::vector<cl_float4> fallback[4];
};
CameraBuffers cameraBuffers(const Scene& scene, const View& v, bool cpuForms) {
  const test::ScopedEnv env("PENUMBRA_CPU_BATCHING", std::string(cpuForms ? "on" : "off"));
  CameraBuffers out;
  {
    RasterStage st(scene, 1);
    cl::Buffer cam = ctx().upload(std::vector<pb_view>{v.pb()}, "test camera view");
    ctx().resetTimings();
    const detail::DeviceGBuffer g = st.raster.gbuffer(cam, v.w, v.h, 0.0f);
    // the path asked for ran: the bands, or the two passes of atomics
    bool bands = false, passes = false;
    for (const auto& [stage, ms] : ctx().stageTimesMs()) {
      bands = bands || stage == "gbuffer/raster";
      passes = passes || stage == "gbuffer/ids";
    }
    EXPECT_EQ(bands, cpuForms);
    EXPECT_EQ(passes, !cpuForms);
    const std::size_t n = std::size_t(v.w) * v.h;
    out.depth = ctx().download<cl_uint>(g.depth, n, "test camera depth");
    out.ids = ctx().download<cl_uint>(g.ids, n, "test camera ids");
    const cl::Buffer* planes[4] = {&g.position, &g.normal, &g.geometricNormal, &g.albedo};
    for (int p = 0; p < 4; ++p)
      out.planes[p] = ctx().download<cl_float4>(*planes[p], n, "test camera G-buffer");
    if (cpuForms) {
      cl::Kernel k =
          ctx().kernel("raster.cl", "gbuffer_resolve_batch",
                       "-DGB_GROUP=64 -DGB_LOW=0x1p127f" + detail::simdLoopOption(ctx()));
      cl::Buffer fb[4];
      for (auto& b : fb) b = ctx().buffer(n * sizeof(cl_float4), "test fallback plane");
      ctx().launchWith("test fallback", k, cl::NDRange((std::size_t(v.w) + 63) / 64, v.h),
                       cl::NullRange, st.scene.positionBuffer(), st.scene.normalBuffer(),
                       st.scene.triangleBuffer(), st.scene.albedoBuffer(), cam, g.ids, fb[0],
                       fb[1], fb[2], fb[3], cl_float(0.0f));
      for (int p = 0; p < 4; ++p)
        out.fallback[p] = ctx().download<cl_float4>(fb[p], n, "test fallback plane");
    }
  }
  return out;
}

// Whether two planes hold the same bits (tolerance 0), or values within `tolerance` of each other
// relative to the larger magnitude (at least 1).
bool samePlanes(const std::vector<cl_float4>& a, const std::vector<cl_float4>& b,
                float tolerance = 0.0f) {
  if (a.size() != b.size()) return false;
  if (tolerance == 0.0f)
    return a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(cl_float4)) == 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    for (int c = 0; c < 4; ++c) {
      const float x = a[i].s[c], y = b[i].s[c];
      if (!(std::fabs(x - y) <= tolerance * std::max({1.0f, std::fabs(x), std::fabs(y)})))
        return false;
    }
  return true;
}

// The built-in scene with every triangle of its first mesh twice (the copy after all the others,
// so its indices are larger): where the two are hit their t is the same float, and only the least
// index may win the pixel.
Scene sceneWithTwins() {
  Scene s = builtinScene(0.4f);
  s.meshes.push_back(s.meshes[0]);
  s.meshes.back().name += " (twin)";
  return s;
}

// resolveTolerance: how far gbuffer_resolve_batch's planes may be from gbuffer_resolve's (0: the
// same bits, as on PoCL, whose normalize(v) is v * rsqrt(dot(v, v)); oclgrind's rounds otherwise).
void expectCameraBandsMatch(const Scene& scene, int w, int h, std::size_t minCovered,
                            float resolveTolerance = 0.0f) {
  SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
  const double ty = std::tan(25 * M_PI / 180);
  const View v = makeView({4.0, 3.0, 6.0}, {0.0, 0.5, 0.0}, {0, 1, 0}, ty * w / h, ty, w, h, false);
  const CameraBuffers a = cameraBuffers(scene, v, false), b = cameraBuffers(scene, v, true);
  std::size_t covered = 0, differ = 0;
  for (std::size_t i = 0; i < a.depth.size(); ++i) {
    covered += a.ids[i] != PB_ID_EMPTY;
    if ((a.depth[i] != b.depth[i] || a.ids[i] != b.ids[i]) && differ++ < 5)
      ADD_FAILURE() << "pixel " << i << ": depth " << b.depth[i] << " id " << b.ids[i]
                    << " vs the atomics' " << a.depth[i] << " id " << a.ids[i];
  }
  EXPECT_EQ(differ, 0u);
  EXPECT_GE(covered, minCovered);  // the camera sees the scene
  // the G-buffer's planes: gbuffer_resolve_batch against gbuffer_resolve, and its fallback
  for (int p = 0; p < 4; ++p) {
    EXPECT_TRUE(samePlanes(a.planes[p], b.planes[p], resolveTolerance))
        << "plane " << p << ": the two resolves";
    EXPECT_TRUE(samePlanes(a.planes[p], b.fallback[p])) << "plane " << p << ": the fallback";
  }
}

}  // namespace

// The CPU form of the camera's G-buffer passes (raster_bands: bands of rows, one writer each,
// depth and id in one pass) keeps the depths and the triangle ids of the two passes of atomics,
// and the resolve's (gbuffer_resolve_batch, 64 pixels of a row a work-item, and its per-pixel
// fallback) the four planes of gbuffer_resolve, bit for bit: 1 x 1, one column, one row, an odd
// frame, and one taller than the bands and wider than a work-group, on a scene where a mesh is
// there twice (equal depths: the least index wins).
// Negative control: keeping the last triangle at an equal depth instead (<= for < in
// raster_triangle's pass 2) fails on the twins.
TEST(Raster, CameraBandsMatchTheTwoPasses) {
  const Scene scene = sceneWithTwins();
  for (auto [w, h, minCovered] : {std::tuple{1, 1, 1}, {1, 37, 10}, {37, 1, 1}, {97, 41, 1000},
                                  {200, 130, 8000}})
    expectCameraBandsMatch(scene, w, h, std::size_t(minCovered));
}

// The same on the simulator, small: races (there must be none: each band has one writer). The
// simulator's normalize() rounds differently from PoCL's v * rsqrt(dot(v, v)), which the
// resolve's CPU form computes: its planes are compared within 1e-5 of the larger magnitude
// (measured: at most 1.9e-6, on the positions, whose hit distance carries the ray direction's
// last bit), its fallback, which calls normalize(), bit for bit.
TEST(OclgrindRaster, CameraBands) { expectCameraBandsMatch(sceneWithTwins(), 13, 9, 20, 1e-5f); }
