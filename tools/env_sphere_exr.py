"""A sphere under a constant environment (issue 12 item 4's must-show): per-pixel coefficient of
variation and albedo against the sphere's diffusion closed form (DESIGN 2).

    tools/env_sphere_exr.py ours.exr --material skin1 [--eta 1.3] [--radius 10] [--env 1]
        [--camera 0,0,60:0,0,0:30] [--diffusion grosjean|classical] [--exit-query moments|flux]
        [--min-cos 0.15] [--json]

The image must be rendered with `--env-constant E,E,E --light dir:0,-1,0:0,0,0 --no-specular`
and the same `--camera` and `--size-mm 2R` (`--shape sphere`). The shading writes L_o =
F_t(eta, theta_o) X / (pi eta^2) with X = J+ = M / (1 - F_dr) (flux query; q = pi E eta^2 (1 -
F_dr)) or X = M eta^2 / (1 - 2 C1(1/eta)) (moments; q = pi E (1 - 2 C1(1/eta))), so in both the
albedo M / q of a pixel is L_o / (F_t(eta, theta_o) E), with theta_o from
the camera ray's hit on the sphere. Pixels with cos theta_o below --min-cos (the silhouette band,
where supersampling mixes in the background) and alpha below 1 are left out. Prints per channel
the CV of the radiance, the CV of the albedo per pixel, the mean albedo and its error against the
closed form (the channels whose closed-form J+ is negative are reported as such). Runs in the
venv tools/pt_reference.py makes (as tools/compare_exr.py).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pt_reference import ensure_mitsuba  # noqa: E402

# Jensen et al. 2001, Fig. 5, as engine/src/material/presets.rs (sigma_s', sigma_a in 1/mm).
PRESETS = {
    "marble": ([2.19, 2.62, 3.0], [0.0021, 0.0041, 0.0071]),
    "skin1": ([0.74, 0.88, 1.01], [0.032, 0.17, 0.48]),
    "ketchup": ([0.18, 0.07, 0.03], [0.061, 0.97, 1.45]),
    "skimmilk": ([0.7, 1.22, 1.9], [0.0014, 0.0025, 0.0142]),
}


def diffuse_reflectance(eta: float) -> float:
    """Internal F_dr (engine/src/material/fresnel.rs)."""
    if eta >= 1.0:
        return -1.440 / eta**2 + 0.710 / eta + 0.668 + 0.0636 * eta
    return -0.4399 + 0.7099 / eta - 0.3319 / eta**2 + 0.0636 / eta**3


def fresnel_transmittance(eta: float, cos_o: float) -> float:
    """1 - F_r for unpolarized light arriving from outside at cos_o (reciprocal on exit)."""
    c = min(max(cos_o, 0.0), 1.0)
    sin2_t = (1.0 - c * c) / (eta * eta)
    if sin2_t >= 1.0:
        return 0.0
    ct = math.sqrt(1.0 - sin2_t)
    rs = (c - eta * ct) / (c + eta * ct)
    rp = (eta * c - ct) / (eta * c + ct)
    return 1.0 - 0.5 * (rs * rs + rp * rp)


def fresnel_moment(eta: float, k: int, steps: int = 20000) -> float:
    """C_k(eta) = int_0^1 F_r mu^k dmu seen from inside (engine/src/material/fresnel.rs)."""
    total = 0.0
    for i in range(steps):
        mu = (i + 0.5) / steps
        total += (1.0 - fresnel_transmittance(1.0 / eta, mu)) * mu**k / steps
    return total


def sphere_albedo(sigma_s: float, sigma_a: float, eta: float, radius: float, kind: str,
                  exit_query: str) -> float:
    """The model's closed form on a sphere under a uniform diffuse flux q (DESIGN 2, 2.5-2.6):
    phi = alpha sinh(s r) / r, dphi/dz_in = -g phi at r = R with g = s coth(sR) - 1/R, the Robin
    condition phi + 2 A D g phi = flux_gain q, the exit query's M / q; `flux` is
    solver::analytic::Homogeneous::sphere_albedo."""
    sigma_t = sigma_s + sigma_a
    d = (2 * sigma_a + sigma_s) / (3 * sigma_t**2) if kind == "grosjean" else 1 / (3 * sigma_t)
    s = math.sqrt(sigma_a / d)
    sr = s * radius
    g = s * s * radius / 3 if sr < 1e-4 else s / math.tanh(sr) - 1 / radius
    if exit_query == "moments":
        c1, c2 = fresnel_moment(eta, 1), fresnel_moment(eta, 2)
        a = (1 + 3 * c2) / (1 - 2 * c1)
        phi = 4 / (1 - 2 * c1) / (1 + 2 * a * d * g)
        return 0.25 * (1 - 2 * c1) * phi - 0.5 * (1 - 3 * c2) * d * g * phi
    f = diffuse_reflectance(eta)
    a = (1 + f) / (1 - f)
    phi = 4 / (1 - f) / (1 + 2 * a * d * g)
    j_plus = (1 + 1 / a) * phi / 4 - 1 / (1 + f)
    return (1 - f) * j_plus


def main() -> int:
    ensure_mitsuba()
    import numpy as np

    from compare_exr import load

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("image", type=Path)
    p.add_argument("--material", required=True, choices=sorted(PRESETS))
    p.add_argument("--eta", type=float, default=1.3)
    p.add_argument("--radius", type=float, default=10.0)
    p.add_argument("--env", type=float, default=1.0)
    p.add_argument("--camera", default="0,0,60:0,0,0:30")
    p.add_argument("--diffusion", choices=["grosjean", "classical"], default="grosjean")
    p.add_argument("--exit-query", choices=["moments", "flux"], default="moments",
                   help="the render's exit query (moments: render's default with --source second)")
    p.add_argument("--min-cos", type=float, default=0.15)
    p.add_argument("--json", action="store_true")
    a = p.parse_args()
    rgb, alpha = load(a.image)
    h, w = rgb.shape[:2]
    eye_s, target_s, fov_s = a.camera.split(":")
    eye = np.array([float(x) for x in eye_s.split(",")])
    target = np.array([float(x) for x in target_s.split(",")])
    tan_half = math.tan(math.radians(float(fov_s)) / 2)
    forward = (target - eye) / np.linalg.norm(target - eye)
    up = np.array([0.0, 1.0, 0.0]) if abs(forward[1]) < 0.999 else np.array([0.0, 0.0, 1.0])
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    ys, xs = np.mgrid[0:h, 0:w]
    ndc_x = (2 * (xs + 0.5) / w - 1) * tan_half * (w / h)
    ndc_y = (1 - 2 * (ys + 0.5) / h) * tan_half
    d = forward + ndc_x[..., None] * right + ndc_y[..., None] * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    # Ray |eye + t d| = R (the sphere at the origin).
    b = d @ eye
    disc = b * b - (eye @ eye - a.radius**2)
    hit = disc > 0
    t = -b - np.sqrt(np.maximum(disc, 0))
    x = eye + t[..., None] * d
    cos_o = np.where(hit, -np.sum(d * x, axis=-1) / a.radius, 0.0)
    mask = hit & (cos_o >= a.min_cos)
    if alpha is not None:
        mask &= alpha >= 0.999
    f_t = np.vectorize(lambda c: fresnel_transmittance(a.eta, c))(cos_o)
    sigma_s, sigma_a = PRESETS[a.material]
    out = {"pixels": int(mask.sum()), "cv_radiance": [], "cv_albedo": [], "albedo": [],
           "closed_form": [], "error": []}
    for c in range(3):
        radiance = rgb[..., c][mask]
        albedo = radiance / (f_t[mask] * a.env)
        exact = sphere_albedo(sigma_s[c], sigma_a[c], a.eta, a.radius, a.diffusion,
                              a.exit_query)
        out["cv_radiance"].append(float(np.std(radiance) / max(np.mean(radiance), 1e-30)))
        out["cv_albedo"].append(float(np.std(albedo) / max(np.mean(albedo), 1e-30)))
        out["albedo"].append(float(np.mean(albedo)))
        out["closed_form"].append(exact)
        out["error"].append(float(np.mean(albedo) / exact - 1) if exact > 0 else None)
    if a.json:
        print(json.dumps(out))
        return 0
    for c, name in enumerate("RGB"):
        err = out["error"][c]
        err_s = f"{100 * err:+.2f}%" if err is not None else "closed-form J+ < 0"
        print(f"{name}: CV radiance {100 * out['cv_radiance'][c]:.2f}%, CV albedo "
              f"{100 * out['cv_albedo'][c]:.2f}%, albedo {out['albedo'][c]:.4f}, closed form "
              f"{out['closed_form'][c]:.4f} ({err_s})")
    print(f"{out['pixels']} px with cos theta_o >= {a.min_cos}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
