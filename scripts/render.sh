#!/usr/bin/env bash
# Sets up the machine if needed, builds hybrid in release mode and renders.
# All arguments go to `hybrid render` and are read relative to the current
# folder; with none, the default scene (dae/cornell.dae) is rendered, with
# settings that converge in about ten seconds, to
# ./cornell.png.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/scripts/setup.sh"
(cd "$root" && cargo build --release --quiet)
exec "$root/target/release/hybrid" render "$@"
