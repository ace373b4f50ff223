#!/usr/bin/env bash
# Renders one frame as N parts (bands of rows, `hybrid render --part K/N`)
# and merges them (`hybrid merge`) into the image one process would render.
#
#   scripts/split-render.sh --engine local|slurm -n N -f OUT.png|OUT.exr [--parts DIR] -- RENDER ARGS...
#
# local: N processes on this machine (xargs -P, one thread each by default).
# slurm: one job array `sbatch --array=0-(N-1) --wait`, one task per band;
#        the binary, the scene and DIR must be on a filesystem every node
#        sees. Extra sbatch options: SBATCH_ARGS (e.g. "-p render -t 10").
# The binary is HYBRID, else target/release/hybrid beside this script.
#
# Failures: a part whose process fails (killed, out of memory, a lost
# node) is run again, up to RETRIES more times (default 2): locally in the
# same fan-out, on Slurm as a new array of just the missing bands. Parts
# are written under a temporary name and renamed when complete, so a file
# part-K.exr is a finished part; a rerun with the same DIR and the same
# render arguments keeps those and renders only what is missing (DIR/frame
# records the arguments; other arguments start the folder afresh). A part
# that keeps failing ends the run with one line naming the band, its exit
# status and its log.
set -euo pipefail

here="$(cd "$(dirname "$0")/.." && pwd)"
hybrid="${HYBRID:-$here/target/release/hybrid}"
engine="" n="" out="" parts=""
while [ $# -gt 0 ]; do
  case "$1" in
    --engine) engine="$2"; shift 2 ;;
    -n) n="$2"; shift 2 ;;
    -f) out="$2"; shift 2 ;;
    --parts) parts="$2"; shift 2 ;;
    --) shift; break ;;
    *) echo "split-render: unknown option '$1' (see the header of $0)" >&2; exit 2 ;;
  esac
done
case "$engine" in local|slurm) ;; *) echo "split-render: --engine local|slurm is required" >&2; exit 2 ;; esac
case "$n" in ''|*[!0-9]*|0) echo "split-render: -n N (N >= 1 parts) is required" >&2; exit 2 ;; esac
[ -n "$out" ] || { echo "split-render: -f OUT is required" >&2; exit 2; }
[ -x "$hybrid" ] || { echo "split-render: $hybrid is not built (cargo build --release, or set HYBRID)" >&2; exit 2; }
for arg in "$@"; do
  case "$arg" in -f|-p|--part) echo "split-render: '$arg' is set by the script; leave it out of the render arguments" >&2; exit 2 ;; esac
done
parts="${parts:-$(mktemp -d "${TMPDIR:-/tmp}/hybrid-parts.XXXXXX")}"
mkdir -p "$parts"
parts="$(cd "$parts" && pwd)"
retries="${RETRIES:-2}"
case "$retries" in ''|*[!0-9]*) echo "split-render: RETRIES must be a count, not '$retries'" >&2; exit 2 ;; esac
# The frame these parts belong to: the binary's answer to the arguments
# would be better, but the arguments and N name it well enough to keep
# finished parts of the same command and drop those of another.
printf -v frame '%q ' "$n" "$@"
if [ "$(cat "$parts/frame" 2>/dev/null || true)" != "$frame" ]; then
  rm -f "$parts"/part-*.exr "$parts"/part-*.log "$parts"/slurm-*.out
  printf '%s' "$frame" >"$parts/frame"
fi
missing() { for k in $(seq 0 $((n - 1))); do [ -f "$parts/part-$k.exr" ] || echo "$k"; done; }
kept=$((n - $(missing | wc -l)))
[ "$kept" -eq 0 ] || echo "split-render: $kept of $n parts already rendered in $parts, kept"

start=$(date +%s%N)
case "$engine" in
  local)
    # One band, tried 1 + RETRIES times; its log keeps every attempt.
    band() {
      local k=$1 try status=0
      for try in $(seq 0 "$retries"); do
        status=0
        "$hybrid" render "${@:2}" ${THREADS_PER_PART:+-t "$THREADS_PER_PART"} --part "$k/$n" \
          -f "$parts/part-$k.exr" >>"$parts/part-$k.log" 2>&1 || status=$?
        [ "$status" -ne 0 ] || return 0
        echo "split-render: part $k/$n failed (exit $status, try $((try + 1)) of $((retries + 1)))" >>"$parts/part-$k.log"
      done
      echo "split-render: part $k/$n (band $k of $n) failed $((retries + 1)) times, last exit $status; log: $parts/part-$k.log" >&2
      return 255
    }
    export -f band
    export hybrid n parts retries THREADS_PER_PART
    missing | xargs -r -P "${JOBS:-$(nproc)}" -I{} bash -c 'band "$@"' _ {} "$@" || exit 1
    ;;
  slurm)
    command -v sbatch >/dev/null || { echo "split-render: sbatch not found (is Slurm installed?)" >&2; exit 2; }
    printf -v cmd '%q ' "$hybrid" render "$@"
    for try in $(seq 0 "$retries"); do
      todo="$(missing | paste -sd, -)"
      [ -n "$todo" ] || break
      # A failed task fails the array's --wait; the loop reruns the bands
      # still missing as a new array.
      # shellcheck disable=SC2086
      sbatch --parsable --wait --array="$todo" ${SBATCH_ARGS:-} \
        --job-name=hybrid-render --output="$parts/slurm-%A_%a.out" \
        --wrap "echo split-render: band \${SLURM_ARRAY_TASK_ID} of $n on \${SLURMD_NODENAME}; ${cmd} --part \${SLURM_ARRAY_TASK_ID}/$n -f $parts/part-\${SLURM_ARRAY_TASK_ID}.exr" >/dev/null ||
        echo "split-render: bands $todo: the job array reported a failure (try $((try + 1)) of $((retries + 1)))" >&2
    done
    todo="$(missing | paste -sd, -)"
    if [ -n "$todo" ]; then
      echo "split-render: bands $todo of $n still missing after $((retries + 1)) arrays; task logs in $parts/slurm-*.out" >&2
      exit 1
    fi
    ;;
esac
rendered=$(date +%s%N)
files=()
for k in $(seq 0 $((n - 1))); do files+=("$parts/part-$k.exr"); done
"$hybrid" merge -f "$out" "${files[@]}"
echo "split-render: $n parts on $engine in $(( (rendered - start) / 1000000 )) ms, merged into $out (parts in $parts)"
