"""The queries beyond the nearest hit (closest points, distances, inside tests, winding
numbers, lists of hits), the inputs Open3D's and trimesh's users hold, and raycast.trimesh
against trimesh's own intersector. Exact answers on simple geometry and a brute-force NumPy
float64 reference; Open3D itself is not needed (CI has none), trimesh is."""

import copy
import math
import os
import pickle
import subprocess
import sys
import types

import numpy as np
import pytest

import raycast
from test_raycast import uv_sphere

INVALID = raycast.RaycastingScene.INVALID_ID
MODES = [("f32", "gpu"), ("f64", "gpu"), ("f32", "cpu"), ("f64", "cpu")]
POINT_QUERIES = (
    "compute_closest_points",
    "compute_distance",
    "compute_signed_distance",
    "compute_occupancy",
    "compute_winding_number",
)


# --- Geometry and references -------------------------------------------------------------


def cube(faces=("x0", "x1", "y0", "y1", "z0", "z1")):
    """The unit cube [0, 1]^3 as 12 triangles (two per face), normals out; `faces` picks
    some of its faces ("z1" is the face z = 1), two triangles each, in that order."""
    vertices = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    triangles = []
    for face in faces:
        a, side = "xyz".index(face[0]), int(face[1])
        b, c = (a + 1) % 3, (a + 2) % 3  # b x c = a: the loop b then c turns about +a

        def corner(i, j):
            p = [0, 0, 0]
            p[a], p[b], p[c] = side, i, j
            return p[0] + 2 * p[1] + 4 * p[2]

        loop = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)]
        if side == 0:
            loop = loop[::-1]  # facing -a
        triangles += [[loop[0], loop[1], loop[2]], [loop[0], loop[2], loop[3]]]
    return vertices, np.array(triangles)


def scene_of(vertices, triangles):
    scene = raycast.RaycastingScene()
    scene.add_triangles(vertices, triangles)
    return scene


def at_barycentrics(vertices, triangles, primitive_ids, uvs):
    """The points at barycentric `uvs` on the triangles `primitive_ids`: (1 - u - v) a + u b
    + v c, Open3D's convention."""
    a, b, c = (vertices[triangles[primitive_ids, i]] for i in range(3))
    u, v = uvs[:, :1], uvs[:, 1:]
    return (1 - u - v) * a + u * b + v * c


def dot(a, b):
    return np.sum(a * b, axis=-1)


