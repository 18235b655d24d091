"""Peer methods: each runs from a study file and from Python, its first steps equal a direct call
of the peer's own API written here (not through softbench's adapter), and everything a peer
cannot run is refused when the scene is loaded.

Without the packages these tests print a ``skipped:`` line; under CI (``CI`` set) a missing
package fails them.
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest

import softbench

# A hanging box small enough for seconds (16 tets... 48 tets, 45 vertices), clamped at x = 0.
BOX = {
    "mesh": {"generate": {"box": [4, 2, 2], "size": [1.0, 0.5, 0.5]}},
    "material": {
        "model": "stable-neo-hookean",
        "youngs_modulus": 1e5,
        "poisson_ratio": 0.4,
        "density": 1000.0,
        "mass": "lumped",
    },
    "fixed": {"rule": {"axis": "x", "side": "min", "tolerance": 1e-6}},
    "forces": {"gravity": [0.0, -9.81, 0.0]},
    "integrator": {"method": "backward-euler"},
    "run": {"dt": 0.01, "steps": 2},
}
E, NU, RHO = 1e5, 0.4, 1000.0
MU = E / (2 * (1 + NU))
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))


def need(module: str):
    """Import a peer package, or skip (fail under CI) when it is missing."""
    try:
        return __import__(module)
    except ImportError:
        if os.environ.get("CI"):
            pytest.fail(f"{module} is not installed (CI installs the peers: pip install .[peers])")
        print(f"skipped: {module} is not installed (pip install .[peers])")
        pytest.skip(f"{module} is not installed")


def scene(method: str, material: str = "stable-neo-hookean", **peer) -> dict:
    s = {k: dict(v) if isinstance(v, dict) else v for k, v in BOX.items()}
    s["material"] = {**BOX["material"], "model": material}
    s["integrator"] = {"method": method, **({"peer": peer} if peer else {})}
    return s


def rest():
    model = softbench.Model(scene("backward-euler"))
    x = model.full_positions(model.rest_q)
    fixed = np.asarray(model.fixed)
    fixed = np.nonzero(fixed)[0] if fixed.dtype == bool else fixed
    return model, x, np.asarray(model.tets, dtype=np.int64), fixed.astype(np.int64)


def run_softbench(method, steps, material="stable-neo-hookean", **peer):
    out = softbench.simulate(scene(method, material, **peer), {"run.steps": steps})
    assert out.outcome == "completed", out.summary
    return out.final_positions


def test_every_peer_is_registered_with_its_package_and_twin():
    listed = softbench.methods().set_index("name")
    for name in softbench.peers.NAMES:
        assert name in listed.index
    assert bool(listed.loc["newton-semi-implicit", "explicit"])
    assert not bool(listed.loc["pbat-vbd", "explicit"])


def test_pbat_vbd_steps_equal_pbatoolkits_own_integrator():
    need("pbatoolkit")
    from pbatoolkit import pbat

    _, x0, tets, fixed = rest()
    X = np.asfortranarray(x0.T)
    T = np.asfortranarray(tets.T)
    n, m = X.shape[1], T.shape[1]
    V, F = pbat.geometry.simplex_mesh_boundary(T, n)
    g = np.asfortranarray(np.tile(np.array([[0.0], [-9.81], [0.0]]), (1, n)))
    data = (
        pbat.sim.vbd.Data()
        .with_volume_mesh(X, T)
        .with_surface_mesh(V, F)
        .with_material(np.full(m, RHO), np.full(m, MU), np.full(m, LAM + MU))
        .with_acceleration(g)
        .with_initialization_strategy(pbat.sim.vbd.InitializationStrategy.KineticEnergyMinimum)
        .with_contact_parameters(0.0, 0.0, 1e-3)
        .with_dirichlet_vertices(fixed)
        .construct(validate=True)
    )
    vbd = pbat.sim.vbd.Integrator(data)
    for _ in range(2):
        vbd.step(0.01, 7, 1)
    ours = run_softbench(
        "pbat-vbd", 2, "xpbd-neo-hookean", iterations=7, initialization="KineticEnergyMinimum"
    )
    np.testing.assert_allclose(ours, np.asarray(vbd.x).T, rtol=0, atol=1e-12)


def test_pbat_xpbd_steps_equal_pbatoolkits_own_integrator():
    need("pbatoolkit")
    from pbatoolkit import pbat, pypbat

    model, x0, tets, fixed = rest()
    X = np.asfortranarray(x0.T)
    T = np.asfortranarray(tets.T)
    n, m = X.shape[1], T.shape[1]
    V, F = pbat.geometry.simplex_mesh_boundary(T, n)
    minv = 1.0 / np.asarray(model.vertex_masses)
    minv[fixed] = 0.0
    ptr, adj, _ = pypbat.sim.xpbd.partition_mesh_constraints(X, T)
    g = np.asfortranarray(np.tile(np.array([[0.0], [-9.81], [0.0]]), (1, n)))
    data = (
        pbat.sim.xpbd.Data()
        .with_volume_mesh(X, T)
        .with_surface_mesh(V, F)
        .with_mass_inverse(minv)
        .with_elastic_material(
            np.asfortranarray(np.vstack([np.full(m, MU), np.full(m, LAM + MU)]))
        )
        .with_acceleration(g)
        .with_partitions(ptr, adj)
        .with_dirichlet_vertices(fixed)
        .construct(validate=True)
    )
    xpbd = pbat.sim.xpbd.Integrator(data)
    for _ in range(2):
        xpbd.step(0.01, 1, 10)
    ours = run_softbench("pbat-xpbd", 2, "xpbd-neo-hookean", substeps=10)
    np.testing.assert_allclose(ours, np.asarray(xpbd.x).T, rtol=0, atol=1e-12)


def newton_direct(solver_of, k_mu, k_lambda, steps, substeps, colour=False):
    """Newton's own API on the box: ``steps`` steps of ``substeps`` substeps at dt = 0.01."""
    need("newton")
    import newton
    import warp as wp

    _, x0, tets, fixed = rest()
    builder = newton.ModelBuilder(up_axis=newton.Axis.Y, gravity=(0.0, -9.81, 0.0))
    builder.add_soft_mesh(
        pos=wp.vec3(0.0, 0.0, 0.0), rot=wp.quat_identity(), scale=1.0, vel=wp.vec3(0.0, 0.0, 0.0),
        vertices=[wp.vec3(*p) for p in x0], indices=tets.reshape(-1).tolist(), density=RHO,
        k_mu=k_mu, k_lambda=k_lambda, k_damp=0.0,
    )
    for v in fixed:
        builder.particle_mass[int(v)] = 0.0
    if colour:
        builder.color()
    model = builder.finalize(device="cpu")
    model.particle_grid = None
    model.particle_max_radius = 0.0
    solver = solver_of(model)
    s0, s1, control = model.state(), model.state(), model.control()
    for _ in range(steps * substeps):
        s0.clear_forces()
        solver.step(s0, s1, control, None, 0.01 / substeps)
        s0, s1 = s1, s0
    return s0.particle_q.numpy().astype(np.float64)


