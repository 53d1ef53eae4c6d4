// kernels/render/raster.cl against Embree: the device camera G-buffer covers exactly the pixels
// whose primary ray hits geometry in the reference (same rays, scene.hpp's cameraRayDirection), on
// awkward image sizes.
#include <gtest/gtest.h>

#include "common.hpp"

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
