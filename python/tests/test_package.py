"""The package itself: its version, its names, what its optional extra's ImportError tells a
user to install, and `render`'s size, against the command line's `--size`. Runs the
command-line binary that `cargo test` built (RAYCAST_BIN to use another)."""

import os
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest

import raycast

ROOT = pathlib.Path(__file__).resolve().parents[2]
BINARY = os.environ.get("RAYCAST_BIN", str(ROOT / "target" / "debug" / "raycast"))
BUNNY = ROOT / "scenes" / "course" / "bunny.json"


def toml_value(path, key):
    """The first `key = "value"` of a TOML file (Python 3.9 has no tomllib)."""
    return re.search(rf'^{key} = "(.*)"$', path.read_text(), re.MULTILINE).group(1)


def test_version_is_the_packages_one_version():
    """`raycast.__version__` is python/Cargo.toml's, which maturin gives the wheel: the
    pyproject declares its version dynamic instead of writing a second one."""
    assert raycast.__version__ == toml_value(ROOT / "python" / "Cargo.toml", "version")
    assert re.fullmatch(r"\d+\.\d+\.\d+", raycast.__version__)
    pyproject = (ROOT / "python" / "pyproject.toml").read_text()
    assert re.search(r'^dynamic = \["version"\]$', pyproject, re.MULTILINE)
    assert not re.search(r"^version = ", pyproject, re.MULTILINE)


def test_names_are_the_packages_own():
    """`dir(raycast)` and `from raycast import *` hold the package's names, not the modules
    and typing names its code imports; every name listed is there."""
    public = {"Array", "RaycastingScene", "load", "info", "trimesh", "distributed"}
    names = set(dir(raycast))
    assert public | {"__version__", "__doc__", "__all__"} <= names
    assert {n for n in names if not n.startswith("__")} == public
    for name in names:
        getattr(raycast, name)
    star = {}
    exec("from raycast import *", star)
    assert set(star) - {"__builtins__"} == {"Array", "RaycastingScene", "load", "info"}


def test_distributed_without_ray_says_what_to_install(monkeypatch, tmp_path):
    """The ImportError names a requirement pip installs: the `distributed` extra's own."""
    from raycast import distributed

    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` raises ImportError
    with pytest.raises(ImportError, match="raycast.distributed needs Ray Data") as error:
        distributed.render([BUNNY], 2, tmp_path / "out")
    suggested = re.search(r'pip install "([^"]+)"$', str(error.value)).group(1)
    extra = re.search(r"^distributed = \[\"([^\"]+)\"\]$",
                      (ROOT / "python" / "pyproject.toml").read_text(), re.MULTILINE)
    assert suggested == extra.group(1)
    assert not suggested.startswith("raycast")  # not on PyPI


def test_render_size_renders_what_the_command_lines_size_does(tmp_path):
    args = ["--size", "64x36", "--format", "npy", "--precision", "f32", "--device", "cpu"]
    subprocess.run([BINARY, "render", BUNNY, *args, "-o", tmp_path], check=True,
                   capture_output=True)
    scene = raycast.load(BUNNY)
    for size in ((64, 36), np.array([64, 36])):
        images = scene.render(precision="f32", device="cpu", size=size)
        for key in ("id", "distance", "normal"):
            assert np.array_equal(images[key], np.load(tmp_path / f"{key}.npy")), key
    assert images["id"].shape == (36, 64)
    # Without a size, the scene's resolution, as without --size.
    assert scene.render(device="cpu")["id"].shape == (360, 640)


@pytest.mark.parametrize(
    "size, error, message",
    [
        ("64x36", TypeError, "size: expected (width, height), got str"),
        (64, TypeError, "size: expected (width, height), got int"),
        ((64,), ValueError, "size: expected (width, height), got 1 numbers"),
        ((64, 36, 1), ValueError, "size: expected (width, height), got 3 numbers"),
        ((64.0, 36), TypeError, "size: expected integers (width, height), got 64.0"),
        ((True, 36), TypeError, "size: expected integers (width, height), got True"),
        ((64, 0), ValueError, "size: expected (width, height) of at least 1 each, got (64, 0)"),
        ((-1, 36), ValueError, "size: expected (width, height) of at least 1 each, got (-1, 36)"),
        ((2**32, 1), ValueError, "size: expected (width, height) of at least 1 each"),
    ],
)
def test_render_refuses_a_bad_size_naming_it(size, error, message):
    scene = raycast.load(BUNNY)
    with pytest.raises(error, match=f"^{re.escape(message)}"):
        scene.render(device="cpu", size=size)
