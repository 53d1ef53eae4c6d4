// Ellipse (volumetric) lights and textured lights (lights.hpp makeEllipseLight, setLightTexture,
// lightSamples; Sintorn et al. 2008 §4.1): the ellipse's solid angle and its shading polygon's irradiance
// against quadrature of the true ellipse, its samples, the textured radiance's integral, the
// per-sample weights of the bitmask technique, brute force and the Embree light-set reference
// (a blocker over the bright half of a half-black light), a uniform texture rendering as no
// texture bit for bit, the light-set JSON, and the changed kernels under oclgrind.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "shadows/bitmask.hpp"
#include "common.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

using namespace penumbra::test::dvec;
constexpr double kDeg = M_PI / 180;

// Quadrature of the true ellipse (half-angles a, b about d, frame right = d x up, up), written
// independently of the library: polar coordinates of the unit disk, x = tan(a) r cos(phi),
// y = tan(b) r sin(phi), area element tan(a) tan(b) r dr dphi of the gnomonic plane, solid angle
// (1 + x^2 + y^2)^(-3/2) per unit area, clamped cosine with each normal. The boundary is exact
// (r = 1), the integrand smooth but for the horizon's kink; 600 x 1200 midpoint cells, whose own
// error (second order in the cell size) is of order 1e-6 relative.
struct EllipseQuad {
  double omega = 0;
  std::vector<double> e;
};
EllipseQuad ellipseQuadrature(V3 dir, V3 up, double a, double b, const std::vector<V3>& normals,
                              int nr = 600, int np = 1200) {
  const D3 d = unitD({dir[0], dir[1], dir[2]});
  D3 u = {up[0], up[1], up[2]};
  const double du = dot(u, d);
  for (int c = 0; c < 3; ++c) u[c] -= du * d[c];
  u = unitD(u);
  const D3 rt = cross(d, u);
  const double ta = std::tan(a), tb = std::tan(b);
  EllipseQuad q;
  q.e.assign(normals.size(), 0.0);
  for (int i = 0; i < nr; ++i) {
    const double r = (i + 0.5) / nr;
    for (int j = 0; j < np; ++j) {
      const double ph = 2 * M_PI * (j + 0.5) / np;
      const double x = ta * r * std::cos(ph), y = tb * r * std::sin(ph), s = 1 + x * x + y * y;
      const double dw = ta * tb * r / nr * 2 * M_PI / np / (s * std::sqrt(s));
      D3 w;
      for (int c = 0; c < 3; ++c) w[c] = (d[c] + x * rt[c] + y * u[c]) / std::sqrt(s);
      q.omega += dw;
      for (std::size_t k = 0; k < normals.size(); ++k)
        q.e[k] += dw * std::max(0.0, normals[k][0] * w[0] + normals[k][1] * w[1] + normals[k][2] * w[2]);
    }
  }
  return q;
}

std::vector<V3> someNormals(V3 d) {
  // the light's own direction, tilted ones, and grazing ones that clip the light at the horizon
  std::vector<V3> n = {d, unit(0, 1, 0), unit(1, 0, 0), unit(0, 0, 1), unit(1, 1, 0),
                       unit(-1, 0.3, 0.2), unit(0.2, -0.1, 1)};
  const D3 dd = {d[0], d[1], d[2]};
  D3 ref = std::fabs(dd[1]) < 0.9 ? D3{0, 1, 0} : D3{1, 0, 0};
  const D3 p = unitD(cross(ref, dd));
  for (double t : {80.0, 88.0, 92.0, 100.0}) {
    const double c = std::cos(t * kDeg), s = std::sin(t * kDeg);
    n.push_back(unit(c * dd[0] + s * p[0], c * dd[1] + s * p[1], c * dd[2] + s * p[2]));
  }
  return n;
}

LightSet oneLightSet(const AreaLight& l) {
  LightSet s;
  s.lights.push_back(l);
  return s;
}

}  // namespace

