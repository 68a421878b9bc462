# ours / reference per band of n.l and per channel on the front-lit sphere (benches/litcap/rows.py
# split by channel). usage: rows_ch.py REF OURS..
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p): return np.array(mi.Bitmap(p)).astype(float)
rf = load(sys.argv[1]); alpha = rf[..., 3]; rf = rf[..., :3]
import os; L = np.array([float(v) for v in os.environ.get("LIGHT", "0.5,-1,-0.5").split(",")]); L = -L / np.linalg.norm(L)
eye = np.array([0, 20, 60.]); fwd = -eye / np.linalg.norm(eye); up = np.array([0, 1, 0.]); right = np.cross(fwd, up); right /= np.linalg.norm(right); up = np.cross(right, fwd)
h, w = rf.shape[:2]; t = np.tan(np.radians(30) / 2); R = 10.0
J, I, NL = [], [], []
for j in range(h):
    for i in range(w):
        if alpha[j, i] < 0.999: continue
        x = (2 * (i + .5) / w - 1) * t; y = (1 - 2 * (j + .5) / h) * t
        d = fwd + x * right + y * up; d /= np.linalg.norm(d)
        b = eye @ d; c = eye @ eye - R * R; disc = b * b - c
        if disc < 0: continue
        p = eye + (-b - np.sqrt(disc)) * d; J.append(j); I.append(i); NL.append(p / R @ L)
J, I, NL = map(np.array, (J, I, NL)); r = rf[J, I]
bands = [(-1, -0.2), (-0.2, 0), (0, 0.2), (0.2, 0.4), (0.4, 0.6), (0.6, 0.8), (0.8, 1.01)]
print('band'.ljust(22) + ' '.join(f'{a:+.1f}..{b:+.1f}' for a, b in bands) + '   RMS% R G B (all)')
for p in sys.argv[2:]:
    om = load(p)[..., :3]; o = om[J, I]; m = alpha >= 0.999
    rms = [np.sqrt(((om[m][:, c] - rf[m][:, c]) ** 2).sum() / (rf[m][:, c] ** 2).sum()) for c in range(3)]
    ra = np.sqrt(((om[m] - rf[m]) ** 2).sum() / (rf[m] ** 2).sum())
    for c, nm in enumerate('RGB'):
        cells = [o[(NL >= a) & (NL < b), c].sum() / r[(NL >= a) & (NL < b), c].sum() for a, b in bands]
        print((p.split('/')[-1][:-4][:18] + ' ' + nm).ljust(22) + ' '.join(f'{x:9.3f}' for x in cells)
              + (f'   {100*rms[0]:.1f} {100*rms[1]:.1f} {100*rms[2]:.1f} ({100*ra:.1f})' if c == 0 else ''))
    # share of the squared error per band (channels pooled)
    se = ((om[m] - rf[m]) ** 2).sum(); e = ((o - r) ** 2).sum(1)
    print('  sq-err share'.ljust(22) + ' '.join(f'{e[(NL >= a) & (NL < b)].sum() / se:9.3f}' for a, b in bands))