# Newton's Stable Neo-Hookean takes the paper's parameters: mu' = 4/3 mu, lambda' = lambda + 5/6 mu.
SNH = (4.0 / 3.0 * MU, LAM + 5.0 / 6.0 * MU)


def test_newton_semi_implicit_steps_equal_newtons_own_solver():
    need("newton")
    import newton

    direct = newton_direct(
        lambda m: newton.solvers.SolverSemiImplicit(m, enable_tri_contact=False), *SNH, 2, 20
    )
    ours = run_softbench("newton-semi-implicit", 2, substeps=20)
    # softbench hands Newton the state as float64 and reads it back: float32 round-off of the
    # positions (|x| <= 1) between steps is the only difference.
    np.testing.assert_allclose(ours, direct, rtol=0, atol=1e-6)


def test_newton_xpbd_steps_equal_newtons_own_solver():
    need("newton")
    import newton

    direct = newton_direct(
        lambda m: newton.solvers.SolverXPBD(m, iterations=2, soft_body_relaxation=0.9),
        MU, LAM, 2, 20,
    )
    ours = run_softbench("newton-xpbd", 2, "xpbd-neo-hookean")
    np.testing.assert_allclose(ours, direct, rtol=0, atol=1e-6)


def test_newton_vbd_steps_equal_newtons_own_solver():
    need("newton")
    import newton

    direct = newton_direct(
        lambda m: newton.solvers.SolverVBD(m, iterations=10), MU, LAM, 2, 1, colour=True
    )
    ours = run_softbench("newton-vbd", 2, "xpbd-neo-hookean")
    np.testing.assert_allclose(ours, direct, rtol=0, atol=1e-6)


