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

from . import setting

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


class _Energy:
    """pbatoolkit's own Stable Neo-Hookean energy (``pbat.fem.hyper_elastic_potential``) on
    the mesh, measured from the rest state (pbatoolkit's is not zero there)."""

    def __init__(self, problem):
        pbat = _pbat()
        self.fem = pbat.fem
        X, self.E = _mesh(problem)
        self.n = X.shape[1]
        element = pbat.fem.Element.Tetrahedron
        self.element = element
        self.wg = pbat.fem.mesh_quadrature_weights(self.E, X, element, order=1, quadrature_order=1)
        self.wg = self.wg.ravel(order="F")
        self.eg = pbat.fem.mesh_quadrature_elements(self.E.shape[1], 1).ravel(order="F")
        self.GNeg = pbat.fem.shape_function_gradients(
            self.E, X, element, order=1, dims=3, quadrature_order=1
        )
        mu, lam = _lame(problem)
        self.mug = np.full(self.wg.size, mu)
        self.lambdag = np.full(self.wg.size, lam)
        self.rest = self.energy(problem["rest_positions"], from_rest=False)

    def energy(self, x, from_rest=True):
        flags = int(self.fem.ElementElasticityComputationFlags.Potential)
        u = self.fem.hyper_elastic_potential(
            self.E, self.n, self.eg, self.wg, self.GNeg, self.mug, self.lambdag,
            np.ascontiguousarray(x, dtype=np.float64).ravel(),
            energy=self.fem.HyperElasticEnergy.StableNeoHookean, flags=flags,
            element=self.element,
        )[0]
        return u - self.rest if from_rest else u


class _Stepper:
    """Steps a pbatoolkit integrator from softbench's state: ``x``, ``v`` are ``(n, 3)``."""

    def __init__(self, integrator, iterations, substeps, problem, masses, hessians):
        self.integrator = integrator
        # Each sweep evaluates every element's gradient (VBD: and its Hessian); counted as
        # softbench's own local solvers count their sweeps.
        self.hessians = bool(hessians)
        self.iterations = int(iterations)
        self.substeps = int(substeps)
        self.problem = problem
        self.masses = masses
        self._energy = None

    def conventions(self, x):
        """pbatoolkit's own masses, fixed set and elastic energy at ``x`` (every vertex)."""
        if self._energy is None:
            self._energy = _Energy(self.problem)
        return {
            "masses": np.asarray(self.masses(self.integrator.data), dtype=np.float64),
            "fixed": [int(i) for i in np.asarray(self.integrator.data.dbc).ravel()],
            "elastic_energy": float(self._energy.energy(x)),
        }

    def step(self, x, v, dt):
        self.integrator.x = np.asfortranarray(x.T)
        self.integrator.v = np.asfortranarray(v.T)
        self.integrator.step(dt, self.iterations, self.substeps)
        sweeps = self.iterations * self.substeps
        counts = {
            "iterations": sweeps,
            "substeps": self.substeps,
            "gradient_passes": sweeps,
            "hessian_passes": sweeps if self.hessians else 0,
        }
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
    return _Stepper(
        pbat.sim.vbd.Integrator(data), s["iterations"], s["substeps"], problem, lambda d: d.m,
        hessians=True,
    )


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
    # Its masses are the inverses it was given (infinite where fixed, reported as 0); its
    # energy is pbat.fem's Stable Neo-Hookean, the energy its constraints are built from.
    def masses(d):
        minv = np.asarray(d.minv)
        return np.where(minv > 0, 1.0 / np.where(minv > 0, minv, 1.0), 0.0)

    return _Stepper(
        pbat.sim.xpbd.Integrator(data), s["iterations"], s["substeps"], problem, masses,
        hessians=False,
    )


INITIALIZATIONS = ["Position", "Inertia", "KineticEnergyMinimum", "AdaptiveVbd", "AdaptivePbat"]

PEERS = [
    dict(
        name="pbat-vbd",
        make=make_vbd,
        package=PACKAGE,
        pins=PINS,
        description="pbatoolkit's own vertex block descent (pbat.sim.vbd), without contact",
        materials=["xpbd-neo-hookean"],
        settings=[
            setting("iterations", 20, "VBD sweeps per substep (pbatoolkit's examples: 20)",
                    positive=True, twin_key="integrator.vbd.iterations"),
            setting("substeps", 1, "substeps per step (pbatoolkit's default: 1)",
                    positive=True, neutral=1),
            setting("initialization", "AdaptivePbat",
                    "the first iterate (pbat.sim.vbd.InitializationStrategy; its default)",
                    choices=INITIALIZATIONS, twin_key="integrator.vbd.initialization",
                    twin_values={"Position": "previous", "Inertia": "inertia",
                                 "AdaptiveVbd": "adaptive"}),
            setting("dirichlet_penalty", 1.0,
                    "muD of with_dirichlet_vertices (pbatoolkit's default 1.0)", positive=True,
                    neutral=1.0),
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
            setting("iterations", 1, "constraint sweeps per substep (pbatoolkit's examples: 1)",
                    positive=True, twin_key="integrator.xpbd.iterations"),
            setting("substeps", 50, "substeps per step (pbatoolkit's examples: 50)",
                    positive=True, twin_key="integrator.xpbd.substeps"),
        ],
        twin="xpbd",
    ),
]
