//! Numerical stress on the CPU side (issue 6, DESIGN section 9): sliver-prone and near-degenerate
//! geometry written as OBJ files into a temp dir and taken through the command line's loading path
//! (load, validate, normalize, bake, f64 solve): each either works with finite output and an exact
//! energy balance, or fails with a typed error naming the problem; object sizes outside
//! `mesh::SIZE_RANGE_MM` and non-finite inputs anywhere are typed errors. The GPU side is
//! `stress_gpu.rs`; the full matrix `cargo run --release -p translucent-benches --bin stress`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::DVec3;
use translucent::material::{Material, MaterialField, VolGrid};
use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshError, MeshSolid, TriMesh, ValidateOptions, SIZE_RANGE_MM};
use translucent::quadgraph::{BakeError, BakeParams};
use translucent::scene::{self, Environment, Scene};
use translucent::solver::{self, CpuSolveParams};
use translucent::QuadGraph;
use translucent_benches::fixtures::{box_mesh, write_obj};

fn scratch(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("translucent-stress-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The CLI's path: load, validate (default options), normalize to `size`, bake.
fn load_and_bake(
    path: &Path,
    size: f64,
    resolution: u32,
    levels: u32,
) -> Result<QuadGraph, String> {
    let mut mesh = TriMesh::load_obj(path).map_err(|e| e.to_string())?;
    mesh.validate(&ValidateOptions::default())
        .map_err(|e| e.to_string())?;
    let (mut mesh, _) = mesh.normalized(size).map_err(|e| e.to_string())?;
    mesh.compute_normals();
    let solid = MeshSolid::new(mesh).map_err(|e| e.to_string())?;
    let params = BakeParams {
        resolution,
        levels,
        ..Default::default()
    };
    QuadGraph::bake(solid.mesh(), &solid, &params, &mut |_| {})
        .map(|(g, _)| g)
        .map_err(|e| e.to_string())
}

/// Solves and checks: finite everywhere, J+ >= 0 displayed, energy balanced to 1e-8.
fn solve_finite(graph: &QuadGraph, name: &str) {
    let field = MaterialField::Homogeneous(Material::preset("skimmilk").unwrap());
    let scene = Scene {
        lights: vec!["dir:-0.3,-1,0.2:1,1,1".parse().unwrap()],
        environment: Environment::Constant([0.1; 3]),
    };
    let sol = solver::solve(graph, &field, &scene, None, &CpuSolveParams::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    assert!(
        sol.phi
            .iter()
            .chain(&sol.j_plus)
            .flatten()
            .chain(
                sol.vertex_j_plus
                    .iter()
                    .flatten()
                    .map(|&v| v as f64)
                    .collect::<Vec<_>>()
                    .iter()
            )
            .all(|v| v.is_finite()),
        "{name}: NaN/Inf"
    );
    assert!(sol.j_plus_clamped.iter().flatten().all(|&v| v >= 0.0));
    let e = sol.energy;
    for c in 0..3 {
        let imbalance = (e.transmitted_input[c] - e.exitance[c] - e.absorbed[c]).abs();
        assert!(
            imbalance <= 1e-8 * e.transmitted_input[c],
            "{name}: energy {e:?}"
        );
    }
}

#[test]
fn thin_and_near_degenerate_meshes_bake_and_solve_or_are_typed_errors() {
    let dir = scratch("geometry");
    // Thinner than the lattice: the bake says so (and what to do), at a coarse resolution...
    for (name, half) in [
        ("thin box", DVec3::new(25.0, 0.5, 25.0)),
        ("sheet", DVec3::new(25.0, 0.005, 25.0)),
        ("needle", DVec3::new(0.25, 25.0, 0.25)),
    ] {
        let path = dir.join(format!("{name}.obj"));
        let (v, f) = box_mesh(half);
        write_obj(&path, &v, &f).expect("write OBJ");
        let e = load_and_bake(&path, 50.0, 16, 2).expect_err(name);
        assert!(
            e.contains("no tetrahedra") && e.contains("--resolution"),
            "{name}: {e}"
        );
    }
    // ...and works once the lattice resolves it (a 1 mm plate at 64 cells across 50 mm).
    let path = dir.join("plate.obj");
    let (v, f) = box_mesh(DVec3::new(25.0, 0.5, 25.0));
    write_obj(&path, &v, &f).expect("write OBJ");
    let graph = load_and_bake(&path, 50.0, 64, 1).expect("a resolved plate bakes");
    solve_finite(&graph, "plate");

    // A near-duplicate vertex (1e-9 mm), a zero-area face and a sliver pair (1e-7 mm off an edge):
    // validation drops the degenerate faces, and the rest is a solid box.
    let (v, f) = box_mesh(DVec3::splat(10.0));
    let mut near_duplicate = (v.clone(), f.clone());
    near_duplicate.0.push(v[7] + DVec3::splat(1e-9));
    near_duplicate.1[3] = [4, 8, 6];
    let mut zero_area = (v.clone(), f.clone());
    zero_area.0.push(0.5 * (v[0] + v[1]));
    zero_area.1.push([0, 8, 1]);
    let mut sliver = (v.clone(), f.clone());
    sliver
        .0
        .push(0.5 * (v[0] + v[3]) + DVec3::new(0.0, 0.0, -1e-7));
    sliver.1[0] = [0, 2, 8];
    sliver.1.push([8, 2, 3]);
    for (name, (v, f)) in [
        ("near-duplicate vertex", near_duplicate),
        ("zero-area face", zero_area),
        ("sliver triangles", sliver),
    ] {
        let path = dir.join(format!("{name}.obj"));
        write_obj(&path, &v, &f).expect("write OBJ");
        match load_and_bake(&path, 50.0, 12, 2) {
            Ok(graph) => solve_finite(&graph, name),
            // A typed error must name the problem; none of these is expected to need one.
            Err(e) => panic!("{name}: {e}"),
        }
    }
    // Every face degenerate: refused, naming it.
    let path = dir.join("flat.obj");
    write_obj(
        &path,
        &[DVec3::ZERO, DVec3::X, DVec3::X * 2.0],
        &[[0, 1, 2], [0, 2, 1]],
    )
    .expect("write OBJ");
    assert!(load_and_bake(&path, 50.0, 12, 1).is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn sizes_outside_the_supported_range_are_typed_errors_and_inside_it_solve() {
    let (v, f) = box_mesh(DVec3::splat(1.0));
    let unit = TriMesh {
        positions: v,
        normals: vec![],
        indices: f,
    };
    // 1e300 used to exhaust memory in the bake, 1e-300 to give zero volumes.
    for size in [f64::NAN, f64::INFINITY, 0.0, -1.0, 1e-300, 1e-5, 1e9, 1e300] {
        assert!(
            matches!(unit.normalized(size), Err(MeshError::InvalidSize(_))),
            "{size}"
        );
    }
    let params = BakeParams {
        resolution: 8,
        levels: 1,
        ..Default::default()
    };
    for radius in [1e300, 1e-300, 1e10] {
        let shape = Shape::Sphere { radius };
        let e = QuadGraph::bake(&shape.triangulate(8), &shape, &params, &mut |_| {})
            .err()
            .unwrap_or_else(|| panic!("radius {radius} baked"));
        assert!(matches!(e, BakeError::Invalid(_)), "{e}");
        assert!(e.to_string().contains("supported"), "{e}");
    }
    // Both ends of the range bake and solve finite with fixed coefficients (marble: 2e-4 to 2e8
    // mean free paths).
    for size in [*SIZE_RANGE_MM.start(), *SIZE_RANGE_MM.end()] {
        let shape = Shape::Sphere { radius: 0.5 * size };
        let (graph, _) = QuadGraph::bake(&shape.triangulate(8), &shape, &params, &mut |_| {})
            .unwrap_or_else(|e| panic!("{size}: {e}"));
        solve_finite(&graph, &format!("size {size}"));
    }
}

#[test]
fn non_finite_inputs_are_typed_errors() {
    let dir = scratch("inputs");
    let (v, f) = box_mesh(DVec3::splat(10.0));
    for bad in ["nan", "inf", "-inf", "1e400"] {
        let path = dir.join("bad.obj");
        let mut text = String::new();
        for (i, p) in v.iter().enumerate() {
            if i == 3 {
                writeln!(text, "v {} {bad} {}", p.x, p.z).unwrap();
            } else {
                writeln!(text, "v {} {} {}", p.x, p.y, p.z).unwrap();
            }
        }
        for t in &f {
            writeln!(text, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1).unwrap();
        }
        std::fs::write(&path, text).unwrap();
        let e = load_and_bake(&path, 50.0, 8, 1).expect_err(bad);
        assert!(
            e.contains("non-finite") && e.contains("bad.obj"),
            "{bad}: {e}"
        );
    }
    let marble = Material::preset("marble").unwrap();
    for scale in [f64::INFINITY, f64::NAN] {
        let e = Material::new(
            marble.sigma_s.map(|s| s * scale),
            marble.sigma_a.map(|s| s * scale),
            marble.eta,
        )
        .expect_err("preset x inf/nan");
        assert!(e.to_string().contains("sigma"), "{e}");
    }
    // A .vol grid with a NaN or Inf voxel, written by hand (VolGrid refuses to hold one).
    let grid = VolGrid::from_fn([2, 2, 2], DVec3::splat(-1.0), DVec3::splat(1.0), |_| {
        ([1.0; 3], [0.1; 3])
    })
    .unwrap();
    for bad in [f32::NAN, f32::INFINITY] {
        let mut bytes = grid.to_bytes();
        let at = bytes.len() - 4;
        bytes[at..].copy_from_slice(&bad.to_le_bytes());
        let path = dir.join("bad.vol");
        std::fs::write(&path, bytes).unwrap();
        let e = VolGrid::read(&path).expect_err("NaN voxel");
        assert!(e.to_string().contains("voxel [1, 1, 1]"), "{e}");
    }
    for light in [
        "dir:nan,-1,0:1,1,1",
        "dir:0,-1,0:1,inf,1",
        "point:0,1e400,0:1,1,1",
        "spot:0,50,0:0,-1,0:1,1,1:nan,20",
        "dir:1e-320,0,0:1,1,1",
        "dir:0,-1,0:1e31,1,1",
    ] {
        assert!(light.parse::<scene::Light>().is_err(), "{light}");
    }
    for env in [[f64::NAN, 0.0, 0.0], [f64::INFINITY; 3], [1e31; 3]] {
        assert!(Environment::Constant(env).validate().is_err(), "{env:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
