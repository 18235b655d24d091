"""Newton's (on NVIDIA Warp) semi-implicit Euler, XPBD and VBD solvers on tet meshes.

Conventions matched, solver by solver (each has its own tet energy):

- ``SolverSemiImplicit``: Smith et al.'s Stable Neo-Hookean with its log term, in the paper's
  parameters (α = 1 + 3μ/(4λ)); softbench's ``stable-neo-hookean`` reparameterizes the Lamé
  parameters the same way (μ' = 4μ/3, λ' = λ + 5μ/6), so Newton is given μ', λ'.
- ``SolverVBD``: ψ = μ/2 (I_C − 3) + λ'/2 (J − 1 − μ/λ')² with λ' = λ + μ from the Lamé
  parameters it is given: softbench's ``xpbd-neo-hookean``.
- ``SolverXPBD``: two constraints, I_C − 3 (compliance 1/(μV)) and J − 1 (1/(λV)): an energy
  of Newton's own (quartic in the stretch, rest volume ratio 1) that no softbench material
  has. It accepts ``xpbd-neo-hookean`` scenes, given their Lamé parameters, and says so in its
  description: a trajectory beside softbench's ``xpbd`` differs by the energy as well as by
  the method.
 Masses are lumped from the density by ``add_soft_mesh``; a fixed vertex has zero mass.
Newton runs in float32 (Warp's ``vec3``), so its states round to ~1e-7 relative. Its
particle-particle contact and triangle contact are switched off: softbench runs peers without
contact. The device is a setting (``"cpu"`` here; ``"cuda"`` where a GPU is present).
"""

from __future__ import annotations

import numpy as np

from . import setting

PACKAGE = "newton"
PINS = "newton==1.8.0 warp-lang==1.19.0"


def _stable_neo_hookean(problem):
    mu, lam = problem["mu"], problem["lambda"]
    return 4.0 / 3.0 * mu, lam + 5.0 / 6.0 * mu


def _lame(problem):
    return problem["mu"], problem["lambda"]


def _newton():
    """Newton, with Warp's start-up and module-load messages off (set before Warp starts)."""
    import warp as wp

    wp.config.quiet = True
    import newton

    return newton, wp


def _build(problem, parameters, colour=False):
    newton, wp = _newton()
    s = problem["settings"]
    k_mu, k_lambda = parameters(problem)
    gravity = tuple(float(g) for g in problem["gravity"])
    builder = newton.ModelBuilder(up_axis=newton.Axis.Y, gravity=gravity)
    builder.add_soft_mesh(
        pos=wp.vec3(0.0, 0.0, 0.0),
        rot=wp.quat_identity(),
        scale=1.0,
        vel=wp.vec3(0.0, 0.0, 0.0),
        vertices=[wp.vec3(*p) for p in problem["rest_positions"]],
        indices=[int(i) for i in np.asarray(problem["tets"]).reshape(-1)],
        density=float(problem["density"]),
        k_mu=float(k_mu),
        k_lambda=float(k_lambda),
        k_damp=0.0,
    )
    for v in np.asarray(problem["fixed"], dtype=np.int64):
        builder.particle_mass[int(v)] = 0.0
    if colour:
        builder.color()
    model = builder.finalize(device=s["device"])
    model.particle_grid = None
    model.particle_max_radius = 0.0
    return model


class _Stepper:
    """Steps a Newton solver from softbench's state (``(n, 3)`` float64, rounded to float32)."""

    def __init__(self, model, solver, substeps, iterations=None, forces=None, note=None,
                 hessians=False):
        # Element passes per step, counted as softbench's own methods count theirs: a force
        # evaluation per substep (semi-implicit), a constraint sweep per iteration (XPBD), a
        # gradient-and-Hessian sweep per iteration (VBD).
        self.hessians = hessians
        self.forces = forces
        self.note = note
        self.model = model
        self.solver = solver
        self.substeps = int(substeps)
        self.iterations = iterations
        self.state_0 = model.state()
        self.state_1 = model.state()
        self.control = model.control()

    def conventions(self, x):
        """Newton's own masses and fixed set (zero mass) and, for the semi-implicit solver,
        the elastic forces of its tet kernel at ``x``."""
        masses = self.model.particle_mass.numpy().astype(np.float64)
        found = {"masses": masses, "fixed": [int(i) for i in np.nonzero(masses == 0.0)[0]]}
        if self.forces is None:
            found["note"] = self.note
            return found
        state = self.model.state()
        state.particle_q.assign(np.asarray(x, dtype=np.float32))
        state.particle_qd.zero_()
        state.particle_f.zero_()
        self.forces(self.model, state, self.control, state.particle_f)
        found["elastic_forces"] = state.particle_f.numpy().astype(np.float64).ravel()
        return found

    def step(self, x, v, dt):
        self.state_0.particle_q.assign(np.asarray(x, dtype=np.float32))
        self.state_0.particle_qd.assign(np.asarray(v, dtype=np.float32))
        h = dt / self.substeps
        for _ in range(self.substeps):
            self.state_0.clear_forces()
            self.solver.step(self.state_0, self.state_1, self.control, None, h)
            self.state_0, self.state_1 = self.state_1, self.state_0
        counts = {"substeps": self.substeps, "gradient_passes": self.substeps}
        if self.iterations is not None:
            sweeps = self.iterations * self.substeps
            counts["iterations"] = sweeps
            counts["gradient_passes"] = sweeps
            counts["hessian_passes"] = sweeps if self.hessians else 0
        return (
            self.state_0.particle_q.numpy().astype(np.float64),
            self.state_0.particle_qd.numpy().astype(np.float64),
            counts,
        )


