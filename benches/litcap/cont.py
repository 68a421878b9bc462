# The code's `second` source (two-moment fit, planar particular solution in the Robin row) in the
# continuous axisymmetric sphere solve of benches/backlit/sphere_diffusion.py, per ring against
# the Monte Carlo's orders >= 2 (ring_mc.py, files target/crescent/ring_{R,G,B}.npy).
# usage: sphere_second.py VARIANT.. with VARIANT: `plain` (the code's fit), `first_power` (the
# pre-fit first x r), `flux<MU0` (the fit fading to the boundary flux below MU0), `flux` (all
# orders, against all), `vol:SRC` (a volume source of benches/backlit/sphere_diffusion.py: first,
# planar, curv_lit, shift, mue; all orders, against all).
import sys, numpy as np
CH_ARG = sys.argv[1].split(','); ARGS = sys.argv[2:]; sys.argv_chs = CH_ARG; sys.path.insert(0, 'benches/backlit'); sys.argv = ['x', '1500']
import sphere_diffusion as sd
sd.MAT.update({'mR': (0.7, 0.0014), 'mG': (1.22, 0.0025), 'mB': (1.9, 0.0142)})
CHS = sys.argv_chs
R, E = 10.0, 5.0
def fit(ss, sa, mut):
    st = ss + sa; D = 1 / (3 * st); s = np.sqrt(sa / D) / st; b = 1 / np.maximum(mut, 1e-6)
    mm = (np.arange(64) + 0.5) / 64
    J = (1 / ((s + b[:, None]) * (1 + b[:, None] * mm)) + 1 / ((s + b[:, None]) * (1 + s * mm))).mean(1)
    ratio = ss / st * (b + s) * 0.5 * J
    zb = 2 * D * st
    c = b[:, None] * mm / (b[:, None] * mm + 1)
    rt = ss / st * 0.5 * (2 * (1 / b[:, None] + zb) - (zb - mm) * c).mean(1) / (1 / b + zb)
    mue = mut + np.maximum((rt / ratio) * (mut + zb) - zb - mut, 0)
    return ratio, ratio * (1 + s * mue) / (1 + s * mut), mue

def run(ch, variant):
    global LASTK
    ss, sa = sd.MAT[ch]; st = ss + sa; D = 1 / (3 * st)
    mu = sd.mu; lit = mu > 0; mut = np.maximum(mu, 1e-6)
    irr_mu = mu  # the surface irradiance / E
    KC = 'kc' in variant; variant = variant.replace('kc', '')
    if variant.startswith('upstream'):
        # the beam's first collisions moved downstream by the lateral mean free path: the node
        # takes the light of its upstream point (cosine mu + c (1 - mu^2)), with the map's
        # Jacobian (mu + c (1 - 3 mu^2) in all), c = H / sigma_t' (H = 1/R), scaled by C
        c = float(variant[8:] or 1) / (R * st)
        up = mu + c * (1 - mu ** 2); irr_mu = np.maximum(mu + c * (1 - 3 * mu ** 2), 0)
        lit = (up > 0) & (irr_mu > 0); mut = np.maximum(up, 1e-6)
    ratio, gain, mue = fit(ss, sa, mut)
    if variant.startswith('beam'):
        gain, mue = np.ones_like(mut), mut
    if variant == 'first_power':   # the beam (gain 1, mu_t) scaled by r: the pre-fit code
        gain, mue = ratio, mut
    beta = st / mue; Q0 = gain * ss * E * irr_mu / mue
    K = Q0 / (sa - D * beta ** 2 - (2 * D * beta / R if KC else 0)) * lit
    q = -K * (1 + 2 * D * beta) / 4
    qf = np.zeros_like(mu)
    if variant.startswith('flux<'):
        m0 = float(variant[5:]); t = np.clip(mu / m0, 0, 1); w = t * t * (3 - 2 * t)
        qf = (1 - w) * ratio * E * mu * lit; q = w * q + qf; K = w * K
    if variant == 'flux':
        qf = E * mu * lit; q = qf; K = 0 * K
    sd.Q_OVERRIDE = np.where(lit, q, 0)
    _, f, _ = sd.solve(ch, 'flux')
    sd.Q_OVERRIDE = None
    mus = np.linspace(-1, 1, 4001); P = sd.legendre_table(mus, sd.L); phi = (f[:, None] * P).sum(0)
    return mus, phi / 2 + np.interp(mus, mu, K) / 2 - np.interp(mus, mu, qf)
edges = np.linspace(-1, 1, 41)
mc = {c: np.load(f'target/litcap/ring_{c}.npy') for c in CHS}
for variant in [v for v in ARGS if not v.startswith("vol:")]:
    rows = []
    for ch in CHS:
        mus, M = run(ch, variant)
        Mb = np.array([M[(mus >= a) & (mus < b)].mean() for a, b in zip(edges[:-1], edges[1:])])
        rows.append(Mb / mc[ch][1 if variant in ('flux',) or 'beam' in variant else 2])
    r = np.mean(rows, 0)
    for ch, rr in zip(CHS, rows): print('  ', ch, ' '.join(f'{x:.3f}' for x in rr[12::2]))
    print(variant.ljust(12), ' '.join(f'{c:+.2f}:{x:.3f}' for c, x in zip(mc[CHS[0]][0], r) if c > -0.4))
for variant in [v for v in ARGS if v.startswith('vol:')]:
    src = variant[4:]; rows = []
    for ch in CHS:
        _, f, _ = sd.solve(ch, src)
        mus = np.linspace(-1, 1, 4001); P = sd.legendre_table(mus, sd.L); M = (f[:, None] * P).sum(0) / 2
        Mb = np.array([M[(mus >= a) & (mus < b)].mean() for a, b in zip(edges[:-1], edges[1:])])
        rows.append(Mb / mc[ch][1])
    r = np.mean(rows, 0)
    for ch, rr in zip(CHS, rows): print('  ', ch, ' '.join(f'{x:.3f}' for x in rr[12::2]))
    print(variant.ljust(12), ' '.join(f'{c:+.2f}:{x:.3f}' for c, x in zip(mc[CHS[0]][0], r) if c > -0.4))
