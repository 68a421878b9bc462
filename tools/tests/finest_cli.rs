//! `translucent render --finest-operator graph --update-storage f16` (issue 13 item 4;
//! benches/RESULTS.md "Matrix-free finest level (wave 8)"): the JSON names what ran, the
//! matrix-free finest level stores no finest rows (its `values` hold the coarse levels' only) and
//! fp16 updates take 8 bytes per node, for the same cycles; the total bytes per finest node stay
//! below a bound.

mod common;

use std::path::Path;

use common::{json_of, scratch, translucent};

/// Bytes per finest node of this small scene with both cuts (measured 851.7; 888.1 with neither:
/// at resolution 16 the coarse levels, the textures' padding and the fixed-size buffers weigh more
/// per finest node than on the default scene's 531.3 -> 482.5): the finest rows uploaded again
/// (+~60) fail it.
const TOTAL_BOUND: f64 = 870.0;
/// The finest rows' share of the CSR path, bytes per finest node, at least (measured 27.6 here):
/// 3.6 entries of 12 bytes (values) and 4 (columns) per node and a row start, less the texel map
/// and the geometric factors the graph reads (a padded texture at this size).
const ROWS_SAVED: f64 = 20.0;
/// fp16 d (all levels, > 1 node per finest node) and z_old: 4 bytes per node each at least.
const HALF_SAVED: f64 = 8.0;

fn render(dir: &Path, extra: &[&str]) -> serde_json::Value {
    let out = dir.join("x.png");
    let mut args = vec![
        "render",
        "--out",
        out.to_str().expect("path"),
        "--json",
        "--width",
        "48",
        "--height",
        "48",
        "--resolution",
        "16",
        "--levels",
        "3",
        "--supersample",
        "1",
        "--single-scattering",
        "off",
    ];
    args.extend_from_slice(extra);
    json_of(&translucent(&args, dir))
}

fn per_node(json: &serde_json::Value, part: &str) -> f64 {
    json["gpu_bytes_split"]["bytes_per_finest_node"][part]
        .as_f64()
        .expect("bytes per node")
}

#[test]
fn matrix_free_finest_level_and_half_updates_take_fewer_bytes() {
    let dir = scratch("finest");
    let csr = render(
        &dir,
        &["--finest-operator", "csr", "--update-storage", "f32"],
    );
    let graph = render(&dir, &["--update-storage", "f32"]);
    let both = render(&dir, &[]);
    assert_eq!(csr["finest_storage"]["operator"], "csr");
    assert_eq!(csr["finest_storage"]["updates"], "f32");
    assert_eq!(graph["finest_storage"]["operator"], "graph", "the default");
    assert_eq!(both["finest_storage"]["updates"], "f16", "the default");
    for json in [&csr, &graph, &both] {
        assert_eq!(json["multigrid"]["state"], "Converged", "{json}");
        assert_eq!(json["multigrid"]["cycles"], csr["multigrid"]["cycles"]);
    }
    let (t_csr, t_graph, t_both) = (
        per_node(&csr, "total"),
        per_node(&graph, "total"),
        per_node(&both, "total"),
    );
    println!("bytes per finest node: csr {t_csr:.1}, graph {t_graph:.1}, graph + f16 {t_both:.1}");
    assert!(t_graph + ROWS_SAVED <= t_csr, "{t_graph} against {t_csr}");
    assert!(t_both + HALF_SAVED <= t_graph, "{t_both} against {t_graph}");
    assert!(t_both <= TOTAL_BOUND, "{t_both} bytes per finest node");
    let _ = std::fs::remove_dir_all(&dir);
}
