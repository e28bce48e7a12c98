"""The Python package against exact answers, the CPU reference and its own invariants (run by
.ci/run on lavapipe; Open3D itself is compared in benches/open3d_rays.py, outside CI)."""

import json
import math
import pathlib
import threading

import numpy as np
import pytest

import raycast

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODES = [(p, d) for p in ("f32", "f64", "adaptive") for d in ("gpu", "cpu")]


def unit_square():
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=np.float64)
    triangles = np.array([[0, 1, 2], [1, 3, 2]], dtype=np.int64)
    return vertices, triangles


def uv_sphere(center, radius, slices=24, stacks=16):
    """A closed mesh: vertices on the sphere, every edge shared by two triangles."""
    vertices = [np.add(center, [0, radius, 0]), np.add(center, [0, -radius, 0])]
    for j in range(1, stacks):
        theta = math.pi * j / stacks
        for i in range(slices):
            phi = 2 * math.pi * i / slices
            vertices.append(
                np.add(center, radius * np.array(
                    [math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi)]))
            )
    ring = lambda j, i: 2 + (j - 1) * slices + i % slices  # noqa: E731
    triangles = []
    for i in range(slices):
        triangles.append([0, ring(1, i + 1), ring(1, i)])
        triangles.append([1, ring(stacks - 1, i), ring(stacks - 1, i + 1)])
        for j in range(1, stacks - 1):
            a, b, c, d = ring(j, i), ring(j, i + 1), ring(j + 1, i + 1), ring(j + 1, i)
            triangles += [[a, b, c], [a, c, d]]
    return np.array(vertices), np.array(triangles)


@pytest.mark.parametrize("precision,device", MODES)
def test_mesh_hits_are_exact(precision, device):
    scene = raycast.RaycastingScene()
    sphere = scene.add_sphere([5, 5, 5], 0.5)
    mesh = scene.add_triangles(*unit_square())
    assert (sphere, mesh) == (0, 1)
    rays = np.array([[0.25, 0.5, 2, 0, 0, -2], [0.75, 0.5, 1, 0, 0, -1], [3, 3, 1, 0, 0, -1]])
    ans = scene.cast_rays(rays, precision=precision, device=device)
    assert ans["t_hit"].tolist() == [1.0, 1.0, math.inf]
    assert ans["geometry_ids"].tolist() == [1, 1, raycast.RaycastingScene.INVALID_ID]
    assert ans["geometry_ids"].dtype == np.uint32
    assert ans["primitive_ids"].tolist() == [0, 1, raycast.RaycastingScene.INVALID_ID]
    assert ans["primitive_uvs"].tolist() == [[0.25, 0.5], [0.25, 0.25], [0, 0]]
    assert ans["primitive_normals"].tolist() == [[0, 0, 1], [0, 0, 1], [0, 0, 0]]
    expected = np.float64 if precision == "f64" else np.float32
    assert ans["t_hit"].dtype == expected


def test_leading_dimensions_and_dtypes_are_kept_or_converted():
    scene = raycast.RaycastingScene()
    scene.add_triangles(*unit_square())
    ray = [0.5, 0.25, 1, 0, 0, -1]
    for dtype in (np.float16, np.float32, np.float64, np.int32):
        rays = np.tile(np.array(ray, dtype=dtype), (2, 3, 1))
        ans = scene.cast_rays(rays)
        assert ans["t_hit"].shape == (2, 3)
        assert ans["primitive_uvs"].shape == (2, 3, 2)
        assert ans["primitive_normals"].shape == (2, 3, 3)
        assert np.all(ans["geometry_ids"] == 0)
    # A strided (non-contiguous) view and a plain list.
    wide = np.zeros((4, 12))
    wide[:, ::2] = ray
    assert scene.cast_rays(wide[:, ::2])["t_hit"].tolist() == [1.0] * 4
    assert scene.cast_rays([ray])["t_hit"].tolist() == [1.0]
    assert scene.cast_rays(np.zeros((0, 6)))["t_hit"].shape == (0,)


