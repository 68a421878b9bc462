# Variants of benches/litcap/cont.py (the code's formulas in the continuous axisymmetric sphere
# solve, per ring against the ring Monte Carlo's orders >= 2): the upstream beam's irradiance
# factor mu + c (1 - mu^2) - A c mu^2 and the particular solution's curvature term
# K = Q0 / (sigma_a - D beta^2 - B 2 D H beta).
# usage: cont2.py CHS A,B [A,B ..]    (current code: A = 2, B = 0)
import sys, numpy as np
CHS = sys.argv[1].split(','); VARS = sys.argv[2:]
sys.path.insert(0, 'benches/backlit'); sys.argv = ['x', '1500']
import sphere_diffusion as sd
sd.MAT.update({'mR': (0.7, 0.0014), 'mG': (1.22, 0.0025), 'mB': (1.9, 0.0142)})
R, E = 10.0, 5.0
def fit(ss, sa, mut):
    st = ss + sa; D = 1 / (3 * st); s = np.sqrt(sa / D) / st; b = 1 / np.maximum(mut, 1e-6)
    mm = (np.arange(64) + 0.5) / 64
    J = (1 / ((s + b[:, None]) * (1 + b[:, None] * mm)) + 1 / ((s + b[:, None]) * (1 + s * mm))).mean(1)
    ratio = ss / st * (b + s) * 0.5 * J
    zb = 2 * D * st
    c = b[:, None] * mm / (b[:, None] * mm + 1)
    rt = ss / st * 0.5 * (2 * (1 / b[:, None] + zb) - (zb - mm) * c).mean(1) / (1 / b + zb)
    w = np.clip((0.3 - s) / 0.15, 0, 1); w = w * w * (3 - 2 * w)
    mue = mut + w * np.maximum((rt / ratio) * (mut + zb) - zb - mut, 0)
    return ratio, ratio * (1 + s * mue) / (1 + s * mut), mue
def particular(ch, A, B, mu, F=0):
    ss, sa = sd.MAT[ch]; st = ss + sa; D = 1 / (3 * st)
    c = min(1 / (R * st), 0.2)
    up = np.minimum(mu + c * (1 - mu ** 2), 1)
    irr = np.maximum(mu + c * (1 - mu ** 2) - A * c * mu ** 2, 0)
    lit = (up > 0) & (irr > 0) & (mu > -0.2); mut = np.maximum(up, 1e-6)
    ratio, gain, mue = fit(ss, sa, mut)
    beta = st / mue; Q0 = gain * ss * E * irr / mue
    if B < 0:   # the narrowing with the node's upstream cosine instead of the profile's mu_e
        K = Q0 / (sa - D * beta ** 2 * (1 - B * 2 * c * mut))
    else:
        w = 1.0
        if F > 0:   # the narrowing faded in over n.l in [0, F]
            t = np.clip(mu / F, 0, 1); w = t * t * (3 - 2 * t)
        K = Q0 / (sa - D * beta ** 2 - w * B * 2 * D * beta / R)
    return K, beta, Q0, lit
def run(ch, A, B, C=0, F=0):
    ss, sa = sd.MAT[ch]; st = ss + sa; D = 1 / (3 * st); mu = sd.mu
    K, beta, Q0, lit = particular(ch, A, B, mu, F); K = np.where(lit, K, 0)
    if C:
        # the lateral Laplacian of K(mu) e^(-beta(mu) z), z-integrated (moments 1/b, 1/b^2, 2/b^3)
        # and folded into K, with K0's mu derivatives by finite differences of the formula
        h = 1e-3
        Kp, bp, _, _ = particular(ch, A, B, mu + h, F); Km, bm_, _, _ = particular(ch, A, B, mu - h, F)
        K0 = particular(ch, A, B, mu, F)[0]
        dK = (Kp - Km) / (2 * h); d2K = (Kp - 2 * K0 + Km) / h ** 2
        db = (bp - bm_) / (2 * h); d2b = (bp - 2 * beta + bm_) / h ** 2
        LK = (1 - mu ** 2) * d2K - 2 * mu * dK; Lb = (1 - mu ** 2) * d2b - 2 * mu * db
        lat = LK / beta - (2 * (1 - mu ** 2) * dK * db + K0 * Lb) / beta ** 2 + K0 * db ** 2 * (1 - mu ** 2) * 2 / beta ** 3
        lat = np.where(lit & np.isfinite(lat), lat, 0)
        if C < 0:   # taper: smoothstep over mu in [0, -C]
            t = np.clip(mu / -C, 0, 1); lat = lat * t * t * (3 - 2 * t)
        else:
            lat = lat * C
        K = np.where(lit, K + D * lat / R ** 2 * beta / np.where(lit, Q0 / np.where(K == 0, 1, K), 1), 0)
    q = -K * (1 + 2 * D * beta) / 4
    sd.Q_OVERRIDE = np.where(lit, q, 0)
    _, f, _ = sd.solve(ch, 'flux'); sd.Q_OVERRIDE = None
    mus = np.linspace(-1, 1, 4001); P = sd.legendre_table(mus, sd.L); phi = (f[:, None] * P).sum(0)
    return mus, phi / 2 + np.interp(mus, mu, K) / 2
edges = np.linspace(-1, 1, 41)
mc = {c: np.load(f'target/litcap/ring_{c}.npy') for c in CHS}
cen = mc[CHS[0]][0]; sel = cen > -0.4
print('n.l     ', ' '.join(f'{x:+.3f}' for x in cen[sel][::2]))
for v in VARS:
    p = list(map(float, v.split(','))); rows = []
    for ch in CHS:
        mus, M = run(ch, *p)
        Mb = np.array([M[(mus >= a) & (mus < b)].mean() for a, b in zip(edges[:-1], edges[1:])])
        rows.append(Mb / mc[ch][2]); print(f'  {ch:3s} {v:8s}', ' '.join(f'{x:.3f}' for x in rows[-1][sel][::2]))
    r = np.mean(rows, 0)
    # area-weighted RMS of (ratio - 1) over n.l > -0.2, channels pooled
    m = cen > -0.2; rms = np.sqrt(np.mean((np.array(rows)[:, m] - 1) ** 2))
    print(f'  all {v:8s}', ' '.join(f'{x:.3f}' for x in r[sel][::2]), f' rms {100*rms:.1f}%')
