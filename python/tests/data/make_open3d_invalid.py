"""Writes open3d_invalid.json beside this file: Open3D's own answers to rays and query points
that hold NaN or infinite coordinates or have a zero direction, among valid ones, for every
query of its RaycastingScene, which python/tests/test_open3d_invalid.py compares raycast's with.

Run it with real Open3D (not needed by the tests, so not installed by scripts/test.sh):

    python3 -m venv /tmp/o3d && /tmp/o3d/bin/pip install open3d-cpu numpy
    /tmp/o3d/bin/python python/tests/data/make_open3d_invalid.py

(open3d-cpu 0.20 on Python 3.11 wrote the committed file; it needs libusb-1.0 installed.)
Every output field is kept as Open3D returns it (float32 as the float it is exactly), but for
compute_closest_points' points, primitive_uvs and primitive_normals at NaN or infinite
points: Open3D leaves those as whatever its memory held (they change from run to run), so
they are written as null.
"""

import json
import math
import pathlib
import re

import numpy as np
import open3d as o3d

nan, inf = math.nan, math.inf

# A closed cube (its occupancy and signed distance mean something) and a square below it.
CUBE_VERTICES = [[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)]
CUBE_TRIANGLES = [
    [0, 1, 3], [0, 3, 2],  # x = 0
    [4, 6, 7], [4, 7, 5],  # x = 1
    [0, 4, 5], [0, 5, 1],  # y = 0
    [2, 3, 7], [2, 7, 6],  # y = 1
    [0, 2, 6], [0, 6, 4],  # z = 0
    [1, 5, 7], [1, 7, 3],  # z = 1
]
SQUARE_VERTICES = [[-1, -1, -1], [2, -1, -1], [2, 2, -1], [-1, 2, -1]]
SQUARE_TRIANGLES = [[0, 1, 2], [0, 2, 3]]
MESHES = [(CUBE_VERTICES, CUBE_TRIANGLES), (SQUARE_VERTICES, SQUARE_TRIANGLES)]

# Valid rays (away from the triangles' edges) between invalid ones of every kind.
RAYS = [
    [0.3, 0.4, 3, 0, 0, -1],  # through the cube's top and bottom, then the square
    [nan, 0.4, 3, 0, 0, -1],  # NaN origin
    [0.3, 0.4, 3, 0, nan, -1],  # NaN direction
    [0.3, 0.6, 0.45, 0.1, 0.2, 1],  # from inside the cube, direction not of length 1
    [inf, 0.4, 0.5, -1, 0, 0],  # infinite origin, towards the cube
    [0.3, 0.4, -inf, 0, 0, 1],  # origin at z = -inf, towards the square and the cube
    [0.3, 0.4, 3, 0, 0, -inf],  # infinite direction
    [0.3, 0.4, 3, inf, 0, -1],
    [5, 5, 5, 1, 0, 0],  # a miss
    [0.3, 0.4, 3, 0, 0, 0],  # zero direction
    [0.3, 0.4, 1, -0.0, 0.0, -0.0],  # zero direction (negative zeros), from the cube's top
    [0.6, 0.7, 2, 0.2, -0.1, -2],  # a slanted ray
    [nan, nan, nan, nan, nan, nan],
    [inf, inf, inf, 0, 0, 0],
    [-inf, 0.4, 0.5, nan, 0, 0],
]

POINTS = [
    [0.3, 0.6, 0.45],  # inside the cube
    [nan, 0.5, 0.5],
    [2, 0.3, 0.6],  # outside, nearest the cube
    [0.5, 0.5, nan],
    [inf, 0.5, 0.5],
    [-0.5, 1.5, -0.5],  # nearest the square
    [0.5, -inf, 0.5],
    [inf, nan, 0],
    [nan, nan, nan],
    [inf, -inf, inf],
]

# Occlusion tests: Open3D's defaults, then a range that some valid rays hit within.
OCCLUSION_RANGES = [(0.0, inf), (1.5, 2.5)]
NSAMPLES = [1, 3]


def check_random_invalid_rays(scene: "o3d.t.geometry.RaycastingScene", n: int = 200_000) -> None:
    """That Open3D misses every invalid ray, not only those of RAYS: `n` random rays about the
    scene, each with one coordinate inf, -inf or NaN, or a zero direction."""
    rng = np.random.default_rng(1)
    rays = rng.uniform(-2, 3, (n, 6)).astype(np.float32)
    kind = rng.integers(0, 4, n)
    column = rng.integers(0, 6, n)
    for k, value in enumerate((inf, -inf, nan)):
        rays[kind == k, column[kind == k]] = value
    rays[kind == 3, 3:] = 0
    tensor = o3d.core.Tensor(rays)
    hits = (scene.cast_rays(tensor)["geometry_ids"].numpy() != 4294967295).sum()
    crossings = scene.count_intersections(tensor).numpy().sum()
    assert hits == 0 and crossings == 0, f"{hits} hits, {crossings} crossings"
    assert not scene.test_occlusions(tensor).numpy().any()


def readable_json(value: dict) -> str:
    """`value` as JSON with each list of numbers (a ray, a point, a short result) on a line."""
    text = json.dumps(value, indent=1)
    return re.sub(r"\[\s+([^][{}]*?)\s+\]", lambda m: f"[{' '.join(m.group(1).split())}]", text)


def listed(tensor: "o3d.core.Tensor") -> list:
    return tensor.numpy().tolist()


def main() -> None:
    scene = o3d.t.geometry.RaycastingScene()
    for vertices, triangles in MESHES:
        scene.add_triangles(
            o3d.core.Tensor(np.array(vertices, dtype=np.float32)),
            o3d.core.Tensor(np.array(triangles, dtype=np.uint32)),
        )
    check_random_invalid_rays(scene)
    rays = o3d.core.Tensor(np.array(RAYS, dtype=np.float32))
    points = o3d.core.Tensor(np.array(POINTS, dtype=np.float32))

    closest = {key: listed(value) for key, value in scene.compute_closest_points(points).items()}
    undefined = [not all(math.isfinite(x) for x in p) for p in POINTS]
    for key in ("points", "primitive_uvs", "primitive_normals"):
        closest[key] = [None if bad else row for bad, row in zip(undefined, closest[key])]

    answers = {
        "open3d": o3d.__version__,
        "meshes": [{"vertices": v, "triangles": t} for v, t in MESHES],
        "rays": RAYS,
        "points": POINTS,
        "cast_rays": {key: listed(value) for key, value in scene.cast_rays(rays).items()},
        "test_occlusions": [
            {"tnear": tnear, "tfar": tfar,
             "hit": listed(scene.test_occlusions(rays, tnear=tnear, tfar=tfar))}
            for tnear, tfar in OCCLUSION_RANGES
        ],
        "count_intersections": listed(scene.count_intersections(rays)),
        "list_intersections": {
            key: listed(value) for key, value in scene.list_intersections(rays).items()
        },
        "compute_closest_points": closest,
        "compute_distance": listed(scene.compute_distance(points)),
        "compute_signed_distance": [
            {"nsamples": n, "distance": listed(scene.compute_signed_distance(points, nsamples=n))}
            for n in NSAMPLES
        ],
        "compute_occupancy": [
            {"nsamples": n, "occupancy": listed(scene.compute_occupancy(points, nsamples=n))}
            for n in NSAMPLES
        ],
    }
    path = pathlib.Path(__file__).with_name("open3d_invalid.json")
    path.write_text(readable_json(answers) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
