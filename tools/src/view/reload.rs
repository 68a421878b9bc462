//! Shader hot reload: the viewer's shaders come from a `shaders-glsl/` directory on disk
//! (`--shader-dir`, else `TRANSLUCENT_SHADER_DIR`, else the source tree this binary was built
//! from). On `F5` (the script's `reload-shaders`), or when a file there changes (modification
//! times, read every [`POLL`]), every shader whose source differs from the one built into the
//! binary is compiled with glslc (`translucent::shader::runtime`; compiled results are cached by
//! source) and installed in the context; the viewer then rebuilds what uses a changed shader:
//! its present pass (`viewer/`) and/or the object (any other shader: its pipelines are made
//! again, so its solution is solved again). A shader that fails to compile or to match its
//! pass's interface leaves the old pipelines running; the overlay and the report say why.

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime};

use translucent::shader::runtime::{Glslc, ShaderTree};
use translucent::shader::ShaderError;

/// How often the files' modification times are read.
const POLL: Duration = Duration::from_millis(500);

/// The shader directory, its files' modification times and the compiled shaders.
pub struct ShaderWatch {
    root: PathBuf,
    stamps: Vec<(PathBuf, Option<SystemTime>)>,
    last_poll: Instant,
    glslc: Option<Glslc>,
    /// SPIR-V words by (shader name, source key).
    cache: HashMap<(String, u64), Vec<u32>>,
    /// The shaders installed in the context now: name -> source key.
    installed: BTreeMap<String, u64>,
}

/// The shaders of the directory that differ from the built-in ones, compiled.
pub struct Compiled {
    /// Words by shader name, for `Context::set_shader_overrides`.
    pub overrides: HashMap<String, Vec<u32>>,
    keys: BTreeMap<String, u64>,
    /// Shaders whose SPIR-V changes from what is installed (new, edited or back to built-in).
    pub changed: Vec<String>,
    /// Shaders glslc compiled now (the others came from the cache).
    pub compiled: usize,
}

impl ShaderWatch {
    /// Watches `dir` (`None`: `TRANSLUCENT_SHADER_DIR`, else the build's source tree).
    pub fn new(dir: Option<PathBuf>) -> ShaderWatch {
        let root = dir
            .or_else(|| std::env::var_os("TRANSLUCENT_SHADER_DIR").map(PathBuf::from))
            .unwrap_or_else(|| {
                PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders-glsl"))
            });
        let mut watch = ShaderWatch {
            root,
            stamps: Vec::new(),
            last_poll: Instant::now(),
            glslc: None,
            cache: HashMap::new(),
            installed: BTreeMap::new(),
        };
        watch.stamps = watch.read_stamps();
        watch
    }

    pub fn root(&self) -> &std::path::Path {
        &self.root
    }

    fn read_stamps(&self) -> Vec<(PathBuf, Option<SystemTime>)> {
        let Ok(tree) = ShaderTree::new(&self.root) else {
            return Vec::new();
        };
        tree.files()
            .into_iter()
            .map(|f| {
                let stamp = std::fs::metadata(&f).and_then(|m| m.modified()).ok();
                (f, stamp)
            })
            .collect()
    }

    /// Whether a file was added, removed or modified since the last call (read at most every
    /// [`POLL`]).
    pub fn changed(&mut self) -> bool {
        if self.last_poll.elapsed() < POLL {
            return false;
        }
        self.last_poll = Instant::now();
        let stamps = self.read_stamps();
        let changed = stamps != self.stamps;
        self.stamps = stamps;
        changed
    }

    /// Compiles every shader of the directory whose source differs from the built-in one
    /// (cached by source); says which differ from what is installed now.
    pub fn compile(&mut self) -> Result<Compiled, ShaderError> {
        let tree = ShaderTree::new(&self.root)?;
        let mut compiled = Compiled {
            overrides: HashMap::new(),
            keys: BTreeMap::new(),
            changed: Vec::new(),
            compiled: 0,
        };
        for source in tree.scan()?.into_iter().filter(|s| s.differs) {
            let cache_key = (source.name.clone(), source.key);
            let words = match self.cache.get(&cache_key) {
                Some(words) => words.clone(),
                None => {
                    if self.glslc.is_none() {
                        self.glslc = Some(Glslc::find()?);
                    }
                    let glslc = self.glslc.as_ref().ok_or_else(|| ShaderError::NoCompiler {
                        program: "glslc".into(),
                        message: "not found".into(),
                    })?;
                    let words = glslc.compile(&tree, &source.name)?.words;
                    compiled.compiled += 1;
                    self.cache.insert(cache_key, words.clone());
                    words
                }
            };
            compiled.overrides.insert(source.name.clone(), words);
            compiled.keys.insert(source.name, source.key);
        }
        let names: std::collections::BTreeSet<&String> =
            compiled.keys.keys().chain(self.installed.keys()).collect();
        compiled.changed = names
            .into_iter()
            .filter(|n| compiled.keys.get(*n) != self.installed.get(*n))
            .cloned()
            .collect();
        Ok(compiled)
    }

    /// `compiled` is installed in the context now.
    pub fn installed(&mut self, compiled: &Compiled) {
        self.installed = compiled.keys.clone();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn copy_tree(from: &std::path::Path, to: &std::path::Path) {
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
    fn an_edit_is_noticed_compiled_once_and_reverting_it_changes_back() {
        let dir = std::env::temp_dir().join(format!("translucent-watch-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        copy_tree(
            std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders-glsl")),
            &dir,
        );
        let mut watch = ShaderWatch::new(Some(dir.clone()));
        // Nothing differs from the built-in shaders.
        let none = watch.compile().expect("compile");
        assert!(none.overrides.is_empty() && none.changed.is_empty());

        let frag = dir.join("viewer/present.frag");
        let original = std::fs::read_to_string(&frag).expect("read");
        std::fs::write(&frag, format!("{original}\n// edited\n")).expect("write");
        // A later modification time, whatever the file system's resolution.
        let later = SystemTime::now() + Duration::from_secs(2);
        std::fs::File::options()
            .write(true)
            .open(&frag)
            .and_then(|f| f.set_modified(later))
            .expect("set mtime");
        watch.last_poll = Instant::now() - POLL;
        assert!(watch.changed(), "the edit is seen");
        assert!(!watch.changed(), "read at most every POLL");

        let edited = watch.compile().expect("compile");
        assert_eq!(edited.changed, ["viewer/present.frag"]);
        assert_eq!(edited.compiled, 1);
        watch.installed(&edited);
        let again = watch.compile().expect("compile");
        assert!(again.changed.is_empty(), "{:?}", again.changed);
        assert_eq!(again.compiled, 0, "cached");

        std::fs::write(&frag, original).expect("revert");
        let reverted = watch.compile().expect("compile");
        assert!(reverted.overrides.is_empty());
        assert_eq!(
            reverted.changed,
            ["viewer/present.frag"],
            "back to built-in"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
