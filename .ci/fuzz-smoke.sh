#!/usr/bin/env bash
# Every fuzz target for a few seconds each (FUZZ_SECONDS, default 10): a
# target that panics, aborts, leaks past 2 GiB or hangs on its seeds or on
# what libFuzzer makes of them in that time fails CI. Longer runs are local
# (fuzz/run.sh). Installs cargo-fuzz from crates.io when it is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${FUZZ_SECONDS:-10}"
command -v cargo-fuzz >/dev/null 2>&1 || cargo install --quiet --locked cargo-fuzz
for target in load render embree camera part environment cli rays; do
  log=$(mktemp)
  if ! bash fuzz/run.sh "$target" "$seconds" >"$log" 2>&1; then
    tail -n 40 "$log"
    echo "fuzz-smoke: $target failed" >&2
    exit 1
  fi
  echo "fuzz-smoke: $target: $(grep -o 'Done [0-9]* runs' "$log" | tail -n 1 || echo 'no count')"
  rm -f "$log"
done
