#!/usr/bin/env bash
# Fuzzes the loader (`load`) or loader + native build + 4x3 render
# (`render`) for SECONDS, seeded with the project's own scenes.
#   bash fuzz/run.sh [load|render] [SECONDS]
# Needs cargo-fuzz (`cargo install cargo-fuzz`) and a nightly compiler or
# RUSTC_BOOTSTRAP=1 (set here). Findings land in fuzz/artifacts/TARGET/.
set -euo pipefail
cd "$(dirname "$0")"
target="${1:-load}"
seconds="${2:-300}"
corpus="corpus/$target"
mkdir -p "$corpus"
# Seeds: the project's own scenes (never the shared course scenes).
cp ../dae/*.dae ../tests/data/*.dae "$corpus/"
export RUSTC_BOOTSTRAP=1
# -rss_limit_mb: an allocation sized from the input is a finding.
cargo fuzz run --release "$target" "$corpus" -- \
  -max_total_time="$seconds" -rss_limit_mb=2048 -max_len=65536 \
  -dict=collada.dict
