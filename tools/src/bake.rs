//! `translucent bake`: bakes (or loads from the cache) the QuadGraph of a mesh or procedural shape
//! and reports node counts, texture memory, angles, locality and timings; a thin layer over
//! `translucent::quadgraph` (DESIGN section 8).
//!
//! ```text
//! translucent bake --mesh ../shared/meshes/spot.obj --json
//! translucent bake --shape torus --levels 2 --resolution 32 --export out/
//! ```

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use translucent::quadgraph::cache::{self, CacheOutcome};
use translucent::quadgraph::{export, BakeStats};
use translucent::QuadGraph;

use crate::object_args::{Object, ObjectArgs};

#[derive(clap::Args)]
pub struct BakeArgs {
    #[command(flatten)]
    pub object: ObjectArgs,
    /// Bake even if the cache file matches.
    #[arg(long)]
    pub rebuild: bool,
    /// Cache file (default: NAME.qgraph in the current directory).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Write tets-L.vtk, nodes-L.csv per level and surface.obj into DIR.
    #[arg(long, value_name = "DIR")]
    pub export: Option<PathBuf>,
}

pub fn run(args: &BakeArgs) -> anyhow::Result<()> {
    let object = args.object.load(None)?;
    // A bake has no material or image of its own: `auto` uses render's default material.
    let field = translucent::material::MaterialField::Homogeneous(
        translucent::material::Material::preset(crate::render::DEFAULT_MATERIAL)?,
    );
    let resolution = args.object.resolution(&object, &field, None);
    let params = args.object.bake_params_for(&resolution, &field);
    let Object {
        name,
        surface,
        solid,
        validation,
        ..
    } = &object;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{name}.qgraph")));
    if args.rebuild {
        let _ = std::fs::remove_file(&out);
    }

    let bar = progress_bar(args.json);
    let mut on_progress = |p: translucent::quadgraph::BakeProgress| {
        bar.set_message(format!(
            "{} (level {} of {})",
            p.stage,
            p.level + 1,
            p.levels
        ));
    };
    let start = Instant::now();
    let (graph, stats, outcome) =
        cache::bake_cached(&out, surface, solid.as_ref(), &params, &mut on_progress)
            .map_err(|e| object.explain_bake_error(e))?;
    let elapsed = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if let CacheOutcome::Rebuilt(reason) = &outcome {
        eprintln!("warning: {reason}; baked again");
    }
    // A cache hit is timed again on its own: the total above includes computing the stats.
    let load_s = match outcome {
        CacheOutcome::Loaded => {
            let t = Instant::now();
            QuadGraph::load(&out, None)?;
            Some(t.elapsed().as_secs_f64())
        }
        _ => None,
    };
    let exported = match &args.export {
        Some(dir) => export::export(&graph, dir)?,
        None => Vec::new(),
    };
    if args.json {
        let value = serde_json::json!({
            "name": name,
            "cache": out,
            "cache_outcome": match &outcome { CacheOutcome::Loaded => "loaded".to_string(), CacheOutcome::Baked => "baked".to_string(), CacheOutcome::Rebuilt(e) => format!("rebuilt: {e}") },
            "validation": validation,
            "up": object.up.describe(),
            "resolution": resolution.json(stats.levels.last().map(|l| l.surface_nodes + l.inner_nodes)),
            "params": { "resolution": params.resolution, "K": params.k, "levels": params.levels, "relax": params.relax, "block": params.block },
            "surface_vertices": surface.positions.len(),
            "surface_triangles": surface.indices.len(),
            "seconds": elapsed,
            "load_seconds": load_s,
            "stats": stats,
            "exported": exported,
        });
        use std::io::Write as _;
        let _ = writeln!(
            std::io::stdout().lock(),
            "{}",
            serde_json::to_string_pretty(&value)?
        );
    } else {
        eprintln!("up: {}", object.up.describe());
        eprintln!(
            "{}",
            resolution.line(
                stats
                    .levels
                    .last()
                    .map_or(0, |l| l.surface_nodes + l.inner_nodes)
            )
        );
        print_report(
            name,
            &out,
            &outcome,
            &stats,
            elapsed,
            load_s,
            validation.as_deref(),
            &exported,
        );
    }
    Ok(())
}

fn progress_bar(json: bool) -> indicatif::ProgressBar {
    if json || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new_spinner();
    bar.enable_steady_tick(Duration::from_millis(100));
    bar
}

#[allow(clippy::too_many_arguments)]
fn print_report(
    name: &str,
    out: &Path,
    outcome: &CacheOutcome,
    stats: &BakeStats,
    seconds: f64,
    load_s: Option<f64>,
    validation: Option<&str>,
    exported: &[PathBuf],
) {
    // Written at once, ignoring a closed pipe (`translucent bake ... | head`).
    let mut out_text = String::new();
    macro_rules! outln {
        ($s:expr, $($arg:tt)*) => {{
            use std::fmt::Write as _;
            let _ = writeln!($s, $($arg)*);
        }};
    }
    if let Some(v) = validation {
        outln!(out_text, "{name}: {v}");
    }
    let how = match outcome {
        CacheOutcome::Loaded => "loaded from cache",
        _ => "baked",
    };
    outln!(
        out_text,
        "{name}: {how} {} in {seconds:.2} s",
        out.display()
    );
    if let Some(l) = load_s {
        outln!(out_text, "  cache load alone: {l:.3} s");
    }
    outln!(
        out_text,
        "  level  spacing_mm  surface   inner   texture      MB  locality (random)  dihedral"
    );
    for (l, s) in stats.levels.iter().enumerate() {
        outln!(
            out_text,
            "  {l:>5}  {:>10.3}  {:>7}  {:>7}  {:>5}x{:<5} {:>6.2}  {:>8.3} ({:.3})  [{:.1}, {:.1}]",
            s.spacing_mm,
            s.surface_nodes,
            s.inner_nodes,
            s.texture_width,
            s.texture_height,
            s.bytes as f64 / 1e6,
            s.locality,
            s.random_locality,
            s.min_dihedral_deg,
            s.max_dihedral_deg
        );
    }
    outln!(
        out_text,
        "  texture memory {:.2} MB, {:.1} bytes per node (the paper: about 90)",
        stats.total_bytes as f64 / 1e6,
        stats.bytes_per_node
    );
    for (stage, t) in &stats.timings_s {
        outln!(out_text, "  {stage:<22} {t:>8.3} s");
    }
    for f in exported {
        outln!(out_text, "  wrote {}", f.display());
    }
    use std::io::Write as _;
    let _ = std::io::stdout().lock().write_all(out_text.as_bytes());
}
