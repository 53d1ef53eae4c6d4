// Bent normals at light silhouettes (Sintorn et al. 2008 §4.3, RenderOptions::bentNormals): the
// per-vertex
// I_bend kernel against a plain C++ loop on awkward meshes, and the frame on the built-in scene's
// smooth sphere lit by one small light: black on every light-back-facing triangle, continuous
// across the terminator (where bitmask-hard alone jumps), unchanged where every face around a
// triangle faces the light.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/bent_normals.hpp"
#include "scene/shadow_offset.hpp"
#include "shadows/bitmask.hpp"
#include "common.hpp"

using namespace penumbra;
using penumbra::test::ctx;

namespace {

using V = std::array<float, 3>;

V sub(V a, V b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V crossv(V a, V b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
float dotv(V a, V b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
V unit(V a) {
  float l = std::sqrt(dotv(a, a));
  return {a[0] / l, a[1] / l, a[2] / l};
}

// The renderer's upload of a scene (src/render/renderer.cpp): float4 positions (w 1), normals (w 1,
// or all 0 without vertex normals), int4 triangles (w: mesh index).
struct Uploaded {
  std::vector<cl_float4> pos, nrm;
  std::vector<cl_int4> tris;
};
Uploaded upload(const std::vector<Mesh>& meshes) {
  Uploaded u;
  for (std::size_t mi = 0; mi < meshes.size(); ++mi) {
    const Mesh& m = meshes[mi];
    const int base = int(u.pos.size());
    const bool hasN = m.normals.size() == m.positions.size();
    for (std::size_t i = 0; i < m.positions.size(); ++i) {
      u.pos.push_back({{m.positions[i][0], m.positions[i][1], m.positions[i][2], 1}});
      u.nrm.push_back(hasN ? cl_float4{{m.normals[i][0], m.normals[i][1], m.normals[i][2], 1}}
                           : cl_float4{{0, 0, 0, 0}});
    }
    for (auto& t : m.triangles) u.tris.push_back({{base + t[0], base + t[1], base + t[2], int(mi)}});
  }
  return u;
}

Mesh sphereOfBuiltinScene() {
  for (Mesh& m : builtinScene().meshes)
    if (m.name == "sphere") return m;
  ADD_FAILURE() << "the built-in scene has no sphere";
  return {};
}

Mesh meshOf(const Scene& s, const std::string& name) {
  for (const Mesh& m : s.meshes)
    if (m.name == name) return m;
  ADD_FAILURE() << "no mesh " << name;
  return {};
}

// Octahedron with smooth (radial) normals: the smallest closed smooth mesh.
Mesh octahedron() {
  Mesh m;
  m.name = "octahedron";
  m.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.normals = m.positions;
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                 {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  return m;
}

// An open strip of 7 triangles folded along its length (a zig-zag roof), smooth normals.
Mesh strip() {
  Mesh m;
  m.name = "strip";
  for (int i = 0; i < 5; ++i) {
    const float x = 0.4f * i, y = 0.15f * float(i % 2);
    m.positions.push_back({x, y, 0});
    m.positions.push_back({x, y, 0.5f});
    m.normals.push_back(unit({i % 2 ? 0.2f : -0.2f, 1, 0}));
    m.normals.push_back(unit({i % 2 ? 0.2f : -0.2f, 1, 0.1f}));
  }
  for (int i = 0; i < 4; ++i) {
    const int a = 2 * i, b = a + 1, c = a + 2, d = a + 3;
    m.triangles.push_back({a, b, d});
    if (i < 3) m.triangles.push_back({a, d, c});
  }
  return m;
}

pb_light lightTowards(V d) {
  pb_light L{};
  V u = unit(d);
  for (int k = 0; k < 3; ++k) L.dir[k] = u[k];
  L.dir[3] = 1;
  return L;
}

// Runs bent_vertices on the welded triangles and compares with the C++ reference.
void expectVerticesMatch(const std::vector<Mesh>& meshes, const std::string& what) {
  SCOPED_TRACE(what);
  Uploaded u = upload(meshes);
  const std::vector<V> dirs = {{0.3f, 1, 0.2f}, {1, 0, 0}, {0, 0, 1}, {-0.7f, -0.2f, 0.4f}};
  std::vector<pb_light> lights;
  for (const V& d : dirs) lights.push_back(lightTowards(d));
  std::vector<V> unitDirs;
  for (const pb_light& L : lights) unitDirs.push_back({L.dir[0], L.dir[1], L.dir[2]});
  const std::vector<cl_int4> welded = detail::weldedTriangles(u.pos, u.nrm, u.tris);
  const int nv = int(u.pos.size()), nl = int(lights.size());
  cl::Buffer posB = ctx().upload(u.pos, "positions"), nrmB = ctx().upload(u.nrm, "normals");
  cl::Buffer triB = ctx().upload(welded, "triangles"), lightB = ctx().upload(lights, "lights");
  cl::Buffer bend = ctx().buffer(std::size_t(nv) * nl * 8, "bend");
  detail::bentVertices(ctx(), posB, nrmB, triB, int(welded.size()), nv, lightB, nl, bend);
  const std::vector<cl_int> got = ctx().download<cl_int>(bend, std::size_t(nv) * nl * 2, "bend");
  const auto want = detail::bentVerticesReference(u.pos, u.nrm, welded, unitDirs);
  ASSERT_EQ(want.size(), std::size_t(nv) * nl);
  int reached = 0;
  for (std::size_t i = 0; i < want.size(); ++i) {
    if (want[i][0] == std::numeric_limits<float>::infinity()) {
      // Not a vertex of any (welded) face: the kernel leaves the fill.
      EXPECT_EQ(got[2 * i], INT32_MAX) << "entry " << i;
      EXPECT_EQ(got[2 * i + 1], INT32_MIN) << "entry " << i;
      continue;
    }
    ++reached;
    // BOUND: float rounding of the face normal and the dot product, host against device
    // (contracted multiply-adds); measured at most 6e-8 on these meshes.
    EXPECT_NEAR(pb_ordered_to_float(got[2 * i]), want[i][0], 1e-6f) << "min, entry " << i;
    EXPECT_NEAR(pb_ordered_to_float(got[2 * i + 1]), want[i][1], 1e-6f) << "max, entry " << i;
  }
  EXPECT_GT(reached, 0);
}

}  // namespace

TEST(BentNormals, VerticesMatchReferenceOnAwkwardMeshes) {
  Mesh one;
  one.name = "one triangle";
  one.positions = {{0, 0, 0}, {1, 0, 0}, {0, 0.3f, 1}};
  one.normals = {unit({0, 1, 0.1f}), unit({0.2f, 1, 0}), unit({0, 1, -0.3f})};
  one.triangles = {{0, 2, 1}};
  expectVerticesMatch({one}, "one triangle");
  expectVerticesMatch({strip()}, "strip");
  expectVerticesMatch({octahedron()}, "octahedron");
  // 482 vertices and 960 triangles: more than a work-group of either.
  expectVerticesMatch({sphereOfBuiltinScene()}, "sphere");
  // 768 vertices, several meshes at once, a flat-normal mesh (the box: per-face vertices) and one
  // without vertex normals (w = 0), whose faces keep their winding's orientation.
  Scene s = builtinScene();
  Mesh bare = strip();
  bare.normals.clear();
  expectVerticesMatch({meshOf(s, "torus"), meshOf(s, "box"), bare}, "torus, box, bare strip");
  // Winding flipped against the normals: faces are oriented by the vertex normal, so the result
  // is the unflipped mesh's.
  Mesh flipped = octahedron();
  for (auto& t : flipped.triangles) std::swap(t[1], t[2]);
  expectVerticesMatch({flipped}, "flipped octahedron");
  const Uploaded a = upload({octahedron()}), b = upload({flipped});
  const V l = unit({0.3f, 1, 0.2f});
  EXPECT_EQ(detail::bentVerticesReference(a.pos, a.nrm, a.tris, {l}),
            detail::bentVerticesReference(b.pos, b.nrm, b.tris, {l}));
  // A vertex no face uses (the fill stays), and a degenerate face (skipped).
  Mesh stray = one;
  stray.positions.push_back({5, 5, 5});
  stray.normals.push_back({0, 1, 0});
  stray.positions.push_back({2, 0, 0});
  stray.normals.push_back({0, 1, 0});
  stray.triangles.push_back({1, 4, 1});  // repeats a vertex: zero area
  expectVerticesMatch({stray}, "stray vertex, degenerate face");
}

TEST(BentNormals, WeldingJoinsSplitVerticesOfTheSameNormal) {
  // A quad of two triangles whose diagonal's vertices are duplicated (a texture seam), plus a
  // corner duplicated with a different normal (a hard edge), which stays apart.
  Mesh m;
  m.name = "seam";
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}, {0, 0, 0}, {1, 0, 1}, {0, 0, 1}};
  m.normals = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {1, 0, 0}};
  m.triangles = {{0, 2, 1}, {4, 6, 5}};
  Uploaded u = upload({m});
  const auto w = detail::weldedTriangles(u.pos, u.nrm, u.tris);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ((std::array<int, 3>{w[1].s[0], w[1].s[1], w[1].s[2]}), (std::array<int, 3>{0, 6, 2}));
  EXPECT_EQ((std::array<int, 3>{w[0].s[0], w[0].s[1], w[0].s[2]}), (std::array<int, 3>{0, 2, 1}));
  EXPECT_EQ(w[1].s[3], 0);  // the mesh index stays
}

namespace {

// The test frame: the built-in scene's sphere alone, seen from +z, lit by one small cap from
// about +x, so the terminator runs down the middle of the picture. No ambient: black is black.
constexpr int kW = 160, kH = 160;

struct SphereFrame {
  Scene scene;
  Camera cam;
  LightSet lights;
  Environment env = builtinEnvironment(64);
  V l;
  SphereFrame() {
    scene.meshes.push_back(sphereOfBuiltinScene());
    cam.eye = {1.5f, 0.6f, 3.2f};
    cam.target = {1.5f, 0.6f, 0.7f};
    cam.fovyDeg = 32;
    AreaLight a;
    l = unit({1, 0.15f, 0.1f});
    a.direction = l;
    a.cosAlpha = std::cos(1.0f * float(M_PI) / 180);  // 1 degree half-angle: small
    a.setPower({1, 1, 1});
    lights.lights = {a};
    lights.method = "user";
  }
  Image render(ShadowTechnique t, bool bent, float scale = RenderOptions{}.bentNormalsScale) const {
    Renderer r(ctx());
    RenderOptions o;
    o.bentNormalsScale = scale;
    o.width = kW;
    o.height = kH;
    o.shadows = t;
    o.bentNormals = bent;
    o.environmentBackground = false;
    return r.render(scene, cam, lights, env, o).image;
  }
};

// What each pixel sees, traced on the host: triangle index (-1: none) and barycentrics.
struct Hit {
  int tri = -1;
  float b[3] = {0, 0, 0};
};
std::vector<Hit> traceSphere(const SphereFrame& f) {
  const Mesh& m = f.scene.meshes[0];
  CameraBasis cb = cameraBasis(f.cam, kW, kH);
  std::vector<Hit> hits(std::size_t(kW) * kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const V d = cameraRayDirection(cb, kW, kH, x + 0.5f, y + 0.5f);
      float best = std::numeric_limits<float>::infinity();
      Hit h;
      for (std::size_t t = 0; t < m.triangles.size(); ++t) {
        const V a = m.positions[m.triangles[t][0]], b = m.positions[m.triangles[t][1]],
                c = m.positions[m.triangles[t][2]];
        const V e1 = sub(b, a), e2 = sub(c, a), p = crossv(d, e2);
        const float det = dotv(e1, p);
        if (std::fabs(det) < 1e-20f) continue;
        const V s = sub(cb.eye, a);
        const float u = dotv(s, p) / det;
        const V q = crossv(s, e1);
        const float v = dotv(d, q) / det, tt = dotv(e2, q) / det;
        if (u < 0 || v < 0 || u + v > 1 || tt <= 0 || tt >= best) continue;
        best = tt;
        h.tri = int(t);
        h.b[0] = 1 - u - v;
        h.b[1] = u;
        h.b[2] = v;
      }
      hits[std::size_t(y) * kW + x] = h;
    }
  return hits;
}

float faceDot(const Mesh& m, int t, const V& l) {
  const V a = m.positions[m.triangles[t][0]], b = m.positions[m.triangles[t][1]],
          c = m.positions[m.triangles[t][2]];
  return dotv(unit(crossv(sub(b, a), sub(c, a))), l);
}

float lum(const Image& im, int x, int y) {
  const float* p = &im.pixels[(std::size_t(y) * kW + x) * 4];
  return 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2];
}

// Pixels well inside their triangle (the host and device rasterizers agree on them).
bool inside(const Hit& h) { return h.tri >= 0 && std::min({h.b[0], h.b[1], h.b[2]}) > 0.02f; }

// Largest |difference| of neighbouring pixels along the rows through the sphere's middle band,
// both pixels within the terminator's band: the surface's interpolated normal n at the pixel
// (host trace) has |n . l| < 0.4, and every pixel nearby is on the sphere (away from the outline).
float maxJump(const Image& im, const std::vector<Hit>& hits, const Mesh& m, const V& l) {
  auto nl = [&](int x, int y) {
    const Hit& h = hits[std::size_t(y) * kW + x];
    V n{0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) n[c] += h.b[k] * m.normals[m.triangles[h.tri][k]][c];
    return dotv(unit(n), l);
  };
  float worst = 0;
  for (int y = kH / 2 - kH / 8; y <= kH / 2 + kH / 8; ++y)
    for (int x = 8; x + 9 < kW; ++x) {
      bool geo = true;
      for (int k = -3; k <= 4; ++k) geo = geo && hits[std::size_t(y) * kW + x + k].tri >= 0;
      if (!geo || std::fabs(nl(x, y)) >= 0.4f || std::fabs(nl(x + 1, y)) >= 0.4f) continue;
      worst = std::max(worst, std::fabs(lum(im, x + 1, y) - lum(im, x, y)));
    }
  return worst;
}

}  // namespace

