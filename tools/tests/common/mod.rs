//! Helpers shared by the command-line tests: run the built `translucent` with validation on (any
//! validation message makes the command fail) in a scratch directory that also holds its cache.

#![allow(dead_code)] // each test file uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `translucent args...` on lavapipe with validation on, caching bakes in `cache`.
pub fn translucent(args: &[&str], cache: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_translucent"))
        .args(args)
        .env("TRANSLUCENT_VALIDATION", "1")
        .env("TRANSLUCENT_DEVICE", "llvmpipe")
        .env("TRANSLUCENT_CACHE_DIR", cache)
        .output()
        .expect("run the translucent binary")
}

/// A fresh, empty scratch directory unique to this test process.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("translucent-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

/// The JSON a successful `--json` command printed (fails the test with its output otherwise).
pub fn json_of(out: &Output) -> serde_json::Value {
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "exit {:?}\nstdout: {stdout}\nstderr: {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_str(stdout.trim()).unwrap_or_else(|e| panic!("{e}: {stdout}"))
}

/// An `[r, g, b]` JSON array.
pub fn rgb(v: &serde_json::Value) -> [f64; 3] {
    let a = v.as_array().expect("array");
    std::array::from_fn(|c| a[c].as_f64().expect("number"))
}
