//! The physics rows of the stress matrix: absorption, contrast, size, light and geometry extremes,
//! each against a closed form, the exact discrete solution or a scaling law.

use super::*;

/// Case 1: sigma_a = 0. Uniform light: phi = 4q/(1 - F_dr) at every node for any kappa(x) (the
/// homogeneous path and a 1e4 kappa contrast through the harmonic-mean weights); a directional
/// light: exact energy balance.
pub(super) fn case_no_absorption(rows: &mut Vec<Row>, ctx: &Context) -> Result<()> {
    let graph = sphere(20.0, 12, 2)?;
    let env = 1.0;
    let uniform = Scene {
        lights: vec![],
        environment: Environment::Constant([env; 3]),
    };
    let q = std::f64::consts::PI * env * (1.0 - fresnel::external_diffuse_reflectance(1.3));
    let expected = 4.0 * q / (1.0 - fresnel::diffuse_reflectance(1.3));
    let fields = [
        ("homogeneous", homogeneous([1.0, 0.5, 2.0], [0.0; 3])),
        (
            "split, kappa contrast 1e4",
            split(([0.1; 3], [0.0; 3]), ([1000.0; 3], [0.0; 3])),
        ),
    ];
    let max_rel = |phi: &mut dyn Iterator<Item = f64>| {
        phi.map(|v| (v - expected).abs() / expected)
            .fold(0.0, f64::max)
    };
    for (variant, field) in &fields {
        let variant = format!("{variant}, uniform light");
        let sol = cpu(&graph, field, &uniform);
        rows.push(cpu_row(
            "sigma_a = 0",
            &variant,
            "phi = 4q/(1-F_dr) (max rel.)",
            Some(1e-8),
            &sol,
            |s| max_rel(&mut s.phi.iter().flatten().copied()),
        ));
        gpu_rows(
            rows,
            ctx,
            "sigma_a = 0",
            &variant,
            &graph,
            field,
            &uniform,
            "phi = 4q/(1-F_dr) (max rel.)",
            |p| {
                Some(if p == Precision::Fp16 {
                    FP16_STALL
                } else {
                    2e-3
                })
            },
            |o| max_rel(&mut o.phi.iter().flatten().map(|&v| f64::from(v))),
        );
        let lit = Scene {
            lights: vec![dir_light(1.0)],
            environment: Environment::None,
        };
        let sol = cpu(&graph, field, &lit);
        rows.push(cpu_row(
            "sigma_a = 0",
            format!(
                "{}, directional light",
                variant.trim_end_matches(", uniform light")
            )
            .as_str(),
            "energy: |in - out| / in",
            Some(1e-8),
            &sol,
            energy_imbalance,
        ));
    }
    Ok(())
}

/// Case 2: sigma_a >> sigma_s'. Against the exact discrete solution; J+ < 0 where lit is clamped
/// (never negative radiance).
pub(super) fn case_strong_absorption(rows: &mut Vec<Row>, ctx: &Context) -> Result<()> {
    let graph = sphere(20.0, 12, 2)?;
    let scene = Scene {
        lights: vec![dir_light(1.0)],
        environment: Environment::Constant([0.1; 3]),
    };
    for ratio in [100.0, 1e4] {
        let field = homogeneous([1.0; 3], [ratio; 3]);
        let variant = format!("sigma_a = {ratio:e} sigma_s'");
        let sol = cpu(&graph, &field, &scene)?;
        let mut row = cpu_row(
            "sigma_a >> sigma_s'",
            &variant,
            "energy: |in - out| / in",
            Some(1e-8),
            &Ok(sol.clone()),
            energy_imbalance,
        );
        let negative = sol
            .j_plus_clamped
            .iter()
            .flatten()
            .filter(|&&v| v < 0.0)
            .count();
        if negative > 0 {
            row.note = format!("{negative} negative displayed J+");
            row.tolerance = Some(-1.0);
        }
        rows.push(row);
        let want = sol.phi.clone();
        let j_want = sol.j_plus_clamped.clone();
        let q_max = sol.q.iter().flatten().fold(0.0f64, |m, &v| m.max(v));
        gpu_rows(
            rows,
            ctx,
            "sigma_a >> sigma_s'",
            &variant,
            &graph,
            &field,
            &scene,
            "exact discrete phi (rel. RMS); J+ >= 0",
            |p| {
                Some(if p == Precision::Fp16 {
                    FP16_STALL
                } else {
                    5e-3
                })
            },
            |o| {
                // Negative displayed J+ would be a failure whatever phi is.
                if o.j_plus.iter().flatten().any(|&v| v < 0.0) {
                    return f64::INFINITY;
                }
                let j_err = o
                    .j_plus
                    .iter()
                    .zip(&j_want)
                    .flat_map(|(g, w)| (0..3).map(move |c| (f64::from(g[c]) - w[c]).abs()))
                    .fold(0.0, f64::max)
                    / q_max;
                rel_rms(&o.phi, &want).max(j_err)
            },
        );
    }
    Ok(())
}

