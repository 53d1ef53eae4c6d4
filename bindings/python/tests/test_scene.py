import numpy as np
import pytest

import penumbra


def test_builtin_scene_moves():
    s0, s1 = penumbra.builtin_scene(), penumbra.builtin_scene(time=0.75)
    assert s0.triangle_count() > 0 and len(s0.meshes) == len(s1.meshes)
    moved = [not np.array_equal(a.positions, b.positions) for a, b in zip(s0.meshes, s1.meshes)]
    assert any(moved) and not all(moved)
    assert "triangles" in repr(s0)


def test_mesh_arrays():
    mesh = penumbra.builtin_scene().meshes[0]
    assert mesh.name
    assert mesh.positions.dtype == np.float32 and mesh.positions.shape[1] == 3
    assert mesh.triangles.dtype == np.int32 and mesh.triangles.shape[1] == 3
    assert mesh.triangles.max() < len(mesh.positions)
    assert mesh.normals.shape[1] == 3
    m = penumbra.Mesh()
    m.name = "tri"
    m.positions = np.array([[0, 0, 0], [1, 0, 0], [0, 0, -1]], np.float64)
    m.triangles = [[0, 1, 2]]
    m.albedo = (0.5, 0.25, 0.125)
    s = penumbra.Scene()
    s.meshes = [m]
    assert s.triangle_count() == 1 and s.meshes[0].albedo == [0.5, 0.25, 0.125]
    b = s.bounds()
    assert b.lo == [0, 0, -1] and b.hi == [1, 0, 0]
    assert np.allclose(b.center(), (0.5, 0, -0.5)) and b.radius() > 0


def test_camera():
    scene = penumbra.builtin_scene()
    # frame_camera frames what stands on the ground (src/scene/scene.cpp: the ground plane is left
    # out when anything else is there): the bounds of the other meshes, computed here.
    pts = np.concatenate([m.positions for m in scene.meshes if m.name != "ground"])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    center, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    for aspect in (2.0, 0.5):
        cam = penumbra.frame_camera(scene, aspect)
        # Above the objects, looking at their centre, far enough that their sphere fits the view
        # both ways: radius / distance <= sin of the smaller half field of view.
        eye = np.array(cam.eye)
        assert np.allclose(cam.target, center, atol=1e-4)
        assert eye[1] > center[1]
        dist = np.linalg.norm(eye - center)
        half_v = np.radians(cam.fovy_deg) / 2
        half_h = np.arctan(aspect * np.tan(half_v))
        assert radius / dist <= np.sin(min(half_v, half_h)) * (1 + 1e-5)
        # ... and not much further (a 5% margin in the code; 10% here).
        assert radius / dist >= np.sin(min(half_v, half_h)) / 1.1
    c = penumbra.Camera(eye=(0, 1, 5), fovy_deg=30)
    c.target = (0, 0.5, 0)
    c.up = (0, 1, 0)
    assert c.eye == [0, 1, 5] and c.target == [0, 0.5, 0] and c.fovy_deg == 30
    p = penumbra.parse_camera("1,2,3,0,0,0,50")
    assert p.eye == [1, 2, 3] and p.fovy_deg == 50 and "Camera" in repr(p)


def test_load_scene(data):
    path = str(data / "meshes" / "good" / "spider.obj")
    with_ground = penumbra.load_scene(path)
    without = penumbra.load_scene(path, add_ground=False)
    assert with_ground.triangle_count() > without.triangle_count() > 0
    assert penumbra.scene_from("builtin").triangle_count() == penumbra.builtin_scene().triangle_count()
    assert penumbra.scene_from(path, add_ground=False).triangle_count() == without.triangle_count()
