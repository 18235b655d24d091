"""softbench from Python: meshes as NumPy arrays, scenes and studies run by softbench's Rust
core with their results as pandas DataFrames, the FEM model's energy, gradient, Hessian and
mass (SciPy CSC) at any positions, and methods written in Python that studies run by name.

>>> import softbench
>>> run = softbench.simulate("experiments/scenes/soft_beam.toml", {"run.steps": 10})
>>> run.trajectory[["t", "total"]].tail(1)          # doctest: +SKIP

Coordinates: a model's ``q`` and ``v`` are the free DOFs, stacked ``[x0, y0, z0, x1, ...]``
over the vertices that are not fixed, in vertex order; ``full_positions(q)`` gives every
vertex as an ``(n, 3)`` array. SI units throughout.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import pandas as pd
import scipy.sparse

from . import _native
from ._native import BadInputError, SoftbenchError, __version__
from . import peers

# The field's own implementations, registered as methods (installed or not: a scene naming a
# missing package is refused with its `pip install` line).
peers.register_all()

__all__ = [
    "BadInputError",
    "Model",
    "Simulation",
    "SoftbenchError",
    "StepModel",
    "__version__",
    "load_mesh",
    "methods",
    "peers",
    "register_method",
    "run_study",
    "simulate",
]

PathLike = Union[str, "os.PathLike[str]"]
#: A scene: a TOML file's path, or the same content as a dict (``tomllib.load`` gives one).
SceneLike = Union[PathLike, Mapping[str, Any]]
#: Overrides: ``{"run.dt": 1e-3, "integrator.method": "rk4"}`` or ``["run.dt=1e-3", ...]``
#: (the command line's ``--set``).
Overrides = Union[Mapping[str, Any], Sequence[str], None]


def load_mesh(path: PathLike, data_dir: Optional[PathLike] = None) -> Tuple[np.ndarray, np.ndarray]:
    """Read a tet mesh of any format softbench reads (MEDIT, TetGen, Gmsh, VTK, ...).

    Returns ``(vertices, tets)``: float64 ``(n, 3)`` and int64 ``(m, 4)``, 0-based. ``path`` is
    looked up as given, then in ``data_dir`` (default: the ``SOFTBENCH_DATA`` folder).
    """
    return _native.load_mesh(os.fspath(path), _opt_path(data_dir))


@dataclass
class Simulation:
    """What :func:`simulate` returns.

    ``trajectory`` has the columns of ``trajectory.csv`` (one row every ``run.sample_every``
    steps); ``final_positions`` is every vertex at the end, ``(n, 3)``; ``summary`` is
    ``summary.json`` (outcome, steps completed, free and fixed DOFs, costs); with ``every``,
    ``times`` and ``positions`` (``(frames, n, 3)``) hold a frame every ``every`` steps plus
    the first and last. ``out`` is the folder written, or ``None`` when it was temporary.
    """

    trajectory: pd.DataFrame
    final_positions: np.ndarray
    summary: dict
    times: Optional[np.ndarray] = None
    positions: Optional[np.ndarray] = None
    out: Optional[Path] = None

    @property
    def outcome(self) -> str:
        """How the run ended: ``completed``, ``unstable``, ``solver-failed``, ...; the rest of
        ``summary["summary"]["outcome"]`` says at which step and why."""
        return self.summary["summary"]["outcome"]["status"]


def simulate(
    scene: SceneLike,
    overrides: Overrides = None,
    *,
    out: Optional[PathLike] = None,
    every: Optional[int] = None,
    base_dir: Optional[PathLike] = None,
    data_dir: Optional[PathLike] = None,
    threads: Optional[int] = None,
) -> Simulation:
    """Run one scene as ``softbench simulate`` does and return its results.

    ``scene`` is a TOML file or a dict of the same content (relative paths in a dict are found
    in ``base_dir``, default the current folder). With ``out`` the files are written there
    (and kept); otherwise into a temporary folder that is removed. A run that blows up is a
    result (see ``.outcome``); a bad scene raises :class:`BadInputError`. ``threads`` is the
    size of the run's own pool (default: ``RAYON_NUM_THREADS``, else one per core); the
    results are the same for any count.
    """
    if every is not None and every < 1:
        raise BadInputError("every must be at least 1")
    args = _scene_args(scene, overrides, base_dir)
    with tempfile.TemporaryDirectory(prefix="softbench-") as tmp:
        folder = Path(out) if out is not None else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        _, frames = _native.simulate(
            os.fspath(folder),
            data_dir=_opt_path(data_dir),
            every=every,
            threads=threads,
            **args,
        )
        trajectory = pd.read_csv(folder / "trajectory.csv")
        final = pd.read_csv(folder / "final_positions.csv")[["x", "y", "z"]].to_numpy()
        with open(folder / "summary.json", encoding="utf-8") as f:
            summary = json.load(f)
    times, positions = frames if frames is not None else (None, None)
    return Simulation(
        trajectory=trajectory,
        final_positions=final,
        summary=summary,
        times=times,
        positions=positions,
        out=Path(out) if out is not None else None,
    )


def run_study(
    path: PathLike,
    out: PathLike = "results",
    *,
    quick: bool = False,
    jobs: int = 1,
    only: Optional[str] = None,
    force: bool = False,
    data_dir: Optional[PathLike] = None,
    threads: Optional[int] = None,
) -> pd.DataFrame:
    """Run a study file as ``softbench run`` does (into ``out/<study name>/``: runs.csv,
    series/, plots, report.md, meta.json) and return its ``runs.csv``.

    Finished runs with the same configuration are reused unless ``force``. The DataFrame's
    ``attrs["dir"]`` is the study's folder. ``threads`` is the size of the study's own pool
    (``softbench run --threads``).
    """
    folder = _native.run_study(
        os.fspath(path),
        os.fspath(out),
        quick,
        jobs,
        only,
        force,
        _opt_path(data_dir),
        threads,
    )
    runs = pd.read_csv(Path(folder) / "runs.csv")
    runs.attrs["dir"] = Path(folder)
    return runs


def _csc(arrays: Tuple[np.ndarray, np.ndarray, np.ndarray, int]) -> scipy.sparse.csc_matrix:
    data, indices, indptr, n = arrays
    return scipy.sparse.csc_matrix((data, indices, indptr), shape=(n, n))


def _vec(x: Any) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64).reshape(-1)


class _Evaluations:
    """Energy and derivatives over the free DOFs; shared by :class:`Model` and
    :class:`StepModel`."""

    _inner: Any

    @property
    def num_dofs(self) -> int:
        """Free DOFs (3 per free vertex)."""
        return self._inner.num_dofs()

    @property
    def counts(self) -> dict:
        """Vertices, free and fixed vertices, free and fixed DOFs."""
        return self._inner.counts()

    @property
    def vertex_masses(self) -> np.ndarray:
        """Lumped mass of every vertex (kg), ``(n,)``."""
        return self._inner.vertex_masses()

    def full_positions(self, q: Any) -> np.ndarray:
        """Every vertex's position, ``(n, 3)``, with the free ones from ``q``."""
        return self._inner.full_positions(_vec(q))

    def energy(self, q: Any) -> float:
        """The potential at ``q`` (J): elastic, springs, gravity, vertex and contact
        potentials."""
        return self._inner.energy(_vec(q))

    def gradient(self, q: Any) -> np.ndarray:
        """The potential's gradient at ``q`` (N), ``(num_dofs,)``."""
        return self._inner.gradient(_vec(q))

    def hessian(self, q: Any, projected: bool = False) -> scipy.sparse.csc_matrix:
        """The potential's Hessian at ``q`` as SciPy CSC (both triangles stored); with
        ``projected`` every element matrix is projected to positive semi-definite first."""
        return _csc(self._inner.hessian(_vec(q), projected))

    def mass(self) -> scipy.sparse.csc_matrix:
        """The mass matrix over the free DOFs (lumped or consistent, as the scene says)."""
        return _csc(self._inner.mass())


