//! Live edits on the GPU (solver::gpu::edit): the homogeneous specialization, `set_material`
//! (homogeneous <-> heterogeneous) and `deform` (affine, twist, uploaded positions, identity),
//! against the f64 CPU reference on the same iteration schedule and against a solve built fresh.
//! Validation (with synchronization validation) is on and any message fails.
//!
//! Tolerances: 0.5% relative RMS of J+ against the CPU on the same schedule (as gpu_diffusion.rs:
//! fp32 weights, fp16 q and corrections are far below it; after a deformation the weights are
//! also computed in fp32 from fp32 positions). Edits that must reproduce a computation exactly
//! (set_material vs a fresh solve, Identity vs the baked pose) are compared bit for bit.

use glam::{DVec3, Mat4, Vec3};
use translucent::material::{Material, MaterialField, Procedural};
use translucent::mesh::shapes::Shape;
use translucent::mesh::GpuMesh;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Scene};
use translucent::solver::gpu::{Deformation, GpuDiffusion, GpuSolveParams, Precision};
use translucent::solver::{self, rel_rms, CpuSolveParams, Scheme};
use translucent::vk::{Access, Context, ImageReadback};
use translucent::{QuadGraph, TranslucentObject};
use translucent_tests::tol;
use translucent_tests::{quadgraph_object, render_once, solve_once, GpuTest};

const ITERATIONS: u32 = 48;

fn bake(resolution: u32, levels: u32) -> QuadGraph {
    let shape = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution,
        levels,
        ..Default::default()
    };
    QuadGraph::bake(&shape.triangulate(24), &shape, &params, &mut |_| {})
        .expect("bake")
        .0
}

fn scene() -> Scene {
    Scene {
        lights: vec!["dir:-0.3,-1,0.2:1,1,1".parse().unwrap()],
        environment: Environment::Constant([0.05; 3]),
    }
}

fn params(scheme: Scheme) -> GpuSolveParams {
    GpuSolveParams {
        scheme,
        iterations: vec![ITERATIONS],
        tolerance: 0.0,
        ..Default::default()
    }
}

fn homogeneous(preset: &str) -> MaterialField {
    MaterialField::Homogeneous(Material::preset(preset).unwrap())
}

fn split() -> MaterialField {
    split_along(DVec3::new(1.0, 0.3, 0.0).normalize(), 0.0)
}

fn split_along(normal: DVec3, offset: f64) -> MaterialField {
    MaterialField::procedural(
        Procedural::Split {
            normal,
            offset,
            below: Material::preset("marble").unwrap().coefficients(),
            above: Material::preset("skin1").unwrap().coefficients(),
        },
        1.3,
    )
    .unwrap()
}

/// Uploads the CPU q of `graph` (its levels as given: rest or deformed), solves, reads J+.
fn solve(ctx: &Context, gpu: &mut GpuDiffusion, graph: &QuadGraph, eta: f64) -> Vec<[f32; 3]> {
    let q: Vec<Vec<[f32; 3]>> = graph
        .levels
        .iter()
        .map(|l| {
            scene()
                .surface_irradiance(l, eta, None)
                .iter()
                .map(|q| q.map(|v| v as f32))
                .collect()
        })
        .collect();
    gpu.set_q_scale(GpuDiffusion::exposure_for(q.iter().flatten()));
    for (h, q) in q.iter().enumerate() {
        gpu.upload_q(ctx, h, q).expect("upload q");
    }
    solve_once(ctx, gpu, false);
    let j = gpu.read_j_plus(ctx).expect("read J+");
    assert!(j.iter().flatten().all(|v| v.is_finite()), "NaN/Inf in J+");
    j
}

fn cpu(graph: &QuadGraph, field: &MaterialField, scheme: Scheme) -> Vec<[f64; 3]> {
    let params = CpuSolveParams {
        scheme,
        iterations: vec![ITERATIONS as usize],
        tolerance: 0.0,
        exact: false,
        ..Default::default()
    };
    solver::solve(graph, field, &scene(), None, &params)
        .expect("cpu solve")
        .j_plus_clamped
}

