# The front's shadow edges term by term (wave 13). usage:
#   edge_terms.py GEOM2.npz REF.exr LIGHT_DIR FULL.exr [NAME=TERM_OFF.exr ..]
# GEOM2.npz from shadow.py (per-pixel cast-shadow visibility); LIGHT_DIR the light's travel
# direction. For FULL and every TERM_OFF image: ours / ref over the lit and dark pixels within
# 1.5 px of the other class (shadow.py's classes). For every term T = FULL - TERM_OFF: its mean
# on lit pixels > 6 px from a dark one (its level where fully lit), and its mean on the dark
# pixels within 1.5 / 1.5-3 px of a lit one as a share of that level ("leak": 0 for a term that
# follows the true shadow edge, ~0.5 for one blurred over a few pixels).
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p): return np.array(mi.Bitmap(p), dtype=np.float64)
g = np.load(sys.argv[1]); R = load(sys.argv[2]); a = R[..., 3]; m = a >= 0.999
ref = R[..., :3].sum(-1)
L = -np.array([float(v) for v in sys.argv[3].split(',')]); L /= np.linalg.norm(L)
nl = (g['nrm'] * L).sum(-1); vis = g['vis']
lit = (nl > 0) & (vis > 0.5); dark = ~lit
ys, xs = np.nonzero(a > 0)
pl = np.array([(y, x) for y, x in zip(ys, xs) if lit[y, x]])
pd = np.array([(y, x) for y, x in zip(ys, xs) if dark[y, x]])
D = np.full(a.shape, np.inf)
for y, x in zip(ys, xs):
    other = pd if lit[y, x] else pl
    if len(other): D[y, x] = np.sqrt(((other - [y, x]) ** 2).sum(1)).min()
full = load(sys.argv[4])[..., :3].sum(-1)
cls = {'lit <=1.5': lit & (D <= 1.5), 'dark <=1.5': dark & (D <= 1.5),
       'dark 1.5-3': dark & (D > 1.5) & (D <= 3), 'cast': (nl > 0) & (vis < 0.5),
       'lit >6': lit & (D > 6)}
cls = {k: v & m for k, v in cls.items()}
def ratios(o):
    return '  '.join(f'{k} {o[s].sum() / ref[s].sum():.3f}' for k, s in cls.items())
print(f'full: {ratios(full)}')
for arg in sys.argv[5:]:
    name, path = arg.split('=', 1)
    off = load(path)[..., :3].sum(-1)
    t = full - off
    level = t[cls['lit >6']].mean()
    leak = '  '.join(f'{k} {t[cls[k]].mean() / level:.3f}'
                     for k in ('lit <=1.5', 'dark <=1.5', 'dark 1.5-3', 'cast'))
    print(f'{name} off: {ratios(off)}')
    print(f'  term {name}: level {level:.4f} ({level / ref[cls["lit >6"]].mean():.3f} of ref), '
          f'share of level: {leak}')