def segment_distance(p, a, b):
    ab = b - a
    t = np.clip(dot(p - a, ab) / dot(ab, ab), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def distance_reference(points, vertices, triangles):
    """The distance from each point to the mesh, brute force in float64: to each triangle, the
    distance to its plane where the point projects inside it, else to its nearest edge."""
    p = points[:, None, :]
    a, b, c = (vertices[triangles[:, i]][None] for i in range(3))
    n = np.cross(b - a, c - a)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    height = dot(p - a, n)
    q = p - height[..., None] * n
    inside = (
        (dot(np.cross(b - a, q - a), n) >= 0)
        & (dot(np.cross(c - b, q - b), n) >= 0)
        & (dot(np.cross(a - c, q - c), n) >= 0)
    )
    edges = np.minimum(
        np.minimum(segment_distance(p, a, b), segment_distance(p, b, c)),
        segment_distance(p, c, a),
    )
    return np.where(inside, np.abs(height), edges).min(axis=1)


def winding_reference(points, vertices, triangles):
    """The generalized winding number, the solid angles of the triangles seen from each point
    over 4 pi, by Van Oosterom and Strackee's formula, in float64."""
    a, b, c = (vertices[triangles[:, i]][None] - points[:, None, :] for i in range(3))
    la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
    numerator = dot(a, np.cross(b, c))
    denominator = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la
    return (2 * np.arctan2(numerator, denominator)).sum(axis=1) / (4 * math.pi)


def away_from_cube_surface(points, margin=1e-3):
    """The points farther than `margin` from the unit cube's surface."""
    vertices, triangles = cube()
    return points[distance_reference(points, vertices, triangles) > margin]


def in_cube(points):
    return np.all((points > 0) & (points < 1), axis=1)


def float_type(precision):
    return np.float64 if precision == "f64" else np.float32


# --- Closest points and distances --------------------------------------------------------

# Points in each region of the unit cube: (point, closest point, the closest face's normal,
# or None where an edge or a vertex is closest).
CUBE_REGIONS = [
    ([0.5, 0.5, 0.25], [0.5, 0.5, 0.0], [0, 0, -1]),  # inside, nearest the face z = 0
    ([0.3, 0.6, 1.5], [0.3, 0.6, 1.0], [0, 0, 1]),  # above the face z = 1
    ([0.4, -2.0, 0.7], [0.4, 0.0, 0.7], [0, -1, 0]),  # in front of the face y = 0
    ([1.5, 0.4, 1.5], [1.0, 0.4, 1.0], None),  # beside the edge x = z = 1
    ([-1.0, 0.25, -0.5], [0.0, 0.25, 0.0], None),  # beside the edge x = z = 0
    ([2.0, 2.0, -1.0], [1.0, 1.0, 0.0], None),  # beyond the vertex (1, 1, 0)
    ([-0.5, -0.5, -0.5], [0.0, 0.0, 0.0], None),  # beyond the vertex at the origin
]


@pytest.mark.parametrize("precision,device", MODES)
def test_closest_points_on_a_cube_in_every_region(precision, device):
    vertices, triangles = cube()
    scene = scene_of(vertices, triangles)
    points = np.array([p for p, _, _ in CUBE_REGIONS])
    closest = np.array([c for _, c, _ in CUBE_REGIONS])
    tol = 1e-6 if precision == "f32" else 1e-14
    ans = scene.compute_closest_points(points, precision=precision, device=device)
    assert set(ans) == {
        "points", "geometry_ids", "primitive_ids", "primitive_uvs", "primitive_normals"
    }
    np.testing.assert_allclose(ans["points"], closest, atol=tol)
    assert ans["points"].dtype == float_type(precision)
    assert ans["primitive_uvs"].dtype == float_type(precision)
    assert ans["geometry_ids"].dtype == np.uint32 and np.all(ans["geometry_ids"] == 0)
    assert ans["primitive_ids"].dtype == np.uint32
    # The primitive is a triangle the closest point lies on, at its barycentric coordinates.
    on_triangle = at_barycentrics(vertices, triangles, ans["primitive_ids"], ans["primitive_uvs"])
    np.testing.assert_allclose(on_triangle, closest, atol=tol)
    for (_, _, normal), got in zip(CUBE_REGIONS, ans["primitive_normals"]):
        if normal is not None:
            np.testing.assert_allclose(got, normal, atol=tol)
    distance = scene.compute_distance(points, precision=precision, device=device)
    assert distance.dtype == float_type(precision)
    np.testing.assert_allclose(distance, np.linalg.norm(points - closest, axis=1), rtol=tol)


@pytest.mark.parametrize("precision,device", MODES + [("adaptive", "gpu")])
def test_distances_agree_with_a_brute_force_reference(precision, device):
    """Random points around and inside a sphere mesh of 168 triangles: distances within 1e-5
    of the mesh's size in f32, 1e-12 in f64; closest points on their triangles."""
    vertices, triangles = uv_sphere([0.1, -0.2, 0.3], 1.0, slices=12, stacks=8)
    scene = scene_of(vertices, triangles)
    rng = np.random.default_rng(7)
    points = rng.uniform(-2, 2, (300, 3))
    expected = distance_reference(points, vertices, triangles)
    tol = 1e-12 if precision == "f64" else 1e-5 * 2.0  # the mesh is 2 across
    distance = scene.compute_distance(points, precision=precision, device=device)
    np.testing.assert_allclose(distance, expected, atol=tol, rtol=0)
    ans = scene.compute_closest_points(points, precision=precision, device=device)
    np.testing.assert_allclose(np.linalg.norm(ans["points"] - points, axis=1), expected, atol=tol)
    on_triangle = at_barycentrics(vertices, triangles, ans["primitive_ids"], ans["primitive_uvs"])
    np.testing.assert_allclose(on_triangle, ans["points"], atol=tol)
    uvs = ans["primitive_uvs"]
    assert np.all(uvs >= -tol) and np.all(uvs.sum(axis=1) <= 1 + tol)
    corners = vertices[triangles[ans["primitive_ids"]]]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    np.testing.assert_allclose(ans["primitive_normals"], normals, atol=max(tol, 1e-6))


def test_results_keep_the_leading_dimensions():
    scene = scene_of(*cube())
    points = np.random.default_rng(3).uniform(-1, 2, (2, 3, 4, 3))
    ans = scene.compute_closest_points(points)
    assert ans["points"].shape == (2, 3, 4, 3) and ans["primitive_normals"].shape == (2, 3, 4, 3)
    assert ans["primitive_uvs"].shape == (2, 3, 4, 2) and ans["primitive_ids"].shape == (2, 3, 4)
    for method in POINT_QUERIES[1:]:
        result = getattr(scene, method)(points)
        assert result.shape == (2, 3, 4), method
        flat = getattr(scene, method)(points.reshape(-1, 3))
        np.testing.assert_array_equal(result.reshape(-1), flat, err_msg=method)


def test_an_empty_scene_has_no_closest_point_and_nothing_inside():
    scene = raycast.RaycastingScene()
    points = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]])
    ans = scene.compute_closest_points(points)
    assert ans["geometry_ids"].tolist() == [INVALID, INVALID]
    assert ans["primitive_ids"].tolist() == [INVALID, INVALID]
    assert scene.compute_occupancy(points).tolist() == [0.0, 0.0]
    assert scene.compute_winding_number(points).tolist() == [0.0, 0.0]


