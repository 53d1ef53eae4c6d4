// The GL interop layer (include/penumbra/gl): headless contexts, the interop API's texture checks,
// `render --gl` against the OpenCL-only path under Mesa llvmpipe (EGL and OSMesa), resizing, the
// missing-GL error, and the interop's conversion kernels against a plain C++ reference.
#include <gtest/gtest.h>
#include <unistd.h>

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "gl/glfuncs.hpp"
#include "shadows/shadow_pass.hpp"
#include "common.hpp"
#include "penumbra/gl/interop.hpp"
#include "penumbra/penumbra.hpp"

using namespace penumbra;
using penumbra::test::ctx;
using penumbra::test::expectBadInput;
namespace fs = std::filesystem;

namespace {

// llvmpipe without a display: the surfaceless EGL platform, software rendering. Set before the
// first context (the CTest environment may set them already; these are the fallback).
void softwareGL() {
  setenv("EGL_PLATFORM", "surfaceless", 0);
  setenv("LIBGL_ALWAYS_SOFTWARE", "1", 0);
  setenv("GALLIUM_DRIVER", "llvmpipe", 0);
}

struct SmallFrame {
  Scene scene = builtinScene();
  Environment env = builtinEnvironment();
  Camera camera;
  LightSet lights;
  RenderOptions opt;
  SmallFrame(int w, int h, int s, int nlights) {
    camera = frameCamera(scene, float(w) / float(h));
    ExtractOptions eo;
    eo.medianCut.lights = nlights;
    eo.medianCut.faceSize = 64;
    lights = extractLights(ctx(), env, eo);
    opt.width = w;
    opt.height = h;
    opt.shadowMapSize = s;
    // The GL interop receives textures, no triangles, so it has no contact shadows and `auto`
    // gives no light exact visibility there (AutoOptions::exactShare's compact sources included);
    // the OpenCL path they are compared with goes without them too.
    opt.shadow.contactShadows = false;
    opt.autoChoice.exactShare = 0;
  }
};

// Relative RMSE bound between `render --gl` and the OpenCL-only path. The two rasterize the same
// triangles differently: OpenCL casts a ray through each pixel centre and counts hits within 1e-6
// of an edge on both sides (raster.cl), GL applies the top-left fill rule, and GL's interpolated
// positions, normals and depths differ from the exact ray hit in the last bits. Shadow-map texels
// on caster edges that one path covers and the other not make up nearly all of the difference
// (the frames' visibility differs by 0.0012 RMS; camera coverage is identical). Measured on this
// frame (160x90, 16 lights, 128^2 maps, MSSM4; Mesa 22.3 llvmpipe, PoCL 3.1): 0.0011 with EGL and
// with OSMesa (identical images); 0.0003 since both lift their positions off the surface where
// shadow tests start (README, "Where shadow tests start"; with only the OpenCL path lifting, two
// pixels at the sun's hard shadow edge flipped and the frames differed by 0.0104). The bound
// leaves ~3.5x of the first for other Mesa/LLVM versions; swapped surfaces from a poor depth
// buffer gave 0.029, a row flip or a wrong matrix far more.
constexpr double kGLBound = 0.004;

void expectMatchesOpenCL(gl::Backend backend) {
  softwareGL();
  gl::HeadlessContext glc(backend);
  EXPECT_EQ(glc.backend(), backend);
  EXPECT_NE(glc.description().find("llvmpipe"), std::string::npos) << glc.description();
  SmallFrame f(160, 90, 128, 16);
  Renderer cl(ctx());
  Frame ref = cl.render(f.scene, f.camera, f.lights, f.env, f.opt);
  gl::GLRenderer glr(ctx(), glc.loader());
  Frame got = glr.render(f.scene, f.camera, f.lights, f.env, f.opt);
  ASSERT_EQ(got.image.width, 160);
  ASSERT_EQ(got.image.height, 90);
  ImageMetrics m = compareImages(got.image, ref.image);
  std::printf("render --gl (%s) vs OpenCL-only: relative RMSE %.4f\n", gl::toString(backend),
              m.relativeRmse);
  EXPECT_LT(m.relativeRmse, kGLBound) << "rmse " << m.rmse << " max " << m.maxAbsError;
  // Background pixels carry the environment in both, alpha 0; same geometry coverage nearly
  // everywhere (silhouettes aside).
  int alphaDiff = 0;
  for (int i = 0; i < 160 * 90; ++i)
    alphaDiff += got.image.pixels[i * 4 + 3] != ref.image.pixels[i * 4 + 3];
  // Measured 0 (both sample pixel centres); a few silhouette pixels may differ elsewhere.
  EXPECT_LE(alphaDiff, 16) << "coverage differs on " << alphaDiff << " pixels";
  std::vector<std::string> stages;
  for (auto& [name, ms] : got.timingsMs) stages.push_back(name);
  for (const char* s : {"gl/gbuffer", "gl/shadow-maps", "interop/upload", "interop/download",
                        "gl/shade", "mssm4/visibility"})
    EXPECT_NE(std::find(stages.begin(), stages.end(), s), stages.end()) << s;
}

}  // namespace

