"""The Python package against softbench itself: the same files the command line writes, the
same trajectories as built-in methods, derivatives checked by finite differences, meshes
checked against meshio, and bad input raised as BadInputError."""

import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.sparse

import softbench

TIMING = {"wall_seconds", "assemble_seconds", "factor_seconds", "solve_seconds",
          "elapsed_seconds", "qp_seconds", "force_seconds", "mass_solve_seconds"}


def untimed(df: pd.DataFrame) -> pd.DataFrame:
    return df[[c for c in df.columns if c not in TIMING and not c.endswith("_seconds")]]


def test_version_is_the_crates(root):
    cargo = tomllib.loads((root / "Cargo.toml").read_text())
    assert softbench.__version__ == cargo["workspace"]["package"]["version"]


def test_load_mesh_matches_meshio(root, tmp_path):
    meshio = pytest.importorskip("meshio")
    vertices, tets = softbench.load_mesh(root / "experiments/scenes/contact/two_cubes.mesh")
    assert vertices.dtype == np.float64 and vertices.shape[1] == 3
    assert tets.dtype == np.int64 and tets.shape[1] == 4
    other = meshio.read(root / "experiments/scenes/contact/two_cubes.mesh")
    # meshio's MEDIT reader keeps single precision; the indices are exact.
    np.testing.assert_allclose(vertices, other.points, rtol=1e-7)
    np.testing.assert_array_equal(tets, other.cells_dict["tetra"])
    # A file meshio writes in another format reads back the same.
    meshio.write(tmp_path / "m.vtu", meshio.Mesh(vertices, [("tetra", tets)]))
    v2, t2 = softbench.load_mesh(tmp_path / "m.vtu")
    np.testing.assert_array_equal(v2, vertices)
    np.testing.assert_array_equal(t2, tets)


def test_simulate_returns_what_the_command_line_writes(beam, tmp_path):
    run = softbench.simulate(beam, {"run.steps": 20}, out=tmp_path / "run")
    assert run.outcome == "completed"
    header = (tmp_path / "run" / "trajectory.csv").read_text().splitlines()[0].split(",")
    assert list(run.trajectory.columns) == header
    assert run.trajectory["step"].iloc[-1] == 20
    assert run.final_positions.shape == (99, 3)
    assert run.summary["summary"]["steps_completed"] == 20
    # The same scene again, into a temporary folder, gives the same numbers.
    again = softbench.simulate(beam, ["run.steps=20"])
    assert again.out is None
    pd.testing.assert_frame_equal(untimed(again.trajectory), untimed(run.trajectory))
    np.testing.assert_array_equal(again.final_positions, run.final_positions)


def test_simulate_matches_the_softbench_binary(root, beam, tmp_path):
    binary = root / "target" / "release" / "softbench"
    if not binary.exists():
        pytest.skip("target/release/softbench is not built")
    cli = tmp_path / "cli"
    subprocess.run([binary, "simulate", beam, "--out", cli, "--set", "run.steps=15",
                    "--set", "integrator.method=bdf2"], check=True, capture_output=True)
    run = softbench.simulate(beam, {"run.steps": 15, "integrator.method": "bdf2"})
    expected = pd.read_csv(cli / "trajectory.csv")
    pd.testing.assert_frame_equal(untimed(run.trajectory), untimed(expected))
    final = pd.read_csv(cli / "final_positions.csv")[["x", "y", "z"]].to_numpy()
    np.testing.assert_array_equal(run.final_positions, final)


def test_a_scene_dict_runs_like_its_file(beam):
    scene = tomllib.loads(beam.read_text())
    scene["run"]["steps"] = 10
    from_dict = softbench.simulate(scene, base_dir=beam.parent)
    from_file = softbench.simulate(beam, {"run.steps": 10})
    np.testing.assert_array_equal(from_dict.final_positions, from_file.final_positions)


def test_threads_are_a_setting_of_each_call_and_do_not_change_the_bits(beam, tmp_path):
    over = {"run.steps": 4, "integrator.method": "backward-euler"}
    one = softbench.simulate(beam, over, threads=1)
    three = softbench.simulate(beam, over, threads=3)
    np.testing.assert_array_equal(one.final_positions, three.final_positions)
    model = softbench.Model(beam, threads=2)
    q, _, _ = model.initial_state()
    assert model.energy(q) == softbench.Model(beam, threads=1).energy(q)
    with pytest.raises(softbench.BadInputError, match="threads"):
        softbench.simulate(beam, over, threads=0)


