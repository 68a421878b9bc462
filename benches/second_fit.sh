#!/bin/sh
# benches/second_fit.sh BIN TAG: the back-lit marble sphere, torus, plate and the front-lit marble and
# skim milk spheres (benches/gpu_terms.sh command lines, render defaults) against tests/reference/pt/,
# one compare_exr.py line each; writes target/second2/NAME-TAG.{exr,json,log}. Run from the repository
# root after `python3 tests/reference/pt/make_shapes.py` (the plate).
mkdir -p target/second2
T=$1; TAG=$2; O=target/second2; R=tests/reference/pt
C=0,20,60:0,0,0:30; F=dir:0.5,-1,-0.5:4,4,4; B=dir:0.2,-0.35,1:5,5,5; S="--camera $C --width 96 --height 96"
MARBLE="--material marble --eta 1"; SPHERE="--shape sphere --size-mm 20"
r() { name=$1; ref=$2; shift 2
  nice -n 10 $T render "$@" $S --json --out $O/$name-$TAG.exr > $O/$name-$TAG.json 2> $O/$name-$TAG.log || echo "$name failed"
  echo "$name $TAG $(python3 tools/compare_exr.py $O/$name-$TAG.exr $R/$ref 2>&1 | tail -3 | tr '\n' ' ')"
}
r marble-back marble-sphere-backlit-eta1.exr $SPHERE $MARBLE --light $B --no-specular
r torus-back marble-torus-backlit-eta1.exr --shape torus --size-mm 20 $MARBLE --light $B --no-specular
r plate-back plate-on-base-backlit-eta1.exr --mesh target/pt-shapes/plate-on-base.obj --size-mm 30 $MARBLE --light $B --no-specular
r marble-front marble-sphere-dir-eta1.exr $SPHERE $MARBLE --light $F --no-specular
r milk-front skimmilk-sphere-dir-eta1.exr $SPHERE --material skimmilk --eta 1 --light $F --no-specular
