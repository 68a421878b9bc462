"""Grey Monte Carlo of the back-lit marble sphere (R 10 mm, eta 1, beam travelling -z, E 5, one
channel): exitance per ring of mu = n.l (lit pole +z) from photons scattered >= 2 times (M2) and
all (M), 0.05-wide bins. usage: ring_mc.py CH NPHOT SEED OUT.npy"""
import numpy as np, sys, time
MAT = {'R': (2.19, 0.0021), 'G': (2.62, 0.0041), 'B': (3.0, 0.0071), 'mR': (0.7, 0.0014), 'mG': (1.22, 0.0025), 'mB': (1.9, 0.0142)}
ch = sys.argv[1]; n = int(sys.argv[2]); seed = int(sys.argv[3])
ss, sa = MAT[ch]; st = ss + sa; alb = ss / st; R = 10.0; E = 5.0
rng = np.random.default_rng(seed)
nb = 40; edges = np.linspace(-1, 1, nb + 1); t_all = np.zeros(nb); t_2 = np.zeros(nb); t_22 = np.zeros(nb)
t0 = time.time(); done = 0; chunk = 100000
while done < n:
    m = min(chunk, n - done); done += m
    rho = R * np.sqrt(rng.random(m)); ph = 2 * np.pi * rng.random(m)
    p = np.stack([rho * np.cos(ph), rho * np.sin(ph), np.sqrt(R * R - rho * rho) - 1e-9], 1)
    w = np.ones(m); d = np.tile([0.0, 0.0, -1.0], (m, 1)); order = np.zeros(m, int)
    while len(w):
        s = -np.log(rng.random(len(w))) / st
        q = p + s[:, None] * d
        out = (q * q).sum(1) >= R * R
        if out.any():
            po = p[out]; do = d[out]
            b = (po * do).sum(1); c = (po * po).sum(1) - R * R
            t = -b + np.sqrt(np.maximum(b * b - c, 0))
            xe = po + t[:, None] * do
            mu = np.clip(xe[:, 2] / R, -1, 1)
            idx = np.minimum(((mu + 1) / 2 * nb).astype(int), nb - 1)
            wo = w[out]; o2 = order[out] >= 2
            np.add.at(t_all, idx, wo); np.add.at(t_2, idx[o2], wo[o2]); np.add.at(t_22, idx[o2], wo[o2] ** 2)
        keep = ~out
        p = q[keep]; w = w[keep] * alb; order = order[keep] + 1
        k = keep.sum()
        cz = 2 * rng.random(k) - 1; phi = 2 * np.pi * rng.random(k); sz = np.sqrt(1 - cz * cz)
        d = np.stack([sz * np.cos(phi), sz * np.sin(phi), cz], 1)
print(f'{ch} n={n} time {time.time()-t0:.1f}s', file=sys.stderr)
area = 2 * np.pi * R * R * (edges[1:] - edges[:-1]); scale = E * np.pi * R * R / n
np.save(sys.argv[4], np.stack([0.5 * (edges[1:] + edges[:-1]), t_all * scale / area, t_2 * scale / area,
                               np.sqrt(np.maximum(t_22 - t_2 ** 2 / n, 0)) * scale / area]))
