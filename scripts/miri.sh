#!/usr/bin/env bash
# Runs the native backend's portable kernels and its checked Tree under
# Miri (undefined-behaviour checks): the scalar walks on a small scene
# against brute force, and the Tree's acceptance and refusal tests.
# Needs a nightly toolchain with the miri component, which rustup fetches
# from static.rust-lang.org (CI's machines reach only the package
# registries, so CI does not run this). About two minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! cargo +nightly miri --version >/dev/null 2>&1; then
    rustup toolchain install nightly --profile minimal --component miri
fi
cargo +nightly miri setup
# Tree Borrows: crossbeam-epoch (rayon's) trips Stacked Borrows on its own
# code; rayon's pool threads outlive the tests.
export MIRIFLAGS="-Zmiri-tree-borrows -Zmiri-permissive-provenance -Zmiri-ignore-leaks"
cargo +nightly miri test --lib -- accel::native::tests accel::native::tree accel::native::node