/// Case 3: a 1e4 contrast between neighbouring materials (kappa and mu), GPU against the exact
/// discrete solution of the same harmonic-mean system.
pub(super) fn case_contrast(rows: &mut Vec<Row>, ctx: &Context) -> Result<()> {
    let graph = sphere(20.0, 12, 2)?;
    let scene = Scene {
        lights: vec![dir_light(1.0)],
        environment: Environment::Constant([0.1; 3]),
    };
    let field = split(([0.1; 3], [1e-3; 3]), ([1000.0; 3], [10.0; 3]));
    let sol = cpu(&graph, &field, &scene)?;
    rows.push(cpu_row(
        "contrast 1e4",
        "split: sigma_s' 0.1 / 1000, sigma_a 1e-3 / 10",
        "energy: |in - out| / in",
        Some(1e-8),
        &Ok(sol.clone()),
        energy_imbalance,
    ));
    let want = sol.phi.clone();
    gpu_rows(
        rows,
        ctx,
        "contrast 1e4",
        "split: sigma_s' 0.1 / 1000, sigma_a 1e-3 / 10",
        &graph,
        &field,
        &scene,
        "exact discrete phi (rel. RMS)",
        |p| {
            Some(if p == Precision::Fp16 {
                FP16_STALL
            } else {
                5e-3
            })
        },
        |o| rel_rms(&o.phi, &want),
    );
    Ok(())
}

/// Case 4: object size. Marble under a constant environment: the CPU's albedo (exitance / input)
/// against the closed-form sphere (a resolution floor where the diffusion length is below the
/// lattice spacing), the GPU against the exact discrete solution.
pub(super) fn case_size(rows: &mut Vec<Row>, ctx: &Context, sizes: &[f64]) -> Result<()> {
    // Marble (sigma_t' about 2.2 to 2.6 /mm) and a thin medium (sigma_t' = 0.101 /mm): a 1 mm
    // object is 2.2 and 0.1 mean free paths across, a 10 m one 2.2e4 and 1e3.
    let thin = Material::new([0.1; 3], [1e-3; 3], 1.3)?;
    for (name, material) in [
        ("marble", Material::preset("marble")?),
        ("thin medium", thin),
    ] {
        case_size_material(rows, ctx, sizes, name, material)?;
    }
    Ok(())
}

pub(super) fn case_size_material(
    rows: &mut Vec<Row>,
    ctx: &Context,
    sizes: &[f64],
    name: &str,
    marble: Material,
) -> Result<()> {
    let field = MaterialField::Homogeneous(marble);
    let scene = Scene {
        lights: vec![],
        environment: Environment::Constant([1.0; 3]),
    };
    for &size in sizes {
        let mfp = size
            * marble
                .sigma_t()
                .iter()
                .fold(f64::INFINITY, |m, &v| m.min(v));
        let variant = format!("{name} sphere, diameter {size:e} mm ({mfp:.1e} mfp)");
        let graph = match sphere(size, 12, 2) {
            Ok(g) => g,
            Err(e) => {
                let mut row = Row::new("object size", &variant, "bake");
                row.typed_error = Some(e.to_string());
                row.error_expected = !translucent::mesh::SIZE_RANGE_MM.contains(&size);
                rows.push(row);
                continue;
            }
        };
        let spacing = graph.finest().spacing;
        let sol = cpu(&graph, &field, &scene);
        let mut row = cpu_row(
            "object size",
            &variant,
            "closed-form sphere albedo (max over RGB, rel.)",
            None,
            &sol,
            |s| {
                (0..3)
                    .map(|c| {
                        let exact = Homogeneous::channel(&marble, c).sphere_albedo(0.5 * size);
                        let got = s.energy.exitance[c] / s.energy.transmitted_input[c];
                        (got - exact).abs() / exact
                    })
                    .fold(0.0, f64::max)
            },
        );
        // The closed form is a fair bound only where the lattice resolves the diffusion length
        // 1/s (marble's smallest, blue: ~4 mm).
        let diffusion = (0..3)
            .map(|c| 1.0 / Homogeneous::channel(&marble, c).s)
            .fold(f64::INFINITY, f64::min);
        row.note = format!(
            "{}; spacing {spacing:.2e} mm, min diffusion length {diffusion:.1} mm",
            row.note
        );
        if spacing < diffusion {
            row.tolerance = Some(0.03);
        }
        rows.push(row);
        if sol.is_err() {
            continue;
        }
        // Lit by a directional light as well: the shadow maps and the gather at this scale.
        let lit = Scene {
            lights: vec![dir_light(1.0)],
            environment: Environment::Constant([0.1; 3]),
        };
        let sol = cpu(&graph, &field, &lit);
        let Ok(sol) = sol else {
            rows.push(cpu_row("object size", &variant, "", None, &sol, |_| 0.0));
            continue;
        };
        let want = sol.phi.clone();
        gpu_rows(
            rows,
            ctx,
            "object size",
            &format!("{variant}, directional light"),
            &graph,
            &field,
            &lit,
            "exact discrete phi (rel. RMS)",
            |p| {
                Some(if p == Precision::Fp16 {
                    FP16_STALL
                } else {
                    5e-3
                })
            },
            |o| rel_rms(&o.phi, &want),
        );
    }
    Ok(())
}