// The ellipse's solid angle (a 1D quadrature in lights.cpp) and its shading polygon's irradiance
// (Lambert's formula on the 32-gon of the same frame area, shared.h) against the 2D quadrature of
// the true ellipse. A circular ellipse is a cap: its solid angle is the cap's closed form.
TEST(EllipseLights, SolidAngleAndIrradianceMatchQuadrature) {
  for (double a : {1.0, 20.0, 60.0}) {
    AreaLight l = makeEllipseLight({0, 1, 0}, {0, 0, 1}, {a * kDeg, a * kDeg}, {1, 1, 1});
    const double cap = 2 * M_PI * (1 - std::cos(a * kDeg));
    EXPECT_NEAR(l.solidAngle(), cap, 2e-6 * cap) << a;  // float rounding of the result
  }
  struct Case { V3 dir, up; double a, b; };
  const Case cases[] = {{unit(0, 1, 0), {0, 0, 1}, 5, 2},
                        {unit(0.3, 1, 0.2), {1, 0, 0.4f}, 30, 10},
                        {unit(1, 0.2, -0.3), {0, 1, 0}, 60, 20},
                        {unit(-0.2, 0.5, 1), {0.3f, 1, 0}, 15, 45},
                        {unit(0, 0.1, 1), {0, 1, 0}, 80, 35}};
  double worstOmega = 0, worstE = 0;
  for (const Case& c : cases) {
    const AreaLight l = makeEllipseLight(c.dir, c.up, {c.a * kDeg, c.b * kDeg}, {1, 1, 1});
    const std::vector<V3> normals = someNormals(c.dir);
    const EllipseQuad q = ellipseQuadrature(c.dir, c.up, c.a * kDeg, c.b * kDeg, normals);
    const double eo = std::fabs(l.solidAngle() - q.omega) / q.omega;
    worstOmega = std::max(worstOmega, eo);
    // Measured: worst 1.3e-6, the test quadrature's own error (the library's 512-point periodic
    // trapezoid converges geometrically); bound 1e-5.
    EXPECT_LT(eo, 1e-5) << c.a << " x " << c.b;
    // Irradiance of the 32-gon, relative to the light's irradiance at normal incidence (errors
    // where the horizon clips off most of the light are small in absolute terms). Measured:
    // worst 3.8e-5 over these 5 ellipses x 11 normals; bound 2e-4 (the polygon's boundary is
    // within 0.33% of the ellipse's radius, and its area is the ellipse's: the error is second
    // order, and would be ~1e-3 if the polygon were inscribed instead).
    const double e0 = q.e[0];
    for (std::size_t k = 0; k < normals.size(); ++k) {
      const double e = l.irradiance(normals[k])[0];
      const double err = std::fabs(e - q.e[k]) / e0;
      worstE = std::max(worstE, err);
      EXPECT_LT(err, 2e-4) << c.a << " x " << c.b << " normal " << k << ": " << e << " vs " << q.e[k];
    }
  }
  std::printf("ellipse vs quadrature: solid angle worst relative error %.2e, 32-gon irradiance "
              "worst error %.2e of the normal-incidence irradiance\n", worstOmega, worstE);
}

// lightSamples of an ellipse: inside it, deterministic, and their weights integrate its solid
// angle (sum of weights x the disk area per sample, pi tan a tan b / n); the rotation moves them.
TEST(EllipseLights, SamplesInsideTheEllipseWithTheirSolidAngles) {
  const AreaLight l = makeEllipseLight(unit(0.3, 1, 0.2), {1, 0, 0.4f}, {30 * kDeg, 10 * kDeg}, {1, 1, 1});
  for (int n : {1, 7, 128, 1024}) {
    const auto s = lightSamples(l, n);
    ASSERT_EQ(int(s.size()), n);
    double sum = 0;
    for (const auto& x : s) {
      const auto xy = l.frameCoords(x.dir);
      EXPECT_LE(xy[0] * xy[0] + xy[1] * xy[1], 1.0f + 1e-5f);
      EXPECT_GT(x.weight, 0.0f);
      EXPECT_LE(x.weight, 1.0f);
      sum += x.weight;
    }
    const double omega = sum * M_PI * l.tanHalf[0] * l.tanHalf[1] / n;
    // Fibonacci points on a smooth integrand: measured 3e-5 relative at n = 128; bound 1e-3
    if (n >= 128) EXPECT_NEAR(omega, l.solidAngle(), 1e-3 * l.solidAngle()) << n;
    const auto again = lightSamples(l, n);
    for (int k = 0; k < n; ++k) EXPECT_EQ(again[k].dir, s[k].dir);
  }
  const auto a = lightSamples(l, 64), b = lightSamples(l, 64, 1.0f);
  int moved = 0;
  for (int k = 0; k < 64; ++k) moved += a[k].dir != b[k].dir;
  EXPECT_EQ(moved, 64);
}

