#!/usr/bin/env python3
"""Each light's share of a technique's error against exact visibility of the same lights.

Renders one frame (320x180 by default) with each technique of --techniques and with the bitmask
technique (exact visibility of the same lights, the reference here), reads every light's
visibility row (Renderer.last_visibility), and weights each light's visibility error by what that
light adds to the pixel unshadowed (a frame of that light alone with shadows off). A light's error
image is then (V_technique - V_exact) * C_light / mean(frame), and the table lists its sum of
squares as a share of the first technique's total, and its mean (the signed bias), the lights
ordered by half-angle with their elevation above the horizontal plane (y up). The errors of the
lights add up to the frame's technique error up to cross terms, which the first line states.

Used for `auto`'s elevation cut (src/shadows/auto.cpp; README, "Within 1.15x of the floor"):
  PYTHONPATH=build/bindings/python /usr/bin/python3 tools/per_light_error.py \
      --env DATA/envmaps/courtyard.exr --scene DATA/meshes/good/WusonOBJ.obj --techniques mssm4,pcss
The light set is `penumbra lights -l N` of the map (median cut, the render command's default).
`--env builtin --scene builtin` measures the built-in scene; `--auto-filtered N` sets auto's filtered
budget (used for auto's ranking by irradiance on screen, bench/results/accuracy.md, "The filtered
budget by irradiance on screen").
"""
import argparse
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

import penumbra as pb


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--env", required=True, help="environment map, or 'builtin'")
    ap.add_argument("--scene", required=True,
                    help="mesh file (a ground plane is added), or 'builtin'")
    ap.add_argument("--lights", type=int, default=64, help="median-cut lights (default 64)")
    ap.add_argument("--techniques", default="mssm4,pcss", help="comma-separated (default mssm4,pcss)")
    ap.add_argument("--size", default="320x180", help="WxH (default 320x180)")
    ap.add_argument("--cli", default="build/penumbra", help="the penumbra CLI (light extraction)")
    ap.add_argument("--auto-filtered", type=int, default=None,
                    help="auto's filtered budget (AutoOptions.filtered_lights; default its own)")
    a = ap.parse_args()
    W, H = (int(v) for v in a.size.split("x"))
    techs = a.techniques.split(",")

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "lights.json")
        envarg = [] if a.env == "builtin" else ["--env", a.env]
        subprocess.run([a.cli, "lights", *envarg, "-l", str(a.lights), "-o", path],
                       check=True, stderr=subprocess.DEVNULL)
        lights = pb.load_light_set(path)
        singles = []
        for i in range(len(lights.lights)):
            s = pb.load_light_set(path)
            s.lights = [lights.lights[i]]
            s.has_ambient = False
            singles.append(s)

    env = pb.builtin_environment() if a.env == "builtin" else pb.load_environment(a.env)
    scene = pb.builtin_scene() if a.scene == "builtin" else pb.load_scene(a.scene)
    camera = pb.frame_camera(scene, W / H)
    renderer = pb.Renderer(pb.Context())

    def render(light_set, technique):
        o = pb.RenderOptions(width=W, height=H, technique=technique)
        if a.auto_filtered is not None:
            o.auto_choice.filtered_lights = a.auto_filtered
        o.environment_background = False
        frame = renderer.render(scene, camera, light_set, env, o)
        return np.asarray(renderer.last_visibility(W, H)), np.asarray(frame.image)[..., :3]

    vis = {t: render(lights, t)[0] for t in techs}
    exact, full = render(lights, "bitmask")
    contrib = np.array([render(s, "none")[1].mean(-1) for s in singles])
    geometry = full.sum(-1) > 0
    mean = full[geometry].mean()

    sq = {t: [] for t in techs}
    bias = {t: [] for t in techs}
    for t in techs:
        err = (vis[t] - exact) * contrib / mean
        combined = err.sum(0)
        sq[t] = (err ** 2).sum(axis=(1, 2))
        bias[t] = err.mean(axis=(1, 2))
        print(f"{t}: frame technique error {100 * math.sqrt((combined[geometry] ** 2).mean()):.3f}% "
              f"(relative RMSE of the lights' summed error, luminance), "
              f"lights' squares {sq[t].sum() / sq[techs[0]].sum():.3f} of {techs[0]}'s")
    total = sq[techs[0]].sum()
    print("light  half-angle  elevation  " + "  ".join(f"{t:>8} share   bias" for t in techs))
    order = sorted(range(len(lights.lights)), key=lambda i: lights.lights[i].half_angle())
    for i in order:
        L = lights.lights[i]
        elev = math.degrees(math.asin(max(-1.0, min(1.0, L.direction[1]))))
        cells = "  ".join(f"{sq[t][i] / total:14.4f} {bias[t][i]:+.5f}" for t in techs)
        print(f"{i:5d}  {math.degrees(L.half_angle()):9.1f}  {elev:9.1f}  {cells}")


if __name__ == "__main__":
    sys.exit(main())
