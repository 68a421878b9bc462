//! `--resolution auto` (the default of bake, render and view; DESIGN 5.1): the command reports the
//! chosen spacing and node count on stderr and in `--json`, and the choice follows the material
//! and the image.

mod common;

use common::{json_of, scratch, translucent};

/// The JSON's spacing times the cells is the object's longest side within this (the bounding box
/// of a 96-segment sphere is its diameter to ~1e-3).
const LONGEST_SIDE_REL: f64 = 1e-2;

fn resolution_of(json: &serde_json::Value) -> (u64, f64, Option<String>, u64) {
    let r = &json["resolution"];
    (
        r["resolution"].as_u64().expect("resolution"),
        r["spacing_mm"].as_f64().expect("spacing_mm"),
        r["auto"]["bound"].as_str().map(str::to_string),
        r["finest_nodes"].as_u64().expect("finest_nodes"),
    )
}

#[test]
fn bake_reports_what_auto_chose_and_a_given_resolution_is_kept() {
    let dir = scratch("resolution-bake");
    let out = dir.join("s.qgraph");
    let out = out.to_str().expect("utf-8 path");
    // A 50 mm sphere of bake's default material (skim milk: blue diffusion length ~3.5 mm,
    // two cells per diffusion length): the material decides, coarser than the old fixed 48.
    let auto = translucent(
        &[
            "bake",
            "--shape",
            "sphere",
            "--size-mm",
            "50",
            "--levels",
            "2",
            "--out",
            out,
            "--json",
        ],
        &dir,
    );
    let json = json_of(&auto);
    let (cells, spacing, bound, nodes) = resolution_of(&json);
    assert_eq!(bound.as_deref(), Some("material"), "{}", json["resolution"]);
    assert!((24..48).contains(&cells), "{cells}");
    assert!(
        (cells as f64 * spacing - 50.0).abs() < LONGEST_SIDE_REL * 50.0,
        "{cells} x {spacing}"
    );
    assert_eq!(json["params"]["resolution"].as_u64(), Some(cells));
    let finest = json["stats"]["levels"]
        .as_array()
        .and_then(|l| l.last())
        .expect("levels");
    assert_eq!(
        nodes,
        finest["surface_nodes"].as_u64().unwrap() + finest["inner_nodes"].as_u64().unwrap()
    );
    // Without --json the choice is one line on stderr.
    let text = translucent(
        &[
            "bake",
            "--shape",
            "sphere",
            "--size-mm",
            "50",
            "--levels",
            "2",
            "--out",
            out,
        ],
        &dir,
    );
    assert!(text.status.success());
    let stderr = String::from_utf8_lossy(&text.stderr);
    assert!(
        stderr.contains(&format!("resolution auto: {cells} cells across"))
            && stderr.contains(&format!("{nodes} nodes on the finest level")),
        "{stderr}"
    );
    // A number is kept as given; auto is absent.
    let given = json_of(&translucent(
        &[
            "bake",
            "--shape",
            "sphere",
            "--size-mm",
            "50",
            "--levels",
            "2",
            "--resolution",
            "12",
            "--out",
            out,
            "--json",
        ],
        &dir,
    ));
    assert_eq!(resolution_of(&given).0, 12);
    assert!(given["resolution"]["auto"].is_null());
    // A bad value names the option.
    let bad = translucent(&["bake", "--shape", "sphere", "--resolution", "fine"], &dir);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--resolution"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn render_auto_follows_the_material_and_the_image() {
    let dir = scratch("resolution-render");
    let render = |material: &str, pixels: &str| {
        let png = dir.join(format!("{material}-{pixels}.png"));
        json_of(&translucent(
            &[
                "render",
                "--shape",
                "sphere",
                "--size-mm",
                "20",
                "--levels",
                "2",
                "--material",
                material,
                "--solver",
                "cpu",
                "--width",
                pixels,
                "--height",
                pixels,
                "--out",
                png.to_str().expect("utf-8"),
                "--json",
            ],
            &dir,
        ))
    };
    // Ketchup at 192 px: its blue mean free path (~0.68 mm) decides: ~30 cells over 20 mm.
    let (fine, _, bound, _) = resolution_of(&render("ketchup", "192"));
    assert_eq!(bound.as_deref(), Some("material"));
    assert!((26..=34).contains(&fine), "{fine}");
    // The same at 24 px: a pixel covers ~1.1 mm of the object, so the image bound is coarser
    // than the material's and the lattice falls to the minimum.
    let (coarse, _, bound, _) = resolution_of(&render("ketchup", "24"));
    assert!(coarse < fine, "{coarse} vs {fine}");
    assert!(
        matches!(bound.as_deref(), Some("image" | "minimum")),
        "{bound:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