# --- Inside, signed distance, winding numbers ------------------------------------------


@pytest.mark.parametrize("precision,device", MODES)
def test_occupancy_and_signed_distance_of_a_cube(precision, device):
    scene = scene_of(*cube())
    rng = np.random.default_rng(11)
    points = away_from_cube_surface(rng.uniform(-0.5, 1.5, (400, 3)))
    inside = in_cube(points)
    assert 0.05 < inside.mean() < 0.95
    distance = scene.compute_distance(points, precision=precision, device=device)
    for sign in ("parity", "winding"):
        for nsamples in (1, 3):
            kw = dict(nsamples=nsamples, sign=sign, precision=precision, device=device)
            occupancy = scene.compute_occupancy(points, **kw)
            assert occupancy.dtype == float_type(precision)
            np.testing.assert_array_equal(occupancy, inside.astype(float), err_msg=(sign, nsamples))
            signed = scene.compute_signed_distance(points, **kw)
            assert signed.dtype == float_type(precision)
            np.testing.assert_array_equal(signed, np.where(inside, -distance, distance))
    # Exact values: a point inside, nearest the face z = 0, and one above the face z = 1.
    points = [[0.5, 0.4, 0.25], [0.3, 0.6, 1.5]]
    signed = scene.compute_signed_distance(points, precision=precision, device=device)
    np.testing.assert_allclose(signed, [-0.25, 0.5], rtol=1e-6)


@pytest.mark.parametrize("precision,device", MODES)
def test_a_ray_through_an_edge_crosses_the_surface_once(precision, device):
    """Rays through an edge or a vertex two or more triangles share cross the surface there
    once, as Open3D counts and lists them: the parity test's first ray, (1, 1, 1), leaves the
    cube through an edge from every point with x = y, which must still be inside."""
    scene = scene_of(*cube())
    kw = dict(precision=precision, device=device)
    rays = np.array([
        [0.5, 0.5, 0.25, 1, 1, 1],  # out through the edge x = y = 1
        [0.5, 0.5, -1, 0, 0, 1],  # through the middle of two faces, on their diagonals
        [0.0, 0.0, -1, 0, 0, 1],  # along the edge x = y = 0, in at one vertex, out at another
    ])
    assert scene.count_intersections(rays, **kw).tolist() == [1, 2, 2]
    assert scene.list_intersections(rays, **kw)["ray_splits"].tolist() == [0, 1, 3, 5]
    points = [[0.5, 0.5, 0.25], [0.2, 0.2, 0.9]]
    assert scene.compute_occupancy(points, **kw).tolist() == [1, 1]
    signed = scene.compute_signed_distance(points, **kw)
    np.testing.assert_allclose(signed, [-0.25, -0.1], rtol=1e-6)


@pytest.mark.parametrize("precision,device", MODES)
def test_winding_numbers_against_the_solid_angle_formula(precision, device):
    """1 inside a closed mesh and 0 outside; for open meshes, the solid angle they span: half
    of all directions at the cube's centre for three of its faces, five sixths for five."""
    rng = np.random.default_rng(13)
    points = away_from_cube_surface(rng.uniform(-0.5, 1.5, (300, 3)))
    tol = 1e-5 if precision == "f32" else 1e-12
    closed = scene_of(*cube())
    w = closed.compute_winding_number(points, precision=precision, device=device)
    assert w.dtype == np.float64
    np.testing.assert_allclose(w, in_cube(points).astype(float), atol=tol)
    for faces, at_centre in ((("x0", "y0", "z0"), 0.5), (("x0", "x1", "y0", "y1", "z0"), 5 / 6)):
        vertices, triangles = cube(faces)
        scene = scene_of(vertices, triangles)
        centre = scene.compute_winding_number([[0.5, 0.5, 0.5]], precision=precision, device=device)
        np.testing.assert_allclose(centre, [at_centre], atol=tol)
        w = scene.compute_winding_number(points, precision=precision, device=device)
        np.testing.assert_allclose(w, winding_reference(points, vertices, triangles), atol=tol)


def test_the_winding_reference_is_right():
    """The reference itself: 1 inside the closed cube, 0 outside, and the centre's values."""
    vertices, triangles = cube()
    points = np.array([[0.5, 0.5, 0.5], [0.1, 0.9, 0.2], [2.0, 0.5, 0.5], [-1.0, -1.0, 3.0]])
    w = winding_reference(points, vertices, triangles)
    np.testing.assert_allclose(w, [1, 1, 0, 0], atol=1e-12)


