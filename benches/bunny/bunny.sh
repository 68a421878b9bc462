# benches/bunny/bunny.sh TAG [render options]: the two bunny references at render's defaults plus the options,
# images and metric under target/bunny/ (run from the repository root).
mkdir -p target/bunny
. benches/pt_scenes.sh; T=target/release/translucent; O=target/bunny; tag=$1; shift
for sc in front side; do
  if [ $sc = front ]; then L=$F; ref=bunny-marble-dir-eta1.exr; else L=dir:1,-0.2,0:5,5,5; ref=bunny-marble-side-eta1.exr; fi
  nice -n 10 $T render $BUNNY $MARBLE --light $L --no-specular $S "$@" --out $O/$tag-$sc.exr > $O/$tag-$sc.log 2>&1 || { echo "$tag $sc failed"; tail -3 $O/$tag-$sc.log; continue; }
  python3 tools/compare_exr.py --json $O/$tag-$sc.exr $R/$ref > $O/$tag-$sc.json
  python3 -c "
import json; c=json.load(open('$O/$tag-$sc.json'))
print('$tag $sc: ' + ', '.join(f'{100*v:.1f}' for v in c['rel_rms']) + f' ({100*c[\"rel_rms_all\"]:.2f}) ratio ' + ' '.join(f'{v:.3f}' for v in c['ratio_of_means']))"
done
