#!/usr/bin/env python3
"""Checks `hybrid bench`'s plain-C Embree figures against an independent C
program (tools/embree_replay.c) on the same exported rays.

Each pair runs `hybrid bench DIR` and the C program for Embree 3 and 4, in
alternating order, all pinned to one core; per ray kind it prints the
median and range of bench's plain-C Mrays/s over the C program's, pair by
pair. Native's figure is the same in both, so these ratios are also how far
bench's native/Embree ratios lie from native over the C program.

With --batched it checks the packet16 columns of `hybrid bench --batched`
(camera and light rays) against the C program's rtcIntersect16 /
rtcOccluded16, taking in both the faster of with and without the coherent
hint, as bench does.

    python3 tools/check_plain_c.py DIR [PAIRS] [CPU] [--batched]

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
BATCHED_KINDS = ["camera", "light"]


def fail(message):
    print(f"check_plain_c: {message}", file=sys.stderr)
    sys.exit(2)


def run(command):
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        fail(f"{' '.join(command)} failed: {done.stderr.strip()[:300]}")
    return done.stdout


def standalone(program, directory, version, cpu, batched):
    command = ["taskset", "-c", cpu, program, directory, LIBRARIES[version], "3"]
    out = run(command + (["packets"] if batched else []))
    figures = {}
    for line in out.splitlines():
        m = re.match(r"(\w+)( packet16)?( hint)?\s+\d+ rays\s+\d+ hits\s+([\d.]+) Mrays/s", line)
        if m:
            # With and without the hint: the faster, as bench takes it.
            figures[m.group(1)] = max(figures.get(m.group(1), 0.0), float(m.group(4)))
    return figures


def bench(directory, cpu, batched):
    command = [HYBRID, "bench", directory, "--min-rounds", "3", "--max-rounds", "3"]
    out = run(["taskset", "-c", cpu] + command + (["--batched"] if batched else []))
    mode = "packet16" if batched else "plain C"
    figures, columns = {}, {}
    for line in out.splitlines():
        cells = [c.strip() for c in line.split("|")]
        if len(cells) > 2 and cells[1] == "rays":
            columns = {v: cells.index(f"embree{v} {mode} Mrays/s") for v in LIBRARIES}
            continue
        kind = cells[1].replace(" ", "_") if len(cells) > 2 else ""
        if columns and kind in KINDS:
            for version, column in columns.items():
                figures[(version, kind)] = float(cells[column].split()[0])
    if not columns:
        fail(f"no table in the output of {' '.join(command)}")
    return figures


def main():
    batched = "--batched" in sys.argv
    args = [a for a in sys.argv[1:] if a != "--batched"]
    if not args:
        fail("usage: check_plain_c.py DIR [PAIRS] [CPU] [--batched]")
    directory = args[0]
    pairs = int(args[1]) if len(args) > 1 else 8
    cpu = args[2] if len(args) > 2 else "1"
    kinds = BATCHED_KINDS if batched else KINDS
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
        ratios = {(v, k): [] for v in versions for k in kinds}
        for i in range(pairs):
            # Alternate which goes first, so that a drift of the machine's
            # speed during a pair does not always favour one side.
            if i % 2 == 0:
                b = bench(directory, cpu, batched)
                c = {v: standalone(programs[v], directory, v, cpu, batched) for v in versions}
            else:
                c = {v: standalone(programs[v], directory, v, cpu, batched) for v in versions}
                b = bench(directory, cpu, batched)
            for v in versions:
                for k in kinds:
                    if (v, k) in b and k in c[v]:
                        ratios[(v, k)].append(b[(v, k)] / c[v][k])
    what = "packet16" if batched else "plain-C"
    print(f"{directory}: hybrid bench's {what} Mrays/s over tools/embree_replay.c's, {pairs} pairs")
    for (v, k), r in ratios.items():
        if r:
            r.sort()
            print(f"embree{v} {k:12} median {statistics.median(r):.3f}  range {r[0]:.3f}-{r[-1]:.3f}")


if __name__ == "__main__":
    main()
