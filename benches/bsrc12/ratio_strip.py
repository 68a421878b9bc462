# A strip of ratio images, 4x upscaled: source / local (blue < 1 < red, 0.85..1.15), local / ref
# and source / ref (0.7..1.3), |source - ref| - |local - ref| (blue: source closer, red: farther,
# +-5% of the reference's mean); prints the share of the squared-error change per region of that
# last map. usage: ratio_strip.py SOURCE.exr LOCAL.exr REF.exr OUT.png
import sys, numpy as np
sys.path.insert(0, 'tools')
from compare_exr import load
from pathlib import Path
import mitsuba as mi
mi.set_variant('scalar_rgb')
(src, _), (loc, _), (ref, ra) = (load(Path(p)) for p in sys.argv[1:4])
m = ra >= 0.999
s, l, r = src.mean(2), loc.mean(2), ref.mean(2)
def cmap(x, lo, hi):
    t = np.clip((x - lo) / (hi - lo), 0, 1)[..., None]
    blue, white, red = np.array([0.1, 0.3, 1.0]), np.ones(3), np.array([1.0, 0.15, 0.1])
    c = np.where(t < 0.5, blue + (white - blue) * (t * 2), white + (red - white) * (t * 2 - 1))
    return np.where(m[..., None], c, 0.0)
eps = 1e-6
d = np.abs(s - r) - np.abs(l - r)
tiles = [cmap(s / np.maximum(l, eps), 0.85, 1.15), cmap(l / np.maximum(r, eps), 0.7, 1.3),
         cmap(s / np.maximum(r, eps), 0.7, 1.3), cmap(d / r[m].mean(), -0.05, 0.05)]
strip = np.concatenate([np.pad(t, ((0, 0), (0, 2), (0, 0))) for t in tiles], 1)
strip = np.repeat(np.repeat(strip, 4, 0), 4, 1)
mi.util.write_bitmap(sys.argv[4], mi.Bitmap(strip.astype(np.float32)).convert(
    mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, False))
de = (s - r) ** 2 - (l - r) ** 2
tot = ((l - r) ** 2)[m].sum()
h = r.shape[0]
for name, sel in [("source brighter", m & (s > l * 1.01)), ("source darker", m & (s < l * 0.99)),
                  ("top third", m & (np.arange(h)[:, None] < h // 3)),
                  ("middle third", m & (np.arange(h)[:, None] >= h // 3) & (np.arange(h)[:, None] < 2 * h // 3)),
                  ("bottom third", m & (np.arange(h)[:, None] >= 2 * h // 3))]:
    print(f"{name}: n {sel.sum()}, local/ref {l[sel].mean() / r[sel].mean():.3f}, source/ref "
          f"{s[sel].mean() / r[sel].mean():.3f}, squared-error change {100 * de[sel].sum() / tot:+.1f}% of local's")
