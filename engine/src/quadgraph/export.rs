//! Export of a bake for tools that are not ours (DESIGN section 8, `translucent bake --export DIR`):
//! per level `L` (0: coarsest), `tets-L.vtk` (legacy ASCII VTK unstructured grid of the tetrahedra,
//! in mm), `nodes-L.csv` (`id,kind,x,y,z,n0,n1,n2,n3`, kind `inner|surface`, neighbour ids, -1
//! where none), and `surface.obj` (the normalized input surface). Every file is written to a
//! temporary name and renamed, so none is ever half-written.
//!
//! ```no_run
//! # use translucent::mesh::shapes::Shape;
//! # use translucent::quadgraph::BakeParams;
//! # let ball = Shape::Sphere { radius: 10.0 };
//! # let (graph, _) = translucent::QuadGraph::bake(&ball.triangulate(16), &ball, &BakeParams::default(), &mut |_| {}).unwrap();
//! let files = translucent::quadgraph::export::export(&graph, "bake-out".as_ref()).unwrap();
//! assert_eq!(files.len(), 2 * graph.levels.len() + 1);
//! ```

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::cache::write_atomically;
use super::graph::{GraphLevel, QuadGraph, NO_NODE};
use super::BakeError;

/// Writes the export files into `dir` (created if missing); returns their paths.
pub fn export(graph: &QuadGraph, dir: &Path) -> Result<Vec<PathBuf>, BakeError> {
    std::fs::create_dir_all(dir).map_err(|source| BakeError::Io {
        path: dir.into(),
        source,
    })?;
    let mut written = Vec::new();
    for (l, level) in graph.levels.iter().enumerate() {
        let vtk = dir.join(format!("tets-{l}.vtk"));
        write_atomically(&vtk, vtk_text(level, l).as_bytes())?;
        written.push(vtk);
        let csv = dir.join(format!("nodes-{l}.csv"));
        write_atomically(&csv, nodes_csv(level).as_bytes())?;
        written.push(csv);
    }
    let obj = dir.join("surface.obj");
    write_atomically(&obj, obj_text(graph).as_bytes())?;
    written.push(obj);
    Ok(written)
}

/// Legacy VTK: POINTS, CELLS (4 ids each), CELL_TYPES 10 (VTK_TETRA).
pub fn vtk_text(level: &GraphLevel, l: usize) -> String {
    let (v, t) = (&level.tets.vertices, &level.tets.tets);
    let mut s = String::with_capacity(40 * v.len() + 30 * t.len());
    let _ = write!(
        s,
        "# vtk DataFile Version 3.0\nTranslucent QuadGraph level {l} tetrahedra (mm)\nASCII\n"
    );
    let _ = writeln!(s, "DATASET UNSTRUCTURED_GRID\nPOINTS {} double", v.len());
    for p in v {
        let _ = writeln!(s, "{} {} {}", p.x, p.y, p.z);
    }
    let _ = writeln!(s, "CELLS {} {}", t.len(), 5 * t.len());
    for c in t {
        let _ = writeln!(s, "4 {} {} {} {}", c[0], c[1], c[2], c[3]);
    }
    let _ = writeln!(s, "CELL_TYPES {}", t.len());
    for _ in t {
        s.push_str("10\n");
    }
    s
}

/// `id,kind,x,y,z,n0,n1,n2,n3`; a surface node lists its one inner node in `n0`.
pub fn nodes_csv(level: &GraphLevel) -> String {
    let mut s = String::with_capacity(80 * level.node_count());
    s.push_str("id,kind,x,y,z,n0,n1,n2,n3\n");
    let id = |j: u32| if j == NO_NODE { -1 } else { j as i64 };
    let ni = level.inner_count();
    for (i, p) in level.positions.iter().enumerate() {
        let (kind, nb) = if i < ni {
            ("inner", level.neighbors[i].map(id))
        } else {
            (
                "surface",
                [level.surface_faces[i - ni].0 as i64, -1, -1, -1],
            )
        };
        let _ = writeln!(
            s,
            "{i},{kind},{},{},{},{},{},{},{}",
            p.x, p.y, p.z, nb[0], nb[1], nb[2], nb[3]
        );
    }
    s
}

/// The normalized input surface as OBJ (positions, normals, 1-based faces).
pub fn obj_text(graph: &QuadGraph) -> String {
    let m = &graph.surface;
    let mut s = String::with_capacity(40 * m.positions.len() + 30 * m.indices.len());
    s.push_str("# Translucent: normalized input surface (mm)\n");
    for p in &m.positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    let with_normals = m.normals.len() == m.positions.len();
    if with_normals {
        for n in &m.normals {
            let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
        }
    }
    for t in &m.indices {
        let [a, b, c] = t.map(|i| i + 1);
        if with_normals {
            let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
        } else {
            let _ = writeln!(s, "f {a} {b} {c}");
        }
    }
    s
}
