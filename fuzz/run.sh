#!/usr/bin/env bash
# Fuzzes one target for SECONDS, seeded with inputs the project makes itself:
#   bash fuzz/run.sh TARGET [SECONDS]
# TARGET: load (the COLLADA loader), render (loader + native build + a 4x3
# render), embree (loader + both Embree versions' builds and traces),
# camera (camera files), part (merge parts: EXR headers, the hybrid.part
# attribute, channels, and their merge), environment (environment maps),
# cli (command lines, parsed and checked as before any work), rays (ray
# files, checked and traced by every backend as bench traces them).
# Needs cargo-fuzz (`cargo install cargo-fuzz`) and a nightly compiler or
# RUSTC_BOOTSTRAP=1 (set here). Findings land in fuzz/artifacts/TARGET/.
set -euo pipefail
cd "$(dirname "$0")"
target="${1:-load}"
seconds="${2:-300}"
corpus="corpus/$target"
mkdir -p "$corpus"
hybrid=../target/release/hybrid
seed_with_binary() {
  [ -x "$hybrid" ] || (cd .. && cargo build --release --quiet)
}
extra=()
case "$target" in
  load | render | embree)
    # The project's own scenes (never the shared course scenes).
    cp ../dae/*.dae ../tests/data/*.dae "$corpus/"
    extra=(-dict=collada.dict)
    ;;
  camera)
    seed_with_binary
    "$hybrid" render -r 8 6 --save-camera "$corpus/default.cam" -f "$corpus/default.png" >/dev/null
    rm -f "$corpus/default.png"
    ;;
  part)
    seed_with_binary
    "$hybrid" render -r 4 3 -s 2 -p 0 0 2 2 -f "$corpus/cell.exr" >/dev/null
    "$hybrid" render -r 4 3 -s 4 -a 2 0.1 -f "$corpus/adaptive.exr" >/dev/null
    rm -f "$corpus"/*_rate.png
    ;;
  environment)
    (cd .. && cargo run --release --quiet --example sky_map -- "fuzz/$corpus/sky.exr")
    ;;
  rays)
    seed_with_binary
    tmp=$(mktemp -d)
    "$hybrid" rays export "$tmp/set" ../tests/data/tiny.dae --rays 64 >/dev/null
    cp "$tmp"/set/*.rays "$corpus/"
    rm -rf "$tmp"
    ;;
  cli)
    printf 'render\0-r\0008\0006\0-s\0004' >"$corpus/render"
    printf 'series\0--vary\0s=1,2,...,8\0--columns\0003' >"$corpus/series"
    printf 'merge\0-f\0out.png\0part.exr' >"$corpus/merge"
    printf 'series\0--vary\0scene=a.dae,b.dae\0-f\0sheet.png' >"$corpus/series-outputs"
    printf 'rays\0export\0set\0../tests/data/tiny.dae\0--rays\00064' >"$corpus/export"
    ;;
  *)
    echo "fuzz/run.sh: unknown target '$target'" >&2
    exit 2
    ;;
esac
export RUSTC_BOOTSTRAP=1
# -rss_limit_mb: an allocation sized from the input is a finding.
cargo fuzz run --release "$target" "$corpus" -- \
  -max_total_time="$seconds" -rss_limit_mb=2048 -max_len=65536 "${extra[@]}"
