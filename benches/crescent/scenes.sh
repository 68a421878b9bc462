# benches/crescent/scenes.sh: per scene of benches/pt_scenes.sh, GPU default and --single-scattering off, CPU second base and --upstream-beam; prints add_ss.py for both (ketchup: NaN, use the skin1 mask by hand)
. benches/pt_scenes.sh; O=target/crescent/sc; mkdir -p $O; T=target/release/translucent; P=target/pt-venv/bin/python
run() { name=$1; ref=$2; shift 2
  nice -n 10 $T render "$@" $S --out $O/$name-def.exr > /dev/null 2>&1
  nice -n 10 $T render "$@" $S --single-scattering off --out $O/$name-noss.exr > /dev/null 2>&1
  nice -n 10 $T render "$@" $S --solver cpu --source second --out $O/$name-cpu.exr > /dev/null 2>&1
  nice -n 10 $T render "$@" $S --solver cpu --source second --upstream-beam --out $O/$name-up.exr > /dev/null 2>&1
  for v in cpu up; do echo "$name $v: $($P benches/crescent/add_ss.py $O/$name-$v.exr $O/$name-def.exr $O/$name-noss.exr $R/$ref 2>&1 | tail -1)"; done
  echo "$name gpu: $(python3 tools/compare_exr.py $MASK $O/$name-def.exr $R/$ref | tail -1)"
}
pt_scenes
