// Tests for what the library refuses before it works: device memory (a buffer over the device's
// per-buffer limit, a context over its global memory, a frame whose own buffers cannot fit) and
// the inputs handed to Renderer::render in code, checked as the file loaders check files.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <unistd.h>

#include "common.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

// One triangle over a ground quad, and one light straight above: a scene every check accepts.
struct SmallFrame {
  Scene scene;
  Camera camera;
  LightSet lights;
  Environment env = builtinEnvironment(64);
  RenderOptions opt;
  SmallFrame() {
    scene.meshes.push_back(planarQuad("ground", -2, 2, -2, 2, 0));
    Mesh tri;
    tri.name = "tri";
    tri.positions = {{0, 1, 0}, {1, 1, 0}, {0, 1, 1}};
    tri.triangles = {{0, 2, 1}};
    scene.meshes.push_back(tri);
    camera = frameCamera(scene, 2.0f);
    AreaLight l;
    l.direction = {0, 1, 0};
    l.cosAlpha = std::cos(0.2f);
    l.setPower({1, 1, 1});
    lights.lights.push_back(l);
    opt.width = 32;
    opt.height = 16;
    opt.shadowMapSize = 64;
  }
  Frame render() {
    Renderer r(ctx());
    return r.render(scene, camera, lights, env, opt);
  }
};

}  // namespace

// ----- device memory --------------------------------------------------------------------------

TEST(DeviceMemory, LedgerCountsLiveBuffers) {
  Context& c = ctx();
  c.finish();
  const std::uint64_t before = c.deviceBytesInUse();
  {
    cl::Buffer a = c.buffer(3 << 20, "test buffer a");
    cl::Buffer b = c.buffer(5 << 20, "test buffer b");
    EXPECT_EQ(c.deviceBytesInUse(), before + (8u << 20));
    EXPECT_GE(c.peakDeviceBytes(), before + (8u << 20));
    cl::Buffer copy = a;  // a second handle to the same memory counts once
    EXPECT_EQ(c.deviceBytesInUse(), before + (8u << 20));
  }
  c.finish();
  EXPECT_EQ(c.deviceBytesInUse(), before);
  c.resetPeakDeviceBytes();
  EXPECT_EQ(c.peakDeviceBytes(), before);
}

TEST(DeviceMemory, OverTheDeviceLimitsIsRefusedBeforeTheDriver) {
  Context& c = ctx();
  const DeviceInfo& d = c.info();
  ASSERT_GT(d.maxAllocBytes, 0u);
  ASSERT_GE(d.globalMemBytes, d.maxAllocBytes);
  expectError(ErrorKind::OutOfMemory, [&] { c.buffer(d.maxAllocBytes + 1, "one huge buffer"); },
              {"one huge buffer", "per buffer", d.name});
  // Buffers each within the per-buffer limit, together over the global memory: the one that
  // would pass it is refused, and nothing is left counted afterwards.
  const std::uint64_t before = c.deviceBytesInUse();
  std::vector<cl::Buffer> held;
  try {
    for (int i = 0; i < 64; ++i) held.push_back(c.buffer(d.maxAllocBytes, "slice " + std::to_string(i)));
    ADD_FAILURE() << "64 buffers of the per-buffer limit fit the device";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::OutOfMemory) << e.what();
    EXPECT_NE(std::string(e.what()).find("already in use"), std::string::npos) << e.what();
  }
  EXPECT_LE(c.deviceBytesInUse(), d.globalMemBytes);
  held.clear();
  c.finish();
  EXPECT_EQ(c.deviceBytesInUse(), before);
}

// Issue 14: 16384^2 aborted inside PoCL after 2.9 s; now refused up front naming the sizes.
TEST(DeviceMemory, FrameTooLargeForTheDeviceIsRefusedUpFront) {
  SmallFrame f;
  f.opt.width = 16384;
  f.opt.height = 16384;
  const auto t0 = std::chrono::steady_clock::now();
  expectError(ErrorKind::OutOfMemory, [&] { f.render(); },
              {"16384x16384", "MiB", ctx().info().name});
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  // The same renderer inputs at a small size still render.
  f.opt.width = 32;
  f.opt.height = 16;
  EXPECT_EQ(f.render().image.width, 32);
}