def test_float32_rays_are_read_as_they_are():
    """float32 rays (read without a float64 copy) give exactly what their float64 values give,
    as a flat list, an image and a strided view; a NaN among them misses, as in Open3D, and
    leaves the others' answers as they were."""
    scene = raycast.RaycastingScene()
    scene.add_triangles(*uv_sphere([0.3, -0.2, 0.1], 1.0))
    rng = np.random.default_rng(5)
    rays = np.concatenate([rng.uniform(-3, 3, (600, 3)), rng.uniform(-1, 1, (600, 3))], 1)
    rays = rays.astype(np.float32)
    for shaped in (rays, rays.reshape(20, 30, 6), np.repeat(rays, 2, axis=0)[::2]):
        for precision in ("f32", "f64"):
            a = scene.cast_rays(shaped, precision=precision)
            b = scene.cast_rays(shaped.astype(np.float64), precision=precision)
            assert a.keys() == b.keys()
            for key in a:
                assert np.array_equal(a[key], b[key]), (key, precision)
    bad = rays.copy()
    bad[17, 4] = np.nan
    for precision in ("f32", "f64"):
        a = scene.cast_rays(bad, precision=precision)
        b = scene.cast_rays(rays, precision=precision)
        assert a["t_hit"][17] == math.inf
        assert a["geometry_ids"][17] == a["primitive_ids"][17] == raycast.RaycastingScene.INVALID_ID
        for key in a:
            np.testing.assert_array_equal(np.delete(a[key], 17, 0), np.delete(b[key], 17, 0))


def test_gpu_f32_equals_cpu_f32_bit_for_bit():
    scene = raycast.RaycastingScene()
    scene.add_triangles(*uv_sphere([0.3, -0.2, 0.1], 1.0))
    scene.add_sphere([1.5, 0.5, 0], 0.4)
    scene.add_plane([0, -2, 0], [0, 1, 0.1])
    rng = np.random.default_rng(5)
    rays = np.concatenate([rng.uniform(-3, 3, (5000, 3)), rng.uniform(-1, 1, (5000, 3))], axis=1)
    gpu = scene.cast_rays(rays, device="gpu")
    cpu = scene.cast_rays(rays, device="cpu")
    assert np.mean(gpu["geometry_ids"] != raycast.RaycastingScene.INVALID_ID) > 0.3
    for key in gpu:
        np.testing.assert_array_equal(gpu[key], cpu[key], err_msg=key)
    np.testing.assert_array_equal(
        scene.count_intersections(rays, device="gpu"), scene.count_intersections(rays, device="cpu")
    )


@pytest.mark.parametrize("precision,device", MODES)
def test_closed_mesh_counts_and_barycentrics(precision, device):
    vertices, triangles = uv_sphere([0.5, -0.25, 0.0], 1.0)
    scene = raycast.RaycastingScene()
    scene.add_triangles(vertices, triangles)
    rng = np.random.default_rng(1)
    inside = np.concatenate([np.tile([0.5, -0.25, 0.1], (300, 1)), rng.uniform(-1, 1, (300, 3))], 1)
    outside = np.concatenate([np.tile([3.0, 2.0, -1.0], (300, 1)), rng.uniform(-1, 1, (300, 3))], 1)
    counts = scene.count_intersections(inside, precision=precision, device=device)
    assert counts.dtype == np.int32 and np.all(counts == 1)
    counts = scene.count_intersections(outside, precision=precision, device=device)
    assert np.all(counts % 2 == 0) and np.any(counts == 2)
    ans = scene.cast_rays(inside, precision=precision, device=device)
    corners = vertices[triangles[ans["primitive_ids"]]]
    u, v = ans["primitive_uvs"][:, 0:1], ans["primitive_uvs"][:, 1:2]
    on_triangle = (1 - u - v) * corners[:, 0] + u * corners[:, 1] + v * corners[:, 2]
    along_ray = inside[:, :3] + ans["t_hit"][:, None] * inside[:, 3:]
    assert np.max(np.abs(on_triangle - along_ray)) < 1e-5


def test_sphere_counts_and_occlusions():
    scene = raycast.RaycastingScene()
    scene.add_sphere([0, 0, 0], 1)
    rays = np.array([[0, 0, 5, 0, 0, -2], [0, 0, 0, 0, 4, 0], [0, 0, 5, 0, 0, 1]])
    assert scene.count_intersections(rays).tolist() == [2, 1, 0]
    assert scene.cast_rays(rays)["t_hit"].tolist() == [2.0, 0.25, math.inf]
    assert scene.test_occlusions(rays).tolist() == [True, True, False]
    assert scene.test_occlusions(rays, tfar=1.9).tolist() == [False, True, False]
    assert scene.test_occlusions(rays, tnear=2.5, tfar=3.0).tolist() == [True, False, False]
    assert scene.test_occlusions(rays, tnear=2.5, tfar=2.9).tolist() == [False, False, False]