// The textured radiance's integral is the light's power: a half-black rect (exact: half the rect's
// solid angle by symmetry), a checkered ellipse against the 2D quadrature of the texture over the
// true ellipse, and a uniform texture giving the texel's radiance exactly.
TEST(TexturedLights, PowerIsTheIntegralOfTheTexture) {
  AreaLight rect = makeRectLight(unit(0, 1, 0), {0, 0, 1}, {20 * kDeg, 10 * kDeg}, {0, 0, 0});
  const float omega = rect.solidAngle();
  setLightTexture(rect, {2, 1, {4, 2, 1, 0, 0, 0}});
  EXPECT_NEAR(rect.power[0], 2 * omega, 1e-6 * omega);
  EXPECT_NEAR(rect.power[1], omega, 1e-6 * omega);
  EXPECT_NEAR(rect.radiance[0], 2.0f, 1e-6f);  // mean: half the bright texel
  EXPECT_EQ(rect.sampleWeight(unit(-0.1, 1, 0.05)), 1.0f);  // x < 0: the left texel
  EXPECT_EQ(rect.sampleWeight(unit(0.1, 1, 0.05)), 0.0f);

  const V3 dir = unit(0.3, 1, 0.2), up = {1, 0, 0.4f};
  AreaLight el = makeEllipseLight(dir, up, {30 * kDeg, 12 * kDeg}, {0, 0, 0});
  LightTexture tex{5, 3, {}};
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 5; ++i)
      for (int c = 0; c < 3; ++c) tex.radiance.push_back(float(1 + (i + 2 * j + c) % 4));
  setLightTexture(el, tex);
  // quadrature: texel of each cell centre, as radianceAt looks it up
  const int nr = 1600, np = 3200;
  const double ta = std::tan(30 * kDeg), tb = std::tan(12 * kDeg);
  double p[3] = {0, 0, 0};
  for (int i = 0; i < nr; ++i)
    for (int j = 0; j < np; ++j) {
      const double r = (i + 0.5) / nr, ph = 2 * M_PI * (j + 0.5) / np;
      const double x = r * std::cos(ph), y = r * std::sin(ph), s = 1 + ta * ta * x * x + tb * tb * y * y;
      const double dw = ta * tb * r / nr * 2 * M_PI / np / (s * std::sqrt(s));
      const int ti = std::min(4, int((x + 1) / 2 * 5)), tj = std::min(2, int((1 - y) / 2 * 3));
      for (int c = 0; c < 3; ++c) p[c] += dw * tex.radiance[(tj * 5 + ti) * 3 + c];
    }
  // Measured: worst 1.2e-5 relative over RGB, this quadrature's own error (its cells straddle
  // texel edges, looked up at their centres: 4.0e-5 at 800 x 1600 cells, 1.2e-5 at 1600 x 3200);
  // bound 5e-5.
  double worst = 0;
  for (int c = 0; c < 3; ++c) {
    worst = std::max(worst, std::fabs(el.power[c] - p[c]) / p[c]);
    EXPECT_NEAR(el.power[c], p[c], 5e-5 * p[c]) << c;
  }
  std::printf("textured ellipse: power vs quadrature of the texture, worst relative error %.2e\n", worst);
  EXPECT_NEAR(el.radiance[0], el.power[0] / el.solidAngle(), 1e-6 * el.radiance[0]);

  AreaLight plain = makeEllipseLight(dir, up, {30 * kDeg, 12 * kDeg}, {0.5f, 2, 3});
  AreaLight uni = makeEllipseLight(dir, up, {30 * kDeg, 12 * kDeg}, {0, 0, 0});
  setLightTexture(uni, {3, 2, std::vector<float>{0.5f, 2, 3, 0.5f, 2, 3, 0.5f, 2, 3, 0.5f, 2, 3, 0.5f, 2, 3, 0.5f, 2, 3}});
  EXPECT_EQ(uni.radiance, plain.radiance);
  EXPECT_EQ(uni.power, plain.power);
  AreaLight cap;
  cap.direction = dir;
  cap.cosAlpha = float(std::cos(10 * kDeg));
  setLightTexture(cap, {1, 2, {1, 1, 1, 3, 3, 3}});  // top half 1, bottom half 3
  // the two halves of the disk have equal solid angles: mean radiance 2 (printed; bound 1e-5
  // relative)
  std::printf("textured cap: mean radiance %.7f (exact 2)\n", cap.radiance[0]);
  EXPECT_NEAR(cap.radiance[0], 2.0f, 2e-5f);
  EXPECT_NEAR(cap.power[0], 2.0f * cap.solidAngle(), 2e-5f * cap.power[0]);
  EXPECT_GT(cap.tanHalf[0], 0.0f);
}

namespace {

// A floor, and a blocker at height h over x < 0: from a floor point at x0 > 0 the light's
// directions towards -x (the rect's left half: its frame's right is +x) pass under the blocker's
// edge only if they are steep enough. Camera straight down on the strip near x = 0.
struct HalfScene {
  Scene scene;
  Camera cam;
  HalfScene() {
    scene.meshes.push_back(planarQuad("floor", -0.2f, 0.6f, -0.4f, 0.4f, 0));
    scene.meshes.push_back(planarQuad("blocker", -1.5f, 0.0f, -1.5f, 1.5f, 0.3f));
    cam.eye = {0.05f, 3, 0.01f};
    cam.target = {0.05f, 0, 0};
    cam.fovyDeg = 4;  // floor x in about [-0.05, 0.15]: the blocker's edge and the penumbra
  }
};

AreaLight halfTextured(bool brightLeft, bool ellipse) {
  // direction +y, up +z: right = d x up = +x
  AreaLight l = ellipse ? makeEllipseLight({0, 1, 0}, {0, 0, 1}, {25 * kDeg, 15 * kDeg}, {0, 0, 0})
                        : makeRectLight({0, 1, 0}, {0, 0, 1}, {25 * kDeg, 15 * kDeg}, {0, 0, 0});
  setLightTexture(l, {2, 1, brightLeft ? std::vector<float>{8, 8, 8, 0, 0, 0}
                                       : std::vector<float>{0, 0, 0, 8, 8, 8}});
  return l;
}

// Visibility at the floor pixels nearest the blocker's edge: x0 in (0, 0.02), where the blocker
// covers the light's whole left half but a sliver (7% of it at x0 = 0.01 for the rect).
struct EdgeVis {
  double mean = 0;
  int pixels = 0;
};
EdgeVis edgeVisibility(const Image& shadowed, const Image& unshadowed, const Camera& cam) {
  EdgeVis v;
  const int W = shadowed.width, H = shadowed.height;
  const CameraBasis b = cameraBasis(cam, W, H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      // the pixel's floor point, as the renderers cast it (cameraRayDirection)
      const Vec3 d = cameraRayDirection(b, W, H, x + 0.5f, y + 0.5f);
      if (!(d[1] < 0)) continue;
      const float fx = b.eye[0] - b.eye[1] / d[1] * d[0];
      if (!(fx > 0.002f && fx < 0.02f)) continue;
      const float u = unshadowed.at(x, y, 0);
      if (!(u > 0)) continue;
      v.mean += shadowed.at(x, y, 0) / u;
      ++v.pixels;
    }
  if (v.pixels) v.mean /= v.pixels;
  return v;
}

}  // namespace