def test_winding_sign_is_right_where_parity_fails():
    """A cube without its face at x = 1: a ray along (1, 1, 1) from inside that leaves through
    the hole crosses nothing, so parity calls the point outside; its winding number (the
    exact solid angle of the five faces, in numpy) is above one half, and so says inside."""
    vertices, triangles = cube(("x0", "y0", "y1", "z0", "z1"))
    scene = scene_of(vertices, triangles)
    points = np.array([[0.6, 0.3, 0.2], [0.7, 0.2, 0.4]])
    exact = winding_reference(points, vertices, triangles)
    assert min(exact) > 0.6
    np.testing.assert_allclose(scene.compute_winding_number(points), exact, atol=0.02)
    assert scene.compute_occupancy(points, sign="winding").tolist() == [1, 1]
    assert scene.compute_occupancy(points, sign="parity").tolist() == [0, 0]


# --- Lists of hits -----------------------------------------------------------------------


@pytest.mark.parametrize("precision,device", MODES)
def test_list_intersections_lists_what_count_intersections_counts(precision, device):
    vertices, triangles = uv_sphere([0.1, -0.2, 0.3], 1.0, slices=12, stacks=8)
    scene = scene_of(vertices, triangles)
    scene.add_triangles(*cube())
    rng = np.random.default_rng(17)
    rays = np.concatenate([rng.uniform(-2, 2, (400, 3)), rng.normal(size=(400, 3))], axis=1)
    kw = dict(precision=precision, device=device)
    ans = scene.list_intersections(rays, **kw)
    assert set(ans) == {
        "ray_splits", "ray_ids", "t_hit", "geometry_ids", "primitive_ids", "primitive_uvs"
    }
    splits = ans["ray_splits"]
    assert splits.dtype == np.uint32 and splits.shape == (401,) and splits[0] == 0
    counts = np.diff(splits.astype(np.int64))
    np.testing.assert_array_equal(counts, scene.count_intersections(rays, **kw))
    assert counts.max() >= 3  # rays through both objects
    k = int(splits[-1])
    for key in ("ray_ids", "geometry_ids", "primitive_ids"):
        assert ans[key].dtype == np.uint32 and ans[key].shape == (k,), key
    assert ans["t_hit"].dtype == float_type(precision) and ans["primitive_uvs"].shape == (k, 2)
    np.testing.assert_array_equal(ans["ray_ids"], np.repeat(np.arange(400), counts))
    # In order along each ray, from t = 0; the first is the nearest hit.
    t = ans["t_hit"]
    same_ray = ans["ray_ids"][1:] == ans["ray_ids"][:-1]
    assert np.all(t >= 0) and np.all(t[1:][same_ray] >= t[:-1][same_ray])
    nearest = scene.cast_rays(rays, **kw)
    hit = counts > 0
    first = splits[:-1][hit]
    tol = 1e-5 if precision == "f32" else 1e-12
    np.testing.assert_allclose(t[first], nearest["t_hit"][hit], rtol=tol, atol=tol)
    np.testing.assert_array_equal(ans["geometry_ids"][first], nearest["geometry_ids"][hit])
    # Each hit is where its ray meets its triangle.
    meshes = {0: (vertices, triangles), 1: cube()}
    for g, (v, tris) in meshes.items():
        mine = ans["geometry_ids"] == g
        uvs = ans["primitive_uvs"][mine]
        on_triangle = at_barycentrics(v, tris, ans["primitive_ids"][mine], uvs)
        r = rays[ans["ray_ids"][mine]]
        np.testing.assert_allclose(on_triangle, r[:, :3] + t[mine][:, None] * r[:, 3:], atol=tol)


