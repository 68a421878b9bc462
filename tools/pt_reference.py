#!/usr/bin/env python3
"""Path-traced reference images (Mitsuba 3, volumetric path tracing) of the scenes `translucent
render` draws, to measure the diffusion solvers against (DESIGN sections 2 and 8; issue 6).

    tools/pt_reference.py --shape sphere --size-mm 20 --material skimmilk --eta 1 \
        --light dir:0,-1,0:4,4,4 --camera 0,20,60:0,0,0:30 --width 96 --height 96 \
        --spp 256 --out milk.exr

The first run creates a virtual environment (`target/pt-venv` in the repository, or
`$TRANSLUCENT_PT_VENV`) with mitsuba==3.9.1 and numpy from PyPI; later runs reuse it.

Scene mapping (units: mm and 1/mm, +Y up, right-handed; pixel (0,0) top-left):
- Geometry: `translucent bake --export` writes the normalized surface (`surface.obj`): the display
  mesh `render` shades, in the same frame, so both images have the same silhouette. `--translucent`
  names the binary (default `target/release/translucent`).
- Medium: sigma_t = sigma_s' + sigma_a, albedo = sigma_s' / sigma_t, isotropic phase (DESIGN
  section 2: `--sigma-s` is the reduced coefficient). RGB values above 1 go through `scale`.
- Boundary: eta = 1 is a `null` BSDF (index matched: light crosses unbent). Otherwise a
  `dielectric` of index eta. Mitsuba cannot connect a delta light (directional, point, spot)
  through a specular surface, so such an image would be black where it should be lit: delta lights
  with eta != 1 are refused; use `--eta 1` (and `translucent render --eta 1`) or `--env-constant`.
- Lights: `dir:X,Y,Z:R,G,B` -> `directional` (irradiance, travelling along X,Y,Z),
  `point:X,Y,Z:R,G,B` -> `point` (intensity), `spot:...` -> `spot` (Mitsuba's falloff is linear
  in angle between the cone half-angles; ours is a smoothstep in cos: the ramp differs).
  `--env-constant R,G,B` -> `constant` (radiance), hidden from camera rays so the background is 0.
- `--volume FILE.vol` (our 6-channel grid): written as two 3-channel Mitsuba grids, sigma_t and
  albedo, with use_grid_bbox (Mitsuba's grid volume evaluates 1 or 3 channels), one render per
  colour channel with grey grids (see render(): 3x the time). The grid is first resampled with
  our trilinear rule onto at least 64 cells per axis (resample_vol6), so that Mitsuba's
  interpolation of sigma_t and albedo renders the medium ours samples (sigma_s', sigma_a).

Output: linear RGBA EXR (alpha = pixel coverage by the object), black background, written to a
temporary file and renamed. The script prints the equivalent `translucent render` command: the
real-time default (GPU frame, specular on, so a dielectric's mirror reflection of the environment
is drawn as the reference has it; at eta = 1 the Fresnel reflectance and so every specular term is
0); add `--solver cpu` for the f64 discrete solution.
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
MITSUBA_VERSION = "3.9.1"

# Jensen et al. 2001, Fig. 5 (../shared/materials.csv): sigma_s' RGB, sigma_a RGB (1/mm), eta.
PRESETS = {
    "apple": ((2.29, 2.39, 1.97), (0.003, 0.0034, 0.046), 1.3),
    "chicken1": ((0.15, 0.21, 0.38), (0.015, 0.077, 0.19), 1.3),
    "chicken2": ((0.19, 0.25, 0.32), (0.018, 0.088, 0.2), 1.3),
    "cream": ((7.38, 5.47, 3.15), (0.0002, 0.0028, 0.0163), 1.3),
    "ketchup": ((0.18, 0.07, 0.03), (0.061, 0.97, 1.45), 1.3),
    "marble": ((2.19, 2.62, 3.0), (0.0021, 0.0041, 0.0071), 1.3),
    "potato": ((0.68, 0.7, 0.55), (0.0024, 0.009, 0.12), 1.3),
    "skimmilk": ((0.7, 1.22, 1.9), (0.0014, 0.0025, 0.0142), 1.3),
    "skin1": ((0.74, 0.88, 1.01), (0.032, 0.17, 0.48), 1.3),
    "skin2": ((1.09, 1.59, 1.79), (0.013, 0.07, 0.145), 1.3),
    "spectralon": ((11.6, 20.4, 14.9), (0.0, 0.0, 0.0), 1.3),
    "wholemilk": ((2.55, 3.21, 3.77), (0.0011, 0.0024, 0.014), 1.3),
}
SHAPES = ("sphere", "torus", "box", "capsule")
# `translucent render`'s lights when none is given, for its default camera (tools/src/scene_args.rs,
# default_lights; render turns them with a --camera, so the printed command passes them explicitly).
DEFAULT_LIGHTS = ["dir:0.2,-0.35,1:5,5,5", "dir:-0.6,-0.7,-0.4:0.6,0.6,0.6"]


class SceneError(Exception):
    """Bad input: the message names the option and the problem."""


# ---------------------------------------------------------------------------------------------
# Virtual environment


def venv_dir() -> Path:
    env = os.environ.get("TRANSLUCENT_PT_VENV")
    return Path(env) if env else REPO / "target" / "pt-venv"


def ensure_mitsuba() -> None:
    """Re-executes this script inside the venv (created on first use) unless mitsuba imports."""
    try:
        import mitsuba  # noqa: F401

        if mitsuba.__version__ == MITSUBA_VERSION:
            return
    except ImportError:
        pass
    venv = venv_dir()
    python = venv / "bin" / "python"
    if Path(sys.prefix).resolve() == venv.resolve():
        sys.exit(f"error: mitsuba=={MITSUBA_VERSION} is not importable in {venv}")
    if not python.exists():
        print(f"creating {venv} with mitsuba=={MITSUBA_VERSION} (first use)", file=sys.stderr)
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    probe = subprocess.run(
        [str(python), "-c", "import mitsuba, numpy; print(mitsuba.__version__)"],
        capture_output=True,
        text=True,
    )
    if probe.returncode != 0 or probe.stdout.strip() != MITSUBA_VERSION:
        subprocess.run(
            [str(python), "-m", "pip", "install", "-q", f"mitsuba=={MITSUBA_VERSION}", "numpy"],
            check=True,
        )
    os.execv(str(python), [str(python), *sys.argv])


# ---------------------------------------------------------------------------------------------
# Parsing (the syntax of DESIGN section 8)


def numbers(option: str, text: str, n: int) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise SceneError(f"{option} {text!r}: expected {n} comma-separated numbers") from None
    if len(values) != n:
        raise SceneError(f"{option} {text!r}: expected {n} numbers, got {len(values)}")
    if not all(math.isfinite(v) for v in values):
        raise SceneError(f"{option} {text!r}: values must be finite")
    return values


def colour(option: str, text: str) -> list[float]:
    c = numbers(option, text, 3)
    if any(v < 0 for v in c):
        raise SceneError(f"{option} {text!r}: colours must be >= 0")
    return c


def direction(option: str, text: str) -> list[float]:
    d = numbers(option, text, 3)
    length = math.sqrt(sum(v * v for v in d))
    if length == 0:
        raise SceneError(f"{option} {text!r}: direction must be non-zero")
    return [v / length for v in d]


def parse_light(text: str) -> dict:
    option = f"--light {text!r}"
    parts = text.split(":")
    kind = parts[0]
    if kind == "dir" and len(parts) == 3:
        return {
            "type": "directional",
            "direction": direction(option, parts[1]),
            "irradiance": {"type": "rgb", "value": colour(option, parts[2])},
        }
    if kind == "point" and len(parts) == 3:
        return {
            "type": "point",
            "position": numbers(option, parts[1], 3),
            "intensity": {"type": "rgb", "value": colour(option, parts[2])},
        }
    if kind == "spot" and len(parts) == 5:
        inner, outer = numbers(option, parts[4], 2)
        if not (0 <= inner <= outer < 180):
            raise SceneError(f"{option}: need 0 <= INNER_DEG <= OUTER_DEG < 180")
        return {
            "type": "spot",
            "position": numbers(option, parts[1], 3),
            "direction": direction(option, parts[2]),
            "intensity": {"type": "rgb", "value": colour(option, parts[3])},
            "beam_width": inner,
            "cutoff_angle": max(outer, 1e-3),
        }
    raise SceneError(
        f"{option}: expected dir:X,Y,Z:R,G,B, point:X,Y,Z:R,G,B or "
        "spot:X,Y,Z:DX,DY,DZ:R,G,B:INNER_DEG,OUTER_DEG"
    )


def parse_camera(text: str) -> tuple[list[float], list[float], float]:
    parts = text.split(":")
    if len(parts) != 3:
        raise SceneError(f"--camera {text!r}: expected X,Y,Z:TX,TY,TZ:FOVY_DEG")
    eye = numbers("--camera eye", parts[0], 3)
    target = numbers("--camera target", parts[1], 3)
    (fovy,) = numbers("--camera field of view", parts[2], 1)
    if eye == target:
        raise SceneError(f"--camera {text!r}: eye and target coincide")
    if not 0 < fovy < 180:
        raise SceneError(f"--camera {text!r}: field of view must be in (0, 180) degrees")
    return eye, target, fovy


def material(args) -> tuple[list[float], list[float], float]:
    """(sigma_s', sigma_a, eta) of a homogeneous material."""
    if args.sigma_a is not None or args.sigma_s is not None:
        if args.sigma_a is None or args.sigma_s is None:
            raise SceneError("--sigma-a and --sigma-s go together")
        sigma_s = colour("--sigma-s", args.sigma_s)
        sigma_a = colour("--sigma-a", args.sigma_a)
        eta = 1.3
    else:
        name = args.material or "skimmilk"
        if name not in PRESETS:
            raise SceneError(f"--material {name!r}: unknown (known: {', '.join(PRESETS)})")
        sigma_s, sigma_a, eta = (list(v) if isinstance(v, tuple) else v for v in PRESETS[name])
    if any(s + a <= 0 for s, a in zip(sigma_s, sigma_a)):
        raise SceneError("sigma_s' + sigma_a must be > 0 in every channel")
    return sigma_s, sigma_a, args.eta if args.eta is not None else eta


# ---------------------------------------------------------------------------------------------
# .vol grids (DESIGN section 2)


def read_vol6(path: Path):
    """Our 6-channel grid: (bbox min, bbox max, array [z, y, x, 6]) in mm and 1/mm."""
    import numpy as np

    data = path.read_bytes()
    if len(data) < 48 or data[:3] != b"VOL" or data[3] != 3:
        raise SceneError(f"--volume {path}: not a version 3 .vol file")
    encoding, xres, yres, zres, channels = struct.unpack_from("<5i", data, 4)
    bbox = struct.unpack_from("<6f", data, 24)
    if encoding != 1 or channels != 6 or min(xres, yres, zres) < 1:
        raise SceneError(
            f"--volume {path}: need dense f32 with 6 channels, got encoding {encoding}, "
            f"{channels} channels, {xres}x{yres}x{zres}"
        )
    count = xres * yres * zres * 6
    if len(data) != 48 + 4 * count:
        raise SceneError(f"--volume {path}: {len(data)} bytes, expected {48 + 4 * count}")
    grid = np.frombuffer(data, dtype="<f4", offset=48).reshape(zres, yres, xres, 6)
    if not np.all(np.isfinite(grid)) or np.any(grid < 0):
        raise SceneError(f"--volume {path}: values must be finite and >= 0")
    sigma_t = grid[..., 0:3] + grid[..., 3:6]
    if np.any(sigma_t <= 0):
        raise SceneError(f"--volume {path}: a voxel has sigma_s' + sigma_a = 0")
    if not all(math.isfinite(b) for b in bbox) or any(bbox[i] >= bbox[i + 3] for i in range(3)):
        raise SceneError(f"--volume {path}: bad bounding box {bbox}")
    return bbox[:3], bbox[3:], grid


# Cells per axis the grid handed to Mitsuba has at least (axes of one cell stay one cell).
RESAMPLE_MIN_CELLS = 64


def resample_vol6(bbox_min, bbox_max, grid):
    """The grid resampled, with our trilinear rule (cell centres, clamped: DESIGN section 2), onto
    a finer grid over the same box. Mitsuba interpolates the sigma_t and albedo grids it is given,
    ours sigma_s' and sigma_a: between two coarse cells those differ (the milk | skin1 split's blue
    sigma_a at its middle: 0.288 against our 0.247). Between fine cells the difference is second
    order in the cell size, so the medium Mitsuba renders is the one `translucent render` samples.
    """
    import numpy as np

    for axis in range(3):  # grid is [z, y, x, 6]: array axis 2 - axis is x, y, z
        a = 2 - axis
        res = grid.shape[a]
        if res == 1:
            continue
        k = max(1, math.ceil(RESAMPLE_MIN_CELLS / res))
        u = np.clip((np.arange(res * k) + 0.5) / k - 0.5, 0.0, res - 1)
        i0 = np.minimum(np.floor(u).astype(int), res - 1)
        i1 = np.minimum(i0 + 1, res - 1)
        f = (u - i0).reshape([-1 if d == a else 1 for d in range(4)])
        grid = np.take(grid, i0, axis=a) * (1 - f) + np.take(grid, i1, axis=a) * f
    return bbox_min, bbox_max, grid.astype(np.float32)


def write_vol3(path: Path, bbox_min, bbox_max, values) -> None:
    """A 3-channel Mitsuba grid (same layout, channels = 3)."""
    import numpy as np

    zres, yres, xres, _ = values.shape
    header = b"VOL" + bytes([3]) + struct.pack("<5i", 1, xres, yres, zres, 3)
    header += struct.pack("<6f", *bbox_min, *bbox_max)
    path.write_bytes(header + np.ascontiguousarray(values, dtype="<f4").tobytes())


# ---------------------------------------------------------------------------------------------
# Scene


def export_surface(args, work: Path) -> Path:
    """The normalized display surface, written by `translucent bake --export`."""
    binary = Path(args.translucent)
    if not binary.exists():
        raise SceneError(
            f"--translucent {binary}: not found (cargo build --release -p translucent-tools)"
        )
    cmd = [str(binary), "bake", "--size-mm", repr(args.size_mm)]
    cmd += ["--mesh", str(args.mesh)] if args.mesh else ["--shape", args.shape or "torus"]
    # The lattice does not matter here: only surface.obj is used, so bake the cheapest one.
    cmd += ["--resolution", "8", "--levels", "1", "--out", str(work / "object.qgraph")]
    cmd += ["--export", str(work / "export")]
    if args.force:
        cmd.append("--force")
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        raise SceneError(f"{' '.join(cmd)} failed:\n{run.stderr.strip()}")
    return work / "export" / "surface.obj"


def medium(args, work: Path, channel: int | None) -> dict:
    if args.volume:
        import numpy as np

        bmin, bmax, grid = resample_vol6(*read_vol6(Path(args.volume)))
        # One channel at a time, as a grey grid (see render()).
        sigma_s = np.repeat(grid[..., channel : channel + 1], 3, -1)
        sigma_t = sigma_s + np.repeat(grid[..., 3 + channel : 4 + channel], 3, -1)
        albedo = sigma_s / sigma_t
        scale = float(sigma_t.max())
        write_vol3(work / "sigma_t.vol", bmin, bmax, sigma_t / scale)
        write_vol3(work / "albedo.vol", bmin, bmax, np.clip(albedo, 0.0, 1.0))

        def grid_volume(name):
            return {
                "type": "gridvolume",
                "filename": str(work / name),
                "use_grid_bbox": True,
                "filter_type": "trilinear",
            }

        return {
            "type": "heterogeneous",
            "sigma_t": grid_volume("sigma_t.vol"),
            "albedo": grid_volume("albedo.vol"),
            "scale": scale,
            "phase": {"type": "isotropic"},
        }
    sigma_s, sigma_a, _ = material(args)
    sigma_t = [s + a for s, a in zip(sigma_s, sigma_a)]
    scale = max(sigma_t)
    return {
        "type": "homogeneous",
        "sigma_t": {"type": "rgb", "value": [v / scale for v in sigma_t]},
        "albedo": {"type": "rgb", "value": [s / t for s, t in zip(sigma_s, sigma_t)]},
        "scale": scale,
        "phase": {"type": "isotropic"},
    }


def scene_dict(args, work: Path, channel: int | None = None) -> tuple[dict, float]:
    import mitsuba as mi

    if args.volume:
        eta = args.eta if args.eta is not None else 1.3
    else:
        eta = material(args)[2]
    if not 0.3 <= eta <= 3.5:
        raise SceneError(f"--eta {eta}: must be in [0.3, 3.5]")
    lights = [parse_light(t) for t in (args.light or ([] if args.env_constant else DEFAULT_LIGHTS))]
    if lights and eta != 1.0:
        raise SceneError(
            f"eta = {eta} with a directional/point/spot light: Mitsuba cannot connect a delta "
            "light through a specular (dielectric) boundary, the image would be black. Use --eta 1 "
            "(null boundary; render ours with --eta 1 too) or an --env-constant light only."
        )
    eye, target, fovy = parse_camera(args.camera)
    forward = [t - e for t, e in zip(target, eye)]
    # Same rule as Camera::view_proj: +Y up unless looking along Y.
    cross = math.hypot(forward[2], forward[0]) / math.sqrt(sum(v * v for v in forward))
    up = [0, 1, 0] if cross > 1e-6 else [0, 0, 1]
    for option, v in (("--width", args.width), ("--height", args.height)):
        if not 1 <= v <= 16384:
            raise SceneError(f"{option} {v}: must be in 1..=16384")
    if args.spp < 1:
        raise SceneError(f"--spp {args.spp}: must be >= 1")

    surface = export_surface(args, work)
    if eta == 1.0:
        boundary = {"type": "null"}
    else:
        boundary = {"type": "dielectric", "int_ior": eta, "ext_ior": 1.0}
    scene = {
        "type": "scene",
        "integrator": {
            "type": args.integrator,
            "max_depth": args.max_depth,
            # Russian roulette kills long diffusion paths in high-albedo media at a large
            # variance cost; the albedo weights end them instead.
            "rr_depth": args.max_depth,
            "hide_emitters": True,
        },
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": fovy,
            "to_world": mi.ScalarTransform4f().look_at(origin=eye, target=target, up=up),
            "sampler": {"type": "independent", "sample_count": args.spp, "seed": args.seed},
            "film": {
                "type": "hdrfilm",
                "width": args.width,
                "height": args.height,
                "pixel_format": "rgba",
                "component_format": "float32",
                # One pixel's footprint, as the rasterizer covers it.
                "rfilter": {"type": "box"},
            },
        },
        "object": {
            "type": "obj",
            "filename": str(surface),
            "bsdf": boundary,
            "interior": medium(args, work, channel),
        },
    }
    for i, light in enumerate(lights):
        scene[f"light{i}"] = light
    if args.env_constant:
        scene["environment"] = {
            "type": "constant",
            "radiance": {"type": "rgb", "value": colour("--env-constant", args.env_constant)},
        }
    return scene, eta


