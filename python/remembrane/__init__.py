"""remembrane: closed triangulated membranes moved by overdamped Langevin
dynamics under their free energy, with free-energy-controlled remeshing.

Units are the engine's natural units: energy Ē = 10 k_BT, length l̄ = 1 µm,
time 1 s.

    >>> import remembrane as rm
    >>> scene = rm.Scene.load("scenes/red_blood_cell.ron", iterations=1000)
    >>> sim = rm.Simulation(scene)
    >>> sim.step(100)
    >>> sim.positions.shape            # (N, 3) float64
    >>> sim.energies()                 # {"vin": ..., "bending": ..., ...}
    >>> summary = rm.Simulation(scene).run(out="runs/rbc")   # the CLI's run directory
    >>> run = rm.load_run("runs/rbc")                         # series, summary, frames

Force terms written in Python join the schedule like the built-in ones
(add them before the first step):

    >>> def gravity(x):
    ...     g = 0.01                           # Ē/l̄ per vertex
    ...     f = np.zeros_like(x); f[:, 2] = -g
    ...     return g * x[:, 2].sum(), f        # energy, −∇E
    >>> sim = rm.Simulation(scene)
    >>> sim.add_force_term("gravity", gravity)
    >>> rm.check_force(gravity, rm.perturbed_icosphere())["passed"]
    True
"""

from __future__ import annotations

import csv
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np

from . import _core
from ._core import (
    Scene,
    SceneError,
    Simulation,
    SimulationError,
    __version__,
    collect,
    sweep,
)

__all__ = [
    "Mesh",
    "Run",
    "Scene",
    "SceneError",
    "Simulation",
    "SimulationError",
    "SweepResult",
    "check_force",
    "collect",
    "disc",
    "from_meshio",
    "icosphere",
    "load_run",
    "perturbed_icosphere",
    "read_frame",
    "read_mesh",
    "spherical_cap",
    "sweep",
    "to_meshio",
    "write_mesh",
    "__version__",
]

ForceFunction = Callable[[np.ndarray], Tuple[float, np.ndarray]]


@dataclass
class Mesh:
    """A triangle mesh: `points` (N×3 float64, l̄), `faces` (F×3 int64,
    counter-clockwise seen from outside) and optional per-vertex arrays."""

    points: np.ndarray
    faces: np.ndarray
    point_data: Dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.points = np.ascontiguousarray(self.points, dtype=np.float64)
        self.faces = np.ascontiguousarray(self.faces, dtype=np.int64)
        if self.points.ndim != 2 or self.points.shape[1] != 3:
            raise ValueError(f"points must be N×3, got shape {self.points.shape}")
        if self.faces.ndim != 2 or self.faces.shape[1] != 3:
            raise ValueError(f"faces must be F×3 triangles, got shape {self.faces.shape}")

    @property
    def boundary_edges(self) -> np.ndarray:
        """The edges (E×2, as the faces traverse them) that lie in one face
        only: empty for a closed mesh."""
        e = np.concatenate([self.faces[:, [0, 1]], self.faces[:, [1, 2]], self.faces[:, [2, 0]]])
        key = np.sort(e, axis=1)
        _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        return e[counts[inverse.ravel()] == 1]

    def to_meshio(self):
        """This mesh as a `meshio.Mesh` (needs meshio)."""
        meshio = _require("meshio", "to_meshio")
        return meshio.Mesh(self.points, [("triangle", self.faces)], point_data=dict(self.point_data))


def _require(module: str, what: str):
    try:
        return __import__(module)
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(f"{what} needs the {module} package: pip install {module}") from e


def _as_mesh(obj: Any) -> Mesh:
    """A Mesh from a Mesh, a (points, faces) pair, a Simulation or a
    meshio.Mesh."""
    if isinstance(obj, Mesh):
        return obj
    if isinstance(obj, Simulation):
        return Mesh(obj.positions, obj.faces)
    if isinstance(obj, tuple) and len(obj) == 2:
        return Mesh(obj[0], obj[1])
    if hasattr(obj, "points") and hasattr(obj, "cells_dict"):
        return from_meshio(obj)
    raise TypeError(f"expected a Mesh, (points, faces), a Simulation or a meshio.Mesh, got {type(obj).__name__}")