def test_positions_over_time(beam):
    run = softbench.simulate(beam, {"run.steps": 20}, every=5)
    assert run.positions.shape == (5, 99, 3)
    np.testing.assert_allclose(run.times, [0.0, 0.01, 0.02, 0.03, 0.04])
    np.testing.assert_array_equal(run.positions[-1], run.final_positions)


def test_model_derivatives_by_finite_differences(beam):
    model = softbench.Model(beam)
    q0, v0, t0 = model.initial_state()
    assert model.counts["free_dofs"] == q0.size == model.num_dofs == 270
    assert model.counts["fixed_vertices"] == 9 and model.fixed.sum() == 9
    rng = np.random.default_rng(7)
    q = q0 + 0.01 * rng.standard_normal(q0.size)
    d = rng.standard_normal(q.size)
    g = model.gradient(q)
    h = model.hessian(q)
    assert isinstance(h, scipy.sparse.csc_matrix) and h.shape == (270, 270)
    assert abs(h - h.T).max() < 1e-9 * abs(h).max()
    eps = 1e-6
    fd = (model.energy(q + eps * d) - model.energy(q - eps * d)) / (2 * eps)
    assert abs(fd - g @ d) < 1e-6 * max(1.0, abs(g @ d))
    fd_h = (model.gradient(q + eps * d) - model.gradient(q - eps * d)) / (2 * eps)
    assert np.linalg.norm(fd_h - h @ d) < 1e-6 * np.linalg.norm(h @ d)
    # The projected Hessian is positive semi-definite.
    hp = model.hessian(q, projected=True).toarray()
    assert np.linalg.eigvalsh(hp).min() > -1e-8 * np.abs(hp).max()
    # Lumped mass: diagonal, 3 entries per free vertex, the free vertices' masses.
    m = model.mass()
    free = ~model.fixed
    np.testing.assert_allclose(m.diagonal(), np.repeat(model.vertex_masses[free], 3))
    parts = model.energy_parts(q)
    assert parts["total"] == pytest.approx(model.energy(q))
    assert model.full_positions(q).shape == (99, 3)


def symplectic_euler(model, q, v, t, dt):
    a = model.acceleration(q, v)
    v = v + dt * a
    return q + dt * v, v


