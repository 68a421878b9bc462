#!/bin/sh
# benches/gpu_single_scattering.sh: run from the repository root after cargo build --release -p translucent-tools.
# GPU frame (real-time default, boundary flux) with --single-scattering off, always (the march on
# every view) and on (the march unless every light is in front: the front-lit skip rule), DESIGN
# 2.8, the shared pass, 96 px, against tests/reference/pt/. Writes target/gpu-ss/*.exr and prints
# tools/compare_exr.py's line and the passes' GPU ms per render (march + depth pre-pass).
# SS_MODES="off always" limits the modes; SOURCE=beam measures the beam source (default flux, as measured).
C=0,20,60:0,0,0:30; S="--size-mm 20 --camera $C --width 96 --height 96 --no-specular --source ${SOURCE:-flux}"; R=tests/reference/pt; O=target/gpu-ss; mkdir -p $O
T=target/release/translucent
run() { name=$1; ref=$2; shift 2
  for v in ${SS_MODES:-off always on}; do
    $T render "$@" $S --single-scattering $v --profile --out $O/$name-$v.exr > $O/$name-$v.log 2>&1
    ms=$(grep -E "^ *single_scattering(_depths)? " $O/$name-$v.log | awk '{print $2}' | paste -sd+)
    total=$(grep -E "^ *total " $O/$name-$v.log | awk '{print $2}')
    echo "$name $v (pass ${ms:-absent} ms of $total ms): $(python3 tools/compare_exr.py $O/$name-$v.exr $R/$ref 2>&1 | tail -1)"
  done
}
run marble-back marble-sphere-backlit-eta1.exr --shape sphere --material marble --eta 1 --light dir:0.2,-0.35,1:5,5,5
run torus-back marble-torus-backlit-eta1.exr --shape torus --material marble --eta 1 --light dir:0.2,-0.35,1:5,5,5
run bunny-side bunny-marble-side-eta1.exr --mesh ../shared/meshes/stanford-bunny.obj --material marble --eta 1 --light dir:1,-0.2,0:5,5,5
run marble-sphere marble-sphere-dir-eta1.exr --shape sphere --material marble --eta 1 --light dir:0.5,-1,-0.5:4,4,4
run milk-sphere skimmilk-sphere-dir-eta1.exr --shape sphere --material skimmilk --eta 1 --light dir:0.5,-1,-0.5:4,4,4
run bunny-front bunny-marble-dir-eta1.exr --mesh ../shared/meshes/stanford-bunny.obj --material marble --eta 1 --light dir:0.5,-1,-0.5:4,4,4
