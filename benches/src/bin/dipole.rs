//! Measurements of the dipole method (Mertens et al. 2003) for `benches/RESULTS.md`, section
//! "Dipole method". Each subcommand prints a markdown table:
//!
//! ```text
//! cargo run --release -p translucent-benches --bin dipole -- links      # links per triangle, build times (Table 3)
//! cargo run --release -p translucent-benches --bin dipole -- sweep [paper] [uniform] E1S E2S TOLS  # error against the brute-force sum per link parameters
//! cargo run --release -p translucent-benches --bin dipole -- modes      # render / on-the-fly / relink after a deformation (full, incremental) against T
//! cargo run --release -p translucent-benches --bin dipole -- diagnose   # per-link form factors against their leaves' (spot)
//! ```
//! Options (after the subcommand): `--eps1 F --eps2 F --receiver-tolerance F --tolerance F
//! --ratio F` (link parameters),
//! `--max-triangles N` (skip larger meshes), `--material NAME`, `--size-mm F`. Meshes come from
//! `$TRANSLUCENT_MESH_DIR` (default `../shared/meshes`); run from the repository root.

use std::path::{Path, PathBuf};
use std::time::Instant;

use translucent::material::Material;
use translucent::mesh::shapes::Shape;
use translucent::mesh::TriMesh;
use translucent::solver::dipole::form_factor::FormFactorParams;
use translucent::solver::dipole::{
    links, links::ReceiverCriterion, BoundaryModel, DipoleProfile, FaceClusterHierarchy,
    LinkParams, LinkSet, NearField,
};
use translucent_benches::dipole::{load_normalized, subdivide_midpoint};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

struct Options {
    params: LinkParams,
    max_triangles: usize,
    material: String,
    size_mm: f64,
    rest: Vec<String>,
}

fn options(args: &[String]) -> Result<Options> {
    let mut o = Options {
        params: LinkParams::default(),
        max_triangles: usize::MAX,
        material: "marble".into(),
        size_mm: 25.0,
        rest: Vec::new(),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || -> Result<String> {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{a} needs a value").into())
        };
        match a.as_str() {
            "--eps1" => {
                o.params.receiver = ReceiverCriterion::SolidAngle {
                    epsilon: value()?.parse()?,
                }
            }
            "--receiver-tolerance" => {
                o.params.receiver = ReceiverCriterion::Transport {
                    tolerance: value()?.parse()?,
                }
            }
            "--eps2" => o.params.emitter_epsilon = value()?.parse()?,
            "--tolerance" => o.params.sample_tolerance = value()?.parse()?,
            "--planarity" => o.params.min_planarity = value()?.parse()?,
            "--ratio" => {
                if let NearField::SemiAnalytic(f) = &mut o.params.near_field {
                    f.max_length_over_r0 = value()?.parse()?;
                }
            }
            "--max-triangles" => o.max_triangles = value()?.parse()?,
            "--material" => o.material = value()?,
            "--size-mm" => o.size_mm = value()?.parse()?,
            other => o.rest.push(other.to_string()),
        }
    }
    o.params.validate()?;
    Ok(o)
}

