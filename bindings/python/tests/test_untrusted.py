"""Untrusted meshes and inputs built in Python: refused with BadInput, the interpreter unharmed."""
import time

import numpy as np
import pytest

import penumbra
from conftest import small_options


def test_mesh_that_aborts_assimp_is_refused(data):
    # Aborted the whole interpreter (SIGABRT inside Assimp) before the loader ran in a child.
    path = str(data / "meshes" / "bad" / "triangulate_abort.ply")
    t0 = time.monotonic()
    with pytest.raises(penumbra.BadInput, match="triangulate_abort.ply.*crashed"):
        penumbra.load_scene(path)
    assert time.monotonic() - t0 < 10


def test_declared_counts_beyond_the_file(tmp_path):
    ply = tmp_path / "huge.ply"
    ply.write_text("ply\nformat ascii 1.0\nelement vertex 99999999999999\nproperty float x\n"
                   "property float y\nproperty float z\nend_header\n0 0 0\n")
    with pytest.raises(penumbra.BadInput, match="99999999999999 'vertex'"):
        penumbra.load_scene(str(ply))


def test_load_limits_are_keywords(data):
    path = str(data / "meshes" / "good" / "WusonOBJ.obj")
    with pytest.raises(penumbra.BadInput, match="longer than its limit"):
        penumbra.load_scene(path, timeout_seconds=0.001)
    assert penumbra.load_scene(path, add_ground=False, timeout_seconds=60).triangle_count() > 3000


def test_render_validates_a_scene_built_in_python(camera, lights, env, renderer):
    mesh = penumbra.Mesh()
    mesh.name = "tri"
    mesh.positions = np.array([[0, 0, 0], [1, 0, 0], [0, 0, -1], [1, 0, -1]], np.float32)
    mesh.triangles = [[0, 1, 9]]  # vertex 9 of 4: the kernels read past the buffer before
    scene = penumbra.Scene()
    scene.meshes = [mesh]
    with pytest.raises(penumbra.BadInput, match="triangle 0 refers to vertex 9 of 4"):
        penumbra.validate_scene(scene)
    with pytest.raises(penumbra.BadInput, match="vertex 9 of 4"):
        renderer.render(scene, camera, lights, env, small_options())


def test_render_validates_lights(scene, camera, lights, env, renderer):
    penumbra.validate_light_set(lights)
    bad = penumbra.light_set_from_json(lights.to_json())
    light = bad.lights[0]
    light.direction = (float("nan"), 1.0, 0.0)
    items = list(bad.lights)
    items[0] = light
    bad.lights = items
    with pytest.raises(penumbra.BadInput, match="LightSet: light 0: direction"):
        penumbra.validate_light_set(bad)
    with pytest.raises(penumbra.BadInput, match="light 0"):
        renderer.render(scene, camera, bad, env, small_options())
