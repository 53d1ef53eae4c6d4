# Thread safety from Python (README "Thread safety"): four threads share one Context, for light
# extraction and for rendering with one shared Renderer; every light set and frame equals the one a
# single thread computes. The long calls release the GIL, so the threads really overlap.
import threading

import numpy as np

import penumbra
from conftest import H, W, small_options

THREADS = 4


def run_threads(work, iterations):
    """Runs work(thread, iteration) on THREADS threads released together; returns the failures."""
    barrier = threading.Barrier(THREADS)
    failures = []

    def body(t):
        barrier.wait()
        for i in range(iterations):
            try:
                msg = work(t, i)
            except Exception as e:  # any raised error is a failure of the shared use
                msg = repr(e)
            if msg:
                failures.append(f"thread {t}, iteration {i}: {msg}")

    threads = [threading.Thread(target=body, args=(t,)) for t in range(THREADS)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    return failures


def job_for(t, i, n):
    # even iterations: every thread on the same job; odd: each on a different one
    return (i + (t if i % 2 else 0)) % n


def test_extraction_from_shared_context(ctx, data):
    envs = [penumbra.builtin_environment(64 * (k + 1)) for k in range(2)]
    envs.append(penumbra.load_environment(str(data / "envmaps" / "studio.exr")))
    opt = penumbra.ExtractOptions(median_cut=penumbra.MedianCutOptions(lights=8, face_size=32))
    expected = [penumbra.extract_lights(ctx, e, options=opt).to_json() for e in envs]
    shared = penumbra.Context()

    def work(t, i):
        j = job_for(t, i, len(envs))
        got = penumbra.extract_lights(shared, envs[j], options=opt).to_json()
        return "" if got == expected[j] else f"light set differs for map {j}"

    failures = run_threads(work, 2 * len(envs))
    assert not failures, "\n".join(failures)


def quad(x0, x1, z0, z1, y):
    m = penumbra.Mesh()
    m.positions = np.array([[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]], np.float32)
    m.triangles = np.array([[0, 2, 1], [0, 3, 2]], np.int32)
    return m


def test_shared_renderer(ctx, lights, env):
    # a ground and a blocker (the bitmask's lists cost seconds a frame on the built-in scene)
    scene = penumbra.Scene()
    scene.meshes = [quad(-2, 2, -2, 2, 0), quad(-0.5, 0.5, -0.5, 0.5, 0.6)]
    camera = penumbra.frame_camera(scene, W / H)
    options = [small_options(technique=t) for t in ("mssm4", "bitmask")]
    alone = penumbra.Renderer(ctx)
    expected = [alone.render(scene, camera, lights, env, o).image.copy() for o in options]
    shared = penumbra.Renderer(penumbra.Context())

    def work(t, i):
        j = job_for(t, i, len(options))
        img = shared.render(scene, camera, lights, env, options[j]).image
        return "" if np.array_equal(img, expected[j]) else f"frame {j} differs"

    failures = run_threads(work, 4)
    assert not failures, "\n".join(failures)
    # what was compared shows the techniques' shadows: they differ
    assert not np.array_equal(expected[0], expected[1])


def test_thread_safety_is_documented():
    for cls in (penumbra.Context, penumbra.Renderer):
        assert "Thread safety" in cls.__doc__, cls
