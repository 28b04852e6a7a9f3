#!/bin/sh
# make bench-geom's README: the baseline on the given mesh (nvdiffrecmc) beside the baseline on
# the visual hull (nvdiffrecmc-vhull, mf recon --geometry vhull), per scene, from mf eval's
# scenes.csv, with the hull and unwrap seconds from each vhull run's run.json.
# usage: sh eval/bench_geom_report.sh RESULTS_SPLIT_DIR REPORT_DIR "SCENES" "COMMAND" > README.md
set -eu
res=$1 rep=$2 scenes=$3 cmd=$4
[ -f "$rep/scenes.csv" ] || { echo "bench_geom_report: $rep/scenes.csv missing (mf eval did not run)" >&2; exit 1; }
n=$(echo $scenes | wc -w)
# hull_s / unwrap_s per scene: "scene hull_s unwrap_s" lines (run.json: options.geometry_result)
times=$(for s in $scenes; do
  j=$res/nvdiffrecmc-vhull/$s/run.json
  [ -f "$j" ] || { echo "bench_geom_report: $j missing" >&2; exit 1; }
  h=$(grep -o '"hull_s":[^,}]*' "$j" | head -1 | cut -d: -f2 | tr -d ' ')
  u=$(grep -o '"unwrap_s":[^,}]*' "$j" | head -1 | cut -d: -f2 | tr -d ' ')
  echo "$s ${h:-nan} ${u:-nan}"
done)
cat <<EOF
# Geometry recovery in mf recon on test-3d ($n of the 9 scenes)

Made by \`$cmd\`: the nvdiffrecmc-style baseline (its default budget,
baselines/nvdiffrecmc.json) on each scene's given mesh (**given**) and on the visual hull of the
same 64 training masks at 128 px (**vhull**: \`mf recon --geometry vhull\`: \`mf hull\`'s defaults,
128^3 grid, 40k triangles, then \`mf unwrap\`'s atlas), scored by \`mf eval\` against the GT mesh
and the relit test views. $n scene(s) only: the full split (9 scenes, \`make bench-geom\`
without SCENES) did not fit the session that made this table on a shared 2-core machine.
DMTet (pass 1, which should fix the hull's cavities) is not implemented.

Chamfer: Stanford-ORB's, x1e3 (object extent 1). Normals: mean angle between the shading normals
of the two meshes over the test views' pixels that show both. hull s / unwrap s: wall seconds of
the hull and of the UV atlas inside \`mf recon\` (run.json). Full tables: geometry.md, relight.md,
materials.md, paired.md (vhull minus given), index.html.

| scene | mesh | Chamfer x1e3 | normals deg | mask IoU | relit PSNR | albedo PSNR | recon s | hull s | unwrap s |
|---|---|---|---|---|---|---|---|---|---|
EOF
echo "$times" | awk -v csv="$rep/scenes.csv" -v scenes="$scenes" '
  BEGIN {
    while ((getline line < csv) > 0) { split(line, f, ","); v[f[1] SUBSEP f[3] SUBSEP f[4]] = f[5] } }
  { hs[$1] = $2; us[$1] = $3 }
  function val(m, s, k, fmt) { return ((m SUBSEP s SUBSEP k) in v) ? sprintf(fmt, v[m SUBSEP s SUBSEP k]) : "-" }
  END { n = split(scenes, sc, " ")
    for (i = 1; i <= n; i++) { s = sc[i]
      for (j = 1; j <= 2; j++) { m = j == 1 ? "nvdiffrecmc" : "nvdiffrecmc-vhull"
        printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", s, j == 1 ? "given" : "vhull",
          val(m, s, "geom_chamfer", "%.3f"), val(m, s, "geom_view_normal_deg", "%.1f"), val(m, s, "geom_mask_iou", "%.4f"),
          val(m, s, "relit_psnr", "%.2f"), val(m, s, "albedo_psnr", "%.2f"), val(m, s, "time_s", "%.0f"),
          j == 1 ? "-" : sprintf("%.2f", hs[s]), j == 1 ? "-" : sprintf("%.2f", us[s]) } } }'
