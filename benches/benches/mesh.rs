//! Mesh query throughput: hierarchy build per test mesh, `contains` (fast winding number),
//! `ray_hit` (closest) and `any_hit` (shadow rays) on the Stanford bunny normalized to 50 mm.
//!
//! `cargo bench -p translucent-benches --bench mesh`; numbers go to `benches/RESULTS.md`.
//! Meshes come from `TRANSLUCENT_MESH_DIR` or `<workspace>/../shared/meshes`.

use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::DVec3;
use translucent::mesh::{MeshSolid, Solid, TriMesh};

fn mesh_dir() -> PathBuf {
    std::env::var_os("TRANSLUCENT_MESH_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes"))
}

fn load(name: &str) -> Option<TriMesh> {
    let path = mesh_dir().join(format!("{name}.obj"));
    match TriMesh::load_obj(&path).and_then(|m| m.normalized(50.0)) {
        Ok((mesh, _)) => Some(mesh),
        Err(e) => {
            eprintln!("skipped {name}: {e}");
            None
        }
    }
}

/// Deterministic uniform numbers in [0, 1) (splitmix64).
fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        (z ^ (z >> 31)) as f64 / u64::MAX as f64
    }
}

fn build(c: &mut Criterion) {
    let mut group = c.benchmark_group("mesh/build");
    group.sample_size(10);
    for name in [
        "spot",
        "fandisk",
        "homer",
        "cheburashka",
        "rocker-arm",
        "stanford-bunny",
        "nefertiti",
    ] {
        let Some(mesh) = load(name) else { continue };
        group.throughput(Throughput::Elements(mesh.indices.len() as u64));
        group.bench_with_input(BenchmarkId::from_parameter(name), &mesh, |b, mesh| {
            b.iter(|| MeshSolid::new(mesh.clone()).map(|s| s.bounds()))
        });
    }
    group.finish();
}

fn queries(c: &mut Criterion) {
    let Some(mesh) = load("stanford-bunny") else {
        return;
    };
    let solid = MeshSolid::new(mesh).expect("the bunny builds");
    let (lo, hi) = solid.bounds();
    let mut next = uniform(5);
    let mut in_box = || lo + (hi - lo) * DVec3::new(next(), next(), next());
    let points: Vec<DVec3> = (0..10_000).map(|_| in_box()).collect();
    // Rays from a sphere of radius 60 mm towards random points of the bounding box: most hit.
    let rays: Vec<(DVec3, DVec3)> = points
        .iter()
        .enumerate()
        .map(|(i, &target)| {
            let origin = points[(i * 7919) % points.len()].normalize_or(DVec3::Y) * 60.0;
            (origin, (target - origin).normalize())
        })
        .collect();

    // Points within 0.5 mm of the surface, as the bake's bisection of cut lattice edges asks.
    let mut jitter = uniform(6);
    let near: Vec<DVec3> = (0..points.len())
        .map(|i| {
            let tri = solid.mesh().indices[(i * 7) % solid.mesh().indices.len()];
            let p = tri.map(|v| solid.mesh().positions[v as usize]);
            let offset = DVec3::new(jitter(), jitter(), jitter()) - DVec3::splat(0.5);
            (p[0] + p[1] + p[2]) / 3.0 + offset
        })
        .collect();

    // Cut edges as the bake sees them: 0.6 mm segments through the surface along face normals.
    let cuts: Vec<(DVec3, DVec3)> = solid
        .mesh()
        .indices
        .iter()
        .step_by(7)
        .filter_map(|tri| {
            let [a, b, c] = tri.map(|v| solid.mesh().positions[v as usize]);
            let n = (b - a).cross(c - a).normalize_or_zero();
            let centre = (a + b + c) / 3.0;
            let (inside, outside) = (centre - n * 0.3, centre + n * 0.3);
            (solid.contains(inside) && !solid.contains(outside)).then_some((inside, outside))
        })
        .take(2000)
        .collect();

    let mut group = c.benchmark_group("mesh/bunny");
    group.sample_size(10);
    group.throughput(Throughput::Elements(points.len() as u64));
    group.bench_function("contains (1 thread)", |b| {
        b.iter(|| points.iter().filter(|p| solid.contains(**p)).count())
    });
    group.bench_function("contains near the surface (1 thread)", |b| {
        b.iter(|| near.iter().filter(|p| solid.contains(**p)).count())
    });
    group.throughput(Throughput::Elements(cuts.len() as u64));
    group.bench_function("boundary_crossing 1e-4 mm (1 thread)", |b| {
        b.iter(|| {
            cuts.iter()
                .map(|(i, o)| solid.boundary_crossing(*i, *o, 1e-4).x)
                .sum::<f64>()
        })
    });
    group.bench_function("bisection of contains to 1e-4 mm (1 thread)", |b| {
        b.iter(|| {
            cuts.iter()
                .map(|&(mut i, mut o)| {
                    while (o - i).length() > 1e-4 {
                        let m = 0.5 * (i + o);
                        if solid.contains(m) {
                            i = m;
                        } else {
                            o = m;
                        }
                    }
                    i.x
                })
                .sum::<f64>()
        })
    });
    group.throughput(Throughput::Elements(points.len() as u64));
    group.bench_function("contains_many (rayon)", |b| {
        b.iter(|| solid.contains_many(&points))
    });
    group.bench_function("winding_number (1 thread)", |b| {
        b.iter(|| points.iter().map(|p| solid.winding_number(*p)).sum::<f64>())
    });
    group.bench_function("ray_hit (1 thread)", |b| {
        b.iter(|| {
            rays.iter()
                .filter_map(|(o, d)| solid.ray_hit(*o, *d, 200.0))
                .count()
        })
    });
    group.bench_function("any_hit (1 thread)", |b| {
        b.iter(|| {
            rays.iter()
                .filter(|(o, d)| solid.any_hit(*o, *d, 200.0))
                .count()
        })
    });
    group.bench_function("closest_point (1 thread)", |b| {
        b.iter(|| {
            points
                .iter()
                .filter_map(|p| solid.closest_point(*p))
                .count()
        })
    });
    group.finish();
}

criterion_group!(benches, build, queries);
criterion_main!(benches);
