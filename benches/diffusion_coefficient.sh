#!/bin/sh
# benches/diffusion_coefficient.sh: `render --diffusion-coefficient classical|grosjean` against the
# path-traced references of tests/reference/pt/ (GPU frame, render's defaults: the second-collision
# source for homogeneous materials, single scattering on), each with the Shepard and the interior
# surface. Run from the repository root after `cargo build --release -p translucent-tools`.
#
#   sh benches/diffusion_coefficient.sh                      # every scene, both D, both surfaces
#   DC_SCENES="ketchup-sphere skin1-sphere" DC_SURFACES=interior sh benches/diffusion_coefficient.sh
#
# Writes target/diffusion-coefficient/*.{exr,json} and prints one line per render (scene, D,
# surface: relative RMS R, G, B (all) in %, ratio of means per channel; benches/terms_row.py).
C=0,20,60:0,0,0:30; R=tests/reference/pt; T=target/release/translucent
O=target/diffusion-coefficient; mkdir -p $O
KINDS=${DC_KINDS:-"classical grosjean"}; SURFACES=${DC_SURFACES:-"shepard interior"}
F=dir:0.5,-1,-0.5:4,4,4; B=dir:0.2,-0.35,1:5,5,5; S="--camera $C --width 96 --height 96"
SPHERE="--shape sphere --size-mm 20"
run() { name=$1; ref=$2; shift 2
  case " ${DC_SCENES:-$name} " in *" $name "*) ;; *) return ;; esac
  for k in $KINDS; do for surf in $SURFACES; do
    out=$O/$name-$k-$surf; start=$(date +%s)
    nice -n 10 $T render "$@" $S --diffusion-coefficient $k --surface $surf --json --profile \
      --trace $out.trace.json --out $out.exr > $out.json 2> $out.log
    rc=$?; end=$(date +%s)
    if [ $rc -ne 0 ]; then echo "$name $k-$surf: render failed (rc $rc, $out.log)"; continue; fi
    python3 tools/compare_exr.py --json $MASK $out.exr $R/$ref > $out.compare.json 2>> $out.log
    python3 benches/terms_row.py "$name" "$k-$surf" $out $((end-start))
  done; done
}
run milk-sphere skimmilk-sphere-dir-eta1.exr $SPHERE --material skimmilk --eta 1 --light $F --no-specular
run marble-sphere marble-sphere-dir-eta1.exr $SPHERE --material marble --eta 1 --light $F --no-specular
run marble-back marble-sphere-backlit-eta1.exr $SPHERE --material marble --eta 1 --light $B --no-specular
# The split sphere is heterogeneous: render keeps the boundary flux unless --source is named.
run split-sphere split-sphere-dir-eta1.exr $SPHERE --volume $R/milk-skin-split.vol --eta 1 --light $F --no-specular
run split-second split-sphere-dir-eta1.exr $SPHERE --volume $R/milk-skin-split.vol --eta 1 --light $F --no-specular --source second
run skin1-sphere skin1-sphere-dir-eta1.exr $SPHERE --material skin1 --eta 1 --light $F --no-specular
# Ketchup: its reference has alpha < 0.999 everywhere (rays cross it unscattered): skin1's mask.
MASK="--mask-from $R/skin1-sphere-dir-eta1.exr"
run ketchup-sphere ketchup-sphere-dir-eta1.exr $SPHERE --material ketchup --eta 1 --light $F --no-specular
MASK=""