TEST(BentNormals, BlackOnLightBackFacingTrianglesUnchangedWhereAllFacesFaceTheLight) {
  SphereFrame f;
  const Mesh& m = f.scene.meshes[0];
  const std::vector<Hit> hits = traceSphere(f);
  // I_bend per vertex, from the reference.
  Uploaded u = upload({m});
  const auto bend = detail::bentVerticesReference(u.pos, u.nrm, u.tris, {f.l});
  // The default scale c = 3 with bitmask-hard and without shadows, and a sharper c = 10.
  const float c0 = RenderOptions{}.bentNormalsScale;
  // Where the Embree reference's shadow ray reaches the light: from the hit, lifted along its
  // camera-facing facet normal by the shadow offset (scene/shadow_offset.hpp), as the G-buffer
  // lifts the pixel.
  const detail::SampleTracer tracer(f.scene);
  const Bounds box = f.scene.bounds();
  const float eps = detail::shadowRayOffset(box.lo.data(), box.hi.data());
  const CameraBasis cb = cameraBasis(f.cam, kW, kH);
  auto reaches = [&](int x, int y, const Hit& h) {
    const V a = m.positions[m.triangles[h.tri][0]], b = m.positions[m.triangles[h.tri][1]],
            c = m.positions[m.triangles[h.tri][2]];
    V n = unit(crossv(sub(b, a), sub(c, a)));
    const V d = cameraRayDirection(cb, kW, kH, x + 0.5f, y + 0.5f);
    if (dotv(n, d) > 0) n = {-n[0], -n[1], -n[2]};
    std::array<float, 3> o;
    for (int k = 0; k < 3; ++k) o[k] = h.b[0] * a[k] + h.b[1] * b[k] + h.b[2] * c[k] + eps * n[k];
    return !tracer.occluded(o, {f.l[0], f.l[1], f.l[2]});
  };
  for (auto [t, c] : {std::pair{ShadowTechnique::BitmaskHard, c0}, std::pair{ShadowTechnique::None, c0},
                      std::pair{ShadowTechnique::BitmaskHard, 10.0f}}) {
    SCOPED_TRACE(std::string(toString(t)) + ", c = " + std::to_string(c));
    const Image off = f.render(t, false), on = f.render(t, true, c);
    int back = 0, backLitBefore = 0, backReached = 0, unlike = 0, front = 0, changed = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const Hit& h = hits[std::size_t(y) * kW + x];
        if (!inside(h)) continue;
        const float* p = &on.pixels[(std::size_t(y) * kW + x) * 4];
        const float* q = &off.pixels[(std::size_t(y) * kW + x) * 4];
        if (faceDot(m, h.tri, f.l) < 0) {
          ++back;
          const bool lit = q[0] + q[1] + q[2] > 0, reached = reaches(x, y, h);
          backLitBefore += lit;
          backReached += reached;
          unlike += lit != reached;
          EXPECT_EQ(p[0] + p[1] + p[2], 0.0f) << "light-back-facing pixel " << x << "," << y;
        }
        float minBend = 1;
        for (int k = 0; k < 3; ++k) minBend = std::min(minBend, bend[m.triangles[h.tri][k]][0]);
        // 1/c plus a margin for the device's float interpolation of the vertices' values.
        if (minBend >= 1.0f / c + 1e-4f) {
          ++front;
          for (int c = 0; c < 4; ++c) EXPECT_EQ(p[c], q[c]) << "pixel " << x << "," << y;
        } else {
          changed += p[0] != q[0];
        }
      }
    // Both sets are large: the light's silhouette crosses the picture's middle.
    std::printf("%s, c = %g: %d light-back-facing pixels, %d with every face around at cos >= "
                "1/c, %d of the others changed; %d back-facing pixels lit without bent normals, "
                "%d reached by the reference's ray, %d of them unlike\n",
                toString(t), c, back, front, changed, backLitBefore, backReached, unlike);
    EXPECT_GT(back, 1000);
    EXPECT_GT(front, 1000);
    EXPECT_GT(changed, 300);  // and the band between them does change
    // Without shadows, the interpolated normal lights the back-facing triangles next to the
    // terminator, which bent normals black out. Bitmask-hard lights only those the reference's
    // ray reaches (its rays start where the reference's do): a few next to the facet's edge, where
    // the ray from the lifted point passes over the neighbouring facet.
    if (t == ShadowTechnique::None) EXPECT_GT(backLitBefore, 20);
    if (t == ShadowTechnique::BitmaskHard) {
      EXPECT_EQ(unlike, 0);
      EXPECT_LT(backLitBefore, back / 20);
    }
  }
}

