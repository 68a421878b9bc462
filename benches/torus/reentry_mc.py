#!/usr/bin/env python3
"""Monte Carlo of the back-lit marble torus (major 7, minor 3 mm, eta 1, `dir:0.2,-0.35,1`): how
much of each surface region's exitance is light that left the torus and entered it again (issue
12, wave 9). Isotropic scattering with the reduced coefficients (marble green: sigma_s' 2.62,
sigma_a 0.0041 per mm), photons from the directional light, a random walk inside (sphere tracing
against the torus's exact signed distance), every exit traced through the air: a ray that meets
the torus again re-enters (eta 1: no refraction) and walks on, counted as re-entered. Prints per
region (by the exit point) the exitance split into light that never left and light that
re-entered, and per re-entered photon where it had re-entered (the inner band or elsewhere).

    python3 benches/torus/reentry_mc.py [PHOTONS] [SEED]
"""
import sys
import numpy as np

MAJOR, MINOR = 7.0, 3.0
SIGMA_S, SIGMA_A = 2.62, 0.0041
LIGHT = np.array([0.2, -0.35, 1.0]); LIGHT /= np.linalg.norm(LIGHT)
EPS = 1e-4


def sdf(p):
    return np.hypot(np.hypot(p[:, 0], p[:, 2]) - MAJOR, p[:, 1]) - MINOR


