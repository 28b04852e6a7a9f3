#!/bin/sh
# The prior term's cost (issue 12 item 7): the baseline and MaterialFusion back to back on one
# test-3d scene, REPEATS times, and MaterialFusion's wall and CPU time by stage (run.json's
# time_split and cpu_split, mf/cli/cmd_recon.c) -> a markdown report.
#
#   tools/sds_cost.sh MF DATA WORK OUT [LABEL=MF_BIN[:MF_ARGS] ...]
#
# MF: the mf binary measured; DATA: the scene folder, made by `MF gen --split test-3d --scenes 1
# --test 4 -o DATA` when missing; WORK: result folders (rewritten); OUT: the report. Each extra
# LABEL=MF_BIN runs MaterialFusion with another binary (and optional extra flags, e.g. an older
# build, or `:--prior-threads 0`) right after MF's run, so each repetition compares runs made under
# the same machine load. Environment: ITERS (default 100), REPEATS (2), THREADS (OMP_NUM_THREADS,
# default 1), CONFIG (baselines/nvdiffrecmc.json), NOTE (a paragraph for the report: what the
# variants are), REPORT_ONLY=1 (no runs: the report again from WORK's run.json files).
set -eu
[ $# -ge 4 ] || { echo "usage: $0 MF DATA WORK OUT [LABEL=MF_BIN[:MF_ARGS] ...]" >&2; exit 2; }
MF=$1 DATA=$2 WORK=$3 OUT=$4
shift 4
ITERS=${ITERS:-100} REPEATS=${REPEATS:-2} THREADS=${THREADS:-1} CONFIG=${CONFIG:-baselines/nvdiffrecmc.json} NOTE=${NOTE:-} REPORT_ONLY=${REPORT_ONLY:-0}
command -v jq >/dev/null || { echo "$0: jq not found (apt-get install jq)" >&2; exit 1; }
[ -x "$MF" ] || { echo "$0: $MF: not an executable mf binary" >&2; exit 1; }
if [ "$REPORT_ONLY" != 1 ] && [ ! -f "$DATA/000_cup/transforms_train.json" ]; then
    "$MF" gen --split test-3d --scenes 1 --test 4 -o "$DATA"
fi
SCENE=$DATA/000_cup
[ "$REPORT_ONLY" = 1 ] || { rm -rf "$WORK"; mkdir -p "$WORK"; }
run() { # label binary method rep [args...]
    l=$1 b=$2 m=$3 r=$4
    shift 4
    OMP_NUM_THREADS=$THREADS "$b" recon "$SCENE" -o "$WORK/$r/$l" --method "$m" --config "$CONFIG" --iters "$ITERS" "$@" \
        > "$WORK/$r-$l.log" 2>&1 || { echo "$0: $b recon ($l, repetition $r) failed: $WORK/$r-$l.log" >&2; exit 1; }
}
r=1
[ "$REPORT_ONLY" = 1 ] && r=$((REPEATS + 1))
while [ "$r" -le "$REPEATS" ]; do
    run baseline "$MF" nvdiffrecmc "$r"
    run materialfusion "$MF" materialfusion "$r"
    for v in "$@"; do
        l=${v%%=*} rest=${v#*=}
        b=${rest%%:*} a=
        [ "$b" = "$rest" ] || a=${rest#*:}
        # shellcheck disable=SC2086
        run "$l" "$b" materialfusion "$r" $a
    done
    r=$((r + 1))
done
[ "$REPORT_ONLY" = 1 ] || echo "$(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores" > "$WORK/loadavg"

# ---- the report ----
j() { jq -r "$2" "$WORK/$1/run.json"; }
tmp=$OUT.tmp
{
    echo "# The prior term's cost (issue 12 item 7)"
    echo
    echo "Written by \`tools/sds_cost.sh\` (\`make bench-sds-cost\`): test-3d/000_cup, $ITERS iterations of"
    echo "\`--config $CONFIG\`, OMP_NUM_THREADS=$THREADS, $REPEATS repetitions; in each, the baseline and"
    echo "MaterialFusion (and the variants below) ran back to back. Revision $(j 1/materialfusion .git_revision)."
    echo "Load average at the end of the runs: $(cat "$WORK/loadavg" 2>/dev/null || echo unknown)."
    echo
    if [ -n "$NOTE" ]; then
        echo "$NOTE"
        echo
    fi
    echo "## MaterialFusion / baseline, per repetition"
    echo
    echo "| repetition | run | wall s | CPU s | wall / baseline | CPU / baseline | prior term share of wall |"
    echo "|---:|---|---:|---:|---:|---:|---:|"
    r=1
    while [ "$r" -le "$REPEATS" ]; do
        bw=$(j "$r/baseline" .wall_seconds) bc=$(j "$r/baseline" .options.cpu_seconds)
        for d in "$WORK/$r"/*/; do
            l=$(basename "$d")
            w=$(j "$r/$l" .wall_seconds) c=$(j "$r/$l" .options.cpu_seconds)
            p=$(j "$r/$l" '[.options.time_split | to_entries[] | select(.key | startswith("prior_")) | .value] | add // 0')
            awk -v r="$r" -v l="$l" -v w="$w" -v c="$c" -v bw="$bw" -v bc="$bc" -v p="$p" 'BEGIN {
                printf "| %s | %s | %.1f | %.1f | %.2f | %.2f | %.0f%% |\n", r, l, w, c, w / bw, c / bc, 100 * p / w }'
        done
        r=$((r + 1))
    done
    echo
    echo "## Stages (mean over the repetitions; seconds)"
    echo
    echo "Disjoint stages of run.json's time_split (wall) and cpu_split (CPU of the process). image: the"
    echo "baseline's own render, loss and adjoint of the batch's views; prior_*: the SDS term (cond: condition"
    echo "images and cameras; aov: material AOV render; encode: Enc(maps); denoise: noising and 5 guided DDIM"
    echo "steps with CFG, batch 2K; decode: D(zhat); encoder_backward: the gradient through the encoder;"
    echo "aov_backward: through the AOV render; apply: the held gradient added every iteration)."
    echo
    labels=$(for d in "$WORK/1"/*/; do basename "$d"; done)
    printf "| stage |"
    for l in $labels; do printf " %s wall | %s CPU |" "$l" "$l"; done
    echo
    printf "|---|"
    for l in $labels; do printf -- "---:|---:|"; done
    echo
    keys=$(j 1/materialfusion '.options.time_split | keys_unsorted[]')
    for k in $keys total; do
        printf "| %s |" "$k"
        for l in $labels; do
            for s in time_split cpu_split; do
                sum=0
                r=1
                while [ "$r" -le "$REPEATS" ]; do
                    if [ "$k" = total ]; then
                        f=.wall_seconds
                        [ "$s" = cpu_split ] && f=.options.cpu_seconds
                        v=$(j "$r/$l" "$f")
                    else
                        v=$(j "$r/$l" ".options.$s.$k // 0")
                    fi
                    sum=$(awk -v a="$sum" -v b="$v" 'BEGIN { print a + b }')
                    r=$((r + 1))
                done
                awk -v s="$sum" -v n="$REPEATS" 'BEGIN { printf " %.2f |", s / n }'
            done
        done
        echo
    done
    echo
    echo "The machine is shared (2 cores, other agents' builds and benchmarks): wall times include the"
    echo "time other processes held the cores; CPU seconds do not, and are the better basis for before/after"
    echo "ratios. Results are compared byte for byte separately (albedo.png, orm.png, env.exr):"
    r=1
    while [ "$r" -le "$REPEATS" ]; do
        for d in "$WORK/$r"/*/; do
            l=$(basename "$d")
            [ "$l" = baseline ] || [ "$l" = materialfusion ] && continue
            same=yes
            for f in albedo.png orm.png env.exr; do cmp -s "$WORK/$r/materialfusion/$f" "$WORK/$r/$l/$f" || same=no; done
            echo "- repetition $r: $l's textures and env identical to materialfusion's: $same"
        done
        r=$((r + 1))
    done
    echo
    echo "Commands:"
    echo
    for d in "$WORK/1"/*/; do
        echo "    $(jq -r '.argv | join(" ")' "$d/run.json")  # $(basename "$d"), OMP_NUM_THREADS=$THREADS"
    done
} > "$tmp"
mv "$tmp" "$OUT"
echo "$0: wrote $OUT"