def equivalent_render(args, eta: float, out: str) -> str:
    cmd = ["target/release/translucent", "render"]
    cmd += ["--mesh", str(args.mesh)] if args.mesh else ["--shape", args.shape or "torus"]
    cmd += ["--size-mm", f"{args.size_mm:g}"]
    if args.volume:
        cmd += ["--volume", str(args.volume)]
    elif args.sigma_a is not None:
        cmd += ["--sigma-a", args.sigma_a, "--sigma-s", args.sigma_s]
    else:
        cmd += ["--material", args.material or "skimmilk"]
    cmd += ["--eta", f"{eta:g}"]
    for light in args.light or ([] if args.env_constant else DEFAULT_LIGHTS):
        cmd += ["--light", light]
    if args.env_constant:
        cmd += ["--env-constant", args.env_constant]
        if not args.light:
            # render adds its default lights when none is given: a black one keeps the scene.
            cmd += ["--light", "dir:0,-1,0:0,0,0"]
    cmd += ["--camera", args.camera, "--width", str(args.width), "--height", str(args.height)]
    cmd += ["--out", out]
    return " ".join(cmd)


def render(args) -> tuple[object, float, float]:
    """(RGBA image, eta, seconds); SceneError for bad input."""
    import mitsuba as mi
    import numpy as np

    mi.set_variant(args.variant)
    start = time.monotonic()
    if not args.volume:
        with tempfile.TemporaryDirectory(prefix="pt-reference-") as tmp:
            scene, eta = scene_dict(args, Path(tmp))
            image = np.array(mi.render(mi.load_dict(scene)), dtype=np.float32)
            return image, eta, time.monotonic() - start
    # Mitsuba's heterogeneous medium bounds all channels by one majorant; the channel whose
    # sigma_t reaches it came out biased dark (-6% to -10%) and noisy in a uniform grid (3.9.1,
    # volpathmis). A grey medium has no such channel: render R, G, B separately and keep each.
    channels = []
    for c in range(3):
        with tempfile.TemporaryDirectory(prefix="pt-reference-") as tmp:
            scene, eta = scene_dict(args, Path(tmp), channel=c)
            channels.append(np.array(mi.render(mi.load_dict(scene)), dtype=np.float32))
    image = np.stack([channels[c][..., c] for c in range(3)] + [channels[0][..., 3]], axis=-1)
    return image, eta, time.monotonic() - start


