"""The thin-wall rule of DESIGN 2.7 measured on the slab (issue 12, item 5): transmitted and
reflected exitance of a slab lit by a collimated beam (eta 1, isotropic phase with the reduced
coefficients, the plate scene's incidence mu_i = 0.9275), against its thickness in transport mean
free paths, for the source variants the solvers can take at a wall:
  flux      the boundary flux of DESIGN 2 (the thin-wall fallback)
  beam      the collimated particular solution K exp(-beta z) in the lit face's Robin row only
            (the far face's row knows nothing of it: the GPU gather before this change)
  beam+c    the same with the far face's Robin row and exit query carrying K exp(-beta L)
            (continuation: exact for the slab; the f64 CPU's `Transport::continuation`)
  2nd, 2nd+c the second-collision source fitted to both moments (transport::second_collision_fit),
            compared with the Monte Carlo's light scattered more than once (single scattering is the
            march's, added whole)
Diffusion in closed form (phi_h = a cosh(s z) + b sinh(s z), A = 1, D = 1/(3 sigma_t'), the
moments exit query M = phi/4 + (D/2) dphi/dz_in); the Monte Carlo as benches/backlit/slab_mc.py.
Prints per material and thickness the ratio diffusion / Monte Carlo of the transmission T and
reflection R. numpy only; ~1 min.  Usage: python3 benches/thinwall/slab_rule.py [PHOTONS]"""
import sys
import numpy as np

MATERIALS = {'marble R': (2.19, 0.0021), 'marble B': (3.0, 0.0071), 'skimmilk B': (1.9, 0.0142)}
MFP = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0]
MU_I = 0.9275
N = int(sys.argv[1]) if len(sys.argv) > 1 else 400000


def mc(ss, sa, th, rng):
    """Transmitted / reflected exitance per unit E mu_i: all orders, and once scattered."""
    st = ss + sa; alb = ss / st
    T = R = T1 = R1 = 0.0; done = 0
    while done < N:
        m = min(200000, N - done); done += m
        z = np.zeros(m); cz = np.full(m, MU_I); w = np.ones(m); k = np.zeros(m, int)
        while len(w):
            zn = z - np.log(rng.random(len(w))) / st * cz
            out_t = (zn >= th) & (k > 0); out_r = zn <= 0; ball = (zn >= th) & (k == 0)
            T += w[out_t].sum(); R += w[out_r].sum()
            T1 += w[out_t & (k == 1)].sum(); R1 += w[out_r & (k == 1)].sum()
            keep = ~(out_t | out_r | ball)
            z = zn[keep]; w = w[keep] * alb; k = k[keep] + 1
            cz = 2 * rng.random(len(w)) - 1
    return T / N, R / N, T1 / N, R1 / N


def diffusion(ss, sa, th, source, continuation):
    """(T, R) exitance of the slab [0, th] for a particular solution K exp(-beta z) (or a flux)."""
    st = ss + sa; D = 1 / (3 * st); s = np.sqrt(sa / D); h = 2 * D
    q = 0.0; K = 0.0; beta = 0.0
    if source == 'flux':
        q = 1.0                       # E mu_i T_i, T_i = 1 at eta 1
    else:
        mu = MU_I; gain = 1.0
        if source == 'second':
            # transport::second_collision_fit at albedo ~1 (benches/backlit/slab_diffusion.py):
            # power share r, deep moment share r_T (moments.py at mu_t 0.9275), z_b = h sigma_t'.
            b = 1 / MU_I; mm = (np.arange(64) + 0.5) / 64; sm = s / st
            r = ss / st * (b + sm) * 0.5 * np.mean(1 / ((sm + b) * (1 + b * mm)) + 1 / ((sm + b) * (1 + sm * mm)))
            r_t = 0.9984; zb = h * st
            mu = (r_t / r) * (MU_I + zb) - zb
            gain = r * MU_I / mu
        beta = st / mu
        q0 = gain * ss / MU_I          # Q0 = sigma_s' E T_i mu_i / mu_t with E mu_i = 1
        K = q0 / (sa - D * beta * beta)
    # phi_h = a cosh(s z) + b sinh(s z); near face phi_h - h phi_h' = 4q - K (1 + h beta);
    # far face phi_h + h phi_h' = -(K e^{-beta th})(1 - h beta) with continuation, else 0.
    c, sh = np.cosh(s * th), np.sinh(s * th)
    m = np.array([[1.0, -h * s], [c + h * s * sh, sh + h * s * c]])
    far = -K * np.exp(-beta * th) * (1 - h * beta) if continuation else 0.0
    a, b = np.linalg.solve(m, [4 * q - K * (1 + h * beta), far])
    def phi(z, dz):
        ph = a * np.cosh(s * z) + b * np.sinh(s * z)
        dph = s * (a * np.sinh(s * z) + b * np.cosh(s * z))
        pp = K * np.exp(-beta * z); dpp = -beta * pp
        keep = continuation or z == 0.0
        return (ph + (pp if keep else 0.0)), (dph + (dpp if keep else 0.0)) * dz
    p0, d0 = phi(0.0, 1.0)
    pl, dl = phi(th, -1.0)
    # DESIGN 2.6 at A = 1: M = phi/4 + (D/2) dphi/dz_in (with the flux's Robin row, phi/2 - q:
    # DESIGN 2's J+ at eta 1).
    return pl / 4 + D / 2 * dl, p0 / 4 + D / 2 * d0


rng = np.random.default_rng(7)
print(f'photons {N}, mu_i {MU_I}; ratios diffusion / Monte Carlo (T all orders; 2nd: T - T1)')
for name, (ss, sa) in MATERIALS.items():
    st = ss + sa
    print(f'\n{name}: sigma_s\' {ss}, sigma_a {sa} /mm; tau = sigma_t\' d (mfp); tau/mu_t along the beam')
    print(' tau   d mm |  MC T    MC R  |  T: flux   beam  beam+c  2nd  2nd+c |  R: flux   beam  beam+c')
    for tau in MFP:
        th = tau / st
        T, R, T1, R1 = mc(ss, sa, th, rng)
        v = {k: diffusion(ss, sa, th, *k) for k in
             [('flux', False), ('beam', False), ('beam', True), ('second', False), ('second', True)]}
        t = [v[('flux', False)][0] / T, v[('beam', False)][0] / T, v[('beam', True)][0] / T,
             v[('second', False)][0] / (T - T1), v[('second', True)][0] / (T - T1)]
        r = [v[('flux', False)][1] / R, v[('beam', False)][1] / R, v[('beam', True)][1] / R]
        print(f'{tau:4.1f} {th:6.3f} | {T:.4f} {R:.4f} | ' + ' '.join(f'{x:6.3f}' for x in t)
              + ' | ' + ' '.join(f'{x:6.3f}' for x in r))
