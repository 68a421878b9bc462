#!/bin/sh
# benches/bounce.sh: `render --bounce off|local` (issue 12 item 5, one bounce of exitance between
# display vertices) on the path-traced references of tests/reference/pt/ where light leaves the
# surface and enters it again (concave parts), and on the convex front-lit sphere (must not move).
# Run from the repository root after `cargo build --release -p translucent-tools` and
# `python3 tests/reference/pt/make_shapes.py`. Render defaults otherwise (resolution 48, 96 px,
# supersample 2, single scattering on, `--source` default), the lights and camera of
# benches/gpu_terms.sh.
#
#   sh benches/bounce.sh                               # every scene, off and local
#   BOUNCE_SCENES="ublock-front plate-back" BOUNCE_MODES=local sh benches/bounce.sh
#   BOUNCE_EXTRA="--bounce-rays 64" sh benches/bounce.sh
#
# Writes target/bounce/*.{exr,json,trace.json,compare.json} and prints per render: relative RMS
# R, G, B (all) in %, ratio of means, GPU ms of the frame and of the pass `bounce`, the links
# (count, bytes per display vertex, bake seconds) and the wall seconds.
C=0,20,60:0,0,0:30; R=tests/reference/pt; T=target/release/translucent; O=${BOUNCE_OUT:-target/bounce}; mkdir -p $O
MODES=${BOUNCE_MODES:-"off local"}
F=dir:0.5,-1,-0.5:4,4,4; B=dir:0.2,-0.35,1:5,5,5; S="--camera $C --width 96 --height 96"
MARBLE="--material marble --eta 1"; SPHERE="--shape sphere --size-mm 20"; BUNNY="--mesh ../shared/meshes/stanford-bunny.obj --size-mm 20"
run() { name=$1; ref=$2; shift 2
  case " ${BOUNCE_SCENES:-$name} " in *" $name "*) ;; *) return ;; esac
  for m in $MODES; do
    out=$O/$name-$m; start=$(date +%s)
    nice -n 10 $T render "$@" $S --bounce $m $BOUNCE_EXTRA --json --profile --trace $out.trace.json --out $out.exr > $out.json 2> $out.log
    rc=$?; end=$(date +%s)
    if [ $rc -ne 0 ]; then echo "$name $m: render failed (rc $rc, $out.log)"; continue; fi
    python3 tools/compare_exr.py --json $out.exr $R/$ref > $out.compare.json 2>> $out.log
    python3 - "$name" "$m" "$out" $((end-start)) <<'PY'
import json, sys
name, mode, prefix, secs = sys.argv[1:5]
cmp = json.load(open(prefix + ".compare.json")); run = json.load(open(prefix + ".json"))
ev = json.load(open(prefix + ".trace.json"))["traceEvents"]
total = sum(e["dur"] for e in ev if e["args"]["depth"] == 0) / 1000.0
bounce = sum(e["dur"] for e in ev if e["name"] == "bounce") / 1000.0
rel = ", ".join(f"{100 * v:.1f}" for v in cmp["rel_rms"])
b = run.get("bounce") or {}
links = (f"links {b['links']} ({b['linked_vertices']}/{b['display_vertices']} vertices), "
         f"{b['bytes_per_vertex']:.1f} B/vertex, bake {b['build_seconds']:.2f} s") if b else "no links"
print(f"{name} {mode}: {rel} ({100 * cmp['rel_rms_all']:.1f}) | ratio of means "
      + ", ".join(f"{r:.3f}" for r in cmp["ratio_of_means"])
      + f" | GPU ms frame {total:.1f}, bounce {bounce:.2f} | {links} | {secs} s")
PY
  done
}
run marble-sphere marble-sphere-dir-eta1.exr $SPHERE $MARBLE --light $F --no-specular
run ublock-front ublock-marble-dir-eta1.exr --mesh target/pt-shapes/u-block.obj --size-mm 20 $MARBLE --light $F --no-specular
run ublock-back ublock-marble-backlit-eta1.exr --mesh target/pt-shapes/u-block.obj --size-mm 20 $MARBLE --light $B --no-specular
run plate-back plate-on-base-backlit-eta1.exr --mesh target/pt-shapes/plate-on-base.obj --size-mm 30 $MARBLE --light $B --no-specular
run torus-back marble-torus-backlit-eta1.exr --shape torus --size-mm 20 $MARBLE --light $B --no-specular
run bunny-side bunny-marble-side-eta1.exr $BUNNY $MARBLE --light dir:1,-0.2,0:5,5,5 --no-specular
