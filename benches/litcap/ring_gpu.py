# Our exitance per band of n.l (pi L of a Lambert-lobe, no-SS render at eta 1) against the Monte
# Carlo's orders >= 2 (ring_mc.py, E 5 -> the scene's 4). usage: ring_gpu.py marble|milk EXR..
import sys, numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
chs = ['R', 'G', 'B'] if sys.argv[1] == 'marble' else ['mR', 'mG', 'mB']
mc = [np.load(f'target/litcap/ring_{c}.npy') for c in chs]
L = np.array([0.5, -1, -0.5]); L = -L / np.linalg.norm(L)
eye = np.array([0, 20, 60.]); fwd = -eye / np.linalg.norm(eye); up = np.array([0, 1, 0.]); right = np.cross(fwd, up); right /= np.linalg.norm(right); up = np.cross(right, fwd)
ALPHA = np.array(mi.Bitmap('tests/reference/pt/marble-sphere-dir-eta1.exr'))[..., 3]
bands = [(-0.2, 0), (0, 0.2), (0.2, 0.4), (0.4, 0.6), (0.6, 0.8), (0.8, 1.0)]
print('exitance / MC orders>=2'.ljust(30) + ' '.join(f'{a:+.1f}..{b:+.1f}' for a, b in bands))
for path in sys.argv[2:]:
    img = np.array(mi.Bitmap(path)); h, w = img.shape[:2]; t = np.tan(np.radians(30) / 2); R = 10.0
    NL, V = [], []
    for j in range(h):
        for i in range(w):
            x = (2 * (i + .5) / w - 1) * t; y = (1 - 2 * (j + .5) / h) * t
            d = fwd + x * right + y * up; d /= np.linalg.norm(d)
            b = eye @ d; c = eye @ eye - R * R; disc = b * b - c
            if disc < 0 or -b - np.sqrt(disc) < 0: continue
            p = eye + (-b - np.sqrt(disc)) * d
            if ALPHA[j, i] < 0.999 or -(p / R) @ d < 0.2: continue
            NL.append(p / R @ L); V.append(img[j, i, :3])
    NL = np.array(NL); V = np.array(V) * np.pi
    cells = []
    for a, b in bands:
        m = (NL >= a) & (NL < b)
        ours = V[m].mean(0)
        ref = np.array([np.interp(NL[m], q[0], q[2]).mean() * 0.8 for q in mc])
        cells.append((ours / ref).mean())
    print(path.split('/')[-1][:-4].ljust(30) + ' '.join(f'{c:9.3f}' for c in cells))
