#!/bin/sh
# tools/slurm-bench.sh: the bench on a Slurm cluster (make bench SCHED=slurm; README "Running the
# full table on a cluster"). The Makefile calls it; it can be called by hand the same way.
#
#   slurm-bench.sh submit --name NAME --mf BIN --data SPLIT_DIR --results DIR --report DIR
#                         --scenes "s1 s2 ..." --method NAME=FLAGS ... [--recon-args ARGS] [--eval-args ARGS]
#     Submits one job array, a task per scene x method (scene-major, as the local bench runs them)
#     whose result is not complete yet (complete: RESULTS/<method>/<scene>/run.json without a
#     "stopped" field; those tasks are skipped), each task running
#       BIN recon SPLIT_DIR/<scene> -o RESULTS/<method>/<scene> FLAGS RECON_ARGS
#     and one job after it (--dependency=afterany) that gathers the complete results and runs
#       BIN eval SPLIT_DIR --results <gathered> --methods m1,m2,... -o REPORT EVAL_ARGS
#     then writes REPORT/cluster.md: every task's state; a failed task is named with its exit
#     status and log, and the eval job exits 1 (after scoring the others). The task list, logs
#     and exit statuses go to RESULTS/.slurm/<submission>/.
#   slurm-bench.sh job NAME DIR -- COMMAND ARGS...   submits one job running COMMAND in the current
#     directory (its log: DIR/.slurm/<submission>/NAME.out).
#   slurm-bench.sh check                          exits 1 with a message when sbatch is not on PATH.
#   slurm-bench.sh task DIR | gather DIR | run CMD...   what those jobs run (inside Slurm).
#
# Settings (environment): MF_SLURM_CPUS cpus per task (default 2; OMP_NUM_THREADS is set to it,
# so a task's bytes equal a local run's with that many threads), MF_SLURM_TIME (--time of a
# task, e.g. 0:30:00), MF_SLURM_EVAL_TIME (--time of the eval job and of `job` jobs; default
# MF_SLURM_TIME), MF_SLURM_MEM (--mem, e.g. 1G), MF_SLURM_ARGS (more sbatch options for every
# job, e.g. "--partition=cpu --account=lab"). Exit status: 0 submitted, 1 nothing submitted (or, for
# submit, only the array: the message says what to do).
set -eu

