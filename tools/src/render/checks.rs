//! `render`'s checks of option combinations, made before anything is baked or solved: each names
//! the options it refuses and why.

use anyhow::bail;

use super::RenderArgs;
use translucent::material::DiffusionCoefficient;
use translucent::solver;
use translucent::solver::multigrid::MultigridParams;

use super::output::check_writable;

/// `--out`'s format and place, and the options that only apply to one of the formats.
pub(super) fn output(args: &RenderArgs) -> anyhow::Result<()> {
    match args
        .out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png" | "exr") => {}
        _ => bail!("--out {}: must end in .png or .exr", args.out.display()),
    }
    check_writable(&args.out)?;
    if args.backdrop
        && !args
            .out
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        bail!(
            "--backdrop: PNG output only (an EXR is linear radiance on a black background, for comparisons)"
        );
    }
    Ok(())
}

/// Options of one method named with another (`--method auto` is resolved before); the diffusion
/// coefficient the method uses (named, or render's default for the QuadGraph).
pub(super) fn method_options(args: &RenderArgs) -> anyhow::Result<DiffusionCoefficient> {
    if args.method != "voxel"
        && (args.voxels.is_some() || args.voxel_model.is_some() || args.voxel_soft.is_some())
    {
        bail!(
            "--voxels, --voxel-model and --voxel-soft apply to --method voxel (not {})",
            args.method
        );
    }
    if args.texture_only && args.method != "dipole" {
        bail!("--texture-only applies to --method dipole");
    }
    if let Some(bounce) = args.bounce.as_deref().filter(|&b| b != "off") {
        if args.method != "quadgraph" || args.solver != "gpu" {
            bail!(
                "--bounce {bounce}: the GPU quadgraph method only (not --method {} --solver {})",
                args.method,
                args.solver
            );
        }
    }
    let diffusion = args.diffusion()?;
    if diffusion != DiffusionCoefficient::Classical && args.method != "quadgraph" {
        bail!(
            "--diffusion-coefficient {} applies to --method quadgraph (the voxel and dipole methods keep 1 / (3 sigma_t'))",
            diffusion.name()
        );
    }
    Ok(diffusion)
}

/// Options of the GPU solver or of a source named with the CPU reference or another source.
pub(super) fn solver_options(args: &RenderArgs, on_gpu: bool) -> anyhow::Result<()> {
    if args.explicit_beam() && args.exit_query.as_deref() == Some("flux") {
        bail!("a beam source (--source beam|second, --beam-source) is read by the moments exit query (DESIGN 2.6-2.7): drop --exit-query flux");
    }
    if args.shadow_edge_flux && args.light_source() == solver::transport::Source::BoundaryFlux {
        bail!("--shadow-edge-flux applies to a beam source (--source beam|second)");
    }
    if args.continuation.is_some() && args.light_source() == solver::transport::Source::BoundaryFlux
    {
        bail!("--continuation applies to a beam source (--source beam|second)");
    }
    if args.upstream_beam.is_some()
        && args.light_source() == solver::transport::Source::BoundaryFlux
    {
        bail!("--upstream-beam applies to a beam source (--source beam|second)");
    }
    if args.precision.is_some() && !on_gpu {
        bail!("--precision applies to the GPU solver; the CPU reference is f64");
    }
    if !(args.tolerance.is_finite() && args.tolerance >= 0.0) {
        bail!(
            "--tolerance {}: must be a finite non-negative number",
            args.tolerance
        );
    }
    for (name, v) in [
        ("--orbit-light", args.orbit_light),
        ("--orbit-camera", args.orbit_camera),
    ] {
        if let Some(v) = v {
            if !on_gpu {
                bail!("{name} applies to the GPU solver (--solver gpu)");
            }
            if !v.is_finite() {
                bail!("{name} {v}: must be a finite number of degrees");
            }
        }
    }
    if args.no_skip && !on_gpu {
        bail!("--no-skip applies to the GPU solver (--solver gpu)");
    }
    Ok(())
}

/// `base` with the coarse-level options of `args` (`--coarse-operator`, `--coarse-storage`,
/// `--link-storage`, `--vector-storage`, `--finest-operator`, `--update-storage`, `--coarse-drop`), checked.
pub(super) fn coarse_params(
    args: &RenderArgs,
    base: MultigridParams,
) -> anyhow::Result<MultigridParams> {
    let params = MultigridParams {
        coarse: match &args.coarse_operator {
            Some(name) => name.parse()?,
            None => base.coarse,
        },
        coarse_storage: match &args.coarse_storage {
            Some(name) => name.parse()?,
            None => base.coarse_storage,
        },
        link_storage: match &args.link_storage {
            Some(name) => name.parse()?,
            None => base.link_storage,
        },
        vector_storage: match &args.vector_storage {
            Some(name) => name.parse()?,
            None => base.vector_storage,
        },
        finest_operator: match &args.finest_operator {
            Some(name) => name.parse()?,
            None => base.finest_operator,
        },
        update_storage: match &args.update_storage {
            Some(name) => name.parse()?,
            None => base.update_storage,
        },
        sparsify: args.coarse_drop.filter(|&t| t > 0.0).or(base.sparsify),
        ..base
    };
    params.validate()?;
    Ok(params)
}
