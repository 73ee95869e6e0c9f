#!/bin/bash
# Submits a kincal campaign as a job array of K shards plus a merge job that runs when
# every shard succeeded. Prints the two job ids.
#   scripts/slurm/submit.sh KINCAL SCENARIO OUT K [extra sbatch options...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
[[ $# -ge 4 ]] || { echo "usage: $0 KINCAL SCENARIO OUT K [sbatch options...]" >&2; exit 2; }
kincal=$1 scenario=$2 out=$3 k=$4
shift 4
mkdir -p "$out"
array=$(sbatch --parsable --array=0-$((k - 1)) "$@" \
  --export=ALL,KINCAL="$kincal",SCENARIO="$scenario",OUT="$out" \
  "$here/campaign-array.sbatch")
array=${array%%;*}
merge=$(sbatch --parsable --dependency=afterok:"$array" "$@" \
  --export=ALL,KINCAL="$kincal",OUT="$out",SHARDS="$k" \
  "$here/merge.sbatch")
merge=${merge%%;*}
echo "$array $merge"