die() { echo "slurm-bench: $*" >&2; exit 1; }
# $1 quoted for sh (job.env is sourced by the jobs)
q() { printf "'%s'" "$(printf '%s' "$1" | sed "s/'/'\\\\''/g")"; }
abs() { case $1 in /*) printf '%s' "$1" ;; *) printf '%s/%s' "$(pwd)" "$1" ;; esac; }
# a result folder is complete when its run.json exists and records no stop
is_complete() { [ -f "$1/run.json" ] && ! grep -q '"stopped"' "$1/run.json"; }

check() {
    command -v sbatch >/dev/null 2>&1 ||
        die "sbatch not found on PATH: nothing submitted (SCHED=slurm needs a Slurm login node; without SCHED the bench runs on this machine)"
}

# sbatch options every job gets; $1: cpus, $2: time limit (may be empty)
sbatch_opts() {
    printf -- '--cpus-per-task=%s' "$1"
    [ -z "$2" ] || printf ' --time=%s' "$2"
    [ -z "${MF_SLURM_MEM:-}" ] || printf ' --mem=%s' "$MF_SLURM_MEM"
    [ -z "${MF_SLURM_ARGS:-}" ] || printf ' %s' "$MF_SLURM_ARGS"
}

# submission folder under $1/.slurm/, printed
new_sub() {
    d=$1/.slurm/$(date -u +%Y%m%dT%H%M%SZ)-$$
    mkdir -p "$d" || die "$d: cannot create"
    printf '%s' "$d"
}

submit() {
    name='' mf='' data='' results='' report='' scenes='' methods='' recon='' evalargs=''
    while [ $# -gt 0 ]; do
        [ $# -ge 2 ] || die "submit: $1 needs a value"
        case $1 in
        --name) name=$2 ;; --mf) mf=$2 ;; --data) data=$2 ;; --results) results=$2 ;; --report) report=$2 ;;
        --scenes) scenes=$2 ;; --recon-args) recon=$2 ;; --eval-args) evalargs=$2 ;;
        --method) methods="$methods$2
" ;;
        *) die "submit: unknown option $1" ;;
        esac
        shift 2
    done
    check
    for v in name mf data results report scenes methods; do
        eval "[ -n \"\$$v\" ]" || die "submit: --$v is required"
    done
    [ -x "$mf" ] || die "$mf: no mf binary (make all builds it)"
    [ -d "$data" ] || die "$data: no such split folder"
    cpus=${MF_SLURM_CPUS:-2}
    case $cpus in '' | *[!0-9]* | 0) die "MF_SLURM_CPUS=$cpus: expected a positive integer" ;; esac
    mf=$(abs "$mf") data=$(abs "$data") results=$(abs "$results") report=$(abs "$report")
    mkdir -p "$results" || die "$results: cannot create"
    sub=$(new_sub "$results")
    mlist=$(printf '%s' "$methods" | sed 's/=.*//' | paste -sd, -)
    set -f # scene names and flags are words, never patterns
    for s in $scenes; do
        printf '%s' "$methods" | while IFS= read -r mf_line; do
            printf '%s %s %s\n' "${mf_line%%=*}" "$s" "${mf_line#*=}"
        done
    done > "$sub/all.txt"
    : > "$sub/todo.txt"
    while read -r m s _; do
        is_complete "$results/$m/$s" || grep -m1 "^$m $s " "$sub/all.txt" >> "$sub/todo.txt"
    done < "$sub/all.txt"
    set +f
    total=$(wc -l < "$sub/all.txt") n=$(wc -l < "$sub/todo.txt")
    {
        echo "MF=$(q "$mf")"; echo "DATA=$(q "$data")"; echo "RESULTS=$(q "$results")"; echo "REPORT=$(q "$report")"
        echo "RECON_ARGS=$(q "$recon")"; echo "EVAL_ARGS=$(q "$evalargs")"; echo "METHODS=$(q "$mlist")"
    } > "$sub/job.env"
    self=$(abs "$0")
    opts=$(sbatch_opts "$cpus" "${MF_SLURM_TIME:-}")
    arr='' dep=''
    if [ "$n" -gt 0 ]; then
        # shellcheck disable=SC2086 # opts are words
        arr=$(sbatch --parsable --job-name="mf-$name" --array="0-$((n - 1))" --output="$sub/task-%a.out" $opts "$self" task "$sub") ||
            die "$name: sbatch refused the array: nothing submitted"
        arr=${arr%%;*} dep="--dependency=afterany:$arr"
    fi
    # shellcheck disable=SC2086,SC2046
    ev=$(sbatch --parsable --job-name="mf-$name-eval" $dep --output="$sub/eval.out" $(sbatch_opts "$cpus" "${MF_SLURM_EVAL_TIME:-${MF_SLURM_TIME:-}}") \
        "$self" gather "$sub") ||
        die "$name: array ${arr:-(none)} submitted, the eval job refused: rerun the same make command once the array is done"
    ev=${ev%%;*}
    printf 'array=%s\neval=%s\n' "$arr" "$ev" > "$sub/jobs"
    echo "slurm-bench: $name: array ${arr:-(none)} with $n of $total tasks ($((total - n)) complete, skipped), eval job $ev after it -> $report (logs: $sub)"
}

task() {
    sub=$1
    . "$sub/job.env"
    i=${SLURM_ARRAY_TASK_ID:?task: not inside a Slurm job array}
    set -f
    # shellcheck disable=SC2046
    set -- $(sed -n "$((i + 1))p" "$sub/todo.txt")
    m=$1 s=$2
    shift 2
    out=$RESULTS/$m/$s
    if is_complete "$out"; then
        echo "task $i: $m on $s: already complete, skipped"
        echo 0 > "$sub/task-$i.rc"
        exit 0
    fi
    OMP_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}
    export OMP_NUM_THREADS
    echo "task $i: $m on $s ($OMP_NUM_THREADS threads on $(hostname)): $MF recon $DATA/$s -o $out $* $RECON_ARGS"
    rc=0
    # shellcheck disable=SC2086
    "$MF" recon "$DATA/$s" -o "$out" "$@" $RECON_ARGS || rc=$?
    echo "$rc" > "$sub/task-$i.rc"
    exit "$rc"
}

