"""Many views of a scene: `render_views` against `render` of a scene file with each camera and
against the files `raycast render --orbit` writes, and `raycast.distributed.render` on a local
Ray cluster against the command line's files, byte for byte. Runs the command-line binary that
`cargo test` built (RAYCAST_BIN to use another)."""

import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import raycast

ROOT = pathlib.Path(__file__).resolve().parents[2]
BINARY = os.environ.get("RAYCAST_BIN", str(ROOT / "target" / "debug" / "raycast"))
BUNNY = ROOT / "scenes" / "course" / "bunny.json"
SMALL = [64, 36]

# The camera forms of docs/scene-format.md, at a small size.
CAMERAS = [
    {"name": "course", "eye": [0, 0, 2], "look": [0, 0, -1], "up": [0, 1, 0],
     "focal_length": 1, "width": 1.7777777778, "height": 1, "resolution": SMALL},
    {"name": "fov", "eye": [0.5, 0.3, 1.8], "look_at": [0, 0.1, 0], "up": [0, 1, 0],
     "fov": 50, "resolution": SMALL},
    {"name": "intrinsics", "eye": [-0.4, 0.2, 1.5], "look": [0.2, -0.1, -1], "up": [0, 1, 0],
     "intrinsics": {"fx": 40, "fy": 40, "cx": 31.5, "cy": 17.5}, "resolution": SMALL,
     "near": 0.5},
    {"name": "orthographic", "type": "orthographic", "eye": [0, 0, 2], "look": [0, 0, -1],
     "up": [0, 1, 0], "focal_length": 1, "width": 2, "height": 1.125, "resolution": SMALL},
]


def scene_with(tmp_path, name, camera):
    """bunny.json with `camera`, saved in tmp_path (its mesh by absolute path)."""
    scene = json.loads(BUNNY.read_text())
    scene["camera"] = camera
    scene["objects"][0]["stl"] = str(BUNNY.parent / "bunny.stl")
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(scene))
    return path


def cli(*args):
    subprocess.run([BINARY, "render", *map(str, args)], check=True, capture_output=True)


