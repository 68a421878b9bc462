"""Independent axisymmetric diffusion solve of a back-lit sphere (eta = 1, A = 1):
Legendre expansion in theta (axis = toward the light) x finite differences in r (u = r f_l).
Sources: 'flux' = DESIGN 2 boundary flux (Robin rhs 4q); 'first' = first-collision volume source
sigma_s' E exp(-sigma_t' s) (all scattering orders in diffusion); 'second' = second-collision source
(sigma_s' x uncollided fluence of once-scattered light, locally-plane half-space approximation).
First-collision geometries (benches/crescent, issue 12 wave 8): 'planar' = the planar model's
placement (below each lit surface point along its normal, decay sigma_t'/mu with the point's own
cosine), 'curv_lit' = the true chord length back to the surface but only below lit points,
'shift' = 'planar' taken from one lateral mean free path upstream, 'mue[C]' = 'planar' with the
depth's curvature term mu + C / (R sigma_t'), power kept."""
import numpy as np, sys
R = 10.0; E = 5.0
d = np.array([0.2, -0.35, 1.0]); d /= np.linalg.norm(d)       # light travel direction
ncam = np.array([0, 20, 60.0]); ncam /= np.linalg.norm(ncam)  # camera-facing surface normal
mu_c = float(ncam @ -d)                                        # cos angle to the lit pole
MAT = {'R': (2.19, 0.0021), 'G': (2.62, 0.0041), 'B': (3.0, 0.0071)}
N = int(sys.argv[1]) if len(sys.argv) > 1 else 4000; L = 240
mu, wmu = np.polynomial.legendre.leggauss(600)
Q_OVERRIDE = None  # the boundary flux per Gauss node of mu for src 'flux' (benches/crescent)

def legendre_table(x, L):
    P = np.zeros((L + 1,) + np.shape(x)); P[0] = 1; P[1] = x
    for l in range(1, L): P[l + 1] = ((2 * l + 1) * x * P[l] - l * P[l - 1]) / (l + 1)
    return P
Pmu = legendre_table(mu, L); Pc = legendre_table(np.array(mu_c), L)
ls = np.arange(L + 1)

def E1(x):
    # exponential integral E1 (x > 0), series / continued fraction
    x = np.asarray(x, float); out = np.empty_like(x)
    s = x < 1
    xs = x[s]; t = -np.euler_gamma - np.log(xs); term = np.ones_like(xs)
    acc = np.zeros_like(xs)
    for k in range(1, 40):
        term = term * (-xs) / k; acc -= term / k
    out[s] = t + acc
    xl = x[~s]
    # Lentz continued fraction
    b = xl + 1; c = 1e300 * np.ones_like(xl); dd = 1 / b; h = dd
    for i in range(1, 200):
        a = -i * i; b = b + 2; dd = 1 / (a * dd + b); c = b + a / c; de = c * dd; h = h * de
    out[~s] = h * np.exp(-xl)
    return out

def second_profile(st, mui, zmax):
    """half-space, isotropic, incidence cos mui: second-collision density per unit sigma_s'^2 E / mui..
    returns z grid and density q2(z) = sigma_s * phi1(z), phi1 = once-scattered uncollided fluence"""
    z = np.linspace(0, zmax, 1201); dz = z[1] - z[0]
    q1 = np.exp(-st * z / mui)  # first-collision density / (sigma_s E / mui)... scaled below
    zz = np.abs(z[:, None] - z[None, :]) * st
    K = 0.5 * st * E1(np.maximum(zz, 1e-9))  # 1D kernel of isotropic emission -> fluence (per unit source)
    K[zz < 1e-9] = 0.5 * st * (E1(np.array([dz * st / 4]))[0] + 1)  # crude diagonal
    phi1 = (K * q1[None, :]).sum(1) * dz / st * st
    return z, phi1

