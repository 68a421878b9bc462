# What the back-lit sphere's error would be if our diffusion exitance were the Monte Carlo's
# (orders >= 2, per ring of n.l, ring_mc.py) with our Lambertian lobe, plus our single scattering.
# usage: predict.py OURS_DEF OURS_NOSS REF_FULL LIGHT
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p):
    b = np.array(mi.Bitmap(p)); return b[..., :3].astype(float), (b[..., 3] if b.shape[2] > 3 else None)
od, _ = load(sys.argv[1]); on, _ = load(sys.argv[2]); rf, alpha = load(sys.argv[3])
L = np.array([float(x) for x in sys.argv[4].split(',')]); L = -L / np.linalg.norm(L)
mc = [np.load(f'target/crescent/ring_{c}.npy') for c in 'RGB']
eye = np.array([0, 20, 60.]); fwd = -eye / np.linalg.norm(eye); up = np.array([0, 1, 0.]); right = np.cross(fwd, up); right /= np.linalg.norm(right); up = np.cross(right, fwd)
h, w = rf.shape[:2]; t = np.tan(np.radians(30) / 2); R = 10.0
pred = od.copy(); mask = alpha >= 0.999
for j in range(h):
    for i in range(w):
        if not mask[j, i]: continue
        x = (2 * (i + .5) / w - 1) * t; y = (1 - 2 * (j + .5) / h) * t
        d = fwd + x * right + y * up; d /= np.linalg.norm(d)
        b = eye @ d; c = eye @ eye - R * R; disc = b * b - c
        if disc < 0: mask[j, i] = False; continue
        n = (eye + (-b - np.sqrt(disc)) * d) / R; mu = n @ L
        pred[j, i] = (od[j, i] - on[j, i]) + np.array([np.interp(mu, m[0], m[2]) for m in mc]) / np.pi
def rel(a):
    return np.sqrt(((a[mask] - rf[mask]) ** 2).sum() / (rf[mask] ** 2).sum())
print(f"ours {rel(od):.3f}; ours SS + Monte Carlo exitance (>= 2) with Lambert's lobe {rel(pred):.3f}")