/// Case 5: light from `lights` (irradiance of one directional light): J+ / E (the solve and its
/// exposure) and pixels / E (the RGBA16F render target) against the same at E = 1 (linearity), at
/// every precision; the CPU likewise.
pub(super) fn case_light(rows: &mut Vec<Row>, ctx: &Context, lights: &[f64]) -> Result<()> {
    let graph = sphere(20.0, 12, 2)?;
    let field = MaterialField::Homogeneous(Material::preset("marble")?);
    let scene = |e: f64| Scene {
        lights: vec![dir_light(e)],
        environment: Environment::None,
    };
    let cpu_unit = cpu(&graph, &field, &scene(1.0))?;
    for &e in lights {
        let variant = format!("E = {e:e}");
        let sol = cpu(&graph, &field, &scene(e));
        rows.push(cpu_row(
            "light level",
            &variant,
            "J+ / E vs E = 1 (rel. RMS)",
            Some(1e-9),
            &sol,
            |s| {
                let scaled: Vec<[f64; 3]> = s.j_plus.iter().map(|v| v.map(|x| x / e)).collect();
                rel_rms(&scaled, &cpu_unit.j_plus)
            },
        ));
    }
    for precision in PRECISIONS {
        let unit = gpu(ctx, &graph, &field, &scene(1.0), precision)?;
        let unit_j: Vec<[f64; 3]> = unit.j_plus.iter().map(|v| v.map(f64::from)).collect();
        let unit_px: Vec<[f64; 3]> = unit
            .pixels
            .iter()
            .map(|p| [p[0], p[1], p[2]].map(f64::from))
            .collect();
        for &e in lights {
            let mut row = Row::new(
                "light level",
                format!("E = {e:e}"),
                precision_name(precision),
            );
            row.reference = "J+ / E vs E = 1 (rel. RMS)";
            let mut render = Row::new(
                "light level",
                format!("E = {e:e}"),
                format!("{} render", precision_name(precision)),
            );
            render.reference = "pixels / E vs E = 1 (rel. RMS; RGBA16F target)";
            match gpu(ctx, &graph, &field, &scene(e), precision) {
                Ok(out) => {
                    let s = out.scan();
                    let j: Vec<[f64; 3]> = out
                        .j_plus
                        .iter()
                        .map(|v| v.map(|x| f64::from(x) / e))
                        .collect();
                    let px: Vec<[f64; 3]> = out
                        .pixels
                        .iter()
                        .map(|p| [p[0], p[1], p[2]].map(|x| f64::from(x) / e))
                        .collect();
                    row.error = Some(rel_rms(&j, &unit_j));
                    // The solve stops at a 1e-5 error estimate, perhaps a block apart at another
                    // exposure: 1e-4.
                    row.tolerance = Some(1e-4);
                    row.note = format!(
                        "q_scale {:.3e}, iterations {:?}",
                        out.q_scale, out.iterations
                    );
                    let mut j_scan = Scan::default();
                    j_scan.add(
                        out.phi
                            .iter()
                            .chain(&out.j_plus)
                            .flatten()
                            .map(|&v| f64::from(v)),
                    );
                    row.max_abs = j_scan.max_abs;
                    row.nonfinite = j_scan.nonfinite;
                    render.error = Some(rel_rms(&px, &unit_px));
                    // fp16 pixels: half an ulp is 2.4e-4 relative, more in subnormals.
                    render.tolerance = Some(5e-3);
                    render.max_abs = out
                        .pixels
                        .iter()
                        .flat_map(|p| &p[..3])
                        .fold(0.0f64, |m, &v| m.max(f64::from(v).abs()));
                    render.nonfinite = s.nonfinite;
                }
                Err(err) => row.typed_error = Some(err.to_string()),
            }
            eprintln!("light {e:e} {}: {}", row.path, row.result_text());
            rows.push(row);
            rows.push(render);
        }
    }
    Ok(())
}

