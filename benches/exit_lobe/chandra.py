"""Chandrasekhar's H function and the own-light exit lobe (scene::ExitLobe::Chandra), eta 1.

Usage: python3 benches/exit_lobe/chandra.py      # prints the checks of RESULTS "Own-light lobe"

Isotropic half-space (Chandrasekhar, Radiative Transfer, 1950, ch. IV eq. 31):
I(mu, mu0) = (omega F / 4) mu0 / (mu + mu0) H(mu) H(mu0); its single scattering is the "1" of
H H, so the multiple-scattered part has the shape (H(mu) H(mu0) - 1) / (mu + mu0), normalized
here so that 2 int g mu dmu = 1 (the exitance of the Lambertian lobe, g = 1).
"""
import numpy as np


def h_exact(mu, omega, n=2000):
    """H from its integral form (Chandrasekhar 1950, ch. V eq. 48; exact for every albedo):
    ln H(mu) = -(mu / pi) int_0^(pi/2) ln(1 - omega t cot t) / (cos^2 t + mu^2 sin^2 t) dt."""
    x, w = np.polynomial.legendre.leggauss(n)
    t, w = np.pi / 4 * (x + 1), np.pi / 4 * w
    f = np.log(1 - omega * t / np.tan(t))
    mu = np.atleast_1d(np.asarray(mu, float))[:, None]
    return np.exp(-mu[:, 0] / np.pi * (w * f / (np.cos(t) ** 2 + mu**2 * np.sin(t) ** 2)).sum(1))


def h_hapke(mu, omega):
    """Hapke (2002, Icarus 157, eq. 13): < 1% from the exact H for every albedo."""
    mu = np.maximum(np.asarray(mu, float), 1e-6)
    g = np.sqrt(1 - omega)
    r0 = (1 - g) / (1 + g)
    return 1 / (1 - omega * mu * (r0 + 0.5 * (1 - 2 * r0 * mu) * np.log((1 + mu) / mu)))


GL_X, GL_W = np.polynomial.legendre.leggauss(8)
GL_X, GL_W = 0.5 * (GL_X + 1), 0.5 * GL_W


def lobe(mu, mu0, omega, h=h_hapke, nodes=(GL_X, GL_W)):
    """g(mu; mu0, omega) = (H(mu) H(mu0) - 1) / (mu + mu0) / (2 int (H H - 1) mu / (mu + mu0))."""
    x, w = nodes
    h0 = h(np.array([mu0]), omega)[0]
    norm = 2 * np.sum(w * x * (h(x, omega) * h0 - 1) / (x + mu0))
    mu = np.asarray(mu, float)
    return (h(mu, omega) * h0 - 1) / (mu + mu0) / norm


if __name__ == "__main__":
    mus = np.linspace(0, 1, 101)
    print("H: Hapke 2002 vs exact, worst relative error over mu in [0, 1]")
    for om in (0.5, 0.9, 0.99, 0.9926, 0.999, 1.0):
        he = h_exact(mus, om)
        print(f"  omega {om:6.4f}: {np.max(np.abs(h_hapke(mus, om) / he - 1)) * 100:.3f}%  H(1) = {he[-1]:.4f}")
    fine = np.polynomial.legendre.leggauss(200)
    fine = (0.5 * (fine[0] + 1), 0.5 * fine[1])
    print("normalization: 8-point Gauss-Legendre vs 200-point (same H), worst over 25 mu0 in [0.001, 1]")
    for om in (0.5, 0.9926, 0.999, 1.0):
        e = max(abs(lobe(0.5, m0, om) / lobe(0.5, m0, om, nodes=fine) - 1) for m0 in np.linspace(0.001, 1, 25))
        print(f"  omega {om}: {e * 100:.3f}%")
    print("lobe with Hapke's H vs with the exact H (same normalization quadrature, 200 points)")
    for om in (0.9926, 0.999, 1.0):
        e = max(np.max(np.abs(lobe(mus, m0, om, nodes=fine) / lobe(mus, m0, om, h=h_exact, nodes=fine) - 1))
                for m0 in (1.0, 0.5, 0.3, 0.2, 0.05))
        print(f"  omega {om}: {e * 100:.3f}%")
    print("ratio g(0.9) / g(0.3) (exact H): the limb darkening at normal incidence, flat at grazing")
    for om in (1.0, 0.999, 0.9926):
        r = [np.ravel(lobe(0.9, m0, om, h=h_exact, nodes=fine) / lobe(0.3, m0, om, h=h_exact, nodes=fine))[0] for m0 in (1.0, 0.5, 0.3, 0.1)]
        print(f"  omega {om}: mu0 1, 0.5, 0.3, 0.1: " + ", ".join(f"{x:.4f}" for x in r))
    print("g at mu = 0, 0.5, 1 for mu0 = 1 and 0.3 (omega 0.999, Hapke H, 8-point norm):")
    for m0 in (1.0, 0.3):
        print("  ", m0, [round(float(v), 5) for v in lobe(np.array([0.0, 0.5, 1.0]), m0, 0.999)])
