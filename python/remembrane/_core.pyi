"""Type stubs of the compiled module `remembrane._core`."""

from os import PathLike
from pathlib import Path
from typing import Any, Callable, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt
from typing_extensions import final

_Path = Union[str, PathLike[str]]
_Points = npt.NDArray[np.float64]
_Indices = npt.NDArray[np.int64]
_ForceFunction = Callable[[_Points], Tuple[float, _Points]]

__version__: str
__all__ = [
    "Scene",
    "SceneError",
    "Simulation",
    "SimulationError",
    "Species",
    "__version__",
    "check_force",
    "check_run_dir",
    "collect",
    "disc",
    "icosphere",
    "perturbed_icosphere",
    "read_mesh",
    "read_vtp",
    "spherical_cap",
    "sweep",
    "write_mesh",
]

class SceneError(ValueError):
    """A scene that cannot be loaded."""

    file: str
    line: Optional[int]
    col: Optional[int]
    field: Optional[str]
    reason: str

class SimulationError(RuntimeError):
    """A simulation that stopped (blow-up, failed output) or a call that does
    not fit its state."""

@final
class Scene:
    """A parsed, validated scene (see scenes/reference.ron)."""

    @staticmethod
    def load(
        path: _Path,
        *,
        seed: Optional[int] = None,
        iterations: Optional[int] = None,
        frames: Optional[int] = None,
        set: Optional[Dict[str, Any]] = None,
        **params: Any,
    ) -> Scene: ...
    @staticmethod
    def from_str(
        text: str,
        path: Optional[_Path] = None,
        *,
        seed: Optional[int] = None,
        iterations: Optional[int] = None,
        frames: Optional[int] = None,
        set: Optional[Dict[str, Any]] = None,
        **params: Any,
    ) -> Scene: ...
    def replace(
        self,
        *,
        seed: Optional[int] = None,
        iterations: Optional[int] = None,
        frames: Optional[int] = None,
        set: Optional[Dict[str, Any]] = None,
        **params: Any,
    ) -> Scene: ...
    def with_mesh(self, points: _Points, faces: _Indices) -> Scene: ...
    def to_ron(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def path(self) -> Path: ...
    @property
    def seed(self) -> int: ...
    @property
    def iterations(self) -> int: ...
    @property
    def frames(self) -> int: ...
    @property
    def energy_terms(self) -> List[str]: ...

@final
class Species:
    """The protein species' area fractions by name, at the current shape."""

    def keys(self) -> List[str]: ...
    def __len__(self) -> int: ...
    def __contains__(self, name: str, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def __getitem__(self, name: str, /) -> npt.NDArray[np.float64]: ...
    def __setitem__(self, name: str, values: npt.NDArray[np.float64], /) -> None: ...

@final
class Simulation:
    """A scene's simulation, stepped or run through the CLI's code."""

    def __new__(cls, scene: Scene, threads: Optional[int] = None, check_invariants: bool = False) -> Simulation: ...
    def add_force_term(self, name: str, fn: _ForceFunction) -> None: ...
    def step(self, n: int = 1) -> None: ...
    def run(self, out: _Path, progress: bool = True, overwrite: bool = False) -> Dict[str, Any]: ...
    def minimise(self, max_iterations: Optional[int] = None, **settings: Any) -> Dict[str, Any]: ...
    @property
    def time(self) -> float: ...
    @property
    def iteration(self) -> int: ...
    @property
    def scene(self) -> Scene: ...
    @property
    def threads(self) -> Optional[int]: ...
    @property
    def positions(self) -> _Points: ...
    @property
    def faces(self) -> _Indices: ...
    @property
    def boundary_loops(self) -> List[npt.NDArray[np.int64]]: ...
    @property
    def edges(self) -> _Indices: ...
    @property
    def species(self) -> Species: ...
    @property
    def field_names(self) -> List[str]: ...
    def field(self, name: str) -> npt.NDArray[np.float64]: ...
    def energies(self) -> Dict[str, float]: ...
    def forces(self, term: Optional[str] = None) -> _Points: ...
    def report(self) -> Dict[str, Any]: ...
    def mesh_quality(self) -> Dict[str, Any]: ...
    def remesh_stats(self) -> Optional[Dict[str, Any]]: ...
    def flip_stats(self) -> Optional[Dict[str, Any]]: ...

def check_force(
    fn: _ForceFunction,
    points: _Points,
    faces: _Indices,
    *,
    step: float = 1e-4,
    rel_tol: float = 1e-6,
    abs_floor: float = 1e-9,
    stencil: str = "central4",
    vertices: Optional[Sequence[int]] = None,
) -> Dict[str, Any]: ...
def icosphere(level: int, edge_length: float = 1.0) -> Tuple[_Points, _Indices]: ...
def perturbed_icosphere(level: int = 2, seed: int = 1) -> Tuple[_Points, _Indices]: ...
def read_mesh(path: _Path) -> Tuple[_Points, _Indices]: ...
def write_mesh(path: _Path, points: _Points, faces: _Indices) -> None: ...
def disc(radius: float, edge_length: float = 1.0) -> Tuple[_Points, _Indices]: ...
def spherical_cap(sphere_radius: float, opening_angle: float, edge_length: float = 1.0) -> Tuple[_Points, _Indices]: ...
def check_run_dir(dir: _Path) -> None: ...
def read_vtp(path: _Path) -> Tuple[_Points, _Indices, Dict[str, np.ndarray]]: ...
def sweep(
    path: _Path,
    out: _Path,
    *,
    jobs: int = 1,
    shard: Optional[Tuple[int, int]] = None,
    iterations: Optional[int] = None,
    quiet: bool = True,
    phases_only: bool = False,
) -> Dict[str, Any]: ...
def collect(
    dir: _Path,
    *,
    x: Optional[str] = None,
    y: Optional[str] = None,
    frames: Optional[int] = None,
    degree: Optional[int] = None,
) -> Dict[str, Any]: ...
