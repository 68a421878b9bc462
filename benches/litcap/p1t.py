# What the P1 tangential-flux term would do: diffusion part x (1 - (3/2)(D/R) dlnM/dtheta (w . e_theta)),
# with dlnM/dtheta from the Monte Carlo rings. usage: p1t.py marble|milk DEF NOSS REF [SCALE]
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
mat = sys.argv[1]; sc = float(sys.argv[5]) if len(sys.argv) > 5 else 1.0
chs = ['R', 'G', 'B'] if mat == 'marble' else ['mR', 'mG', 'mB']
co = {'R': (2.19, 0.0021), 'G': (2.62, 0.0041), 'B': (3.0, 0.0071), 'mR': (0.7, 0.0014), 'mG': (1.22, 0.0025), 'mB': (1.9, 0.0142)}
Ds = [(2 * co[c][1] + co[c][0]) / (3 * (co[c][0] + co[c][1]) ** 2) for c in chs]
rings = [np.load(f'target/litcap/ring_{c}.npy') for c in chs]
dl = []
for q in rings:
    th = np.arccos(q[0]); dl.append((q[0], np.gradient(np.log(np.maximum(q[2], 1e-12)), th)))
ld = lambda p: np.array(mi.Bitmap(p))
od, on, rf = ld(sys.argv[2])[..., :3], ld(sys.argv[3])[..., :3], ld(sys.argv[4]); alpha = rf[..., 3]; rf = rf[..., :3]
L = np.array([0.5, -1, -0.5]); L = -L / np.linalg.norm(L)
eye = np.array([0, 20, 60.]); fwd = -eye / np.linalg.norm(eye); up = np.array([0, 1, 0.]); right = np.cross(fwd, up); right /= np.linalg.norm(right); up = np.cross(right, fwd)
h, w = rf.shape[:2]; t = np.tan(np.radians(30) / 2); R = 10.0
new = od.copy()
for j in range(h):
    for i in range(w):
        x = (2 * (i + .5) / w - 1) * t; y = (1 - 2 * (j + .5) / h) * t
        d = fwd + x * right + y * up; d /= np.linalg.norm(d)
        b = eye @ d; c = eye @ eye - R * R; disc = b * b - c
        if disc < 0: continue
        p = eye + (-b - np.sqrt(disc)) * d; n = p / R; mu = n @ L
        et = n * mu - L; nt = np.linalg.norm(et)
        if nt < 1e-6: continue
        et /= nt; wt = -d @ et
        for k in range(3):
            g = np.interp(mu, dl[k][0], dl[k][1])
            f = 1 - sc * 1.5 * Ds[k] / R * g * wt
            new[j, i, k] = (od[j, i, k] - on[j, i, k]) + on[j, i, k] * max(f, 0)
m = alpha >= 0.999
def rms(a): return np.sqrt(((a[m] - rf[m]) ** 2).sum(0) / (rf[m] ** 2).sum(0)), np.sqrt(((a[m] - rf[m]) ** 2).sum() / (rf[m] ** 2).sum())
for name, a in [('as rendered', od), (f'with P1 tangential x{sc}', new)]:
    r, al = rms(a); print(name.ljust(28), ', '.join(f'{100*v:.1f}' for v in r), f'({100*al:.1f})')
