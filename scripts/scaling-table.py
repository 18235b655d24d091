#!/usr/bin/env python3
"""Print the solver-scaling table of results/README.md from a solver_scaling study's runs.csv: the steady
time per converged backward-Euler step (the median of the steps after the first) of every solver
on every scene, then in brackets the first step's setup (its excess over the steady step:
ordering, symbolic analysis, AMG build), with the solver `auto` chose, and a mark on any run that
did not complete.

    scripts/scaling-table.py results/solver_scaling/runs.csv
"""
import csv
import sys

COLUMNS = [
    ("Cholesky AMD", lambda r: r["linear_solver"] == "cholesky"
     and r["integrator.solver.direct.ordering"] == "amd" and r["newton_refactor_every"] == "1"),
    ("Cholesky METIS", lambda r: r["linear_solver"] == "cholesky"
     and r["integrator.solver.direct.ordering"] == "metis" and r["newton_refactor_every"] == "1"),
    ("Cholesky METIS, refactor/5", lambda r: r["linear_solver"] == "cholesky"
     and r["newton_refactor_every"] == "5"),
    ("CG AMG", lambda r: r["integrator.solver.cg.preconditioner"] == "amg"),
    ("CG IC(0)", lambda r: r["integrator.solver.cg.preconditioner"] == "incomplete_cholesky"),
    ("CG block-Jacobi", lambda r: r["integrator.solver.cg.preconditioner"] == "block_jacobi3"),
    ("CG Jacobi", lambda r: r["integrator.solver.cg.preconditioner"] == "jacobi"),
    ("auto", lambda r: r["linear_solver"] == "auto"),
]


def seconds(text):
    t = float(text)
    return f"{t * 1e3:.0f} ms" if t < 1.0 else f"{t:.2f} s"


def cell(row):
    if row is None:
        return "–"
    text = seconds(row["step_seconds_median"]) if row["step_seconds_median"] else "–"
    if row.get("setup_seconds"):
        text += f" (+{seconds(row['setup_seconds'])})"
    if row["linear_solver"] == "auto":
        text += f" ({row['linear_solver_used']})"
    if row["outcome"] != "completed":
        text += f" ({row['outcome']})"
    return text


def main():
    rows = list(csv.DictReader(open(sys.argv[1])))
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    print("| scene | tets | " + " | ".join(name for name, _ in COLUMNS) + " |")
    print("|---|---|" + "---|" * len(COLUMNS))
    for scene in scenes:
        mine = [r for r in rows if r["scene"] == scene]
        cells = [cell(next((r for r in mine if match(r)), None)) for _, match in COLUMNS]
        print(f"| {scene} | {int(mine[0]['tets']):,} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
