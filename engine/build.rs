//! Compiles every `shaders-glsl/**/*.{comp,vert,frag}` to SPIR-V with `glslc` and embeds the
//! results: `$OUT_DIR/shaders.rs` holds `EMBEDDED: &[(&str, &[u8])]`, keyed by the path relative
//! to `shaders-glsl/` (e.g. `"laplace/jacobi_step.comp"`). Missing glslc fails the build with the
//! Debian package to install.

use std::path::{Path, PathBuf};
use std::process::Command;

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<_> = entries.filter_map(Result::ok).map(|e| e.path()).collect();
    entries.sort();
    for path in entries {
        println!("cargo:rerun-if-changed={}", path.display());
        if path.is_dir() {
            collect(&path, out);
        } else if matches!(
            path.extension().and_then(|e| e.to_str()),
            Some("comp" | "vert" | "frag")
        ) {
            out.push(path);
        }
    }
}

fn fail(message: &str) -> ! {
    eprintln!("error: {message}");
    println!("cargo:warning={message}");
    std::process::exit(1);
}

fn main() {
    let manifest = PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| fail("CARGO_MANIFEST_DIR not set")),
    );
    let root = manifest.parent().unwrap_or(&manifest).join("shaders-glsl");
    let include = root.join("include");
    let out_dir =
        PathBuf::from(std::env::var("OUT_DIR").unwrap_or_else(|_| fail("OUT_DIR not set")));
    println!("cargo:rerun-if-changed={}", root.display());
    println!("cargo:rerun-if-env-changed=GLSLC");

    let mut sources = Vec::new();
    collect(&root, &mut sources);
    let glslc = std::env::var("GLSLC").unwrap_or_else(|_| "glslc".into());
    let mut table = String::from("/// Embedded SPIR-V, keyed by path under `shaders-glsl/`.\npub static EMBEDDED: &[(&str, &[u8])] = &[\n");
    for source in &sources {
        let rel = source
            .strip_prefix(&root)
            .unwrap_or(source)
            .to_string_lossy()
            .replace('\\', "/");
        let spv = out_dir.join("spv").join(format!("{rel}.spv"));
        if let Some(parent) = spv.parent() {
            std::fs::create_dir_all(parent)
                .unwrap_or_else(|e| fail(&format!("creating {}: {e}", parent.display())));
        }
        let output = Command::new(&glslc)
            // `-g` because `-O` alone strips OpName, and reflection looks bindings up by name.
            .args(["--target-env=vulkan1.3", "-O", "-g", "-I"])
            .arg(&include)
            .arg(source)
            .arg("-o")
            .arg(&spv)
            .output()
            .unwrap_or_else(|e| {
                fail(&format!(
                    "cannot run `{glslc}` ({e}): the shader compiler is needed to build; install the Debian package `glslc` (apt-get install glslc)"
                ))
            });
        if !output.status.success() {
            fail(&format!(
                "glslc failed on {}:\n{}",
                source.display(),
                String::from_utf8_lossy(&output.stderr)
            ));
        }
        table.push_str(&format!(
            "    ({rel:?}, include_bytes!({:?})),\n",
            spv.to_string_lossy()
        ));
    }
    table.push_str("];\n");
    std::fs::write(out_dir.join("shaders.rs"), table)
        .unwrap_or_else(|e| fail(&format!("writing shaders.rs: {e}")));
}
