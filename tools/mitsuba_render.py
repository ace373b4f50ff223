#!/usr/bin/env python3
"""Render a scene that `hybrid render --mitsuba DIR` wrote with Mitsuba 3,
time it, and compare its image with hybrid's.

    python3 tools/mitsuba_render.py DIR [--variant llvm_ad_rgb] [--threads N]
        [--repeat K] [--compare OURS.exr] [--avx2]

Mitsuba comes from PyPI (`pip install mitsuba==3.5.2`); its LLVM variants
need a libLLVM (Debian 12: libllvm15, found by itself or through
DRJIT_LIBLLVM_PATH). Each of the K renders is timed on the wall clock
after the scene is loaded; the first one includes compiling Dr.Jit's
kernels unless they are in its cache (~/.drjit), so the report gives the
first and the fastest of the rest. `--threads 1` runs Dr.Jit's pool on one
thread: pin the process too (`taskset -c 1`) for one-core figures. Pinning
alone is not enough: Dr.Jit sizes its pool by the machine's cores, not the
process's, and two workers on one core took 8.4 s where one took 5.2 s
(CBbunny, 1024 spp, Sapphire Rapids).

`--avx2` has Dr.Jit compile its kernels for an AVX2 CPU (Zen 3, eight
lanes) on a machine with AVX-512, through its C function
`jit_llvm_set_target` (the Python module of Dr.Jit 0.4 does not offer it):
an AVX2-only CPU's kernels on this CPU's cores, not a Zen 3. Embree inside
Mitsuba keeps choosing its own ISA.

With --compare, the two images' per-channel means and their difference
over 8 x 8 pixel blocks (noise averages out there, framing does not) are
printed: on the same scene both converge to the same image, so a mean
ratio far from 1 or block differences well above the noise mean the
scenes or renderers disagree.
"""

import argparse
import sys
import time
from pathlib import Path


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dir", type=Path, help="folder written by --mitsuba")
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--threads", type=int, default=0, help="0: all cores")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--compare", type=Path, help="hybrid's EXR of the same render")
    parser.add_argument("--avx2", action="store_true", help="compile for an AVX2 CPU (8 lanes)")
    args = parser.parse_args()

    scene_file = args.dir / "scene.xml"
    if not scene_file.is_file():
        sys.exit(f"mitsuba_render: {scene_file}: not found (write it with hybrid render --mitsuba {args.dir})")
    if args.repeat < 1:
        sys.exit("mitsuba_render: --repeat: at least 1")
    try:
        import drjit as dr
        import mitsuba as mi
        import numpy as np
    except ImportError as e:
        sys.exit(f"mitsuba_render: {e}: pip install mitsuba==3.5.2 numpy")
    try:
        mi.set_variant(args.variant)
    except Exception as e:  # noqa: BLE001 (Mitsuba raises plain exceptions)
        sys.exit(f"mitsuba_render: variant {args.variant}: {e}")
    if args.threads > 0:
        dr.set_thread_count(args.threads)
    if args.avx2:
        import ctypes
        core = Path(dr.__file__).parent / "libdrjit-core.so"
        jit = ctypes.CDLL(str(core))
        jit.jit_llvm_set_target.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
        features = b"+avx2,+fma,+f16c,+bmi,+bmi2,+popcnt,+lzcnt,+movbe,+avx,+sse4.2,+sse4.1,+ssse3,+cx16,-avx512f"
        jit.jit_llvm_set_target(b"znver3", features, 8)

    start = time.perf_counter()
    scene = mi.load_file(str(scene_file))
    load = time.perf_counter() - start
    film = scene.sensors()[0].film()
    width, height = film.size()
    spp = scene.sensors()[0].sampler().sample_count()

    times = []
    image = None
    for k in range(args.repeat):
        start = time.perf_counter()
        image = mi.render(scene, seed=k)
        pixels = np.array(image)  # waits for the kernels
        times.append(time.perf_counter() - start)
    out = args.dir / "mitsuba.exr"
    # Written synchronously: with the pool at one thread, the asynchronous
    # write (the default) deadlocked after the renders.
    mi.util.write_bitmap(str(out), image, write_async=False)

    best = min(times[1:]) if len(times) > 1 else times[0]
    samples = width * height * spp
    threads = args.threads or "all"
    isa = ", kernels for AVX2 (8 lanes)" if args.avx2 else ""
    print(f"mitsuba {mi.__version__} {args.variant}{isa}, {threads} threads: {width}x{height} at {spp} spp")
    print(f"scene loaded in {load:.3f} s; renders: " + ", ".join(f"{t:.3f} s" for t in times))
    print(f"fastest render after the first: {best:.3f} s, {samples / best / 1e6:.3f} Msamples/s")
    print(f"wrote {out}")

    if args.compare:
        theirs = pixels[..., :3].astype(np.float64)
        ours = np.array(mi.Bitmap(str(args.compare)), dtype=np.float64)[..., :3]
        if ours.shape != theirs.shape:
            sys.exit(f"mitsuba_render: --compare {args.compare}: {ours.shape[1]}x{ours.shape[0]}, Mitsuba's is {width}x{height}")
        mean_ours, mean_theirs = ours.mean(axis=(0, 1)), theirs.mean(axis=(0, 1))
        print("mean RGB hybrid " + " ".join(f"{v:.4f}" for v in mean_ours)
              + ", Mitsuba " + " ".join(f"{v:.4f}" for v in mean_theirs)
              + ", ratio " + " ".join(f"{a / b:.4f}" if b > 0 else "-" for a, b in zip(mean_ours, mean_theirs)))
        h, w = (height // 8) * 8, (width // 8) * 8
        block = lambda img: img[:h, :w].reshape(h // 8, 8, w // 8, 8, 3).mean(axis=(1, 3))
        diff = np.abs(block(ours) - block(theirs)).mean(axis=2)
        scale = max(mean_theirs.mean(), 1e-12)
        print(f"8x8 blocks: mean |difference| {diff.mean() / scale:.4f} of the mean radiance, "
              f"largest {diff.max() / scale:.4f} (block {np.unravel_index(diff.argmax(), diff.shape)[::-1]})")


if __name__ == "__main__":
    main()
