# side.sh TAG: bunny side at the defaults (env XP_* passed through), prints the error and region ratios
. benches/pt_scenes.sh
tag=$1; shift
nice -n 5 target/release/translucent render $BUNNY $MARBLE --light dir:1,-0.2,0:5,5,5 --no-specular $S "$@" --json --out target/lat/side-$tag.exr > target/lat/side-$tag.json 2> target/lat/side-$tag.log || { echo fail; tail -3 target/lat/side-$tag.log; }
python3 tools/compare_exr.py target/lat/side-$tag.exr $R/bunny-marble-side-eta1.exr | tail -1
target/pt-venv/bin/python benches/lateral/ratio.py target/lat/side-$tag.exr /work/main/target/defaults-table/bunny-side.exr tests/reference/pt/bunny-marble-side-eta1.exr 2>&1 | tail -5
