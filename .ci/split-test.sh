#!/usr/bin/env bash
# One frame split into parts and merged, checked byte for byte against the
# single-process render: first fanned out over local processes
# (scripts/split-render.sh --engine local), then as a job array on a
# one-node Slurm cluster on localhost (munge, slurmctld, slurmd from
# Debian's slurm-wlm; scripts/slurm-render.sh). Everything it starts is
# stopped on exit. The Slurm half needs root (it installs packages and runs
# the daemons); without root it is skipped with a message, except under CI.
set -euo pipefail
cd "$(dirname "$0")/.."
root="$(pwd)"
hybrid="$root/target/release/hybrid"
args=(-r 160 120 -s 16 -m 3 --seed 7)

local_dir="$(mktemp -d /tmp/hybrid-split.XXXXXX)"
"$hybrid" render "${args[@]}" -f "$local_dir/single.png" >/dev/null
bash scripts/split-render.sh --engine local -n 5 -f "$local_dir/local.png" --parts "$local_dir/parts" -- "${args[@]}"
cmp "$local_dir/single.png" "$local_dir/local.png"
echo "split-test: 5 local parts merge into the single render's bytes"

# A band whose process is killed once (exit 137) is rendered again, and
# the merge still gives the single render's bytes.
wrap() { # wrap NAME BODY: a stand-in for the binary that runs BODY first
  printf '#!/usr/bin/env bash\n%s\nexec %q "$@"\n' "$2" "$hybrid" >"$local_dir/$1"
  chmod +x "$local_dir/$1"
}
wrap dies-once "for a; do [ \"\$a\" = 2/5 ] && mkdir $local_dir/died 2>/dev/null && kill -KILL \$\$; done"
HYBRID="$local_dir/dies-once" bash scripts/split-render.sh --engine local -n 5 \
  -f "$local_dir/retried.png" --parts "$local_dir/retried" -- "${args[@]}"
[ -d "$local_dir/died" ] || { echo "split-test: the band was never killed" >&2; exit 1; }
grep -q "part 2/5 failed (exit 137" "$local_dir/retried/part-2.log"
cmp "$local_dir/single.png" "$local_dir/retried.png"
echo "split-test: a band killed once is rendered again; the merge is the single render's bytes"

# A rerun keeps the finished parts and renders only the missing one.
rm "$local_dir/retried/part-3.exr"
wrap records "for a; do case \"\$a\" in */5) echo \"\$a\" >>$local_dir/rendered ;; esac; done"
HYBRID="$local_dir/records" bash scripts/split-render.sh --engine local -n 5 \
  -f "$local_dir/resumed.png" --parts "$local_dir/retried" -- "${args[@]}"
[ "$(cat "$local_dir/rendered")" = 3/5 ] || { echo "split-test: the rerun rendered $(tr '\n' ' ' <"$local_dir/rendered")" >&2; exit 1; }
cmp "$local_dir/single.png" "$local_dir/resumed.png"
echo "split-test: a rerun renders only the missing part 3/5 and merges the same bytes"

# A band that always fails ends the run with one line naming it.
wrap always-fails "for a; do [ \"\$a\" = 1/5 ] && exit 3; done"
if HYBRID="$local_dir/always-fails" RETRIES=1 bash scripts/split-render.sh --engine local -n 5 \
  -f "$local_dir/failed.png" --parts "$local_dir/failing" -- "${args[@]}" 2>"$local_dir/failed.err"; then
  echo "split-test: a band that always fails did not fail the run" >&2; exit 1
fi
grep -q "part 1/5 (band 1 of 5) failed 2 times, last exit 3; log: .*part-1.log" "$local_dir/failed.err"
[ ! -e "$local_dir/failed.png" ] || { echo "split-test: a failed run wrote its image" >&2; exit 1; }
echo "split-test: a band that fails every try ends the run: $(head -1 "$local_dir/failed.err")"
rm -rf "$local_dir"

if [ "$(id -u)" != 0 ]; then
  if [ -n "${CI:-}" ]; then echo "split-test: the Slurm test needs root" >&2; exit 1; fi
  echo "split-test: skipping the Slurm test (needs root to install and run slurm-wlm and munge)"
  exit 0
