"""Monte Carlo of a marble slab (thickness 2 mm, eta 1, isotropic phase with reduced coefficients),
a collimated beam at incidence cos mu_i (the plate scene: light dir:0.2,-0.35,1 on the plate's
back face, normal -z): transmitted and reflected exitance per unit incident irradiance on the
surface (E mu_i = 1), and the transmitted radiance lobe L(mu_o) / (M / pi).
Usage: slab_mc.py CH NPHOT [THICK]"""
import numpy as np, sys, time
MAT = {'R': (2.19, 0.0021), 'G': (2.62, 0.0041), 'B': (3.0, 0.0071)}
ch = sys.argv[1]; n = int(sys.argv[2]); th = float(sys.argv[3]) if len(sys.argv) > 3 else 2.0
ss, sa = MAT[ch]; st = ss + sa; alb = ss / st
d0 = np.array([0.2, -0.35, 1.0]); d0 /= np.linalg.norm(d0); mui = d0[2]
rng = np.random.default_rng(2)
nb = 20; T = 0.0; Rf = 0.0; hist = np.zeros(nb); T1 = 0.0
t0 = time.time(); done = 0
while done < n:
    m = min(500000, n - done); done += m
    z = np.zeros(m); cz = np.full(m, mui); w = np.ones(m); k = np.zeros(m, int)
    while len(w):
        s = -np.log(rng.random(len(w))) / st
        zn = z + s * cz
        outT = zn >= th; outR = zn <= 0
        ball = outT & (k == 0); outT = outT & (k > 0)   # the uncollided beam: a delta the camera never sees
        T += w[outT].sum(); Rf += w[outR].sum(); T1 += w[outT & (k == 1)].sum()
        b = np.minimum((cz[outT] * nb).astype(int), nb - 1); np.add.at(hist, b, w[outT])
        keep = ~(outT | outR | ball)
        z = zn[keep]; w = w[keep] * alb; k = k[keep] + 1
        cz = 2 * rng.random(len(w)) - 1
T /= n; Rf /= n; T1 /= n
# lobe: L(mu) ~ hist / (mu dmu); normalised so that int L mu dOmega = M  ->  L/(M/pi)
mu = (np.arange(nb) + 0.5) / nb
lob = hist / (mu * (1 / nb)) / (2 * hist.sum())   # = L(mu) * pi / M
print(f'{ch}: n={n} thickness {th} mm, mu_i {mui:.4f}: T (transmitted exitance / incident) {T:.5f}, R {Rf:.5f}, T after 1 scattering {T1:.5f}  ({time.time()-t0:.0f}s)')
print('   L(mu_o)/(M/pi) at mu_o=', ' '.join(f'{m:.3f}:{l:.3f}' for m, l in zip(mu[1::2], lob[1::2])))
# diffusion closed forms (DESIGN 2, eta 1: A = 1, F_dr = 0), uniform flux source
D = 1 / (3 * st); s_ = np.sqrt(sa / D); h = 2 * D
Tf = (4 * D * s_) / ((1 + h * h * s_ * s_) * np.sinh(s_ * th) + 2 * h * s_ * np.cosh(s_ * th))
print(f'   slab diffusion closed form (boundary flux): T = {Tf:.5f};  MC / closed form = {T / Tf:.3f}')
