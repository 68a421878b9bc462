"""The own-light lobe at eta != 1 with refracted cosines, on the stored half-space Monte Carlo
(benches/exit_lobe/lobe_mc.npz, lit at 30 or 60 degrees): is it better than Lambert there?

Usage: python3 benches/exit_lobe/chandra_eta.py
g evaluated at the refracted view cosine mu_i and the refracted light cosine, renormalized over
the outside hemisphere with F_t (the exitance M unchanged); model = diffusion M x lobe + exact
single scattering against the Monte Carlo (relative RMS over the bins 80..19 degrees).
"""
import os, sys
import numpy as np
sys.path.insert(0, "/work/shared/research/halfspace-mc")
sys.path.insert(0, os.path.dirname(__file__))
from mc import fresnel  # noqa: E402
from chandra import h_hapke  # noqa: E402

d = np.load(os.path.join(os.path.dirname(__file__), "lobe_mc.npz"))
n = 4000
mo = (np.arange(n) + 0.5) / n
for k in d.files:
    if not k.startswith("r_"):
        continue
    _, a, eta, th = k.split("_")
    a, eta, th = float(a), float(eta), float(th)
    cen, la, lex, lss = d[k]
    mu0 = np.cos(np.radians(th))
    mu0t = np.sqrt(1 - (1 - mu0**2) / eta**2)
    to = 1 - fresnel(mo, eta)
    mi = np.sqrt(np.maximum(1 - (1 - mo**2) / eta**2, 0))
    shape = lambda m: (h_hapke(m, a) * h_hapke(mu0t, a) - 1) / (m + mu0t)
    norm = np.sum(to * shape(mi) * mo) / np.sum(to * mo)
    ci = np.sqrt(np.maximum(1 - (1 - cen**2) / eta**2, 0))
    g = shape(ci) / norm
    w = slice(1, None)
    rms = lambda f: np.sqrt(np.mean(((lex * f + lss)[w] / la[w] - 1) ** 2)) * 100
    print(f"{k:18s} lambert {rms(1.0):5.2f}%  chandra {rms(g):5.2f}%")
