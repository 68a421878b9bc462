#!/bin/sh
# benches/defaults_table.sh: every path-traced reference of tests/reference/pt/ through `translucent
# render` with nothing named but the scene (render's real-time defaults as they stand: source,
# diffusion coefficient, bounce, single scattering, multigrid), the lights and camera of
# benches/gpu_terms.sh. Run from the repository root after `cargo build --release -p
# translucent-tools` and `python3 tests/reference/pt/make_shapes.py target/pt-shapes`.
#
#   sh benches/defaults_table.sh
#   DEFAULTS_EXTRA="--bounce off" DEFAULTS_OUT=target/defaults-off sh benches/defaults_table.sh
#
# Prints per scene: relative RMS R, G, B (all) in % (tools/compare_exr.py) and the wall seconds.
C=0,20,60:0,0,0:30; R=tests/reference/pt; T=target/release/translucent
O=${DEFAULTS_OUT:-target/defaults-table}; mkdir -p $O
F=dir:0.5,-1,-0.5:4,4,4; B=dir:0.2,-0.35,1:5,5,5; S="--camera $C --width 96 --height 96"
MARBLE="--material marble --eta 1"; SPHERE="--shape sphere --size-mm 20"; BUNNY="--mesh ../shared/meshes/stanford-bunny.obj --size-mm 20"
run() { name=$1; ref=$2; shift 2
  out=$O/$name; start=$(date +%s)
  nice -n 10 $T render "$@" $S $DEFAULTS_EXTRA --json --out $out.exr > $out.json 2> $out.log
  rc=$?; end=$(date +%s)
  if [ $rc -ne 0 ]; then echo "$name: render failed (rc $rc, $out.log)"; return; fi
  python3 tools/compare_exr.py --json $MASK $out.exr $R/$ref > $out.compare.json 2>> $out.log
  python3 -c "
import json, sys
c = json.load(open('$out.compare.json'))
print('$name: ' + ', '.join(f'{100 * v:.1f}' for v in c['rel_rms']) + f' ({100 * c[\"rel_rms_all\"]:.1f}), {$end - $start} s')"
}
MASK=""
run milk-sphere skimmilk-sphere-dir-eta1.exr $SPHERE --material skimmilk --eta 1 --light $F --no-specular
run marble-sphere marble-sphere-dir-eta1.exr $SPHERE $MARBLE --light $F --no-specular
run split-sphere split-sphere-dir-eta1.exr $SPHERE --volume $R/milk-skin-split.vol --eta 1 --light $F --no-specular
run bunny-front bunny-marble-dir-eta1.exr $BUNNY $MARBLE --light $F --no-specular
run bunny-side bunny-marble-side-eta1.exr $BUNNY $MARBLE --light dir:1,-0.2,0:5,5,5 --no-specular
run marble-back marble-sphere-backlit-eta1.exr $SPHERE $MARBLE --light $B --no-specular
run torus-back marble-torus-backlit-eta1.exr --shape torus --size-mm 20 $MARBLE --light $B --no-specular
run marble-env marble-sphere-env-eta1.3.exr $SPHERE --material marble --eta 1.3 --env-constant 1,1,1 --light dir:0,-1,0:0,0,0
run plate-back plate-on-base-backlit-eta1.exr --mesh target/pt-shapes/plate-on-base.obj --size-mm 30 $MARBLE --light $B --no-specular
run ublock-front ublock-marble-dir-eta1.exr --mesh target/pt-shapes/u-block.obj --size-mm 20 $MARBLE --light $F --no-specular
run ublock-back ublock-marble-backlit-eta1.exr --mesh target/pt-shapes/u-block.obj --size-mm 20 $MARBLE --light $B --no-specular
run skin1-sphere skin1-sphere-dir-eta1.exr $SPHERE --material skin1 --eta 1 --light $F --no-specular
MASK="--mask-from $R/skin1-sphere-dir-eta1.exr"
run ketchup-sphere ketchup-sphere-dir-eta1.exr $SPHERE --material ketchup --eta 1 --light $F --no-specular