TEST(BentNormals, ContinuousAcrossTheTerminatorWhereBitmaskHardJumps) {
  SphereFrame f;
  const std::vector<Hit> hits = traceSphere(f);
  const Image off = f.render(ShadowTechnique::BitmaskHard, false);
  const Image on = f.render(ShadowTechnique::BitmaskHard, true);
  const Image none = f.render(ShadowTechnique::None, false);
  const Mesh& m = f.scene.meshes[0];
  const float jOff = maxJump(off, hits, m, f.l), jOn = maxJump(on, hits, m, f.l),
              jNone = maxJump(none, hits, m, f.l);
  RecordProperty("jump_bitmask_hard", std::to_string(jOff));
  RecordProperty("jump_bent", std::to_string(jOn));
  RecordProperty("jump_unshadowed", std::to_string(jNone));
  std::printf("max neighbour jump: bitmask-hard %.5f, with bent normals %.5f, unshadowed %.5f\n",
              jOff, jOn, jNone);
  // BOUNDS. Measured at 160x160 (PoCL): bitmask-hard 0.0151, bent 0.00227, unshadowed 0.00170.
  // Bitmask-hard's step is the shading at the silhouette edge, the same at any resolution; the
  // smooth shadings' steps shrink with the pixel size, so the ratio (6.6 here) only grows with
  // the image. Near I_bend = 0 the blend falls like e0 I_bend (1 + c delta), delta = n . l -
  // n_F . l ~ 0.1 on this 32 x 16 sphere: ~1.3 times the unshadowed Lambert slope (1.34 here).
  EXPECT_GT(jOff, 5 * jOn);
  EXPECT_LT(jOn, 1.6f * jNone);
  // A sharper blend (c = 10) fades over a third of the I_bend range, so its steps are steeper, yet
  // well below the hard edge (measured 0.00356: 1.6 times the c = 3 step, a quarter of the edge).
  const float jSharp = maxJump(f.render(ShadowTechnique::BitmaskHard, true, 10.0f), hits, m, f.l);
  std::printf("max neighbour jump with c = 10: %.5f\n", jSharp);
  EXPECT_GT(jSharp, jOn);
  EXPECT_LT(2 * jSharp, jOff);
}

