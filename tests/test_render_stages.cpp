// The renderer's stages (src/render/): the device scene re-uploads only what changed, a renderer
// follows a changing scene, and the Context's event list stays bounded over long runs.
#include <gtest/gtest.h>

#include "common.hpp"
#include "render/device_scene.hpp"

using namespace penumbra;

namespace {

Scene twoTriangles() {
  Scene s;
  Mesh m;
  m.name = "quad";
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  s.meshes.push_back(m);
  return s;
}

}  // namespace

// An unchanged scene or environment is not uploaded again; a change of one bit is, and the
// device then holds the new data. Mesh names are not geometry.
TEST(RenderStages, DeviceSceneUploadsOnlyWhatChanged) {
  Context& c = test::ctx();
  detail::DeviceScene ds(c);
  Scene s = twoTriangles();
  ds.update(s);
  EXPECT_EQ(ds.sceneUploads(), 1);
  ds.update(s);
  s.meshes[0].name = "renamed";
  ds.update(s);
  EXPECT_EQ(ds.sceneUploads(), 1);
  s.meshes[0].positions[2][2] = -0.0f;  // equal to 0 as a float, not as bits
  ds.update(s);
  EXPECT_EQ(ds.sceneUploads(), 2);
  s.meshes[0].positions[2][1] = 2.0f;
  ds.update(s);
  EXPECT_EQ(ds.sceneUploads(), 3);
  ASSERT_EQ(ds.positions().size(), 4u);
  auto dev = c.download<cl_float4>(ds.positionBuffer(), 4, "positions");
  EXPECT_EQ(dev[2].s[1], 2.0f);
  EXPECT_EQ(ds.positions()[2].s[1], 2.0f);
  EXPECT_EQ(ds.triangleCount(), 2);
  s.meshes.push_back(s.meshes[0]);  // a second mesh
  ds.update(s);
  EXPECT_EQ(ds.sceneUploads(), 4);
  EXPECT_EQ(ds.triangleCount(), 4);
  EXPECT_EQ(ds.triangles()[3].s[3], 1);  // its triangles name mesh 1
  EXPECT_EQ(ds.triangles()[3].s[0], 4);  // and index its own vertices

  Environment env = builtinEnvironment(16);
  ds.environment(env);
  ds.environment(env);
  EXPECT_EQ(ds.environmentUploads(), 1);
  env.equirect.pixels[5] += 1.0f;
  const cl::Buffer& b = ds.environment(env);
  EXPECT_EQ(ds.environmentUploads(), 2);
  EXPECT_EQ(c.download<float>(b, 6, "environment")[5], env.equirect.pixels[5]);
}

// One renderer over a changing scene: frames of the moved scene differ, and going back to the
// first scene gives the first frame again, bit for bit (nothing stale stays on the device).
TEST(RenderStages, RendererFollowsAChangingScene) {
  Context& c = test::ctx();
  Renderer r(c);
  Environment env = builtinEnvironment(64);
  RenderOptions ro;
  ro.width = 48;
  ro.height = 27;
  ro.shadowMapSize = 64;
  ro.shadows = ShadowTechnique::Hard;
  MedianCutOptions mc;
  mc.lights = 4;
  const LightSet lights = extractMedianCut(c, env, mc);
  const Scene s0 = builtinScene(0.0f), s1 = builtinScene(0.75f);
  const Camera cam = frameCamera(s0, 48.0f / 27.0f);
  const Frame a = r.render(s0, cam, lights, env, ro);
  const Frame b = r.render(s1, cam, lights, env, ro);
  const Frame a2 = r.render(s0, cam, lights, env, ro);
  EXPECT_NE(a.image.pixels, b.image.pixels);
  EXPECT_EQ(a.image.pixels, a2.image.pixels);
  Environment darker = env;
  for (float& v : darker.equirect.pixels) v *= 0.5f;
  ro.environmentBackground = true;
  const Frame d = r.render(s0, cam, lights, darker, ro);
  const Frame e = r.render(s0, cam, lights, env, ro);
  EXPECT_NE(d.image.pixels, e.image.pixels);  // the background shows the new map
}

// Far more launches than the bound: the held events stay under it, and the stages keep their
// first-launch order, including one first launched after events were folded.
TEST(RenderStages, ContextEventListIsBounded) {
  Context& c = test::ctx();
  c.resetTimings();
  std::vector<cl_uint> v(4, PB_DEPTH_EMPTY);
  cl::Buffer front = c.upload(v, "front"), back = c.upload(v, "back");
  cl::Kernel k = c.kernel("raster.cl", "combine_front_back");
  const std::size_t n = Context::kEventBound * 2 + 100;
  std::size_t most = 0;
  for (std::size_t i = 0; i < n; ++i) {
    c.launchWith(i % 2 ? "bounded/b" : "bounded/a", k, cl::NDRange(4), cl::NullRange, front, back,
                 cl_int(4));
    most = std::max(most, c.heldEvents());
  }
  c.launchWith("bounded/c", k, cl::NDRange(4), cl::NullRange, front, back, cl_int(4));
  EXPECT_LE(most, Context::kEventBound);
  const auto t = c.stageTimesMs();
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].first, "bounded/a");
  EXPECT_EQ(t[1].first, "bounded/b");
  EXPECT_EQ(t[2].first, "bounded/c");
  for (auto& [name, ms] : t) EXPECT_GE(ms, 0.0) << name;
  EXPECT_GT(t[0].second + t[1].second, 0.0);
  c.resetTimings();
  EXPECT_EQ(c.heldEvents(), 0u);
  EXPECT_TRUE(c.stageTimesMs().empty());
}