def _example():
    """The worked example as a module, so the tests run its backward Euler."""
    import importlib.util
    path = Path(__file__).resolve().parents[1] / "examples" / "compare_methods.py"
    spec = importlib.util.spec_from_file_location("compare_methods", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


backward_euler = _example().backward_euler


softbench.register_method("py-symplectic-euler", symplectic_euler, order=1,
                          description="symplectic Euler in Python")
softbench.register_method("py-backward-euler", backward_euler, order=1, explicit=False,
                          description="backward Euler by Newton in Python")


def test_a_python_method_reproduces_the_built_in_one(beam):
    assert "py-symplectic-euler" in set(softbench.methods()["name"])
    mine = softbench.simulate(beam, {"run.steps": 50, "integrator.method": "py-symplectic-euler"})
    theirs = softbench.simulate(beam, {"run.steps": 50, "integrator.method": "symplectic-euler"})
    assert mine.outcome == "completed"
    np.testing.assert_array_equal(mine.final_positions, theirs.final_positions)
    implicit = softbench.simulate(beam, {"run.steps": 10, "integrator.method": "py-backward-euler"})
    built_in = softbench.simulate(beam, {"run.steps": 10, "integrator.method": "backward-euler"})
    np.testing.assert_allclose(implicit.final_positions, built_in.final_positions, atol=1e-7)


def test_a_study_runs_python_methods_by_name(beam, tmp_path):
    study = tmp_path / "py.toml"
    study.write_text(f'''name = "py"
study = "trajectory"
scenes = ["{beam.as_posix()}"]

[grid]
"integrator.method" = ["py-symplectic-euler", "symplectic-euler"]

[set]
"run.steps" = 30
''')
    runs = softbench.run_study(study, tmp_path / "results", jobs=2)
    assert list(runs.columns) == (tmp_path / "results/py/runs.csv").read_text().splitlines()[0].split(",")
    assert len(runs) == 2 and set(runs["outcome"]) == {"completed"}
    assert runs.attrs["dir"] == tmp_path / "results" / "py"
    by_method = runs.set_index("method")
    for column in ["energy_drift_max", "energy_drift_final", "steps", "force_evaluations"]:
        assert by_method.loc["py-symplectic-euler", column] == by_method.loc["symplectic-euler", column]


def test_a_failing_python_step_ends_the_run_with_its_message(beam):
    def broken(model, q, v, t, dt):
        if t > 0.005:
            raise ValueError("no convergence here")
        return symplectic_euler(model, q, v, t, dt)

    softbench.register_method("py-broken", broken, order=1)
    run = softbench.simulate(beam, {"run.steps": 10, "integrator.method": "py-broken"})
    assert run.outcome == "solver-failed"
    outcome = run.summary["summary"]["outcome"]
    assert "ValueError: no convergence here" in str(outcome)

    softbench.register_method("py-short", lambda m, q, v, t, dt: (q[:-1], v), order=1)
    run = softbench.simulate(beam, {"run.steps": 3, "integrator.method": "py-short"})
    assert run.outcome == "solver-failed"
    assert "269" in str(run.summary["summary"]["outcome"])


def test_the_step_model_is_only_valid_inside_the_call(beam):
    kept = []

    def keeps(model, q, v, t, dt):
        kept.append(model)
        return symplectic_euler(model, q, v, t, dt)

    softbench.register_method("py-keeps", keeps, order=1)
    softbench.simulate(beam, {"run.steps": 1, "integrator.method": "py-keeps"})
    with pytest.raises(RuntimeError, match="only valid inside the step"):
        kept[0].energy(np.zeros(270))


def test_bad_input_is_bad_input_error(beam, tmp_path):
    with pytest.raises(softbench.BadInputError, match="run.dtt|dtt"):
        softbench.simulate(beam, {"run.dtt": 1.0})
    with pytest.raises(softbench.BadInputError, match="not-a-method"):
        softbench.Model(beam, ["integrator.method=not-a-method"])
    with pytest.raises(softbench.BadInputError):
        softbench.load_mesh(tmp_path / "missing.mesh")
    with pytest.raises(softbench.BadInputError):
        softbench.run_study(tmp_path / "missing.toml", tmp_path)
    with pytest.raises(softbench.SoftbenchError, match="already registered"):
        softbench.register_method("rk4", symplectic_euler, order=1)
    with pytest.raises(TypeError):
        softbench.simulate(42)


def test_the_example_compares_two_methods_and_plots(root, tmp_path):
    pytest.importorskip("matplotlib")
    example = root / "python" / "examples" / "compare_methods.py"
    subprocess.run([sys.executable, example, tmp_path], check=True, capture_output=True,
                   env={**__import__("os").environ, "MPLBACKEND": "Agg"})
    assert (tmp_path / "compare_methods.png").stat().st_size > 10_000
    table = pd.read_csv(tmp_path / "compare_methods.csv")
    assert set(table["method"]) == {"py-backward-euler", "backward-euler"}


def test_ctrl_c_stops_python_m_softbench_as_it_stops_the_binary(tmp_path):
    """SIGINT during ``python -m softbench run`` stops at a safe point and exits 130 with
    softbench's message, not a Python traceback (found stopping the suite)."""
    import signal
    import subprocess
    import sys
    import time

    scene = tmp_path / "long.toml"
    scene.write_text(
        "[mesh]\ngenerate = { box = [8, 4, 4], size = [1.0, 0.5, 0.5] }\n"
        '[material]\nmodel = "stable-neo-hookean"\nyoungs_modulus = 1e5\npoisson_ratio = 0.4\n'
        'density = 1000.0\n[fixed]\nrule = { axis = "x", side = "min", tolerance = 1e-6 }\n'
        "[forces]\ngravity = [0.0, -9.81, 0.0]\n"
        '[integrator]\nmethod = "backward-euler"\n[run]\ndt = 0.001\nsteps = 1000000\n'
    )
    study = tmp_path / "study.toml"
    study.write_text(
        f'name = "long"\nstudy = "trajectory"\nscenes = ["{scene.as_posix()}"]\n'
        '[grid]\n"integrator.method" = ["backward-euler"]\n'
    )
    proc = subprocess.Popen(
        [sys.executable, "-m", "softbench", "run", study, "--out", tmp_path / "out"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    # Wait until the run has started (its lock and series folder exist), then interrupt it.
    deadline = time.time() + 120
    while not (tmp_path / "out" / "long" / "series").exists() and time.time() < deadline:
        assert proc.poll() is None, proc.communicate()[1]
        time.sleep(0.2)
    time.sleep(2.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err, err
    assert "stopped" in err, err
