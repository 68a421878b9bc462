"""Half-space (albedo 1, eta 1, mfp units): first- and second-collision densities for a beam at
refracted cosine mu; their zeroth moment and their moment with the deep-field weight (z + z_b),
z_b = 2/3 (A = 1). Deep transmitted light is proportional to the latter."""
import numpy as np
from sphere_diffusion import E1
z = np.linspace(0, 40, 8001); dz = z[1] - z[0]
zb = 2 / 3
K = 0.5 * E1(np.maximum(np.abs(z[:, None] - z[None, :]), 1e-12)); np.fill_diagonal(K, 0.5 * (1 - np.log(dz / 2) - np.euler_gamma + 1))  # cell-average of E1 near 0
print(' mu_t  | P(first)  M(first)  | P(second)  M(second) | r=P2/P1 (power)  r_T=M2/M1 (deep weight)')
acc = [0, 0, 0, 0]
for mu in [1.0, 0.9275, 0.8, 0.6, 0.4, 0.2, 0.1]:
    q1 = np.exp(-z / mu) / mu          # first collisions per unit length of depth, per unit incident flux
    q2 = (K @ q1) * dz                 # second collisions (albedo 1)
    P1, P2 = q1.sum() * dz, q2.sum() * dz
    M1, M2 = ((z + zb) * q1).sum() * dz, ((z + zb) * q2).sum() * dz
    print(f' {mu:.4f} | {P1:.4f}  {M1:.4f}  | {P2:.4f}  {M2:.4f} | {P2/P1:.4f}  {M2/M1:.4f}')