TEST(BentNormals, ScaleMustBePositiveAndFinite) {
  SphereFrame f;
  Renderer r(ctx());
  RenderOptions o;
  o.width = o.height = 8;
  o.bentNormals = true;
  for (float bad : {0.0f, -1.0f, std::nanf(""), std::numeric_limits<float>::infinity()}) {
    o.bentNormalsScale = bad;
    try {
      r.render(f.scene, f.cam, f.lights, f.env, o);
      ADD_FAILURE() << "scale " << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find("RenderOptions.bentNormalsScale"), std::string::npos) << e.what();
    }
  }
}

TEST(BentNormals, ReportRecordsTheOption) {
  SphereFrame f;
  Renderer r(ctx());
  RenderOptions o;
  o.width = 16;
  o.height = 16;
  o.shadows = ShadowTechnique::None;
  o.bentNormals = true;
  ctx().resetTimings();
  Frame fr = r.render(f.scene, f.cam, f.lights, f.env, o);
  const nlohmann::json j = nlohmann::json::parse(renderReportJson("dev", f.lights, f.env, o, fr));
  EXPECT_EQ(j["bent_normals"], true) << j.dump(2);
  EXPECT_EQ(j["bent_normals_scale"].get<double>(), 3.0) << j.dump(2);
  EXPECT_TRUE(j["timings_ms"].contains("bent-normals/pixels")) << j.dump(2);  // the pass ran
  o.bentNormals = false;
  EXPECT_EQ(nlohmann::json::parse(renderReportJson("dev", f.lights, f.env, o, fr))["bent_normals"],
            false);
}

