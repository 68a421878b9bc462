# benches/pt_scenes.sh: the path-traced references of tests/reference/pt/ as `translucent render`
# scene options (lights, camera, materials as the references were made), sourced by
# benches/gpu_terms.sh and benches/defaults_table.sh. Defines R, C, F, B, S, MARBLE, SPHERE, BUNNY
# and `pt_scenes`, which calls the caller's `run NAME REFERENCE.exr RENDER-OPTIONS..` once per
# scene with MASK set to the compare_exr.py mask option the scene needs.
C=0,20,60:0,0,0:30; R=tests/reference/pt
F=dir:0.5,-1,-0.5:4,4,4; B=dir:0.2,-0.35,1:5,5,5; S="--camera $C --width 96 --height 96"
MARBLE="--material marble --eta 1"; SPHERE="--shape sphere --size-mm 20"; BUNNY="--mesh ../shared/meshes/stanford-bunny.obj --size-mm 20"
pt_scenes() {
MASK=""
run milk-sphere skimmilk-sphere-dir-eta1.exr $SPHERE --material skimmilk --eta 1 --light $F --no-specular
run marble-sphere marble-sphere-dir-eta1.exr $SPHERE $MARBLE --light $F --no-specular
run split-sphere split-sphere-dir-eta1.exr $SPHERE --volume $R/milk-skin-split.vol --eta 1 --light $F --no-specular
run bunny-front bunny-marble-dir-eta1.exr $BUNNY $MARBLE --light $F --no-specular
run bunny-side bunny-marble-side-eta1.exr $BUNNY $MARBLE --light dir:1,-0.2,0:5,5,5 --no-specular
run marble-back marble-sphere-backlit-eta1.exr $SPHERE $MARBLE --light $B --no-specular
run torus-back marble-torus-backlit-eta1.exr --shape torus --size-mm 20 $MARBLE --light $B --no-specular
# Constant environment, eta 1.3: specular on (the reflection drawn, as the reference has it).
run marble-env marble-sphere-env-eta1.3.exr $SPHERE --material marble --eta 1.3 --env-constant 1,1,1 --light dir:0,-1,0:0,0,0
run plate-back plate-on-base-backlit-eta1.exr --mesh target/pt-shapes/plate-on-base.obj --size-mm 30 $MARBLE --light $B --no-specular
run ublock-front ublock-marble-dir-eta1.exr --mesh target/pt-shapes/u-block.obj --size-mm 20 $MARBLE --light $F --no-specular
run ublock-back ublock-marble-backlit-eta1.exr --mesh target/pt-shapes/u-block.obj --size-mm 20 $MARBLE --light $B --no-specular
run skin1-sphere skin1-sphere-dir-eta1.exr $SPHERE --material skin1 --eta 1 --light $F --no-specular
# Ketchup: its reference has alpha < 0.999 everywhere (rays cross it unscattered): the skin1 file's mask.
MASK="--mask-from $R/skin1-sphere-dir-eta1.exr"
run ketchup-sphere ketchup-sphere-dir-eta1.exr $SPHERE --material ketchup --eta 1 --light $F --no-specular
MASK=""
}
