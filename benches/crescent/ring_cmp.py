# Per n.l band: our diffusion's exitance (pi L, Lambert at eta 1) against the Monte Carlo's
# exitance of photons scattered >= 2 times (ring_mc.py), and the reference's lobe
# (reference multiple-scattering radiance / (M2 / pi)). usage: ring_cmp.py OURS_NOSS REF_FULL REF_SS LIGHT
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p):
    b = np.array(mi.Bitmap(p)); return b[..., :3].astype(float), (b[..., 3] if b.shape[2] > 3 else None)
on, _ = load(sys.argv[1]); rf, alpha = load(sys.argv[2]); rss, _ = load(sys.argv[3])
L = np.array([float(x) for x in sys.argv[4].split(',')]); L = -L / np.linalg.norm(L)
mc = [np.load(f'target/crescent/ring_{c}.npy') for c in 'RGB']
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
        p = eye + (-b - np.sqrt(disc)) * d; n = p / R; mu = n @ L
        m2 = sum(np.interp(mu, m[0], m[2]) for m in mc); ma = sum(np.interp(mu, m[0], m[1]) for m in mc)
        rows.append((mu, -(n @ d), np.pi * on[j, i].sum(), m2, ma, (rf[j, i] - rss[j, i]).sum() * np.pi))
a = np.array(rows); mu, vc, mo, m2, ma, rm = a.T
print("n.l band      n | M_ours/M_mc(all) M_ours/M_mc(>=2)  refMultiRadiance/(M_mc/pi)=lobe  ours/refMulti")
for lo in np.arange(-1, 0.4, 0.1):
    m = (mu >= lo) & (mu < lo + 0.1)
    if m.sum() < 3: continue
    print(f"{lo:+.1f}..{lo+.1:+.1f} {m.sum():5d} | {mo[m].sum()/ma[m].sum():.3f}  {mo[m].sum()/m2[m].sum():.3f}   {rm[m].sum()/m2[m].sum():.3f}   {mo[m].sum()/rm[m].sum():.3f}")