// Polygon lights: the shader's port of pb_polygon_irradiance against shade.cl's. Half of the
// lights become squares spanning their caps; same bound as above (measured 0.0011).
TEST(GLFrame, PolygonLightsMatchOpenCLPath) {
  softwareGL();
  gl::HeadlessContext glc;
  SmallFrame f(160, 90, 128, 16);
  for (std::size_t l = 0; l < f.lights.lights.size(); l += 2) {
    const AreaLight c = f.lights.lights[l];
    const auto& d = c.direction;
    std::array<float, 3> ref = std::fabs(d[1]) < 0.9f ? std::array<float, 3>{0, 1, 0}
                                                      : std::array<float, 3>{1, 0, 0};
    auto cross = [](std::array<float, 3> a, std::array<float, 3> b) {
      return std::array<float, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                                  a[0] * b[1] - a[1] * b[0]};
    };
    auto unit = [](std::array<float, 3> a) {
      float n = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
      return std::array<float, 3>{a[0] / n, a[1] / n, a[2] / n};
    };
    std::array<float, 3> u = unit(cross(ref, d)), v = cross(d, u);  // u x v = d
    float r = std::sqrt(1 - c.cosAlpha * c.cosAlpha) / c.cosAlpha;
    std::vector<std::array<float, 3>> verts;
    for (int k = 0; k < 4; ++k) {  // counter-clockwise about d
      float su = k == 0 ? 1.f : (k == 2 ? -1.f : 0.f), sv = k == 1 ? 1.f : (k == 3 ? -1.f : 0.f);
      verts.push_back(unit({d[0] + r * (su * u[0] + sv * v[0]), d[1] + r * (su * u[1] + sv * v[1]),
                            d[2] + r * (su * u[2] + sv * v[2])}));
    }
    f.lights.lights[l] = makePolygonLight(verts, c.radiance);
  }
  Renderer cl(ctx());
  Frame ref = cl.render(f.scene, f.camera, f.lights, f.env, f.opt);
  gl::GLRenderer glr(ctx(), glc.loader());
  Frame got = glr.render(f.scene, f.camera, f.lights, f.env, f.opt);
  double rel = compareImages(got.image, ref.image).relativeRmse;
  std::printf("polygon lights: render --gl vs OpenCL-only: relative RMSE %.4f\n", rel);
  EXPECT_LT(rel, kGLBound);
}

TEST(GLFrame, MatchesOpenCLPathEGL) { expectMatchesOpenCL(gl::Backend::EGL); }

// `auto` with no exact light: the same per-light choices on both paths (the rule reads the
// G-buffer and the depth maps, which GL rasterizes in its own way), hard and MSSM4 both run, and
// the image within the same bound as one technique's (measured 0.0002, as MSSM4 alone). With
// exact lights asked for, the interop refuses (GLInterop.ChecksTextureFormatsAndSizes).
TEST(GLFrame, AutoWithoutExactLightsMatchesOpenCLPath) {
  softwareGL();
  gl::HeadlessContext glc;
  SmallFrame f(160, 90, 128, 16);
  f.opt.shadows = ShadowTechnique::Auto;
  f.opt.autoChoice.exactLights = 0;
  f.opt.autoChoice.filteredLights = 6;
  Renderer cl(ctx());
  Frame ref = cl.render(f.scene, f.camera, f.lights, f.env, f.opt);
  gl::GLRenderer glr(ctx(), glc.loader());
  Frame got = glr.render(f.scene, f.camera, f.lights, f.env, f.opt);
  auto stat = [](const Frame& fr, const std::string& name) {
    for (auto& [n, v] : fr.stats)
      if (n == name) return v;
    ADD_FAILURE() << "no stat " << name;
    return -1.0;
  };
  EXPECT_EQ(stat(got, "auto/lights_mssm4"), 6.0);
  EXPECT_GT(stat(got, "auto/lights_hard"), 0.0);
  EXPECT_EQ(stat(got, "auto/lights_exact"), 0.0);
  for (int l = 0; l < 16; ++l) {
    const std::string name = "auto/light_" + std::to_string(l);
    EXPECT_EQ(stat(got, name), stat(ref, name)) << name;
  }
  std::vector<std::string> stages;
  for (auto& [name, ms] : got.timingsMs) stages.push_back(name);
  for (const char* s : {"hard/visibility", "mssm4/visibility"})
    EXPECT_NE(std::find(stages.begin(), stages.end(), s), stages.end()) << s;
  const double rel = compareImages(got.image, ref.image).relativeRmse;
  std::printf("auto: render --gl vs OpenCL-only: relative RMSE %.4f\n", rel);
  EXPECT_LT(rel, kGLBound);
}
TEST(GLFrame, MatchesOpenCLPathOSMesa) { expectMatchesOpenCL(gl::Backend::OSMesa); }

