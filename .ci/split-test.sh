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