def self_check(parser) -> int:
    """Checks the scene mapping against exact answers; exits non-zero on a failure.

    A non-absorbing object in a constant environment of radiance L is invisible: every pixel it
    covers has radiance L exactly, whatever its scattering or (with a dielectric) its index. That
    fixes the environment's units, the medium's scale, that light through the boundary is not
    hidden with the emitters, and the black background. Bad input must be refused.
    """
    import numpy as np

    failures = []
    clear = ["--sigma-a", "0,0,0", "--sigma-s", "2,1,0.5"]
    base = ["--shape", "sphere", "--size-mm", "10", "--env-constant", "0.5,1,2"]
    base += ["--camera", "0,0,30:0,0,0:30", "--width", "24"]
    base += ["--height", "24", "--spp", "256", "--out", "unused.exr"]
    for eta in ("1", "1.3"):
        image, _, seconds = render(parser.parse_args(base + clear + ["--eta", eta]))
        inside = image[..., 3] >= 0.999
        mean = image[inside][:, :3].mean(axis=0) / np.array([0.5, 1.0, 2.0])
        background = np.abs(image[image[..., 3] == 0]).max(initial=0.0)
        # With eta = 1 a camera ray may cross the object unscattered and see the hidden
        # background: such pixels are not fully covered (alpha < 1) and are left out.
        ok = inside.sum() > 20 and np.all(np.abs(mean - 1) < 0.02) and background == 0
        print(f"invisible sphere, eta {eta}: mean / L = {mean.round(4)}, background max "
              f"{background}, {inside.sum()} pixels, {seconds:.1f} s: {'ok' if ok else 'FAIL'}")
        ok or failures.append(f"eta {eta}")
    # A uniform .vol grid must render like the homogeneous material it holds: checks the 6 -> 2x3
    # channel split, sigma_t's scale and the albedo (means over the object, up to noise).
    lit = ["--shape", "sphere", "--size-mm", "10", "--light", "dir:0.3,-1,-0.5:2,2,2", "--eta", "1"]
    lit += ["--camera", "0,0,30:0,0,0:30", "--width", "32", "--height", "32", "--spp", "256"]
    lit += ["--out", "unused.exr"]
    sigma_s, sigma_a = [4.0, 2.0, 1.0], [0.05, 0.1, 0.2]
    with tempfile.TemporaryDirectory(prefix="pt-check-") as tmp:
        vol = Path(tmp) / "uniform.vol"
        grid = np.broadcast_to(np.array(sigma_s + sigma_a, dtype=np.float32), (3, 4, 5, 6))
        header = b"VOL" + bytes([3]) + struct.pack("<5i", 1, 5, 4, 3, 6)
        vol.write_bytes(header + struct.pack("<6f", -6, -6, -6, 6, 6, 6) + grid.tobytes())
        coefficients = ["--sigma-s", ",".join(map(str, sigma_s))]
        coefficients += ["--sigma-a", ",".join(map(str, sigma_a))]
        homogeneous, _, _ = render(parser.parse_args(lit + coefficients))
        gridded, _, _ = render(parser.parse_args(lit + ["--volume", str(vol)]))
    inside = (homogeneous[..., 3] >= 0.999) & (gridded[..., 3] >= 0.999)
    ratio = gridded[inside][:, :3].mean(axis=0) / homogeneous[inside][:, :3].mean(axis=0)
    ok = inside.sum() > 100 and np.all(np.abs(ratio - 1) < 0.03)
    print(f"uniform .vol / homogeneous: {ratio.round(4)} over {inside.sum()} pixels: "
          f"{'ok' if ok else 'FAIL'}")
    ok or failures.append("uniform .vol")
    for bad in (
        clear + ["--light", "dir:0,-1,0:1,1,1", "--eta", "1.3"],  # delta light, dielectric
        clear + ["--light", "dir:0,0,0:1,1,1", "--eta", "1"],
        clear + ["--light", "sun:0,-1,0:1,1,1", "--eta", "1"],
        ["--sigma-a=-1,0,0", "--sigma-s", "1,1,1"],
        ["--material", "jelly"],
        ["--material", "marble", "--eta", "9"],
        clear + ["--camera", "0,0,0:0,0,0:30"],
        clear + ["--width", "0"],
        clear + ["--translucent", "/nonexistent/translucent"],
    ):
        args = parser.parse_args(base + bad)
        try:
            render(args)
            failures.append(f"accepted {bad}")
            print(f"bad input {bad}: accepted: FAIL")
        except SceneError as e:
            print(f"bad input {bad}: refused ({str(e).splitlines()[0][:90]}): ok")
    print("self-check " + ("passed" if not failures else f"FAILED: {failures}"))
    return 1 if failures else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    obj = parser.add_mutually_exclusive_group()
    obj.add_argument("--mesh", type=Path, help="OBJ file (normalized like render's)")
    obj.add_argument("--shape", choices=SHAPES, help="procedural shape (default torus)")
    parser.add_argument("--size-mm", type=float, default=50.0)
    parser.add_argument("--force", action="store_true", help="accept open/non-manifold meshes")
    parser.add_argument("--material", help="measured preset (default skimmilk)")
    parser.add_argument("--sigma-a", help="absorption R,G,B (1/mm)")
    parser.add_argument("--sigma-s", help="reduced scattering R,G,B (1/mm)")
    parser.add_argument("--eta", type=float, help="n_inside / n_outside (default preset, 1.3)")
    parser.add_argument("--volume", type=Path, help="6-channel .vol grid (sigma_s', sigma_a)")
    parser.add_argument("--light", action="append", help="dir:/point:/spot: as render; repeatable")
    parser.add_argument("--env-constant", help="constant environment radiance R,G,B")
    parser.add_argument("--camera", help="X,Y,Z:TX,TY,TZ:FOVY_DEG (required)")
    parser.add_argument("--width", type=int, default=128)
    parser.add_argument("--height", type=int, default=128)
    parser.add_argument("--spp", type=int, default=256)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-depth", type=int, default=100000, help="path length cap")
    parser.add_argument("--variant", default="scalar_rgb", help="Mitsuba variant")
    parser.add_argument("--integrator", default="volpathmis", choices=["volpath", "volpathmis"])
    parser.add_argument(
        "--translucent",
        default=str(REPO / "target" / "release" / "translucent"),
        help="the translucent binary (exports the normalized surface)",
    )
    parser.add_argument("--out", type=Path, help="FILE.exr (required)")
    parser.add_argument("--self-check", action="store_true", help="test the mapping and exit")
    args = parser.parse_args()
    if args.self_check:
        ensure_mitsuba()
        return self_check(parser)
    if args.camera is None or args.out is None:
        parser.error("--camera and --out are required (references do not auto-frame)")
    if args.out.suffix.lower() != ".exr":
        parser.error(f"--out {args.out}: must end in .exr")
    if args.volume and (args.material or args.sigma_a or args.sigma_s):
        parser.error("--volume excludes --material/--sigma-a/--sigma-s")
    if not (math.isfinite(args.size_mm) and args.size_mm > 0):
        parser.error(f"--size-mm {args.size_mm}: must be a positive number")

    ensure_mitsuba()
    import mitsuba as mi
    import numpy as np

    try:
        image, eta, seconds = render(args)
    except SceneError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if not np.all(np.isfinite(image)):
        print(f"error: {np.count_nonzero(~np.isfinite(image))} non-finite values", file=sys.stderr)
        return 1
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp_out = args.out.with_name(f".{args.out.name}.tmp.exr")
    mi.Bitmap(image, mi.Bitmap.PixelFormat.RGBA).write(str(tmp_out))
    os.replace(tmp_out, args.out)
    print(
        f"wrote {args.out}: {args.width}x{args.height}, {args.spp} spp, {seconds:.1f} s, "
        f"mitsuba {mi.__version__} {args.variant}, "
        f"{'null boundary (eta = 1)' if eta == 1.0 else f'dielectric boundary (eta = {eta:g})'}"
    )
    print("equivalent: " + equivalent_render(args, eta, "ours.exr"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