// A blocker over the bright half of a half-black light: near its edge the visibility is near 0
// with the bright half under it and near 1 with the dark half under it (the untextured light
// gives about 1/2 there), in the bitmask technique, brute force and the Embree light-set
// reference alike; and the three images agree.
TEST(TexturedLights, HalfBlackTextureShadowsOnlyItsBrightHalf) {
  HalfScene hs;
  Environment env = builtinEnvironment(64);
  Renderer r(ctx());
  RenderOptions opt;
  opt.width = 32;
  opt.height = 32;
  opt.shadowMapSize = 512;
  ReferenceOptions ro;
  ro.width = opt.width;
  ro.height = opt.height;
  // A half-black light makes the reference's estimate a coin toss per sample (radiance 0 or twice
  // the mean): relative noise 1 / sqrt(spp), 1.1% at 8192.
  ro.spp = 8192;
  for (bool ellipse : {false, true})
    for (bool brightLeft : {true, false}) {
      const LightSet set = oneLightSet(halfTextured(brightLeft, ellipse));
      opt.shadows = ShadowTechnique::None;
      const Image none = r.render(hs.scene, hs.cam, set, env, opt).image;
      opt.shadows = ShadowTechnique::Bitmask;
      opt.bitmask.lightSamples = 1024;
      const Image bm = r.render(hs.scene, hs.cam, set, env, opt).image;
      opt.shadows = ShadowTechnique::Brute;
      opt.brute.samples = 512;
      const Image br = r.render(hs.scene, hs.cam, set, env, opt).image;
      const Image ref = referenceLights(hs.scene, hs.cam, set, env, ro);
      const EdgeVis vb = edgeVisibility(bm, none, hs.cam), vr = edgeVisibility(br, none, hs.cam),
                    ve = edgeVisibility(ref, none, hs.cam);
      const ImageMetrics mb = compareImages(bm, ref), mr = compareImages(br, ref);
      const ImageMetrics mbr = compareImages(bm, br);
      std::printf("%s, bright %s: edge visibility bitmask %.3f brute %.3f reference %.3f (%d px); "
                  "relative RMSE vs reference: bitmask %.4f brute %.4f; bitmask vs brute %.4f\n",
                  ellipse ? "ellipse" : "rect", brightLeft ? "left (under the blocker)" : "right",
                  vb.mean, vr.mean, ve.mean, vb.pixels, mb.relativeRmse, mr.relativeRmse,
                  mbr.relativeRmse);
      ASSERT_GT(vb.pixels, 10);
      for (double v : {vb.mean, vr.mean, ve.mean}) {
        // Geometry: at x0 in (0.002, 0.02) the blocker leaves 1-12% of the left half's directions
        // (rect) open, so the left-bright visibility is below 0.1; the right-bright one is 1
        // (the right half is never blocked). Bounds 0.15 and 0.97 leave room for the edge pixels'
        // texel rounding in brute force's maps and the reference's noise.
        if (brightLeft) EXPECT_LT(v, 0.15);
        else EXPECT_GT(v, 0.97);
      }
      // Measured (rect, ellipse; bright left, right): against the reference bitmask 1.5%, 1.1%,
      // 1.4%, 1.1% and brute force 1.7%, 1.1%, 1.5%, 1.1% relative RMSE, the reference's own
      // noise (1.1%) plus brute force's map texels at the penumbra; bitmask against brute force
      // 0.9%, 0.0%, 0.8%, 0.04%. Bounds 2.5% and 2%.
      EXPECT_LT(mb.relativeRmse, 0.025);
      EXPECT_LT(mr.relativeRmse, 0.025);
      EXPECT_LT(mbr.relativeRmse, 0.02);
      if (brightLeft) {
        // without the weights the same light's visibility there is about 1/2: the weights are
        // what sends it to 0
        AreaLight plain = halfTextured(true, ellipse);
        plain.texture = LightTexture{};
        opt.shadows = ShadowTechnique::Bitmask;
        const Image pl = r.render(hs.scene, hs.cam, oneLightSet(plain), env, opt).image;
        const EdgeVis vp = edgeVisibility(pl, none, hs.cam);
        std::printf("  untextured: edge visibility bitmask %.3f\n", vp.mean);
        EXPECT_GT(vp.mean, 0.35);
        EXPECT_LT(vp.mean, 0.65);
      }
    }
}