gather() {
    sub=$1
    . "$sub/job.env"
    g=$sub/gathered
    rm -rf "$g" && mkdir -p "$g" "$REPORT"
    failed=0
    {
        echo "# Cluster run"
        echo
        echo "Written by tools/slurm-bench.sh (make bench SCHED=slurm): job array $(sed -n 's/^array=//p' "$sub/jobs" 2>/dev/null),"
        echo "eval job ${SLURM_JOB_ID:-}; task list, logs and exit statuses in $sub."
        echo
        echo "| method | scene | state | log |"
        echo "|---|---|---|---|"
        while read -r m s _; do
            a=$(grep -n "^$m $s " "$sub/todo.txt" | head -n 1 | cut -d: -f1)
            log=-
            if [ -n "$a" ]; then
                a=$((a - 1))
                log=$sub/task-$a.out
            fi
            if is_complete "$RESULTS/$m/$s"; then
                mkdir -p "$g/$m" && ln -s "$RESULTS/$m/$s" "$g/$m/$s"
                if [ -z "$a" ]; then state="complete (before this submission)"; else state=complete; fi
            else
                failed=$((failed + 1))
                if [ -n "$a" ] && [ -f "$sub/task-$a.rc" ]; then
                    state="**FAILED** (task $a, exit $(cat "$sub/task-$a.rc"))"
                elif [ -n "$a" ]; then
                    state="**FAILED** (task $a, no exit status: cancelled, or killed by a time or memory limit)"
                else
                    state="**FAILED** (not submitted)"
                fi
                echo "slurm-bench: FAILED: $m on $s: $state, log $log" >&2
            fi
            echo "| $m | $s | $state | $log |"
        done < "$sub/all.txt"
        echo
        echo "$failed of $(wc -l < "$sub/all.txt") tasks failed; the tables of this folder score the others."
    } > "$REPORT/.cluster.md.tmp"
    mv "$REPORT/.cluster.md.tmp" "$REPORT/cluster.md"
    OMP_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}
    export OMP_NUM_THREADS
    rc=0
    # shellcheck disable=SC2086
    "$MF" eval "$DATA" --results "$g" --methods "$METHODS" -o "$REPORT" $EVAL_ARGS || rc=$?
    [ "$rc" -eq 0 ] || echo "slurm-bench: mf eval exited $rc" >&2
    [ "$failed" -eq 0 ] || { echo "slurm-bench: $failed task(s) failed: see $REPORT/cluster.md" >&2; rc=1; }
    exit "$rc"
}

job() {
    [ $# -ge 4 ] && [ "$3" = -- ] || die "usage: slurm-bench.sh job NAME DIR -- COMMAND ARGS..."
    check
    name=$1 dir=$2
    shift 3
    # make -n runs a recipe line naming $(MAKE) all the same: print the job, submit nothing
    case $(printf '%s' "${MAKEFLAGS:-}" | awk '{ print $1 }') in -* | '') ;; *n*) echo "slurm-bench: make -n: would submit job $name: $*" && return ;; esac
    sub=$(new_sub "$(abs "$dir")")
    # shellcheck disable=SC2046
    id=$(sbatch --parsable --job-name="mf-$name" --output="$sub/$name.out" $(sbatch_opts "${MF_SLURM_CPUS:-2}" "${MF_SLURM_EVAL_TIME:-${MF_SLURM_TIME:-}}") "$(abs "$0")" run "$@") ||
        die "$name: sbatch refused the job: nothing submitted"
    echo "slurm-bench: $name: job ${id%%;*} -> $sub/$name.out"
}

cmd=${1:-}
[ $# -eq 0 ] || shift
case $cmd in
submit) submit "$@" ;;
task) task "$@" ;;
gather) gather "$@" ;;
check) check ;;
job) job "$@" ;;
run)
    OMP_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}
    export OMP_NUM_THREADS
    exec "$@"
    ;;
*) die "usage: slurm-bench.sh submit|job|check|task|gather|run ... (see the comment at the top of tools/slurm-bench.sh)" ;;
esac
