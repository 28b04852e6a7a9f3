#!/bin/sh
# make test-slurm: the bench through a real Slurm (tools/slurm-bench.sh). Starts a one-node Slurm
# on localhost as the current user (munged with a fresh key, slurmctld and slurmd, their config,
# sockets, state and logs in a temp folder; shut down at the end) and runs the tiny bench through
# `make bench-split SCHED=slurm` with the README's settings (MF_SLURM_CPUS/MEM/TIME). Checks:
#  - SCHED=slurm without sbatch on PATH fails with a message naming sbatch and submits nothing;
#  - the cluster run's metrics (scenes.csv, per_view.csv; timings and memory excluded) equal a
#    local run's (make bench-split SCHED=local, same thread count);
#  - a task that fails (a method with a bad flag; one with a partial result folder) is named FAILED
#    in cluster.md, the eval job exits non-zero, and the other tasks are still scored;
#  - a second submission skips the complete tasks and its eval job alone succeeds.
# Where the packages are missing or the daemons cannot start it prints why, then
# "test-slurm: SKIPPED" (exit 0). Run from the repository root; TEST_SLURM_KEEP=1 keeps the temp
# folder.
set -u
MAKE=${MAKE:-make}
T=$(mktemp -d "${TMPDIR:-/tmp}/mf-test-slurm.XXXXXX") || exit 1
chmod 711 "$T" # munged needs its socket's folders searchable by all
started=0
pids='' # of the daemons this script started (from their pid files)

cleanup() {
    for f in "$T/slurmctld.pid" "$T/slurmd.pid" "$T/munge/munged.pid"; do
        [ -s "$f" ] && pids="$pids $(cat "$f")"
    done
    if [ "$started" = 1 ]; then
        scancel --quiet --user="$(id -un)" 2>/dev/null
        i=0 # the jobs' step daemons end with their jobs: wait for that before the daemons go
        while [ -n "$(squeue -h 2>/dev/null)" ] && [ $i -lt 60 ]; do sleep 0.5; i=$((i + 1)); done
        scontrol shutdown >/dev/null 2>&1
    fi
    [ -s "$T/munge/munged.pid" ] && kill "$(cat "$T/munge/munged.pid")" 2>/dev/null
    for p in $pids; do # wait until each has exited, then make sure
        i=0
        while kill -0 "$p" 2>/dev/null && [ $i -lt 20 ]; do sleep 0.5; i=$((i + 1)); done
        kill -9 "$p" 2>/dev/null
    done
    if [ "${TEST_SLURM_KEEP:-0}" = 1 ]; then echo "test-slurm: kept $T"; else rm -rf "$T"; fi
}
trap cleanup EXIT
trap 'exit 1' INT TERM

fail() { echo "test-slurm: FAILED: $*"; exit 1; }
skip() { echo "test-slurm: $*"; echo "test-slurm: SKIPPED"; exit 0; }
pass() { echo "test-slurm: ok: $*"; }

# the tiny bench: 3 scenes of the tiny split, the quick budget cut to 20 iterations
bench() {
    OMP_NUM_THREADS=1 MF_SLURM_CPUS=1 MF_SLURM_MEM=1G MF_SLURM_TIME=10 \
        $MAKE --no-print-directory bench-split BENCH_SPLIT=tiny DATA="$T/data" \
        RECON_CONFIG=baselines/quick.json RECON_EXTRA="--iters 20" FLAGS_broken="--no-such-option 1" "$@"
}
# metric rows of a report's CSV ($1), timings and memory left out, $2: rows to keep (regex)
metrics() { grep -v -E ',(time_s|time_x|mem_mb|prior_share),' "$1" | grep -E "$2" | sort; }
same_metrics() { # $1 $2 report folders, $3 rows
    for f in scenes.csv per_view.csv; do
        [ -s "$1/$f" ] && [ -s "$2/$f" ] || fail "$1/$f or $2/$f missing"
        metrics "$1/$f" "$3" > "$T/a.csv"
        metrics "$2/$f" "$3" > "$T/b.csv"
        [ "$(wc -l < "$T/a.csv")" -gt 10 ] || fail "$1/$f: too few metric rows"
        cmp -s "$T/a.csv" "$T/b.csv" || { diff "$T/a.csv" "$T/b.csv" | head -n 5; fail "$f of $1 and $2 differ"; }
    done
}
# waits for job $1 to end, prints its JobState
wait_job() {
    i=0
    while [ $i -lt 600 ]; do
        st=$(scontrol show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p')
        case $st in PENDING | RUNNING | CONFIGURING | COMPLETING | "") ;; *) echo "$st"; return ;; esac
        sleep 1
        i=$((i + 1))
    done
    echo TIMEOUT
}

