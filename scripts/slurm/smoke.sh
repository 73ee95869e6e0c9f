#!/bin/bash
# A real Slurm run on this machine (driven by `cargo xtask slurm-smoke`): a one-node
# cluster in a temporary directory, munged, slurmctld and slurmd started as our children
# (foreground), a campaign submitted as a job array of K shards plus a dependent merge
# (submit.sh, the same sbatch files the docs show), one running task requeued to show it
# resumes from its checkpoint, and the merged summary.json compared byte for byte with a
# single run's. Everything started here is stopped on every exit path.
#   scripts/slurm/smoke.sh KINCAL [SCENARIO] [TRIALS] [K]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
kincal=${1:?usage: smoke.sh KINCAL [SCENARIO] [TRIALS] [K]}
scenario=${2:-$here/../../scenarios/paper-kr1000.json}
trials=${3:-2000}
k=${4:-4}
scenario=$(cd "$(dirname "$scenario")" && pwd)/$(basename "$scenario")
deadline=$((SECONDS + ${SMOKE_TIMEOUT:-480}))

say() { echo "slurm-smoke: $*" >&2; }
die() { say "FAILED: $*"; exit 1; }

# 1. Packages.
missing=()
for b in munged slurmctld slurmd sbatch; do command -v "$b" >/dev/null || missing+=("$b"); done
if ((${#missing[@]})); then
  say "installing slurm-wlm and munge (missing: ${missing[*]})"
  if [[ $(id -u) -ne 0 ]]; then die "need root to apt-get install slurm-wlm munge"; fi
  if ! command -v apt-get >/dev/null; then die "no apt-get: install slurm-wlm and munge by hand"; fi
  export DEBIAN_FRONTEND=noninteractive
  timeout 300 apt-get update -qq || die "apt-get update failed: cannot install slurm-wlm and munge"
  timeout 300 apt-get install -y -qq slurm-wlm munge >/dev/null ||
    die "apt-get install slurm-wlm munge failed (no network or no such packages?)"
fi

# 2. A one-node cluster in a temporary directory.
tmp=$(mktemp -d /tmp/kincal-slurm.XXXXXX)
chmod 755 "$tmp"
pids=()
cleanup() {
  local rc=$?
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  for _ in $(seq 50); do
    local alive=0
    for p in "${pids[@]}"; do kill -0 "$p" 2>/dev/null && alive=1; done
    ((alive)) || break
    sleep 0.1
  done
  for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  if ((rc)) && [[ -d $tmp ]]; then
    for f in "$tmp"/log/*; do [[ -f $f ]] && { echo "== $f" >&2; tail -n 20 "$f" >&2; }; done
  fi
  rm -rf "$tmp"
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM
mkdir -p "$tmp"/{munge,state,spool,log,out,single}
# A private copy of the binary: a rebuild during the run must not change the executable a
# requeued task resumes with (a checkpoint of another executable is refused).
cp "$kincal" "$tmp/kincal"
kincal=$tmp/kincal
chmod 700 "$tmp/munge"
dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$tmp/munge/munge.key"
munged --foreground --force --key-file="$tmp/munge/munge.key" --socket="$tmp/munge/munge.sock" \
  --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/log/munged.log" \
  --seed-file="$tmp/munge/seed" >/dev/null 2>&1 &
pids+=($!)
node=$(hostname -s)
cpus=$(nproc)
port=$((20000 + RANDOM % 20000))
export SLURM_CONF=$tmp/slurm.conf
cat > "$SLURM_CONF" <<CONF
ClusterName=kincal-smoke
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/munge/munge.sock
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
SchedulerParameters=defer
MinJobAge=600
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=smoke Nodes=$node Default=YES MaxTime=INFINITE State=UP
CONF
for _ in $(seq 50); do [[ -S $tmp/munge/munge.sock ]] && break; sleep 0.1; done
[[ -S $tmp/munge/munge.sock ]] || die "munged did not start"
slurmctld -D -i -f "$SLURM_CONF" >"$tmp/log/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" >"$tmp/log/slurmd.out" 2>&1 &
pids+=($!)
say "cluster up in $tmp (node $node, $cpus CPUs, port $port)"
until sinfo -h -o '%T' 2>/dev/null | grep -qE '^(idle|mixed)'; do
  ((SECONDS < deadline)) || die "the node did not come up: $(sinfo 2>&1)"
  sleep 0.5
done

# 3. The reference: a single run.
"$kincal" campaign "$scenario" --trials "$trials" --out "$tmp/single" --quiet --threads "$cpus" 2>/dev/null ||
  die "the single run failed"

# 4. The job array and the dependent merge.
cd "$tmp/log"
read -r array merge < <(CHECKPOINT_EVERY=20 TRIALS=$trials \
  "$here/submit.sh" "$kincal" "$scenario" "$tmp/out" "$k")
say "submitted array $array (K=$k) and merge $merge (afterok:$array)"

# 5. Preempt one running task once it has a checkpoint, and requeue it.
victim=${array}_0
ck=$tmp/out/shard-0-of-$k.checkpoint.json
until [[ -f $ck ]]; do
  ((SECONDS < deadline)) || die "task $victim wrote no checkpoint"
  [[ -f $tmp/out/shard-0-of-$k.json ]] && die "task $victim finished before it could be requeued (raise TRIALS)"
  sleep 0.05
done
scontrol requeue "$victim" || die "scontrol requeue $victim failed"
say "requeued $victim after its checkpoint at trial $(grep -o '"next_trial":[0-9]*' "$ck" | cut -d: -f2)"

# 6. Wait for everything, bounded; a failed shard ends the wait at once (its merge would
# wait for ever: DependencyNeverSatisfied).
while [[ -n $(squeue -h -j "$array,$merge" 2>/dev/null) ]]; do
  ((SECONDS < deadline)) || die "jobs still queued at the deadline: $(squeue 2>&1)"
  if sacct_failed=$(scontrol show job "$array" 2>/dev/null | grep -E 'JobState=(FAILED|CANCELLED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY)'); then
    for f in "$tmp"/log/kincal-shard-*.out; do echo "== $f" >&2; cat "$f" >&2; done
    die "a shard of array $array failed: $(echo "$sacct_failed" | head -n 1)"
  fi
  sleep 0.5
done
state=$(scontrol show job "$merge" | grep -o 'JobState=[A-Z_]*')
[[ $state == JobState=COMPLETED ]] || die "merge job $merge: $state"
log=$(ls "$tmp"/log/kincal-shard-*_0.out)
grep -q 'resuming' "$log" || die "task $victim did not resume from its checkpoint: $(cat "$log")"
say "task $victim log:"
sed 's/^/    /' "$log" >&2
ls "$tmp/out"/*.checkpoint.json >/dev/null 2>&1 && die "a checkpoint was left behind"
cmp "$tmp/single/summary.json" "$tmp/out/summary.json" ||
  die "the merged summary.json differs from the single run's"
say "PASSED: $k shards + merge under Slurm, one task requeued and resumed; summary.json identical to a single run's ($(wc -c <"$tmp/out/summary.json") bytes)"
