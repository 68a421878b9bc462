//! The library's imports run one way (lib.rs, "The model on one page"): `vk` <- `shader` <-
//! {`render`, `solver`} <- `frame` <- `object`. This test reads the sources and fails on a path
//! into a module a layer may not use (comments and `#[cfg(test)]` modules are not imports of the
//! library).

use std::path::{Path, PathBuf};

/// (directory under engine/src, the crate paths its code must not name, why).
const RULES: &[(&str, &[&str], &str)] = &[
    (
        "vk",
        &[
            "crate::shader",
            "crate::render",
            "crate::solver",
            "crate::frame",
            "crate::object",
        ],
        "vk knows nothing about translucency",
    ),
    (
        "shader",
        &[
            "crate::render",
            "crate::solver",
            "crate::frame",
            "crate::object",
        ],
        "shaders sit below every pass",
    ),
    (
        "render",
        &[
            "crate::solver",
            "crate::frame",
            "crate::object",
            "crate::headless",
            "crate::TranslucentObject",
        ],
        "render passes are shared by every method and know no solver",
    ),
    (
        "solver",
        &[
            "crate::render",
            "crate::frame",
            "crate::object",
            "crate::headless",
            "crate::TranslucentObject",
        ],
        "solvers are composed by frame/, they do not compose frames",
    ),
    (
        "frame",
        &[
            "crate::object",
            "crate::headless",
            "crate::TranslucentObject",
        ],
        "the object composes frames, not the other way",
    ),
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The lines of `source` that are code of the library: up to its first `#[cfg(test)]`, without
/// comments.
fn library_code(source: &str) -> impl Iterator<Item = (usize, &str)> {
    source
        .lines()
        .enumerate()
        .take_while(|(_, l)| l.trim() != "#[cfg(test)]")
        .map(|(i, l)| (i + 1, l.split("//").next().unwrap_or("")))
}

fn violations(src: &Path) -> Vec<String> {
    let mut found = Vec::new();
    for (dir, forbidden, why) in RULES {
        let mut files = Vec::new();
        rust_files(&src.join(dir), &mut files);
        assert!(
            !files.is_empty(),
            "no sources under {}",
            src.join(dir).display()
        );
        for file in files {
            let text = std::fs::read_to_string(&file).expect("readable source");
            for (line, code) in library_code(&text) {
                for path in forbidden.iter() {
                    let named = code.match_indices(path).any(|(at, _)| {
                        // `crate::render` but not `crate::renderer`.
                        !code[at + path.len()..]
                            .starts_with(|c: char| c.is_alphanumeric() || c == '_')
                    });
                    if named {
                        found.push(format!("{}:{line}: {path} ({why})", file.display()));
                    }
                }
            }
        }
    }
    found
}

#[test]
fn imports_run_one_way() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let found = violations(&src);
    assert!(
        found.is_empty(),
        "imports against the layering:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_check_sees_a_forbidden_import() {
    // The check itself can fail: a solver file naming render is reported.
    let dir = std::env::temp_dir().join(format!("translucent-layering-{}", std::process::id()));
    for (sub, _, _) in RULES {
        std::fs::create_dir_all(dir.join(sub)).expect("temp dir");
        std::fs::write(dir.join(sub).join("ok.rs"), "use crate::mesh::TriMesh;\n").expect("write");
    }
    std::fs::write(
        dir.join("solver").join("bad.rs"),
        "// crate::render in a comment is fine\nuse crate::render::ShadowMaps;\n#[cfg(test)]\nuse crate::object::X;\n",
    )
    .expect("write");
    let found = violations(&dir);
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].contains("bad.rs:2: crate::render"), "{found:?}");
}