// A uniform texture is no texture: every technique that samples the light renders the same image
// bit for bit (AreaLight::sampleWeight gives 1 exactly, setLightTexture the texel's radiance).
TEST(TexturedLights, UniformTextureRendersAsNoTextureBitForBit) {
  HalfScene hs;
  Environment env = builtinEnvironment(64);
  Renderer r(ctx());
  RenderOptions opt;
  opt.width = 24;
  opt.height = 20;
  opt.shadowMapSize = 128;
  for (bool ellipse : {false, true}) {
    AreaLight plain = ellipse ? makeEllipseLight(unit(0.2, 1, 0), {0, 0, 1}, {20 * kDeg, 8 * kDeg}, {1, 2, 3})
                              : makeRectLight(unit(0.2, 1, 0), {0, 0, 1}, {20 * kDeg, 8 * kDeg}, {1, 2, 3});
    AreaLight tex = plain;
    setLightTexture(tex, {2, 2, {1, 2, 3, 1, 2, 3, 1, 2, 3, 1, 2, 3}});
    for (ShadowTechnique t : {ShadowTechnique::Bitmask, ShadowTechnique::Brute, ShadowTechnique::PCSS}) {
      opt.shadows = t;
      opt.bitmask.lightSamples = 128;
      opt.brute.samples = 64;
      const Image a = r.render(hs.scene, hs.cam, oneLightSet(plain), env, opt).image;
      const Image b = r.render(hs.scene, hs.cam, oneLightSet(tex), env, opt).image;
      ASSERT_EQ(a.pixels.size(), b.pixels.size());
      int differ = 0;
      for (std::size_t i = 0; i < a.pixels.size(); ++i) differ += a.pixels[i] != b.pixels[i];
      EXPECT_EQ(differ, 0) << toString(t);
    }
  }
}

// The bitmask technique's samples of an ellipse light are the disk's affine image: every one
// inside the true ellipse, the capture's weights those of the texture, and every captured bit
// agrees with an Embree shadow ray along the sample's direction (src/shadows/bitmask.hpp
// SampleTracer).
TEST(EllipseLights, BitmaskSamplesTheEllipseItself) {
  HalfScene hs;
  const AreaLight l = halfTextured(true, true);
  detail::BitmaskCapture cap;
  detail::setBitmaskCapture(&cap);
  Renderer r(ctx());
  RenderOptions opt;
  opt.width = 20;
  opt.height = 16;
  opt.shadows = ShadowTechnique::Bitmask;
  opt.bitmask.lightSamples = 256;
  r.render(hs.scene, hs.cam, oneLightSet(l), Environment{builtinEnvironment(64)}, opt);
  detail::setBitmaskCapture(nullptr);
  ASSERT_EQ(cap.frames.size(), 1u);
  ASSERT_EQ(cap.weights.size(), 256u);
  const float ta = cap.grids[0].tan_alpha;
  int bright = 0;
  for (int k = 0; k < 256; ++k) {
    const auto d = detail::bitmaskSampleDirection(cap.lights[0], ta, cap.frames[0], cap.disk[k][0], cap.disk[k][1]);
    const auto xy = l.frameCoords(d);
    EXPECT_NEAR(xy[0] * xy[0] + xy[1] * xy[1], cap.disk[k][0] * cap.disk[k][0] + cap.disk[k][1] * cap.disk[k][1], 1e-4f);
    EXPECT_EQ(cap.weights[k], xy[0] < 0 ? 1.0f : 0.0f) << k;
    bright += cap.weights[k] > 0;
  }
  EXPECT_GT(bright, 100);
  EXPECT_LT(bright, 156);
  detail::SampleTracer tracer(hs.scene);
  std::int64_t pairs = 0, agree = 0;
  for (int px = 0; px < cap.pixels; ++px) {
    if (cap.slot[px] < 0) continue;
    const auto& P = cap.gpos[px];
    const auto& G = cap.ggeo[px];
    const float eps = 1e-4f * (1.0f + std::max({std::fabs(P[0]), std::fabs(P[1]), std::fabs(P[2])}));
    for (int k = 0; k < 256; ++k) {
      const auto d = detail::bitmaskSampleDirection(cap.lights[0], ta, cap.frames[0], cap.disk[k][0], cap.disk[k][1]);
      const float side = G[0] * d[0] + G[1] * d[1] + G[2] * d[2] >= 0 ? eps : -eps;
      const bool ref = tracer.occluded({P[0] + side * G[0], P[1] + side * G[1], P[2] + side * G[2]}, d);
      const bool ours = (cap.masks[std::size_t(px) * cap.words + k / 32] >> (k % 32)) & 1u;
      ++pairs;
      agree += ref == ours;
    }
  }
  std::printf("ellipse light, bitmask 256 samples: %lld of %lld (view sample, light sample) pairs "
              "agree with Embree\n", (long long)agree, (long long)pairs);
  ASSERT_GT(pairs, 1000);
  // the technique is exact per pair; disagreements are pairs within rounding of the blocker's
  // edge (measured: 0 of the pairs here); bound 1e-3 as tests/test_bitmask.cpp's agreement tests
  EXPECT_GE(double(agree) / double(pairs), 0.999);
}

