"""Exit-lobe fit on the half-space Monte Carlo (research/halfspace-mc) and a slab Monte Carlo.

Usage: python3 benches/exit_lobe/lobe_mc.py run N        # runs the cases, writes lobe_mc.npz
       python3 benches/exit_lobe/lobe_mc.py slabs N      # reruns only the slabs
       python3 benches/exit_lobe/lobe_mc.py refine       # recomputes the diffusion side only
       python3 benches/exit_lobe/lobe_mc.py fit          # fits b of L ~ T_o (1 + b mu_i) / norm
(lobe_mc.npz beside this script, 7 KB, holds the data of RESULTS "Exit lobe": `fit` alone reruns in seconds.)

Reflection: half-space, render's default source (second-collision diffusion + exact single
scattering, diff3.solve2), exitance M of DESIGN 2.6; the lobe only redistributes M over angles.
Transmission: a slab of thickness L (reduced mean free paths), eta 1, lit normally from behind;
the Monte Carlo's transmitted radiance shape against (1 + b mu).
"""
import sys, os
import numpy as np
sys.path.insert(0, "/work/shared/research/halfspace-mc")
from mc import run, fresnel  # noqa: E402
from diff import C1C2  # noqa: E402
# diff3.py runs its command line on import: take its solve2 (the second-collision source) only.
_src = open("/work/shared/research/halfspace-mc/diff3.py").read()
_ns = {}
_src = _src[: _src.index("a=float(sys.argv[1])")]
exec(_src, _ns)
solve2 = _ns["solve2"]  # diff3's 0.01 mfp depth grid (a 0.03 grid moves the exitance by ~4%:
# the kernel's log singularity on the diagonal)

OUT = os.path.join(os.path.dirname(__file__), "lobe_mc.npz")
CASES = [(0.999, 1.0, 30), (0.9, 1.0, 30), (0.999, 1.3, 30), (0.999, 1.5, 30), (0.5, 1.0, 30),
         (0.999, 1.0, 60), (0.999, 1.0, 0), (0.9, 1.5, 30), (0.99, 1.0, 30), (0.999, 1.5, 60)]


def lobe_norm(eta, b, n=4000):
    """1 + b K(eta): K = int T_o mu_i mu_o dmu_o / int T_o mu_o dmu_o (mu_i the refracted cosine)."""
    mo = (np.arange(n) + 0.5) / n
    to = 1 - fresnel(mo, eta)
    mi = np.sqrt(1 - (1 - mo**2) / eta**2)
    return 1 + b * np.sum(to * mi * mo) / np.sum(to * mo)


def slab(alpha, L, N, nb=9, rng=np.random.default_rng(2)):
    """Eta-1 slab z in [0, L], normal beam entering at z = 0; radiance leaving z = L per mu bin."""
    z = np.zeros(N); mu = np.ones(N); w = np.ones(N); alive = np.ones(N, bool)
    scattered = np.zeros(N, bool)  # the unscattered beam is no part of the diffuse exit lobe
    acc = np.zeros(nb)
    while alive.any():
        i = np.nonzero(alive)[0]
        zn = z[i] - mu[i] * np.log(rng.random(i.size))
        out_back = zn > L; out_front = zn < 0
        b = np.minimum((mu[i][out_back] * nb).astype(int), nb - 1)
        np.add.at(acc, b, w[i][out_back] * scattered[i][out_back])
        alive[i[out_back | out_front]] = False
        k = i[~(out_back | out_front)]
        z[k] = zn[~(out_back | out_front)]; w[k] *= alpha; mu[k] = 2 * rng.random(k.size) - 1
        scattered[k] = True
        low = alive & (w < 1e-3); kill = low & (rng.random(N) < 0.5)
        alive[kill] = False; w[low & ~kill] *= 2
    cen = (np.arange(nb) + 0.5) / nb
    return cen, acc / (N * 2 * np.pi / nb * cen)