// ----- inputs given in code -------------------------------------------------------------------

TEST(RenderInputs, ValidFrameRenders) {
  SmallFrame f;
  const Frame frame = f.render();
  for (float v : frame.image.pixels) ASSERT_TRUE(std::isfinite(v));
}

TEST(RenderInputs, SceneIsCheckedAsAFileWouldBe) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  {
    SmallFrame f;  // a triangle indexing vertex 9 of 3 (the kernels read past the buffer before)
    f.scene.meshes[1].triangles[0] = {0, 9, 1};
    expectError(ErrorKind::BadInput, [&] { f.render(); },
                {"Scene.meshes[1] 'tri'", "triangle 0 refers to vertex 9 of 3"});
  }
  {
    SmallFrame f;
    f.scene.meshes[1].triangles[0] = {0, -1, 1};
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"refers to vertex -1"});
  }
  {
    SmallFrame f;
    f.scene.meshes[1].positions[2] = {nan, 0, 0};
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"'tri'", "non-finite vertex position 2"});
  }
  {
    SmallFrame f;
    f.scene.meshes[0].normals[1] = {0, 0, 0};
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"'ground'", "normal 1"});
  }
  {
    SmallFrame f;
    f.scene.meshes[0].normals.pop_back();
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"3 normals for 4 positions"});
  }
  {
    SmallFrame f;
    f.scene.meshes[1].albedo = {0.5f, 1.5f, 0.5f};
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"'tri'", "albedo"});
  }
}

TEST(RenderInputs, LightsAreCheckedAsALightSetFileWouldBe) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  {
    SmallFrame f;
    f.lights.lights[0].direction = {nan, 1, 0};
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"LightSet: light 0", "direction"});
  }
  {
    SmallFrame f;
    f.lights.lights[0].direction = {0, 2, 0};
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"unit vector"});
  }
  {
    SmallFrame f;
    f.lights.lights[0].radiance = {1, -1, 1};
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"light 0", "radiance"});
  }
  {
    SmallFrame f;
    f.lights.lights[0].cosAlpha = std::numeric_limits<float>::quiet_NaN();
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"cosAlpha"});
  }
  {
    SmallFrame f;
    f.lights.ambientSH[3][1] = nan;
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"ambientSH"});
  }
}

TEST(RenderInputs, CameraAndEnvironmentAreChecked) {
  const float inf = std::numeric_limits<float>::infinity();
  {
    SmallFrame f;
    f.camera.eye = {0, inf, 0};
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"camera", "finite"});
  }
  {
    SmallFrame f;
    f.env.equirect.pixels[7] = -1.0f;
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"environment map", "negative"});
  }
  {
    SmallFrame f;
    f.env.rotationYDeg = inf;
    expectError(ErrorKind::BadInput, [&] { f.render(); }, {"rotationYDeg"});
  }
}

// An 8-bit image is accepted as an environment map by design, decoded from its sRGB encoding
// (IEC 61966-2-1): a stored value s becomes ((s + 0.055) / 1.055)^2.4, e.g. 0.5 becomes 0.214.
TEST(EnvironmentInput, LdrMapIsDecodedFromSrgb) {
  const std::string png =
      testing::TempDir() + "/penumbra_ldr_map_" + std::to_string(::getpid()) + ".png";
  Image img(8, 4, 3);
  for (std::size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = 0.05f * float(i % 40);
  writeImage(png, img, 1.0f);  // tone-mapped and sRGB-encoded into 8 bits
  const Image stored = readImage(png);
  const Environment env = loadEnvironment(png);
  ASSERT_EQ(env.equirect.pixels.size(), stored.pixels.size());
  int midTones = 0;
  for (std::size_t i = 0; i < stored.pixels.size(); ++i) {
    const float s = stored.pixels[i];
    const float linear = s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f);
    ASSERT_NEAR(env.equirect.pixels[i], linear, 1e-5f) << i;
    if (s > 0.3f && s < 0.7f) {
      ++midTones;
      EXPECT_LT(env.equirect.pixels[i], 0.75f * s) << i;  // decoding darkens mid-tones
    }
  }
  EXPECT_GT(midTones, 0);
  std::remove(png.c_str());
}
