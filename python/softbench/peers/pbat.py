"""pbatoolkit's vertex block descent and XPBD (``pbat.sim.vbd``, ``pbat.sim.xpbd``).

Conventions matched: pbatoolkit takes column-major ``3 x n`` positions and ``4 x m`` tets, a
lumped mass from the density, and gravity as an external acceleration. Its "Stable Neo-Hookean"
is ψ = μ/2 (I_C − 3) + λ/2 (J − 1 − μ/λ)², without Smith et al.'s log term: softbench's
``xpbd-neo-hookean`` (Macklin and Müller's energy) with λ the Lamé λ + μ, which is what it is
given (measured: the two energies agree to pbatoolkit's quadrature weight, 1 + 2e-6). Its XPBD
projects the constraints of the same energy. Its VBD builds vertex-triangle contact from the boundary mesh it requires;
softbench runs peers without contact, so the collision penalty and friction are set to zero.
"""

from __future__ import annotations

import numpy as np

PACKAGE = "pbatoolkit"
PINS = "pbatoolkit==0.0.11"


def _pbat():
    from pbatoolkit import pbat

    return pbat


def _lame(problem):
    """pbatoolkit's (μ, λ) for softbench's xpbd-neo-hookean built from Lamé (μ, λ)."""
    mu, lam = problem["mu"], problem["lambda"]
    return mu, lam + mu


def _mesh(problem):
    X = np.asfortranarray(problem["rest_positions"].T, dtype=np.float64)
    E = np.asfortranarray(problem["tets"].T, dtype=np.int64)
    return X, E


def _gravity_field(problem, n):
    g = np.asarray(problem["gravity"], dtype=np.float64)
    return np.asfortranarray(np.tile(g[:, None], (1, n)))


class _Stepper:
    """Steps a pbatoolkit integrator from softbench's state: ``x``, ``v`` are ``(n, 3)``."""

    def __init__(self, integrator, iterations, substeps):
        self.integrator = integrator
        self.iterations = int(iterations)
        self.substeps = int(substeps)

    def step(self, x, v, dt):
        self.integrator.x = np.asfortranarray(x.T)
        self.integrator.v = np.asfortranarray(v.T)
        self.integrator.step(dt, self.iterations, self.substeps)
        counts = {"iterations": self.iterations * self.substeps, "substeps": self.substeps}
        return (
            np.ascontiguousarray(self.integrator.x.T),
            np.ascontiguousarray(self.integrator.v.T),
            counts,
        )


def make_vbd(problem):
    """pbatoolkit's VBD integrator for softbench's model ``problem``."""
    pbat = _pbat()
    s = problem["settings"]
    X, E = _mesh(problem)
    n, m = X.shape[1], E.shape[1]
    V, F = pbat.geometry.simplex_mesh_boundary(E, n)
    strategy = getattr(pbat.sim.vbd.InitializationStrategy, s["initialization"])
    data = (
        pbat.sim.vbd.Data()
        .with_volume_mesh(X, E)
        .with_surface_mesh(V, F)
        .with_material(
            np.full(m, problem["density"]),
            np.full(m, _lame(problem)[0]),
            np.full(m, _lame(problem)[1]),
        )
        .with_acceleration(_gravity_field(problem, n))
        .with_initialization_strategy(strategy)
        .with_contact_parameters(0.0, 0.0, 1e-3)
    )
    fixed = np.asarray(problem["fixed"], dtype=np.int64)
    if fixed.size:
        data = data.with_dirichlet_vertices(fixed, muD=s["dirichlet_penalty"])
    data = data.construct(validate=True)
    return _Stepper(pbat.sim.vbd.Integrator(data), s["iterations"], s["substeps"])


def make_xpbd(problem):
    """pbatoolkit's XPBD integrator (Macklin's Stable Neo-Hookean constraints)."""
    pbat = _pbat()
    from pbatoolkit import pypbat

    s = problem["settings"]
    X, E = _mesh(problem)
    n, m = X.shape[1], E.shape[1]
    V, F = pbat.geometry.simplex_mesh_boundary(E, n)
    minv = 1.0 / np.asarray(problem["vertex_masses"], dtype=np.float64)
    minv[np.asarray(problem["fixed"], dtype=np.int64)] = 0.0
    mu, lam = _lame(problem)
    lame = np.asfortranarray(np.vstack([np.full(m, mu), np.full(m, lam)]))
    ptr, adj, _ = pypbat.sim.xpbd.partition_mesh_constraints(X, E)
    data = (
        pbat.sim.xpbd.Data()
        .with_volume_mesh(X, E)
        .with_surface_mesh(V, F)
        .with_mass_inverse(minv)
        .with_elastic_material(lame)
        .with_acceleration(_gravity_field(problem, n))
        .with_partitions(ptr, adj)
    )
    # pbatoolkit's XPBD predicts every vertex, zero inverse mass or not: fixed vertices are its
    # Dirichlet vertices.
    fixed = np.asarray(problem["fixed"], dtype=np.int64)
    if fixed.size:
        data = data.with_dirichlet_vertices(fixed)
    data = data.construct(validate=True)
    return _Stepper(pbat.sim.xpbd.Integrator(data), s["iterations"], s["substeps"])


PEERS = [
    dict(
        name="pbat-vbd",
        make=make_vbd,
        package=PACKAGE,
        pins=PINS,
        description="pbatoolkit's own vertex block descent (pbat.sim.vbd), without contact",
        materials=["xpbd-neo-hookean"],
        settings=[
            ("iterations", 20, [], True, "VBD sweeps per substep (pbatoolkit's examples: 20)"),
            ("substeps", 1, [], True, "substeps per step (pbatoolkit's default: 1)"),
            (
                "initialization",
                "AdaptivePbat",
                ["Position", "Inertia", "KineticEnergyMinimum", "AdaptiveVbd", "AdaptivePbat"],
                False,
                "the first iterate (pbat.sim.vbd.InitializationStrategy; its default)",
            ),
            (
                "dirichlet_penalty",
                1.0,
                [],
                True,
                "muD of with_dirichlet_vertices (pbatoolkit's default 1.0)",
            ),
        ],
        twin="vbd",
    ),
    dict(
        name="pbat-xpbd",
        make=make_xpbd,
        package=PACKAGE,
        pins=PINS,
        description="pbatoolkit's own XPBD with Macklin's Stable Neo-Hookean constraints (pbat.sim.xpbd)",
        materials=["xpbd-neo-hookean"],
        settings=[
            ("iterations", 1, [], True, "constraint sweeps per substep (pbatoolkit's examples: 1)"),
            ("substeps", 50, [], True, "substeps per step (pbatoolkit's examples: 50)"),
        ],
        twin="xpbd",
    ),
]
