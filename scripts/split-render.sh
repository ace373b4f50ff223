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
rm -f "$parts"/part-*.exr

start=$(date +%s%N)
case "$engine" in
  local)
    seq 0 $((n - 1)) | xargs -P "${JOBS:-$(nproc)}" -I{} \
      "$hybrid" render "$@" ${THREADS_PER_PART:+-t "$THREADS_PER_PART"} --part "{}/$n" -f "$parts/part-{}.exr" >/dev/null
    ;;
  slurm)
    command -v sbatch >/dev/null || { echo "split-render: sbatch not found (is Slurm installed?)" >&2; exit 2; }
    printf -v cmd '%q ' "$hybrid" render "$@"
    # shellcheck disable=SC2086
    sbatch --parsable --wait --array=0-$((n - 1)) ${SBATCH_ARGS:-} \
      --job-name=hybrid-render --output="$parts/slurm-%A_%a.out" \
      --wrap "${cmd} --part \${SLURM_ARRAY_TASK_ID}/$n -f $parts/part-\${SLURM_ARRAY_TASK_ID}.exr" >/dev/null || {
        echo "split-render: the job array failed; task logs in $parts/slurm-*.out" >&2; exit 1; }
    ;;
esac
rendered=$(date +%s%N)
files=()
for k in $(seq 0 $((n - 1))); do files+=("$parts/part-$k.exr"); done
"$hybrid" merge -f "$out" "${files[@]}"
echo "split-render: $n parts on $engine in $(( (rendered - start) / 1000000 )) ms, merged into $out (parts in $parts)"
