#!/usr/bin/env bash
# One frame split into parts and merged, checked byte for byte against the
# single-process render: first fanned out over local processes
# (scripts/split-render.sh --engine local), then as a job array on a
# two-node Slurm cluster on this machine (munge, slurmctld, and one slurmd
# in each of two network namespaces with its own name and address, from
# Debian's slurm-wlm; scripts/slurm-render.sh), the parts folder shared as
# a cluster's filesystem would be. Everything it starts is stopped on exit.
# The Slurm half needs root (it installs packages, makes the namespaces and
# runs the daemons); without root it is skipped with a message, except
# under CI.
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
# Two nodes, each a network namespace joined to this host by a veth pair:
# node1 at 10.200.1.2, node2 at 10.200.2.2; slurmctld listens on the
# host's end of node1's link (10.200.1.1), which node2 reaches through its
# own link (a packet for any local address is delivered locally).
nodes=(node1 node2)
export SLURM_CONF="$work/slurm.conf"
cat >"$SLURM_CONF" <<CONF
ClusterName=hybridci
SlurmctldHost=$host(10.200.1.1)
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
SlurmdSpoolDir=$work/d-%n
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd-%n.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd-%n.log
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
NodeName=node1 NodeAddr=10.200.1.2 CPUs=$(nproc) State=UNKNOWN
NodeName=node2 NodeAddr=10.200.2.2 CPUs=$(nproc) State=UNKNOWN
PartitionName=ci Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
mkdir -p "$work/ctld" /run/munge
chown munge:munge /run/munge

stop() {
  for pid in "$work"/slurmd-*.pid "$work/slurmctld.pid"; do
    [ -s "$pid" ] && kill "$(cat "$pid")" 2>/dev/null || true
  done
  [ -n "${munge_pid:-}" ] && kill "$munge_pid" 2>/dev/null || true
  sleep 1
  for k in 1 2; do ip netns del "hyb-node$k" 2>/dev/null || true; done
  rm -rf "$work"
}
trap stop EXIT

for k in 1 2; do
  ns="hyb-node$k"
  ip netns del "$ns" 2>/dev/null || true
  ip netns add "$ns"
  ip link add "hyb-h$k" type veth peer name "hyb-n$k"
  ip link set "hyb-n$k" netns "$ns"
  ip addr add "10.200.$k.1/24" dev "hyb-h$k"
  ip link set "hyb-h$k" up
  ip -n "$ns" addr add "10.200.$k.2/24" dev "hyb-n$k"
  ip -n "$ns" link set "hyb-n$k" up
  ip -n "$ns" link set lo up
  ip -n "$ns" route add default via "10.200.$k.1"
done

runuser -u munge -- /usr/sbin/munged --foreground >"$work/munged.log" 2>&1 &
munge_pid=$!
for _ in $(seq 50); do munge -n </dev/null >/dev/null 2>&1 && break; sleep 0.1; done
/usr/sbin/slurmctld -f "$SLURM_CONF"
# nsenter joins only the network namespace: `ip netns exec` would also
# remount /sys, without the cgroup tree slurmd needs.
for k in 1 2; do
  mkdir -p "$work/d-node$k"
  nsenter --net="/run/netns/hyb-node$k" /usr/sbin/slurmd -f "$SLURM_CONF" -N "node$k" || {
    echo "split-test: slurmd of node$k did not start" >&2
    tail -n 20 "$work/slurmd-node$k.log" >&2 || true
    exit 1
  }
done
for _ in $(seq 150); do
  state="$(sinfo -h -N -o '%N %T' 2>/dev/null | sort | tr '\n' ' ' || true)"
  [ "$state" = "node1 idle node2 idle " ] && break
  sleep 0.2
done
if [ "$state" != "node1 idle node2 idle " ]; then
  echo "split-test: the nodes did not come up (state '$state')" >&2
  tail -n 20 "$work/slurmctld.log" "$work"/slurmd-*.log >&2 || true
  exit 1
fi
echo "split-test: two-node cluster up (node1 at 10.200.1.2, node2 at 10.200.2.2, $(nproc) CPUs each)"

"$hybrid" render "${args[@]}" -f "$work/single.png" >/dev/null
start=$(date +%s%N)
bash scripts/slurm-render.sh -n 6 -f "$work/slurm.png" --parts "$work/parts" -- "${args[@]}"
echo "split-test: job array and merge took $(( ($(date +%s%N) - start) / 1000000 )) ms"
cmp "$work/single.png" "$work/slurm.png"
# Where the tasks ran (each task's log names its node), and a merge on a
# node of its own, of parts written on both.
ran="$(grep -h '^split-render: band' "$work"/parts/slurm-*.out | sort)"
echo "$ran" | sed 's/^/split-test: /'
for node in "${nodes[@]}"; do
  echo "$ran" | grep -q "on $node\$" || { echo "split-test: no task ran on $node" >&2; exit 1; }
done
parts=()
for k in $(seq 0 5); do parts+=("$work/parts/part-$k.exr"); done
srun -N 1 -w node2 "$hybrid" merge -f "$work/merged-on-node2.exr" "${parts[@]}" >/dev/null
"$hybrid" merge -f "$work/merged-here.exr" "${parts[@]}" >/dev/null
cmp "$work/merged-here.exr" "$work/merged-on-node2.exr"
"$hybrid" render "${args[@]}" -f "$work/single.exr" >/dev/null
cmp "$work/single.exr" "$work/merged-here.exr"
echo "split-test: the merged PNG of 6 Slurm tasks on two nodes, and the EXR merged on node2, are the single render's bytes"

# A task killed mid-run: band 2's first process holds with its part half
# written (HYBRID_TEST_HOLD_WRITE), is killed with its task (exit 137), and
# a second array renders the band again. The half-written temporary file
# never counts as a part; the merge is still the single render's bytes.
cat >"$work/dies-mid-write" <<WRAP
#!/usr/bin/env bash
for a; do
  if [ "\$a" = 2/6 ] && mkdir "$work/died" 2>/dev/null; then
    HYBRID_TEST_HOLD_WRITE=1 "$hybrid" "\$@" & pid=\$!
    for _ in \$(seq 300); do compgen -G "$work/killed/.hybrid-*.partial" >/dev/null && break; sleep 0.1; done
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
compgen -G "$work/killed/.hybrid-*.partial" >/dev/null || { echo "split-test: the killed task left no half-written file" >&2; exit 1; }
grep -q "bands 0,1,2,3,4,5: the job array reported a failure" "$work/killed.err"
cmp "$work/single.png" "$work/killed.png"
echo "split-test: a Slurm task killed mid-write is rerun by a second array; its half-written file is ignored; the merge is the single render's bytes"
