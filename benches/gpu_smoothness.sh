#!/bin/sh
# benches/gpu_smoothness.sh: run from the repository root after cargo build --release -p translucent-tools.
# The display vertices' exitance, `--surface shepard` (the surface nodes' J+ through the shading
# weights) against `--surface interior` (reconstructed from the interior solution, DESIGN 2.6):
# (a) high-frequency energy of the image (tools/smoothness_exr.py) on the scenes that showed the
# lattice, (b) relative RMS against the path-traced references (tools/compare_exr.py).
# Writes target/gpu-smoothness/*.exr.
O=target/gpu-smoothness; mkdir -p $O; T=target/release/translucent; R=tests/reference/pt
C=0,20,60:0,0,0:30; S="--size-mm 20 --camera $C --width 96 --height 96 --no-specular"
smooth() { name=$1; shift
  for v in shepard interior; do
    $T render "$@" --surface $v --out $O/$name-$v.exr > $O/$name-$v.log 2>&1
    echo "$name $v: $(python3 tools/smoothness_exr.py $O/$name-$v.exr 2>&1 | tail -1)"
  done
}
accuracy() { name=$1; ref=$2; shift 2
  for v in shepard interior; do
    $T render "$@" $S --surface $v --out $O/acc-$name-$v.exr > $O/acc-$name-$v.log 2>&1
    echo "$name $v: $(python3 tools/compare_exr.py $O/acc-$name-$v.exr $R/$ref 2>&1 | tail -1)"
  done
}
B="--size-mm 20 --width 128 --height 128 --no-specular"
smooth marble-back-48 --shape sphere --material marble --eta 1 --light dir:0.2,-0.35,1:5,5,5 --camera 0,20,60:0,0,0:30 $B --resolution 48
smooth marble-back-auto --shape sphere --material marble --eta 1 --light dir:0.2,-0.35,1:5,5,5 --camera 0,20,60:0,0,0:30 $B
smooth spot-skin1 --mesh ../shared/meshes/spot.obj --material skin1 --width 128 --height 128 --no-specular
smooth spot-ketchup --mesh ../shared/meshes/spot.obj --material ketchup --width 128 --height 128 --no-specular
smooth bunny-skin1 --mesh ../shared/meshes/stanford-bunny.obj --material skin1 --width 128 --height 128 --no-specular
smooth bunny-ketchup --mesh ../shared/meshes/stanford-bunny.obj --material ketchup --width 128 --height 128 --no-specular
smooth skin1-env --shape sphere --material skin1 --eta 1 --env-constant 1,1,1 --light dir:0,-1,0:0,0,0 --width 128 --height 128 --no-specular
smooth ketchup-env --shape sphere --material ketchup --eta 1 --env-constant 1,1,1 --light dir:0,-1,0:0,0,0 --width 128 --height 128 --no-specular
accuracy milk-sphere skimmilk-sphere-dir-eta1.exr --shape sphere --material skimmilk --eta 1 --light dir:0.5,-1,-0.5:4,4,4
accuracy marble-sphere marble-sphere-dir-eta1.exr --shape sphere --material marble --eta 1 --light dir:0.5,-1,-0.5:4,4,4
accuracy bunny-front bunny-marble-dir-eta1.exr --mesh ../shared/meshes/stanford-bunny.obj --material marble --eta 1 --light dir:0.5,-1,-0.5:4,4,4
accuracy marble-back marble-sphere-backlit-eta1.exr --shape sphere --material marble --eta 1 --light dir:0.2,-0.35,1:5,5,5
accuracy torus-back marble-torus-backlit-eta1.exr --shape torus --material marble --eta 1 --light dir:0.2,-0.35,1:5,5,5
accuracy bunny-side bunny-marble-side-eta1.exr --mesh ../shared/meshes/stanford-bunny.obj --material marble --eta 1 --light dir:1,-0.2,0:5,5,5
