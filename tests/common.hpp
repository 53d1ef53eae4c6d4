// Shared fixtures for the test suite: one OpenCL context for the whole binary, data paths.
#pragma once
#include <gtest/gtest.h>
#include <penumbra/penumbra.hpp>

#include "support/expect_error.hpp"

#include "common/shared.h"  // the kernels' constants and helpers (kernels/common/shared.h)

#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace penumbra::test {

// Never destroyed: under oclgrind a Context released during static destruction (after LLVM's
// own static state is gone) corrupts the heap and aborts the run.
// Drains the shared queue once every test has run, before main returns: a test whose last call
// leaves kernels queued would otherwise have PoCL compile them during the process's static
// teardown, after LLVM's own statics are gone, and abort (seen with Scan.BadInputThrows run alone).
// Registered when the context is made (GoogleTest tears environments down in reverse at the end
// of the run, also those added while it runs).
class DrainQueueAtEnd : public ::testing::Environment {
 public:
  explicit DrainQueueAtEnd(Context* c) : c_(c) {}
  void TearDown() override { c_->queue().finish(); }

 private:
  Context* c_;
};
inline Context& ctx() {
  static Context* c = [] {
    Context* made = new Context;
    ::testing::AddGlobalTestEnvironment(new DrainQueueAtEnd(made));
    return made;
  }();
  return *c;
}

// Small double-precision vector helpers for tests that build light geometry by hand
// (polygon, ellipse and textured lights); in their own namespace so that test files with
// other `dot`/`unit` overloads are not affected.
namespace dvec {
using V3 = std::array<float, 3>;
using D3 = std::array<double, 3>;
inline D3 cross(const D3& a, const D3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double dot(const D3& a, const D3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline D3 unitD(const D3& a) {
  const double l = std::sqrt(dot(a, a));
  return {a[0] / l, a[1] / l, a[2] / l};
}
inline V3 unit(double x, double y, double z) {
  const D3 u = unitD({x, y, z});
  return {float(u[0]), float(u[1]), float(u[2])};
}
}  // namespace dvec

// A uniformly random unit vector (rejection from the cube, away from the centre).
inline std::array<float, 3> randomUnit(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (;;) {
    const float x = 2 * u(rng) - 1, y = 2 * u(rng) - 1, z = 2 * u(rng) - 1;
    const float l = std::sqrt(x * x + y * y + z * z);
    if (l > 0.1f && l <= 1.0f) return {x / l, y / l, z / l};
  }
}

// A synthetic frame for the visibility stage's per-pixel steps (tests/test_horizon.cpp,
// tests/test_ground.cpp): G-buffer positions and normals, lights, visibility [light][pixel].
struct SyntheticFrame {
  int w = 0, h = 0;
  std::vector<cl_float4> gpos, gnrm;
  std::vector<pb_light> lights;
  std::vector<float> vis;
};

inline std::string data(const std::string& rel) { return std::string(PENUMBRA_TEST_DATA) + "/" + rel; }

inline const char* kMaps[] = {"envmaps/courtyard.exr", "envmaps/interior.exr", "envmaps/studio.exr"};

// A camera 3 m above the origin looking straight down at the floor (a hair off the vertical so
// the up vector stays defined), vertical field of view fovyDeg.
inline Camera topDownCamera(float fovyDeg) {
  Camera cam;
  cam.eye = {0, 3, 0.01f};
  cam.target = {0, 0, 0};
  cam.fovyDeg = fovyDeg;
  return cam;
}

// A horizontal quad [x0,x1] x [z0,z1] at height y, facing +y: receivers and blockers of the planar
// parallel configuration the filtered techniques are tested on (support/planar_penumbra.hpp).
inline Mesh planarQuad(const std::string& name, float x0, float x1, float z0, float z1, float y) {
  Mesh m;
  m.name = name;
  m.positions = {{x0, y, z0}, {x1, y, z0}, {x1, y, z1}, {x0, y, z1}};
  m.normals = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}};
  return m;
}

inline float luminance(const double rgb[3]) {
  return float(PB_LUM_R * rgb[0] + PB_LUM_G * rgb[1] + PB_LUM_B * rgb[2]);
}

}  // namespace penumbra::test
