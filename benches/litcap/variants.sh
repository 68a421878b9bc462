# usage: sh target/litcap/variants.sh marble|milk NAME EXTRA-OPTIONS..
cd /work/litcap; . benches/pt_scenes.sh; T=${BIN:-target/release/translucent}; O=target/litcap/v; mkdir -p $O
mat=$1; name=$2; shift 2
if [ $mat = marble ]; then M="$MARBLE"; ref=$R/marble-sphere-dir-eta1.exr; ss=target/litcap/marble-front-ss.exr
else M="--material skimmilk --eta 1"; ref=$R/skimmilk-sphere-dir-eta1.exr; ss=target/litcap/milk-front-ss.exr; fi
nice -n 10 $T render $SPHERE $M --light $F --no-specular $S --exit-lobe ${LOBE:-chandra} "$@" --json --out $O/$mat-$name.exr > $O/$mat-$name.json 2> $O/$mat-$name.log || { echo "$mat $name failed"; tail -3 $O/$mat-$name.log; exit 1; }
python3 tools/compare_exr.py --json $O/$mat-$name.exr $ref > $O/$mat-$name.cmp.json 2>/dev/null
python3 -c "
import json; c = json.load(open('$O/$mat-$name.cmp.json')); print('$mat $name rel RMS', ', '.join(f'{100*v:.1f}' for v in c['rel_rms']), f'({100*c[\"rel_rms_all\"]:.1f})')"
