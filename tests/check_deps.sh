#!/bin/sh
# make check-deps: the layering rules of README "Layout", checked by grep.
# 1. An #include "<folder>/..." from a file in folder A must name a folder that A may use.
# 2. No function in mf/cli longer than MAX_CLI_FN lines (commands parse options, call the
#    library and print).
# Exit status 1 on any violation, with one line per violation.
cd "$(dirname "$0")/.." || exit 2
MAX_CLI_FN=80
allowed() { # folder -> folders it may include (besides itself)
  case "$1" in
    core)      echo "" ;;
    io)        echo "core scene/mf_mesh.h scene/mf_tangent.h" ;;   # the mesh readers/writers: see below
    scene)     echo "core io" ;;
    render)    echo "core io scene" ;;
    nn)        echo "core io" ;;      # io: MfTensorSpec and the checkpoint format (mf_ckpt)
    geom)      echo "core io scene" ;;
    inverse)   echo "core io scene render geom" ;;   # geom: mf recon --geometry vhull (mf_recon_geom)
    prior)     echo "core io nn datasets" ;;  # datasets: the 2D splits' layout (ds_prior2d)
    fusion)    echo "core io scene render nn inverse prior" ;;
    baselines) echo "core io" ;;
    datasets)  echo "core io scene render geom" ;;   # geom: mf_bake (UV rasteriser, gutter) and mf_pack (atlas packing) shared with ds_shapes
    eval)      echo "core io scene render datasets" ;;   # datasets: eval reads data sets
    cli)       echo "core io scene render nn geom inverse prior fusion baselines datasets eval" ;;
    *)         echo "?" ;;
  esac
}
# Files with a narrower rule than their folder: the mesh (plain data and its geometry) and its
# tangent frames include only core, so io's OBJ/glTF readers and writers may use them without a
# cycle between io and scene.
allowed_file() { # file folder -> folders and headers it may include (its own folder too)
  case "$1" in
    mf/scene/mf_mesh.[ch]|mf/scene/mf_tangent.[ch]) echo "core scene/mf_mesh.h scene/mf_tangent.h" ;;
    *) echo "$(allowed "$2") $2" ;;
  esac
}
bad=0
for f in mf/*/*.c mf/*/*.h mf/*/*.cpp baselines/*.[ch] datasets/*.[ch] eval/*.[ch]; do
  [ -e "$f" ] || continue
  src=$(dirname "$f"); src=${src#mf/}
  rule=$(allowed_file "$f" "$src")
  ok=" $rule "
  for inc in $(sed -n 's/^[[:space:]]*#[[:space:]]*include[[:space:]]*"\([a-z]*\/[^"]*\)".*/\1/p' "$f" | sort -u); do
    dst=${inc%%/*}
    case "$ok" in
      *" $dst "*|*" $inc "*) ;;
      *) echo "check-deps: $f includes $inc ($f may include: $rule)"; bad=1 ;;
    esac
  done
done
# Function length: a definition starts at column 0 with an identifier and '(' (no ';'),
# its body ends at the first '}' in column 0.
for f in mf/cli/*.c; do
  awk -v max=$MAX_CLI_FN -v file="$f" '
    /^[A-Za-z_].*\(/ && !/;[[:space:]]*$/ && !/^(typedef|struct|enum|#)/ {
      s = $0; sub(/\(.*/, "", s); n = split(s, w, /[ *]+/); name = w[n]; start = NR; next }
    /^}/ && start { len = NR - start + 1
      if (len > max) {
        printf "check-deps: %s:%d %s() is %d lines (mf/cli limit %d)\n", file, start, name, len, max; bad = 1 }
      start = 0 }
    END { exit bad }' "$f" || bad=1
done
[ $bad = 0 ] && echo "check-deps: ok"
exit $bad
