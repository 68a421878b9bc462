# Per band of n.l (and view cosine) on the analytic back-lit sphere: the reference's orders
# (exact single scattering SS, Mitsuba depth 3 = SS + double, full) against our terms
# (our SS = default - `--single-scattering off`; our diffusion = the `off` render).
# usage: terms.py OURS_DEF OURS_NOSS REF_SS REF_D3 REF_FULL LIGHT [REF_D5]
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p):
    b = np.array(mi.Bitmap(p)); return b[..., :3].astype(float), b[..., 3] if b.shape[2] > 3 else None
od, _ = load(sys.argv[1]); on, _ = load(sys.argv[2]); rss, _ = load(sys.argv[3]); rd3, _ = load(sys.argv[4]); rf, alpha = load(sys.argv[5])
L = np.array([float(x) for x in sys.argv[6].split(',')]); L = -L / np.linalg.norm(L)
rd5 = load(sys.argv[7])[0] if len(sys.argv) > 7 else None
eye = np.array([0, 20, 60.]); fwd = -eye / np.linalg.norm(eye); up = np.array([0, 1, 0.]); right = np.cross(fwd, up); right /= np.linalg.norm(right); up = np.cross(right, fwd)
h, w = rf.shape[:2]; t = np.tan(np.radians(30) / 2); R = 10.0
rows = []
for j in range(h):
    for i in range(w):
        if alpha[j, i] < 0.999: continue
        x = (2 * (i + .5) / w - 1) * t; y = (1 - 2 * (j + .5) / h) * t
        d = fwd + x * right + y * up; d /= np.linalg.norm(d)
        b = eye @ d; c = eye @ eye - R * R; disc = b * b - c
        if disc < 0: continue
        p = eye + (-b - np.sqrt(disc)) * d; n = p / R
        v = [n @ L, -(n @ d), od[j, i].sum(), on[j, i].sum(), rss[j, i].sum(), rd3[j, i].sum(), rf[j, i].sum()]
        v.append(rd5[j, i].sum() if rd5 is not None else np.nan)
        rows.append(v)
a = np.array(rows)
nl, vc, ours, diff, rss_, rd3_, rf_, rd5_ = a.T
oss = ours - diff
tot = ((ours - rf_) ** 2).sum()
print(f"pixels {len(a)}, rel RMS all (summed channels) {np.sqrt(((ours-rf_)**2).sum()/(rf_**2).sum()):.3f}")
print("n.l band    n  | ref: SS%  DS%  d4-5% rest% | ours/ref ourSS/refSS ourDiff/ref(multi) ourDiff/ref(order>=3) | err^2 share")
def row(m, label):
    if m.sum() < 3: return
    s = lambda q: q[m].sum()
    ss, d3, f, d5 = s(rss_), s(rd3_), s(rf_), s(rd5_)
    print(f"{label} {m.sum():5d} | {100*ss/f:5.1f} {100*(d3-ss)/f:5.1f} {100*(d5-d3)/f:5.1f} {100*(f-d5)/f:5.1f} | "
          f"{s(ours)/f:.3f}  {s(oss)/ss:.3f}  {s(diff)/(f-ss):.3f}  {s(diff)/(f-d3):.3f} | {((ours-rf_)[m]**2).sum()/tot:.3f}")
for lo in np.arange(-1, 1, 0.2):
    row((nl >= lo) & (nl < lo + 0.2), f"{lo:+.1f}..{lo+.2:+.1f}")
print("terminator band n.l in [-0.2, 0.2] by view cosine")
for lo in np.arange(0, 1, 0.2):
    row((np.abs(nl) < 0.2) & (vc >= lo) & (vc < lo + 0.2), f"vc {lo:.1f}..{lo+.2:.1f}")
