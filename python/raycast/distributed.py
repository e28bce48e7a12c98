"""Datasets on a Ray cluster: many views of many scene files rendered to files, the job
``raycast render SCENE... --views FILE -o OUT`` (or ``--orbit N``) runs on one machine::

    import raycast.distributed
    summary = raycast.distributed.render(["a.json", "b.json"], "views.json", "out")

Every (scene, view) pair of the job is a row of a Ray dataset, in the job's order (every view
of the first scene, then of the next), so that a batch holds a run of views of one scene. Ray
Data hands the batches to a pool of actors, one a GPU (or a CPU where the cluster has no GPU,
rendering on lavapipe or with ``device="cpu"``), each holding a native renderer that keeps the
scene it rendered last loaded and prepared (its BVH's shape, its kernels) for the next batch.
Each view is rendered and written by the library's own code into
``OUT/<scene stem>/<view name>/``, whole or not at all, and the driver then rewrites
``OUT/manifest.jsonl``: the files are byte for byte those the command line writes. Views whose
folder is complete, with a record (``job.json``) of the same options, scene and camera, are
skipped unless ``force``, so a run stopped part way is resumed by running it again; views of
other options or of a changed scene are rendered again (docs/datasets.md).

Workers are given the paths made absolute from the driver's working directory: on a cluster of
several machines they must lie on a filesystem every machine mounts at the same place.

Ray is optional: ``pip install "ray[data]>=2.9"`` (the package's ``distributed`` extra: ``pip
install "./python[distributed]"`` from a checkout installs both). ``import raycast.distributed``
does not import it; ``render`` does.
"""

from __future__ import annotations

import math
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _image_size, _raycast

# What Ray Data the package's `distributed` extra asks for (python/pyproject.toml).
_RAY_REQUIREMENT = "ray[data]>=2.9"

__all__ = ["render"]

PathLike = Union[str, "os.PathLike[str]"]


def _ray() -> Any:
    """The ``ray`` module with Ray Data, or ImportError saying how to install them."""
    try:
        import ray
        import ray.data  # noqa: F401 (Ray Data is an extra of Ray)
    except ImportError as e:
        raise ImportError(
            f'raycast.distributed needs Ray Data ({e}): pip install "{_RAY_REQUIREMENT}"'
        ) from None
    return ray


class _Renderer:
    """An actor of the pool: a native renderer kept from batch to batch, so that a run of
    views of one scene loads and prepares the scene once."""

    def __init__(self, job: Dict[str, Any]) -> None:
        self._job = _raycast.ViewJob(**job)

    def __call__(self, batch: Dict[str, np.ndarray]) -> Dict[str, np.ndarray]:
        rendered = self._job.render([int(p) for p in batch["pair"]])
        return {"rendered": np.array([rendered])}