def test_list_intersections_through_a_cube_exactly():
    scene = scene_of(*cube())
    rays = np.array([[0.3, 0.4, -1, 0, 0, 1], [5, 5, 5, 1, 0, 0], [0.3, 0.4, 0.5, 0, 0, 2]])
    ans = scene.list_intersections(rays.reshape(3, 1, 6), precision="f64")  # flattened
    assert ans["ray_splits"].tolist() == [0, 2, 2, 3]
    assert ans["ray_ids"].tolist() == [0, 0, 2]
    assert ans["t_hit"].tolist() == [1.0, 2.0, 0.25]
    # The faces z = 0 and z = 1 (the cube's 5th and 6th, two triangles each).
    assert (ans["primitive_ids"] // 2).tolist() == [4, 5, 5]


# --- Inputs ---------------------------------------------------------------------------


class FakeTensor:
    """Open3D's core.Tensor as far as raycast reads it: ``numpy()`` and a device, no
    ``__array__``."""

    def __init__(self, array, device="CPU:0"):
        self._array = np.asarray(array)
        self.device = device

    def numpy(self):
        return self._array


class FakeTensorMap(dict):
    """Open3D's TensorMap: ``mesh.vertex.positions`` and ``mesh.vertex["positions"]``."""

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None


class FakeTensorMesh:
    """An Open3D t.geometry.TriangleMesh: float32 positions, int64 indices, as Open3D's."""

    def __init__(self, vertices, triangles=None, device="CPU:0"):
        self.vertex = FakeTensorMap(positions=FakeTensor(np.float32(vertices), device))
        self.triangle = FakeTensorMap()
        if triangles is not None:
            self.triangle["indices"] = FakeTensor(np.int64(triangles), device)


class FakeLegacyMesh:
    """A legacy open3d.geometry.TriangleMesh: ``vertices`` and ``triangles`` that NumPy reads
    through the buffer protocol (Vector3dVector, Vector3iVector)."""

    def __init__(self, vertices, triangles):
        self.vertices = memoryview(np.ascontiguousarray(vertices, dtype=np.float64))
        self.triangles = memoryview(np.ascontiguousarray(triangles, dtype=np.int32))


class DLPackOnly:
    """An array that only DLPack reads (as a JAX or CuPy array would be read)."""

    def __init__(self, array, device=None):
        self._array = np.asarray(array)
        self._device = device

    def __dlpack__(self, **kwargs):
        return self._array.__dlpack__(**kwargs)

    def __dlpack_device__(self):
        return self._device or self._array.__dlpack_device__()


class ArrayOnly:
    """An array that only ``__array__`` reads (as a pandas frame or an xarray would be)."""

    def __init__(self, array):
        self._array = np.asarray(array)

    def __array__(self, dtype=None, copy=None):
        return self._array if dtype is None else self._array.astype(dtype)


def test_meshes_of_open3d_trimesh_and_anything_with_vertices_and_faces():
    vertices, triangles = cube()
    rays = np.array([[0.3, 0.4, -1, 0, 0, 1], [0.3, 0.4, 3, 0, 0, -1]])
    expected = scene_of(vertices, triangles).cast_rays(rays)
    meshes = [FakeTensorMesh(vertices, triangles), FakeLegacyMesh(vertices, triangles)]
    trimesh = pytest.importorskip("trimesh")
    meshes.append(trimesh.Trimesh(vertices, triangles, process=False))
    for mesh in meshes:
        scene = raycast.RaycastingScene()
        assert scene.add_triangles(mesh) == 0
        assert scene.add_triangles(mesh=mesh) == 1
        ans = scene.cast_rays(rays)
        for key in expected:
            np.testing.assert_array_equal(ans[key], expected[key], err_msg=type(mesh).__name__)
    # Open3D's keywords, tensors for both arrays.
    scene = raycast.RaycastingScene()
    scene.add_triangles(
        vertex_positions=FakeTensor(np.float32(vertices)), triangle_indices=FakeTensor(triangles)
    )
    np.testing.assert_array_equal(scene.cast_rays(rays)["t_hit"], expected["t_hit"])


def test_arrays_through_numpy_dlpack_array_and_lists():
    vertices, triangles = cube()
    points = np.array([[0.5, 0.5, 0.25], [2.0, 2.0, -1.0]], dtype=np.float32)
    rays = np.array([[0.3, 0.4, -1, 0, 0, 1]], dtype=np.float32)
    scene = raycast.RaycastingScene()
    scene.add_triangles(DLPackOnly(vertices), ArrayOnly(triangles))
    expected = scene.compute_distance(points)
    for wrapped in (FakeTensor(points), DLPackOnly(points), ArrayOnly(points), points.tolist(),
                    points.astype(np.float16), points.T.copy().T):
        np.testing.assert_array_equal(scene.compute_distance(wrapped), expected)
    np.testing.assert_array_equal(scene.compute_distance(np.array([[2, 2, -1]])), expected[1:])
    t = scene.cast_rays(rays)["t_hit"]
    for wrapped in (FakeTensor(rays), DLPackOnly(rays), ArrayOnly(rays)):
        np.testing.assert_array_equal(scene.cast_rays(wrapped)["t_hit"], t)
        assert scene.list_intersections(wrapped)["t_hit"].tolist() == [1.0, 2.0]


def test_gpu_tensors_are_refused_naming_the_argument():
    scene = scene_of(*cube())
    points = np.zeros((2, 3))
    with pytest.raises(ValueError, match=r"query_points: is on a CUDA:0 device; move it to the"):
        scene.compute_distance(FakeTensor(points, device="CUDA:0"))
    with pytest.raises(ValueError, match=r"rays: is on a CUDA device; move it to the CPU"):
        scene.cast_rays(DLPackOnly(np.zeros((2, 6)), device=(2, 0)))
    with pytest.raises(ValueError, match=r"mesh vertices: is on a CUDA:0 device"):
        scene.add_triangles(FakeTensorMesh(*cube(), device="CUDA:0"))


def test_results_are_numpy_arrays_with_open3d_numpy():
    scene = scene_of(*cube())
    rays = raycast.RaycastingScene.create_rays_pinhole(
        60, [0.5, 0.5, 0.5], [0.5, 0.5, 3], [0, 1, 0], 4, 3
    )
    points = rays[..., :3] + 0.1
    results = [
        rays,
        scene.cast_rays(rays),
        scene.test_occlusions(rays),
        scene.count_intersections(rays),
        scene.list_intersections(rays),
        scene.compute_closest_points(points),
        scene.compute_distance(points),
        scene.compute_signed_distance(points),
        scene.compute_occupancy(points),
        scene.compute_winding_number(points),
    ]
    arrays = [a for r in results for a in (r.values() if isinstance(r, dict) else [r])]
    assert len(arrays) == 23
    for array in arrays:
        assert isinstance(array, np.ndarray)
        plain = array.numpy()
        assert type(plain) is np.ndarray and np.shares_memory(plain, array)
        np.testing.assert_array_equal(plain, array)


def test_empty_inputs_give_empty_results():
    scene = scene_of(*cube())
    for precision in ("f32", "f64"):
        ans = scene.compute_closest_points(np.zeros((0, 3)), precision=precision)
        shapes = {key: value.shape for key, value in ans.items()}
        assert shapes == {"points": (0, 3), "geometry_ids": (0,), "primitive_ids": (0,),
                          "primitive_uvs": (0, 2), "primitive_normals": (0, 3)}
        assert ans["points"].dtype == float_type(precision)
        assert ans["geometry_ids"].dtype == np.uint32
        for method in ("compute_distance", "compute_signed_distance", "compute_occupancy"):
            result = getattr(scene, method)(np.zeros((2, 0, 3)), precision=precision)
            assert result.shape == (2, 0) and result.dtype == float_type(precision), method
        assert scene.compute_winding_number(np.zeros((0, 3))).shape == (0,)
        ans = scene.list_intersections(np.zeros((0, 6)), precision=precision)
        assert ans["ray_splits"].tolist() == [0] and ans["ray_splits"].dtype == np.uint32
        assert ans["t_hit"].shape == (0,) and ans["t_hit"].dtype == float_type(precision)
        assert ans["primitive_uvs"].shape == (0, 2) and ans["ray_ids"].dtype == np.uint32


def test_bad_input_raises_naming_the_argument():
    vertices, triangles = cube()
    scene = scene_of(vertices, triangles)
    for method in POINT_QUERIES:
        query = getattr(scene, method)
        with pytest.raises(ValueError, match=r"query_points: expected shape \(\.\.\., 3\)"):
            query(np.zeros((4, 2)))
        with pytest.raises(TypeError, match="query_points: expected an array of numbers"):
            query([["a", "b", "c"]])
        # Beyond the library's range (NaN and infinity are answered as Open3D answers them).
        with pytest.raises(ValueError, match=r"query_points\[1\]: .* at most 1e18"):
            query([[0, 0, 0], [0, 1e30, 0]])
        with pytest.raises(ValueError, match=r"query_points\[0, 1\]: .* at most 1e18"):
            query([[[0, 0, 0], [-1e19, 0, 0]]])
        with pytest.raises(ValueError, match=r"query_points\[0, 2\]: .* at most 1e18"):
            query([[[0, 0, 0], [np.nan, 0, 0], [-1e19, 0, 0]]])
        with pytest.raises(ValueError, match="query_points: cannot be read"):
            query([[0, 0, 0], [0, 0]])
        with pytest.raises(ValueError, match="precision"):
            query(np.zeros((1, 3)), precision="f16")
        with pytest.raises(ValueError, match="device"):
            query(np.zeros((1, 3)), device="tpu")
    for method in ("compute_signed_distance", "compute_occupancy"):
        for nsamples in (0, 2, -1, 1.5, True, "3"):
            with pytest.raises(ValueError, match="nsamples: expected a positive odd integer"):
                getattr(scene, method)(np.zeros((1, 3)), nsamples=nsamples)
        with pytest.raises(ValueError, match="sign: expected one of parity, winding"):
            getattr(scene, method)(np.zeros((1, 3)), sign="majority")
    with pytest.raises(ValueError, match=r"rays: expected shape \(\.\.\., 6\)"):
        scene.list_intersections(np.zeros((3, 5)))
    with pytest.raises(TypeError, match="rays: expected an array of numbers"):
        scene.list_intersections(np.zeros((1, 6), dtype=bool))
    with pytest.raises(ValueError, match="triangles: the mesh has no triangles"):
        scene.add_triangles(vertices, np.zeros((0, 3), dtype=int))
    with pytest.raises(ValueError, match="mesh triangles: the mesh has no triangles"):
        scene.add_triangles(FakeTensorMesh(vertices))
    with pytest.raises(ValueError, match="mesh triangles: the mesh has no triangles"):
        scene.add_triangles(FakeLegacyMesh(vertices, np.zeros((0, 3))))
    with pytest.raises(TypeError, match="mesh: expected an Open3D or trimesh triangle mesh"):
        scene.add_triangles(object())
    with pytest.raises(TypeError, match="mesh triangles: expected integer indices"):
        scene.add_triangles(types.SimpleNamespace(vertices=vertices, faces=triangles + 0.5))
    with pytest.raises(ValueError, match=r"mesh triangles: index 8 is out of range \(8 vertices\)"):
        scene.add_triangles(FakeTensorMesh(vertices, triangles + 1))
    with pytest.raises(ValueError, match=r"vertices\[1\]: NaN"):
        with_nan = np.where(np.arange(8)[:, None] == 1, np.nan, vertices)
        scene.add_triangles(FakeTensorMesh(with_nan, triangles))
    with pytest.raises(TypeError, match="not both"):
        scene.add_triangles(vertices, triangles, mesh=FakeTensorMesh(vertices, triangles))


def test_nthreads_is_accepted_where_open3d_takes_it():
    scene = scene_of(*cube())
    rays = np.array([[0.3, 0.4, -1, 0, 0, 1]])
    points = np.array([[0.5, 0.5, 0.25]])
    assert scene.cast_rays(rays, 4)["t_hit"].tolist() == [1.0]
    assert scene.test_occlusions(rays, 0.0, 0.5, 4).tolist() == [False]
    assert scene.count_intersections(rays, nthreads=4).tolist() == [2]
    assert scene.list_intersections(rays, 4)["ray_splits"].tolist() == [0, 2]
    assert scene.compute_closest_points(points, 4)["points"].tolist() == [[0.5, 0.5, 0.0]]
    assert scene.compute_distance(points, nthreads=4).tolist() == [0.25]
    assert scene.compute_signed_distance(points, 4, 3).tolist() == [-0.25]
    assert scene.compute_occupancy(points, 4, 3).tolist() == [1.0]


# --- raycast.trimesh ---------------------------------------------------------------------


def test_the_trimesh_module_imports_without_trimesh():
    """`import raycast` does not import raycast.trimesh, and raycast.trimesh does not import
    trimesh (it is handed the mesh)."""
    code = (
        "import sys, raycast; assert 'raycast.trimesh' not in sys.modules; "
        "assert raycast.trimesh.RayMeshIntersector; "
        "assert 'trimesh' not in sys.modules, 'trimesh was imported'"
    )
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    subprocess.run([sys.executable, "-c", code], check=True, env=env)


def random_rays(rng, n, spread=2.0):
    """Rays from anywhere in a box `spread` from the origin, most of them aimed near it."""
    origins = rng.uniform(-spread, spread, (n, 3))
    return origins, rng.uniform(-0.7, 0.7, (n, 3)) - origins + rng.normal(0, 0.3, (n, 3))


def hit_pairs(index_tri, index_ray):
    return set(zip(index_ray.tolist(), index_tri.tolist()))


@pytest.mark.parametrize("shape", ["icosphere", "box"])
def test_trimesh_drop_in_agrees_with_trimeshs_own_intersector(shape):
    trimesh = pytest.importorskip("trimesh")
    pytest.importorskip("rtree")  # trimesh's own intersector needs it
    from trimesh.ray.ray_triangle import RayMeshIntersector as Reference

    from raycast.trimesh import RayMeshIntersector

    mesh = trimesh.creation.icosphere() if shape == "icosphere" else trimesh.creation.box()
    ours, theirs = RayMeshIntersector(mesh), Reference(mesh)
    assert ours.mesh is mesh
    origins, directions = random_rays(np.random.default_rng(19), 300)
    # Every hit of every ray, as (ray, face) pairs; locations within 1e-5.
    tri, ray = ours.intersects_id(origins, directions)
    assert tri.dtype == np.int64 and ray.dtype == np.int64
    assert hit_pairs(tri, ray) == hit_pairs(*theirs.intersects_id(origins, directions))
    assert len(tri) > 100
    locations, ray, tri = ours.intersects_location(origins, directions)
    ref_locations, ref_ray, ref_tri = theirs.intersects_location(origins, directions)
    assert locations.dtype == np.float64 and hit_pairs(tri, ray) == hit_pairs(ref_tri, ref_ray)
    ours_at = {pair: at for pair, at in zip(zip(ray.tolist(), tri.tolist()), locations)}
    for pair, at in zip(zip(ref_ray.tolist(), ref_tri.tolist()), ref_locations):
        np.testing.assert_allclose(ours_at[pair], at, atol=1e-5)
    # The first hits.
    first = ours.intersects_first(origins, directions)
    assert first.dtype == np.int64
    np.testing.assert_array_equal(first, theirs.intersects_first(origins, directions))
    tri, ray = ours.intersects_id(origins, directions, multiple_hits=False)
    expected = theirs.intersects_id(origins, directions, multiple_hits=False)
    assert hit_pairs(tri, ray) == hit_pairs(*expected)
    tri, ray = ours.intersects_id(origins, directions, max_hits=1)
    assert hit_pairs(tri, ray) == {(r, f) for r, f in enumerate(first.tolist()) if f >= 0}
    np.testing.assert_array_equal(ours.intersects_any(origins, directions), first >= 0)
    np.testing.assert_array_equal(
        ours.intersects_any(origins, directions), theirs.intersects_any(origins, directions)
    )
    # trimesh's own functions that cast through mesh.ray.
    points, rays = random_rays(np.random.default_rng(23), 50, spread=0.5)
    expected = trimesh.proximity.longest_ray(mesh, points, rays)
    mesh.ray = ours
    longest = trimesh.proximity.longest_ray(mesh, points, rays)
    np.testing.assert_allclose(longest, expected, rtol=1e-6)


def test_a_ray_through_an_edge_is_located_once():
    """A ray through the middle of a box's face crosses the diagonal two of its triangles
    share: one location per crossing, as trimesh reports them."""
    trimesh = pytest.importorskip("trimesh")
    from raycast.trimesh import RayMeshIntersector

    mesh = trimesh.creation.box()
    locations, ray, _ = RayMeshIntersector(mesh).intersects_location([[0, 0, -2]], [[0, 0, 1]])
    np.testing.assert_allclose(sorted(locations[:, 2]), [-0.5, 0.5], atol=1e-6)


def test_trimesh_contains_and_voxelized_through_the_drop_in():
    trimesh = pytest.importorskip("trimesh")
    from raycast.trimesh import RayMeshIntersector

    rng = np.random.default_rng(29)
    points = rng.uniform(-0.9, 0.9, (500, 3))
    box = trimesh.creation.box()
    sphere = trimesh.creation.icosphere()
    # The exact answers: the box is |x|, |y|, |z| < 0.5, the icosphere convex (inside every
    # face's plane); points within 1e-6 of the surface are left out.
    box_margin = np.abs(np.abs(points).max(axis=1) - 0.5)
    to_faces = points[:, None] - sphere.triangles[None, :, 0]
    heights = np.einsum("fk,pfk->pf", sphere.face_normals, to_faces)
    for mesh, inside, away in (
        (box, np.abs(points).max(axis=1) < 0.5, box_margin > 1e-6),
        (sphere, np.all(heights < 0, axis=1), np.all(np.abs(heights) > 1e-6, axis=1)),
    ):
        mesh.ray = RayMeshIntersector(mesh)
        contains = mesh.contains(points[away])
        assert contains.dtype == bool
        np.testing.assert_array_equal(contains, inside[away])
        assert 0.1 < contains.mean() < 0.9
    # Voxels from rays along z, the same as trimesh's own intersector makes.
    voxels = sphere.voxelized(0.25, method="ray")
    reference = trimesh.Trimesh(sphere.vertices, sphere.faces)
    pytest.importorskip("rtree")
    expected = reference.voxelized(0.25, method="ray")
    ours, theirs = (set(map(tuple, np.round(v.points / 0.25).tolist())) for v in (voxels, expected))
    assert len(ours) > 100 and ours == theirs


def test_trimesh_drop_in_follows_the_mesh_and_copies():
    trimesh = pytest.importorskip("trimesh")
    from raycast.trimesh import RayMeshIntersector

    mesh = trimesh.creation.box()
    ray = RayMeshIntersector(mesh, precision="f64", device="cpu")
    origins, directions = [[0.1, 0.2, -3]], [[0, 0, 1]]
    before = ray.intersects_location(origins, directions)[0]
    mesh.apply_translation([0, 0, 1])
    after = ray.intersects_location(origins, directions)[0]
    np.testing.assert_allclose(after, before + [0, 0, 1])
    for clone in (copy.copy(ray), copy.deepcopy(ray), pickle.loads(pickle.dumps(ray))):
        np.testing.assert_allclose(clone.intersects_location(origins, directions)[0], after)
        assert clone.precision == "f64" and clone.device == "cpu"
    # A ray with no direction hits nothing; an empty mesh has nothing to hit or contain.
    first = ray.intersects_first([[0, 0, 0], [0.1, 0.2, -3]], [[0, 0, 0], [0, 0, 1]])
    assert first[0] == -1 and first[1] >= 0
    empty = RayMeshIntersector(trimesh.Trimesh())
    assert empty.intersects_first(origins, directions).tolist() == [-1]
    assert empty.intersects_id(origins, directions)[0].shape == (0,)
    assert empty.contains_points([[0, 0, 0]]).tolist() == [False]
    with pytest.raises(ValueError, match="points: expected shape"):
        ray.contains_points([0, 0, 0])
