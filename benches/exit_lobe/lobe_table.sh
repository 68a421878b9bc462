#!/bin/sh
# benches/exit_lobe/lobe_table.sh: every path-traced reference of tests/reference/pt/ through
# `translucent render` (GPU frame, render's defaults otherwise) with each `--exit-lobe`.
# Run from the repository root after `cargo build --release -p translucent-tools` and
# `python3 tests/reference/pt/make_shapes.py` (the plate and U-block meshes).
#
#   sh benches/exit_lobe/lobe_table.sh                            # lambert p1 fitted, 13 scenes
#   LOBES="lambert fitted" SCENES="marble-back plate-back" sh benches/exit_lobe/lobe_table.sh
#
# Writes target/exit-lobe/SCENE-LOBE.{exr,json,log} and prints one line per render: scene, lobe,
# seconds, compare_exr.py's line (relative RMS R, G, B (all) over the fully covered pixels).
C=0,20,60:0,0,0:30; R=tests/reference/pt; T=${T:-target/release/translucent}
O=${O:-target/exit-lobe}; mkdir -p $O
F=dir:0.5,-1,-0.5:4,4,4; B=dir:0.2,-0.35,1:5,5,5; S="--camera $C --width 96 --height 96"
MARBLE="--material marble --eta 1"; SPHERE="--shape sphere --size-mm 20"; BUNNY="--mesh ../shared/meshes/stanford-bunny.obj --size-mm 20"
MASK=""
run() { name=$1; ref=$2; shift 2
  case " ${SCENES:-$name} " in *" $name "*) ;; *) return ;; esac
  for lobe in ${LOBES:-lambert p1 fitted}; do
    out=$O/$name-$lobe
    start=$(date +%s)
    nice -n 10 $T render "$@" $S --exit-lobe $lobe --json --out $out.exr > $out.json 2> $out.log
    rc=$?; end=$(date +%s)
    if [ $rc -ne 0 ]; then echo "$name $lobe: render failed (rc $rc, $out.log)"; continue; fi
    echo "$name $lobe ($((end-start)) s): $(python3 tools/compare_exr.py $MASK $out.exr $R/$ref 2>&1 | tail -1)"
  done
}
run milk-front skimmilk-sphere-dir-eta1.exr $SPHERE --material skimmilk --eta 1 --light $F --no-specular
run marble-front marble-sphere-dir-eta1.exr $SPHERE $MARBLE --light $F --no-specular
run split-front split-sphere-dir-eta1.exr $SPHERE --volume $R/milk-skin-split.vol --eta 1 --light $F --no-specular
run bunny-front bunny-marble-dir-eta1.exr $BUNNY $MARBLE --light $F --no-specular
run bunny-side bunny-marble-side-eta1.exr $BUNNY $MARBLE --light dir:1,-0.2,0:5,5,5 --no-specular
run marble-back marble-sphere-backlit-eta1.exr $SPHERE $MARBLE --light $B --no-specular
run torus-back marble-torus-backlit-eta1.exr --shape torus --size-mm 20 $MARBLE --light $B --no-specular
# Constant environment, eta 1.3: specular on (the reflection drawn, as the reference has it).
run marble-env marble-sphere-env-eta1.3.exr $SPHERE --material marble --eta 1.3 --env-constant 1,1,1 --light dir:0,-1,0:0,0,0
run plate-back plate-on-base-backlit-eta1.exr --mesh target/pt-shapes/plate-on-base.obj --size-mm 30 $MARBLE --light $B --no-specular
run ublock-front ublock-marble-dir-eta1.exr --mesh target/pt-shapes/u-block.obj --size-mm 20 $MARBLE --light $F --no-specular
run ublock-back ublock-marble-backlit-eta1.exr --mesh target/pt-shapes/u-block.obj --size-mm 20 $MARBLE --light $B --no-specular
run skin1-sphere skin1-sphere-dir-eta1.exr $SPHERE --material skin1 --eta 1 --light $F --no-specular
# Ketchup: its reference has alpha < 0.999 everywhere (rays cross it unscattered): the skin1 file's mask.
MASK="--mask-from $R/skin1-sphere-dir-eta1.exr"
run ketchup-sphere ketchup-sphere-dir-eta1.exr $SPHERE --material ketchup --eta 1 --light $F --no-specular
