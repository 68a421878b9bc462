#!/bin/sh
# benches/march_terms.sh: the single-scattering march's wave-6 terms (issue 12) through
# `translucent render` (GPU frame, render's defaults), error against the path-traced references
# and the march's GPU ms: the environment sphere (black placeholder light: the dark-light skip and
# the environment's single scattering), the split .vol sphere (heterogeneous tau; its default
# source `flux` marches the difference, `--source second` the whole), and the agate .vol (no
# reference: the march's ms and the image's change). Run from the repository root after
# `cargo build --release -p translucent-tools`; MARCH_BIN picks another binary (main's, for the
# "before" column), MARCH_TAG the output folder (target/march-terms/TAG).
#
#   sh benches/march_terms.sh
#   MARCH_BIN=/work/main/target/release/translucent MARCH_TAG=main sh benches/march_terms.sh
C=0,20,60:0,0,0:30; R=tests/reference/pt; T=${MARCH_BIN:-target/release/translucent}
O=target/march-terms/${MARCH_TAG:-branch}; mkdir -p $O
S="--camera $C --width 96 --height 96 --frames 3 --no-skip"
F=dir:0.5,-1,-0.5:4,4,4; SPHERE="--shape sphere --size-mm 20"
[ -f $O/../agate.vol ] || $T volume --pattern agate --out $O/../agate.vol > /dev/null
run() { name=$1; ref=$2; shift 2
  case " ${MARCH_SCENES:-$name} " in *" $name "*) ;; *) return ;; esac
  out=$O/$name; start=$(date +%s)
  nice -n 10 $T render "$@" $S --json --profile --trace $out.trace.json --out $out.exr > $out.json 2> $out.log
  rc=$?; end=$(date +%s)
  if [ $rc -ne 0 ]; then echo "$name: render failed (rc $rc, $out.log)"; return; fi
  if [ "$ref" = - ]; then
    python3 tools/compare_exr.py --json $out.exr $out.exr > $out.compare.json 2>> $out.log
  else
    python3 tools/compare_exr.py --json $out.exr $R/$ref > $out.compare.json 2>> $out.log
  fi
  python3 benches/terms_row.py "$name" "${MARCH_TAG:-branch}" $out $((end-start))
}
run env-sphere marble-sphere-env-eta1.3.exr $SPHERE --material marble --eta 1.3 --env-constant 1,1,1 --light dir:0,-1,0:0,0,0
run split-flux split-sphere-dir-eta1.exr $SPHERE --volume $R/milk-skin-split.vol --eta 1 --light $F --no-specular
run split-second split-sphere-dir-eta1.exr $SPHERE --volume $R/milk-skin-split.vol --eta 1 --light $F --no-specular --source second
run split-back - $SPHERE --volume $R/milk-skin-split.vol --eta 1 --light dir:0.2,-0.35,1:5,5,5 --no-specular
run agate - $SPHERE --volume $O/../agate.vol --eta 1.5 --light $F --no-specular --source second