class Model(_Evaluations):
    """A scene built once, for energies and derivatives at any positions.

    >>> m = softbench.Model("experiments/scenes/soft_beam.toml")     # doctest: +SKIP
    >>> q, v, t = m.initial_state()                                    # doctest: +SKIP
    >>> m.energy(q), m.gradient(q).shape, m.hessian(q).shape           # doctest: +SKIP
    """

    def __init__(
        self,
        scene: SceneLike,
        overrides: Overrides = None,
        *,
        base_dir: Optional[PathLike] = None,
        data_dir: Optional[PathLike] = None,
        threads: Optional[int] = None,
    ) -> None:
        args = _scene_args(scene, overrides, base_dir)
        self._inner = _native.Model(data_dir=_opt_path(data_dir), threads=threads, **args)

    @property
    def name(self) -> str:
        return self._inner.name

    def initial_state(self) -> Tuple[np.ndarray, np.ndarray, float]:
        """The scene's start: free coordinates ``q``, velocities ``v`` and time ``t``."""
        return self._inner.initial_state()

    @property
    def dt(self) -> float:
        """The scene's time step (``run.dt``)."""
        return self._inner.run_length()[0]

    @property
    def steps(self) -> int:
        """The scene's number of steps (``run.steps``)."""
        return self._inner.run_length()[1]

    @property
    def rest_q(self) -> np.ndarray:
        """The rest configuration's free coordinates."""
        return self._inner.rest_q()

    @property
    def fixed(self) -> np.ndarray:
        """Which vertices are fixed, ``(n,)`` bool."""
        return self._inner.fixed()

    @property
    def tets(self) -> np.ndarray:
        """The body's tets, ``(m, 4)`` int64."""
        return self._inner.tets()

    def energy_parts(self, q: Any) -> dict:
        """The potential at ``q`` by source: elastic, springs, gravity, vertex, contact, total."""
        return self._inner.energy_parts(_vec(q))

    @property
    def evaluations(self) -> dict:
        """How many potential, gradient and Hessian evaluations this model has done."""
        return self._inner.evaluations()

    def ipc_probe(self, positions: Any, displacement: Any = None, t: float = 0.0) -> dict:
        """softbench's incremental potential contact at every vertex's ``positions``
        ``(n, 3)``: ``barrier`` (κ = 1), its ``gradient`` ``(n, 3)``, ``contacts`` within d̂ and
        their ``min_distance``, and with a ``displacement`` ``(n, 3)`` its collision-free
        fraction ``step``. For comparisons with ipc-toolkit; the scene must use
        ``contact.response = "ipc"``."""
        x = np.ascontiguousarray(positions, dtype=np.float64)
        dx = None if displacement is None else np.ascontiguousarray(displacement, dtype=np.float64)
        return self._inner.ipc_probe(x, dx, t)

    def ipc_collision_mesh(self) -> dict:
        """The collision mesh softbench's IPC computes on: ``num_body``,
        ``obstacle_positions`` (vertices ``num_body + i``), the collision ``vertices``,
        ``edges`` and ``faces`` over both, ``dhat`` and ``self_contact``."""
        return self._inner.ipc_collision_mesh()


