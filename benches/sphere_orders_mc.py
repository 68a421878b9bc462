#!/usr/bin/env python3
"""Sphere Monte Carlo of benches/RESULTS.md "Diffusion coefficient at low albedo", section 2.

usage: python3 benches/sphere_orders_mc.py SIGMA_S SIGMA_A N

The 20 mm sphere of the references (eta 1, isotropic phase with the reduced coefficients), lit by
the light dir:0.5,-1,-0.5 of irradiance 4: radiant intensity toward the camera 0,20,60 (photons
leaving within 10 degrees of it) split by scattering order. Needs numpy.
"""
import numpy as np, sys
rng = np.random.default_rng(3)
ss, sa, N = float(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
R = 10.0; st = ss + sa; E = 4.0
l = np.array([0.5, -1, -0.5]); l /= np.linalg.norm(l)
cam = np.array([0, 20, 60.0]); vdir = cam / np.linalg.norm(cam)
cone = np.cos(np.radians(10)); omega = 2 * np.pi * (1 - cone)
# entry points: uniform on the disk perpendicular to l
u = np.cross(l, [0, 0, 1.0]); u /= np.linalg.norm(u); w = np.cross(l, u)
r = R * np.sqrt(rng.random(N)); th = 2 * np.pi * rng.random(N)
q = (r * np.cos(th))[:, None] * u + (r * np.sin(th))[:, None] * w
# start at the near surface: q - l * sqrt(R^2 - r^2)
p = q - l * np.sqrt(R * R - r * r)[:, None]
d = np.tile(l, (N, 1)); wgt = np.ones(N); order = np.zeros(N, int)
tally = {}
alive = np.ones(N, bool)
while alive.any():
    i = np.nonzero(alive)[0]
    pi_, di = p[i], d[i]
    b = np.einsum('ij,ij->i', pi_, di); c = np.einsum('ij,ij->i', pi_, pi_) - R * R
    texit = -b + np.sqrt(np.maximum(b * b - c, 0))
    s = -np.log(rng.random(i.size)) / st
    esc = s >= texit
    e = i[esc]
    good = np.einsum('ij,j->i', d[e], vdir) > cone
    for o in np.unique(order[e[good]]):
        k = min(o, 3)
        tally[k] = tally.get(k, 0) + wgt[e[good]][order[e[good]] == o].sum()
    alive[e] = False
    k = i[~esc]
    p[k] += d[k] * s[~esc][:, None]
    wgt[k] *= ss / st; order[k] += 1
    z = 2 * rng.random(k.size) - 1; ph = 2 * np.pi * rng.random(k.size)
    sz = np.sqrt(1 - z * z)
    d[k] = np.stack([sz * np.cos(ph), sz * np.sin(ph), z], 1)
    low = alive & (wgt < 1e-3); kill = low & (rng.random(N) < 0.5)
    alive[kill] = False; wgt[low & ~kill] *= 2
power = E * np.pi * R * R
I = {k: v / N * power / omega for k, v in tally.items()}
tot = sum(I.values())
print(f"sigma_s {ss} sigma_a {sa}: intensity toward the camera {tot:.4f} (order 1 {I.get(1,0)/tot:.3f}, 2 {I.get(2,0)/tot:.3f}, 3+ {I.get(3,0)/tot:.3f})")