// --- the interop's conversion kernels (kernels/gl/gl_interop.cl) against a plain C++ reference; no
// GL needed. Awkward sizes: 1x1, one row, one column, odd, wider than a work-group.
namespace {

void expectConversionsMatch(const std::vector<std::pair<int, int>>& sizes) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (auto [w, h] : sizes) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    // Depth: maps are square; use S = w for `count` = h maps (at most 3).
    const int S = w, count = std::min(h, 3);
    std::vector<float> gl(std::size_t(S) * S * count);
    for (std::size_t i = 0; i < gl.size(); ++i) {
      float r = u(rng);
      gl[i] = r < 0.2f ? 1.0f : (r < 0.25f ? 1.5f : (r < 0.3f ? NAN : u(rng)));
    }
    std::vector<pb_light> lights(count);
    for (int l = 0; l < count; ++l) lights[l].origin[3] = 2.5f + l;
    cl::Buffer glB = ctx().upload(gl, "gl depth"), lB = ctx().upload(lights, "lights");
    cl::Buffer outB = ctx().buffer(gl.size() * 4, "depth");
    cl::Kernel k = ctx().kernel("gl_interop.cl", "gl_depth_to_distance");
    k.setArg(0, glB);
    k.setArg(1, lB);
    k.setArg(2, cl_int(S));
    k.setArg(3, cl_int(count));
    k.setArg(4, outB);
    ctx().launch("test", k, cl::NDRange(S, S, count));
    auto got = ctx().download<cl_uint>(outB, gl.size(), "depth");
    int bad = 0;
    for (int l = 0; l < count; ++l)
      for (int y = 0; y < S; ++y)
        for (int x = 0; x < S; ++x) {
          float z = gl[(std::size_t(l) * S + (S - 1 - y)) * S + x];
          cl_uint want = PB_DEPTH_EMPTY;
          if (z >= 0.0f && z < 1.0f) {
            float d = z * lights[l].origin[3];
            std::memcpy(&want, &d, 4);
          }
          bad += got[(std::size_t(l) * S + y) * S + x] != want;
        }
    EXPECT_EQ(bad, 0);

