# Type stubs of cfuse's extension module; the package `cfuse` re-exports the public names.
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union
import os
import numpy as np

__version__: str

class InputError(ValueError):
    """Bad input: ``file``, ``line`` and ``column`` (0 when unknown), ``element`` ("" when
    unknown) and ``message`` (without the location)."""
    file: str
    line: int
    column: int
    element: str
    message: str

class InternalError(RuntimeError): ...

class Model:
    name: str
    path: str
    dof: int
    components: List[str]
    joints: List[str]
    points: List[str]
    def check(self) -> Dict[str, Any]: ...

def load_model(path: Union[str, os.PathLike[str]]) -> Model: ...

class Camera:
    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    dist: List[float]
    def __init__(self, fx: float, fy: float, cx: float, cy: float, width: int, height: int,
                 dist: Sequence[float] = ...) -> None: ...
    @staticmethod
    def load(path: Union[str, os.PathLike[str]]) -> Camera: ...
    def project(self, xyz: np.ndarray) -> np.ndarray: ...

class Measurements:
    def __init__(self, *, xyz: Optional[np.ndarray] = None, uv: Optional[np.ndarray] = None,
                 sigma: Union[None, float, np.ndarray] = None, cov: Optional[np.ndarray] = None,
                 labels: Optional[Sequence[Optional[str]]] = None,
                 camera: Optional[Camera] = None) -> None: ...
    @staticmethod
    def load(path: Union[str, os.PathLike[str]]) -> Measurements: ...
    def __len__(self) -> int: ...
    xyz: np.ndarray
    uv: np.ndarray
    cov: Union[np.ndarray, List[np.ndarray]]
    labels: List[Optional[str]]
    camera: Optional[Camera]
    def to_dict(self) -> Dict[str, Any]: ...

def _fk(model: Model, joints: Dict[str, float]) -> Tuple[Dict[str, Any], int, List[str]]: ...
def _simulate(model: Model, seed: int, noise: float, pixel_noise: float, clutter: float,
              occlusion: float, labels: bool, sample_joints: bool,
              camera: Optional[Camera]) -> Tuple[Measurements, Dict[str, Any]]: ...
def _solve(model: Model, measurements: Measurements, guess: Any,
           method: str) -> Tuple[Dict[str, Any], int, List[str]]: ...
def _interpret(model: Model, measurements: Measurements, gate: float,
               max_nodes: int) -> Tuple[Dict[str, Any], int, List[str]]: ...

class _Tracker:
    def __init__(self, model: Model, camera: Camera, init: Any, max_branches: int) -> None: ...
    def track(self, image: np.ndarray, order: str,
              depth: Optional[np.ndarray]) -> Dict[str, Any]: ...
    def skip(self) -> None: ...

def _detect(model: Model, camera: Camera, image: np.ndarray, max_results: int,
            order: str) -> Dict[str, Any]: ...
