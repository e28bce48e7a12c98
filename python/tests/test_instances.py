"""Instances from Python (#64): add_instance places another copy of a mesh, set_transforms
moves copies; casts and renders answer as the copies placed as meshes of their own would."""

import json
import math
import pathlib

import numpy as np
import pytest

import raycast
from test_queries import cube

ROOT = pathlib.Path(__file__).resolve().parents[2]
INVALID = raycast.RaycastingScene.INVALID_ID


def turn(axis, degrees):
    """The 3x3 rotation by `degrees` about `axis` (Rodrigues)."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    a = math.radians(degrees)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(a) * kx + (1 - math.cos(a)) * kx @ kx


def affine(linear, translation):
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = linear, translation
    return m


POSES = [
    affine(turn([1, 2, 3], 40) @ np.diag([1.5, 0.5, 2.0]), [3.0, -2.0, 1.0]),
    affine(np.diag([-1.0, 1.0, 1.0]) @ turn([0, 1, 1], -25), [-3.0, 2.5, 0.5]),
    affine(np.eye(3), [0.2, 3.0, -2.0]),
]


def copies(vertices, triangles, transforms):
    """A scene of the mesh placed by each transform as a mesh of its own, each triangle's
    last two corners swapped where the transform mirrors (as an instance's are)."""
    scene = raycast.RaycastingScene()
    scene.add_sphere([0.5, -2.0, 0.0], 0.75)
    for m in transforms:
        moved = vertices @ m[:3, :3].T + m[:3, 3]
        t = triangles[:, [0, 2, 1]] if np.linalg.det(m[:3, :3]) < 0 else triangles
        scene.add_triangles(moved, t)
    return scene


def grid_rays(n=60):
    k = np.arange(n * n)
    d = np.stack([(k % n) * 0.02 - 0.6, (k // n) * 0.02 - 0.6, -np.ones(n * n)], axis=1)
    return np.concatenate([np.tile([0.5, 0.5, 12.0], (n * n, 1)), d], axis=1)


@pytest.mark.parametrize("precision,device", [("f64", "cpu"), ("f32", "gpu")])
def test_instances_hit_as_their_copies_and_move(precision, device):
    vertices, triangles = cube()
    scene = raycast.RaycastingScene()
    scene.add_sphere([0.5, -2.0, 0.0], 0.75)
    mesh = scene.add_triangles(vertices, triangles)
    ids = [scene.add_instance(mesh, m) for m in POSES]
    assert ids == [2, 3, 4]
    rays = grid_rays()

    def cast(s):
        hits = s.cast_rays(rays, precision=precision, device=device)
        return hits["geometry_ids"], hits["t_hit"]

    def same_hits(got, want):
        np.testing.assert_array_equal(got[0], want[0])
        if precision == "f32" and device == "gpu":
            # The GPU casts ray by ray through the instances, in their meshes' coordinates,
            # where f32 rounds otherwise than at the placed copies: t to a few ulps.
            np.testing.assert_allclose(got[1], want[1], rtol=2e-6)
        else:
            np.testing.assert_array_equal(got[1], want[1])

    got, want = cast(scene), cast(copies(vertices, triangles, [np.eye(4)] + POSES))
    same_hits(got, want)
    assert set(np.unique(got[0])) == {0, 1, 2, 3, 4, INVALID}

    # Moved, by 4x4 and by 3x4 matrices: as the copies placed there.
    moved = affine(np.eye(3), [-1.0, -1.0, 0.5])
    scene.set_transforms(np.array([3, 4]), np.stack([moved, POSES[0]]))
    scene.set_transforms([1], POSES[1][None, :3])
    placed = [POSES[1], POSES[0], moved, POSES[0]]
    same_hits(cast(scene), cast(copies(vertices, triangles, placed)))


def test_a_loaded_scenes_instances_move_in_its_renders(tmp_path):
    course = ROOT / "scenes" / "course"
    (tmp_path / "bunny.stl").write_bytes((course / "bunny.stl").read_bytes())
    scene = json.loads((course / "bunny.json").read_text())
    scene["meshes"] = {"bunny": {"stl": "bunny.stl"}}
    first = {"translate": [-0.6, 0, 0], "scale": 0.5}
    scene["objects"] = [
        {"type": "instance", "mesh": "bunny", "transform": first},
        {"type": "instance", "mesh": "bunny", "transform": {"translate": [0.6, 0, 0], "scale": 0.5}},
    ]
    path = tmp_path / "instances.json"
    path.write_text(json.dumps(scene))
    loaded = raycast.load(path)
    moved = affine(turn([0, 1, 0], 30) * 0.4, [0.5, 0.1, 0.0])
    loaded.set_transforms([1], moved[None])
    images = loaded.render(precision="f32", device="cpu", size=(64, 48))

    # The scene file with the moved instance's matrix written in renders the same.
    scene["objects"][1]["transform"] = moved.tolist()
    path.write_text(json.dumps(scene))
    written = raycast.load(path)
    want = written.render(precision="f32", device="cpu", size=(64, 48))
    np.testing.assert_array_equal(images["id"], want["id"])
    np.testing.assert_array_equal(images["distance"], want["distance"])
    assert set(np.unique(images["id"])) == {-1, 0, 1}
    # And the casts see it there too.
    rays = raycast.RaycastingScene.create_rays_pinhole(
        fov_deg=60, center=[0.0, 0.0, 0.0], eye=[0.0, 0.3, 3.0], up=[0, 1, 0],
        width_px=64, height_px=48)
    cast = [s.cast_rays(rays, precision="f64", device="cpu")["geometry_ids"] for s in (loaded, written)]
    np.testing.assert_array_equal(cast[0], cast[1])
    assert np.sum(cast[0] == 1) > 20


def test_bad_instances_and_transforms_raise_naming_the_argument():
    vertices, triangles = cube()
    scene = raycast.RaycastingScene()
    sphere = scene.add_sphere([0, 0, 0], 1.0)
    mesh = scene.add_triangles(vertices, triangles)
    copy = scene.add_instance(mesh, np.eye(4))
    singular = np.diag([1.0, 1.0, 0.0, 1.0])
    not_affine = np.eye(4)
    not_affine[3, 0] = 1.0
    cases = [
        (lambda: scene.add_instance(sphere, np.eye(4)), ValueError, "mesh: object 0 is not a triangle mesh"),
        (lambda: scene.add_instance(7, np.eye(4)), ValueError, "mesh: object 7 does not exist"),
        (lambda: scene.add_instance(1.5, np.eye(4)), TypeError, "mesh: expected a geometry id"),
        (lambda: scene.add_instance(mesh, np.eye(3)), ValueError, r"transform: expected shape \(4, 4\) or \(3, 4\)"),
        (lambda: scene.add_instance(mesh, singular), ValueError, "transform: is singular"),
        (lambda: scene.add_instance(mesh, not_affine), ValueError, r"transform: the last row must be \[0, 0, 0, 1\]"),
        (lambda: scene.add_instance(mesh, np.full((4, 4), np.nan)), ValueError, "transform: "),
        (lambda: scene.set_transforms([sphere], np.eye(4)[None]), ValueError, "ids\\[0\\]: object 0 is not an instance"),
        (lambda: scene.set_transforms([copy], np.eye(4)), ValueError, r"transforms: expected shape \(n, 4, 4\)"),
        (lambda: scene.set_transforms([copy, mesh], np.eye(4)[None]), ValueError, "transforms: gives 1 transforms for 2 ids"),
        (lambda: scene.set_transforms([0.5], np.eye(4)[None]), TypeError, "ids: expected integer ids"),
        (lambda: scene.set_transforms([copy], singular[None]), ValueError, r"transforms\[0\]: is singular"),
    ]
    rays = grid_rays(20)
    before = scene.cast_rays(rays, precision="f64", device="cpu")["t_hit"]
    for call, error, message in cases:
        with pytest.raises(error, match=message):
            call()
    # Nothing refused changed the scene.
    after = scene.cast_rays(rays, precision="f64", device="cpu")["t_hit"]
    np.testing.assert_array_equal(before, after)