    // G-buffer rows flipped; positions normalized to w in {0, 1}, directions to w = 0.
    std::vector<cl_float4> g(std::size_t(w) * h);
    for (auto& v : g) v = {{u(rng) - 0.5f, u(rng), -u(rng), u(rng)}};
    cl::Buffer src = ctx().upload(g, "gl gbuffer"), dst = ctx().buffer(g.size() * 16, "gbuffer");
    cl::Kernel f = ctx().kernel("gl_interop.cl", "gl_flip_gbuffer");
    for (int kind = 0; kind < 2; ++kind) {
      f.setArg(0, src);
      f.setArg(1, cl_int(w));
      f.setArg(2, cl_int(h));
      f.setArg(3, cl_int(kind));
      f.setArg(4, dst);
      ctx().launch("test", f, cl::NDRange(w, h));
      auto out = ctx().download<cl_float4>(dst, g.size(), "gbuffer");
      int wrong = 0;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          cl_float4 s = g[std::size_t(h - 1 - y) * w + x], o = out[std::size_t(y) * w + x];
          cl_float4 e = s;
          if (kind == 0 && s.s[3] > 0.5f) e.s[3] = 1.0f;
          if (kind == 0 && !(s.s[3] > 0.5f)) e = {{0, 0, 0, 0}};
          if (kind == 1) e.s[3] = 0.0f;
          for (int c = 0; c < 4; ++c) wrong += o.s[c] != e.s[c];
        }
      EXPECT_EQ(wrong, 0) << "kind " << kind;
    }

    // Positions lifted along the geometric normals (normalized), background left alone; a zero
    // normal leaves its position.
    std::vector<cl_float4> pos(std::size_t(w) * h), geo(pos.size());
    for (std::size_t i = 0; i < pos.size(); ++i) {
      pos[i] = {{u(rng) - 0.5f, u(rng), -u(rng), i % 4 == 1 ? 0.0f : 1.0f}};
      const float a = 2.0f * u(rng);
      geo[i] = i % 7 == 3 ? cl_float4{{0, 0, 0, 0}} : cl_float4{{2 * a, -a, 0.5f * a, 0}};
    }
    cl::Buffer posB = ctx().upload(pos, "positions"), geoB = ctx().upload(geo, "normals");
    cl::Kernel lift = ctx().kernel("gl_interop.cl", "gl_lift_positions");
    const float off = 1e-3f;
    ctx().launchWith("test", lift, cl::NDRange(pos.size()), cl::NullRange, posB, geoB,
                     cl_int(pos.size()), off);
    auto lifted = ctx().download<cl_float4>(posB, pos.size(), "positions");
    int moved = 0;
    for (std::size_t i = 0; i < pos.size(); ++i) {
      const float* q = geo[i].s;
      const double len = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2]);
      const bool lifts = pos[i].s[3] != 0 && len > 0;
      moved += lifts;
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(lifted[i].s[c], pos[i].s[c] + (lifts ? off * q[c] / len : 0.0), 1e-6) << i;
      EXPECT_EQ(lifted[i].s[3], pos[i].s[3]) << i;
    }
    if (pos.size() >= 8) EXPECT_GT(moved, 0);
  }
}

}  // namespace

TEST(GLInteropKernels, MatchReference) {
  expectConversionsMatch({{1, 1}, {1, 9}, {9, 1}, {13, 5}, {67, 3}, {300, 2}});
}
TEST(OclgrindGLInterop, ConversionKernels) { expectConversionsMatch({{1, 1}, {5, 3}, {3, 2}}); }

// --- the interop API's texture checks: every wrong texture is named
namespace {

struct Textures {
  gl::detail::GLFunctions& gl;
  std::vector<GLuint> made;
  GLuint make(GLenum internal, int w, int h) {
    GLuint t = 0;
    gl.GenTextures(1, &t);
    gl.BindTexture(GL_TEXTURE_2D, t);
    bool depth = internal == GL_DEPTH_COMPONENT32F || internal == GL_DEPTH_COMPONENT24;
    gl.TexImage2D(GL_TEXTURE_2D, 0, GLint(internal), w, h, 0,
                  depth ? GL_DEPTH_COMPONENT : GL_RGBA, GL_FLOAT, nullptr);
    made.push_back(t);
    return t;
  }
  ~Textures() { gl.DeleteTextures(GLsizei(made.size()), made.data()); }
};

LightSet twoLights() {
  LightSet s;
  s.lights.resize(2);
  s.lights[0].direction = {0.0f, 1.0f, 0.0f};
  s.lights[1].direction = {0.6f, 0.8f, 0.0f};
  for (auto& l : s.lights) {
    l.cosAlpha = 0.98f;
    l.radiance = {1.0f, 1.0f, 1.0f};
  }
  return s;
}

}  // namespace

