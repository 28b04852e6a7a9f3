#!/bin/sh
# make bench-adaptive: issue 16's adaptive default. The baseline at its default budget
# (A_CONFIG) and the same with each set of budget flags (A_CONFIGS, "name=flags;name=flags"), on
# every scene of the validation split (val-3d: where a default may be chosen) and of the test split
# (test-3d: where the choice is checked). Each scene's runs go back to back, so a shared machine's
# load falls on them alike. Then mf eval (every test view, its protocol) and eval/adaptive.py: per
# split and flag set, the loop's wall time over the default's and the PSNR differences, paired
# over the scenes (mean, 95% CI), against the target: the default's quality within 0.2 dB in at
# most 0.5x its time, or better quality in at most its time.
# Resumable: every run is `mf recon --resume`; a run with a run.json is not redone.
#
# Environment (all optional): MF, DATA (the folder of the splits), RESULTS, OUT, SPLITS, A_CONFIG, A_CONFIGS,
# A_TIME_REF ("REF:name,name ...": flag sets timed against REF, a re-run of the default made beside
# them in a later sitting; its outputs must equal the default's; REF must be in A_CONFIGS to be run).
set -eu
MF=${MF:-build/mf}
DATA=${DATA:-data}
RESULTS=${RESULTS:-results/adaptive}
OUT=${OUT:-reports/adaptive}
SPLITS=${SPLITS:-"val-3d test-3d"}
A_CONFIG=${A_CONFIG:-baselines/nvdiffrecmc.json}
A_CONFIGS=${A_CONFIGS:-"adaptive=--early-stop --metal-auto --tex-auto;spp1=--spp 1;sppgrow=--spp-grow;envauto=--env-auto;\
combo=--early-stop --metal-auto --tex-auto --spp-grow;spp4i200=--spp 4 --iters 200;spp4i100=--spp 4 --iters 100;\
sg200=--spp-grow --iters 200;env32=--env-w 32 --env-h 16;env16=--env-w 16 --env-h 8;tv003=--w-env-tv 0.03;tv03=--w-env-tv 0.3"}

recon() { # recon RUN_DIR SCENE_DIR ARGS...: one resumable run; a failed one is named and skipped
    d=$1 sd=$2
    shift 2
    [ -f "$d/run.json" ] && return 0
    mkdir -p "$(dirname "$d")"
    echo "bench-adaptive: $d"
    "$MF" recon "$sd" -o "$d" --config "$A_CONFIG" --method nvdiffrecmc --resume "$@" >"$d.log" 2>&1 ||
        { echo "bench-adaptive: $d failed (log: $d.log; not in the report)"; tail -3 "$d.log"; }
}

for sp in $SPLITS; do
    [ -d "$DATA/$sp" ] || { echo "bench-adaptive: $DATA/$sp missing (make data-$sp)" >&2; exit 1; }
    for sd in "$DATA/$sp"/*/; do
        [ -f "$sd/transforms_train.json" ] || continue
        s=$(basename "$sd")
        recon "$RESULTS/$sp/default/$s" "$sd"
        echo "$A_CONFIGS" | tr ';' '\n' | while IFS='=' read -r name flags; do
            # shellcheck disable=SC2086 # the flags are split into words
            [ -n "$name" ] && recon "$RESULTS/$sp/$name/$s" "$sd" $flags
        done
    done
done
names="default,$(echo "$A_CONFIGS" | tr ';' '\n' | sed -n 's/=.*//p' | paste -sd, -)"
for sp in $SPLITS; do
    if [ -f "$OUT/$sp/scenes.csv" ] && [ -z "$(find "$RESULTS/$sp" -name run.json -newer "$OUT/$sp/scenes.csv")" ]; then
        echo "bench-adaptive: $OUT/$sp is up to date"
    else
        "$MF" eval "$DATA/$sp" --results "$RESULTS/$sp" --methods "$names" --dataset "$sp" --no-curves --no-geom -o "$OUT/$sp"
    fi
done
refs=""
for t in ${A_TIME_REF:-}; do refs="$refs --time-reference $t"; done
# shellcheck disable=SC2086 # one word per --time-reference argument
python3 eval/adaptive.py --results "$RESULTS" --out "$OUT" --splits "$SPLITS" --configs "$A_CONFIGS" --config "$A_CONFIG" $refs
