//! Runtime shader compilation for hot reload: `glslc` as a subprocess, with the flags
//! `build.rs` uses (`--target-env=vulkan1.3 -O -g -I shaders-glsl/include`), so a shader compiled
//! here is the embedded one when its source is the same. No dependency: glslc is the build-time
//! compiler already (Debian package `glslc`). Found as `TRANSLUCENT_GLSLC` (the name `build.rs`
//! reads too), else `GLSLC` (kept for scripts), else `glslc` on `PATH`.
//!
//! [`ShaderTree`] is a `shaders-glsl/` directory on disk: [`ShaderTree::scan`] says which of the
//! embedded shaders' sources there differ from the ones the binary was built from (the file or
//! any file it includes, by content hash), and a key per shader for caching compiled results.
//! A host installs compiled SPIR-V with [`crate::vk::Context::set_shader_overrides`]; pipelines
//! created afterwards use it ([`super::load`]) and go through the same reflection checks.
//!
//! ```no_run
//! use translucent::shader::runtime::{Glslc, ShaderTree};
//! # fn f(ctx: &mut translucent::vk::Context) -> Result<(), translucent::shader::ShaderError> {
//! let glslc = Glslc::find()?;
//! let tree = ShaderTree::new("shaders-glsl")?;
//! let mut overrides = std::collections::HashMap::new();
//! for source in tree.scan()?.into_iter().filter(|s| s.differs) {
//!     overrides.insert(source.name.clone(), glslc.compile(&tree, &source.name)?.words);
//! }
//! ctx.set_shader_overrides(overrides);
//! // Pipelines created from here on use the recompiled shaders.
//! # Ok(()) }
//! ```

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::process::Command;

use super::{embedded_names, ShaderError, Spirv};

/// The environment variable naming the glslc program (default `glslc`, found on `PATH`), for
/// `build.rs` and the runtime compiler alike.
pub const GLSLC_ENV: &str = "TRANSLUCENT_GLSLC";
/// The older name `build.rs` read, used when [`GLSLC_ENV`] is not set (kept for scripts).
pub const GLSLC_ENV_FALLBACK: &str = "GLSLC";

/// Includes nest at most this deep (a cycle is a source error, not a stack overflow).
const MAX_INCLUDE_DEPTH: usize = 16;

/// FNV-1a, 64 bits, of a source file (`build.rs` hashes the embedded sources the same way).
pub fn source_hash(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The hash of the embedded shaders' source file `name` (path under `shaders-glsl/`, includes
/// too), `None` when the binary was built without it.
pub fn embedded_source_hash(name: &str) -> Option<u64> {
    super::embedded::SOURCE_HASHES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, h)| *h)
}

/// The glslc program.
#[derive(Clone, Debug)]
pub struct Glslc {
    program: PathBuf,
}

/// The glslc program named by the environment `var` reads: [`GLSLC_ENV`], else
/// [`GLSLC_ENV_FALLBACK`] (an empty value counts as unset), else `glslc` on `PATH`.
pub fn glslc_program(var: impl Fn(&str) -> Option<std::ffi::OsString>) -> PathBuf {
    [GLSLC_ENV, GLSLC_ENV_FALLBACK]
        .iter()
        .find_map(|name| var(name).filter(|p| !p.is_empty()))
        .map_or_else(|| PathBuf::from("glslc"), PathBuf::from)
}

impl Glslc {
    /// `TRANSLUCENT_GLSLC`, else `GLSLC`, else `glslc` on `PATH`; checked by running
    /// `glslc --version`.
    pub fn find() -> Result<Glslc, ShaderError> {
        Glslc::at(glslc_program(|name| std::env::var_os(name)))
    }

    /// The glslc at `program`; checked by running `program --version`.
    pub fn at(program: impl Into<PathBuf>) -> Result<Glslc, ShaderError> {
        let program = program.into();
        let no_compiler = |message: String| ShaderError::NoCompiler {
            program: program.display().to_string(),
            message,
        };
        let output = Command::new(&program)
            .arg("--version")
            .output()
            .map_err(|e| no_compiler(e.to_string()))?;
        let version = String::from_utf8_lossy(&output.stdout);
        if !output.status.success() || !version.contains("shaderc") {
            return Err(no_compiler(format!(
                "`--version` gave {} and {:?}, not glslc's",
                output.status,
                version.lines().next().unwrap_or("")
            )));
        }
        Ok(Glslc { program })
    }

