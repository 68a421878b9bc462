#!/usr/bin/env python3
"""Diffusion-coefficient variants against the half-space Monte Carlo (benches/RESULTS.md,
"Diffusion coefficient at low albedo").

usage: python3 benches/halfspace_diffusion_coefficient.py N THETA_I ALBEDO...  (eta 1 and 1.3)

Per albedo: the Monte Carlo of ../shared/research/halfspace-mc/mc.py (N photons, collimated beam
at THETA_I degrees), then the mean ratio to it over the view bins 80-19 degrees (and the relative
RMS) of the second-collision source + exact single scattering and of the first-collision
(collimated) source, each with the classical, Grosjean and asymptotic D. Needs numpy.
$HALFSPACE_MC overrides where mc.py and diff.py are.
"""
import os
from pathlib import Path
import numpy as np, sys
sys.path.insert(0, os.environ.get("HALFSPACE_MC", str(Path(__file__).resolve().parents[2] / "shared/research/halfspace-mc")))
from mc import run, fresnel
from diff import C1C2

def k_exact(a):
    # asymptotic transport eigenvalue: a/(2k) ln((1+k)/(1-k)) = 1 (sigma_t = 1)
    lo, hi = 1e-9, 1 - 1e-15
    for _ in range(200):
        m = 0.5 * (lo + hi)
        f = a / (2 * m) * np.log((1 + m) / (1 - m)) - 1
        if f > 0: hi = m
        else: lo = m
    return 0.5 * (lo + hi)

def dcoef(kind, a):
    sa, ss = 1 - a, a
    if kind == "classical": return 1 / 3
    if kind == "grosjean": return (2 * sa + ss) / 3
    if kind == "asymptotic": return sa / k_exact(a) ** 2
    raise ValueError(kind)

def model(alpha, eta, thi, cen, Dkind):
    st = 1.0; ss = alpha; sa = 1 - alpha
    mui = np.cos(np.radians(thi)); Ti = 1 - fresnel(np.array([mui]), eta)[0]
    mut = np.sqrt(1 - (1 - mui ** 2) / eta ** 2)
    D = dcoef(Dkind, alpha)
    k = np.sqrt(sa / D); c1, c2 = C1C2(eta); A = (1 + 3 * c2) / (1 - 2 * c1)
    R = (2 * A * D * k - 1) / (2 * A * D * k + 1)
    dz = 0.01; n = 3000
    z = (np.arange(n) + 0.5) * dz
    Q1 = ss * Ti / mut * np.exp(-st * z / mut)
    mu = (np.arange(400) + 0.5) / 400; Rint = fresnel(mu, 1 / eta)
    d = np.arange(2 * n) * dz
    Kd = 0.5 * np.sum(np.exp(-np.maximum(d, 0.5 * dz)[:, None] / mu) / mu, axis=1) / 400
    Ks = 0.5 * np.sum(Rint * np.exp(-(d + dz)[:, None] / mu) / mu, axis=1) / 400
    i = np.arange(n)
    M1 = Kd[np.abs(i[:, None] - i[None, :])] + Ks[i[:, None] + i[None, :]]
    phi1 = M1 @ (Q1 * dz)
    Q2 = ss * phi1
    def diffuse(Q):
        phi0 = np.sum(Q * np.exp(-k * z) * (1 + R) / (2 * D * k)) * dz
        dphi0 = np.sum(Q * np.exp(-k * z) * (1 - R) / (2 * D)) * dz
        return phi0, dphi0
    co = np.asarray(cen); To = 1 - fresnel(co, eta)
    c1i, _ = C1C2(1 / eta)
    out = {}
    for name, Q in [("beam", Q1), ("2nd", Q2)]:
        phi0, dphi0 = diffuse(Q)
        M = 0.25 * (1 - 2 * c1) * phi0 + 0.5 * (1 - 3 * c2) * D * dphi0
        out[name] = M * To / ((1 - 2 * c1i) * np.pi)
    mup = np.sqrt(1 - (1 - co ** 2) / eta ** 2)
    Lss = alpha / (4 * np.pi) * Ti * To / eta ** 2 / (mut + mup)
    return out, Lss

N = int(sys.argv[1]); th = float(sys.argv[2])
w = slice(1, None)
def rms(x): return np.sqrt(np.mean((x - 1) ** 2))
for eta in (1.0, 1.3):
    for a in map(float, sys.argv[3:]):
        cen, La, Ls, Rt, Rs, Ti = run(a, eta, th, N=N)
        row = [f"a={a:<5} eta={eta} | MC R={Rt:.4f} ss={Rs / Rt:.2f}"]
        for Dk in ("classical", "grosjean", "asymptotic"):
            out, Lss = model(a, eta, th, cen, Dk)
            r2 = (out["2nd"] + Lss)[w] / La[w]
            rb = out["beam"][w] / La[w]
            row.append(f"{Dk[:5]} 2nd+SS mean {np.mean(r2):.3f} rms {rms(r2):.3f} beam mean {np.mean(rb):.3f}")
        rss = Lss[w] / La[w]
        row.append(f"SS only mean {np.mean(rss):.3f}")
        print(" | ".join(row), flush=True)
