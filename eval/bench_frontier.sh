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
# F_RES, F_SPP, F_ITERS, F_MF_ITERS, F_MF_LINES, F_CONFIG, F_FLAGS (1: the budget-flag rows), F_METAL_SPLITS,
# F_EVAL_VIEWS, F_EVAL_SPP, F_EVAL_PS.
set -eu
MF=${MF:-build/mf}
DATA=${DATA:-data/test-3d}
RESULTS=${RESULTS:-results/frontier}
OUT=${OUT:-reports/frontier}
SCENES=${SCENES:-"000_cup 001_vase 002_bottle"}
METHODS=${METHODS:-"nvdiffrecmc materialfusion"}
F_RES=${F_RES:-"64 128"}
F_SPP=${F_SPP:-"1 2 4"}
F_ITERS=${F_ITERS:-"50 100 200 400 800"}
F_MF_ITERS=${F_MF_ITERS:-"50 100 200 400"} # MaterialFusion's ladder (one run per point)
# MaterialFusion's (resolution, spp) lines (set and empty: every F_RES x F_SPP line).
# Its runs cost ~3x the baseline's and one per point, so its spp axis can be left to the baseline.
F_MF_LINES=${F_MF_LINES-"r64_s2 r128_s2"}
F_CONFIG=${F_CONFIG:-baselines/nvdiffrecmc.json}
F_FLAGS=${F_FLAGS:-1}
F_METAL_SPLITS=${F_METAL_SPLITS:-"test-3d test-3d-pov64"}
# mf eval's protocol, reduced (its defaults: every test view, spp 4, 4 pixel samples): the same
# for every point, so differences between points stay comparable
F_EVAL_VIEWS=${F_EVAL_VIEWS:-4}
F_EVAL_SPP=${F_EVAL_SPP:-2}
F_EVAL_PS=${F_EVAL_PS:-2}
# the default budget of mf recon (baselines/nvdiffrecmc.json) on test-3d's 128 px images
F_DEFAULT=${F_DEFAULT:-"r128_s2_i400"}

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
                case " ${F_MF_LINES:-r${r}_s${p}} " in *" r${r}_s${p} "*) ;; *) continue ;; esac
                for i in $F_MF_ITERS; do
                    mkdir -p "$RESULTS/runs/${m}_r${r}_s${p}_i${i}"
                    recon "$RESULTS/runs/${m}_r${r}_s${p}_i${i}/$s" "$s" --method "$m" --res "$r" --spp "$p" \
                        --iters "$i" --snapshot-every 0 --checkpoint-every "$i"
                done
            done
        done
    done
done
# metal_auto's decision on every scene of the metal-test splits (the warm-up only: 50 iterations at
# 64 px), against the ground truth (manifest "diffuse", else object.json's parts) -> metal.csv
for sp in $F_METAL_SPLITS; do
    [ -d "$(dirname "$DATA")/$sp" ] || { echo "bench-frontier: $(dirname "$DATA")/$sp missing: metal test skipped on it"; continue; }
    for d in "$(dirname "$DATA")/$sp"/*/; do
        [ -f "$d/transforms_train.json" ] || continue
        s=$(basename "$d")
        mkdir -p "$RESULTS/metal/$sp"
        [ -f "$RESULTS/metal/$sp/$s/run.json" ] && continue
        echo "bench-frontier: metal test $sp/$s"
        "$MF" recon "$d" -o "$RESULTS/metal/$sp/$s" --config "$F_CONFIG" --res 64 --iters 50 --metal-auto --metal-warmup 50 \
            --snapshot-every 0 --checkpoint-every 50 >"$RESULTS/metal/$sp/$s.log" 2>&1 ||
            echo "bench-frontier: metal test $sp/$s failed (log: $RESULTS/metal/$sp/$s.log)"
    done
done
python3 eval/frontier.py metal --metal "$RESULTS/metal" --data "$(dirname "$DATA")" --out "$OUT"
# one result folder per budget point (eval's layout), then one mf eval over all of them
python3 eval/frontier.py stage --runs "$RESULTS/runs" --eval "$RESULTS/eval" --iters "$F_ITERS"
methods=$(ls "$RESULTS/eval" | tr '\n' ',' | sed 's/,$//')
# scored already when no staged result is newer than the report's scores
if [ -f "$OUT/eval/scenes.csv" ] && [ -z "$(find "$RESULTS/eval" -name run.json -newer "$OUT/eval/scenes.csv")" ]; then
    echo "bench-frontier: $OUT/eval is up to date"
else
    "$MF" eval "$DATA" --results "$RESULTS/eval" --methods "$methods" --scenes "$(echo $SCENES | tr ' ' ',')" \
        --max-views "$F_EVAL_VIEWS" --spp "$F_EVAL_SPP" --pixel-samples "$F_EVAL_PS" --no-curves -o "$OUT/eval"
fi
# every point paired with the default budget (mean difference, 95% CI, wins, t-test and sign-test p)
if [ -d "$RESULTS/eval/nvdiffrecmc_$F_DEFAULT" ]; then
    "$MF" compare "$OUT/eval/scenes.csv" --ref "nvdiffrecmc_$F_DEFAULT" -o "$OUT/paired"
fi
python3 eval/frontier.py report --eval-dir "$OUT/eval" --points "$RESULTS/eval" --out "$OUT" --default "$F_DEFAULT" \
    --ladder "config $F_CONFIG; scenes $SCENES; methods $METHODS; resolution $F_RES px; spp $F_SPP; baseline iterations $F_ITERS; MaterialFusion iterations $F_MF_ITERS${F_MF_LINES:+ on lines $F_MF_LINES}; budget flags on the baseline at $F_DEFAULT; mf eval on $F_EVAL_VIEWS test views per scene with --spp $F_EVAL_SPP --pixel-samples $F_EVAL_PS (its defaults: every view, 4, 4)."
