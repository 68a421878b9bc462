# usage: rows.py REF OURS.. : ours/ref (channels summed) per n.l band, and rel RMS (all)
import sys, json, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p):
    b = np.array(mi.Bitmap(p)); return b[..., :3].astype(float), b[..., 3] if b.shape[2] > 3 else None
rf, alpha = load(sys.argv[1])
L = np.array([0.5, -1, -0.5]); L = -L / np.linalg.norm(L)
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
bands = [(-0.2, 0), (0, 0.2), (0.2, 0.4), (0.4, 0.6), (0.6, 0.8), (0.8, 1.01)]
print('variant'.ljust(28) + ' '.join(f'{a:+.1f}..{b:+.1f}' for a, b in bands) + '   RMS% (alpha mask)')
for p in sys.argv[2:]:
    o = load(p)[0][J, I]
    cells = [o[(NL >= a) & (NL < b)].sum() / r[(NL >= a) & (NL < b)].sum() for a, b in bands]
    om, _ = load(p); m = alpha >= 0.999
    rms = np.sqrt(((om[m] - rf[m][:, :3]) ** 2).sum() / (rf[m][:, :3] ** 2).sum())
    print(p.split('/')[-1][:-4].ljust(28) + ' '.join(f'{c:9.3f}' for c in cells) + f'   {100*rms:.1f}')