fn mesh_dir() -> PathBuf {
    std::env::var_os("TRANSLUCENT_MESH_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("../shared/meshes"))
}

/// The meshes of the link-count table: a torus subdivided like the paper's model (2k, 8k, 31k,
/// 124k), spot subdivided (6k, 23k, 94k), and the shared scans as they are.
fn meshes(size_mm: f64, max_triangles: usize) -> Result<Vec<(String, TriMesh)>> {
    let mut out = Vec::new();
    let torus = Shape::Torus {
        major: 10.0,
        minor: 4.0,
    }
    .triangulate(22);
    let mut m = torus.normalized(size_mm)?.0;
    for _ in 0..4 {
        out.push((format!("torus {}", m.indices.len()), m.clone()));
        m = subdivide_midpoint(&m);
    }
    let dir = mesh_dir();
    if let Ok(spot) = load_normalized(&dir.join("spot.obj"), size_mm) {
        let mut m = spot;
        for k in 0..3 {
            out.push((
                format!(
                    "spot{}",
                    if k == 0 {
                        String::new()
                    } else {
                        format!(" /{k}")
                    }
                ),
                m.clone(),
            ));
            m = subdivide_midpoint(&m);
        }
    } else {
        eprintln!("spot.obj not found in {}: skipped", dir.display());
    }
    for name in [
        "homer",
        "fandisk",
        "cheburashka",
        "rocker-arm",
        "stanford-bunny",
        "nefertiti",
    ] {
        match load_normalized(&dir.join(format!("{name}.obj")), size_mm) {
            Ok(m) => out.push((name.to_string(), m)),
            Err(e) => eprintln!("{name}: {e}: skipped"),
        }
    }
    out.retain(|(_, m)| m.indices.len() <= max_triangles);
    Ok(out)
}

fn links_table(o: &Options) -> Result<()> {
    let profile = DipoleProfile::new(&Material::preset(&o.material)?, BoundaryModel::Moments);
    println!(
        "material {} at {} mm, receiver {:?} eps2 {} sample tolerance {} planarity {}",
        o.material,
        o.size_mm,
        o.params.receiver,
        o.params.emitter_epsilon,
        o.params.sample_tolerance,
        o.params.min_planarity
    );
    println!("| mesh | T | L | L/T | near links | segments | depth | hierarchy s | links s | render s (CPU) | on-the-fly s (CPU) | link MB |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, mesh) in meshes(o.size_mm, o.max_triangles)? {
        let (tree, hs) = FaceClusterHierarchy::build(&mesh)?;
        let (set, ls) = LinkSet::build(&tree, &profile, &o.params);
        let irradiance = vec![[1.0; 3]; tree.leaf_count()];
        let start = Instant::now();
        let _ = links::render(&tree, &profile, &set, &irradiance, None);
        let render_s = start.elapsed().as_secs_f64();
        let (_, fly) = links::on_the_fly(&tree, &profile, &o.params, &irradiance, None);
        let t = tree.leaf_count() as f64;
        println!(
            "| {name} | {} | {:.0}K | {:.1} | {:.1}% | {} | {} | {:.2} | {:.2} | {:.3} | {:.2} | {:.0} |",
            tree.leaf_count(),
            ls.links as f64 / 1e3,
            ls.links as f64 / t,
            100.0 * ls.near_links as f64 / ls.links as f64,
            ls.form_factor.segments,
            hs.depth,
            hs.seconds,
            ls.seconds,
            render_s,
            fly.seconds,
            set.bytes() as f64 / 1e6
        );
    }
    Ok(())
}

/// Leaf exitance at `receivers` by brute force: every triangle's semi-analytic form factor (second
/// order, default subdivision: 2e-4 per triangle) times its irradiance. O(receivers x T).
fn reference_exitance(
    tree: &FaceClusterHierarchy,
    profile: &DipoleProfile,
    irradiance: &[[f64; 3]],
    receivers: &[usize],
) -> Vec<[f64; 3]> {
    use rayon::prelude::*;
    use translucent::solver::dipole::form_factor::{triangle_form_factor, FormFactorStats};
    let params = FormFactorParams::default();
    receivers
        .par_iter()
        .map(|&r| {
            let x = tree.geometry[r].centroid;
            let mut m = [0.0; 3];
            let mut stats = FormFactorStats::default();
            for (f, e) in irradiance.iter().enumerate().take(tree.leaf_count()) {
                let ff = triangle_form_factor(profile, x, tree.triangle(f), &params, &mut stats);
                (0..3).for_each(|k| m[k] += ff[k] * e[k]);
            }
            m
        })
        .collect()
}

/// Relative RMS over receivers and channels.
fn rms_error(ours: &[[f64; 3]], reference: &[[f64; 3]]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (a, b) in ours.iter().zip(reference) {
        for k in 0..3 {
            num += (a[k] - b[k]).powi(2);
            den += b[k] * b[k];
        }
    }
    (num / den).sqrt()
}

/// Exitance error and cost against the link parameters on one mesh (spot, or a torus without it).
fn sweep(o: &Options) -> Result<()> {
    use translucent::scene::Scene;
    use translucent::solver::dipole::irradiance::leaf_irradiance;
    let mesh = match load_normalized(&mesh_dir().join("spot.obj"), o.size_mm) {
        Ok(m) => m,
        Err(_) => {
            Shape::Torus {
                major: 10.0,
                minor: 4.0,
            }
            .triangulate(38)
            .normalized(o.size_mm)?
            .0
        }
    };
    let material = Material::preset(&o.material)?;
    let profile = DipoleProfile::new(&material, BoundaryModel::Moments);
    let (tree, _) = FaceClusterHierarchy::build(&mesh)?;
    let scene = Scene {
        lights: vec!["dir:-0.4,-1,-0.5:1,1,1".parse()?],
        ..Default::default()
    };
    let solid = translucent::mesh::MeshSolid::new(mesh.clone())?;
    let uniform = o.rest.iter().any(|a| a == "uniform");
    let irradiance = if uniform {
        vec![[1.0; 3]; tree.leaf_count()]
    } else {
        leaf_irradiance(&tree, &scene, material.eta, Some(&solid))?
    };
    let t = tree.leaf_count();
    let receivers: Vec<usize> = (0..t).step_by((t / 400).max(1)).collect();
    let start = Instant::now();
    let reference = reference_exitance(&tree, &profile, &irradiance, &receivers);
    eprintln!(
        "reference: {} receivers in {:.1} s",
        receivers.len(),
        start.elapsed().as_secs_f64()
    );
    println!(
        "{} triangles, {} at {} mm, {}; error: relative RMS of leaf exitance at {} triangles",
        t,
        o.material,
        o.size_mm,
        if uniform {
            "uniform irradiance"
        } else {
            "directional light with shadows"
        },
        receivers.len()
    );
    println!(
        "| receiver | eps2 | sample tolerance | L/T | near links | segments/T | link s | error |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let eps = |v: &[String], i: usize, d: &str| -> Vec<f64> {
        v.get(i)
            .map_or(d, |s| s.as_str())
            .split(',')
            .filter_map(|x| x.parse().ok())
            .collect()
    };
    let rest = &o.rest;
    let rest: Vec<String> = rest.iter().filter(|a| *a != "uniform").cloned().collect();
    let paper = rest.first().is_some_and(|m| m == "paper");
    let rest = &rest[1.min(rest.len())..];
    for e1 in eps(rest, 0, "0.02,0.05,0.1") {
        for e2 in eps(rest, 1, "0.05,0.1,0.3") {
            for tol in eps(rest, 2, "0.25,0.5,1,2") {
                let receiver = if paper {
                    ReceiverCriterion::SolidAngle { epsilon: e1 }
                } else {
                    ReceiverCriterion::Transport { tolerance: e1 }
                };
                let params = LinkParams {
                    receiver,
                    emitter_epsilon: e2,
                    sample_tolerance: tol,
                    ..o.params
                };
                let (set, ls) = LinkSet::build(&tree, &profile, &params);
                let m = links::render(&tree, &profile, &set, &irradiance, None);
                let ours: Vec<[f64; 3]> = receivers.iter().map(|&r| m.leaf[r]).collect();
                println!(
                    "| {receiver:?} | {e2} | {tol} | {:.1} | {:.1}% | {:.1} | {:.2} | {:.2e} |",
                    ls.links as f64 / t as f64,
                    100.0 * ls.near_links as f64 / ls.links as f64,
                    ls.form_factor.segments as f64 / t as f64,
                    ls.seconds,
                    rms_error(&ours, &reference)
                );
            }
        }
    }
    Ok(())
}

/// Per-link form factors against the sum of their leaves' exact form factors (a diagnostic).
fn diagnose(o: &Options) -> Result<()> {
    use translucent::solver::dipole::form_factor::{triangle_form_factor, FormFactorStats};
    let mesh = load_normalized(&mesh_dir().join("spot.obj"), o.size_mm)?;
    let profile = DipoleProfile::new(&Material::preset(&o.material)?, BoundaryModel::Moments);
    let (tree, _) = FaceClusterHierarchy::build(&mesh)?;
    let (set, _) = LinkSet::build(&tree, &profile, &o.params);
    let t = tree.leaf_count();
    let mut leaves: Vec<Vec<u32>> = vec![Vec::new(); tree.nodes.len()];
    for n in 0..tree.nodes.len() {
        if n < t {
            leaves[n].push(n as u32);
        } else {
            let [a, b] = tree.nodes[n].children;
            let mut v = leaves[a as usize].clone();
            v.extend(&leaves[b as usize]);
            leaves[n] = v;
        }
    }
    let params = FormFactorParams::default();
    let mut worst: Vec<(f64, String)> = Vec::new();
    let mut total_err = [0.0f64; 2];
    let mut by_kind = [0.0f64; 4];
    for x in (0..t).step_by(211) {
        let cx = tree.geometry[x].centroid;
        let mut sum_exact = 0.0;
        let mut sum_ours = 0.0;
        for r in tree.ancestors(x as u32) {
            for l in set.of(r) {
                let mut st = FormFactorStats::default();
                let exact: f64 = leaves[l.source as usize]
                    .iter()
                    .map(|&f| {
                        triangle_form_factor(
                            &profile,
                            cx,
                            tree.triangle(f as usize),
                            &params,
                            &mut st,
                        )[2]
                    })
                    .sum();
                let ours = l.form_factor[2] as f64;
                sum_exact += exact;
                sum_ours += ours;
                let kind = (r as usize >= t) as usize * 2 + (l.source as usize >= t) as usize;
                by_kind[kind] += ours - exact;
                let g = &tree.geometry[l.source as usize];
                let gr = &tree.geometry[r as usize];
                worst.push(((ours - exact).abs(), format!("x {x} R {r} (radius {:.2}) E {} (radius {:.2}, planarity {:.3}) dist {:.2}: ours {ours:.4e} exact {exact:.4e}", gr.radius, l.source, g.radius, g.planarity, (gr.centroid - g.centroid).length())));
            }
        }
        total_err[0] += (sum_ours - sum_exact).powi(2);
        total_err[1] += sum_exact.powi(2);
    }
    worst.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (_, w) in worst.iter().take(20) {
        println!("{w}");
    }
    println!("signed error by (receiver cluster, emitter cluster): leaf-leaf {:.2e} leaf-cluster {:.2e} cluster-leaf {:.2e} cluster-cluster {:.2e}", by_kind[0], by_kind[1], by_kind[2], by_kind[3]);
    println!("rms {:.3e}", (total_err[0] / total_err[1]).sqrt());
    Ok(())
}

/// The modes of section 5.5 against triangle count (the torus of the links table, 2k-124k): render
/// mode (gather along stored links), on-the-fly (oracle + gather every frame, nothing stored), and
/// after a deformation (a twist of the whole object) the refit plus either a full relink or
/// incremental relinking drained to the end (and the form factors that took). CPU, rayon.
fn modes(o: &Options) -> Result<()> {
    use translucent::solver::dipole::IncrementalLinks;
    let profile = DipoleProfile::new(&Material::preset(&o.material)?, BoundaryModel::Moments);
    let budget: u64 = 100_000;
    println!(
        "material {} at {} mm, receiver {:?} eps2 {} sample tolerance {}; deformation: twist of 0.02 rad/mm",
        o.material, o.size_mm, o.params.receiver, o.params.emitter_epsilon, o.params.sample_tolerance
    );
    println!("| mesh | T | L/T | link s | render s | on-the-fly s | refit s | full relink s | incremental s (steps of {budget} form factors) | incremental form factors | links after (incr. / full) |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, mesh) in meshes(o.size_mm, o.max_triangles)?
        .into_iter()
        .filter(|(n, _)| n.starts_with("torus"))
    {
        let (mut tree, _) = FaceClusterHierarchy::build(&mesh)?;
        let (set, ls) = LinkSet::build(&tree, &profile, &o.params);
        let irradiance = vec![[1.0; 3]; tree.leaf_count()];
        let start = Instant::now();
        let _ = links::render(&tree, &profile, &set, &irradiance, None);
        let render_s = start.elapsed().as_secs_f64();
        let (_, fly) = links::on_the_fly(&tree, &profile, &o.params, &irradiance, None);
        let mut incremental = IncrementalLinks::new(&tree, &profile, &o.params);
        drop(set);
        let twisted: Vec<_> = mesh
            .positions
            .iter()
            .map(|p| {
                let (s, c) = (0.02 * p.y).sin_cos();
                glam::DVec3::new(c * p.x + s * p.z, p.y, -s * p.x + c * p.z)
            })
            .collect();
        let start = Instant::now();
        let report = tree.refit(&twisted)?;
        let refit_s = start.elapsed().as_secs_f64();
        let (full, fs) = LinkSet::build(&tree, &profile, &o.params);
        let start = Instant::now();
        incremental.geometry_changed(&report);
        let mut form_factors = 0;
        while incremental.pending() > 0 {
            form_factors += incremental.step(&tree, budget).form_factors;
        }
        let incremental_s = start.elapsed().as_secs_f64();
        let t = tree.leaf_count();
        println!(
            "| {name} | {t} | {:.1} | {:.2} | {:.3} | {:.2} | {:.3} | {:.2} | {:.2} | {form_factors} | {:.1} / {:.1} |",
            ls.links as f64 / t as f64,
            ls.seconds,
            render_s,
            fly.seconds,
            refit_s,
            fs.seconds,
            incremental_s,
            incremental.len() as f64 / t as f64,
            full.len() as f64 / t as f64,
        );
    }
    Ok(())
}

#[allow(dead_code)]
fn unused() -> Result<()> {
    let total_err = [0.0f64; 2];
    println!(
        "net signed error {:.3e} of {:.3e}",
        total_err[0], total_err[1]
    );
    Ok(())
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(command) = args.first() else {
        return Err(
            "usage: dipole links|accuracy|boundary|modes|images [options] (see the module doc)"
                .into(),
        );
    };
    let o = options(&args[1..])?;
    match command.as_str() {
        "links" => links_table(&o),
        "sweep" => sweep(&o),
        "diagnose" => diagnose(&o),
        "modes" => modes(&o),
        other => Err(format!("unknown subcommand {other}").into()),
    }
}

#[allow(dead_code)]
fn exists(p: &Path) -> bool {
    p.exists()
}

#[allow(dead_code)]
fn default_ff() -> FormFactorParams {
    FormFactorParams::default()
}
