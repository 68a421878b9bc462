#!/bin/sh
# benches/defaults_table.sh: every path-traced reference of tests/reference/pt/ through `translucent
# render` with nothing named but the scene (render's real-time defaults as they stand: source,
# diffusion coefficient, bounce, single scattering, multigrid), the lights and camera of
# benches/gpu_terms.sh. Run from the repository root after `cargo build --release -p
# translucent-tools` and `python3 tests/reference/pt/make_shapes.py target/pt-shapes`.
#
#   sh benches/defaults_table.sh
#   DEFAULTS_EXTRA="--bounce off" DEFAULTS_OUT=target/defaults-off sh benches/defaults_table.sh
#   ONLY="milk-sphere marble-back" sh benches/defaults_table.sh   # the named scenes only
#   T=path/to/other/translucent sh benches/defaults_table.sh      # another binary
#
# Prints per scene: relative RMS R, G, B (all) in % (tools/compare_exr.py) and the wall seconds.
. benches/pt_scenes.sh; T=${T:-target/release/translucent}
O=${DEFAULTS_OUT:-target/defaults-table}; mkdir -p $O
run() { name=$1; ref=$2; shift 2
  if [ -n "$ONLY" ]; then case " $ONLY " in *" $name "*) ;; *) return;; esac; fi
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
pt_scenes
