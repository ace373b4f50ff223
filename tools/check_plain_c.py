#!/usr/bin/env python3
"""Checks `hybrid bench`'s plain-C Embree figures against an independent C
program (tools/embree_replay.c) on the same exported rays.

Each pair runs `hybrid bench DIR` and the C program for Embree 3 and 4, in
alternating order, all pinned to one core; per ray kind it prints the
median and range of bench's plain-C Mrays/s over the C program's, pair by
pair. Native's figure is the same in both, so these ratios are also how far
bench's native/Embree ratios lie from native over the C program.

    python3 tools/check_plain_c.py DIR [PAIRS] [CPU]

DIR is a folder from `hybrid rays export`; PAIRS defaults to 8, CPU to 1.
Needs a release build (`cargo build --release`) and gcc.
"""

import os
import re
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HYBRID = os.path.join(ROOT, "target", "release", "hybrid")
LIBRARIES = {
    3: os.environ.get("HYBRID_EMBREE3", "/usr/lib/x86_64-linux-gnu/libembree3.so.3"),
    4: os.environ.get(
        "HYBRID_EMBREE4",
        os.path.expanduser("~/.local/lib/hybrid/embree4/libembree4.so.4"),
    ),
}
KINDS = ["camera", "camera_rows", "incoherent", "shadow", "bounce", "light"]
# Columns of `hybrid bench`'s table (after the leading empty cell): the
# plain-C Mrays/s of each version.
PLAIN_C_COLUMN = {3: 5, 4: 7}


def fail(message):
    print(f"check_plain_c: {message}", file=sys.stderr)
    sys.exit(2)


def run(command):
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        fail(f"{' '.join(command)} failed: {done.stderr.strip()[:300]}")
    return done.stdout


def standalone(program, directory, version, cpu):
    out = run(["taskset", "-c", cpu, program, directory, LIBRARIES[version], "3"])
    figures = {}
    for line in out.splitlines():
        m = re.match(r"(\w+)\s+\d+ rays\s+\d+ hits\s+([\d.]+) Mrays/s", line)
        if m:
            figures[m.group(1)] = float(m.group(2))
    return figures


def bench(directory, cpu):
    out = run(
        ["taskset", "-c", cpu, HYBRID, "bench", directory, "--min-rounds", "3", "--max-rounds", "3"]
    )
    figures = {}
    for line in out.splitlines():
        cells = [c.strip() for c in line.split("|")]
        kind = cells[1].replace(" ", "_") if len(cells) > 10 else ""
        if kind in KINDS:
            for version, column in PLAIN_C_COLUMN.items():
                figures[(version, kind)] = float(cells[column].split()[0])
    return figures


def main():
    if len(sys.argv) < 2:
        fail("usage: check_plain_c.py DIR [PAIRS] [CPU]")
    directory = sys.argv[1]
    pairs = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    cpu = sys.argv[3] if len(sys.argv) > 3 else "1"
    if not os.path.isfile(HYBRID):
        fail(f"{HYBRID} is missing: run cargo build --release first")
    versions = [v for v in LIBRARIES if os.path.isfile(LIBRARIES[v])]
    with tempfile.TemporaryDirectory() as tmp:
        programs = {}
        for v in versions:
            programs[v] = os.path.join(tmp, f"replay{v}")
            run(
                ["gcc", "-O2", "-o", programs[v], os.path.join(ROOT, "tools", "embree_replay.c"),
                 "-ldl", f"-DEMBREE_MAJOR={v}"]
            )
        ratios = {(v, k): [] for v in versions for k in KINDS}
        for i in range(pairs):
            # Alternate which goes first, so that a drift of the machine's
            # speed during a pair does not always favour one side.
            if i % 2 == 0:
                b = bench(directory, cpu)
                c = {v: standalone(programs[v], directory, v, cpu) for v in versions}
            else:
                c = {v: standalone(programs[v], directory, v, cpu) for v in versions}
                b = bench(directory, cpu)
            for v in versions:
                for k in KINDS:
                    if (v, k) in b and k in c[v]:
                        ratios[(v, k)].append(b[(v, k)] / c[v][k])
    print(f"{directory}: hybrid bench's plain-C Mrays/s over tools/embree_replay.c's, {pairs} pairs")
    for (v, k), r in ratios.items():
        if r:
            r.sort()
            print(f"embree{v} {k:12} median {statistics.median(r):.3f}  range {r[0]:.3f}-{r[-1]:.3f}")


if __name__ == "__main__":
    main()
