//! Shader hot reload (feature `hot-reload`): the viewer watches its own shaders' files and,
//! when one changes (or on `F5`), recompiles them with the library's runtime compiler
//! (`translucent::shader::hot_reload`, shaderc) and rebuilds its present pipeline; a shader that
//! fails to compile or to match the pass's interface leaves the old pipeline running and says
//! why in the overlay. The object's own pipelines are embedded in the library and have no
//! reload entry point yet.

use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime};

use anyhow::Context as _;
use translucent::shader::Spirv;

use super::present::{FRAGMENT_SHADER, VERTEX_SHADER};

/// How often the files' modification times are read.
const POLL: Duration = Duration::from_millis(500);

/// The viewer's shader files and when they last changed.
pub struct ShaderWatch {
    /// `shaders-glsl/` (`TRANSLUCENT_SHADER_DIR`, else the source tree this binary was built from).
    root: PathBuf,
    stamps: Vec<Option<SystemTime>>,
    last_poll: Instant,
}

impl ShaderWatch {
    pub fn new() -> ShaderWatch {
        let root = std::env::var_os("TRANSLUCENT_SHADER_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|| {
                PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders-glsl"))
            });
        let mut watch = ShaderWatch {
            root,
            stamps: Vec::new(),
            last_poll: Instant::now(),
        };
        watch.stamps = watch.read_stamps();
        watch
    }

    fn files(&self) -> [PathBuf; 2] {
        [VERTEX_SHADER, FRAGMENT_SHADER].map(|s| self.root.join(s))
    }

    fn read_stamps(&self) -> Vec<Option<SystemTime>> {
        self.files()
            .iter()
            .map(|f| std::fs::metadata(f).and_then(|m| m.modified()).ok())
            .collect()
    }

    /// Whether a file changed since the last call (read at most every [`POLL`]).
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

    /// Compiles the vertex and fragment shaders from their files.
    pub fn compile(&self) -> anyhow::Result<(Spirv, Spirv)> {
        let include = self.root.join("include");
        let [v, f] = self.files();
        let vs = translucent::shader::hot_reload::compile_file(&v, &include)
            .with_context(|| v.display().to_string())?;
        let fs = translucent::shader::hot_reload::compile_file(&f, &include)
            .with_context(|| f.display().to_string())?;
        Ok((vs, fs))
    }
}