// Light-set JSON: ellipses and textured lights load, toJson writes them back as such, and bad
// input names the file and the light.
TEST(TexturedLights, LightSetJsonRoundTripAndBadInput) {
  const std::string text = R"({"lights": [
    {"shape": "ellipse", "direction": [0.3, 1, 0.2], "up": [1, 0, 0.4], "half_angles_deg": [30, 10], "radiance": [1, 2, 3]},
    {"shape": "rect", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [20, 10],
     "texture": {"width": 2, "height": 1, "radiance": [4, 2, 1, 0, 0, 0]}},
    {"shape": "cap", "direction": [1, 1, 0], "half_angle_deg": 12, "up": [0, 1, 0],
     "texture": {"width": 1, "height": 2, "radiance": [1, 1, 1, 3, 3, 3]}},
    {"shape": "ellipse", "direction": [0, 1, 1], "up": [0, 1, 0], "half_angles_deg": [5, 40], "power": [1, 1, 1],
     "texture": {"width": 3, "height": 1, "radiance": [1, 1, 1, 0, 0, 0, 2, 2, 2]}}
  ]})";
  const LightSet a = lightSetFromJson(text, "lights.json");
  ASSERT_EQ(a.lights.size(), 4u);
  EXPECT_EQ(a.lights[0].outline, AreaLight::Outline::Ellipse);
  EXPECT_EQ(int(a.lights[0].vertices.size()), PB_ELLIPSE_VERTS);
  EXPECT_NEAR(a.lights[0].tanHalf[0], std::tan(30 * kDeg), 1e-6);
  EXPECT_NEAR(a.lights[0].power[0], a.lights[0].solidAngle(), 1e-6);
  EXPECT_EQ(a.lights[1].outline, AreaLight::Outline::Rect);
  EXPECT_NEAR(a.lights[1].radiance[0], 2.0f, 1e-5f);
  EXPECT_EQ(a.lights[2].texture.height, 2);
  EXPECT_EQ(a.lights[3].power, (std::array<float, 3>{1, 1, 1}));  // as given
  // "power" beside a texture scales the texture to it: its mean (the radiance) times the solid
  // angle is the power, as for every other light (it kept the texture's own scale before).
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(a.lights[3].radiance[c] * a.lights[3].solidAngle(), 1.0f, 1e-4f) << c;
  const LightSet b = lightSetFromJson(a.toJson(), "again.json");
  ASSERT_EQ(b.lights.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    const AreaLight &x = a.lights[i], &y = b.lights[i];
    EXPECT_EQ(x.shape, y.shape) << i;
    EXPECT_EQ(x.outline, y.outline) << i;
    EXPECT_EQ(x.texture.width, y.texture.width) << i;
    EXPECT_EQ(x.texture.radiance, y.texture.radiance) << i;
    EXPECT_EQ(x.vertices.size(), y.vertices.size()) << i;
    for (std::size_t v = 0; v < x.vertices.size(); ++v)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(x.vertices[v][c], y.vertices[v][c], 1e-6f) << i;
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(x.axisU[c], y.axisU[c], 1e-6f) << i;
      EXPECT_NEAR(x.power[c], y.power[c], 1e-6f * (1 + x.power[c])) << i;
      EXPECT_NEAR(x.radiance[c], y.radiance[c], 1e-6f * (1 + x.radiance[c])) << i;
    }
    for (int c = 0; c < 2; ++c) EXPECT_NEAR(x.tanHalf[c], y.tanHalf[c], 1e-6f) << i;
  }
  struct Bad { std::string light, expect; };
  const std::string ok = R"({"shape": "cap", "direction": [0, 1, 0], "half_angle_deg": 10, "radiance": [1, 1, 1]})";
  const Bad bad[] = {
      {R"({"shape": "ellipse", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [0, 10], "radiance": [1, 1, 1]})", "half_angles_deg"},
      {R"({"shape": "ellipse", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 90], "radiance": [1, 1, 1]})", "half_angles_deg"},
      {R"({"shape": "ellipse", "direction": [0, 1, 0], "up": [0, 2, 0], "half_angles_deg": [30, 10], "radiance": [1, 1, 1]})", "parallel"},
      {R"({"shape": "rect", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 10], "texture": {"width": 2, "height": 2, "radiance": [1, 1, 1]}})", "needs 12 radiance values"},
      {R"({"shape": "rect", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 10], "texture": {"width": 1, "height": 1, "radiance": [1, -1, 1]}})", "finite number >= 0"},
      {R"({"shape": "rect", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 10], "texture": {"width": 1, "height": 1, "radiance": [1, 1e39, 1]}})", "finite number >= 0"},  // beyond float; 1e999, beyond double, is a JSON error (test_json.cpp)
      {R"({"shape": "rect", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 10], "texture": {"width": 1.5, "height": 1, "radiance": [1, 1, 1]}})", "integers"},
      {R"({"shape": "rect", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 10], "texture": {"width": 0, "height": 1, "radiance": []}})", "integers"},
      {R"({"shape": "rect", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 10], "texture": {"width": 1, "height": 1, "radiance": [0, 0, 0]}})", "black"},
      {R"({"shape": "polygon", "vertices": [[0.1, 1, 0.1], [-0.1, 1, 0.1], [0, 1, -0.1]], "texture": {"width": 1, "height": 1, "radiance": [1, 1, 1]}})", "no frame"},
      // only the corner texel (0, 0) is bright, and it lies wholly outside the disk
      {R"({"shape": "cap", "direction": [0, 1, 0], "half_angle_deg": 10, "texture": {"width": 8, "height": 8, "radiance": [1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]}})", "black over the light"},
      {R"({"shape": "rect", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 10], "power": [1, 1, 1], "texture": {"width": 1, "height": 1, "radiance": [1, 0, 0]}})", "where the texture is black"},
      {R"({"shape": "rect", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 10], "texture": [1, 2]})", "texture"},
      {R"({"shape": "ellipse", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 10]})", "needs \"radiance\""},
  };
  for (const Bad& x : bad) {
    const std::string doc = "{\"lights\": [" + ok + ", " + x.light + "]}";
    try {
      lightSetFromJson(doc, "user.json");
      ADD_FAILURE() << "accepted: " << x.light;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      const std::string m = e.what();
      EXPECT_NE(m.find("user.json: light 1"), std::string::npos) << m;
      EXPECT_NE(m.find(x.expect), std::string::npos) << m;
    }
  }
}

