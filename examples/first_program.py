"""The first Python program of docs/first_program.md: render the built-in scene and write frame.exr."""
import penumbra

ctx = penumbra.Context()
scene = penumbra.builtin_scene()
env = penumbra.builtin_environment()
cam = penumbra.frame_camera(scene, 16 / 9)
lights = penumbra.extract_lights(ctx, env, method="median-cut", lights=32)
frame = penumbra.Renderer(ctx).render(scene, cam, lights, env,
                                      penumbra.RenderOptions(width=320, height=180))
penumbra.write_image("frame.exr", frame.image)   # float32 NumPy array (H, W, 4)
print(frame.timings)
