//! Compiles every `shaders-glsl/**/*.{comp,vert,frag}` to SPIR-V with `glslc` and embeds the
//! results: `$OUT_DIR/shaders.rs` holds `EMBEDDED: &[(&str, &[u8])]`, keyed by the path relative
//! to `shaders-glsl/` (e.g. `"laplace/jacobi_step.comp"`), and `SOURCE_HASHES: &[(&str, u64)]`,
//! the FNV-1a hash of every file under `shaders-glsl/` (includes too), so that hot reload
//! (`translucent::shader::runtime`) can tell which sources on disk differ from the embedded ones.
//! Missing glslc fails the build with the Debian package to install.

use std::path::{Path, PathBuf};
use std::process::Command;

/// FNV-1a, 64 bits (`translucent::shader::runtime::source_hash` is the same function).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>, all: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<_> = entries.filter_map(Result::ok).map(|e| e.path()).collect();
    entries.sort();
    for path in entries {
        println!("cargo:rerun-if-changed={}", path.display());
        if path.is_dir() {
            collect(&path, out, all);
            continue;
        }
        all.push(path.clone());
        if matches!(
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
    // The compiler: `TRANSLUCENT_GLSLC` (the one name, as the runtime compiler of
    // `shader::runtime` reads it), else `GLSLC` (kept for scripts), else `glslc` on PATH.
    println!("cargo:rerun-if-env-changed=TRANSLUCENT_GLSLC");
    println!("cargo:rerun-if-env-changed=GLSLC");

    let mut sources = Vec::new();
    let mut files = Vec::new();
    collect(&root, &mut sources, &mut files);
    let glslc = ["TRANSLUCENT_GLSLC", "GLSLC"]
        .iter()
        .find_map(|name| std::env::var(name).ok().filter(|v| !v.is_empty()))
        .unwrap_or_else(|| "glslc".into());
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
    table.push_str("/// FNV-1a hash of every file under `shaders-glsl/` the SPIR-V was compiled from.\npub static SOURCE_HASHES: &[(&str, u64)] = &[\n");
    for file in &files {
        let rel = file
            .strip_prefix(&root)
            .unwrap_or(file)
            .to_string_lossy()
            .replace('\\', "/");
        let bytes = std::fs::read(file)
            .unwrap_or_else(|e| fail(&format!("reading {}: {e}", file.display())));
        table.push_str(&format!("    ({rel:?}, {:#x}),\n", fnv1a(&bytes)));
    }
    table.push_str("];\n");
    std::fs::write(out_dir.join("shaders.rs"), table)
        .unwrap_or_else(|e| fail(&format!("writing shaders.rs: {e}")));
}