TEST(GLInterop, ChecksTextureFormatsAndSizes) {
  softwareGL();
  gl::HeadlessContext glc;
  gl::detail::GLFunctions gl;
  gl.load(glc.loader());
  Textures t{gl, {}};
  const int W = 9, H = 5, S = 8;
  gl::GBuffer g{t.make(GL_RGBA32F, W, H), t.make(GL_RGBA32F, W, H), t.make(GL_RGBA8, W, H), 0};
  std::vector<gl::TextureId> maps{t.make(GL_DEPTH_COMPONENT32F, S, S),
                                  t.make(GL_DEPTH_COMPONENT24, S, S)};
  GLuint out = t.make(GL_RGBA32F, W, H);
  Scene scene = builtinScene();
  Environment env = builtinEnvironment(64);
  Camera cam = frameCamera(scene, float(W) / H);
  LightSet lights = twoLights();
  RenderOptions opt;
  gl::Interop interop(ctx(), glc.loader());
  auto shade = [&](const std::vector<gl::TextureId>& m, const gl::GBuffer& gb, GLuint o,
                   const LightSet& ls, const RenderOptions& op) {
    interop.shade(m, gb, o, cam, ls, scene.bounds(), env, op);
  };
  // Valid textures: a frame of background only (positions cleared to alpha 0 by nothing: the
  // textures are undefined, so fill them), visibility computed, output written.
  std::vector<float> zeros(std::size_t(W) * H * 4, 0.0f);
  gl.BindTexture(GL_TEXTURE_2D, g.position);
  gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, W, H, GL_RGBA, GL_FLOAT, zeros.data());
  ASSERT_NO_THROW(shade(maps, g, out, lights, opt));
  EXPECT_EQ(interop.lastVisibility().size(), std::size_t(W) * H * 2);

  gl::GBuffer bad = g;
  bad.normal = t.make(GL_RGBA8, W, H);
  expectBadInput([&] { shade(maps, bad, out, lights, opt); },
                 {"G-buffer normal texture", "wrong format", "GL_RGBA8"});
  bad = g;
  bad.position = t.make(GL_RGBA32F, W - 1, H);
  expectBadInput([&] { shade(maps, bad, out, lights, opt); },
                 {"G-buffer position texture", "wrong size", "9x5"});
  bad = g;
  bad.albedo = 12345;
  expectBadInput([&] { shade(maps, bad, out, lights, opt); },
                 {"G-buffer albedo texture", "not a GL texture"});
  auto badMaps = maps;
  badMaps[1] = t.make(GL_DEPTH_COMPONENT32F, 2 * S, 2 * S);
  expectBadInput([&] { shade(badMaps, g, out, lights, opt); }, {"shadow map 1", "wrong size"});
  badMaps = maps;
  badMaps[0] = t.make(GL_RGBA32F, S, S);
  expectBadInput([&] { shade(badMaps, g, out, lights, opt); }, {"shadow map 0", "wrong format"});
  badMaps[0] = t.make(GL_DEPTH_COMPONENT32F, S, S + 1);
  expectBadInput([&] { shade(badMaps, g, out, lights, opt); }, {"shadow map 0", "square"});
  expectBadInput([&] { shade({maps[0]}, g, out, lights, opt); },
                 {"1 shadow-map textures for 2 lights"});
  expectBadInput([&] { shade(maps, g, t.make(GL_RGBA8, W, H), lights, opt); },
                 {"output texture", "wrong format"});
  RenderOptions brute = opt;
  brute.shadows = ShadowTechnique::Brute;
  expectBadInput([&] { shade(maps, g, out, lights, brute); }, {"RenderOptions.shadows brute"});
  RenderOptions exact = opt;
  exact.shadows = ShadowTechnique::Auto;
  exact.autoChoice.exactLights = 1;
  expectBadInput([&] { shade(maps, g, out, lights, exact); },
                 {"RenderOptions.autoChoice.exactLights is 1", "--auto-exact 0"});
  RenderOptions bent = opt;
  bent.bentNormals = true;
  expectBadInput([&] { shade(maps, g, out, lights, bent); },
                 {"RenderOptions.bentNormals", "without GL"});
  // After all the refusals the valid frame still works.
  EXPECT_NO_THROW(shade(maps, g, out, lights, opt));
}

// Resizing and re-creating textures between frames: the renderer re-creates its G-buffer, output
// and shadow-map textures when the size changes; the third frame repeats the first exactly.
TEST(GLInterop, ResizesBetweenFrames) {
  softwareGL();
  gl::HeadlessContext glc;
  gl::GLRenderer glr(ctx(), glc.loader());
  SmallFrame a(48, 27, 64, 4), b(80, 45, 96, 4);
  Frame fa = glr.render(a.scene, a.camera, a.lights, a.env, a.opt);
  Frame fb = glr.render(b.scene, b.camera, b.lights, b.env, b.opt);
  Frame fc = glr.render(a.scene, a.camera, a.lights, a.env, a.opt);
  ASSERT_EQ(fb.image.width, 80);
  ASSERT_EQ(fb.image.height, 45);
  ASSERT_EQ(fc.image.pixels.size(), fa.image.pixels.size());
  EXPECT_EQ(fc.image.pixels, fa.image.pixels);
  // The resized frame is the OpenCL path's frame, not leftovers of the first size.
  Renderer cl(ctx());
  Frame ref = cl.render(b.scene, b.camera, b.lights, b.env, b.opt);
  int geoGL = 0, geoCL = 0;
  for (int i = 0; i < 80 * 45; ++i) {
    geoGL += fb.image.pixels[i * 4 + 3] > 0.5f;
    geoCL += ref.image.pixels[i * 4 + 3] > 0.5f;
  }
  EXPECT_NEAR(geoGL, geoCL, 0.03 * geoCL);
  // Measured 0.0043: with 4 lights and 96^2 maps at 80x45, each caster-edge texel that the two
  // rasterizers disagree on covers more pixels. 3x of it, as above.
  double rel = compareImages(fb.image, ref.image).relativeRmse;
  std::printf("80x45 render --gl vs OpenCL-only: relative RMSE %.4f, geometry %d vs %d\n", rel,
              geoGL, geoCL);
  EXPECT_LT(rel, 0.013);
}

