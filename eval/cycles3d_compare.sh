#!/bin/sh
# make bench-cycles-3d's renderer comparison: the same test-3d objects, cameras and probes lit by our
# renderer (test-3d) and by Blender Cycles (test-3d-cyc), each scored by mf eval into its scenes.csv.
# Writes DIR/renderer.csv (mf compare's records: dataset = a method, or "<METHOD> - <REF>" for the
# per-scene difference of the two; method = ours or cycles, the renderer of the images it was given)
# and, per dataset, DIR/<dataset>/paired.md (cycles minus ours, paired over the scenes both hold).
# Time and memory columns are left out (they measure the machine, not the images).
# usage: sh eval/cycles3d_compare.sh MF OURS_SCENES_CSV CYC_SCENES_CSV REF METHOD DIR
set -eu
mf=$1 ours=$2 cyc=$3 ref=$4 meth=$5 dir=$6
for f in "$ours" "$cyc"; do [ -f "$f" ] || { echo "cycles3d_compare: $f missing (mf eval did not run)" >&2; exit 1; }; done
mkdir -p "$dir"
tmp=$dir/renderer.csv.tmp
{
  echo "method,dataset,scene,metric,value"
  for r in ours cycles; do
    [ $r = ours ] && f=$ours || f=$cyc
    awk -F, -v r=$r -v ref="$ref" -v m="$meth" '
      NR > 1 && $4 !~ /^(time_s|time_x|mem_mb)$/ && ($1 == ref || $1 == m) {
        print r "," $1 "," $3 "," $4 "," $5; v[$1 SUBSEP $3 SUBSEP $4] = $5; k[$3 SUBSEP $4] = 1 }
      END { for (x in k) { split(x, p, SUBSEP)
              if ((ref SUBSEP x) in v && (m SUBSEP x) in v) print r "," m " - " ref "," p[1] "," p[2] "," v[m SUBSEP x] - v[ref SUBSEP x] } }' "$f"
  done
} > "$tmp"
mv "$tmp" "$dir/renderer.csv"
for d in "$ref" "$meth" "$meth - $ref"; do
  sub=$(echo "$d" | tr -d ' ')
  "$mf" compare "$dir/renderer.csv" --ref ours --dataset "$d" -o "$dir/$sub"
done
