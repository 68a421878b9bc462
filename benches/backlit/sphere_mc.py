"""Analog-ish Monte Carlo of a grey isotropic sphere (R = 10 mm, eta = 1, no boundary), lit by a
collimated beam travelling -z (E = 5). Tallies exitance M(mu) by polar angle of the exit point
(mu = cos angle to the lit pole), weight *= albedo per scattering. Usage: sphere_mc.py CH NPHOT SEED"""
import numpy as np, sys, time
MAT = {'R': (2.19, 0.0021), 'G': (2.62, 0.0041), 'B': (3.0, 0.0071)}
ch = sys.argv[1]; n = int(sys.argv[2]); seed = int(sys.argv[3]) if len(sys.argv) > 3 else 0
ss, sa = MAT[ch]; st = ss + sa; alb = ss / st; R = 10.0; E = 5.0
rng = np.random.default_rng(seed)
nb = 40; edges = np.linspace(-1, 1, nb + 1); tally = np.zeros(nb); tally2 = np.zeros(nb); lobe = np.zeros(10)
t0 = time.time(); done = 0; chunk = 100000
while done < n:
    m = min(chunk, n - done); done += m
    rho = R * np.sqrt(rng.random(m)); ph = 2 * np.pi * rng.random(m)
    p = np.stack([rho * np.cos(ph), rho * np.sin(ph), np.sqrt(R * R - rho * rho) - 1e-9], 1)
    w = np.ones(m); d = np.tile([0.0, 0.0, -1.0], (m, 1))
    steps = 0
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
            np.add.at(tally, idx, w[out]); np.add.at(tally2, idx, w[out] ** 2)
            ring = (mu > -0.85) & (mu < -0.70)
            co = np.clip((xe[ring] * do[ring]).sum(1) / R, 0, 0.99999)
            np.add.at(lobe, (co * 10).astype(int), w[out][ring])
        keep = ~out
        p = q[keep]; w = w[keep] * alb
        k = keep.sum()
        cz = 2 * rng.random(k) - 1; phi = 2 * np.pi * rng.random(k); sz = np.sqrt(1 - cz * cz)
        d = np.stack([sz * np.cos(phi), sz * np.sin(phi), cz], 1)
        steps += 1
print(f'{ch} n={n} time {time.time()-t0:.1f}s', file=sys.stderr)
area = 2 * np.pi * R * R * (edges[1:] - edges[:-1])
scale = E * np.pi * R * R / n
M = tally * scale / area; err = np.sqrt(np.maximum(tally2 - tally**2 / n, 0)) * scale / area
mo = (np.arange(10) + 0.5) / 10
print('ring mu in (-0.85,-0.70): L(mu_o)/(M/pi):', ' '.join(f'{a:.2f}:{b:.3f}' for a, b in zip(mo, lobe / (mo * 0.1) / (2 * lobe.sum()))), file=sys.stderr)
np.save(f'mc_{ch}_{seed}.npy', np.stack([0.5 * (edges[1:] + edges[:-1]), M, err]))
for c, m_, e_ in zip(0.5 * (edges[1:] + edges[:-1]), M, err):
    print(f'{c:+.3f} {m_:.6f} {e_:.6f}')
