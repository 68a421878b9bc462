#!/bin/sh
# benches/auto_resolution.sh: run from the repository root after cargo build --release -p translucent-tools.
# `--resolution auto` (the default) against the old fixed default 48: wall time of the whole render
# (bake from an empty cache + GPU frame) and relative RMS against the path-traced references.
C=0,20,60:0,0,0:30; S="--size-mm 20 --camera $C --width 96 --height 96 --no-specular --eta 1"
R=tests/reference/pt; O=target/auto-resolution; mkdir -p $O
T=target/release/translucent
export TRANSLUCENT_DEVICE=llvmpipe
run() { name=$1; ref=$2; shift 2
  for res in auto 48; do
    export TRANSLUCENT_CACHE_DIR=$O/cache-$name-$res; rm -rf $TRANSLUCENT_CACHE_DIR
    start=$(date +%s.%N)
    $T render "$@" $S --resolution $res --out $O/$name-$res.exr --json > $O/$name-$res.json 2> $O/$name-$res.log
    end=$(date +%s.%N)
    chosen=$(python3 -c "import json; r=json.load(open('$O/$name-$res.json'))['resolution']; print(r['resolution'], round(r['spacing_mm'],3), r['finest_nodes'], (r['auto'] or {}).get('bound','given'))")
    echo "$name $res [$chosen] $(echo "$end - $start" | bc) s: $(python3 tools/compare_exr.py $O/$name-$res.exr $R/$ref 2>&1 | tail -1)"
  done
}
run milk-sphere skimmilk-sphere-dir-eta1.exr --shape sphere --material skimmilk --light dir:0.5,-1,-0.5:4,4,4
run marble-sphere marble-sphere-dir-eta1.exr --shape sphere --material marble --light dir:0.5,-1,-0.5:4,4,4
run split-sphere split-sphere-dir-eta1.exr --shape sphere --volume $R/milk-skin-split.vol --light dir:0.5,-1,-0.5:4,4,4
run bunny-front bunny-marble-dir-eta1.exr --mesh ../shared/meshes/stanford-bunny.obj --material marble --light dir:0.5,-1,-0.5:4,4,4