/// The CPU reference of a deformation: every level deformed as the GPU does it.
fn deformed(graph: &QuadGraph, d: &Deformation) -> QuadGraph {
    let mut out = graph.clone();
    for (h, l) in out.levels.iter_mut().enumerate() {
        *l = d.deformed_level(h, &graph.levels[h]);
    }
    out
}

#[test]
fn homogeneous_variant_reads_no_per_channel_weights_and_allocates_none() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake(10, 2);
    let marble = homogeneous("marble");
    // The homogeneous pipelines have the per-channel weight bindings filled with a NaN texture:
    // any read would make J+ NaN (solve() asserts finite) and break the CPU match.
    let mut solver = GpuDiffusion::new(ctx, &graph, &marble, &params(Scheme::Fv)).unwrap();
    let j = solve(ctx, &mut solver, &graph, 1.3);
    let err = rel_rms(&j, &cpu(&graph, &marble, Scheme::Fv));
    assert!(err <= tol::GPU_VS_EXACT, "homogeneous vs CPU: {err}");
    let (homogeneous_bytes, per_node_h) = solver.bytes();
    let hetero = GpuDiffusion::new(ctx, &graph, &split(), &params(Scheme::Fv)).unwrap();
    let (hetero_bytes, per_node) = hetero.bytes();
    // frac, kappa and mu: 3 RGBA32F = 48 bytes per texel more (the default derives the weights
    // in the sweep; stored weights add 48 more: gpu_memory.rs).
    let texels: u64 = (0..graph.levels.len())
        .map(|h| {
            let p = &graph.levels[h].packing;
            u64::from(p.width) * u64::from(p.height)
        })
        .sum();
    assert_eq!(hetero_bytes - homogeneous_bytes, 48 * texels);
    println!("bytes per node: homogeneous {per_node_h:.1}, heterogeneous {per_node:.1}");
    drop((solver, hetero));
    gpu.finish();
}

#[test]
fn set_material_matches_the_cpu_and_a_fresh_solve_both_ways() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake(10, 2);
    for scheme in [Scheme::Fv, Scheme::Paper] {
        let p = params(scheme);
        let mut edited = GpuDiffusion::new(ctx, &graph, &homogeneous("marble"), &p).unwrap();
        solve(ctx, &mut edited, &graph, 1.3);
        // homogeneous -> heterogeneous -> another homogeneous (other eta) -> heterogeneous.
        let mut jade = Material::preset("skimmilk").unwrap();
        jade.eta = 1.5;
        let steps = [split(), MaterialField::Homogeneous(jade), split()];
        for (i, field) in steps.iter().enumerate() {
            edited
                .set_material(ctx, &graph, field)
                .expect("set_material");
            let j = solve(ctx, &mut edited, &graph, field.eta());
            let reference = cpu(&graph, field, scheme);
            let err = rel_rms(&j, &reference);
            println!("{scheme:?} step {i}: rel RMS vs CPU {err:.2e}");
            assert!(err <= tol::GPU_VS_EXACT, "{scheme:?} step {i}: {err}");
            let mut fresh = GpuDiffusion::new(ctx, &graph, field, &p).unwrap();
            let jf = solve(ctx, &mut fresh, &graph, field.eta());
            assert_eq!(j, jf, "{scheme:?} step {i}: edited != fresh");
        }
        // A bad material is a typed error and leaves the last one in place.
        let bad = MaterialField::procedural(
            Procedural::Split {
                normal: DVec3::X,
                offset: 0.0,
                below: Material::preset("marble").unwrap().coefficients(),
                above: translucent::material::Coefficients {
                    sigma_s: [f64::NAN; 3],
                    sigma_a: [0.0; 3],
                },
            },
            1.3,
        );
        if let Ok(bad) = bad {
            assert!(edited.set_material(ctx, &graph, &bad).is_err());
        }
        assert!(!edited.edits_pending());
    }
    gpu.finish();
}

#[test]
fn identity_restores_the_baked_result_exactly() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake(10, 2);
    for field in [homogeneous("marble"), split()] {
        let mut s = GpuDiffusion::new(ctx, &graph, &field, &params(Scheme::Fv)).unwrap();
        let baked = solve(ctx, &mut s, &graph, 1.3);
        s.deform(
            ctx,
            &graph,
            &Deformation::Twist {
                radians_per_mm: 0.03,
            },
            &[],
        )
        .unwrap();
        let twisted = solve(ctx, &mut s, &graph, 1.3);
        assert_ne!(baked, twisted, "the twist changed nothing");
        s.deform(ctx, &graph, &Deformation::Identity, &[]).unwrap();
        let restored = solve(ctx, &mut s, &graph, 1.3);
        assert_eq!(baked, restored);
    }
    gpu.finish();
}