def render(
    scenes: Union[PathLike, Sequence[PathLike]],
    views: Union[PathLike, int],
    out: PathLike,
    formats: Union[str, Sequence[str]] = ("png",),
    size: Optional[Tuple[int, int]] = None,
    precision: Optional[str] = None,
    device: str = "gpu",
    force: bool = False,
    ray_address: Optional[str] = None,
    num_gpus: Optional[int] = None,
    concurrency: Optional[int] = None,
    batch_size: Optional[int] = None,
) -> Dict[str, Any]:
    """Renders every view of every scene file into ``out`` on a Ray cluster, as ``raycast
    render SCENES... --views VIEWS -o OUT`` does (``--orbit VIEWS`` where ``views`` is a
    number), then rewrites ``out/manifest.jsonl``.

    ``formats`` (``--format``: png, ppm, npy, npz, exr, depth16), ``size`` (``(width,
    height)``, ``--size``), ``precision`` (``--precision``; None: the device's default,
    adaptive on the GPU) and ``device`` are the command line's, as is ``force`` (render views
    whose folder is complete again).

    Ray: connects to ``ray_address`` (``ray.init(address=...)``) unless Ray is initialised
    already, else starts a local cluster (``ray.init()``). Renders with one actor a GPU, on
    ``num_gpus`` GPUs (default: every GPU of the cluster; 0: on CPUs), or without GPUs with
    one actor a CPU; ``concurrency`` sets the number of actors instead. ``batch_size`` views
    go to an actor at a time (default: a scene's views, at most an even share of the job).

    Returns ``rendered`` (stale views among them) and ``skipped`` (complete already) view
    counts, ``views`` (the job's) and ``manifest`` (its path). A bad argument raises
    ValueError or TypeError before Ray starts; an error while rendering is raised as Ray
    reports it."""
    job = _job(scenes, views, out, formats, size, precision, device, force)
    _count("num_gpus", num_gpus, 0)
    _count("concurrency", concurrency, 1)
    _count("batch_size", batch_size, 1)
    driver = _raycast.ViewJob(**job)
    total = driver.check()  # every camera and name checked before Ray starts

    ray = _ray()
    if not ray.is_initialized():
        if ray_address:
            ray.init(address=ray_address)
        else:
            ray.init()
    cluster = ray.cluster_resources()
    gpus = int(cluster.get("GPU", 0)) if num_gpus is None else num_gpus
    on_gpus = device == "gpu" and gpus > 0
    # One actor a GPU: a renderer uses its device whole. Without, one a CPU (the renderer's
    # own threads share the CPUs its node has).
    # TODO(library): wgpu picks the adapter by WGPU_ADAPTER_NAME, not CUDA_VISIBLE_DEVICES,
    # which is how Ray hands an actor its GPU: on a machine of several identical GPUs every
    # actor may open the same one.
    actors = concurrency or (gpus if on_gpus else max(1, int(cluster.get("CPU", 1))))
    actors = min(actors, total)
    scene_views = total // max(1, len(job["scenes"]))
    batch = batch_size or max(1, min(scene_views, math.ceil(total / actors)))
    # The workers' job: the same, with paths that do not depend on their working directory
    # (the driver's keeps them as given, for the manifest's `scene` entries).
    absolute = dict(job, scenes=[os.path.abspath(s) for s in job["scenes"]],
                    out=os.path.abspath(job["out"]))
    if isinstance(job["views"], str):
        absolute["views"] = os.path.abspath(job["views"])
    resources = {"num_gpus": 1} if on_gpus else {"num_cpus": 1}
    pairs = ray.data.from_items([{"pair": p} for p in range(total)])
    done = pairs.map_batches(
        _Renderer,
        fn_constructor_kwargs={"job": absolute},
        batch_size=batch,
        batch_format="numpy",
        concurrency=actors,
        **resources,
    ).take_all()
    rendered = sum(int(row["rendered"]) for row in done)
    manifest = driver.write_manifest()
    return {"rendered": rendered, "skipped": total - rendered, "views": total,
            "manifest": str(manifest)}


def _job(
    scenes: Any,
    views: Any,
    out: Any,
    formats: Any,
    size: Any,
    precision: Any,
    device: Any,
    force: Any,
) -> Dict[str, Any]:
    """The arguments of ``_raycast.ViewJob``, checked: plain strings, numbers and lists that
    Ray sends to the workers."""
    if isinstance(scenes, (str, os.PathLike)):
        scenes = [scenes]
    if isinstance(scenes, (bytes, dict)) or not isinstance(scenes, Sequence):
        raise TypeError(f"scenes: expected a list of scene files, got {scenes!r}")
    if not scenes:
        raise ValueError("scenes: expected at least one scene file")
    paths: List[str] = [os.fspath(s) for s in scenes]
    if isinstance(views, (bool, np.bool_)):
        raise TypeError("views: expected a views file or a number of orbit views, got a bool")
    if isinstance(views, (int, np.integer)):
        if not 1 <= views < 2**32:
            raise ValueError(f"views: expected at least 1 orbit view, got {views}")
        views = int(views)
    elif isinstance(views, (str, os.PathLike)):
        views = os.fspath(views)
    else:
        raise TypeError(f"views: expected a views file or a number of orbit views, got {views!r}")
    if isinstance(formats, str):
        formats = formats.split(",")
    formats = [str(f).strip() for f in formats]
    size = _image_size(size)
    if precision not in (None, "f32", "f64", "adaptive"):
        raise ValueError(f"precision: expected None, f32, f64 or adaptive, got {precision!r}")
    if device not in ("gpu", "cpu"):
        raise ValueError(f"device: expected gpu or cpu, got {device!r}")
    return {"scenes": paths, "views": views, "out": os.fspath(out), "formats": formats,
            "size": size, "precision": precision, "device": device, "force": bool(force)}


def _count(name: str, value: Any, least: int) -> None:
    if value is not None and (
        isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least
    ):
        raise ValueError(f"{name}: expected an integer of at least {least}, got {value!r}")