def test_planes_and_normals():
    scene = raycast.RaycastingScene()
    scene.add_plane([0, 0, -1], [0, 0, 2])
    ans = scene.cast_rays([[0, 0, 0, 0, 0, -1]], precision="f64")
    assert ans["t_hit"].tolist() == [1.0]
    assert ans["primitive_normals"].tolist() == [[0, 0, 1]]


def test_create_rays_pinhole_looks_at_the_centre():
    rays = raycast.RaycastingScene.create_rays_pinhole(90, [0, 0, 0], [0, 0, 4], [0, 1, 0], 2, 2)
    assert rays.shape == (2, 2, 6) and rays.dtype == np.float32
    assert np.all(rays[..., :3] == [0, 0, 4])
    # fov 90 over 2 pixels: focal length 1 pixel, pixel centres half a pixel off the axis.
    directions = rays[..., 3:].reshape(-1, 3)
    assert np.allclose(np.abs(directions), [0.5, 0.5, 1])
    assert np.all(directions[:, 2] == -1)
    # The intrinsic form: the same rays from the equivalent matrices.
    k = np.array([[1, 0, 1], [0, 1, 1], [0, 0, 1]])
    extrinsic = raycast._look_at([0, 0, 0], [0, 0, 4], [0, 1, 0])
    same = raycast.RaycastingScene.create_rays_pinhole(k, extrinsic, 2, 2)
    np.testing.assert_allclose(same, rays, atol=1e-6)
    # A camera's rays hit a sphere at its centre on the central pixel of an odd image.
    scene = raycast.RaycastingScene()
    scene.add_sphere([0, 0, 0], 1)
    rays = raycast.RaycastingScene.create_rays_pinhole(60, [0, 0, 0], [0, 0, 4], [0, 1, 0], 5, 5)
    assert scene.cast_rays(rays)["t_hit"][2, 2] == 3.0


def test_load_and_render_a_scene_file():
    scene = raycast.load(ROOT / "scenes" / "course" / "bunny.json")
    images = scene.render(precision="f32", device="gpu")
    cpu = scene.render(precision="f32", device="cpu")
    h, w = images["id"].shape
    assert images["normal"].shape == (h, w, 3)
    np.testing.assert_array_equal(images["id"], cpu["id"])
    # The bunny in a room: every pixel sees one of its objects, at a finite distance.
    assert images["id"].min() >= 0 and images["id"].max() < 6
    assert np.all(np.isfinite(images["distance"]))
    bunny = images["id"] == 0
    assert 0.01 < np.mean(bunny) < 0.5


def test_instances_of_a_scene_file_are_objects_and_an_unplaced_mesh_warns(tmp_path):
    course = ROOT / "scenes" / "course"
    (tmp_path / "bunny.stl").write_bytes((course / "bunny.stl").read_bytes())
    scene = json.loads((course / "bunny.json").read_text())
    scene["meshes"] = {"bunny": {"stl": "bunny.stl"}, "spare": {"stl": "bunny.stl"}}
    scene["objects"] = [
        {"type": "instance", "mesh": "bunny", "transform": {"translate": [-0.6, 0, 0], "scale": 0.5}},
        {"type": "instance", "mesh": "bunny",
         "transform": [[-0.5, 0, 0, 0.6], [0, 0.5, 0, 0], [0, 0, 0.5, 0], [0, 0, 0, 1]]},
    ]
    path = tmp_path / "instances.json"
    path.write_text(json.dumps(scene))
    with pytest.warns(UserWarning, match="meshes.spare is declared but no instance places it"):
        loaded = raycast.load(path)
    images = loaded.render(precision="f32", device="gpu")
    ids = images["id"]
    # Each copy seen, one the other's mirror image: as many pixels of each, nearly.
    left, right = np.sum(ids == 0), np.sum(ids == 1)
    assert left > 100 and abs(left - right) <= 0.02 * left
    assert set(np.unique(ids)) == {-1, 0, 1}