def solve(ch, src):
    ss, sa = MAT[ch]; st = ss + sa; D = 1 / (3 * st); h = R / N
    r = np.arange(N + 1) * h
    q_l = np.zeros(L + 1); Q = np.zeros((L + 1, N + 1))
    if src == 'flux':
        q = E * np.maximum(0, mu) if Q_OVERRIDE is None else Q_OVERRIDE; q_l = (2 * ls + 1) / 2 * (Pmu * (q * wmu)).sum(1)
    elif src in ('beam', 'beam_curv'):
        # DESIGN 2.7 as the code does it: planar particular solution K exp(-beta z) moved into the
        # Robin row (phi_h - 2 D phi_h' = -K (1 + 2 D beta)); far side phi = phi_h.
        # beam_curv: K with the sphere's curvature term, K = Q0 / (sa - D beta^2 - 2 D beta / R).
        mut = np.maximum(mu, 1e-6); beta = st / mut; Q0 = ss * E * (mu > 0)
        den = sa - D * beta**2 - (2 * D * beta / R if src == 'beam_curv' else 0)
        Kp = Q0 / den
        q = -Kp * (1 + 2 * D * beta) / 4 * (mu > 0); q_l = (2 * ls + 1) / 2 * (Pmu * (q * wmu)).sum(1)
    else:
        # point (r, mu): axis toward light; distance travelled from entry along -axis... beam travels -axis
        rr = r[:, None]; z = rr * mu[None, :]; rho2 = rr**2 * (1 - mu[None, :]**2)
        s = np.sqrt(np.maximum(R**2 - rho2, 0)) - z   # path length inside from entry point
        if src == 'first':
            dens = ss * E * np.exp(-st * s)
        elif src in ('curv_lit', 'shift'):
            m_ = mu[None, :] + 0 * rr; zz = R - rr
            if src == 'curv_lit':
                # exact chord length back to the surface along the light, only below lit points
                sx = -(R - zz) * m_ + np.sqrt(np.maximum((R - zz) ** 2 * m_ ** 2 + 2 * R * zz - zz ** 2, 0))
                dens = ss * E * np.exp(-st * sx) * (m_ > 0)
            else:
                # planar profile of the point one lateral mean free path upstream (toward the light)
                th = np.arccos(np.clip(m_, -1, 1)) - np.sqrt(np.maximum(1 - np.maximum(m_, 0) ** 2, 0)) / st / R
                mup = np.cos(np.maximum(th, 0))
                dens = ss * E * np.exp(-st * zz / np.maximum(mup, 1e-6)) * (mup > 0)
        elif src.startswith('mue'):
            c_ = float(src[3:] or 1)
            m_ = mu[None, :] + 0 * rr; zz = R - rr
            me = np.maximum(m_, 0) + c_ / (R * st)
            dens = ss * E * (m_ / me) * np.exp(-st * zz / me) * (m_ > 0)
        elif src == 'planar':
            # the first collision as the planar model places it: below each surface point along its
            # normal, decay sigma_t' / mu with mu the point's own cosine to the light
            mp = np.maximum(mu[None, :], 1e-6) + 0 * rr
            dens = ss * E * np.exp(-st * (R - rr) / mp) * (mu[None, :] > 0)
        elif src == 'first_r':
            # the code's `second`: first-collision shape times r(mu_t) (transport::second_collision_ratio, eta 1)
            mui = np.sqrt(np.maximum(R**2 - rho2, 0)) / R
            sig = np.sqrt(sa / D) / st; b = 1 / np.maximum(mui, 1e-6)
            mm = (np.arange(64) + 0.5) / 64
            J = (1 / ((sig + b[..., None]) * (1 + b[..., None] * mm)) + 1 / ((sig + b[..., None]) * (1 + sig * mm))).mean(-1)
            rr_ = (ss / st) * (b + sig) * 0.5 * J
            dens = rr_ * ss * E * np.exp(-st * s)
        else:
            # second collisions: local plane approx, depth below surface along normal = R - r,
            # local incidence cos = entry point's normal . (-d)
            mui = np.sqrt(np.maximum(R**2 - rho2, 0)) / R
            depth = R - rr + 0 * mu[None, :]
            dens = np.zeros_like(s)
            grid_mu = np.linspace(0.02, 1, 50); prof = []
            zmax = 12 / st
            for m in grid_mu:
                zg, p1 = second_profile(st, m, zmax)
                prof.append(ss * (ss * E) * p1 / st)   # sigma_s * fluence of once-scattered light
            prof = np.array(prof)
            im = np.clip(np.searchsorted(grid_mu, mui), 0, len(grid_mu) - 1)
            iz = np.clip((depth / (zg[1] - zg[0])).astype(int), 0, len(zg) - 1)
            dens = prof[im, iz] * (depth < zmax) * (mui > 0.02)
            # only where the point is on the lit side (beam reaches it from the near surface)
        Q = (2 * ls[:, None, None] + 1) / 2 * np.einsum('lm,rm->lr', Pmu, dens * wmu)[:, :, None]
        Q = Q[:, :, 0]
    # u'' D - (D l(l+1)/r^2 + sa) u = -r Q ; u(0)=0; at R: u/R + 2D (u'/R - u/R^2) = 4 q_l
    f_R = np.zeros(L + 1); tot = 0
    for l in range(L + 1):
        n = N  # unknowns u_1..u_N
        a = np.full(n, D / h**2); c = np.full(n, D / h**2)
        b = -2 * D / h**2 - D * l * (l + 1) / r[1:]**2 - sa
        rhs = -r[1:] * Q[l, 1:]
        # boundary row (i = N): ghost via one-sided second order: u'(R) ~ (3u_N - 4u_{N-1} + u_{N-2})/(2h)
        # use ghost node: u_{N+1} = u_{N-1} + 2h u'(R), u'(R) = (4 q_l - u_N/R + 2D u_N/R^2) R/(2D)
        g = R / (2 * D)
        # D(u_{N+1} - 2u_N + u_{N-1})/h^2 => D(2u_{N-1} - 2u_N + 2h g (4q_l - u_N/R + 2D u_N/R^2))/h^2
        a[-1] = 2 * D / h**2
        b[-1] += 2 * h * g * D / h**2 * (-1 / R + 2 * D / R**2)
        rhs[-1] -= 2 * h * g * D / h**2 * 4 * q_l[l]
        rhs[-1] /= 1.0
        # Thomas (a: sub, b: diag, c: super)
        cp = np.zeros(n); dp = np.zeros(n)
        cp[0] = c[0] / b[0]; dp[0] = rhs[0] / b[0]
        for i in range(1, n):
            m = b[i] - a[i] * cp[i - 1]
            cp[i] = c[i] / m; dp[i] = (rhs[i] - a[i] * dp[i - 1]) / m
        u = np.zeros(n); u[-1] = dp[-1]
        for i in range(n - 2, -1, -1): u[i] = dp[i] - cp[i] * u[i + 1]
        f_R[l] = u[-1] / R
    phi_c = float(f_R @ Pc[:, ()] if False else (f_R * Pc).sum())
    # source power (for energy check): 4 pi R^2 * (l=0 flux) or volume integral
    return phi_c, f_R, (4*np.pi*(r[:,None]**2*dens*wmu/2).sum(1).sum()*h if src not in ('flux','beam','beam_curv') else None)

if __name__ == '__main__':
    print('mu_c', mu_c, 'angle', np.degrees(np.arccos(mu_c)))
    for src in sys.argv[2:] or ['flux', 'first']:
        for ch in 'RGB':
            phi, f, P = solve(ch, src)
            M = phi / 2
            print(f'{src} {ch}: power/input {P/(np.pi*R*R*E) if P else 1:.3f} phi {phi:.6f}  M {M:.6f}  L_lambert {M/np.pi:.6f}  L_p1(normal) {1.25*M/np.pi:.6f}')
