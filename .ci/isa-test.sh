#!/usr/bin/env bash
# The paths other CPUs take, on this one: the suite's backend agreement,
# packet and image-identity tests again with the instruction set capped
# (HYBRID_ISA), so that an AVX-512 machine also proves what an AVX2-only
# CPU runs (native AVX2 packets of 8 and, in the renderer, 16 rays;
# Embree's AVX2 kernels) and what a CPU
# without AVX2 runs (native scalar kernels, Embree's SSE4.2 kernels). On a
# CPU below a cap, the cap changes nothing and the run repeats the suite's.
set -euo pipefail
cd "$(dirname "$0")/.."
tests=(
  parity::
  batches::
  embree_backend::
  cli::parity_command
  integrators::same_seed_gives_the_same_image_for_any_thread_count
  integrators::every_estimator_converges_to_the_same_image
  split::cells_and_sample_ranges_merge_into_the_single_render
  hostile::a_signal_during_the_write_leaves_nothing_behind
)
for isa in avx2 sse4.2; do
  echo "== HYBRID_ISA=$isa"
  HYBRID_ISA=$isa cargo test --release --test suite -- "${tests[@]}"
done
