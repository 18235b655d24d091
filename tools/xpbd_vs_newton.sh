#!/bin/sh
# softbench's XPBD against Newton's (NVIDIA Warp, CPU) at equal substeps, in interleaved rounds:
# each round times Newton's XPBD on the 12k- and 49k-tet boxes (tools/newton_xpbd.py, 50
# substeps, 1 iteration, Warp's CPU kernels on one thread, float32) and then softbench's own
# (`cargo bench --bench thread_crossover -- xpbd --quick`: the same boxes, 50 substeps,
# 1 iteration, f64, one thread and two). Outside CI: needs a Python with warp-lang and newton,
#   python3 -m venv /tmp/peers && /tmp/peers/bin/pip install warp-lang newton
#   PYTHON=/tmp/peers/bin/python tools/xpbd_vs_newton.sh 3 | tee results/benchmarks/xpbd_vs_newton.txt
set -eu
rounds=${1:-3}
python=${PYTHON:-python3}
cargo bench --bench thread_crossover --no-run >/dev/null 2>&1
echo "commit $(git rev-parse --short HEAD), $(nproc) cores, $(date -u +%FT%TZ)"
i=1
while [ "$i" -le "$rounds" ]; do
    echo "== round $i, load $(cut -d' ' -f1-3 /proc/loadavg)"
    echo "newton 12000 tets: $("$python" tools/newton_xpbd.py --cells 20 10 10 --steps 10 2>/dev/null | grep ms/step)"
    echo "newton 49152 tets: $("$python" tools/newton_xpbd.py --cells 32 16 16 --steps 5 2>/dev/null | grep ms/step)"
    cargo bench --bench thread_crossover -- xpbd --quick 2>/dev/null | sed -n '/default chunk/,/^xpbd, default/p' | grep -E '^\| (12000|49152)|^\| box'
    i=$((i + 1))
done
echo "load at end $(cut -d' ' -f1-3 /proc/loadavg)"