def normal(p):
    r = np.hypot(p[:, 0], p[:, 2])[:, None]
    c = np.stack([p[:, 0], np.zeros(len(p)), p[:, 2]], 1) / r * MAJOR
    n = p - c
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def march_out(o, d, tmax=60.0, steps=200):
    """First hit of rays starting outside: (hit, t)."""
    t = np.zeros(len(o)); hit = np.zeros(len(o), bool); alive = np.ones(len(o), bool)
    for _ in range(steps):
        idx = np.nonzero(alive)[0]
        if len(idx) == 0:
            break
        s = sdf(o[idx] + t[idx, None] * d[idx])
        h = s < EPS
        hit[idx[h]] = True; alive[idx[h]] = False
        t[idx[~h]] += s[~h]
        far = t[idx] > tmax
        alive[idx[far]] = False
    return hit, t


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 100000
    rng = np.random.default_rng(int(sys.argv[2]) if len(sys.argv) > 2 else 1)
    sigma_t = SIGMA_S + SIGMA_A; albedo = SIGMA_S / sigma_t
    # Photons over a disk perpendicular to the light, covering the torus.
    u = np.cross(LIGHT, [0, 1, 0.0]); u /= np.linalg.norm(u); v = np.cross(LIGHT, u)
    rad = MAJOR + MINOR + 0.5
    r = rad * np.sqrt(rng.random(n)); phi = 2 * np.pi * rng.random(n)
    o = -30 * LIGHT + (r * np.cos(phi))[:, None] * u + (r * np.sin(phi))[:, None] * v
    d = np.broadcast_to(LIGHT, o.shape).copy()
    hit, t = march_out(o, d)
    p = o[hit] + t[hit, None] * d[hit]; d = d[hit]
    m = len(p)
    w = np.ones(m); reent = np.zeros(m, int); where = np.full(m, -1)
    n0 = normal(p)
    # Where the light entered: 0 near ring (z > 0) top/outer, 1 near ring inner wall, 2 far ring.
    entry = np.where(p[:, 2] <= 0, 2, np.where((n0[:, 0] * p[:, 0] + n0[:, 2] * p[:, 2]) < 0, 1, 0))
    entry_mu = n0 @ -LIGHT
    p = p - normal(p) * 2 * EPS
    exits = []  # (point, weight, reentered, where it first re-entered)
    for it in range(20000):
        if m == 0:
            break
        s = rng.exponential(1 / sigma_t, m)
        # Walk s inside, stopping at the boundary.
        travelled = np.zeros(m); out = np.zeros(m, bool); act = np.ones(m, bool)
        for _ in range(64):
            idx = np.nonzero(act)[0]
            if len(idx) == 0:
                break
            q = p[idx] + travelled[idx, None] * d[idx]
            dist = -sdf(q)
            o_ = dist < EPS
            out[idx[o_]] = True; act[idx[o_]] = False
            rem = s[idx] - travelled[idx]
            step = np.minimum(np.maximum(dist, 0), rem)
            travelled[idx] += np.where(o_, 0, step)
            done = (~o_) & (step >= rem)
            act[idx[done]] = False
        out |= act & (-sdf(p + travelled[:, None] * d) < 1e-3)  # stuck at a grazing wall
        p = p + travelled[:, None] * d
        # Exits: trace through the air.
        eo = np.nonzero(out)[0]
        if len(eo):
            pe = p[eo]; de = d[eo]
            hit2, t2 = march_out(pe + de * 3 * EPS + normal(pe) * 2 * EPS, de)
            esc = eo[~hit2]
            exits.append((p[esc], w[esc], reent[esc], where[esc], entry[esc], entry_mu[esc]))
            back = eo[hit2]
            if len(back):
                pb = pe[hit2] + 3 * EPS * de[hit2] + normal(pe[hit2]) * 2 * EPS + t2[hit2, None] * de[hit2]
                nb = normal(pb)
                first = reent[back] == 0
                nr = (nb[:, 0] * pb[:, 0] + nb[:, 2] * pb[:, 2]) / np.hypot(pb[:, 0], pb[:, 2])
                where[back[first]] = (nr[first] < 0).astype(int)
                reent[back] += 1
                p[back] = pb - nb * 2 * EPS
        # Scatter the rest.
        sc = np.nonzero(~out)[0]
        w[sc] *= albedo
        cz = 2 * rng.random(len(sc)) - 1; ph = 2 * np.pi * rng.random(len(sc)); sz = np.sqrt(1 - cz * cz)
        d[sc] = np.stack([sz * np.cos(ph), sz * np.sin(ph), cz], 1)
        keep = ~out
        # Re-entered photons keep walking (their direction unchanged).
        if len(eo):
            keep[eo[hit2]] = True
        p, d, w, reent, where, entry, entry_mu = p[keep], d[keep], w[keep], reent[keep], where[keep], entry[keep], entry_mu[keep]
        m = len(p)
    pe = np.concatenate([e[0] for e in exits]); we = np.concatenate([e[1] for e in exits])
    re = np.concatenate([e[2] for e in exits]); wh = np.concatenate([e[3] for e in exits])
    en = np.concatenate([e[4] for e in exits]); emu = np.concatenate([e[5] for e in exits])
    ne = normal(pe)
    nr = (ne[:, 0] * pe[:, 0] + ne[:, 2] * pe[:, 2]) / np.hypot(pe[:, 0], pe[:, 2])
    nl = ne @ -LIGHT
    print(f"{n} photons, {len(pe)} exits, {m} still walking, total exitance {we.sum() / n:.4f} of the disk's")
    near = (nr >= 0) & (nl <= 0) & (pe[:, 2] > 0)
    regions = [("outer, unlit, z>0 (near ring's face)", near),
               ("  its centre (|x| < 3)", near & (np.abs(pe[:, 0]) < 3)),
               ("  its ends (|x| >= 3)", near & (np.abs(pe[:, 0]) >= 3)),
               ("outer, unlit, z<=0", (nr >= 0) & (nl <= 0) & (pe[:, 2] <= 0)),
               ("outer, lit", (nr >= 0) & (nl > 0)), ("inner, unlit", (nr < 0) & (nl <= 0)),
               ("inner, lit", (nr < 0) & (nl > 0)), ("all", np.ones(len(pe), bool))]
    print("region: exitance (photon weight / photons), share re-entered, of which entered at the inner band")
    for name, r in regions:
        tot = we[r].sum(); ree = we[r & (re > 0)].sum(); inner = we[r & (re > 0) & (wh == 1)].sum()
        print(f"  {name:38s} {tot / n:.4f}  re-entered {ree / max(tot, 1e-12):.3f}  (inner band {inner / max(ree, 1e-12):.2f})")
        shares = [we[r & (en == k)].sum() / max(tot, 1e-12) for k in range(3)]
        mus = [np.average(emu[r & (en == k)], weights=we[r & (en == k)]) if (r & (en == k)).any() else 0 for k in range(3)]
        print(f"      entered: near top/outer {shares[0]:.3f} (mean mu {mus[0]:.2f}), near inner wall {shares[1]:.3f} ({mus[1]:.2f}), far ring {shares[2]:.3f} ({mus[2]:.2f})")


if __name__ == "__main__":
    main()

