#!/usr/bin/env python3
"""Second-collision density in the 20 mm sphere against the half-space ratio
(transport::second_collision_ratio averaged over the lit disk), benches/RESULTS.md "Diffusion
coefficient at low albedo", section 2.

usage: python3 benches/sphere_second_collision_mc.py SIGMA_S SIGMA_A N   (needs numpy)
"""
import os
from pathlib import Path
import numpy as np, sys
sys.path.insert(0, os.environ.get("HALFSPACE_MC", str(Path(__file__).resolve().parents[2] / "shared/research/halfspace-mc")))
from mc import fresnel
rng = np.random.default_rng(5)
ss, sa, N = float(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
R = 10.0; st = ss + sa; alb = ss / st
l = np.array([0.5, -1, -0.5]); l /= np.linalg.norm(l)
u = np.cross(l, [0, 0, 1.0]); u /= np.linalg.norm(u); w = np.cross(l, u)
r = R * np.sqrt(rng.random(N)); th = 2 * np.pi * rng.random(N)
q = (r * np.cos(th))[:, None] * u + (r * np.sin(th))[:, None] * w
p = q - l * np.sqrt(R * R - r * r)[:, None]
mu_i = np.sqrt(1 - (r / R) ** 2)
def exit_dist(p, d):
    b = np.einsum('ij,ij->i', p, d); c = np.einsum('ij,ij->i', p, p) - R * R
    return -b + np.sqrt(np.maximum(b * b - c, 0))
d = np.tile(l, (N, 1))
s = -np.log(rng.random(N)) / st
first = s < exit_dist(p, d)
p1 = p[first] + d[first] * s[first][:, None]
z = 2 * rng.random(p1.shape[0]) - 1; ph = 2 * np.pi * rng.random(p1.shape[0]); sz = np.sqrt(1 - z * z)
d1 = np.stack([sz * np.cos(ph), sz * np.sin(ph), z], 1)
s2 = -np.log(rng.random(p1.shape[0])) / st
second = s2 < exit_dist(p1, d1)
# half-space ratio per photon (eta 1): albedo (b + s~) J / 2 with s~ = sqrt(3 (1-alb)) (classical D)
def ratio(mu_t, stil):
    b = 1 / mu_t; m = (np.arange(64) + 0.5) / 64
    J = np.mean(1 / ((stil + b) * (1 + b * m[:, None])) + 1 / ((stil + b) * (1 + stil * m[:, None])), axis=0)
    return alb * (b + stil) * 0.5 * J
for name, stil in [("classical", np.sqrt(3 * (1 - alb))), ("grosjean", np.sqrt((1 - alb) / ((2 - alb) / 3)))]:
    pred = ratio(mu_i[first], stil).sum()
    print(f"{name}: half-space predicted 2nd/1st {pred / first.sum():.3f}")
print(f"sphere MC: 2nd/1st collisions x albedo {alb * second.sum() / first.sum():.3f}; 1st collisions per photon {first.mean():.3f}")
