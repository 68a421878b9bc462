"""Ours / reference of the split .vol sphere (or any 10 mm sphere of benches/pt_scenes.sh, camera
0,20,60:0,0,0:30, light dir:0.5,-1,-0.5) by region: the halves and the ramp between them (y of
the hit point on the analytic sphere), lit / terminator by n.l, the silhouette by the view
cosine; per channel the ratio of sums and the share of the squared error. Optionally writes the
ratio image (0.7..1.3 mapped to 0..1 per channel).

    target/pt-venv/bin/python benches/heterogeneous/split_regions.py OURS.exr REFERENCE.exr [RATIO.png]
"""
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
def load(p):
    b = np.array(mi.Bitmap(p)).astype(float); return b[..., :3], (b[..., 3] if b.shape[2] > 3 else None)
ours, _ = load(sys.argv[1]); ref, alpha = load(sys.argv[2])
L = -np.array([0.5, -1, -0.5]); L /= np.linalg.norm(L)
eye = np.array([0, 20, 60.]); fwd = -eye / np.linalg.norm(eye); up = np.array([0, 1, 0.])
right = np.cross(fwd, up); right /= np.linalg.norm(right); up = np.cross(right, fwd)
h, w = ref.shape[:2]; t = np.tan(np.radians(30) / 2); R = 10.0
rows = []
for j in range(h):
    for i in range(w):
        if alpha[j, i] < 0.999: continue
        x = (2 * (i + .5) / w - 1) * t; y = (1 - 2 * (j + .5) / h) * t
        d = fwd + x * right + y * up; d /= np.linalg.norm(d)
        b = np.dot(eye, d); c = np.dot(eye, eye) - R * R; disc = b * b - c
        if disc < 0: continue
        s = -b - np.sqrt(disc); p = eye + s * d; n = p / R
        rows.append((p[1], np.dot(n, L), -np.dot(n, d), *ours[j, i], *ref[j, i]))
a = np.array(rows); py, nl, vc = a[:, 0], a[:, 1], a[:, 2]; o = a[:, 3:6]; r = a[:, 6:9]
tot = ((o - r) ** 2).sum(0); den = (r ** 2).sum(0)
print(f"pixels {len(a)}  rel RMS R,G,B: " + ", ".join(f"{100*np.sqrt(tot[c]/den[c]):.1f}" for c in range(3)))
regions = {
    'milk y<-5': py < -5, 'ramp -5..0': (py >= -5) & (py < 0), 'ramp 0..5': (py >= 0) & (py < 5), 'skin y>5': py >= 5,
    'lit n.l>0.3': nl > 0.3, 'terminator |n.l|<0.3': np.abs(nl) <= 0.3, 'unlit n.l<-0.3': nl < -0.3,
    'silhouette vc<0.3': vc < 0.3, 'inner vc>=0.3': vc >= 0.3,
    'skin lit': (py >= 5) & (nl > 0.3), 'milk lit': (py < -5) & (nl > 0.3), 'milk unlit': (py < -5) & (nl < -0.3),
    'ramp lit': (np.abs(py) < 5) & (nl > 0.3), 'ramp unlit': (np.abs(py) < 5) & (nl < -0.3),
}
print(f"{'region':22s} {'n':>5s}  ratio R G B (sum ours/sum ref)   share of err^2 R G B")
for k, m in regions.items():
    if m.sum() == 0: continue
    ra = o[m].sum(0) / r[m].sum(0); sh = ((o[m] - r[m]) ** 2).sum(0) / tot
    print(f"{k:22s} {m.sum():5d}  " + " ".join(f"{v:.3f}" for v in ra) + "   " + " ".join(f"{v:.2f}" for v in sh))
if len(sys.argv) > 3:
    ratio = np.where(alpha[..., None] > 0.999, ours / np.maximum(ref, 1e-6), 1.0)
    # map 0.7..1.3 -> 0..1 per channel, written as a PNG
    img = np.clip((ratio - 0.7) / 0.6, 0, 1)
    mi.util.write_bitmap(sys.argv[3], mi.Bitmap(np.ascontiguousarray(img.astype(np.float32)), pixel_format=mi.Bitmap.PixelFormat.RGB).convert(srgb_gamma=False))
