#!/bin/sh
# benches/gpu_accuracy.sh: run from the repository root after cargo build --release -p translucent-tools.
# GPU frame (real-time default) with the boundary flux and with --beam-source (DESIGN 2.6 + 2.7).
C=0,20,60:0,0,0:30; S="--size-mm 20 --camera $C --width 96 --height 96 --no-specular"; R=tests/reference/pt; O=target/gpu-accuracy; mkdir -p $O
T=target/release/translucent
run() { name=$1; ref=$2; shift 2
  for v in flux beam; do
    extra="--source flux"; [ $v = beam ] && extra="--source beam"
    start=$(date +%s)
    $T render "$@" $S $extra --out $O/$name-$v.exr > $O/$name-$v.log 2>&1
    end=$(date +%s)
    echo "$name $v ($((end-start)) s): $(python3 tools/compare_exr.py $O/$name-$v.exr $R/$ref 2>&1 | tail -1)"
  done
}
run milk-sphere skimmilk-sphere-dir-eta1.exr --shape sphere --material skimmilk --eta 1 --light dir:0.5,-1,-0.5:4,4,4
run marble-sphere marble-sphere-dir-eta1.exr --shape sphere --material marble --eta 1 --light dir:0.5,-1,-0.5:4,4,4
run bunny-front bunny-marble-dir-eta1.exr --mesh ../shared/meshes/stanford-bunny.obj --material marble --eta 1 --light dir:0.5,-1,-0.5:4,4,4
run marble-back marble-sphere-backlit-eta1.exr --shape sphere --material marble --eta 1 --light dir:0.2,-0.35,1:5,5,5
run torus-back marble-torus-backlit-eta1.exr --shape torus --material marble --eta 1 --light dir:0.2,-0.35,1:5,5,5
run bunny-side bunny-marble-side-eta1.exr --mesh ../shared/meshes/stanford-bunny.obj --material marble --eta 1 --light dir:1,-0.2,0:5,5,5
