#!/bin/sh
# make bench-frontier: relit / albedo / ORM PSNR against wall time over a ladder of budgets
# (training resolution x samples per pixel x iterations) for each method on a few test-3d
# scenes, plus rows for the budget flags of mf recon (early_stop, metal_auto, tex_auto).
# Resumable: every run is `mf recon --resume`, a run with a run.json is not redone.
#
# The baseline's iteration ladder comes from one run per (resolution, spp) with snapshots: its
# learning rate depends on the iteration only (lr0 10^(-0.0002 it)), not on the total, so the
# snapshot at iteration I holds the textures and light of an I-iteration run (same seed and
# options); its wall time is the one log.csv records at I. MaterialFusion's SDS weight
# gamma_i = 1 - (i / iters)^p depends on the total, so it gets one run per iteration count.
#
# Environment (all optional): MF, DATA (the split folder), RESULTS, OUT, SCENES, METHODS,
# F_RES, F_SPP, F_ITERS, F_MF_ITERS, F_CONFIG, F_FLAGS (1: the budget-flag rows), F_EVAL_VIEWS, F_EVAL_SPP, F_EVAL_PS.
set -eu
MF=${MF:-build/mf}
DATA=${DATA:-data/test-3d}
RESULTS=${RESULTS:-results/frontier}
OUT=${OUT:-reports/frontier}
SCENES=${SCENES:-"000_cup 001_vase 002_bottle"}
METHODS=${METHODS:-"nvdiffrecmc materialfusion"}
F_RES=${F_RES:-64}
F_SPP=${F_SPP:-2}
F_ITERS=${F_ITERS:-"50 100 200 400"}
F_MF_ITERS=${F_MF_ITERS:-$F_ITERS} # MaterialFusion's ladder (one run per point)
F_CONFIG=${F_CONFIG:-baselines/nvdiffrecmc.json}
F_FLAGS=${F_FLAGS:-1}
# mf eval's protocol, reduced (its defaults: every test view, spp 4, 4 pixel samples): the same
# for every point, so differences between points stay comparable
F_EVAL_VIEWS=${F_EVAL_VIEWS:-4}
F_EVAL_SPP=${F_EVAL_SPP:-2}
F_EVAL_PS=${F_EVAL_PS:-2}
# the default budget of mf recon (baselines/nvdiffrecmc.json) at the ladder's resolution
F_DEFAULT=${F_DEFAULT:-"r64_s2_i400"}

max_iters=0
for i in $F_ITERS; do [ "$i" -gt "$max_iters" ] && max_iters=$i; done
snap=$(echo $F_ITERS | tr ' ' '\n' | awk 'function g(a,b){return b?g(b,a%b):a} {x=g(x,$1)} END{print x}')

recon() { # recon RUN_DIR SCENE ARGS...: one resumable run; a failed one is named and skipped
    d=$1 s=$2
    shift 2
    [ -f "$d/run.json" ] && return 0
    echo "bench-frontier: $d"
    "$MF" recon "$DATA/$s" -o "$d" --config "$F_CONFIG" --resume "$@" >"$d.log" 2>&1 ||
        { echo "bench-frontier: $d failed (log: $d.log; not a point of the report)"; tail -3 "$d.log"; }
}

mkdir -p "$RESULTS/runs" "$OUT"
# cheapest first: the baseline's ladders, the budget flags, then MaterialFusion's ladder
for s in $SCENES; do
    for r in $F_RES; do
        for p in $F_SPP; do
            mkdir -p "$RESULTS/runs/nvdiffrecmc_r${r}_s${p}"
            recon "$RESULTS/runs/nvdiffrecmc_r${r}_s${p}/$s" "$s" --method nvdiffrecmc --res "$r" --spp "$p" \
                --iters "$max_iters" --snapshot-every "$snap" --checkpoint-every "$max_iters"
        done
    done
done
# the budget flags, each alone, on the baseline at the default budget of the ladder
if [ "$F_FLAGS" = 1 ] && [ "$F_DEFAULT" != none ]; then
    r=$(echo "$F_DEFAULT" | sed 's/^r\([0-9]*\)_.*/\1/')
    p=$(echo "$F_DEFAULT" | sed 's/.*_s\([0-9]*\)_.*/\1/')
    i=$(echo "$F_DEFAULT" | sed 's/.*_i\([0-9]*\)$/\1/')
    for s in $SCENES; do
        for f in early-stop metal-auto tex-auto; do
            mkdir -p "$RESULTS/runs/nvdiffrecmc+${f}_r${r}_s${p}_i${i}"
            recon "$RESULTS/runs/nvdiffrecmc+${f}_r${r}_s${p}_i${i}/$s" "$s" --method nvdiffrecmc --res "$r" --spp "$p" \
                --iters "$i" --snapshot-every 0 --checkpoint-every "$i" --"$f"
        done
    done
fi
for m in $METHODS; do
    [ "$m" = nvdiffrecmc ] && continue
    for s in $SCENES; do
        for r in $F_RES; do
            for p in $F_SPP; do
                for i in $F_MF_ITERS; do
                    mkdir -p "$RESULTS/runs/${m}_r${r}_s${p}_i${i}"
                    recon "$RESULTS/runs/${m}_r${r}_s${p}_i${i}/$s" "$s" --method "$m" --res "$r" --spp "$p" \
                        --iters "$i" --snapshot-every 0 --checkpoint-every "$i"
                done
            done
        done
    done
done
# one result folder per budget point (eval's layout), then one mf eval over all of them
python3 eval/frontier.py stage --runs "$RESULTS/runs" --eval "$RESULTS/eval" --iters "$F_ITERS"
methods=$(ls "$RESULTS/eval" | tr '\n' ',' | sed 's/,$//')
"$MF" eval "$DATA" --results "$RESULTS/eval" --methods "$methods" --scenes "$(echo $SCENES | tr ' ' ',')" \
    --max-views "$F_EVAL_VIEWS" --spp "$F_EVAL_SPP" --pixel-samples "$F_EVAL_PS" --no-curves -o "$OUT/eval"
# every point paired with the default budget (mean difference, 95% CI, wins, t-test and sign-test p)
if [ -d "$RESULTS/eval/nvdiffrecmc_$F_DEFAULT" ]; then
    "$MF" compare "$OUT/eval/scenes.csv" --ref "nvdiffrecmc_$F_DEFAULT" -o "$OUT/paired"
fi
python3 eval/frontier.py report --eval-dir "$OUT/eval" --runs "$RESULTS/runs" --out "$OUT" --default "$F_DEFAULT" \
    --mf "$MF"