#[test]
fn scale_twist_and_uploaded_positions_match_the_cpu_on_the_deformed_level() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake(10, 2);
    let scale = Mat4::from_scale(Vec3::splat(1.5));
    let stretch = Mat4::from_cols_array(&[
        1.2, 0.1, 0.0, 0.0, //
        0.0, 0.8, 0.0, 0.0, //
        0.2, 0.0, 1.0, 0.0, //
        1.0, -2.0, 0.5, 1.0,
    ]);
    let twist = Deformation::Twist {
        radians_per_mm: 0.04,
    };
    // Uploaded positions: a bend (not affine) given per vertex.
    let bend = Deformation::TetPositions(
        graph
            .levels
            .iter()
            .map(|l| {
                l.tets
                    .vertices
                    .iter()
                    .map(|v| {
                        let y = v.y + 0.01 * v.x * v.x;
                        [v.x as f32, y as f32, v.z as f32]
                    })
                    .collect()
            })
            .collect(),
    );
    // The material moves with the object (sampled at rest positions), the CPU reference samples
    // the deformed level: they agree for the heterogeneous field only where the deformation keeps
    // every node on its side of the split plane y = 0.37 (maps that keep y: a scale in x and z,
    // the twist about Y).
    let cases = [
        ("uniform scale", Deformation::Affine(scale), false),
        (
            "xz scale",
            Deformation::Affine(Mat4::from_scale(Vec3::new(1.5, 1.0, 0.7))),
            true,
        ),
        ("affine stretch", Deformation::Affine(stretch), false),
        ("twist", twist.clone(), true),
        ("bend (uploaded positions)", bend.clone(), false),
    ];
    for field in [homogeneous("marble"), split_along(DVec3::Y, 0.37)] {
        let mut s = GpuDiffusion::new(ctx, &graph, &field, &params(Scheme::Fv)).unwrap();
        let hetero = !matches!(field, MaterialField::Homogeneous(_));
        for (name, d, keeps_split) in &cases {
            if hetero && !keeps_split {
                continue;
            }
            let d = d.clone();
            s.deform(ctx, &graph, &d, &[]).unwrap();
            let reference_graph = deformed(&graph, &d);
            let j = solve(ctx, &mut s, &reference_graph, 1.3);
            let err = rel_rms(&j, &cpu(&reference_graph, &field, Scheme::Fv));
            println!(
                "{name} (heterogeneous {hetero}): rel RMS vs CPU on the deformed level {err:.2e}"
            );
            assert!(err <= tol::GPU_VS_EXACT, "{name}: {err}");
            // The gather's inputs follow: surface positions and normals of every level.
            for (h, level) in reference_graph.levels.iter().enumerate() {
                let pos = ImageReadback::capture(
                    ctx,
                    s.surface_position(h).unwrap(),
                    Access::ComputeReadWrite,
                )
                .unwrap();
                let nrm = ImageReadback::capture(
                    ctx,
                    s.surface_normal(h).unwrap(),
                    Access::ComputeReadWrite,
                )
                .unwrap();
                let inner = level.inner_count();
                let p = &graph.levels[h].packing;
                for sidx in 0..level.surface_count() {
                    let [u, v] = p.texels[inner + sidx];
                    let g = pos.pixel(u, v);
                    let c = level.positions[inner + sidx];
                    let e = (DVec3::new(g[0].into(), g[1].into(), g[2].into()) - c).length();
                    assert!(e <= 1e-4 * (1.0 + c.length()), "level {h} node {sidx}: {e}");
                    let n = nrm.pixel(u, v);
                    let dot = DVec3::new(n[0].into(), n[1].into(), n[2].into())
                        .dot(level.surface_normals[sidx]);
                    assert!(dot > 0.998, "level {h} normal {sidx}: cos {dot}");
                }
            }
        }
    }
    gpu.finish();
}

