//! Malformed meshes get the typed error that names the problem (and the file), never a panic.

use std::path::PathBuf;

use glam::DVec3;
use translucent::mesh::{MeshError, MeshSolid, Solid, TriMesh, ValidateOptions};

/// Writes `text` to a fresh file in a per-process temporary directory.
fn obj(name: &str, text: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("translucent-mesh-bad-input-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// A closed tetrahedron, outward, as OBJ text (vertices 1-4).
const TETRA: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

fn load_err(name: &str, text: &str) -> (MeshError, String) {
    let path = obj(name, text);
    let err = TriMesh::load_obj(&path).unwrap_err();
    let message = err.to_string();
    assert!(
        message.contains(name),
        "the message names the file: {message}"
    );
    (err, message)
}

#[test]
fn a_good_tetrahedron_loads_and_validates() {
    let mut mesh = TriMesh::load_obj(obj("tetra.obj", TETRA)).unwrap();
    let report = mesh.validate(&ValidateOptions::default()).unwrap();
    assert_eq!(
        (
            report.faces,
            report.vertices,
            report.boundary_edges,
            report.components
        ),
        (4, 4, 0, 1)
    );
    assert!((report.signed_volume - 1.0 / 6.0).abs() < 1e-15 && !report.inverted);
    let solid = MeshSolid::new(mesh).unwrap();
    assert!(solid.contains(DVec3::splat(0.1)) && !solid.contains(DVec3::splat(0.5)));
}

#[test]
fn file_normals_are_averaged_per_vertex() {
    // Flat-shaded tetrahedron: one normal per face, so every vertex gets three different ones.
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 -1\nvn 0 -1 0\nvn -1 0 0\nvn 1 1 1\n\
                f 1//1 3//1 2//1\nf 1//2 2//2 4//2\nf 1//3 4//3 3//3\nf 2//4 3//4 4//4\n";
    let mesh = TriMesh::load_obj(obj("normals.obj", text)).unwrap();
    assert_eq!(
        mesh.positions.len(),
        4,
        "vertices are not split at normal seams"
    );
    let origin = mesh
        .positions
        .iter()
        .position(|p| *p == DVec3::ZERO)
        .unwrap();
    assert!((mesh.normals[origin] - DVec3::splat(-1.0).normalize()).length() < 1e-6);
    let x = mesh.positions.iter().position(|p| *p == DVec3::X).unwrap();
    let expected =
        (DVec3::new(0.0, 0.0, -1.0) + DVec3::new(0.0, -1.0, 0.0) + DVec3::ONE.normalize())
            .normalize();
    assert!(
        (mesh.normals[x] - expected).length() < 1e-6,
        "{}",
        mesh.normals[x]
    );
}

#[test]
fn missing_file_is_an_io_error_naming_it() {
    let path = std::env::temp_dir().join("translucent-no-such-mesh.obj");
    let err = TriMesh::load_obj(&path).unwrap_err();
    assert!(matches!(err, MeshError::Io { .. }), "{err:?}");
    assert!(
        err.to_string().contains("translucent-no-such-mesh.obj"),
        "{err}"
    );
}

#[test]
fn empty_files_are_refused() {
    for (name, text) in [
        ("empty.obj", ""),
        ("only-vertices.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"),
        ("comment.obj", "# nothing\n"),
    ] {
        let (err, _) = load_err(name, text);
        assert!(matches!(err.root(), MeshError::Empty), "{name}: {err:?}");
    }
}

#[test]
fn non_finite_coordinates_name_the_vertex_and_line() {
    for (name, text, vertex, line) in [
        ("nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", 2, 2),
        (
            "inf.obj",
            "# c\nv 0 0 0\nv 1 0 0\nv 0 1 -inf\nf 1 2 3\n",
            3,
            4,
        ),
        (
            "overflow.obj",
            "v 0 0 0\nv 1e400 0 0\nv 0 1 0\nf 1 2 3\n",
            2,
            2,
        ),
        (
            "beyond-f32.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1e39 0\nf 1 2 3\n",
            3,
            3,
        ),
    ] {
        let (err, message) = load_err(name, text);
        let MeshError::NonFiniteVertex {
            vertex: v, line: l, ..
        } = err.root()
        else {
            panic!("{name}: {err:?}")
        };
        assert_eq!((*v, *l), (vertex, Some(line)), "{name}");
        assert!(
            message.starts_with(&format!("{}:{line}: ", obj(name, text).display())),
            "{message}"
        );
    }
    // Built in code: the vertex index, no line.
    let mesh = TriMesh {
        positions: vec![DVec3::ZERO, DVec3::X, DVec3::new(0.0, f64::NAN, 0.0)],
        normals: vec![],
        indices: vec![[0, 1, 2]],
    };
    let err = MeshSolid::new(mesh.clone()).unwrap_err();
    assert!(
        matches!(
            err,
            MeshError::NonFiniteVertex {
                vertex: 2,
                line: None,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(matches!(
        mesh.normalized(10.0),
        Err(MeshError::NonFiniteVertex { .. })
    ));
}

#[test]
fn face_indices_out_of_range_name_the_face_and_line() {
    for (name, text, index) in [
        (
            "too-big.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n",
            9,
        ),
        ("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 0),
        (
            "relative.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -5\n",
            -5,
        ),
        (
            "with-normals.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 4//1\n",
            4,
        ),
    ] {
        let (err, message) = load_err(name, text);
        let MeshError::IndexOutOfRange {
            index: i,
            vertices,
            line,
            ..
        } = err.root()
        else {
            panic!("{name}: {err:?}")
        };
        assert_eq!((*i, *vertices), (index, 3), "{name}");
        let line = line.expect("a line");
        assert!(
            message.contains(&format!("{name}:{line}: face")),
            "{message}"
        );
    }
    let mesh = TriMesh {
        positions: vec![DVec3::ZERO; 3],
        normals: vec![],
        indices: vec![[0, 1, 2], [0, 1, 3]],
    };
    let err = MeshSolid::new(mesh.clone()).unwrap_err();
    assert!(
        matches!(
            err,
            MeshError::IndexOutOfRange {
                face: 1,
                index: 3,
                vertices: 3,
                line: None
            }
        ),
        "{err:?}"
    );
    // The helpers that take any mesh skip the bad face instead of panicking.
    let mut mesh = mesh;
    assert_eq!((mesh.signed_volume(), mesh.surface_area()), (0.0, 0.0));
    mesh.compute_normals();
    assert_eq!(mesh.normals.len(), 3);
    assert!(matches!(
        mesh.validate(&ValidateOptions::default()),
        Err(MeshError::IndexOutOfRange { face: 1, .. })
    ));
}

#[test]
fn tabs_crlf_and_faces_before_their_vertices_load() {
    let text = "f 1 3 2\r\nf 1 2 4\r\nf 1 4 3\r\nf 2 3 4\r\nv\t0 0 0\r\nv 1 0 0\r\nv\t0 1 0\r\nv 0 0 1\r\n";
    let mut mesh = TriMesh::load_obj(obj("crlf.obj", text)).unwrap();
    let report = mesh.validate(&ValidateOptions::default()).unwrap();
    assert_eq!((report.faces, report.boundary_edges), (4, 0));
}

#[test]
fn unparsable_obj_is_a_syntax_error_at_its_line() {
    let (err, message) = load_err("garbage.obj", "v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n");
    assert!(
        matches!(err.root(), MeshError::Syntax { line: 3, .. }),
        "{err:?}"
    );
    assert!(
        message.ends_with("garbage.obj:3: vertex 3: coordinate z \"zero\" is not a number"),
        "{message}"
    );
    // Each rule tobj applies, refused at its line with the file named (FILE:LINE: problem).
    let tetra = TETRA;
    for (name, text, line) in [
        ("cut-vertex.obj", format!("{tetra}v 1 2"), 9),
        ("cut-number.obj", format!("{tetra}v 1 2 3e"), 9),
        ("weight-zero.obj", format!("v 0 0 0 0\n{tetra}"), 1),
        ("two-extra.obj", format!("v 0 0 0 1 1\n{tetra}"), 1),
        ("mixed-colours.obj", format!("v 0 0 0 1 1 1\n{tetra}"), 2),
        ("cut-normal.obj", format!("vn 0 0\n{tetra}"), 1),
        ("cut-texcoord.obj", format!("{tetra}vt 0"), 9),
        ("bad-index.obj", format!("{tetra}f 1 2 x"), 9),
        ("four-slashes.obj", format!("{tetra}f 1/1/1/1 2 3"), 9),
        ("empty-face.obj", format!("{tetra}f"), 9),
        (
            "normal-index.obj",
            format!("vn 0 0 1\n{tetra}f 1//2 2//1 3//1"),
            10,
        ),
        ("not-utf8.obj", tetra.to_string(), 9),
        ("usemtl.obj", format!("{tetra}usemtl\n"), 9),
        (
            "forward-across-objects.obj",
            format!("o a\nf 1 2 3\no b\n{tetra}"),
            2,
        ),
    ] {
        let mut bytes = text.into_bytes();
        if name == "not-utf8.obj" {
            bytes.extend_from_slice(b"# caf\xe9\n"); // Latin-1, not UTF-8
        }
        let path = obj(name, "");
        std::fs::write(&path, &bytes).unwrap();
        let err = TriMesh::load_obj(&path).unwrap_err();
        let message = err.to_string();
        assert_eq!(err.line(), Some(line), "{name}: {message}");
        assert!(
            message.starts_with(&format!("{}:{line}: ", path.display())),
            "{name}: {message}"
        );
    }
}

#[test]
fn non_manifold_edge_is_refused_naming_the_edge() {
    // The tetrahedron plus a fin on its edge 1-2 (that edge now has three faces), plus a degenerate
    // face, which is dropped only if the mesh is accepted.
    let text = format!("{TETRA}v 1 1 -1\nf 2 1 5\nf 1 1 2\n");
    let mut mesh = TriMesh::load_obj(obj("fin.obj", &text)).unwrap();
    let err = mesh.validate(&ValidateOptions::default()).unwrap_err();
    let MeshError::NonManifoldEdge {
        a,
        b,
        faces,
        pa,
        pb,
    } = err
    else {
        panic!("{err:?}")
    };
    assert_eq!(faces, 3);
    // Indices are the loaded mesh's (numbered by first use); positions are the file's.
    assert_eq!(
        (
            mesh.positions[a as usize].to_array(),
            mesh.positions[b as usize].to_array()
        ),
        (pa, pb)
    );
    let mut ends = [pa, pb];
    ends.sort_by(|x, y| x.partial_cmp(y).unwrap());
    assert_eq!(ends, [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]);
    assert!(
        err.to_string()
            .contains("non-manifold edge between vertices"),
        "{err}"
    );
    assert!(err.to_string().contains("(1 0 0)"), "{err}");
    // Forced: accepted, counted, said.
    assert_eq!(mesh.indices.len(), 6, "a refused mesh is left as it was");
    let report = mesh.validate(&ValidateOptions::forced()).unwrap();
    assert!(
        report.forced && report.non_manifold_edges == 1 && report.boundary_edges == 2,
        "{report:?}"
    );
}

#[test]
fn inconsistent_orientation_is_refused() {
    // One face of the tetrahedron wound the other way.
    let text = TETRA.replace("f 2 3 4", "f 2 4 3");
    let mut mesh = TriMesh::load_obj(obj("flipped-face.obj", &text)).unwrap();
    let err = mesh.validate(&ValidateOptions::default()).unwrap_err();
    assert!(
        matches!(err, MeshError::InconsistentOrientation { edges: 3, .. }),
        "{err:?}"
    );
    // Forced, the face is turned back when the solid is built: the winding number is whole again
    // and ray normals point out.
    let report = mesh.validate(&ValidateOptions::forced()).unwrap();
    assert!(report.forced && report.summary().contains("turned to agree"));
    let solid = MeshSolid::new(mesh).unwrap();
    assert!((solid.winding_number(DVec3::splat(0.1)) - 1.0).abs() < 1e-9);
    let (t, n) = solid
        .ray_hit(DVec3::splat(0.1), DVec3::ONE.normalize(), 10.0)
        .unwrap();
    assert!((n - DVec3::ONE.normalize()).length() < 1e-12, "{t} {n}");
}

#[test]
fn inside_out_mesh_is_accepted_and_reported() {
    let text = TETRA
        .replace("f 1 3 2", "f 1 2 3")
        .replace("f 1 2 4", "f 1 4 2")
        .replace("f 1 4 3", "f 1 3 4")
        .replace("f 2 3 4", "f 2 4 3");
    let mut mesh = TriMesh::load_obj(obj("inside-out.obj", &text)).unwrap();
    let report = mesh.validate(&ValidateOptions::default()).unwrap();
    assert!(
        report.inverted && report.summary().contains("inside-out"),
        "{}",
        report.summary()
    );
    let solid = MeshSolid::new(mesh).unwrap();
    assert!(solid.contains(DVec3::splat(0.1)));
    let (t, n) = solid
        .ray_hit(DVec3::new(0.1, 0.1, -1.0), DVec3::Z, 10.0)
        .unwrap();
    assert!((t - 1.0).abs() < 1e-12 && n == -DVec3::Z, "{t} {n}");
}

#[test]
fn degenerate_faces_are_dropped_and_counted_but_not_all() {
    // A zero-area sliver (collinear) and a repeated index added to the closed tetrahedron.
    let text = format!("{TETRA}v 0.5 0 0\nf 1 5 2\nf 1 1 2\n");
    let mut mesh = TriMesh::load_obj(obj("slivers.obj", &text)).unwrap();
    let report = mesh.validate(&ValidateOptions::default()).unwrap();
    assert_eq!(
        (
            report.degenerate_faces_dropped,
            report.faces,
            report.boundary_edges
        ),
        (2, 4, 0)
    );
    assert!(report.summary().contains("dropped 2 degenerate faces"));

    // Loading checks structure only; validation finds the degenerate faces.
    let mut mesh = TriMesh::load_obj(obj(
        "all-degenerate.obj",
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 1 2\n",
    ))
    .unwrap();
    let err = mesh.validate(&ValidateOptions::default()).unwrap_err();
    assert!(
        matches!(err, MeshError::AllDegenerate { faces: 2 }),
        "{err:?}"
    );
}

#[test]
fn groups_and_objects_merge_into_one_closed_mesh() {
    let text = "o first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\ng second\nf 1 4 3\nf 2 3 4\n";
    let mut mesh = TriMesh::load_obj(obj("groups.obj", text)).unwrap();
    let report = mesh.validate(&ValidateOptions::default()).unwrap();
    assert_eq!(
        (
            report.faces,
            report.vertices,
            report.boundary_edges,
            report.components
        ),
        (4, 4, 0, 1),
        "{report:?}"
    );
    // Quads are fanned into triangles.
    let quads = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
                 f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    let mut cube = TriMesh::load_obj(obj("cube.obj", quads)).unwrap();
    let report = cube.validate(&ValidateOptions::default()).unwrap();
    assert_eq!((report.faces, report.boundary_edges), (12, 0));
    assert!((report.signed_volume - 1.0).abs() < 1e-12);
}

#[test]
fn normalization_rejects_bad_sizes_and_flat_inputs() {
    let mesh = TriMesh {
        positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
        normals: vec![],
        indices: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
    };
    for size in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(
            matches!(mesh.normalized(size), Err(MeshError::InvalidSize(_))),
            "{size}"
        );
    }
    let point = TriMesh {
        positions: vec![DVec3::ONE; 3],
        normals: vec![],
        indices: vec![[0, 1, 2]],
    };
    assert!(matches!(point.normalized(10.0), Err(MeshError::ZeroExtent)));
    assert!(matches!(
        TriMesh::default().normalized(10.0),
        Err(MeshError::Empty)
    ));
    // Exact: a unit tetrahedron to 30 mm is scaled by 30 about (0.5, 0.5, 0.5).
    let (n, t) = mesh.normalized(30.0).unwrap();
    assert_eq!((t.centre, t.scale), (DVec3::splat(0.5), 30.0));
    assert_eq!(n.positions[1], DVec3::new(15.0, -15.0, -15.0));
    assert_eq!(t.invert(n.positions[1]), mesh.positions[1]);
}
