"""Peer methods: the field's own implementations, run by softbench's studies beside its own.

Each peer method calls another package's code (pbatoolkit's VBD and XPBD, Newton's
semi-implicit, XPBD and VBD solvers) and is registered under ``<package>-<method>`` when
``softbench`` is imported, whether or not the package is installed: a scene naming a missing
one is refused with the ``pip install`` line. The adapters build the peer's problem from the
run's model (rest positions, tets, fixed vertices, density, the material's Lamé parameters in
the peer's own convention, gravity) and its ``[integrator.peer]`` settings, whose defaults are
the package's own. softbench refuses what a peer cannot run (another material, a consistent
mass, damping, drags, obstacles) when the scene is loaded.

Every step starts the peer from softbench's state (positions and velocities of every vertex)
and returns the peer's end-of-step state, so a step is a function of the state alone.
"""

from __future__ import annotations

from importlib import metadata
from typing import Callable, List, Optional, Sequence

from .. import _native


def setting(
    key: str,
    default,
    description: str,
    choices: Sequence[str] = (),
    positive: bool = False,
    twin_key: Optional[str] = None,
    twin_values: Optional[dict] = None,
    neutral=None,
) -> dict:
    """One of a peer's settings: its key under ``[integrator.peer]``, the package's default,
    what it does, the values it may take, and how it matches the twin's settings
    (``twin_key``, ``twin_values`` translating values; ``neutral``: the value that needs no
    match, such as one substep)."""
    return dict(
        key=key, default=default, description=description, choices=list(choices),
        positive=positive, twin_key=twin_key, twin_values=twin_values, neutral=neutral,
    )


def installed(package: str) -> Optional[str]:
    """The installed version of ``package``, or ``None``."""
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return None


def _register(
    name: str,
    make: Callable,
    package: str,
    pins: str,
    description: str,
    materials: List[str],
    settings: List[dict],
    twin: Optional[str],
    explicit: bool = False,
) -> None:
    _native.register_peer(
        name,
        make,
        package,
        installed(package),
        f"pip install {pins}",
        description,
        1,
        materials,
        settings,
        twin,
        explicit,
    )


def register_all() -> None:
    """Register every peer method (once per process)."""
    from . import newton_warp, pbat

    for spec in pbat.PEERS + newton_warp.PEERS:
        _register(**spec)


#: Every peer method's name.
NAMES = [
    "pbat-vbd",
    "pbat-xpbd",
    "newton-semi-implicit",
    "newton-xpbd",
    "newton-vbd",
]
