# Per band of n.l x view cosine on the analytic front-lit sphere: ours/ref, our SS / exact SS,
# our diffusion / (ref - exact SS). usage: split.py OURS_DEF OURS_NOSS REF_SS REF_FULL LIGHT
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p):
    b = np.array(mi.Bitmap(p)); return b[..., :3].astype(float), b[..., 3] if b.shape[2] > 3 else None
od, _ = load(sys.argv[1]); on, _ = load(sys.argv[2]); rss, _ = load(sys.argv[3]); rf, alpha = load(sys.argv[4])
L = np.array([float(x) for x in sys.argv[5].split(',')]); L = -L / np.linalg.norm(L)
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
        rows.append([n @ L, -(n @ d)] + list(od[j, i]) + list(on[j, i]) + list(rss[j, i]) + list(rf[j, i]))
a = np.array(rows); nl, vc = a[:, 0], a[:, 1]
od, on, rs, rf = a[:, 2:5], a[:, 5:8], a[:, 8:11], a[:, 11:14]
def row(m, label):
    if m.sum() < 3: return
    s = lambda q: q[m].sum(0)
    f = s(rf); ss = s(rs)
    print(f"{label} {m.sum():4d} refSS% {100*ss.sum()/f.sum():4.1f} | ours/ref " + " ".join(f"{v:.3f}" for v in s(od)/f) + f" ({s(od).sum()/f.sum():.3f})"
          + " | ourSS/refSS " + " ".join(f"{v:.3f}" for v in (s(od)-s(on))/ss)
          + " | diff/(ref-SS) " + " ".join(f"{v:.3f}" for v in s(on)/(f-ss)) + f" ({s(on).sum()/(f-ss).sum():.3f})")
for lo in np.arange(-0.2, 1, 0.2):
    row((nl >= lo) & (nl < lo + 0.2), f"nl {lo:+.1f}")
print("n.l 0.8-1 by view cosine")
for lo in np.arange(0.2, 1, 0.2):
    row((nl >= 0.8) & (vc >= lo) & (vc < lo + 0.2), f"vc {lo:.1f}")
