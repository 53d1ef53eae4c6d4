#!/usr/bin/env python3
"""Quality against speed of penumbra's shadow techniques on the built-in scene.

Renders the built-in scene under the built-in sky with each technique, measures the relative RMSE
against the Embree reference lit by the same light set (so only visibility differs), and the
render time (wall clock of Renderer.render, best of --repeat). Prints a table, writes it as JSON,
and, when matplotlib is importable, draws error against time as compare_techniques.png.

    PYTHONPATH=build/bindings/python python3 bindings/python/examples/compare_techniques.py \
        --out-dir /tmp/cmp --size 160x90
"""
import argparse
import json
import pathlib
import time

import penumbra


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default=".", help="where the PNG and JSON go")
    ap.add_argument("--size", default="160x90", help="image size WxH")
    ap.add_argument("--lights", type=int, default=16, help="median-cut lights")
    ap.add_argument("--shadow-map-size", type=int, default=256)
    ap.add_argument("--spp", type=int, default=64, help="reference samples per pixel")
    ap.add_argument("--repeat", type=int, default=2, help="renders per technique (best is kept)")
    ap.add_argument("--techniques", default="hard,pcss,cssm,mssm4,mssm6,brute",
                    help="comma-separated technique names")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    out = pathlib.Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)

    ctx = penumbra.Context()
    scene = penumbra.builtin_scene()
    env = penumbra.builtin_environment(256)
    camera = penumbra.frame_camera(scene, width / height)
    lights = penumbra.extract_lights(ctx, env, lights=args.lights)
    reference = penumbra.reference_lights(
        scene, camera, lights, env,
        penumbra.ReferenceOptions(width=width, height=height, spp=args.spp))

    renderer = penumbra.Renderer(ctx)
    rows = []
    for name in args.techniques.split(","):
        opt = penumbra.RenderOptions(width=width, height=height, technique=name,
                                     shadow_map_size=args.shadow_map_size)
        opt.brute.samples = 16
        best, frame = float("inf"), None
        for _ in range(max(1, args.repeat)):  # the first render also builds the kernels
            t0 = time.perf_counter()
            frame = renderer.render(scene, camera, lights, env, opt)
            best = min(best, (time.perf_counter() - t0) * 1e3)
        m = penumbra.compare_images(frame.image, reference)
        rows.append({"technique": name, "relative_rmse": m.relative_rmse, "psnr": m.psnr,
                     "ms": best, "device_ms": frame.timings})
        print(f"{name:13s} relative RMSE {m.relative_rmse * 100:6.2f}%   {best:8.1f} ms")

    (out / "compare_techniques.json").write_text(json.dumps(
        {"device": ctx.info.name, "size": [width, height], "lights": len(lights),
         "shadow_map_size": args.shadow_map_size, "spp": args.spp, "results": rows}, indent=2))

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not found: no figure (JSON written)")
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    for r in rows:
        ax.scatter(r["ms"], r["relative_rmse"] * 100)
        ax.annotate(r["technique"], (r["ms"], r["relative_rmse"] * 100),
                    textcoords="offset points", xytext=(4, 4))
    ax.set_xscale("log")
    ax.set_xlabel("render time per frame, ms (log)")
    ax.set_ylabel("relative RMSE vs Embree, %")
    ax.set_title(f"penumbra, built-in scene, {width}x{height}, {len(lights)} lights\n"
                 f"{ctx.info.name}", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    png = out / "compare_techniques.png"
    fig.savefig(png, dpi=100)
    print(f"wrote {png}")


if __name__ == "__main__":
    main()
