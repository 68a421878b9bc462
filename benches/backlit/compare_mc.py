import numpy as np, sys
sys.argv = ['x', '3000']
import sphere_diffusion as sd
edges = np.linspace(-1, 1, 41)
for ch in 'RGB':
    mc = np.load(f'mc_{ch}_1.npy')
    out = []
    for src in ['flux', 'first']:
        _, f = sd.solve(ch, src)
        # bin-averaged phi
        mus = np.linspace(-1, 1, 4001); P = sd.legendre_table(mus, sd.L)
        phi = (f[:, None] * P).sum(0)
        Mb = np.array([phi[(mus >= a) & (mus < b)].mean() / 2 for a, b in zip(edges[:-1], edges[1:])])
        out.append(Mb)
    print(f'channel {ch}: mu  M_mc +- err   M_diff(flux)  M_diff(first)   mc/flux  mc/first')
    for i in range(40):
        c = mc[0, i]
        if c < 0.05 and (i % 2 == 0 or abs(c + 0.777) < 0.05):
            print(f'  {c:+.3f} {mc[1,i]:.5f} {mc[2,i]:.5f}  {out[0][i]:.5f}  {out[1][i]:.5f}   {mc[1,i]/out[0][i]:.3f}  {mc[1,i]/out[1][i]:.3f}')