def icosphere(level: int, edge_length: float = 1.0) -> Mesh:
    """An icosphere of `level` subdivisions (level 3: 642 vertices) with mean
    edge length `edge_length` (l̄)."""
    return Mesh(*_core.icosphere(level, edge_length))


def perturbed_icosphere(level: int = 2, seed: int = 1) -> Mesh:
    """The seeded, randomly perturbed icosphere the engine's own
    finite-difference tests use."""
    return Mesh(*_core.perturbed_icosphere(level, seed))


def disc(radius: float, edge_length: float = 1.0) -> Mesh:
    """A flat open disc in z = 0 of `radius` (l̄) with mean edge near
    `edge_length` (l̄), normal +z, one boundary loop (the scene's `Disc`)."""
    return Mesh(*_core.disc(radius, edge_length))


def spherical_cap(sphere_radius: float, opening_angle: float, edge_length: float = 1.0) -> Mesh:
    """The open cap of a sphere of `sphere_radius` (l̄) within `opening_angle`
    degrees (0, 90] of its +z pole, one boundary loop (the scene's
    `SphericalCap`)."""
    return Mesh(*_core.spherical_cap(sphere_radius, opening_angle, edge_length))


def read_mesh(path: Union[str, os.PathLike]) -> Mesh:
    """Reads a `.ply` or `.obj` mesh, closed or open (e.g. a run's
    `final.ply`)."""
    return Mesh(*_core.read_mesh(os.fspath(path)))


def write_mesh(path: Union[str, os.PathLike], mesh: Any) -> None:
    """Writes a mesh (a Mesh, a (points, faces) pair, a Simulation or a
    meshio.Mesh), closed or open, to a `.ply` or `.obj` file. It must pass
    the engine's invariant check (manifold, consistently oriented; a
    closed one outward), or `ValueError` says why and nothing is
    written."""
    m = _as_mesh(mesh)
    _core.write_mesh(os.fspath(path), m.points, m.faces)


def read_frame(path: Union[str, os.PathLike]) -> Mesh:
    """Reads a frame `frames/frame_NNNNNN.vtp` with its point data
    (`force`, `mean_curvature`, `density`, ...)."""
    points, faces, data = _core.read_vtp(os.fspath(path))
    return Mesh(points, faces, data)


def check_force(fn: ForceFunction, mesh: Any = None, **options: Any) -> Dict[str, Any]:
    """Checks a Python force term `fn(positions) -> (energy, forces)` against
    central finite differences of its energy at every vertex of `mesh`
    (default: `perturbed_icosphere()`).

    Options: `step` (1e-4 l̄), `rel_tol` (1e-6), `abs_floor` (1e-9 Ē/l̄),
    `stencil` ("central4" or "central2"), `vertices` (a list of indices).
    Returns a dict with `passed`, `max_rel_error`, `max_abs_error`,
    `max_force` and `failures`.
    """
    m = perturbed_icosphere() if mesh is None else _as_mesh(mesh)
    return _core.check_force(fn, m.points, m.faces, **options)


def to_meshio(obj: Any):
    """A `meshio.Mesh` of a Simulation's current state (with its per-vertex
    fields) or of a Mesh."""
    if isinstance(obj, Simulation):
        data = {name: obj.field(name) for name in obj.field_names}
        return Mesh(obj.positions, obj.faces, data).to_meshio()
    return _as_mesh(obj).to_meshio()


def from_meshio(m: Any) -> Mesh:
    """A Mesh from a `meshio.Mesh` of triangles (its point data kept); use it
    as a scene's membrane with `scene.with_mesh(mesh.points, mesh.faces)`."""
    triangles = [c.data for c in m.cells if c.type == "triangle"]
    others = sorted({c.type for c in m.cells if c.type != "triangle"})
    if others or not triangles:
        raise ValueError(f"a membrane is made of triangles only (the mesh has: {others or 'no cells'})")
    points = np.asarray(m.points, dtype=np.float64)
    if points.shape[1] == 2:
        raise ValueError("a membrane needs 3-D points")
    data = {k: np.asarray(v) for k, v in (m.point_data or {}).items()}
    return Mesh(points, np.concatenate(triangles), data)


