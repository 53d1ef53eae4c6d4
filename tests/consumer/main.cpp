// Renders a tiny frame through the installed package and checks it is lit: proof that
// find_package(penumbra) / pkg-config give everything a consumer needs.
#include <penumbra/penumbra.hpp>

#include <cstdio>
#include <filesystem>
#include <string>
#include <unistd.h>

int main() {
  try {
    penumbra::Context ctx;
    penumbra::Environment env = penumbra::builtinEnvironment(128);
    penumbra::Scene scene = penumbra::builtinScene();
    penumbra::Camera cam = penumbra::frameCamera(scene, 2.0f);
    penumbra::MedianCutOptions mc;
    mc.lights = 8;
    penumbra::LightSet lights = penumbra::extractMedianCut(ctx, env, mc);
    penumbra::RenderOptions ro;
    ro.width = 32;
    ro.height = 16;
    ro.shadowMapSize = 64;
    penumbra::Renderer renderer(ctx);
    penumbra::Frame f = renderer.render(scene, cam, lights, env, ro);
    double sum = 0;
    for (float v : f.image.pixels) sum += v;
    std::printf("penumbra %s: %zu lights, image sum %.3f\n", PENUMBRA_VERSION, lights.lights.size(), sum);
    // Image files go through the OpenImageIO module installed beside libpenumbra.
    const std::string file = (std::filesystem::temp_directory_path() /
                              ("penumbra_consumer_" + std::to_string(::getpid()) + ".exr")).string();
    penumbra::writeImage(file, f.image);
    const penumbra::Image back = penumbra::readImage(file);
    std::filesystem::remove(file);
    if (back.width != f.image.width || back.height != f.image.height) return 1;
    return sum > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 1;
  }
}
