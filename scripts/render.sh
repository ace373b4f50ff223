#!/usr/bin/env bash
# Sets up the machine if needed, builds hybrid in release mode and renders.
# All arguments go to `hybrid render`; with none, the default scene
# (dae/cornell.dae) is rendered to cornell.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --quiet
exec ./target/release/hybrid render "$@"
