#!/usr/bin/env bash
# Run any shardable vibrobar batch command as a Slurm job array, then merge the shards.
#
#   scripts/slurm-submit.sh COMMAND N OUT.csv -- ARGS...
#
#   scripts/slurm-submit.sh map 64 maps/map.csv -- --preset paper --friction none \
#       --ratios 0.9:1.1:0.001 --gaps-mm 0.01:1:0.01 --solver rk4
#
# Submits an array of N tasks; task K (= SLURM_ARRAY_TASK_ID, 1..N) runs
#     vibrobar COMMAND ARGS --shard K/N --resume --out DIR/STEM.K.csv
# and a merge job (--dependency=afterok:<array>) that runs
#     vibrobar merge --out OUT.csv DIR/STEM.1.csv ... DIR/STEM.N.csv
# The merged file is byte-identical to `vibrobar COMMAND ARGS --out OUT.csv` on one machine.
# Prints "ARRAY_JOB_ID MERGE_JOB_ID" on stdout (everything else goes to stderr).
#
# Resubmitting the same command after a task was killed (time limit, preemption, scancel) resumes
# it: every task runs with --resume, which keeps the rows in DIR/STEM.K.csv.journal. Resubmit
# only some tasks with ONLY=5,17. A failed task leaves no merged file: the merge job's afterok
# dependency can never be satisfied (Slurm cancels it with SchedulerParameters=kill_invalid_depend,
# otherwise it stays pending with reason DependencyNeverSatisfied: scancel it).
#
# Environment: VIBROBAR (the binary; default: `vibrobar` on PATH, resolved here so the nodes run
# the same file), CPUS (CPUs per task, default 1; RAYON_NUM_THREADS follows it), TIME (time limit
# per task, default 02:00:00), MERGE_TIME (default 00:20:00), SBATCH_ARGS (extra sbatch options
# for both jobs, e.g. "--partition=long --account=me"), MERGE_ARGS (extra merge flags, e.g.
# --no-figures), ONLY (array indices to (re)submit, default 1-N).
set -euo pipefail

# The shardable commands: every one takes --shard K/N, --resume and --out, and `merge` joins its
# shards. A new batch command (e.g. `lobes` once it shards) is one more word here.
SHARDABLE=(map placement ensemble)

usage() {
    echo "usage: $0 COMMAND N OUT.csv -- ARGS...   (COMMAND one of: ${SHARDABLE[*]})" >&2
    exit 2
}
die() {
    echo "slurm-submit: $*" >&2
    exit 2
}

[ $# -ge 3 ] || usage
cmd=$1 n=$2 out=$3
shift 3
if [ $# -gt 0 ]; then
    [ "$1" = "--" ] || die "expected -- before the command's arguments, got '$1'"
    shift
fi
args=("$@")

ok=0
for c in "${SHARDABLE[@]}"; do [ "$c" = "$cmd" ] && ok=1; done
[ $ok = 1 ] || die "'$cmd' cannot be sharded (no --shard/--resume/merge); shardable commands: ${SHARDABLE[*]}"
[[ "$n" =~ ^[1-9][0-9]*$ ]] || die "N (number of shards) must be an integer >= 1, got '$n'"
[[ "$out" == *.csv ]] || die "OUT must be a .csv file, got '$out'"
for a in "${args[@]}"; do
    case "$a" in
        --shard | --shard=* | --out | --out=* | --resume | --threads | --threads=*)
            die "do not pass $a in ARGS: the recipe sets --shard, --out, --resume and the threads" ;;
    esac
done

only=${ONLY:-1-$n}
# Every index of ONLY must be a shard 1..N: a task outside it would compute nothing useful.
for part in ${only//,/ }; do
    [[ "$part" =~ ^([0-9]+)(-([0-9]+))?$ ]] || die "ONLY: '$part' is not an index or a range A-B"
    lo=${BASH_REMATCH[1]} hi=${BASH_REMATCH[3]:-${BASH_REMATCH[1]}}
    if [ "$lo" -lt 1 ] || [ "$hi" -gt "$n" ] || [ "$lo" -gt "$hi" ]; then
        die "ONLY: shard index range '$part' out of range: shards are 1..$n"
    fi
done

vibrobar=${VIBROBAR:-$(command -v vibrobar || true)}
[ -n "$vibrobar" ] && [ -x "$vibrobar" ] || die "no vibrobar binary: put it on PATH or set VIBROBAR"
vibrobar=$(cd "$(dirname "$vibrobar")" && pwd)/$(basename "$vibrobar")

dir=$(dirname "$out")
stem=$(basename "$out" .csv)
mkdir -p "$dir/logs"
dir=$(cd "$dir" && pwd)
shard_file() { echo "$dir/$stem.$1.csv"; }

# Quote every word for the batch scripts (arguments may hold spaces or quotes).
q_args=""
[ ${#args[@]} -eq 0 ] || q_args=$(printf '%q ' "${args[@]}")
shards=""
for ((k = 1; k <= n; k++)); do shards+=" $(printf '%q' "$(shard_file "$k")")"; done

cpus=${CPUS:-1}
# shellcheck disable=SC2086 # SBATCH_ARGS is a list of options
array_job=$(sbatch --parsable ${SBATCH_ARGS:-} \
    --job-name="vibrobar-$cmd" --array="$only" --cpus-per-task="$cpus" \
    --time="${TIME:-02:00:00}" --output="$dir/logs/$stem.%a.out" <<SBATCH
#!/usr/bin/env bash
set -euo pipefail
k=\${SLURM_ARRAY_TASK_ID:?not a Slurm array task}
# N is fixed here, not SLURM_ARRAY_TASK_COUNT: a resubmission of some indices keeps N.
if [ "\$k" -lt 1 ] || [ "\$k" -gt $n ]; then
    echo "array index \$k out of range: shards are 1..$n" >&2
    exit 2
fi
export RAYON_NUM_THREADS=\${SLURM_CPUS_PER_TASK:-1}
exec $(printf '%q' "$vibrobar") $(printf '%q' "$cmd") $q_args --shard "\$k/$n" --resume \\
    --out $(printf '%q' "$dir/$stem").\$k.csv
SBATCH
)
array_job=${array_job%%;*}

# shellcheck disable=SC2086
merge_job=$(sbatch --parsable ${SBATCH_ARGS:-} \
    --job-name="vibrobar-merge-$cmd" --dependency="afterok:$array_job" --cpus-per-task=1 \
    --time="${MERGE_TIME:-00:20:00}" --output="$dir/logs/$stem.merge.out" <<SBATCH
#!/usr/bin/env bash
set -euo pipefail
exec $(printf '%q' "$vibrobar") merge ${MERGE_ARGS:-} --out $(printf '%q' "$dir/$stem.csv")$shards
SBATCH
)
merge_job=${merge_job%%;*}

echo "submitted $cmd: array job $array_job (tasks $only of $n) and merge job $merge_job -> $dir/$stem.csv; logs in $dir/logs" >&2
echo "$array_job $merge_job"