    /// Compiles `name` (a `.comp`, `.vert` or `.frag` path under `tree`) to SPIR-V. A compile
    /// error is [`ShaderError::Compile`] with glslc's message and the first error's line.
    pub fn compile(&self, tree: &ShaderTree, name: &str) -> Result<Spirv, ShaderError> {
        let path = tree.root.join(name);
        if !matches!(
            path.extension().and_then(|e| e.to_str()),
            Some("comp" | "vert" | "frag")
        ) {
            return Err(ShaderError::Source {
                path: path.display().to_string(),
                message: "a shader stage ends in .comp, .vert or .frag".into(),
            });
        }
        if !path.is_file() {
            return Err(ShaderError::Source {
                path: path.display().to_string(),
                message: "no such file".into(),
            });
        }
        let output = Command::new(&self.program)
            // `-g` because `-O` alone strips OpName, and reflection looks bindings up by name.
            .args(["--target-env=vulkan1.3", "-O", "-g", "-I"])
            .arg(tree.root.join("include"))
            .arg(&path)
            .args(["-o", "-"])
            .output()
            .map_err(|e| ShaderError::NoCompiler {
                program: self.program.display().to_string(),
                message: e.to_string(),
            })?;
        let stderr = String::from_utf8_lossy(&output.stderr);
        if !output.status.success() {
            return Err(ShaderError::Compile {
                shader: path.display().to_string(),
                line: first_error_line(&stderr),
                message: stderr.trim().to_string(),
            });
        }
        Spirv::from_bytes(name, &output.stdout)
    }
}

/// `a/../b/c.glsl` -> `b/c.glsl`, with `/` separators (the embedded names' form).
fn normalize(path: &Path) -> String {
    let mut parts: Vec<String> = Vec::new();
    for component in path.components() {
        match component {
            std::path::Component::ParentDir => {
                parts.pop();
            }
            std::path::Component::Normal(s) => parts.push(s.to_string_lossy().into_owned()),
            _ => {}
        }
    }
    parts.join("/")
}

/// The line of glslc's first `FILE:LINE: error:` message.
fn first_error_line(stderr: &str) -> Option<u32> {
    stderr.lines().find_map(|l| {
        let (location, _) = l.split_once(": error:")?;
        location.rsplit(':').next()?.trim().parse().ok()
    })
}

/// An embedded shader's source in a [`ShaderTree`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ShaderSource {
    /// The path under `shaders-glsl/` (the embedded name).
    pub name: String,
    /// The hash of the file and every file it includes (changes when any of them does).
    pub key: u64,
    /// The file or a file it includes differs from the source the embedded SPIR-V came from.
    pub differs: bool,
}

/// A `shaders-glsl/` directory on disk.
#[derive(Clone, Debug)]
pub struct ShaderTree {
    root: PathBuf,
}

impl ShaderTree {
    /// `root` must be a directory (with the layout of `shaders-glsl/`).
    pub fn new(root: impl Into<PathBuf>) -> Result<ShaderTree, ShaderError> {
        let root = root.into();
        if !root.is_dir() {
            return Err(ShaderError::Source {
                path: root.display().to_string(),
                message: "not a directory of GLSL shaders (shaders-glsl/)".into(),
            });
        }
        Ok(ShaderTree { root })
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Every file under the root (for watching modification times), sorted.
    pub fn files(&self) -> Vec<PathBuf> {
        fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
            let Ok(entries) = std::fs::read_dir(dir) else {
                return;
            };
            for path in entries.filter_map(Result::ok).map(|e| e.path()) {
                if path.is_dir() {
                    walk(&path, out);
                } else {
                    out.push(path);
                }
            }
        }
        let mut out = Vec::new();
        walk(&self.root, &mut out);
        out.sort();
        out
    }

    /// Each embedded shader whose source file exists here: its key, and whether it (or a file
    /// it includes) differs from what the binary was built from. Sorted by name.
    pub fn scan(&self) -> Result<Vec<ShaderSource>, ShaderError> {
        let mut contents = HashMap::new();
        let mut sources = Vec::new();
        for name in embedded_names() {
            if !self.root.join(name).is_file() {
                continue;
            }
            let mut closure = BTreeSet::new();
            self.include_closure(name, 0, &mut closure, &mut contents)?;
            let mut key = Vec::with_capacity(16 * closure.len());
            let mut differs = false;
            for file in &closure {
                let hash = contents[file];
                key.extend_from_slice(file.as_bytes());
                key.extend_from_slice(&hash.to_le_bytes());
                differs |= embedded_source_hash(file) != Some(hash);
            }
            sources.push(ShaderSource {
                name: name.to_string(),
                key: source_hash(&key),
                differs,
            });
        }
        sources.sort_by(|a, b| a.name.cmp(&b.name));
        Ok(sources)
    }

