#!/bin/sh
# bench_vs_committed: one method's per-scene results of two benchmark runs of the same split,
# paired over their shared scenes (mf compare: mean difference, 95% CI, wins, p-values) — how a
# re-run's numbers differ from a committed table's (a "numbers unchanged or explained" check).
#
# usage: tools/bench_vs_committed.sh MF METHOD OUT_DIR LABEL=SCENES_CSV[:NAME] [LABEL=SCENES_CSV[:NAME] ...]
# The first LABEL is the reference; each run's rows of METHOD (or of NAME, the same method under
# the name that run gave it) become method "METHOD@LABEL".
# Writes OUT_DIR/joined.csv (the rows compared) and OUT_DIR/paired.{md,csv}.
set -eu
[ $# -ge 5 ] || { echo "usage: $0 MF METHOD OUT_DIR LABEL=SCENES_CSV LABEL=SCENES_CSV [...]" >&2; exit 2; }
mf=$1 method=$2 out=$3
shift 3
mkdir -p "$out"
tmp="$out/joined.csv.tmp.$$"
echo "method,dataset,scene,metric,value" > "$tmp"
ref=""
for run in "$@"; do
  label=${run%%=*} csv=${run#*=} name=$method
  case $csv in *.csv:*) name=${csv##*.csv:} csv=${csv%:"$name"} ;; esac
  [ -f "$csv" ] || { echo "$0: $csv: no such file" >&2; rm -f "$tmp"; exit 1; }
  [ -n "$ref" ] || ref="$method@$label"
  awk -F, -v n="$name" -v m="$method" -v l="$label" 'NR > 1 && $1 == n { OFS = ","; $1 = m "@" l; print }' "$csv" >> "$tmp"
done
mv "$tmp" "$out/joined.csv"
"$mf" compare "$out/joined.csv" --ref "$ref" -o "$out"