echo "test-slurm: tiny data"
$MAKE --no-print-directory data-tiny DATA="$T/data" > "$T/data.log" 2>&1 || { tail -n 5 "$T/data.log"; fail "make data-tiny"; }

# no sbatch on PATH: nothing submitted, a message, non-zero exit (make itself by its full path)
make_path=$(command -v "$MAKE") || fail "$MAKE not found"
out=$(PATH=/nonexistent "$make_path" --no-print-directory bench-split SCHED=slurm BENCH_SPLIT=tiny DATA="$T/data" RESULTS="$T/res-x" REPORT="$T/rep-x" 2>&1) &&
    fail "SCHED=slurm without sbatch exited 0"
echo "$out" | grep -q "sbatch not found on PATH: nothing submitted" || fail "no clear message without sbatch: $out"
[ ! -e "$T/res-x" ] || fail "SCHED=slurm without sbatch wrote $T/res-x"
pass "SCHED=slurm without sbatch: $(echo "$out" | tail -n 1)"

for b in munged munge slurmctld slurmd sbatch squeue scontrol scancel sinfo; do
    command -v "$b" >/dev/null 2>&1 || skip "$b not found (make deps installs Debian's slurm-wlm and munge)"
done

# munge: a fresh key, socket and logs in $T
mkdir -m 711 "$T/munge" "$T/state" "$T/spool" "$T/log"
dd if=/dev/urandom of="$T/munge/munge.key" bs=1024 count=1 2>/dev/null && chmod 400 "$T/munge/munge.key"
munged --key-file="$T/munge/munge.key" --socket="$T/munge/sock" --pid-file="$T/munge/munged.pid" \
    --log-file="$T/munge/munged.log" --seed-file="$T/munge/seed" > "$T/munge/start.log" 2>&1 ||
    skip "munged does not start here: $(tail -n 2 "$T/munge/start.log" "$T/munge/munged.log" 2>/dev/null | tr '\n' ' ')"
munge -n -S "$T/munge/sock" | unmunge -S "$T/munge/sock" > /dev/null 2>&1 || skip "munge credentials do not round-trip"

# one node, this host, as the current user; ports from the PID so parallel runs do not collide
host=$(hostname -s)
user=$(id -un)
port=$((20000 + $$ % 20000))
mem_mb=$(awk '/^MemTotal/ { print int($2 / 2048) }' /proc/meminfo)
cat > "$T/slurm.conf" << EOF
ClusterName=mftest
SlurmctldHost=$host(127.0.0.1)
SlurmUser=$user
SlurmdUser=$user
SlurmctldPort=$port
SlurmdPort=$((port + 1))
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$T/munge/sock
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/log/slurmctld.log
SlurmdLogFile=$T/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
SlurmdParameters=config_overrides
ReturnToService=2
MpiDefault=none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) RealMemory=$mem_mb State=UNKNOWN
PartitionName=mftest Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$T/slurm.conf"
started=1
slurmctld > "$T/log/slurmctld.start" 2>&1 || skip "slurmctld does not start: $(tail -n 3 "$T/log/slurmctld.start" "$T/log/slurmctld.log" 2>/dev/null | tr '\n' ' ')"
slurmd -N "$host" > "$T/log/slurmd.start" 2>&1 || skip "slurmd does not start: $(tail -n 3 "$T/log/slurmd.start" "$T/log/slurmd.log" 2>/dev/null | tr '\n' ' ')"
i=0
until [ "$(sinfo -h -o %T 2>/dev/null)" = idle ]; do
    i=$((i + 1))
    [ $i -lt 60 ] || skip "the node did not come up in 30 s (sinfo: $(sinfo -h -o '%T %E' 2>&1)): $(tail -n 3 "$T/log/slurmctld.log" "$T/log/slurmd.log" 2>/dev/null | tr '\n' ' ')"
    sleep 0.5