TEST(OclgrindBentNormals, VerticesAndTinyFrame) {
  expectVerticesMatch({octahedron(), strip()}, "octahedron and strip");
  // A 7x5 frame of the octahedron seen from between +x and +z, no shadows, with and without bent
  // normals: bending only darkens, it darkens something (the faces towards -x, which face away
  // from the light, are lit by their interpolated normals without it), and the pixels around the
  // +x vertex, whose faces all face the light, stay lit.
  Scene s;
  s.meshes.push_back(octahedron());
  Camera cam;
  cam.eye = {2.5f, 0.8f, 2.5f};
  cam.target = {0, 0, 0};
  cam.fovyDeg = 40;
  AreaLight a;
  a.direction = unit({1, 0.2f, 0.1f});
  a.cosAlpha = std::cos(0.02f);
  a.setPower({1, 1, 1});
  LightSet ls;
  ls.lights = {a};
  ls.method = "user";
  Renderer r(ctx());
  RenderOptions o;
  o.width = 7;
  o.height = 5;
  o.shadows = ShadowTechnique::None;
  const Environment env = builtinEnvironment(16);
  const Image off = r.render(s, cam, ls, env, o).image;
  o.bentNormals = true;
  const Image on = r.render(s, cam, ls, env, o).image;
  int darker = 0, lit = 0;
  for (std::size_t i = 0; i < on.pixels.size(); i += 4) {
    if (on.pixels[i + 3] < 0.5f) continue;
    for (int c = 0; c < 3; ++c) {
      EXPECT_TRUE(std::isfinite(on.pixels[i + c]) && on.pixels[i + c] >= 0);
      EXPECT_LE(on.pixels[i + c], off.pixels[i + c]);
    }
    darker += on.pixels[i] < off.pixels[i];
    lit += on.pixels[i] > 0;
  }
  EXPECT_GT(darker, 0);
  EXPECT_GT(lit, 0);
}