class StepModel(_Evaluations):
    """The run's model as a Python method's ``step`` sees it; valid only during that call.

    Besides :class:`Model`'s evaluations it has ``t`` (the step's start time) and
    :meth:`acceleration`.
    """

    def __init__(self, inner: Any) -> None:
        self._inner = inner

    @property
    def t(self) -> float:
        return self._inner.t

    def acceleration(self, q: Any, v: Any, t: Optional[float] = None) -> np.ndarray:
        """``a = M⁻¹(−∇V(q) − D v)`` at time ``t`` (default the step's start), with the
        scene's damping and mass; what an explicit method needs."""
        return self._inner.acceleration(_vec(q), _vec(v), t)


#: A Python method's step: ``step(model, q, v, t, dt) -> (q_new, v_new)``.
StepFunction = Callable[[StepModel, np.ndarray, np.ndarray, float, float], Tuple[Any, Any]]


def register_method(
    name: str,
    step: StepFunction,
    *,
    order: int,
    description: str = "a method written in Python",
    explicit: bool = True,
) -> None:
    """Register a method written in Python under ``name``; scene and study files then name it
    like a built-in method (``integrator.method = "<name>"``).

    ``step(model, q, v, t, dt)`` gets the state at the step's start (fresh float64 arrays it
    may keep or change) and returns the state at its end ``(q, v)``. An exception it raises
    ends the run as ``solver-failed`` with its message. ``order`` is the method's formal order
    (a convergence study checks it). One Python call per step: slow, but measured like any
    method. Names are lowercase letters, digits and ``-``; registering is for the life of the
    process.
    """

    def call(inner: Any, q: np.ndarray, v: np.ndarray, t: float, dt: float) -> Tuple[np.ndarray, np.ndarray]:
        result = step(StepModel(inner), q, v, t, dt)
        if not isinstance(result, tuple) or len(result) != 2:
            raise TypeError(f"step must return a tuple (q, v), not {type(result).__name__}")
        return _vec(result[0]), _vec(result[1])

    _native.register_method(name, call, order, description, explicit)


def methods() -> pd.DataFrame:
    """Every method softbench knows (built-in, then registered, the peer methods among them):
    name, order, explicit, description."""
    rows = _native.methods()
    return pd.DataFrame(rows, columns=["name", "order", "explicit", "description"])


def _opt_path(p: Optional[PathLike]) -> Optional[str]:
    return None if p is None else os.fspath(p)


def _scene_args(scene: SceneLike, overrides: Overrides, base_dir: Optional[PathLike]) -> dict:
    args: dict = {"base_dir": _opt_path(base_dir)}
    if isinstance(scene, Mapping):
        args["table_json"] = json.dumps(scene)
    elif isinstance(scene, (str, os.PathLike)):
        args["path"] = os.fspath(scene)
    else:
        raise TypeError(f"scene must be a path or a dict, not {type(scene).__name__}")
    if overrides is None:
        pass
    elif isinstance(overrides, Mapping):
        args["set_json"] = json.dumps(dict(overrides))
    elif isinstance(overrides, Sequence) and not isinstance(overrides, str):
        args["set"] = [str(o) for o in overrides]
    else:
        raise TypeError("overrides must be a dict of dotted keys or a list of 'key=value' strings")
    return args