done
timeout 60 sbatch --wait --output=/dev/null --wrap true > "$T/log/smoke.log" 2>&1 ||
    skip "a trivial job does not run: $(tail -n 2 "$T/log/smoke.log" "$T/log/slurmd.log" | tr '\n' ' ')"
pass "one-node Slurm up ($(sinfo -V), node $host, $(nproc) CPUs), a trivial job runs"

# the cluster run (with a method whose every task fails; one of them left a partial result folder
# behind, as a task killed by its time limit does), and meanwhile the same bench here
mkdir -p "$T/res-s/tiny/broken/000_cup" && echo "iter,wall_s" > "$T/res-s/tiny/broken/000_cup/log.csv"
out=$(bench SCHED=slurm RESULTS="$T/res-s" REPORT="$T/rep-s" BENCH_METHODS="nvdiffrecmc materialfusion broken" 2>&1) ||
    { echo "$out"; fail "make bench-split SCHED=slurm"; }
echo "$out" | tail -n 1
ev=$(echo "$out" | sed -n 's/.* with 9 of 9 tasks (0 complete, skipped), eval job \([0-9]*\) after it.*/\1/p')
[ -n "$ev" ] || fail "expected an array of 9 tasks and an eval job: $out"
bench SCHED=local RESULTS="$T/res-l" REPORT="$T/rep-l" BENCH_METHODS="nvdiffrecmc materialfusion" > "$T/local.log" 2>&1 ||
    { tail -n 5 "$T/local.log"; fail "make bench-split SCHED=local"; }
st=$(wait_job "$ev")
[ "$st" = FAILED ] || fail "eval job $ev: state $st, expected FAILED (three tasks failed)"
for s in 000_cup 001_vase 002_bottle; do
    grep -q "^| broken | $s | \*\*FAILED\*\* (task [0-9]*, exit 2) |" "$T/rep-s/cluster.md" || fail "cluster.md does not name broken on $s as failed"
    grep -q "^| nvdiffrecmc | $s | complete |" "$T/rep-s/cluster.md" || fail "cluster.md: nvdiffrecmc on $s not complete"
done
pass "the failed tasks are named in cluster.md, eval job $ev $st"
same_metrics "$T/rep-l" "$T/rep-s" '^(nvdiffrecmc|materialfusion|trivial-grey|trivial-flat-light),'
pass "cluster and local reports: the same metrics ($(wc -l < "$T/a.csv") per-view rows)"

# resubmission: the complete tasks are skipped, the eval job runs alone
out=$(bench SCHED=slurm RESULTS="$T/res-s" REPORT="$T/rep-s2" BENCH_METHODS="nvdiffrecmc materialfusion" SCENE_LIMIT=1 2>&1) ||
    { echo "$out"; fail "second make bench-split SCHED=slurm"; }
ev=$(echo "$out" | sed -n 's/.*array (none) with 0 of 2 tasks (2 complete, skipped), eval job \([0-9]*\) after it.*/\1/p')
[ -n "$ev" ] || fail "expected no array (both tasks complete) and an eval job: $out"
st=$(wait_job "$ev")
[ "$st" = COMPLETED ] || fail "eval job $ev: state $st, expected COMPLETED"
same_metrics "$T/rep-l" "$T/rep-s2" '^(nvdiffrecmc|materialfusion),tiny,000_cup,'
pass "resubmission: complete tasks skipped, eval job $ev $st, the same metrics"
echo "test-slurm: PASSED"
