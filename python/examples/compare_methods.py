"""Prototype a method in Python against softbench's FEM and compare it with a built-in one.

Backward Euler written in twenty lines of NumPy/SciPy (Newton on softbench's gradient and
sparse Hessian, SciPy's sparse solver) is registered as ``py-backward-euler``; both it and
softbench's ``backward-euler`` run the soft cantilever; the script prints the cost and the
difference, writes their energy over time to a CSV and plots it with matplotlib.

    python python/examples/compare_methods.py [out folder, default out]
"""

import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.sparse.linalg

import softbench

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "experiments" / "scenes" / "soft_beam.toml"


def backward_euler(model, q, v, t, dt):
    """x = q + dt v_new with M (x - q - dt v) + dt² ∇V(x) = 0, by Newton."""
    m = model.mass()
    x = q + dt * v
    for _ in range(20):
        r = m @ (x - q - dt * v) + dt * dt * model.gradient(x)
        if np.linalg.norm(r) < 1e-10 * max(1.0, np.linalg.norm(m @ v)):
            break
        x = x - scipy.sparse.linalg.spsolve((m + dt * dt * model.hessian(x)).tocsc(), r)
    return x, (x - q) / dt


def main() -> None:
    import matplotlib.pyplot as plt  # only the plot needs it (the tests import this module)

    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out")
    out.mkdir(parents=True, exist_ok=True)
    softbench.register_method("py-backward-euler", backward_euler, order=1, explicit=False,
                              description="backward Euler by Newton in Python")
    runs = {}
    for method in ["py-backward-euler", "backward-euler"]:
        start = time.perf_counter()
        runs[method] = softbench.simulate(SCENE, {"integrator.method": method, "run.steps": 100})
        seconds = time.perf_counter() - start
        print(f"{method:>18}: {runs[method].outcome}, {seconds:.2f} s for 100 steps")
    gap = np.abs(runs["py-backward-euler"].final_positions
                 - runs["backward-euler"].final_positions).max()
    print(f"largest difference in final positions: {gap:.2e} m")
    table = pd.concat(
        [r.trajectory[["t", "kinetic", "elastic", "gravity", "total"]].assign(method=m)
         for m, r in runs.items()]
    )
    table.to_csv(out / "compare_methods.csv", index=False)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    for method, rows in table.groupby("method"):
        ax.plot(rows["t"], rows["total"], label=method)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("total energy (J)")
    ax.set_title("Soft cantilever: a Python prototype against softbench")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "compare_methods.png", dpi=120)
    print(f"wrote {out / 'compare_methods.csv'} and {out / 'compare_methods.png'}")


if __name__ == "__main__":
    main()