    /// Adds `name` (a path under the root) and every file it includes to `closure`, resolving
    /// `#include "x"` as glslc does: next to the including file, then in `include/`.
    fn include_closure(
        &self,
        name: &str,
        depth: usize,
        closure: &mut BTreeSet<String>,
        contents: &mut HashMap<String, u64>,
    ) -> Result<(), ShaderError> {
        if depth > MAX_INCLUDE_DEPTH {
            return Err(ShaderError::Source {
                path: self.root.join(name).display().to_string(),
                message: format!("includes nest deeper than {MAX_INCLUDE_DEPTH} (a cycle?)"),
            });
        }
        if !closure.insert(name.to_string()) {
            return Ok(());
        }
        let path = self.root.join(name);
        let bytes = std::fs::read(&path).map_err(|e| ShaderError::Source {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        contents.insert(name.to_string(), source_hash(&bytes));
        let dir = Path::new(name).parent().unwrap_or(Path::new(""));
        for line in String::from_utf8_lossy(&bytes).lines() {
            let Some(rest) = line.trim_start().strip_prefix("#include") else {
                continue;
            };
            let Some(included) = rest
                .trim()
                .strip_prefix('"')
                .and_then(|r| r.split('"').next())
            else {
                continue;
            };
            let candidates = [dir.join(included), Path::new("include").join(included)];
            // A missing include is glslc's error to report (with its line), not ours.
            if let Some(found) = candidates.iter().find(|c| self.root.join(c).is_file()) {
                let found = normalize(found);
                self.include_closure(&found, depth + 1, closure, contents)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::{embedded, Reflection};

    /// This crate's `shaders-glsl/`, which the embedded SPIR-V was compiled from.
    fn source_tree() -> ShaderTree {
        ShaderTree::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders-glsl")).expect("tree")
    }

    #[test]
    fn one_glslc_variable_with_the_old_name_as_fallback() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |name: &str| {
                pairs
                    .iter()
                    .find(|(n, _)| *n == name)
                    .map(|(_, v)| std::ffi::OsString::from(v))
            }
        };
        assert_eq!(glslc_program(env(&[])), PathBuf::from("glslc"));
        assert_eq!(
            glslc_program(env(&[("GLSLC", "/old")])),
            PathBuf::from("/old")
        );
        assert_eq!(
            glslc_program(env(&[("GLSLC", "/old"), ("TRANSLUCENT_GLSLC", "/new")])),
            PathBuf::from("/new")
        );
        assert_eq!(
            glslc_program(env(&[("GLSLC", "/old"), ("TRANSLUCENT_GLSLC", "")])),
            PathBuf::from("/old"),
            "an empty value counts as unset"
        );
    }

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("translucent-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch dir");
        dir
    }

    /// Copies `from` into `to` recursively.
    fn copy_tree(from: &Path, to: &Path) {
        for entry in std::fs::read_dir(from)
            .expect("read_dir")
            .filter_map(Result::ok)
        {
            let (src, dst) = (entry.path(), to.join(entry.file_name()));
            if src.is_dir() {
                std::fs::create_dir_all(&dst).expect("mkdir");
                copy_tree(&src, &dst);
            } else {
                std::fs::copy(&src, &dst).expect("copy");
            }
        }
    }

    #[test]
    fn every_embedded_shader_recompiles_to_spirv_with_the_same_reflection() {
        let glslc = Glslc::find().expect("glslc (the build-time compiler) is installed");
        let tree = source_tree();
        let sources = tree.scan().expect("scan");
        let names: Vec<&str> = embedded_names().collect();
        assert_eq!(
            sources.len(),
            names.len(),
            "every embedded shader's source is in the tree"
        );
        // The build compiled these very files.
        assert!(sources.iter().all(|s| !s.differs), "{sources:?}");
        let workers = std::thread::available_parallelism().map_or(2, |n| n.get());
        let chunk = names.len().div_ceil(workers);
        std::thread::scope(|scope| {
            for part in names.chunks(chunk) {
                let (glslc, tree) = (&glslc, &tree);
                scope.spawn(move || {
                    for &name in part {
                        let runtime = glslc.compile(tree, name).expect(name);
                        let built = embedded(name).expect("embedded");
                        let (a, b) = (
                            Reflection::new(&runtime).expect("reflects"),
                            Reflection::new(&built).expect("reflects"),
                        );
                        assert_eq!(a.stage, b.stage, "{name}");
                        assert_eq!(a.bindings, b.bindings, "{name}");
                        assert_eq!(a.push_constant_size, b.push_constant_size, "{name}");
                        assert_eq!(a.workgroup_size, b.workgroup_size, "{name}");
                        assert_eq!(a.spec_constants, b.spec_constants, "{name}");
                    }
                });
            }
        });
    }

    #[test]
    fn an_edit_is_found_through_includes_and_a_broken_shader_names_its_line() {
        let dir = scratch("runtime-tree");
        copy_tree(source_tree().root(), &dir);
        let tree = ShaderTree::new(&dir).expect("tree");
        let before = tree.scan().expect("scan");
        assert!(before.iter().all(|s| !s.differs));
        // An include shared by several shaders changes: exactly the shaders that include it
        // differ (it is included directly only, by stage files).
        let includers: Vec<String> = embedded_names()
            .filter(|n| {
                std::fs::read_to_string(dir.join(n))
                    .is_ok_and(|t| t.contains("#include \"rsm_view.glsl\""))
            })
            .map(String::from)
            .collect();
        assert!(includers.len() >= 2, "{includers:?}");
        let include = dir.join("include/rsm_view.glsl");
        let mut text = std::fs::read_to_string(&include).expect("read");
        text.push_str("\n// edited\n");
        std::fs::write(&include, text).expect("write");
        let after = tree.scan().expect("scan");
        let differing: Vec<&str> = after
            .iter()
            .filter(|s| s.differs)
            .map(|s| s.name.as_str())
            .collect();
        let mut includers = includers;
        includers.sort();
        assert_eq!(differing, includers);
        for (a, b) in before.iter().zip(&after) {
            assert_eq!(a.key == b.key, !b.differs, "{}", b.name);
        }

        // A broken line 3 in the viewer's fragment shader.
        let frag = dir.join("viewer/present.frag");
        let text = std::fs::read_to_string(&frag).expect("read");
        let mut lines: Vec<&str> = text.lines().collect();
        lines.insert(2, "this is not glsl;");
        std::fs::write(&frag, lines.join("\n")).expect("write");
        let glslc = Glslc::find().expect("glslc");
        match glslc.compile(&tree, "viewer/present.frag") {
            Err(ShaderError::Compile {
                shader,
                line,
                message,
            }) => {
                assert!(shader.ends_with("viewer/present.frag"), "{shader}");
                assert_eq!(line, Some(3), "{message}");
                assert!(message.contains("error"), "{message}");
            }
            other => panic!("expected a compile error, got {other:?}"),
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_missing_compiler_or_directory_is_a_typed_error() {
        let missing = Glslc::at("/nonexistent/glslc");
        assert!(
            matches!(&missing, Err(ShaderError::NoCompiler { program, .. }) if program == "/nonexistent/glslc"),
            "{missing:?}"
        );
        let message = missing.err().map(|e| e.to_string()).unwrap_or_default();
        assert!(message.contains("apt-get install glslc"), "{message}");
        // A program that is not glslc.
        assert!(matches!(
            Glslc::at("true"),
            Err(ShaderError::NoCompiler { .. })
        ));
        assert!(matches!(
            ShaderTree::new("/nonexistent/shaders-glsl"),
            Err(ShaderError::Source { .. })
        ));
        let glslc = Glslc::find().expect("glslc");
        assert!(matches!(
            glslc.compile(&source_tree(), "viewer/missing.frag"),
            Err(ShaderError::Source { .. })
        ));
        assert!(matches!(
            glslc.compile(&source_tree(), "include/optics.glsl"),
            Err(ShaderError::Source { .. })
        ));
    }

    #[test]
    fn glslc_error_lines_are_read_from_its_first_error() {
        assert_eq!(
            first_error_line("a/b.frag:42: error: 'x' : undeclared identifier\n1 error generated."),
            Some(42)
        );
        assert_eq!(
            first_error_line("/tmp/bad.frag: error: #version: needs 140\n"),
            None
        );
    }
}
