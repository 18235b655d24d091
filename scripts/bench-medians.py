#!/usr/bin/env python3
"""Print the median time (and throughput, if measured) of every benchmark in criterion's
console output, one line each.

    cargo bench 2>&1 | tee bench.txt; scripts/bench-medians.py bench.txt
"""
import re
import sys

text = open(sys.argv[1]).read() if len(sys.argv) > 1 else sys.stdin.read()
SKIP = {"Benchmarking", "Warning", "Found", "Running", "Gnuplot", "WARNING"}
rows, name = [], None
for line in text.splitlines():
    # A benchmark's name starts a line (alone, or before its `time:`): `group/id/...`, or a
    # single word for an ungrouped benchmark; criterion's own lines start with known words.
    head = re.match(r"^([\w.\-]+(?:/[\w.\-]+)*)(?:\s+(time:.*))?$", line)
    if head and head.group(1) not in SKIP:
        name, line = head.group(1), head.group(2) or ""
    t = re.search(r"time:\s+\[\S+ \S+ (\S+ \S+) \S+ \S+\]", line)
    if t and name:
        rows.append([name, t.group(1), ""])
        name = None
    thr = re.search(r"thrpt:\s+\[\S+ \S+ (\S+ \S+) \S+ \S+\]", line)
    if thr and rows:
        rows[-1][2] = f"({thr.group(1)})"
for name, median, throughput in rows:
    print(f"{name:44s} median {median:>11s}  {throughput}")
