#!/bin/sh
# benches/curved11/some.sh: benches/defaults_table.sh for the scenes named in ONLY (space-separated
# names of benches/pt_scenes.sh), e.g.
#   ONLY="milk-sphere marble-back" DEFAULTS_EXTRA="--upstream-beam curved" DEFAULTS_OUT=target/x sh benches/curved11/some.sh
. benches/pt_scenes.sh; T=target/release/translucent
O=${DEFAULTS_OUT:-target/curved11}; mkdir -p $O
run() { name=$1; ref=$2; shift 2
  case " $ONLY " in *" $name "*) ;; *) return;; esac
  out=$O/$name; start=$(date +%s)
  nice -n 10 $T render "$@" $S $DEFAULTS_EXTRA --json --out $out.exr > $out.json 2> $out.log
  rc=$?; end=$(date +%s)
  if [ $rc -ne 0 ]; then echo "$name: render failed (rc $rc, $out.log)"; return; fi
  python3 tools/compare_exr.py --json $MASK $out.exr $R/$ref > $out.compare.json 2>> $out.log
  python3 -c "
import json, sys
c = json.load(open('$out.compare.json'))
print('$name: ' + ', '.join(f'{100 * v:.1f}' for v in c['rel_rms']) + f' ({100 * c[\"rel_rms_all\"]:.2f}), {$end - $start} s')"
}
pt_scenes
