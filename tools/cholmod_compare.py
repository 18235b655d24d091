#!/usr/bin/env python3
"""CHOLMOD side by side with softbench's factorization, on the same matrices (not part of CI).

`cargo run --release --example cholmod_export -- DIR` writes DIR/<mesh>.mtx (the
backward-Euler system M + dt^2 K, Matrix Market, lower triangle) and
DIR/<mesh>.softbench.json (softbench's nnz(L), flops and numeric-factorization times with
METIS at 1 and 2 threads: its default scheduler, and each scheduler — `subtrees`, `faer` —
when the file has them). This script factors each matrix with CHOLMOD (supernodal,
METIS ordering; scikit-sparse 0.4.16 over Debian's libsuitesparse-dev, OpenBLAS) at 1 and 2
threads and writes DIR/comparison.csv plus a Markdown table on stdout.

CHOLMOD's thread count is its BLAS's, fixed when the library loads, so each thread count runs
in a child process with OPENBLAS_NUM_THREADS / OMP_NUM_THREADS set. nnz(L) is the exact fill
of CHOLMOD's METIS permutation (a simplicial factor with the same ordering: supernodal
storage pads relaxed supernodes with zeros); times are of the numeric factorization only
(`Factor.cholesky_inplace` after one `analyze`), like softbench's.

    python3 tools/cholmod_compare.py DIR [repeats]
"""

import csv
import json
import os
import statistics
import subprocess
import sys
import time


def child(mtx_path, repeats):
    """Runs in a child process: factor `mtx_path` with CHOLMOD, print JSON."""
    import scipy.io
    import scipy.sparse
    from sksparse.cholmod import analyze

    a = scipy.sparse.csc_matrix(scipy.io.mmread(mtx_path))
    simplicial = analyze(a, mode="simplicial", ordering_method="metis")
    simplicial_factor = simplicial.cholesky(a)
    nnz_l = simplicial_factor.L().nnz
    factor = analyze(a, mode="supernodal", ordering_method="metis")
    factor.cholesky_inplace(a)  # warm-up: first touch of the factor's pages
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        factor.cholesky_inplace(a)
        times.append(time.perf_counter() - start)
    print(json.dumps({"nnz_l": int(nnz_l), "seconds": times}))


def cholmod(mtx_path, threads, repeats):
    env = dict(os.environ)
    env["OPENBLAS_NUM_THREADS"] = str(threads)
    env["OMP_NUM_THREADS"] = str(threads)
    out = subprocess.run(
        [sys.executable, __file__, "--child", mtx_path, str(repeats)],
        env=env,
        check=True,
        capture_output=True,
        text=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    if len(sys.argv) >= 2 and sys.argv[1] == "--child":
        child(sys.argv[2], int(sys.argv[3]))
        return
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    folder = sys.argv[1]
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    meshes = sorted(
        f[: -len(".softbench.json")]
        for f in os.listdir(folder)
        if f.endswith(".softbench.json")
    )
    if not meshes:
        sys.exit(f"no <mesh>.softbench.json in {folder}: run the cholmod_export example first")
    rows = []
    for mesh in meshes:
        with open(os.path.join(folder, f"{mesh}.softbench.json")) as f:
            ours = json.load(f)
        mtx = os.path.join(folder, f"{mesh}.mtx")
        for threads in (1, 2):
            theirs = cholmod(mtx, threads, repeats)
            ours_t = ours["factor_metis_threads"][str(threads)]["median_seconds"]
            theirs_t = statistics.median(theirs["seconds"])
            per_scheduler = {
                f"softbench_{name}_s": times[str(threads)]["median_seconds"]
                for name, times in ours.get("factor_metis_schedulers", {}).items()
            }
            # The settings a scene gets by default (ordering `auto`, the flops rule for
            # threads), when the export has them.
            defaults = ours.get("factor_defaults", {}).get(str(threads))
            if defaults:
                per_scheduler["softbench_defaults_s"] = defaults["median_seconds"]
            rows.append(
                {
                    "mesh": mesh,
                    "n": ours["n"],
                    "threads": threads,
                    "softbench_nnz_l": ours["orderings"]["metis"]["factor_nnz"],
                    "cholmod_nnz_l": theirs["nnz_l"],
                    "nnz_ratio": ours["orderings"]["metis"]["factor_nnz"] / theirs["nnz_l"],
                    "softbench_factor_s": ours_t,
                    "cholmod_factor_s": theirs_t,
                    "speedup": theirs_t / ours_t,
                    "repeats": f'{ours["repeats"]}/{repeats}',
                    **per_scheduler,
                    **(
                        {
                            "defaults_ordering": defaults["ordering"],
                            "defaults_nnz_l": defaults["factor_nnz"],
                            "cholmod_over_defaults": theirs_t / defaults["median_seconds"],
                        }
                        if defaults
                        else {}
                    ),
                }
            )
            print(f"{mesh} {threads}t: softbench {ours_t:.4f} s, CHOLMOD {theirs_t:.4f} s", file=sys.stderr)
    path = os.path.join(folder, "comparison.csv")
    with open(path + ".partial", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    os.replace(path + ".partial", path)
    schedulers = [k for k in rows[0] if k.startswith("softbench_") and k.endswith("_s")
                  and k != "softbench_factor_s"]
    extra_head = "".join(f" {k[len('softbench_'):-2]} (s) |" for k in schedulers)
    print("| mesh | DOFs | threads | nnz(L) softbench | nnz(L) CHOLMOD | ratio | factor softbench (s) |"
          + extra_head + " factor CHOLMOD (s) | CHOLMOD / softbench |")
    print("|---" * (9 + len(schedulers)) + "|")
    for r in rows:
        extra = "".join(f" {r.get(k, float('nan')):.3f} |" for k in schedulers)
        print(
            f'| {r["mesh"]} | {r["n"]} | {r["threads"]} | {r["softbench_nnz_l"]:,} | {r["cholmod_nnz_l"]:,} '
            f'| {r["nnz_ratio"]:.3f} | {r["softbench_factor_s"]:.3f} |{extra} {r["cholmod_factor_s"]:.3f} | {r["speedup"]:.2f}× |'
        )
    if any("defaults_ordering" in r for r in rows):
        print()
        print("| mesh | threads | default ordering (auto chose) | nnz(L) | factor, defaults (s) | CHOLMOD (s) | CHOLMOD / defaults |")
        print("|---" * 7 + "|")
        for r in rows:
            if "defaults_ordering" in r:
                print(
                    f'| {r["mesh"]} | {r["threads"]} | {r["defaults_ordering"]} | {r["defaults_nnz_l"]:,} '
                    f'| {r["softbench_defaults_s"]:.3f} | {r["cholmod_factor_s"]:.3f} | {r["cholmod_over_defaults"]:.2f}× |'
                )


if __name__ == "__main__":
    main()
