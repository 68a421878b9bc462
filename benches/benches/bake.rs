//! Bake benchmark: bakes every test mesh at default settings and prints the markdown table of
//! `benches/RESULTS.md` (bake section): nodes per level, texture memory, bake time, cache load time
//! and packing locality. Run with
//! `cargo bench -p translucent-benches --bench bake` (meshes from `TRANSLUCENT_MESH_DIR`, else
//! `../shared/meshes` beside the workspace). Speed targets are measured here, never asserted.

use std::path::{Path, PathBuf};
use std::time::Instant;

use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshSolid, Solid, TriMesh, ValidateOptions};
use translucent::quadgraph::BakeParams;
use translucent::QuadGraph;

const MESHES: [&str; 7] = [
    "spot",
    "stanford-bunny",
    "rocker-arm",
    "fandisk",
    "cheburashka",
    "homer",
    "nefertiti",
];

fn mesh_dir() -> PathBuf {
    std::env::var_os("TRANSLUCENT_MESH_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes"))
}

fn load(path: &Path) -> Result<(TriMesh, MeshSolid), String> {
    let mut mesh = TriMesh::load_obj(path).map_err(|e| e.to_string())?;
    mesh.validate(&ValidateOptions::default())
        .map_err(|e| e.to_string())?;
    let (mut mesh, _) = mesh.normalized(50.0).map_err(|e| e.to_string())?;
    if mesh.normals.len() != mesh.positions.len() {
        mesh.compute_normals();
    }
    let solid = MeshSolid::new(mesh.clone()).map_err(|e| e.to_string())?;
    Ok((mesh, solid))
}

fn row(
    name: &str,
    triangles: usize,
    surface: &TriMesh,
    solid: &dyn Solid,
    params: &BakeParams,
    scratch: &Path,
) {
    let start = Instant::now();
    let (graph, stats) = match QuadGraph::bake(surface, solid, params, &mut |_| {}) {
        Ok(x) => x,
        Err(e) => {
            println!("| {name} | bake failed: {e} |");
            return;
        }
    };
    let bake_s = start.elapsed().as_secs_f64();
    let path = scratch.join(format!("{name}.qgraph"));
    if let Err(e) = graph.save(&path, 1) {
        println!("| {name} | save failed: {e} |");
        return;
    }
    let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    // Best of 3: the first read may come from disk, the others from the page cache.
    let load_s = (0..3)
        .map(|_| {
            let t = Instant::now();
            let _ = QuadGraph::load(&path, Some(1));
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    let _ = std::fs::remove_file(&path);
    let per_level = |f: &dyn Fn(&translucent::quadgraph::LevelStats) -> String| {
        stats.levels.iter().map(f).collect::<Vec<_>>().join(" / ")
    };
    let finest = stats.levels.last().cloned().unwrap_or_default();
    println!(
        "| {name} | {triangles} | {} | {} | {:.1} | {:.0} | {:.1} - {:.1} | {:.2} | {:.3} ({:.0} MB) | {:.2} ({:.3}) |",
        per_level(&|l| l.surface_nodes.to_string()),
        per_level(&|l| l.inner_nodes.to_string()),
        stats.total_bytes as f64 / 1e6,
        stats.bytes_per_node,
        stats.min_dihedral_deg,
        stats.max_dihedral_deg,
        bake_s,
        load_s,
        size as f64 / 1e6,
        finest.locality,
        finest.random_locality,
    );
}

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --benches` runs benches as tests: skip the work.
    if std::env::args().any(|a| a == "--test" || a == "--list") {
        return;
    }
    let params = BakeParams::default();
    let scratch =
        std::env::temp_dir().join(format!("translucent-bake-bench-{}", std::process::id()));
    if let Err(e) = std::fs::create_dir_all(&scratch) {
        eprintln!("cannot create {}: {e}", scratch.display());
        return;
    }
    println!(
        "Default parameters: resolution {}, K {}, {} levels, r = {}; size 50 mm; {} threads.\n",
        params.resolution,
        params.k,
        params.levels,
        params.block,
        rayon::current_num_threads()
    );
    println!("| mesh | triangles | N_s per level (coarse / .. / fine) | N_i per level | texture MB | bytes/node | dihedral deg | bake s | cache load s (file) | locality finest (random) |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let sphere = Shape::Sphere { radius: 25.0 };
    let surface = sphere.triangulate(96);
    row(
        "sphere (procedural)",
        surface.indices.len(),
        &surface,
        &sphere,
        &params,
        &scratch,
    );
    let dir = mesh_dir();
    for name in MESHES {
        let path = dir.join(format!("{name}.obj"));
        match load(&path) {
            Ok((mesh, solid)) => row(name, mesh.indices.len(), &mesh, &solid, &params, &scratch),
            Err(e) => println!("| {name} | skipped: {e} |"),
        }
    }
    for name in ["teapot", "suzanne"] {
        if let Err(e) = load(&dir.join(format!("{name}.obj"))) {
            println!("\n{name}: refused: {e}");
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
}
