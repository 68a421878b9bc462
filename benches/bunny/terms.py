# The front's light split into single scattering, diffusion and bounce, each against path tracing
# (wave 11). usage: terms.py REF.exr PT_SS.exr DEFAULT.exr SS_OFF.exr SS_OFF_BOUNCE_OFF.exr GEOM2.npz LIGHT_DIR
# PT_SS.exr: tools/pt_reference.py with --max-depth 2 (paths of one scattering event: the reference's
# single scattering). Ours: render at the defaults, with --single-scattering off (`second`: the
# once-scattered light is the march's alone) and with --single-scattering off --bounce off.
import sys, math, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p): return np.array(mi.Bitmap(p), dtype=np.float64)
R = load(sys.argv[1]); m = R[..., 3] >= 0.999; ref = R[..., :3]
pss = load(sys.argv[2])[..., :3]; pms = ref - pss
full, noss, diff = (load(p)[..., :3] for p in sys.argv[3:6])
g = np.load(sys.argv[6]); L = -np.array([float(v) for v in sys.argv[7].split(',')]); L /= np.linalg.norm(L)
nl = (g['nrm'] * L).sum(-1); vis = g['vis']
ss = full - noss; bounce = noss - diff; refsq = (ref ** 2).sum(-1)[m].sum()
rms = lambda x: 100 * math.sqrt((x ** 2).sum(-1)[m].sum() / refsq)
print(f"single scattering: PT {pss[m].sum() / ref[m].sum():.3f} of the reference, ours / PT {ss[m].sum() / pss[m].sum():.3f}, rms of the difference {rms(ss - pss):.2f}% (of the reference)")
print(f"multiple scattering (diffusion + bounce): ours / PT {noss[m].sum() / pms[m].sum():.3f}, rms {rms(noss - pms):.2f}%; diffusion alone / PT {diff[m].sum() / pms[m].sum():.3f}, bounce {bounce[m].sum() / pms[m].sum():.3f} of PT's")
for name, s in (('lit', (nl > 0) & (vis > 0.5)), ('cast shadow', (nl > 0) & (vis < 0.5)), ('attached', nl <= 0)):
    s = s & m
    print(f"  {name:12s} SS ours / PT {ss[s].sum() / max(pss[s].sum(), 1e-12):.3f} (PT SS {pss[s].sum() / ref[s].sum():.3f} of the reference); diffusion / PT multiple {diff[s].sum() / pms[s].sum():.3f}, bounce {bounce[s].sum() / pms[s].sum():.3f}")
for k in (0.0, 0.5, 0.75, 1.0, 1.25):
    x = full - (1 - k) * bounce
    print(f"  bounce x{k}: {rms(x - ref):.2f}%  ours/ref {x[m].sum() / ref[m].sum():.3f}")