/// The near-degenerate OBJ fixtures: (name, vertices, faces).
type Fixture = (&'static str, Vec<DVec3>, Vec<[u32; 3]>);

fn geometry_fixtures() -> Vec<Fixture> {
    let mut out: Vec<Fixture> = Vec::new();
    let (v, f) = box_mesh(DVec3::new(25.0, 0.5, 25.0));
    out.push(("thin box 50 x 1 x 50", v, f));
    let (v, f) = box_mesh(DVec3::new(25.0, 0.005, 25.0));
    out.push(("sheet-thin box 50 x 0.01 x 50", v, f));
    let (v, f) = box_mesh(DVec3::new(0.25, 25.0, 0.25));
    out.push(("needle 0.5 x 50 x 0.5", v, f));
    // A box with a near-duplicate of corner 7 (1e-9 away) used by two of its faces.
    let (mut v, mut f) = box_mesh(DVec3::splat(10.0));
    v.push(v[7] + DVec3::splat(1e-9));
    f[3] = [4, 8, 6];
    out.push(("box, near-duplicate vertex (1e-9)", v, f));
    // A box with a zero-area face (three collinear points on an edge) added.
    let (mut v, mut f) = box_mesh(DVec3::splat(10.0));
    v.push(0.5 * (v[0] + v[1]));
    f.push([0, 8, 1]);
    out.push(("box + zero-area face", v, f));
    // A box whose face 0-2-3 is split at a point 1e-7 off its edge: a sliver pair.
    let (mut v, mut f) = box_mesh(DVec3::splat(10.0));
    v.push(0.5 * (v[0] + v[3]) + DVec3::new(0.0, 0.0, -1e-7));
    f[0] = [0, 2, 8];
    f.push([8, 2, 3]);
    out.push(("box, sliver triangles (1e-7)", v, f));
    out
}

/// Case 6: near-degenerate geometry from OBJ files, through the CLI's loading path: validate,
/// normalize to 50 mm, bake, then the CPU and GPU solves: finite output or a typed error.
pub(super) fn case_geometry(rows: &mut Vec<Row>, ctx: &Context, dir: &Path) -> Result<()> {
    let field = MaterialField::Homogeneous(Material::preset("skimmilk")?);
    let scene = Scene {
        lights: vec![dir_light(1.0)],
        environment: Environment::Constant([0.1; 3]),
    };
    for (name, v, f) in geometry_fixtures() {
        let (v, f): (Vec<DVec3>, Vec<[u32; 3]>) = (v, f);
        let path = dir.join(format!(
            "{}.obj",
            name.replace([' ', ',', '(', ')', '.'], "_")
        ));
        write_obj(&path, &v, &f)?;
        let baked = (|| -> Result<Arc<QuadGraph>> {
            let mut mesh = TriMesh::load_obj(&path)?;
            mesh.validate(&ValidateOptions::default())?;
            let (mut mesh, _) = mesh.normalized(50.0)?;
            mesh.compute_normals();
            let solid = MeshSolid::new(mesh)?;
            let params = BakeParams {
                resolution: 16,
                levels: 2,
                ..Default::default()
            };
            Ok(Arc::new(
                QuadGraph::bake(solid.mesh(), &solid, &params, &mut |_| {})?.0,
            ))
        })();
        let graph = match baked {
            Ok(g) => g,
            Err(e) => {
                let mut row = Row::new("degenerate geometry", name, "load + bake");
                row.typed_error = Some(e.to_string());
                row.error_expected = true;
                eprintln!("{name}: {e}");
                rows.push(row);
                continue;
            }
        };
        let sol = cpu(&graph, &field, &scene);
        rows.push(cpu_row(
            "degenerate geometry",
            name,
            "energy: |in - out| / in",
            Some(1e-8),
            &sol,
            energy_imbalance,
        ));
        let Ok(sol) = sol else { continue };
        let want = sol.phi.clone();
        gpu_rows(
            rows,
            ctx,
            "degenerate geometry",
            name,
            &graph,
            &field,
            &scene,
            "exact discrete phi (rel. RMS)",
            |p| {
                Some(if p == Precision::Fp16 {
                    FP16_STALL
                } else {
                    5e-3
                })
            },
            |o| rel_rms(&o.phi, &want),
        );
    }
    Ok(())
}