def test_a_lit_render_of_a_scene_file():
    scene = raycast.load(ROOT / "scenes" / "ray-tracing" / "sphere-and-plane.json")
    gpu = scene.render(precision="f32", device="gpu", lit=True)
    cpu = scene.render(precision="f32", device="cpu", lit=True)
    h, w = gpu["id"].shape
    assert gpu["color"].shape == (h, w, 4) and gpu["color"].dtype == np.uint8
    # The GPU's f32 and its CPU mirror: the same colours but for a few pixels, by a level.
    differ = np.any(gpu["color"] != cpu["color"], axis=2)
    assert np.mean(differ) <= 1e-4
    assert np.abs(gpu["color"].astype(int) - cpu["color"]).max() <= 1
    # A shadow ray to each of the two lights from every hit at least; the plane fills the
    # lower half, the sky the upper half.
    hits = np.count_nonzero(gpu["id"] >= 0)
    assert gpu["hook_rays"] >= 2 * hits
    assert abs(gpu["hook_rays"] - cpu["hook_rays"]) <= 1e-4 * cpu["hook_rays"]
    # The same hook given as a file gives the same picture; a plain render has no colour.
    hook = ROOT / "shaders" / "examples" / "raytrace.wgsl"
    np.testing.assert_array_equal(scene.render(shader=hook)["color"], gpu["color"])
    assert "color" not in scene.render()
    with pytest.raises(ValueError, match="not both"):
        scene.render(lit=True, shader=hook)
    with pytest.raises(ValueError, match="the CPU reference runs no shader"):
        scene.render(device="cpu", shader=ROOT / "shaders" / "examples" / "toon.wgsl")


def test_bad_input_raises_naming_the_argument():
    scene = raycast.RaycastingScene()
    v, t = unit_square()
    with pytest.raises(ValueError, match="triangles: index 4 is out of range"):
        scene.add_triangles(v, [[0, 1, 4]])
    with pytest.raises(ValueError, match="triangles: index -1"):
        scene.add_triangles(v, [[0, 1, -1]])
    with pytest.raises(ValueError, match=r"vertices\[1\]: NaN"):
        scene.add_triangles([[0, 0, 0], [np.nan, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match=r"vertices: expected shape \(\.\.\., 3\)"):
        scene.add_triangles(np.zeros((3, 2)), [[0, 1, 2]])
    with pytest.raises(TypeError, match="triangles: expected integer"):
        scene.add_triangles(v, [[0, 1, 2.5]])
    with pytest.raises(ValueError, match="radius"):
        scene.add_sphere([0, 0, 0], -1)
    with pytest.raises(ValueError, match=r"rays: expected shape \(\.\.\., 6\)"):
        scene.cast_rays(np.zeros((3, 5)))
    with pytest.raises(TypeError, match="rays: expected an array of numbers"):
        scene.cast_rays([["a"] * 6])
    # Beyond the library's range (a zero direction, NaN and infinity miss, as in Open3D).
    with pytest.raises(ValueError, match=r"rays\[1\] direction: .* at most 1e18 in magnitude"):
        scene.cast_rays([[0, 0, 1, 0, 0, -1], [0, 0, 1, 0, 0, -1e30]])
    with pytest.raises(ValueError, match="precision"):
        scene.cast_rays(np.zeros((0, 6)), precision="f16")
    with pytest.raises(ValueError, match="device"):
        scene.cast_rays(np.zeros((0, 6)), device="tpu")
    with pytest.raises(ValueError, match="fov_deg"):
        raycast.RaycastingScene.create_rays_pinhole(180, [0, 0, 0], [0, 0, 1], [0, 1, 0], 4, 4)
    with pytest.raises(OSError):
        raycast.load(ROOT / "no-such-scene.json")
    assert scene.cast_rays([[0, 0, 1, 0, 0, -1]])["geometry_ids"].tolist() == [4294967295]


def test_other_threads_run_while_casting():
    """The GIL is released while casting: a thread counting in Python keeps counting."""
    scene = raycast.RaycastingScene()
    scene.add_triangles(*uv_sphere([0, 0, 0], 1.0, 64, 48))
    rays = raycast.RaycastingScene.create_rays_pinhole(60, [0, 0, 0], [0, 0, 3], [0, 1, 0], 640, 480)
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(1)

    thread = threading.Thread(target=count)
    thread.start()
    try:
        before = len(ticks)
        scene.cast_rays(rays, device="cpu")
        during = len(ticks) - before
    finally:
        done.set()
        thread.join()
    assert during > 1000, f"the other thread ran only {during} times"