def test_a_study_runs_peers_beside_their_twins(tmp_path):
    need("pbatoolkit")
    study = tmp_path / "twins.toml"
    scene_file = tmp_path / "box.toml"
    import tomllib  # noqa: F401  (the scene is written as TOML below)

    scene_file.write_text(
        "[mesh]\ngenerate = { box = [4, 2, 2], size = [1.0, 0.5, 0.5] }\n"
        '[material]\nmodel = "xpbd-neo-hookean"\nyoungs_modulus = 1e5\npoisson_ratio = 0.4\n'
        'density = 1000.0\nmass = "lumped"\n'
        '[fixed]\nrule = { axis = "x", side = "min", tolerance = 1e-6 }\n'
        "[forces]\ngravity = [0.0, -9.81, 0.0]\n[run]\ndt = 0.01\nsteps = 5\n"
    )
    study.write_text(
        f'name = "twins"\nstudy = "trajectory"\nscenes = ["{scene_file.as_posix()}"]\n'
        '[grid]\n"integrator.method" = ["vbd", "pbat-vbd"]\n'
    )
    runs = softbench.run_study(study, tmp_path / "results")
    assert set(runs["outcome"]) == {"completed"}
    assert set(runs["method"]) == {"vbd", "pbat-vbd"}
    import json

    meta = json.loads((tmp_path / "results/twins/meta.json").read_text())
    assert meta["peers"]["pbat-vbd"]["package"] == "pbatoolkit"
    assert meta["peers"]["pbat-vbd"]["twin"] == "vbd"
    assert meta["peers"]["pbat-vbd"]["version"] == "0.0.11"
    integrators = meta["config"]["integrators"].values()
    recorded = [i["peer"] for i in integrators if i.get("method") == "pbat-vbd"]
    assert recorded == [
        {"dirichlet_penalty": 1.0, "initialization": "AdaptivePbat", "iterations": 20, "substeps": 1}
    ]
    # The same study from the command line (python -m softbench), resumed: nothing reruns.
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-m", "softbench", "run", study, "--out", tmp_path / "results"],
        capture_output=True, text=True,
    )
    assert done.returncode == 0, done.stderr
    assert pd.read_csv(tmp_path / "results/twins/runs.csv").shape[0] == 2


@pytest.mark.parametrize(
    "change, key",
    [
        ({"material": {**BOX["material"], "model": "stvk"}}, "material.model"),
        (
            {"material": {**BOX["material"], "model": "xpbd-neo-hookean", "mass": "consistent"}},
            "material.mass",
        ),
        ({"damping": {"rayleigh": {"alpha": 0.1, "beta": 0.0}}}, "damping.rayleigh"),
        ({"obstacles": [{"kind": "plane", "point": [0, -1, 0], "normal": [0, 1, 0]}]}, "obstacles[0]"),
        ({"integrator": {"method": "pbat-vbd", "peer": {"iteratons": 3}}}, "integrator.peer.iteratons"),
        ({"integrator": {"method": "pbat-vbd", "peer": {"initialization": "Best"}}}, "integrator.peer.initialization"),
        ({"integrator": {"method": "pbat-vbd", "peer": {"iterations": 0}}}, "integrator.peer.iterations"),
        ({"integrator": {"method": "vbd", "peer": {"iterations": 3}}}, "integrator.peer.iterations"),
    ],
)
def test_what_a_peer_cannot_run_is_refused_naming_key_and_package(change, key):
    s = {**scene("pbat-vbd", "xpbd-neo-hookean"), **change}
    with pytest.raises(softbench.BadInputError) as refused:
        softbench.simulate(s)
    message = str(refused.value)
    assert key in message, message
    if s["integrator"]["method"] == "pbat-vbd" and "peer" not in s["integrator"]:
        assert "pbatoolkit" in message, message


def test_a_peer_whose_package_is_missing_is_refused_with_its_install_line():
    name = "absent-peer"
    if name not in set(softbench.methods()["name"]):
        softbench._native.register_peer(
            name, lambda problem: None, "absentpkg", None, "pip install absentpkg==1.0",
            "a peer whose package is not installed", 1, ["stable-neo-hookean"], [], None,
        )
    with pytest.raises(softbench.BadInputError, match="pip install absentpkg==1.0"):
        softbench.simulate(scene(name))