def make_semi_implicit(problem):
    """Newton's ``SolverSemiImplicit`` (symplectic Euler on Newton's forces)."""
    newton, _ = _newton()
    model = _build(problem, _stable_neo_hookean)
    from newton._src.solvers.semi_implicit.kernels_particle import eval_tetrahedra_forces

    solver = newton.solvers.SolverSemiImplicit(model, enable_tri_contact=False)
    return _Stepper(model, solver, problem["settings"]["substeps"], forces=eval_tetrahedra_forces)


def make_xpbd(problem):
    """Newton's ``SolverXPBD`` with its tet constraints."""
    newton, _ = _newton()
    s = problem["settings"]
    model = _build(problem, _lame)
    solver = newton.solvers.SolverXPBD(
        model, iterations=s["iterations"], soft_body_relaxation=s["soft_body_relaxation"]
    )
    note = "SolverXPBD exposes no energy or force evaluation of its constraints"
    return _Stepper(model, solver, s["substeps"], s["iterations"], note=note)


def make_vbd(problem):
    """Newton's ``SolverVBD`` (its tet energy: Stable Neo-Hookean)."""
    newton, _ = _newton()
    s = problem["settings"]
    model = _build(problem, _lame, colour=True)
    solver = newton.solvers.SolverVBD(model, iterations=s["iterations"])
    note = "SolverVBD evaluates its energy per vertex inside its kernels only"
    return _Stepper(model, solver, s["substeps"], s["iterations"], note=note, hessians=True)


_DEVICE = setting("device", "cpu", "Warp device the kernels run on", choices=["cpu", "cuda"],
                  neutral="cpu")
_SUBSTEPS = setting("substeps", 1, "Newton steps per softbench step (Newton has no default)",
                    positive=True, neutral=1)

PEERS = [
    dict(
        name="newton-semi-implicit",
        make=make_semi_implicit,
        package=PACKAGE,
        pins=PINS,
        description="Newton's own semi-implicit Euler (SolverSemiImplicit), float32, without contact",
        materials=["stable-neo-hookean"],
        settings=[_SUBSTEPS, _DEVICE],
        twin="symplectic-euler",
        explicit=True,
    ),
    dict(
        name="newton-xpbd",
        make=make_xpbd,
        package=PACKAGE,
        pins=PINS,
        description="Newton's own XPBD (SolverXPBD), float32, without contact; its constraints "
        "minimize an energy of Newton's own, not xpbd-neo-hookean's",
        materials=["xpbd-neo-hookean"],
        settings=[
            setting("iterations", 2, "constraint sweeps per substep (SolverXPBD's default: 2)",
                    positive=True, twin_key="integrator.xpbd.iterations"),
            setting("substeps", 20, "XPBD substeps per step (softbench's xpbd default: 20)",
                    positive=True, twin_key="integrator.xpbd.substeps"),
            setting("soft_body_relaxation", 0.9,
                    "relaxation of the tet constraints' deltas (SolverXPBD's default: 0.9)",
                    positive=True, neutral=1.0),
            _DEVICE,
        ],
        twin="xpbd",
    ),
    dict(
        name="newton-vbd",
        make=make_vbd,
        package=PACKAGE,
        pins=PINS,
        description="Newton's own vertex block descent (SolverVBD), float32, without contact",
        materials=["xpbd-neo-hookean"],
        settings=[
            setting("iterations", 10, "VBD sweeps per substep (SolverVBD's default: 10)",
                    positive=True, twin_key="integrator.vbd.iterations"),
            _SUBSTEPS,
            _DEVICE,
        ],
        twin="vbd",
    ),
]