// Under oclgrind (--check-api --data-races): one bitmask frame with a textured ellipse light and
// a plain cap (two frames, one weighted), 64 samples, a jittered frame; the resolve recomputed in
// C++ from the capture's masks, frames and weights.
TEST(OclgrindTexturedLights, BitmaskFrame) {
  HalfScene hs;
  LightSet set = oneLightSet(halfTextured(true, true));
  AreaLight cap;
  cap.direction = unit(0.3, 1, 0.1);
  cap.cosAlpha = float(std::cos(8 * kDeg));
  cap.radiance = {1, 1, 1};
  set.lights.push_back(cap);
  detail::BitmaskCapture c;
  detail::setBitmaskCapture(&c);
  Renderer r(ctx());
  RenderOptions opt;
  opt.width = 9;
  opt.height = 7;
  opt.shadowMapSize = 4;
  opt.shadows = ShadowTechnique::Bitmask;
  opt.bitmask.lightSamples = 64;
  opt.bitmask.jitter = 3;
  r.render(hs.scene, hs.cam, set, Environment{builtinEnvironment(16)}, opt);
  detail::setBitmaskCapture(nullptr);
  const std::vector<float> vis = r.lastVisibility();
  const int nl = 2, npx = c.pixels, K = int(c.disk.size());
  ASSERT_EQ(vis.size(), std::size_t(nl) * npx);
  int shadowed = 0;
  for (int l = 0; l < nl; ++l)
    for (int px = 0; px < npx; ++px) {
      const std::size_t at = std::size_t(l) * npx + px;
      double expect = 1.0;
      if (c.slot[at] >= 0) {
        const pb_light& L = c.lights[l];
        const auto& n = c.gnrm[px];
        const auto& fr = c.frames[l];
        const double nx = n[0] * fr.e1[0] + n[1] * fr.e1[1] + n[2] * fr.e1[2];
        const double ny = n[0] * fr.e2[0] + n[1] * fr.e2[1] + n[2] * fr.e2[2];
        const double nz = n[0] * L.dir[0] + n[1] * L.dir[1] + n[2] * L.dir[2];
        const double ta = c.grids[l].tan_alpha;
        double total = 0, lit = 0;
        bool any = false;
        for (int k = 0; k < K; ++k) {
          const double u = c.disk[k][0] * ta * fr.e1[3], v = c.disk[k][1] * ta * fr.e2[3];
          const double q = 1 + u * u + v * v;
          const double w = std::max(nz + u * nx + v * ny, 0.0) / (q * q) * c.weights[std::size_t(l) * K + k];
          const bool blocked = (c.masks[at * c.words + k / 32] >> (k % 32)) & 1u;
          any |= blocked;
          total += w;
          if (!blocked) lit += w;
        }
        expect = any && total > 0 ? lit / total : 1.0;
      }
      shadowed += expect < 0.99;
      ASSERT_NEAR(vis[at], expect, 2e-5) << "light " << l << " pixel " << px;
    }
  EXPECT_GT(shadowed, 0);
}

// The example light set (an ellipse, a textured rect, a textured cap) loads and every technique
// renders it: finite pixels no brighter than the unshadowed frame (a shadow only takes light away).
TEST(TexturedLights, EveryTechniqueRendersTheExampleFile) {
  const LightSet set =
      loadLightSet(std::string(PENUMBRA_TEST_DATA) + "/../../examples/lights/lamp_and_stained_window.json");
  ASSERT_EQ(set.lights.size(), 3u);
  EXPECT_EQ(set.lights[0].outline, AreaLight::Outline::Ellipse);
  EXPECT_FALSE(set.lights[1].texture.empty());
  EXPECT_FALSE(set.lights[2].texture.empty());
  Scene scene = builtinScene();
  const Camera cam = frameCamera(scene, 17.0f / 9.0f);
  Environment env = builtinEnvironment(64);
  Renderer r(ctx());
  RenderOptions opt;
  opt.width = 17;
  opt.height = 9;
  opt.shadowMapSize = 64;
  opt.shadows = ShadowTechnique::None;
  const Image a = r.render(scene, cam, set, env, opt).image;
  for (ShadowTechnique t : {ShadowTechnique::Hard, ShadowTechnique::PCSS, ShadowTechnique::CSSM,
                            ShadowTechnique::MSSM4, ShadowTechnique::MSSM6, ShadowTechnique::Brute,
                            ShadowTechnique::Bitmask, ShadowTechnique::BitmaskHard,
                            ShadowTechnique::AreaApprox}) {
    opt.shadows = t;
    opt.brute.samples = 64;
    opt.bitmask.lightSamples = 128;
    const Image b = r.render(scene, cam, set, env, opt).image;
    for (int y = 0; y < b.height; ++y)
      for (int x = 0; x < b.width; ++x)
        for (int c = 0; c < 3; ++c) {
          EXPECT_TRUE(std::isfinite(b.at(x, y, c))) << toString(t);
          EXPECT_LE(b.at(x, y, c), a.at(x, y, c) * 1.0001f + 1e-6f) << toString(t);
        }
  }
}