// --- the command line: --gl's backends, report stages, and the missing-GL error
namespace {
int runShell(const std::string& cmd) {
  int st = std::system(cmd.c_str());
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}
std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}
}  // namespace

TEST(GLCli, MissingGLIsAClearErrorAndOpenCLStillWorks) {
  fs::path dir = fs::path(testing::TempDir()) / ("penumbra_gl_cli_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string cli = PENUMBRA_CLI, cd = "cd '" + dir.string() + "' && ";
  const std::string noGL = "PENUMBRA_EGL_LIBRARY=/nonexistent/libEGL.so.1 "
                           "PENUMBRA_OSMESA_LIBRARY=/nonexistent/libOSMesa.so.8 ";
  const std::string small = " --size 32x18 --lights 4 --shadow-map-size 64";
  EXPECT_EQ(runShell(cd + noGL + cli + " render --gl auto" + small +
                     " --out gl.png > out.txt 2> err.txt"), 2);
  std::string err = slurp(dir / "err.txt");
  EXPECT_NE(err.find("no OpenGL context (--gl auto)"), std::string::npos) << err;
  EXPECT_NE(err.find("cannot load /nonexistent/libEGL.so.1"), std::string::npos) << err;
  EXPECT_NE(err.find("cannot load /nonexistent/libOSMesa.so.8"), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_FALSE(fs::exists(dir / "gl.png"));
  // The OpenCL-only path in the same environment.
  EXPECT_EQ(runShell(cd + noGL + cli + " render" + small + " --out cl.png > out.txt 2> err.txt"),
            0) << slurp(dir / "err.txt");
  EXPECT_TRUE(fs::exists(dir / "cl.png"));
  // An unknown backend is named.
  EXPECT_EQ(runShell(cd + cli + " render --gl vulkan" + small + " > out.txt 2> err.txt"), 2);
  EXPECT_NE(slurp(dir / "err.txt").find("--gl: unknown backend 'vulkan'"), std::string::npos);
}

TEST(GLCli, RenderGLWritesStageTimes) {
  fs::path dir = fs::path(testing::TempDir()) / ("penumbra_gl_cli_report_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string cli = PENUMBRA_CLI, cd = "cd '" + dir.string() + "' && ";
  for (const char* backend : {"egl", "osmesa"}) {
    SCOPED_TRACE(backend);
    fs::remove(dir / "r.json");
    ASSERT_EQ(runShell(cd + "EGL_PLATFORM=surfaceless " + cli + " render --gl " + backend +
                       " --size 48x27 --lights 4 --shadow-map-size 64 --out gl.exr"
                       " --report r.json > out.txt 2> err.txt"),
              0) << slurp(dir / "err.txt");
    std::string json = slurp(dir / "r.json"), out = slurp(dir / "out.txt");
    for (const char* s : {"\"gl/gbuffer\"", "\"gl/shadow-maps\"", "\"interop/upload\"",
                          "\"interop/download\"", "\"gl/shade\"", "\"mssm4/visibility\""})
      EXPECT_NE(json.find(s), std::string::npos) << s;
    EXPECT_NE(out.find(std::string(backend) == "egl" ? "GL EGL" : "GL OSMesa"), std::string::npos)
        << out;
    // The GL path has no triangles on the OpenCL side: no contact shadows, and the report says so.
    EXPECT_NE(json.find("\"contact_shadows\": false"), std::string::npos) << json;
  }
  EXPECT_EQ(runShell(cd + "EGL_PLATFORM=surfaceless " + cli + " render --gl egl --contact-texels 4"
                     " --size 48x27 --lights 4 --out gl2.exr > out.txt 2> err.txt"),
            2);
  EXPECT_NE(slurp(dir / "err.txt").find("--contact-texels does not work with --gl"),
            std::string::npos) << slurp(dir / "err.txt");
  EXPECT_FALSE(fs::exists(dir / "gl2.exr"));
}
