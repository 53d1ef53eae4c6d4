// examples/first_program.cpp: render the built-in scene under the built-in sky and write frame.exr and frame.png.
#include <penumbra/penumbra.hpp>
#include <cstdio>

int main() {
  try {
    penumbra::Context ctx;                                   // $PENUMBRA_DEVICE or device 0
    penumbra::Scene scene = penumbra::builtinScene();        // or loadScene("bunny.glb")
    penumbra::Environment env = penumbra::builtinEnvironment();  // or loadEnvironment("sky.exr")
    penumbra::Camera cam = penumbra::frameCamera(scene, 16.0f / 9.0f);
    penumbra::LightSet lights = penumbra::extractLights(ctx, env, {});  // 32 median-cut lights
    penumbra::Renderer renderer(ctx);                        // keep it: buffers are reused
    penumbra::RenderOptions opt;                             // 640x360, MSSM4, 384^2 maps
    penumbra::Frame frame = renderer.render(scene, cam, lights, env, opt);
    penumbra::writeImage("frame.exr", frame.image);          // linear radiance
    penumbra::writeImage("frame.png", frame.image, 0.0f);    // tone-mapped, automatic exposure
    for (const auto& [stage, ms] : frame.timingsMs) std::printf("%-24s %8.2f ms\n", stage.c_str(), ms);
    return 0;
  } catch (const penumbra::Error& e) {  // one message naming the input and the problem
    std::fprintf(stderr, "first: %s (%s)\n", e.what(), penumbra::toString(e.kind()));
    return 1;
  }
}