// Extracted lights textured from their map (textureLightsFromMap): power and mean radiance stay
// as extracted, each light's sample weights follow the map's luminance towards the samples, and
// more closely with finer textures.
TEST(TexturedLights, ExtractOptionsRefuseATextureSizeOutOfRange) {
  const Environment env = builtinEnvironment();
  for (int bad : {-1, 65}) {
    ExtractOptions eo;
    eo.lightTexture = bad;
    try {
      extractLights(ctx(), env, eo);
      ADD_FAILURE() << "accepted lightTexture " << bad;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find("lightTexture"), std::string::npos) << e.what();
    }
  }
}

TEST(TexturedLights, ExtractedLightsTakeTheirMapsRadiance) {
  const Environment env = loadEnvironment(data(kMaps[0]));
  MedianCutOptions mo;
  mo.lights = 8;
  mo.faceSize = 64;
  const LightSet plain = extractMedianCut(ctx(), env, mo);
  double meanR[2] = {0, 0};
  const int sizes[2] = {8, 16};
  for (int pass = 0; pass < 2; ++pass) {
    LightSet set = plain;
    textureLightsFromMap(env, set, sizes[pass], 4);
    ASSERT_EQ(set.lights.size(), plain.lights.size());
    int varied = 0;
    for (std::size_t i = 0; i < set.lights.size(); ++i) {
      const AreaLight &l = set.lights[i], &p = plain.lights[i];
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(l.power[c], p.power[c], 1e-5f * p.power[c] + 1e-12f) << i;
        EXPECT_NEAR(l.radiance[c], p.radiance[c], 1e-5f * p.radiance[c] + 1e-12f) << i;
      }
      if (l.texture.empty()) continue;
      // Pearson correlation of the sample weights with the map's luminance along the samples
      const auto s = lightSamples(l, 256);
      double sw = 0, sm = 0, sww = 0, smm = 0, swm = 0;
      for (const auto& x : s) {
        float rgb[3];
        env.lookup(x.dir[0], x.dir[1], x.dir[2], rgb);
        const double m = PB_LUM_R * rgb[0] + PB_LUM_G * rgb[1] + PB_LUM_B * rgb[2], w = x.weight;
        sw += w, sm += m, sww += w * w, smm += m * m, swm += w * m;
      }
      const double n = double(s.size());
      const double vw = sww / n - (sw / n) * (sw / n), vm = smm / n - (sm / n) * (sm / n);
      if (!(vw > 1e-6 && vm > 1e-12)) continue;  // a uniform patch of the map
      ++varied;
      const double r = (swm / n - sw / n * sm / n) / std::sqrt(vw * vm);
      std::printf("%d x %d textures, light %zu: correlation of weights with the map %.3f\n",
                  sizes[pass], sizes[pass], i, r);
      // Measured: 0.65 to 0.89 at 8 x 8 (the texture averages 16 look-ups per texel, each
      // sample looks up one map texel, so detail finer than a texel is lost); untextured weights
      // are constant (no correlation). Bound 0.5.
      EXPECT_GT(r, 0.5) << i;
      meanR[pass] += r;
    }
    ASSERT_GT(varied, 0);
    meanR[pass] /= varied;
  }
  std::printf("mean correlation: 8 x 8 %.3f, 16 x 16 %.3f\n", meanR[0], meanR[1]);
  EXPECT_GT(meanR[1], meanR[0]);
  LightSet set = plain;
  try {
    textureLightsFromMap(env, set, 0, 4);
    ADD_FAILURE() << "size 0 accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    EXPECT_NE(std::string(e.what()).find("got 0"), std::string::npos) << e.what();
  }
}

// `penumbra lights --light-texture N` writes textured caps that load back; out-of-range N is
// bad input (exit 2) naming the option.
TEST(TexturedLights, CliLightTexture) {
  // Named by process: two runs at once (two checkouts, CI beside a developer) must not share them.
  const std::string stem = ::testing::TempDir() + "/textured_lights_" + std::to_string(::getpid());
  const std::string out = stem + ".json", err = stem + ".err";
  const std::string cli = PENUMBRA_CLI;
  int rc = std::system((cli + " lights --lights 3 --face-size 32 --light-texture 3 --out " + out +
                        " 2> " + err).c_str());
  ASSERT_EQ(rc, 0);
  const LightSet set = loadLightSet(out);
  ASSERT_EQ(set.lights.size(), 3u);
  int textured = 0;
  for (const AreaLight& l : set.lights)
    if (!l.texture.empty()) {
      ++textured;
      EXPECT_EQ(l.texture.width, 3);
      EXPECT_EQ(l.texture.height, 3);
    }
  EXPECT_GT(textured, 0);
  rc = std::system((cli + " lights --light-texture 65 --out " + out + " 2> " + err).c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 2);
  std::FILE* f = std::fopen(err.c_str(), "r");
  ASSERT_NE(f, nullptr);
  char buf[512] = {0};
  const std::size_t got = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  std::remove(out.c_str());
  std::remove(err.c_str());
  EXPECT_NE(std::string(buf, got).find("--light-texture must be in [1, 64], got 65"), std::string::npos) << buf;
}
