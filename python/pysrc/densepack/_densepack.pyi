"""Type stubs of the extension module ``densepack._densepack`` (written by hand; CI checks
them against the module with ``mypy.stubtest``)."""

import os
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "__version__",
    "DensepackError",
    "RunFailed",
    "Scene",
    "Packing",
    "_run",
    "take",
    "_run_realisation",
    "_seeds_to_run",
    "_append_summary",
    "_read_summary",
]

__version__: str

class DensepackError(Exception):
    """Base class of densepack's own errors."""

class RunFailed(DensepackError):
    """A run ended without a packing; nothing was written."""

    verdict: str
    stage: Optional[int]
    message: str

@final
class Scene:
    """A validated scene (spheres, ellipsoids or a sphere + cylinder mixture). Immutable,
    picklable."""

    @staticmethod
    def from_toml(source: Union[str, os.PathLike[str]]) -> Scene: ...
    @staticmethod
    def from_dict(d: Dict[str, Any]) -> Scene: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def to_toml(self) -> str: ...
    def with_seed(self, seed: int) -> Scene: ...
    def with_values(self, values: Dict[str, Any]) -> Scene: ...
    @property
    def seed(self) -> int: ...
    @property
    def kind(self) -> str: ...
    def __eq__(self, value: object, /) -> bool: ...
    def __reduce__(self) -> Tuple[Any, Tuple[str]]: ...

@final
class Packing:
    """A packing: container, particles, statistics and provenance. Immutable, picklable."""

    @staticmethod
    def load(path: Union[str, os.PathLike[str]]) -> Packing: ...
    @staticmethod
    def import_file(
        path: Union[str, os.PathLike[str]],
        source: str,
        *,
        box: Optional[Sequence[float]] = None,
        cylinder: Optional[Sequence[float]] = None,
        periodic: Optional[Sequence[bool]] = None,
    ) -> Packing: ...
    def save(self, path: Union[str, os.PathLike[str]]) -> None: ...
    @staticmethod
    def from_json(text: str, name: str = "<json>") -> Packing: ...
    def to_json(self) -> str: ...
    def __len__(self) -> int: ...
    def __reduce__(self) -> Tuple[Any, Tuple[str]]: ...
    @property
    def centers(self) -> npt.NDArray[np.float64]: ...
    @property
    def radii(self) -> npt.NDArray[np.float64]: ...
    @property
    def semi_axes(self) -> npt.NDArray[np.float64]: ...
    @property
    def orientations(self) -> npt.NDArray[np.float64]: ...
    @property
    def half_axes(self) -> npt.NDArray[np.float64]: ...
    @property
    def kinds(self) -> npt.NDArray[np.str_]: ...
    @property
    def container(self) -> Dict[str, Any]: ...
    @property
    def stats(self) -> Dict[str, Any]: ...
    @property
    def provenance(self) -> Optional[Dict[str, Any]]: ...
    @property
    def min_gap(self) -> float: ...
    @property
    def seed(self) -> int: ...
    @property
    def packing_fraction(self) -> float: ...
    def verify(self) -> Dict[str, Any]: ...
    def export(
        self,
        path: Union[str, os.PathLike[str]],
        format: str,
        *,
        voxels: Optional[int] = None,
        labels: Optional[str] = None,
        partial_volume: Optional[int] = None,
        interface: Optional[float] = None,
        mesh_size: Optional[float] = None,
        shrink: Optional[float] = None,
    ) -> Dict[str, Any]: ...
    def voxels(
        self, n: int, labels: str = "phase", *, partial_volume: Optional[int] = None
    ) -> npt.NDArray[Any]: ...
    def voxel_grid(self, n: int) -> Dict[str, Any]: ...

def take(
    grading: Union[str, Dict[str, Any]],
    *,
    phi_m: float,
    d_min: float,
    box: Optional[Sequence[float]] = None,
    cylinder: Optional[Sequence[float]] = None,
    volume: Optional[float] = None,
    seed: int = 0,
) -> Tuple[npt.NDArray[np.float64], Dict[str, Any]]: ...
def _run(
    scene: Scene,
    progress: Optional[Callable[[str, int, int, Dict[str, Any]], None]] = None,
    checkpoint: Optional[Union[str, os.PathLike[str]]] = None,
    checkpoint_every: float = 600.0,
) -> Packing: ...
def _run_realisation(scene: Scene, seed: int, dir: Union[str, os.PathLike[str]]) -> Dict[str, Any]: ...
def _seeds_to_run(dir: Union[str, os.PathLike[str]], seeds: Sequence[int]) -> List[int]: ...
def _append_summary(dir: Union[str, os.PathLike[str]], row: Dict[str, Any]) -> None: ...
def _read_summary(dir: Union[str, os.PathLike[str]]) -> List[Dict[str, Any]]: ...
