#!/usr/bin/env bash
# The Slurm recipe (scripts/slurm-submit.sh) against a real single-node Slurm (issue #15).
#
# Starts munged, slurmctld and slurmd by hand (no systemd, no cgroups: proctrack/linuxproc,
# task/none, no accounting), private to this run (own config, ports, state, munge socket, all in a
# temporary directory, on loopback), then for every shardable command (map, placement, ensemble):
#   1. an N-shard array + merge job gives a file byte-identical to the unsharded run;
#   2. recovery: one array task cancelled mid-way (scancel, with rows in its journal), the merge
#      job cancelled with it, the array resubmitted: byte-identical, and the task resumed;
#   3. failure: one task fails (a journal of another job in its way): no merged file, no merge
#      metadata, and the merge job never runs.
# Every daemon it started is stopped on exit (also on failure or Ctrl-C), by its own pid.
#
# Needs root (munged runs as the munge user, slurmd as root) and Debian's packages slurmctld,
# slurmd, slurm-client, munge. With CI=true (and root) it installs them when missing, and an
# unavailable Slurm fails the run; elsewhere it never installs anything: it says which command
# would, and reports the test SKIPPED (exit 0).
#
#   scripts/slurm-test.sh            # uses target/release/vibrobar (build it first)
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
vibrobar=${VIBROBAR:-$repo/target/release/vibrobar}
t_start=$(date +%s.%N)
elapsed() { awk -v a="$1" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }'; }

PKGS=(slurmctld slurmd slurm-client munge)
INSTALL="apt-get install -y --no-install-recommends ${PKGS[*]}"
ci=${CI:-false}

skip() {
    echo "" >&2
    echo "################################################################################" >&2
    echo "## SLURM TESTS SKIPPED: $*" >&2
    echo "################################################################################" >&2
    echo "" >&2
    if [ "$ci" = true ]; then
        echo "slurm-test: CI=true: Slurm must run here; failing" >&2
        exit 1
    fi
    exit 0
}

have_slurm() {
    command -v munged >/dev/null && command -v slurmctld >/dev/null &&
        command -v slurmd >/dev/null && command -v sbatch >/dev/null
}

if [ "$(id -u)" != 0 ]; then
    skip "not root (munged must run as the munge user and slurmd as root)"
fi
if ! have_slurm; then
    if [ "$ci" = true ]; then
        echo "slurm-test: CI=true: installing Debian's Slurm: $INSTALL" >&2
        DEBIAN_FRONTEND=noninteractive apt-get update -qq >&2
        DEBIAN_FRONTEND=noninteractive $INSTALL >&2
    else
        skip "Slurm is not installed; this script never installs system packages outside CI. To install: $INSTALL"
    fi
fi
have_slurm || skip "Slurm still missing after: $INSTALL"
[ -x "$vibrobar" ] || { echo "slurm-test: no binary $vibrobar (cargo build --release)" >&2; exit 1; }