def test_the_shipped_twins_study_checks_conventions_and_compares_every_pair(root, tmp_path):
    need("pbatoolkit")
    need("newton")
    if not os.environ.get("SOFTBENCH_DATA"):
        if os.environ.get("CI"):
            pytest.fail("SOFTBENCH_DATA is not set (the twins study loads the course armadillo)")
        print("skipped: the twins study loads the course armadillo: set SOFTBENCH_DATA")
        pytest.skip("SOFTBENCH_DATA is not set")
    runs = softbench.run_study(
        root / "experiments" / "twins.toml", tmp_path, quick=True, only="twins_box*"
    )
    assert set(runs["outcome"]) == {"completed"}, runs[["run_id", "message"]]
    pairs = dict(zip(runs["method"], runs["partner"]))
    assert pairs == {
        "pbat-vbd": "vbd",
        "pbat-xpbd": "xpbd",
        "newton-vbd": "vbd",
        "newton-xpbd": "xpbd",
        "newton-semi-implicit": "symplectic-euler",
    }
    assert runs["check_fixed_equal"].astype(str).str.lower().eq("true").all()
    pbat = runs[runs["method"].str.startswith("pbat")]
    # pbatoolkit's energy is softbench's xpbd-neo-hookean up to its quadrature weight.
    assert np.allclose(pbat["check_energy_ratio"].astype(float), 1.0, atol=1e-5)
    semi = runs[runs["method"] == "newton-semi-implicit"]
    assert float(semi["check_force_difference"].iloc[0]) < 1e-4
    assert (runs["check_mass_difference"].astype(float) < 1e-5).all()
    # Converged VBD twins are the same step: ten-fold iterations bring them together.
    vbd = runs[runs["method"] == "pbat-vbd"].set_index("integrator.peer.iterations")
    assert float(vbd.loc[200, "difference_first_step"]) < 1e-2 * float(
        vbd.loc[20, "difference_first_step"]
    )
    steps = pd.read_csv(tmp_path / "twins" / "series" / f"{runs['run_id'].iloc[0]}-steps.csv")
    assert list(steps.columns)[:3] == ["step", "t", "difference"] and len(steps) == 5
    assert (tmp_path / "twins" / "difference-twins_box.png").stat().st_size > 5_000


def test_the_shipped_suite_runs_the_peers_as_rows_counted_like_their_twins(root, tmp_path):
    need("pbatoolkit")
    need("newton")
    runs = softbench.run_study(
        root / "experiments" / "suite.toml", tmp_path, quick=True,
        only="vibration-soft-xpbd-neo-hookean*",
    )
    methods = set(runs["method"])
    assert {"pbat-vbd", "pbat-xpbd", "newton-vbd", "newton-xpbd"} <= methods, methods
    peers = runs[runs["method"].isin(["pbat-vbd", "pbat-xpbd", "newton-vbd", "newton-xpbd"])]
    assert set(peers["outcome"]) == {"completed"}, peers[["run_id", "message"]]
    # Each peer block sweeps its cut-off, one value per level.
    assert set(peers["level"]) == {"loose", "tight"}
    assert set(peers["cutoff"].str.split("=").str[0]) == {
        "integrator.peer.iterations", "integrator.peer.substeps"
    }
    # A peer's sweeps are counted as softbench's: VBD at 10 iterations makes the same element
    # evaluations in both packages and in softbench's own.
    row = runs.set_index("run_id")["evaluations"].astype(float)
    own = row["vibration-soft-xpbd-neo-hookean-nu0.3-vbd-iterations=10"]
    assert own > 0
    assert row["vibration-soft-xpbd-neo-hookean-nu0.3-pbat-vbd-iterations=10"] == own
    assert row["vibration-soft-xpbd-neo-hookean-nu0.3-newton-vbd-iterations=10"] == own
    # Converged VBD is the backward Euler step in every implementation: the same error.
    error = runs.set_index("run_id")["error"].astype(float)
    be = error["vibration-soft-xpbd-neo-hookean-nu0.3-backward-euler-cholesky-tolerance=1e-8"]
    for peer in ("pbat-vbd", "newton-vbd"):
        assert abs(error[f"vibration-soft-xpbd-neo-hookean-nu0.3-{peer}-iterations=40"] - be) < 1e-4 * be
    # What a peer cannot run is omitted with its reason, not refused.
    omissions = (tmp_path / "suite" / "omissions.md").read_text()
    assert "`newton-semi-implicit` cannot run" in omissions, omissions
    assert 'has no "xpbd-neo-hookean" material' in omissions, omissions
