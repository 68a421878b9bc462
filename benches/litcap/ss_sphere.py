# Exact single scattering of the eta-1 marble sphere (R 10 mm) seen by the reference camera,
# per pixel (box filter, SUB x SUB rays per pixel), written as an RGBA EXR (alpha = coverage).
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
W = int(sys.argv[1]); out = sys.argv[2]; light = [float(x) for x in sys.argv[3].split(',')]
E = float(sys.argv[4]) if len(sys.argv) > 4 else 5.0
SUB = 4; NU = 256; R = 10.0
MATS = {'marble': ([2.19, 2.62, 3.0], [0.0021, 0.0041, 0.0071]), 'skimmilk': ([0.7, 1.22, 1.9], [0.0014, 0.0025, 0.0142])}
ss, sa = map(np.array, MATS[sys.argv[5] if len(sys.argv) > 5 else 'marble']); st = ss + sa
l = -np.array(light); l /= np.linalg.norm(l)
eye = np.array([0, 20, 60.]); fwd = -eye / np.linalg.norm(eye); up = np.array([0, 1, 0.])
right = np.cross(fwd, up); right /= np.linalg.norm(right); up = np.cross(right, fwd)
t = np.tan(np.radians(30) / 2)
img = np.zeros((W, W, 4))
u = (np.arange(NU) + 0.5) / NU
for j in range(W):
    for i in range(W):
        acc = np.zeros(3); cov = 0
        for a in range(SUB):
            for b in range(SUB):
                x = (2 * (i + (a + .5) / SUB) / W - 1) * t; y = (1 - 2 * (j + (b + .5) / SUB) / W) * t
                d = fwd + x * right + y * up; d /= np.linalg.norm(d)
                bb = eye @ d; c = eye @ eye - R * R; disc = bb * bb - c
                if disc <= 0: continue
                cov += 1
                s0 = -bb - np.sqrt(disc); s1 = -bb + np.sqrt(disc); chord = s1 - s0
                p = eye + s0 * d
                for ch in range(3):
                    m = 1 - np.exp(-st[ch] * chord)
                    tt = -np.log(1 - u * m) / st[ch]
                    xs = p[None, :] + tt[:, None] * d[None, :]
                    xl = xs @ l; sl = -xl + np.sqrt(np.maximum(xl * xl - (xs * xs).sum(1) + R * R, 0))
                    acc[ch] += ss[ch] / (4 * np.pi) * E * m / st[ch] * np.exp(-st[ch] * sl).mean()
        n = SUB * SUB
        img[j, i, :3] = acc / n; img[j, i, 3] = cov / n
mi.Bitmap(img.astype(np.float32), mi.Bitmap.PixelFormat.RGBA).write(out)
print(out, img[..., :3].mean(axis=(0, 1)))
