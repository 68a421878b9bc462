"""The exit lobe's slope swept over the path-traced references, from two renders per scene.

At eta 1 a lobe of slope b multiplies the diffusion's radiance by
g_b(mu) = (1 + b mu) / (1 + 2 b / 3), so g_b - 1 = c_b (g_p1 - 1) with
c_b = (b / (1 + 2 b / 3)) / (1.5 / 2): every slope's image is lambert + c_b (p1 - lambert),
exactly (single scattering, not shaped by the lobe, cancels in the difference).
Run after `sh benches/exit_lobe/lobe_table.sh` (its target/exit-lobe/*-{lambert,p1}.exr):

    python3 benches/exit_lobe/lobe_sweep.py
"""
import sys
from pathlib import Path

sys.dont_write_bytecode = True
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import compare_exr as c  # noqa: E402

R = "tests/reference/pt/"
SKIN1 = R + "skin1-sphere-dir-eta1.exr"
SCENES = {  # eta 1 scenes only (the environment sphere is eta 1.3: rendered, not swept)
    "milk-front": "skimmilk-sphere-dir-eta1.exr", "marble-front": "marble-sphere-dir-eta1.exr",
    "split-front": "split-sphere-dir-eta1.exr", "bunny-front": "bunny-marble-dir-eta1.exr",
    "bunny-side": "bunny-marble-side-eta1.exr", "marble-back": "marble-sphere-backlit-eta1.exr",
    "torus-back": "marble-torus-backlit-eta1.exr", "plate-back": "plate-on-base-backlit-eta1.exr",
    "ublock-front": "ublock-marble-dir-eta1.exr", "ublock-back": "ublock-marble-backlit-eta1.exr",
    "skin1-sphere": "skin1-sphere-dir-eta1.exr", "ketchup-sphere": "ketchup-sphere-dir-eta1.exr",
}
SLOPES = [0.0, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5]


def main():
    c.ensure_mitsuba()
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    out = Path("target/exit-lobe")
    print("scene          " + " ".join(f"b={b:<5}" for b in SLOPES) + "  best")
    totals = [[] for _ in SLOPES]
    for name, ref in SCENES.items():
        lam, _ = c.load(out / f"{name}-lambert.exr")
        p1, _ = c.load(out / f"{name}-p1.exr")
        reference, alpha = c.load(Path(R + ref))
        if name == "ketchup-sphere":
            alpha = c.load(Path(SKIN1))[1]
        mask = alpha >= 0.999
        errs = []
        for i, b in enumerate(SLOPES):
            cb = (b / (1 + 2 * b / 3)) / 0.75
            e = c.relative_rms(lam + cb * (p1 - lam), reference, mask)["rel_rms_all"]
            errs.append(e)
            totals[i].append(e)
        best = SLOPES[min(range(len(SLOPES)), key=lambda i: errs[i])]
        print(f"{name:14s} " + " ".join(f"{e*100:7.2f}" for e in errs) + f"  {best}")
    mean = [sum(t) / len(t) for t in totals]
    print(f"{'mean':14s} " + " ".join(f"{e*100:7.2f}" for e in mean))


if __name__ == "__main__":
    main()