def files(folder):
    """Every file under `folder` by its relative path, with its bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("precision", ["f32", "f64"])
def test_render_views_equal_render_of_a_scene_file_with_each_camera(tmp_path, precision):
    views = list(raycast.load(BUNNY).render_views(CAMERAS, precision=precision, device="cpu"))
    assert [v["name"] for v in views] == [c["name"] for c in CAMERAS]
    for camera, view in zip(CAMERAS, views):
        fields = {k: v for k, v in camera.items() if k != "name"}
        one = raycast.load(scene_with(tmp_path, camera["name"], fields))
        expected = one.render(precision=precision, device="cpu")
        assert sorted(view) == sorted([*expected, "name"])
        for key, image in expected.items():
            assert view[key].dtype == image.dtype, key
            assert np.array_equal(view[key], image), (camera["name"], key)


def test_render_without_a_precision_is_the_command_lines_default_render(tmp_path):
    """`render()` without a precision writes what `raycast render` without `--precision`
    writes: adaptive on the GPU (f32 with a hook), f64 on the CPU."""
    fields = {k: v for k, v in CAMERAS[1].items() if k != "name"}
    path = scene_with(tmp_path, "small", fields)
    for device, hook in [("gpu", []), ("gpu", ["--lit"]), ("cpu", [])]:
        out = tmp_path / f"{device}{len(hook)}"
        cli(path, "--format", "png,npy", "--device", device, *hook, "-o", out)
        images = raycast.load(path).render(device=device, lit=bool(hook))
        for key in ("id", "distance", "normal"):
            expected = np.load(out / f"{key}.npy")
            assert images[key].dtype == expected.dtype, (device, hook, key)
            assert np.array_equal(images[key], expected), (device, hook, key)


def test_a_view_beyond_memory_raises_memory_error_before_it_renders():
    """A view whose images cannot fit in this machine's memory (100000x100000 pixels held
    whole in f64 on the CPU: 360 GB) is refused before it renders (docs/cli.md#memory)."""
    huge = dict(CAMERAS[1], name="huge", resolution=[100000, 100000])
    with pytest.raises(MemoryError, match=r"size 100000x100000: .* needs 360 GB"):
        next(raycast.load(BUNNY).render_views([huge], precision="f64", device="cpu"))


def test_a_view_that_fails_raises_in_its_turn_and_ends_the_views():
    """The views render one ahead of the caller, on a thread: a view that fails (beyond memory
    here) raises when the iteration reaches it, after the views before it, and ends the views;
    a caller that stops early stops the thread."""
    huge = dict(CAMERAS[1], name="huge", resolution=[100000, 100000])
    scene = raycast.load(BUNNY)
    views = scene.render_views([CAMERAS[0], CAMERAS[1], huge, CAMERAS[2]], device="cpu")
    assert [next(views)["name"], next(views)["name"]] == ["course", "fov"]
    with pytest.raises(MemoryError, match="100000x100000"):
        next(views)
    assert list(views) == []
    views = scene.render_views(CAMERAS, device="cpu")
    assert next(views)["name"] == "course"
    views.close()
    assert [v["name"] for v in scene.render_views(CAMERAS[:2], device="cpu")] == ["course", "fov"]


def test_render_views_on_the_gpu_lit_takes_numpy_values_and_default_names():
    camera = {k: v for k, v in CAMERAS[1].items() if k != "name"}
    camera["eye"] = np.array(camera["eye"])
    camera["fov"] = np.float32(50)
    scene = raycast.load(BUNNY)
    views = scene.render_views([camera, camera], lit=True)
    first, second = list(views)
    assert (first["name"], second["name"]) == ("view-000", "view-001")
    assert first["color"].shape == (36, 64, 4) and first["id"].shape == (36, 64)
    for key in ("id", "distance", "normal", "color"):
        assert np.array_equal(first[key], second[key])


@pytest.mark.parametrize("camera", CAMERAS, ids=[c["name"] for c in CAMERAS])
def test_render_views_orbit_renders_what_the_command_line_writes(tmp_path, camera):
    form = {k: v for k, v in camera.items() if k != "name"}
    path = scene_with(tmp_path, "scene", form)
    cli(path, "--orbit", 3, "--format", "npy", "--precision", "f32", "-o", tmp_path / "out")
    views = list(raycast.load(path).render_views(3, precision="f32"))
    assert [v["name"] for v in views] == ["orbit-000", "orbit-001", "orbit-002"]
    for view in views:
        folder = tmp_path / "out" / "scene" / view["name"]
        for key in ("id", "distance", "normal"):
            assert np.array_equal(view[key], np.load(folder / f"{key}.npy")), (view["name"], key)


def test_render_views_orbit_radius_and_elevation_are_the_command_line_options(tmp_path):
    path = scene_with(tmp_path, "scene", {k: v for k, v in CAMERAS[0].items() if k != "name"})
    options = ("--orbit-radius", 2.5, "--orbit-elevation", -10)
    out = tmp_path / "out"
    cli(path, "--orbit", 3, *options, "--format", "npy", "--precision", "f32", "-o", out)
    scene = raycast.load(path)
    views = list(scene.render_views(3, precision="f32", orbit_radius=2.5, orbit_elevation=-10))
    default = next(scene.render_views(1, precision="f32"))
    assert not np.array_equal(views[0]["distance"], default["distance"])
    for view in views:
        folder = out / "scene" / view["name"]
        for key in ("id", "distance", "normal"):
            assert np.array_equal(view[key], np.load(folder / f"{key}.npy")), (view["name"], key)


GOOD = {k: v for k, v in CAMERAS[0].items() if k != "name"}


@pytest.mark.parametrize(
    "cameras, error, message",
    [
        (0, ValueError, "cameras: expected at least 1 orbit view, got 0"),
        (True, TypeError, "cameras: expected a list"),
        ("views.json", TypeError, "cameras: expected a list"),
        (GOOD, TypeError, "cameras: expected a list"),
        ([GOOD, 3], TypeError, "cameras[1]: expected a dict"),
        ([dict(GOOD, fovv=30)], ValueError, "cameras[0].fovv: unknown field `fovv`, did you mean `fov`?"),
        ([dict(GOOD, fov=30)], ValueError, "cameras[0].fov: is an alternative"),
        ([{"eye": [0, 0, 2], "look": [0, 0, -1]}], ValueError, "cameras[0]: missing field `up`"),
        ([dict(GOOD, eye=[0, float("nan"), 2])], ValueError, "cameras[0]: expected finite numbers"),
        ([dict(GOOD, eye="here")], ValueError, "cameras[0].eye: invalid type"),
        ([dict(GOOD, name=7)], TypeError, "cameras[0].name: expected a string"),
        ([dict(GOOD, up=[0, 0, -1])], ValueError, "cameras[0].up: is parallel"),
    ],
)
def test_bad_cameras_raise_naming_the_camera(cameras, error, message):
    scene = raycast.load(BUNNY)
    with pytest.raises(error) as raised:
        scene.render_views(cameras)  # raises at the call, before any view renders
    assert str(raised.value).startswith(message)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize(
    "options, error, message",
    [
        ({"orbit_radius": 0}, ValueError, "orbit_radius: must be a positive distance"),
        ({"orbit_radius": float("inf")}, ValueError, "orbit_radius: must be a positive distance"),
        ({"orbit_elevation": 90}, ValueError, "orbit_elevation: must be between -90 and 90"),
        ({"orbit_elevation": float("nan")}, ValueError, "orbit_elevation: must be between"),
        ({"orbit_radius": "far"}, TypeError, "orbit_radius: expected a number, got str"),
        ({"orbit_elevation": True}, TypeError, "orbit_elevation: expected a number, got bool"),
    ],
)
def test_bad_orbit_options_raise_naming_the_option(options, error, message):
    scene = raycast.load(BUNNY)
    with pytest.raises(error) as raised:
        scene.render_views(3, **options)
    assert str(raised.value).startswith(message)


@pytest.mark.parametrize("option", ["orbit_radius", "orbit_elevation"])
def test_orbit_options_with_a_list_of_cameras_raise(option):
    with pytest.raises(ValueError, match=f"^{option}: sets an orbit's views"):
        raycast.load(BUNNY).render_views([GOOD], **{option: 1.0})


def test_threads_render_one_loaded_scene_at_once():
    """Threads rendering one loaded scene (its views share one BVH shape, under a lock taken
    with the GIL released) all finish, each with its own view's images."""
    import concurrent.futures

    scene = raycast.load(str(BUNNY))
    cameras = [dict(CAMERAS[1], name=f"v{k}", eye=[0.5 + 0.1 * k, 0.3, 1.8]) for k in range(3)]
    alone = [view["id"] for view in scene.render_views(cameras, device="cpu")]
    with concurrent.futures.ThreadPoolExecutor(3) as pool:
        futures = [pool.submit(lambda c=c: next(scene.render_views([c], device="cpu"))["id"])
                   for c in cameras]
        together = [f.result(timeout=120) for f in futures]
    for a, b in zip(alone, together):
        assert np.array_equal(a, b)
    assert not np.array_equal(alone[0], alone[2])


def test_render_views_needs_a_scene_file():
    with pytest.raises(ValueError, match="render_views: the scene has no camera"):
        raycast.RaycastingScene().render_views([GOOD])


def test_import_raycast_imports_no_ray():
    code = "import raycast, raycast.distributed, sys; assert 'ray' not in sys.modules"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    subprocess.run([sys.executable, "-c", code], check=True, env=env)


def test_distributed_render_refuses_bad_arguments_before_ray(tmp_path):
    from raycast import distributed

    with pytest.raises(ValueError, match="^views: expected at least 1 orbit view, got 0$"):
        distributed.render([BUNNY], 0, tmp_path)
    with pytest.raises(TypeError, match="^views: "):
        distributed.render([BUNNY], 2.5, tmp_path)
    with pytest.raises(ValueError, match="^formats: unknown format `jpg`"):
        distributed.render([BUNNY], 2, tmp_path, formats=["jpg"])
    with pytest.raises(ValueError, match="^size: "):
        distributed.render([BUNNY], 2, tmp_path, size=(64, 0))
    with pytest.raises(ValueError, match="^scenes: .* would share the folder `bunny`"):
        distributed.render([BUNNY, BUNNY], 2, tmp_path)


@pytest.fixture(scope="module")
def ray_cluster():
    import ray  # not skipped where missing: scripts/test.sh installs it

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


# A views file (whose path the workers are given made absolute); the orbit's views go through
# the same renderer, which the command line's tests check.
@pytest.mark.parametrize("views", ["file"])
@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # Ray Data's own, at its start
def test_distributed_render_writes_the_command_lines_files(tmp_path, ray_cluster, views):
    from raycast import distributed

    scenes = [str(BUNNY), str(ROOT / "scenes" / "course" / "sphere-and-plane.json")]
    if views == "orbit":
        given = 4
        flag = ["--orbit", "4"]
    else:
        given = str(tmp_path / "views.json")
        pathlib.Path(given).write_text(json.dumps(CAMERAS[:3]))
        flag = ["--views", given]
    common = ["--size", "64x36", "--format", "png,npy"]
    cli(*scenes, *flag, *common, "-o", tmp_path / "cli")
    out = tmp_path / "ray"
    summary = distributed.render(scenes, given, out, formats=("png", "npy"), size=(64, 36))
    total = 2 * (4 if views == "orbit" else 3)
    assert summary == {"rendered": total, "skipped": 0, "views": total,
                       "manifest": str(out / "manifest.jsonl")}
    expected, written = files(tmp_path / "cli"), files(out)
    assert set(written) == set(expected)
    for name, data in expected.items():
        assert written[name] == data, name
    assert "manifest.jsonl" in expected
    # Run again: every view is complete, and the manifest is the same.
    again = distributed.render(scenes, given, out, formats=("png", "npy"), size=(64, 36))
    assert (again["rendered"], again["skipped"]) == (0, total)
    assert (out / "manifest.jsonl").read_bytes() == expected["manifest.jsonl"]