def main_refine():
    """Recompute the diffusion side of the stored cases (the Monte Carlo stays)."""
    res = dict(np.load(OUT))
    for k in [k for k in res if k.startswith("r_")]:
        _, a, e, t = k.split("_")
        cen, La = res[k][0], res[k][1]
        out, Lss = solve2(float(a), float(e), float(t), cen)
        res[k] = np.stack([cen, La, out["2nd"][1], Lss])
        np.savez(OUT, **res)
        print("refined", k, flush=True)


def main_run(N, slabs_only=False):
    res = dict(np.load(OUT)) if slabs_only else {}
    for L in (2.0, 4.0, 8.0):
        cen, Lt = slab(0.999, L, N)
        res[f"t_{L}"] = np.stack([cen, Lt])
        print("done slab", L, flush=True)
    if slabs_only:
        np.savez(OUT, **res)
        return
    for (a, e, t) in CASES:
        cen, La, Ls, Rt, Rs, Ti = run(a, e, t, N=N)
        out, Lss = solve2(a, e, t, cen)
        res[f"r_{a}_{e}_{t}"] = np.stack([cen, La, out["2nd"][1], Lss])
        print("done", a, e, t, flush=True)
        np.savez(OUT, **res)  # after each case: a fit can start on the first ones


def rms(x):
    return float(np.sqrt(np.mean((x - 1) ** 2)))


def p1_slope(eta):
    """b of the P1 lobe: 3 / (2 A), A = (1 + 3 C2) / (1 - 2 C1) (scene::ExitLobe::slope)."""
    c1, c2 = C1C2(eta)
    return 3 / (2 * (1 + 3 * c2) / (1 - 2 * c1))


def main_fit():
    """Columns: the share s of the P1 slope, b = s 3 / (2 A(eta)) (1.5 s at eta 1)."""
    d = np.load(OUT)
    bs = np.round(np.arange(0, 1.67, 1 / 30), 3)
    w = slice(1, None)  # bins 80..19 degrees (the grazing-most bin is noisy)
    table = {}
    for k in d.files:
        if k.startswith("r_"):
            cen, La, Lex, Lss = d[k]
            eta = float(k.split("_")[2])
            mi = np.sqrt(1 - (1 - cen**2) / eta**2)
            errs = [rms(((Lex * (1 + s * p1_slope(eta) * mi) / lobe_norm(eta, s * p1_slope(eta))) + Lss)[w] / La[w]) for s in bs]
            table[k] = errs
        else:
            cen, Lt = d[k]
            # shape only: the exitance is the slab model's job; fit the best-scaled (1 + b mu)
            errs = []
            for s in bs:
                b = s * p1_slope(1.0)
                f = (1 + b * cen) / lobe_norm(1.0, b)
                s = np.sum(Lt[w] * cen[w]) / np.sum(f[w] * cen[w])
                errs.append(rms(s * f[w] / Lt[w]))
            table[k] = errs
    print("share of P1     " + " ".join(f"{b:5.2f}" for b in bs[::5]) + "   best s  rms@best  lambert")
    for k, e in table.items():
        e = np.array(e); i = int(np.argmin(e))
        print(f"{k:15s} " + " ".join(f"{x*100:5.1f}" for x in e[::5]) + f"   {bs[i]:5.2f}  {e[i]*100:5.2f}%  {e[0]*100:5.2f}%")
    refl = np.array([v for k, v in table.items() if k.startswith("r_")])
    tr = np.array([v for k, v in table.items() if k.startswith("t_")])
    for name, arr in (("reflection", refl), ("transmission", tr), ("all", np.vstack([refl, tr]))):
        m = np.sqrt(np.mean(arr**2, axis=0)); i = int(np.argmin(m))
        print(f"{name:12s} best share {bs[i]:.2f}: mean rms {m[i]*100:.2f}% (lambert {m[0]*100:.2f}%, "
              f"share 0.5 {m[15]*100:.2f}%, p1 {m[30]*100:.2f}%)")


if __name__ == "__main__":
    if sys.argv[1] == "refine":
        main_refine()
    elif sys.argv[1] in ("run", "slabs"):
        main_run(int(sys.argv[2]), slabs_only=sys.argv[1] == "slabs")
    else:
        main_fit()
