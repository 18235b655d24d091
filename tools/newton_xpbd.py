#!/usr/bin/env python3
"""Time NVIDIA Newton's XPBD soft-body solver (Warp, CPU device) on softbench's box mesh.

Peer comparison for softbench's own XPBD at equal substeps (not part of CI). The mesh matches
softbench's `box_mesh([nx, ny, nz], [1.0, 0.5, 0.5])`: (nx+1)(ny+1)(nz+1) lattice vertices, x
fastest, 6 positively oriented Kuhn tets per cell in the same order. Material E = 1e6 Pa,
nu = 0.45 (Lame mu, lambda; no damping), density 1000, gravity 9.81 along -y, vertices at x = 0
fixed (particle mass 0, so inverse mass 0: Newton's XPBD neither integrates nor moves them).

No collisions: particle radius 0 (so Newton builds no particle hash grid and runs no
particle-particle contact kernel), no shapes, no ground, no surface bending edges, and
`contacts=None` is passed to `solver.step` (no collision pipeline at all). One step of
dt = 0.01 s is `substeps` calls of `SolverXPBD.step` with dt/substeps and state swapping. Warp
arrays are float32; Warp's CPU kernels run on one thread. Timed: `--steps` steps after 2
untimed warm-up steps (which compile the kernels), wall clock between `wp.synchronize()` calls.

    /tmp/peers/bin/python tools/newton_xpbd.py --cells 20 10 10 --substeps 50 --steps 20
"""

import argparse
import statistics
import time
from itertools import permutations

import numpy as np
import warp as wp

wp.config.log_level = wp.LOG_WARNING  # no init banner or module-load lines
import newton  # noqa: E402


def box_mesh(cells, size):
    """Vertices (N, 3) and tets (M, 4) as softbench's `mesh::generate::box_mesh`."""
    nx, ny, nz = cells
    k, j, i = np.meshgrid(*(np.arange(n + 1) for n in (nz, ny, nx)), indexing="ij")
    verts = np.stack([i / nx * size[0], j / ny * size[1], k / nz * size[2]], -1).reshape(-1, 3)
    local = []  # 6 Kuhn tets as corner offsets, order (a, b, c) walks a, then b, then c
    for order in permutations(range(3)):  # same order as softbench's ORDERS
        c = [np.zeros(3, int)]
        for axis in order:
            c.append(c[-1].copy())
            c[-1][axis] = 1
        if np.linalg.det(np.array([c[1] - c[0], c[2] - c[0], c[3] - c[0]])) < 0:
            c[2], c[3] = c[3], c[2]
        local.append(c)
    local = np.array(local)  # (6, 4, 3)
    ck, cj, ci = (a.ravel() for a in np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij"))
    base = np.stack([ci, cj, ck], -1)[:, None, None, :] + local[None]  # cells x fastest
    tets = base[..., 0] + (nx + 1) * (base[..., 1] + (ny + 1) * base[..., 2])
    return verts, tets.reshape(-1, 4)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, nargs=3, default=[20, 10, 10])
    ap.add_argument("--substeps", type=int, default=50)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--iterations", type=int, default=1)
    args = ap.parse_args()
    wp.init()
    wp.set_device("cpu")

    verts, tets = box_mesh(args.cells, [1.0, 0.5, 0.5])
    e, nu = 1.0e6, 0.45
    mu, lam = e / (2 * (1 + nu)), e * nu / ((1 + nu) * (1 - 2 * nu))
    builder = newton.ModelBuilder(up_axis=newton.Axis.Y, gravity=(0.0, -9.81, 0.0))
    builder.add_soft_mesh(
        pos=wp.vec3(0.0, 0.0, 0.0), rot=wp.quat_identity(), scale=1.0, vel=wp.vec3(0.0, 0.0, 0.0),
        vertices=verts.tolist(), indices=tets.ravel().tolist(), density=1000.0,
        k_mu=mu, k_lambda=lam, k_damp=0.0, particle_radius=0.0, add_surface_mesh_edges=False,
    )
    for v in np.flatnonzero(verts[:, 0] == 0.0):
        builder.particle_mass[v] = 0.0  # inverse mass 0: fixed
    model = builder.finalize(device="cpu")
    assert model.tet_count == len(tets) and model.particle_count == len(verts)
    assert model.particle_grid is None and model.shape_count == 0 and model.edge_count == 0

    solver = newton.solvers.SolverXPBD(model, iterations=args.iterations)
    s0, s1, control = model.state(), model.state(), model.control()
    dt = 0.01 / args.substeps

    def step():
        nonlocal s0, s1
        for _ in range(args.substeps):
            solver.step(s0, s1, control, None, dt)  # contacts=None: no collision handling
            s0, s1 = s1, s0

    for _ in range(2):
        step()
    times = []
    for _ in range(args.steps):
        wp.synchronize()
        t = time.perf_counter()
        step()
        wp.synchronize()
        times.append((time.perf_counter() - t) * 1e3)

    q = s0.particle_q.numpy()
    print(f"warp {wp.__version__}, newton {newton.__version__}, device cpu, SolverXPBD")
    print(f"mesh box {args.cells}: {model.tet_count} tets, {model.particle_count} vertices, "
          f"{int((verts[:, 0] == 0).sum())} fixed; precision {q.dtype} (wp.vec3)")
    print(f"mu {mu:.6g} Pa, lambda {lam:.6g} Pa; substeps {args.substeps}, iterations {args.iterations}, dt 0.01; "
          f"{args.steps} timed steps after 2 warm-up")
    print(f"ms/step: median {statistics.median(times):.2f}, min {min(times):.2f}, max {max(times):.2f}")
    print("per-step ms:", " ".join(f"{t:.2f}" for t in times))
    print(f"sanity after {args.steps + 2} steps ({(args.steps + 2) * 0.01:.2f} s): lowest y "
          f"{q[:, 1].min():.5f}, NaN: {bool(np.isnan(q).any())}")


if __name__ == "__main__":
    main()