#[test]
fn flattening_is_a_typed_error_and_near_flat_stays_finite() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake(8, 2);
    let mut s = GpuDiffusion::new(ctx, &graph, &split(), &params(Scheme::Fv)).unwrap();
    solve(ctx, &mut s, &graph, 1.3); // records the construction's staged material
    let flat = Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0));
    let mirror = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    for d in [
        Deformation::Affine(flat),
        Deformation::Affine(mirror),
        Deformation::Affine(Mat4::from_scale(Vec3::splat(f32::NAN))),
        Deformation::Twist {
            radians_per_mm: f32::INFINITY,
        },
        Deformation::TetPositions(vec![vec![[0.0; 3]; 3]]),
        Deformation::TetPositions(
            graph
                .levels
                .iter()
                .map(|l| {
                    l.tets
                        .vertices
                        .iter()
                        .map(|v| [v.x as f32, 0.0, v.z as f32])
                        .collect()
                })
                .collect(),
        ),
    ] {
        let err = s
            .deform(ctx, &graph, &d, &[])
            .expect_err("accepted a degenerate deformation");
        println!("{err}");
        assert!(err.to_string().contains("deformation"), "{err}");
        assert!(!s.edits_pending(), "a refused deformation staged work");
    }
    // 1000:1 squash: legal, every weight finite, J+ finite (solve() asserts it).
    let squash = Deformation::Affine(Mat4::from_scale(Vec3::new(1.0, 1e-3, 1.0)));
    s.deform(ctx, &graph, &squash, &[]).unwrap();
    let j = solve(ctx, &mut s, &deformed(&graph, &squash), 1.3);
    assert!(j.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    drop(s);
    gpu.finish();
}

#[test]
fn frame_deform_moves_the_meshes_and_refits_the_shadows() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake(8, 1);
    let field = homogeneous("marble");
    let p = GpuSolveParams {
        precision: Precision::Mixed,
        ..params(Scheme::Fv)
    };
    let mut object = quadgraph_object(ctx, &graph, &field, &scene(), p);
    let m = Mat4::from_scale_rotation_translation(
        Vec3::new(2.0, 1.0, 1.0),
        glam::Quat::from_rotation_z(0.3),
        Vec3::new(5.0, 0.0, 0.0),
    );
    let record = |object: &mut TranslucentObject| {
        let (captured, report) = render_once(ctx, object, 16, 16);
        assert!(
            captured
                .image
                .pixels
                .iter()
                .flatten()
                .all(|v| v.is_finite()),
            "{report:?}"
        );
    };
    record(&mut object);
    let (c0, r0) = object.shadow_bounds();
    object.deform(ctx, &Deformation::Affine(m)).unwrap();
    // The shadow views follow the deformed bounds: x doubled (rotated a little), moved by +5.
    let (c1, r1) = object.shadow_bounds();
    assert!((c1.x - c0.x - 5.0).abs() < 0.5, "{c0} -> {c1}");
    assert!(r1 > 1.6 * r0 && r1 < 2.2 * r0, "{r0} -> {r1}");
    record(&mut object);
    let read = |mesh: &GpuMesh| -> Vec<translucent::mesh::Vertex> {
        let b = mesh.vertex_buffer().read_bytes().unwrap();
        let f: Vec<f32> = b
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        f.chunks_exact(9)
            .map(|v| translucent::mesh::Vertex {
                position: [v[0], v[1], v[2]],
                normal: [v[3], v[4], v[5]],
                exitance: [v[6], v[7], v[8]],
            })
            .collect()
    };
    let normal_map = m.inverse().transpose();
    // The display mesh, which is also the shadow caster.
    let mesh = object.mesh().clone();
    {
        let v = read(&mesh);
        for (i, (x, r)) in v.iter().zip(&graph.surface.positions).enumerate() {
            let want = m.transform_point3(r.as_vec3());
            let e = (Vec3::from(x.position) - want).length();
            assert!(e < 1e-3, "vertex {i}: {e}");
            let nw = normal_map
                .transform_vector3(graph.surface.normals[i].as_vec3())
                .normalize();
            assert!(Vec3::from(x.normal).dot(nw) > 0.999, "normal {i}");
        }
    }
    // J+ still lands in the displayed mesh, finite.
    assert!(read(&mesh)
        .iter()
        .all(|v| v.exitance.iter().all(|e| e.is_finite())));
    object.deform(ctx, &Deformation::Identity).unwrap();
    record(&mut object);
    for (x, r) in read(&mesh).iter().zip(&graph.surface.positions) {
        assert_eq!(
            x.position,
            r.as_vec3().to_array(),
            "identity restores the rest mesh"
        );
    }
    let report = object
        .quadgraph()
        .expect("quadgraph")
        .report(ctx, &field, &scene(), None)
        .unwrap();
    assert!(report.energy.exitance.iter().all(|e| e.is_finite()));
    drop((object, mesh));
    gpu.finish();
}

