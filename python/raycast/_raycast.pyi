"""Type stubs of the native module (python/src/lib.rs); use the wrappers in raycast/__init__.py."""

from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class Scene:
    def __init__(self) -> None: ...
    @staticmethod
    def load(path: str) -> "Scene": ...
    def add_mesh(
        self, vertices: npt.NDArray[np.float64], triangles: npt.NDArray[np.uint32]
    ) -> int: ...
    def add_sphere(self, center: List[float], radius: float) -> int: ...
    def add_plane(self, point: List[float], normal: List[float]) -> int: ...
    def add_instance(self, mesh: int, transform: npt.NDArray[np.float64]) -> int: ...
    def set_transforms(self, ids: List[int], transforms: npt.NDArray[np.float64]) -> None: ...
    def intersect(
        self,
        rays: Union[npt.NDArray[np.float32], npt.NDArray[np.float64]],
        width: Optional[int],
        precision: str,
        device: str,
    ) -> Dict[str, np.ndarray]: ...
    def occluded(
        self,
        rays: Union[npt.NDArray[np.float32], npt.NDArray[np.float64]],
        width: Optional[int],
        t_range: Tuple[float, float],
        precision: str,
        device: str,
    ) -> npt.NDArray[np.bool_]: ...
    def count(
        self,
        rays: Union[npt.NDArray[np.float32], npt.NDArray[np.float64]],
        precision: str,
        device: str,
    ) -> npt.NDArray[np.uint32]: ...
    def every_hit(
        self,
        rays: Union[npt.NDArray[np.float32], npt.NDArray[np.float64]],
        precision: str,
        device: str,
    ) -> Dict[str, np.ndarray]:
        """Every hit of every ray, nearest first: flat ``ray_splits`` (n + 1, uint32),
        ``ray_ids``, ``t_hit``, ``geometry_ids``, ``primitive_ids`` (k) and ``primitive_uvs``
        (2k)."""
    def closest(
        self, points: npt.NDArray[np.float64], precision: str, device: str
    ) -> Dict[str, np.ndarray]:
        """The closest surface point to each (n, 3) point: flat ``points`` (3n), ``distance``
        (n), ``geometry_ids``, ``primitive_ids`` (n, uint32), ``primitive_uvs`` (2n) and
        ``primitive_normals`` (3n); float64 for f64, else float32."""
    def winding_numbers(
        self, points: npt.NDArray[np.float64], precision: str, device: str
    ) -> npt.NDArray[np.float64]:
        """The generalized winding number at each (n, 3) point."""
    def inside(
        self,
        points: npt.NDArray[np.float64],
        sign: str,
        nsamples: int,
        precision: str,
        device: str,
    ) -> npt.NDArray[np.bool_]:
        """Whether each (n, 3) point is inside: ``sign`` "parity" (``nsamples`` rays vote)
        or "winding"."""
    def render(
        self,
        precision: Optional[str],
        device: str,
        lit: bool = ...,
        shader: Optional[str] = ...,
        camera: Optional[Camera] = ...,
        size: Optional[List[int]] = ...,
    ) -> Dict[str, Any]:
        """The scene file's camera (or ``camera``) rendered, at ``size`` [width, height] where
        given: flat ``id``, ``distance``, ``normal`` (and ``color``, ``hook_rays``), ``width``
        and ``height``."""
    def render_each(
        self,
        precision: Optional[str],
        device: str,
        cameras: List[Camera],
        lit: bool = ...,
        shader: Optional[str] = ...,
    ) -> ViewStream:
        """``render`` of each of ``cameras`` in turn, a thread rendering the next view while
        the last is taken."""
    def views(
        self,
        cameras: Optional[str] = ...,
        orbit: Optional[int] = ...,
        orbit_radius: Optional[float] = ...,
        orbit_elevation: Optional[float] = ...,
    ) -> List[Tuple[str, Camera]]:
        """The named cameras of a views file's JSON text (``cameras``) or of an orbit of
        ``orbit`` views (at ``orbit_radius`` and ``orbit_elevation`` where given), for this
        scene, as ``raycast render --views``/``--orbit`` renders them; errors are ValueErrors
        naming ``cameras[k]``."""

class Camera:
    """A camera for ``Scene.render``, from ``Scene.views``."""
    @property
    def resolution(self) -> List[int]: ...

class ViewStream:
    """The views of ``Scene.render_each``, each a dict as ``Scene.render`` returns it; a view
    whose render failed raises its error, and ends them."""
    def __iter__(self) -> "ViewStream": ...
    def __next__(self) -> Dict[str, Any]: ...

class ViewJob:
    """``raycast render SCENES... --views FILE|--orbit N -o OUT`` as a job that workers share."""
    def __init__(
        self,
        scenes: List[str],
        views: Union[str, int],
        out: str,
        formats: List[str],
        size: Optional[List[int]] = ...,
        precision: Optional[str] = ...,
        device: str = ...,
        force: bool = ...,
    ) -> None: ...
    def check(self) -> int:
        """Checks the job and that OUT is writable; the number of (scene, view) pairs, scene
        by scene."""
    def render(self, pairs: List[int]) -> int:
        """Renders these pairs into their folders (those not complete already with the
        same record, unless forced), the next view prepared and the last finished and written
        while one view's kernel runs; how many it rendered."""
    def write_manifest(self) -> Path:
        """Rewrites OUT/manifest.jsonl from the output folder; its path."""

def info() -> Dict[str, Any]: ...
def invalid_rays(
    rays: Union[npt.NDArray[np.float32], npt.NDArray[np.float64]],
) -> Optional[npt.NDArray[np.bool_]]:
    """Which (n, 6) rays have a NaN or infinite coordinate or a zero direction; None where
    none has."""
def invalid_points(points: npt.NDArray[np.float64]) -> Optional[npt.NDArray[np.bool_]]:
    """Which (n, 3) points have a NaN or infinite coordinate; None where none has."""
