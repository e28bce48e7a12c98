"""raycast's answers to invalid rays and query points (NaN or infinite coordinates, zero
directions) beside Open3D 0.20's own, kept as data in data/open3d_invalid.json (written by
data/make_open3d_invalid.py with real Open3D): every query, every output field.

Exact: ids, counts, booleans, ray_splits and ray_ids, and where each float is inf or nan.
Within 1e-5 (absolute and relative): t_hit, distances, points, uvs and normals, which Open3D
computes in float32 (raycast's f64 differs from them by float32's rounding)."""

import json
import math
import pathlib

import numpy as np
import pytest

import raycast

DATA = json.loads((pathlib.Path(__file__).parent / "data" / "open3d_invalid.json").read_text())
RAYS = np.array(DATA["rays"], dtype=np.float32)  # as Open3D was given them
POINTS = np.array(DATA["points"], dtype=np.float32)
INVALID_RAYS = ~np.isfinite(RAYS).all(axis=1) | (RAYS[:, 3:] == 0).all(axis=1)
INVALID_POINTS = ~np.isfinite(POINTS).all(axis=1)
TOLERANCE = 1e-5
MODES = [("f32", "cpu"), ("f64", "cpu"), ("f32", "gpu"), ("adaptive", "gpu")]


def scene() -> raycast.RaycastingScene:
    s = raycast.RaycastingScene()
    for mesh in DATA["meshes"]:
        s.add_triangles(np.array(mesh["vertices"], dtype=np.float32), mesh["triangles"])
    return s


def assert_matches(actual, expected, name):
    """`actual` equals Open3D's `expected`: the same shape, inf and nan in the same places
    (with the same sign), the other numbers within TOLERANCE (exactly for integers)."""
    actual = np.asarray(actual)
    expected = np.asarray(expected, dtype=actual.dtype)
    assert actual.shape == expected.shape, name
    if not np.issubdtype(actual.dtype, np.floating):
        np.testing.assert_array_equal(actual, expected, err_msg=name)
        return
    np.testing.assert_array_equal(np.isnan(actual), np.isnan(expected), err_msg=name)
    np.testing.assert_array_equal(np.isinf(actual), np.isinf(expected), err_msg=name)
    finite = np.isfinite(expected)
    np.testing.assert_array_equal(actual[~finite & ~np.isnan(expected)],
                                  expected[~finite & ~np.isnan(expected)], err_msg=name)
    np.testing.assert_allclose(actual[finite], expected[finite], rtol=TOLERANCE,
                               atol=TOLERANCE, err_msg=name)


def test_the_data_holds_valid_and_invalid_rays_and_points_of_every_kind():
    """The generator's cases: each kind of invalid ray and point, and valid ones that hit."""
    assert DATA["open3d"].startswith("0.20")
    origins, directions = RAYS[:, :3], RAYS[:, 3:]
    assert np.isnan(origins).any(axis=1).any() and np.isnan(directions).any(axis=1).any()
    assert np.isposinf(origins).any() and np.isneginf(origins).any()
    assert np.isinf(directions).any()
    zero = (directions == 0).all(axis=1)
    assert zero.sum() >= 3 and np.signbit(directions[zero]).any()
    assert 0 < INVALID_RAYS.sum() < len(RAYS) - 2
    assert np.isnan(POINTS).any() and np.isposinf(POINTS).any() and np.isneginf(POINTS).any()
    assert 0 < INVALID_POINTS.sum() < len(POINTS) - 2
    hits = np.array(DATA["cast_rays"]["geometry_ids"]) != raycast.RaycastingScene.INVALID_ID
    assert hits.sum() >= 3 and not hits[INVALID_RAYS].any()


@pytest.mark.parametrize("precision,device", MODES)
def test_ray_queries_answer_as_open3d(precision, device):
    s = scene()
    ans = s.cast_rays(RAYS, precision=precision, device=device)
    assert ans.keys() == DATA["cast_rays"].keys()
    for key, expected in DATA["cast_rays"].items():
        assert_matches(ans[key], expected, f"cast_rays {key}")
    for case in DATA["test_occlusions"]:
        hit = s.test_occlusions(RAYS, tnear=case["tnear"], tfar=case["tfar"],
                                precision=precision, device=device)
        assert_matches(hit, case["hit"], f"test_occlusions {case['tnear']}..{case['tfar']}")
    counts = s.count_intersections(RAYS, precision=precision, device=device)
    assert_matches(counts, DATA["count_intersections"], "count_intersections")
    listed = s.list_intersections(RAYS, precision=precision, device=device)
    assert listed.keys() == DATA["list_intersections"].keys()
    for key, expected in DATA["list_intersections"].items():
        assert_matches(listed[key], expected, f"list_intersections {key}")


