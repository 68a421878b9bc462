"""1D diffusion across the 2 mm marble slab (eta 1, A = 1), lit at mu_i = 0.9275 (E mu_i = 1):
transmitted exitance M_T = phi(L)/2 for sources: boundary flux (DESIGN 2), first-collision
(beam), the true second-collision density (slab, E1 kernel, both faces leak), and the code's
`second` (first-collision shape x r). Compare slab_mc.py."""
import numpy as np
from sphere_diffusion import E1
MAT = {'R': (2.19, 0.0021), 'G': (2.62, 0.0041), 'B': (3.0, 0.0071)}
L = 2.0; mui = 0.9275; N = 4000; z = np.linspace(0, L, N + 1); h = z[1] - z[0]
def solve(D, sa, Q, q0):
    # D phi'' - sa phi = -Q ; phi - 2D phi' = 4 q0 at z=0 (phi' = d/dz inward), phi + 2D phi' = 0 at z=L
    n = N + 1; A = np.zeros((n, n)); b = -Q.copy() * h * h
    for i in range(1, N): A[i, i-1] = D; A[i, i] = -2*D - sa*h*h; A[i, i+1] = D
    A[0, 0] = 1 + 2*D*1.5/h; A[0, 1] = -2*D*2/h; A[0, 2] = 2*D*0.5/h; b[0] = 4*q0
    A[N, N] = 1 + 2*D*1.5/h; A[N, N-1] = -2*D*2/h; A[N, N-2] = 2*D*0.5/h; b[N] = 0
    return np.linalg.solve(A, b)
for ch in 'RGB':
    ss, sa = MAT[ch]; st = ss + sa; D = 1/(3*st)
    first = ss / mui * np.exp(-st * z / mui)     # per unit surface irradiance E mu_i = 1
    K = 0.5 * st * E1(np.maximum(st*np.abs(z[:, None]-z[None, :]), 1e-12)); np.fill_diagonal(K, 0.5*st*(2 - np.log(st*h/2) - np.euler_gamma))
    second = ss * (K @ first) * h / st   # sigma_s x fluence of once-scattered light (kernel E1(sigma_t d)/2)
    s = np.sqrt(sa/D)/st; b = 1/mui; mm = (np.arange(64)+0.5)/64
    r = ss/st*(b+s)*0.5*np.mean(1/((s+b)*(1+b*mm)) + 1/((s+b)*(1+s*mm)))
    out = {}
    out['flux'] = solve(D, sa, 0*z, 1.0)[-1]/2
    out['first'] = solve(D, sa, first, 0.0)[-1]/2
    out['second(true)'] = solve(D, sa, second, 0.0)[-1]/2
    out['first x r'] = solve(D, sa, r*first, 0.0)[-1]/2
    print(ch, f'r={r:.3f} P2/P1={second.sum()/first.sum():.3f}', '  '.join(f'{k}: {v:.4f}' for k, v in out.items()))

print('\nproposed fix: two-moment fit (g, beta\') of the second-collision source; reflected M_R = phi(0)/2 and transmitted M_T')
for ch in 'RGB':
    ss, sa = MAT[ch]; st = ss + sa; D = 1/(3*st)
    first = ss / mui * np.exp(-st * z / mui)
    K = 0.5 * st * E1(np.maximum(st*np.abs(z[:, None]-z[None, :]), 1e-12)); np.fill_diagonal(K, 0.5*st*(2 - np.log(st*h/2) - np.euler_gamma))
    second = ss * (K @ first) * h / st
    s = np.sqrt(sa/D)/st; b = 1/mui; mm = (np.arange(64)+0.5)/64
    r = ss/st*(b+s)*0.5*np.mean(1/((s+b)*(1+b*mm)) + 1/((s+b)*(1+s*mm)))
    rT = 0.9984; zb = 2/3                       # moments.py at mu_t 0.9275
    lp = (rT / r) * (mui + zb) - zb             # 1/beta' in mfp
    g = r * mui / lp
    fit = g * ss / mui * np.exp(-st * z / lp)
    for name, Q in [('true second', second), ('code first x r', r * first), ('fit', fit)]:
        p = solve(D, sa, Q, 0.0)
        print(f'  {ch} {name:15s} M_R {p[0]/2:.4f}  M_T {p[-1]/2:.4f}   (g {g:.3f}, 1/beta\' {lp:.3f} mfp)' if name == 'fit' else f'  {ch} {name:15s} M_R {p[0]/2:.4f}  M_T {p[-1]/2:.4f}')