# ---------------------------------------------------------------------------------------------
# A private single-node cluster.
tmp=$(mktemp -d /tmp/vibrobar-slurm.XXXXXX)
chmod 755 "$tmp"
pids=()
cleanup() {
    local rc=$?
    set +e
    # Jobs of this private cluster first (their slurmstepd would outlive slurmd), then the
    # daemons in reverse order: slurmd, slurmctld, munged. TERM, then KILL what is still there.
    if [ ${#pids[@]} -ge 3 ]; then
        scancel --user="$(id -un)" 2>/dev/null
        for _ in $(seq 30); do
            [ -z "$(squeue -h -o %i 2>/dev/null)" ] && break
            sleep 0.1
        done
    fi
    for ((i = ${#pids[@]} - 1; i >= 0; i--)); do kill "${pids[$i]}" 2>/dev/null; done
    for _ in $(seq 50); do
        alive=0
        for p in "${pids[@]}"; do kill -0 "$p" 2>/dev/null && alive=1; done
        [ $alive = 0 ] && break
        sleep 0.1
    done
    for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done
    if [ $rc != 0 ]; then
        echo "slurm-test: FAILED (rc $rc); daemon logs:" >&2
        tail -n 20 "$tmp"/log/*.log >&2 2>/dev/null
    fi
    rm -rf "$tmp"
    exit $rc
}
trap cleanup EXIT
trap 'exit 130' INT TERM

host=$(hostname -s)
# Ports of this run (two runs on one machine must not meet).
base=$((20000 + ($$ % 20000)))
ctld_port=$base slurmd_port=$((base + 1))
mkdir -p "$tmp"/{etc,state,spool,log,run,munge,work}
chown munge:munge "$tmp/munge"
chmod 755 "$tmp/munge"
cpus=$(nproc)
mem_mb=$(awk '/MemTotal/ {print int($2 / 1024)}' /proc/meminfo)
cat >"$tmp/etc/slurm.conf" <<EOF
ClusterName=vbtest$$
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$tmp/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/run/slurmctld.pid
SlurmdPidFile=$tmp/run/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/builtin
SchedulerParameters=kill_invalid_depend,batch_sched_delay=0,sched_min_interval=0
MpiDefault=none
ReturnToService=2
MinJobAge=600
KillWait=2
InactiveLimit=0
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$((mem_mb / 2)) State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$tmp/etc/slurm.conf

# munged: the key of the package, our own socket, run as the munge user.
mkdir -p /run/munge && chown munge:munge /run/munge
runuser -u munge -- /usr/sbin/munged --socket="$tmp/munge/munge.socket" \
    --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/munge/munged.log" \
    --seed-file="$tmp/munge/munged.seed"
for _ in $(seq 50); do [ -s "$tmp/munge/munged.pid" ] && break; sleep 0.1; done
pids+=("$(cat "$tmp/munge/munged.pid")")
slurmctld -D -i -f "$SLURM_CONF" >"$tmp/log/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" -N "$host" >"$tmp/log/slurmd.out" 2>&1 &
pids+=($!)
# Up when the node takes jobs.
up=0
for _ in $(seq 300); do
    state=$(sinfo -h -n "$host" -o %T 2>/dev/null || true)
    case "$state" in idle | mixed | allocated) up=1; break ;; esac
    sleep 0.1
done
if [ $up = 0 ]; then
    echo "slurm-test: the node did not come up (state '${state:-}')" >&2
    [ "$ci" = true ] && exit 1
    skip "Slurm could not be started here (see the daemon logs above)"
fi
t_up=$(elapsed "$t_start")
echo "slurm-test: single-node Slurm up in $t_up s ($cpus CPUs, node $host)" >&2

# ---------------------------------------------------------------------------------------------
# Helpers.
fail() {
    echo "slurm-test: FAIL: $*" >&2
    exit 1
}
job_states() { # the states of every task of a job (array or not), one a line
    scontrol show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p'
}
wait_job() { # wait until no task of job $1 is pending or running (timeout 60 s)
    for _ in $(seq 600); do
        if ! job_states "$1" | grep -qE 'PENDING|RUNNING|CONFIGURING|COMPLETING|SUSPENDED'; then
            return 0
        fi
        sleep 0.1
    done
    fail "job $1 still not finished after 60 s: $(job_states "$1" | tr '\n' ' ')"
}
merge_never_runs() { # the merge job $1 of a failed array: cancelled, or pending forever
    local st reason
    for _ in $(seq 30); do
        st=$(job_states "$1")
        reason=$(scontrol show job "$1" | sed -n 's/.*Reason=\([A-Za-z_]*\).*/\1/p')
        [ "$st" != PENDING ] || [ "$reason" = DependencyNeverSatisfied ] && break
        sleep 0.1
    done
    case "$st/$reason" in
        CANCELLED/* | PENDING/DependencyNeverSatisfied) ;;
        *) fail "merge job $1 should never run after a failed task: state $st, reason $reason" ;;
    esac
    # Pending forever: cancel it, as a user would (kill_invalid_depend does it on its next pass).
    [ "$st" = PENDING ] && scancel "$1"
    echo "$st"
}
submit() { # COMMAND N OUT -- ARGS...: prints "ARRAY MERGE"
    VIBROBAR=$vibrobar MERGE_ARGS=--no-figures "$repo/scripts/slurm-submit.sh" "$@"
}
refused() { # expect the recipe to refuse, with a message matching $1
    local want=$1
    shift
    local err
    if err=$(VIBROBAR=$vibrobar "$repo/scripts/slurm-submit.sh" "$@" 2>&1 >/dev/null); then
        fail "the recipe accepted: $*"
    fi
    grep -q -- "$want" <<<"$err" || fail "the recipe refused '$*' with '$err', expected '$want'"
}

# Tiny runs: a few points, short durations. Each command's arguments (shard count: 3).
declare -A ARGS=(
    [map]="--preset paper --friction none --ratios 0.96:1.04:0.02 --gaps-mm 0.2:0.8:0.2 --duration 0.5"
    [placement]="--friction none --positions-mm 125:175:25 --gaps-mm 0.1:0.2:0.1 --ratios 0.98:1.02:0.04 --solver rk4 --duration 0.03"
    [ensemble]="--friction none --ratios 0.95:1.05:0.05 --gaps-mm 0.5:1.0:0.5 --members 4 --duration 1"
)
# Longer runs for the recovery check: a task must still be working when it is cancelled.
declare -A SLOW=(
    [map]="--preset paper --friction none --ratios 0.96:1.04:0.02 --gaps-mm 0.2:1.0:0.2 --duration 1 --solver rk4"
    [placement]="--friction none --positions-mm 100:175:5 --gaps-mm 0.1:0.2:0.1 --ratios 0.98:1.02:0.04 --solver rk4 --duration 0.2"
    [ensemble]="--friction none --ratios 0.95:1.05:0.02 --gaps-mm 0.5:1.0:0.5 --members 4 --duration 1 --solver rk4"
)
N=3
work=$tmp/work
cd "$work"

t_tests=$(date +%s.%N)
refused "cannot be sharded" sweep 2 x/s.csv -- --preset paper
refused "must be an integer" map 0 x/m.csv -- --preset paper
(
    export ONLY=2-4
    refused "out of range: shards are 1..3" map 3 x/m.csv -- --preset paper
)
refused "do not pass --shard" map 3 x/m.csv -- --preset paper --shard 1/3

for cmd in map placement ensemble; do
    t0=$(date +%s.%N)
    # shellcheck disable=SC2206 # the argument lists above are word lists
    args=(${ARGS[$cmd]})
    # shellcheck disable=SC2206
    slow=(${SLOW[$cmd]})
    "$vibrobar" "$cmd" "${args[@]}" --out "ref/$cmd.csv" >/dev/null 2>&1 ||
        fail "$cmd: the unsharded reference run failed"
    "$vibrobar" "$cmd" "${slow[@]}" --out "ref/$cmd.slow.csv" >/dev/null 2>&1 ||
        fail "$cmd: the unsharded reference run (slow) failed"

    # 1. N shards, merged == unsharded.
    read -r arr mrg < <(submit "$cmd" $N "sharded/$cmd.csv" -- "${args[@]}")
    wait_job "$arr"
    wait_job "$mrg"
    [ "$(job_states "$mrg")" = COMPLETED ] || fail "$cmd: merge job $mrg: $(job_states "$mrg")"
    cmp "sharded/$cmd.csv" "ref/$cmd.csv" || fail "$cmd: $N-shard Slurm run differs from the unsharded run"
    [ "$(job_states "$arr" | sort -u)" = COMPLETED ] || fail "$cmd: array $arr: $(job_states "$arr")"

    t1=$(date +%s.%N)
    # 2. Recovery: cancel task 2 once its journal has a row, then resubmit the whole array.
    out=recover/$cmd.csv
    read -r arr mrg < <(submit "$cmd" $N "$out" -- "${slow[@]}")
    journal=recover/$cmd.2.csv.journal
    for _ in $(seq 600); do
        [ -f "$journal" ] && [ "$(wc -l <"$journal")" -ge 3 ] && break
        sleep 0.05
    done
    [ -f "$journal" ] || fail "$cmd: task 2 never wrote its journal"
    scancel "${arr}_2"
    wait_job "$arr"
    merge_never_runs "$mrg" >/dev/null
    task2=$(scontrol show job "${arr}_2" | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p')
    [ "$task2" = CANCELLED ] || fail "$cmd: task 2 was not killed mid-way (state $task2): make SLOW[$cmd] longer"
    [ ! -e "recover/$cmd.2.csv" ] || fail "$cmd: the cancelled task left a complete-looking shard"
    rows_before=$(($(wc -l <"$journal") - 2))
    [ "$(job_states "$mrg")" != COMPLETED ] || fail "$cmd: merge job ran after a cancelled task"
    [ ! -e "$out" ] || fail "$cmd: a merged file exists after a cancelled task"
    read -r arr mrg < <(submit "$cmd" $N "$out" -- "${slow[@]}")
    wait_job "$arr"
    wait_job "$mrg"
    [ "$(job_states "$mrg")" = COMPLETED ] || fail "$cmd: merge after resubmission: $(job_states "$mrg")"
    cmp "$out" "ref/$cmd.slow.csv" || fail "$cmd: the resumed Slurm run differs from the unsharded run"
    grep -q "resuming" "recover/logs/$cmd.2.out" ||
        fail "$cmd: task 2 did not resume its journal ($(cat "recover/logs/$cmd.2.out"))"
    [ ! -e "$journal" ] || fail "$cmd: journal left behind after a complete run"
    recover_note="task 2 cancelled with $rows_before rows journaled, resumed"
    t2=$(date +%s.%N)

    # 3. Failure: task 2 meets a journal of another job; no merged output, the merge never runs.
    out=fail/$cmd.csv
    mkdir -p fail
    printf '# vibrobar journal v1 fingerprint=0000000000000000\nindex,x\n' >"fail/$cmd.2.csv.journal"
    read -r arr mrg < <(submit "$cmd" $N "$out" -- "${args[@]}")
    wait_job "$arr"
    task2=$(scontrol show job "${arr}_2" | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p')
    [ "$task2" = FAILED ] || fail "$cmd: task 2 should have failed, state $task2"
    mstate=$(merge_never_runs "$mrg")
    [ ! -e "fail/logs/$cmd.merge.out" ] || fail "$cmd: the merge job wrote a log: it ran"
    [ ! -e "$out" ] && [ ! -e "$out.meta.json" ] || fail "$cmd: a merged file exists after a failed task"
    grep -q "journal" "fail/logs/$cmd.2.out" || fail "$cmd: the failed task did not say why: $(cat "fail/logs/$cmd.2.out")"
    echo "slurm-test: $cmd ok: $N shards == unsharded; $recover_note == unsharded; failed task -> merge $mstate, no output ($(elapsed "$t0") s: references+identity $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }') s, recovery $(awk -v a="$t1" -v b="$t2" 'BEGIN { printf "%.1f", b - a }') s, failure $(elapsed "$t2") s)" >&2
done
t_test=$(elapsed "$t_tests")
echo "slurm-test: PASSED: Slurm start-up $t_up s, tests $t_test s, total $(elapsed "$t_start") s" >&2
