# Any scene: pixels grouped by the reference's single-scattering share (Mitsuba depth 2 / full),
# our single scattering (default - `--single-scattering off`) against the reference's, and our
# diffusion against the reference's orders >= 2 (and >= 3 with a depth-3 file).
# usage: orders_any.py OURS_DEF OURS_NOSS REF_D2 REF_D3 REF_FULL
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p):
    b = np.array(mi.Bitmap(p)); return b[..., :3].astype(float).sum(2), (b[..., 3] if b.shape[2] > 3 else None)
od, _ = load(sys.argv[1]); on, _ = load(sys.argv[2]); r2, _ = load(sys.argv[3]); r3, _ = load(sys.argv[4]); rf, alpha = load(sys.argv[5])
m = alpha >= 0.999
od, on, r2, r3, rf = (a[m] for a in (od, on, r2, r3, rf))
share = r2 / np.maximum(rf, 1e-12); tot = ((od - rf) ** 2).sum()
print(f"pixels {m.sum()}, ours/ref {od.sum()/rf.sum():.3f}, rel RMS (channels summed) {np.sqrt(tot/(rf**2).sum()):.3f}")
print("ref SS share  n    | ours/ref  ourSS/refSS  ourDiff/ref(>=2)  ourDiff/ref(>=3) | err^2 share")
for lo, hi in ((0, .05), (.05, .2), (.2, .4), (.4, 1.01)):
    k = (share >= lo) & (share < hi)
    if k.sum() < 3: continue
    s = lambda a: a[k].sum()
    print(f"{lo:.2f}..{min(hi,1):.2f} {k.sum():5d} | {s(od)/s(rf):.3f}  {(s(od)-s(on))/s(r2):.3f}  {s(on)/(s(rf)-s(r2)):.3f}  {s(on)/(s(rf)-s(r3)):.3f} | {((od-rf)[k]**2).sum()/tot:.3f}")
