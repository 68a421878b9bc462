# The front's error split by self-shadowing (wave 11). usage:
#   shadow.py GEOM.npz SURFACE.obj LIGHT_DIR GEOM2.npz            # add per-pixel cast-shadow visibility
#   shadow.py GEOM2.npz OURS.exr REF.exr LIGHT_DIR                  # split the error
# GEOM.npz from geometry.py; LIGHT_DIR the light's travel direction (0.5,-1,-0.5 for the front).
# Visibility: one Mitsuba ray from the pixel's surface point (offset 0.05 mm along n and the light)
# towards the light on the display surface. Classes: lit (n.l > 0, visible), cast shadow (n.l > 0,
# occluded), attached (n.l <= 0); distance (pixels) from each lit / dark pixel to the other class.
import sys, math, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p): return np.array(mi.Bitmap(p), dtype=np.float64)
if sys.argv[2].endswith('.obj'):
    g = dict(np.load(sys.argv[1]))
    scene = mi.load_dict({'type': 'scene', 'object': {'type': 'obj', 'filename': sys.argv[2], 'face_normals': False}})
    L = -np.array([float(v) for v in sys.argv[3].split(',')]); L /= np.linalg.norm(L)
    vis = np.full(g['alpha'].shape, np.nan)
    for y, x in zip(*np.nonzero(g['alpha'] > 0)):
        o = g['pos'][y, x] + g['nrm'][y, x] * 0.05 + L * 0.05
        vis[y, x] = 0.0 if scene.ray_intersect(mi.Ray3f(mi.Point3f(*o), mi.Vector3f(*L))).is_valid() else 1.0
    g['vis'] = vis
    np.savez(sys.argv[4], **g)
    sys.exit(0)
g = np.load(sys.argv[1]); R = load(sys.argv[3]); a = R[..., 3]; m = a >= 0.999; ref = R[..., :3]
ours = load(sys.argv[2])[..., :3]
L = -np.array([float(v) for v in sys.argv[4].split(',')]); L /= np.linalg.norm(L)
nl = (g['nrm'] * L).sum(-1); vis = g['vis']
lit = (nl > 0) & (vis > 0.5); dark = ~lit
ys, xs = np.nonzero(a > 0)
pl = np.array([(y, x) for y, x in zip(ys, xs) if lit[y, x]]); pd = np.array([(y, x) for y, x in zip(ys, xs) if dark[y, x]])
D = np.full(a.shape, np.inf)
for y, x in zip(ys, xs):
    other = pd if lit[y, x] else pl
    if len(other): D[y, x] = np.sqrt(((other - [y, x]) ** 2).sum(1)).min()
err = ((ours - ref) ** 2).sum(-1); tot = err[m].sum(); refsq = (ref ** 2).sum(-1)[m].sum()
o = ours.sum(-1); r = ref.sum(-1)
print(f"all {100 * math.sqrt(tot / refsq):.2f}%  ours/ref {o[m].sum() / r[m].sum():.3f}")
def row(name, s):
    s = s & m
    if s.sum():
        e = err[s].sum()
        print(f"  {name:32s} {s.sum():5d} px  ours/ref {o[s].sum() / r[s].sum():6.3f}  err^2 share {e / tot:6.3f}  rms if perfect {100 * math.sqrt((tot - e) / refsq):5.2f}%")
row('lit (n.l > 0, visible)', lit); row('cast shadow (n.l > 0, occluded)', (nl > 0) & (vis < 0.5)); row('attached (n.l <= 0)', nl <= 0)
for lo, hi in ((0, 1.5), (1.5, 3), (3, 6), (6, np.inf)):
    row(f'lit, {lo}-{hi} px from dark', lit & (D > lo) & (D <= hi)); row(f'dark, {lo}-{hi} px from lit', dark & (D > lo) & (D <= hi))
for c, nm in enumerate('RGB'):
    print(f"  {nm}: {100 * math.sqrt(((ours[..., c] - ref[..., c]) ** 2)[m].sum() / (ref[..., c] ** 2)[m].sum()):.2f}%  ours/ref {ours[..., c][m].sum() / ref[..., c][m].sum():.3f}")
k = (ours[m] * ref[m]).sum() / (ours[m] ** 2).sum()
print(f"  best global scale {k:.3f}: {100 * math.sqrt(((k * ours - ref) ** 2).sum(-1)[m].sum() / refsq):.2f}%")
grey = ((ours / np.maximum(o / 3, 1e-9)[..., None] * (r / 3)[..., None] - ref) ** 2).sum(-1)
print(f"  colour only (ours' grey level replaced by the reference's): {100 * math.sqrt(grey[m].sum() / refsq):.2f}%")
