"""Type stubs of the native module (python/src/lib.rs); use the wrappers in raycast/__init__.py."""

from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

class Scene:
    def __init__(self) -> None: ...
    @staticmethod
    def load(path: str) -> "Scene": ...
    def add_triangles(
        self, vertices: npt.NDArray[np.float64], triangles: npt.NDArray[np.uint32]
    ) -> int: ...
    def add_sphere(self, center: List[float], radius: float) -> int: ...
    def add_plane(self, point: List[float], normal: List[float]) -> int: ...
    def cast(
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
    def render(
        self, precision: str, device: str, lit: bool = ..., shader: Optional[str] = ...
    ) -> Dict[str, Any]: ...

def info() -> Dict[str, Any]: ...
