#!/bin/sh
# The prior's mean roughness and metallic (inside the mask) on chosen views of one scene, per weights
# file and split, as `mf prior` prints them -> a markdown table on stdout.
# usage: tools/prior_views.sh MF DATA SCENE "SPLIT..." "VIEW..." "WEIGHTS..." [mf prior flags]
# e.g. tools/prior_views.sh build/mf data 000_cup "test-3d test-3d-cyc" "000 008" "mf/prior/weights/prior.mfck"
set -eu
[ $# -ge 6 ] || { echo "usage: $0 MF DATA SCENE SPLITS VIEWS WEIGHTS [mf prior flags]" >&2; exit 2; }
mf=$1 data=$2 scene=$3 splits=$4 views=$5 weights=$6
shift 6
tmp=$(mktemp -d) && trap 'rm -rf "$tmp"' EXIT
row() { # SPLIT WEIGHTS CHANNEL VALUES...: one table row, the values and their mean
  s=$1 w=$2 c=$3
  shift 3
  echo "| $s | $w | $c | $(echo "$@" | sed 's/ / | /g') | $(echo "$@" | awk '{s=0; for(i=1;i<=NF;i++) s+=$i; printf "%.3f", s/NF}') |"
}
echo "| split | weights | channel | $(echo $views | sed 's/ / | /g') | mean |"
echo "|---|---|---|$(for v in $views; do printf -- '---:|'; done)---:|"
for s in $splits; do for w in $weights; do
  rough="" metal=""
  for v in $views; do
    img=$data/$s/$scene/train/r_$v.png
    [ -f "$img" ] || { echo "$0: $img: no such view" >&2; exit 1; }
    OMP_NUM_THREADS=1 "$mf" prior "$img" -o "$tmp/o" --weights "$w" "$@" > "$tmp/out" 2> "$tmp/err" \
      || { echo "$0: mf prior failed on $img with $w: $(cat "$tmp/err")" >&2; exit 1; }
    line=$(sed -n 's/^view 0: mean roughness \([0-9.]*\), metallic \([0-9.]*\).*/\1 \2/p' "$tmp/out")
    [ -n "$line" ] || { echo "$0: mf prior printed no means for $img (empty mask?)" >&2; exit 1; }
    rough="$rough ${line% *}" metal="$metal ${line#* }"
  done
  row "$s" "$(basename "$w")" roughness $rough
  row "$s" "$(basename "$w")" metallic $metal
done; done