fi

missing=()
for pkg in slurm-wlm munge; do dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg"); done
if [ ${#missing[@]} -gt 0 ]; then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq "${missing[@]}" >/dev/null
fi

work="$(mktemp -d /tmp/hybrid-slurm.XXXXXX)"
chmod 755 "$work"
host="$(hostname -s)"
export SLURM_CONF="$work/slurm.conf"
cat >"$SLURM_CONF" <<CONF
ClusterName=hybridci
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
MpiDefault=none
ReturnToService=2
StateSaveLocation=$work/ctld
SlurmdSpoolDir=$work/d
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=ci Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
mkdir -p "$work/ctld" "$work/d" /run/munge
chown munge:munge /run/munge

stop() {
  for pid in "$work/slurmd.pid" "$work/slurmctld.pid"; do
    [ -s "$pid" ] && kill "$(cat "$pid")" 2>/dev/null || true
  done
  [ -n "${munge_pid:-}" ] && kill "$munge_pid" 2>/dev/null || true
  sleep 1
  rm -rf "$work"
}
trap stop EXIT

runuser -u munge -- /usr/sbin/munged --foreground >"$work/munged.log" 2>&1 &
munge_pid=$!
for _ in $(seq 50); do munge -n </dev/null >/dev/null 2>&1 && break; sleep 0.1; done
/usr/sbin/slurmctld -f "$SLURM_CONF"
/usr/sbin/slurmd -f "$SLURM_CONF"
for _ in $(seq 100); do
  state="$(sinfo -h -o %T 2>/dev/null || true)"
  [ "$state" = idle ] && break
  sleep 0.2
done
if [ "$state" != idle ]; then
  echo "split-test: the node did not come up (state '$state')" >&2
  tail -n 20 "$work/slurmctld.log" "$work/slurmd.log" >&2 || true
  exit 1
fi
echo "split-test: one-node cluster up ($host, $(nproc) CPUs)"

"$hybrid" render "${args[@]}" -f "$work/single.png" >/dev/null
start=$(date +%s%N)
bash scripts/slurm-render.sh -n 6 -f "$work/slurm.png" --parts "$work/parts" -- "${args[@]}"
echo "split-test: job array and merge took $(( ($(date +%s%N) - start) / 1000000 )) ms"
cmp "$work/single.png" "$work/slurm.png"
echo "split-test: the merged image of 6 Slurm tasks is identical to the single render"

# A task killed mid-run: band 2's first process holds with its part half
# written (HYBRID_TEST_HOLD_WRITE), is killed with its task (exit 137), and
# a second array renders the band again. The half-written temporary file
# never counts as a part; the merge is still the single render's bytes.
cat >"$work/dies-mid-write" <<WRAP
#!/usr/bin/env bash
for a; do
  if [ "\$a" = 2/6 ] && mkdir "$work/died" 2>/dev/null; then
    HYBRID_TEST_HOLD_WRITE=1 "$hybrid" "\$@" & pid=\$!
    for _ in \$(seq 300); do compgen -G "$work/killed/.part-2.exr.partial-*" >/dev/null && break; sleep 0.1; done
    kill -KILL \$pid
    kill -KILL \$\$
  fi
done
exec "$hybrid" "\$@"
WRAP
chmod +x "$work/dies-mid-write"
HYBRID="$work/dies-mid-write" bash scripts/slurm-render.sh -n 6 -f "$work/killed.png" --parts "$work/killed" -- "${args[@]}" 2>"$work/killed.err" || {
  cat "$work/killed.err" >&2; exit 1; }
[ -d "$work/died" ] || { echo "split-test: band 2 was never killed" >&2; exit 1; }
compgen -G "$work/killed/.part-2.exr.partial-*" >/dev/null || { echo "split-test: the killed task left no half-written file" >&2; exit 1; }
grep -q "bands 0,1,2,3,4,5: the job array reported a failure" "$work/killed.err"
cmp "$work/single.png" "$work/killed.png"
echo "split-test: a Slurm task killed mid-write is rerun by a second array; its half-written file is ignored; the merge is the single render's bytes"
