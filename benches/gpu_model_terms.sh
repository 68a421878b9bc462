#!/bin/sh
# benches/gpu_model_terms.sh: run from the repository root after cargo build --release -p translucent-tools.
# The GPU frame (`translucent render`, 96 px, --no-specular, eta 1) against tests/reference/pt/ with
# each combination of the model's terms (benches/RESULTS.md, "Model terms on the GPU (wave 5)"):
#   source  flux (--source flux: boundary flux) | beam (--source beam, DESIGN 2.7) | second
#           (--source second: the second-collision source, single scattering whole, DESIGN 2.8)
#           | beam-edge, second-edge (the same with --shadow-edge-flux)
#   surface shepard | interior (--surface, DESIGN 2.6)
#   ss      off | on (--single-scattering; `on` skips front-lit views, the log says so)
# Environment: SOURCES, SURFACES, SS (space-separated lists, default all), SCENES (names below,
# default all), T (the binary, default target/release/translucent), O (output folder).
# Prints one line per render: scene source surface ss (seconds, skipped?): compare_exr's line.
C=0,20,60:0,0,0:30; S="--size-mm 20 --camera $C --width 96 --height 96 --no-specular"; R=tests/reference/pt
O=${O:-target/gpu-model-terms}; mkdir -p $O
T=${T:-target/release/translucent}
FRONT="--light dir:0.5,-1,-0.5:4,4,4"; BACK="--light dir:0.2,-0.35,1:5,5,5"; SIDE="--light dir:1,-0.2,0:5,5,5"
BUNNY="--mesh ../shared/meshes/stanford-bunny.obj --material marble --eta 1"
MARBLE="--shape sphere --material marble --eta 1"
run() { name=$1; ref=$2; shift 2
  case " ${SCENES:-$name} " in *" $name "*) ;; *) return ;; esac
  for src in ${SOURCES:-flux beam}; do
    case $src in
      beam-edge) extra="--source beam --shadow-edge-flux" ;; second-edge) extra="--source second --shadow-edge-flux" ;;
      *) extra="--source $src" ;;
    esac
    for surf in ${SURFACES:-shepard interior}; do
      for ss in ${SS:-off on}; do
        out=$O/$name-$src-$surf-ss$ss
        start=$(date +%s)
        $T render "$@" $S $extra --surface $surf --single-scattering $ss --out $out.exr > $out.log 2>&1
        end=$(date +%s)
        skip=""; grep -q -i "front-lit" $out.log && skip=", skipped: front-lit"
        echo "$name $src $surf ss-$ss ($((end-start)) s$skip): $(python3 tools/compare_exr.py $out.exr $R/$ref 2>&1 | tail -1)"
      done
    done
  done
}
run milk-front skimmilk-sphere-dir-eta1.exr --shape sphere --material skimmilk --eta 1 $FRONT
run marble-front marble-sphere-dir-eta1.exr $MARBLE $FRONT
run split-front split-sphere-dir-eta1.exr --shape sphere --volume $R/milk-skin-split.vol --eta 1 $FRONT
run bunny-front bunny-marble-dir-eta1.exr $BUNNY $FRONT
run marble-back marble-sphere-backlit-eta1.exr $MARBLE $BACK
run torus-back marble-torus-backlit-eta1.exr --shape torus --material marble --eta 1 $BACK
run bunny-side bunny-marble-side-eta1.exr $BUNNY $SIDE