#[test]
fn the_homogeneous_specialization_solves_like_the_per_node_path() {
    // The same material through both variants: HOMOGENEOUS = true (push constants, no per-node
    // reads) and the per-node path (a split with marble on both sides). The skip must not change
    // the answer beyond fp32 rounding of the weights.
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake(10, 2);
    let marble = Material::preset("marble").unwrap();
    let per_node = MaterialField::procedural(
        Procedural::Split {
            normal: DVec3::Y,
            offset: 0.0,
            below: marble.coefficients(),
            above: marble.coefficients(),
        },
        marble.eta,
    )
    .unwrap();
    let mut s = GpuDiffusion::new(
        ctx,
        &graph,
        &MaterialField::Homogeneous(marble),
        &params(Scheme::Fv),
    )
    .unwrap();
    let skipped = solve(ctx, &mut s, &graph, 1.3);
    s.set_material(ctx, &graph, &per_node).unwrap();
    let full = solve(ctx, &mut s, &graph, 1.3);
    let reference: Vec<[f64; 3]> = full.iter().map(|v| v.map(f64::from)).collect();
    let err = rel_rms(&skipped, &reference);
    println!("homogeneous specialization vs per-node path: rel RMS {err:.2e}");
    assert!(err <= 1e-4, "{err}");
    drop(s);
    gpu.finish();
}

/// `frame::quadgraph::solve_headless` runs the edits `GpuDiffusion::new` and `set_material`
/// stage (a heterogeneous material's derived weights, a new material) before its solve, as an
/// object's frame does: a heterogeneous material solved through it matches the test's own
/// submission (edits, solve, exitance) bit for bit and the CPU on the same schedule.
#[test]
fn solve_headless_runs_the_staged_edits_of_a_heterogeneous_material() {
    use translucent::frame::quadgraph::solve_headless;
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake(10, 2);
    let field = split();
    let upload = |solve: &mut GpuDiffusion| {
        for (h, l) in graph.levels.iter().enumerate() {
            let q: Vec<[f32; 3]> = scene()
                .surface_irradiance(l, field.eta(), None)
                .iter()
                .map(|q| q.map(|v| v as f32))
                .collect();
            if h == 0 {
                solve.set_q_scale(GpuDiffusion::exposure_for(q.iter()));
            }
            solve.upload_q(ctx, h, &q).expect("upload q");
        }
    };
    let p = params(Scheme::Fv);
    let mut headless = GpuDiffusion::new(ctx, &graph, &field, &p).unwrap();
    assert!(
        headless.edits_pending(),
        "a heterogeneous solve stages its weights"
    );
    upload(&mut headless);
    solve_headless(ctx, &mut headless, false).expect("solve_headless");
    assert!(!headless.edits_pending());
    let j = headless.read_j_plus(ctx).expect("J+");
    let mut reference = GpuDiffusion::new(ctx, &graph, &field, &p).unwrap();
    upload(&mut reference);
    solve_once(ctx, &mut reference, false);
    assert_eq!(j, reference.read_j_plus(ctx).expect("J+"));
    let err = rel_rms(&j, &cpu(&graph, &field, Scheme::Fv));
    assert!(err <= tol::GPU_VS_EXACT, "{err}");
    // A material set later is staged and run by the next headless solve as well.
    headless
        .set_material(ctx, &graph, &homogeneous("skimmilk"))
        .expect("set_material");
    solve_headless(ctx, &mut headless, false).expect("solve_headless");
    assert!(!headless.edits_pending());
    drop((headless, reference));
    gpu.finish();
}