@pytest.mark.parametrize("precision,device", MODES)
def test_point_queries_answer_as_open3d(precision, device):
    s = scene()
    closest = s.compute_closest_points(POINTS, precision=precision, device=device)
    assert closest.keys() == DATA["compute_closest_points"].keys()
    for key, expected in DATA["compute_closest_points"].items():
        # Rows Open3D leaves undefined (null): raycast's documented NaN point and zeros.
        undefined = np.array([row is None for row in expected])
        assert (undefined == INVALID_POINTS).all() or not undefined.any(), key
        fill = math.nan if key == "points" else 0.0
        rows = [[fill] * len(closest[key][0]) if row is None else row for row in expected]
        assert_matches(closest[key], rows, f"compute_closest_points {key}")
    distance = s.compute_distance(POINTS, precision=precision, device=device)
    assert_matches(distance, DATA["compute_distance"], "compute_distance")
    for case in DATA["compute_signed_distance"]:
        signed = s.compute_signed_distance(POINTS, nsamples=case["nsamples"],
                                           precision=precision, device=device)
        assert_matches(signed, case["distance"], f"compute_signed_distance {case['nsamples']}")
    for case in DATA["compute_occupancy"]:
        occupancy = s.compute_occupancy(POINTS, nsamples=case["nsamples"],
                                        precision=precision, device=device)
        assert_matches(occupancy, case["occupancy"], f"compute_occupancy {case['nsamples']}")


def test_invalid_rows_keep_their_places_in_any_shape_and_dtype():
    """The rays as an image (two leading dimensions, which the GPU casts in tiles when all are
    valid), in float64 and with the invalid rows moved, give each ray Open3D's answer."""
    s = scene()
    expected = DATA["cast_rays"]
    order = np.argsort(INVALID_RAYS, kind="stable")[::-1]  # the invalid rays first
    shaped = [(RAYS.reshape(3, 5, 6), np.arange(15)), (RAYS[order].astype(np.float64), order)]
    for rays, rows in shaped:
        for device in ("cpu", "gpu"):
            ans = s.cast_rays(rays, device=device)
            for key, values in expected.items():
                got = ans[key].reshape(len(RAYS), -1)
                want = np.asarray(values, dtype=got.dtype).reshape(len(RAYS), -1)[rows]
                assert_matches(got, want, key)
            counts = s.count_intersections(rays, device=device).reshape(-1)
            assert_matches(counts, np.asarray(DATA["count_intersections"])[rows], "counts")
    points = POINTS.reshape(2, 5, 3).astype(np.float64)
    distance = s.compute_distance(points, device="cpu")
    assert distance.shape == (2, 5)
    assert_matches(distance.reshape(-1), DATA["compute_distance"], "compute_distance")


def test_a_ray_or_point_beyond_1e18_is_still_refused_naming_its_row():
    """The library's range (finite coordinates of at most 1e18) stays an error; among
    invalid rows that are left out, the error names the row as it was given."""
    s = scene()
    rays = RAYS.astype(np.float64)
    rays[13] = [0.3, 0.4, 1e30, 0, 0, -1]
    with pytest.raises(ValueError, match=r"^rays\[13\] origin: 1e\+?30|^rays\[13\] origin: 10{30}"):
        s.cast_rays(rays, device="cpu")
    with pytest.raises(ValueError, match=r"^rays\[13\] origin"):
        s.list_intersections(rays, device="cpu")
    points = POINTS.astype(np.float64)
    points[9] = [0, 0, -1e30]
    for query in ("compute_distance", "compute_occupancy", "compute_winding_number"):
        with pytest.raises(ValueError, match=r"^query_points\[9\]: "):
            getattr(s, query)(points, device="cpu")
    with pytest.raises(ValueError, match=r"^query_points\[0\]: "):
        s.compute_distance([[0, 0, 1e30]], device="cpu")


def test_winding_numbers_of_invalid_points_are_nan():
    """Not in Open3D: a point with a NaN or infinite coordinate has no winding number; the
    others have theirs, as given alone."""
    s = scene()
    w = s.compute_winding_number(POINTS)
    assert np.isnan(w[INVALID_POINTS]).all()
    alone = s.compute_winding_number(POINTS[~INVALID_POINTS])
    assert np.isfinite(alone).all()
    np.testing.assert_array_equal(w[~INVALID_POINTS], alone)