def _read_series(path: Path):
    """series.csv as a pandas DataFrame if pandas is installed, otherwise a
    dict of column name -> float64 array."""
    try:
        import pandas as pd  # noqa: F401
    except ImportError:
        pd = None
    if pd is not None:
        return pd.read_csv(path)
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    columns: Dict[str, Any] = {}
    for k, name in enumerate(header):
        values = [r[k] for r in body]
        try:
            columns[name] = np.array([float(v) for v in values])
        except ValueError:
            columns[name] = values
    return columns


class Run:
    """A run directory written by `remembrane run` or `Simulation.run`.

    Attributes: `dir`, `summary` (summary.json as a dict), `series`
    (series.csv: a pandas DataFrame if pandas is installed, else a dict of
    arrays), `frame_files` (the frames' paths in order), `status`.
    """

    def __init__(self, path: Union[str, os.PathLike]):
        self.dir = Path(path)
        if not self.dir.is_dir():
            incomplete = Path(str(self.dir) + ".incomplete")
            hint = " (an interrupted run left it as .incomplete)" if incomplete.exists() else ""
            raise FileNotFoundError(f"{self.dir}: no run directory{hint}")
        summary = self.dir / "summary.json"
        if not summary.exists():
            raise FileNotFoundError(f"{summary}: not a finished run (no summary.json)")
        # The engine's typed reader: a renamed or missing field is a
        # ValueError naming the file and the field, not a KeyError later.
        _core.check_run_dir(str(self.dir))
        self.summary: Dict[str, Any] = json.loads(summary.read_text())
        series = self.dir / "series.csv"
        self.series = _read_series(series) if series.exists() else None
        self.frame_files: List[Path] = [self.dir / f["file"] for f in self.summary.get("frames", [])]

    @property
    def status(self) -> str:
        """`completed` or `blew_up`."""
        return self.summary["status"]

    def frame(self, k: int) -> Mesh:
        """Frame `k` (negative counts from the end) with its point data."""
        return read_frame(self.frame_files[k])

    def frames(self):
        """Every frame in order, as Meshes (read lazily)."""
        return (read_frame(p) for p in self.frame_files)

    def final_mesh(self) -> Mesh:
        """The final mesh (final.ply)."""
        return read_mesh(self.dir / "final.ply")

    def __repr__(self) -> str:
        return f"Run({str(self.dir)!r}, status={self.status!r}, frames={len(self.frame_files)})"


class SweepResult:
    """A sweep's output directory (`remembrane sweep` or `remembrane.sweep`).

    Attributes: `dir`, `index` (sweep.json), `runs` (a list of
    (spec, Run or None) pairs; None for runs that have not finished) and
    `table()` (one row per finished run: condition, axes, repeat, seed,
    status and the final energies, area, volume, reduced volume).
    """

    def __init__(self, path: Union[str, os.PathLike]):
        self.dir = Path(path)
        self.index: Dict[str, Any] = json.loads((self.dir / "sweep.json").read_text())
        self.runs: List[Tuple[Dict[str, Any], Optional[Run]]] = []
        for spec in self.index["runs"]:
            d = self.dir / spec["dir"]
            self.runs.append((spec, Run(d) if (d / "summary.json").exists() else None))

    def table(self):
        """The finished runs, one row each (a DataFrame if pandas is
        installed, else a list of dicts)."""
        rows = []
        for spec, run in self.runs:
            if run is None:
                continue
            row: Dict[str, Any] = {"condition": spec["condition"]}
            for (axis, label), value in zip(spec["point"], spec["point_values"]):
                row[axis] = value if value is not None else label
            row.update(repeat=spec["repeat"], seed=spec["seed"], status=run.status)
            s = run.summary
            for e in s.get("energies", []):
                row[f"energy_{e['term']}"] = e["energy"]
            for key in ("total_energy", "area", "volume", "reduced_volume", "simulated_time", "wall_time_s"):
                row[key] = s.get(key)
            rows.append(row)
        try:
            import pandas as pd
        except ImportError:
            return rows
        return pd.DataFrame(rows)

    def __repr__(self) -> str:
        done = sum(r is not None for _, r in self.runs)
        return f"SweepResult({str(self.dir)!r}, runs={done}/{len(self.runs)})"


def load_run(path: Union[str, os.PathLike]) -> Union[Run, SweepResult]:
    """Reads a run directory (a `Run`) or a sweep's output directory (a
    `SweepResult`, recognised by its sweep.json)."""
    p = Path(path)
    if (p / "sweep.json").exists():
        return SweepResult(p)
    return Run(p)
