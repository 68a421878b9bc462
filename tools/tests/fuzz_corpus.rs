//! The fuzzing regression corpus (issue 17), on stable and in CI: every input in
//! `tests/fuzz-corpus/<target>/` (the seeds the fuzzers started from and every crash, hang or
//! memory blow-up they found, minimized) goes through the same entry point as its cargo-fuzz target
//! (`translucent_tools::hostile`), and then through the `translucent` binary: no input may panic,
//! and the command line must exit 0, 1 (refused, one `error:` line) or 2 (clap's usage error),
//! never 101 (a panic), and must not hang.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::scratch;
use translucent_tools::hostile;

/// Longest any one command-line run may take: the valid inputs render 8 x 8 pixels of a 4-cell
/// bake, which takes a few seconds on lavapipe under load; a hang is what this catches.
const CLI_TIMEOUT: Duration = Duration::from_secs(120);

fn corpus_dir(target: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fuzz-corpus")
        .join(target)
}

/// Every file of a target's corpus, sorted, with its bytes.
fn corpus(target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = corpus_dir(target);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{}: an empty corpus", dir.display());
    files
        .into_iter()
        .map(|p| {
            let name = p
                .file_name()
                .expect("file name")
                .to_string_lossy()
                .into_owned();
            (name, std::fs::read(&p).expect("read a corpus file"))
        })
        .collect()
}

#[test]
fn every_corpus_input_goes_through_its_entry_point_without_a_panic() {
    for target in hostile::TARGETS {
        let mut refused = 0;
        let inputs = corpus(target);
        for (name, data) in &inputs {
            let outcome = std::panic::catch_unwind(|| hostile::run(target, data));
            match outcome {
                Ok(Ok(())) => {}
                Ok(Err(message)) => {
                    refused += 1;
                    assert!(!message.is_empty(), "{target}/{name}: an empty refusal");
                }
                Err(_) => panic!("{target}/{name}: panicked (message above)"),
            }
        }
        println!("{target}: {} inputs, {refused} refused", inputs.len());
    }
}

/// A seed the reader refuses seeds nothing, and a found input refused at the version or an array
/// length no longer reaches the check it regresses: after a cache format change both go stale.
/// Every `seed-*` input of the cache target must be accepted, every `found-*` input must get past
/// the header and the decoder's lengths.
#[test]
fn cache_corpus_is_in_the_current_format() {
    for (name, data) in corpus("cache") {
        let outcome = hostile::run("cache", &data);
        if name.starts_with("seed-") {
            if let Err(message) = outcome {
                panic!(
                    "cache/{name} is refused ({message}): regenerate the seeds with `cargo run \
                     --release -p translucent-tools --example fuzz_replay -- make-cache-seeds \
                     tests/fuzz-corpus/cache`"
                );
            }
        } else if let Err(message) = outcome {
            assert!(
                !message.contains("version") && !message.contains("does not fit"),
                "cache/{name} is refused before the check it regresses ({message}): carry it \
                 into the current format"
            );
        }
    }
}

/// Runs the binary in `dir` (so any relative output lands there), killing it after
/// [`CLI_TIMEOUT`].
fn run_cli(args: &[&str], dir: &Path) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_translucent"))
        .args(args)
        .current_dir(dir)
        .env("TRANSLUCENT_VALIDATION", "1")
        .env("TRANSLUCENT_DEVICE", "llvmpipe")
        .env("TRANSLUCENT_CACHE_DIR", dir.join("cache"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run the translucent binary");
    let start = Instant::now();
    loop {
        if child.try_wait().expect("wait for translucent").is_some() {
            return child.wait_with_output().expect("collect the output");
        }
        if start.elapsed() > CLI_TIMEOUT {
            let _ = child.kill();
            let out = child.wait_with_output().expect("collect the output");
            panic!(
                "translucent {args:?} hung (> {CLI_TIMEOUT:?})\nstderr: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Exit 0, 1 with one `error:` line, or 2 (clap); never a panic.
fn assert_clean_exit(what: &str, out: &Output) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    let code = out.status.code();
    assert!(
        matches!(code, Some(0..=2)) && !stderr.contains("panicked"),
        "{what}: exit {code:?}\nstderr: {stderr}"
    );
    if code == Some(1) {
        let errors = stderr.lines().filter(|l| l.starts_with("error: ")).count();
        assert_eq!(
            errors, 1,
            "{what}: one error line expected\nstderr: {stderr}"
        );
    }
}

#[test]
fn every_corpus_input_through_the_command_line_exits_cleanly() {
    let dir = scratch("fuzz-corpus");
    let dir_s = dir.to_str().expect("utf-8 path");
    let key = hostile::cli_sphere_key();
    for (name, data) in corpus("obj") {
        let (force, text) = data
            .split_first()
            .map_or((false, &data[..]), |(f, t)| (f & 1 == 1, t));
        let file = dir.join("input.obj");
        std::fs::write(&file, text).expect("write the OBJ");
        let mut args = vec![
            "bake",
            "--mesh",
            "input.obj",
            "--resolution",
            "4",
            "--levels",
            "1",
            "--out",
            "o.qgraph",
        ];
        if force {
            args.push("--force");
        }
        assert_clean_exit(&format!("obj/{name}"), &run_cli(&args, &dir));
    }
    for (name, data) in corpus("vol") {
        std::fs::write(dir.join("input.vol"), &data).expect("write the volume");
        let out = dir.join("v.png");
        let _ = std::fs::remove_file(&out);
        let o = run_cli(
            &[
                "render",
                "--volume",
                "input.vol",
                "--shape",
                "sphere",
                "--resolution",
                "4",
                "--levels",
                "1",
                "--width",
                "8",
                "--height",
                "8",
                "--out",
                "v.png",
            ],
            &dir,
        );
        assert_clean_exit(&format!("vol/{name}"), &o);
        // What the entry point refuses, the command refuses, writing nothing.
        if hostile::run("vol", &data).is_err() {
            assert_eq!(o.status.code(), Some(1), "vol/{name} was rendered");
            assert!(!out.exists(), "vol/{name}: a refused volume left an image");
        }
    }
    for (name, data) in corpus("env") {
        std::fs::write(dir.join("input.exr"), &data).expect("write the map");
        let out = dir.join("e.png");
        let _ = std::fs::remove_file(&out);
        let o = run_cli(
            &[
                "render",
                "--env",
                "input.exr",
                "--shape",
                "sphere",
                "--resolution",
                "4",
                "--levels",
                "1",
                "--width",
                "8",
                "--height",
                "8",
                "--out",
                "e.png",
            ],
            &dir,
        );
        assert_clean_exit(&format!("env/{name}"), &o);
        if hostile::run("env", &data).is_err() {
            assert_eq!(o.status.code(), Some(1), "env/{name} was rendered");
            assert!(!out.exists(), "env/{name}: a refused map left an image");
        }
    }
    for (name, data) in corpus("cache") {
        // Payloads under the key the command computes, so that its load reaches the decoder.
        let bytes = match data.split_first() {
            Some((mode, rest)) if mode & 1 == 1 => hostile::cache_file(rest, key),
            Some((_, rest)) => rest.to_vec(),
            None => Vec::new(),
        };
        std::fs::write(dir.join("c.qgraph"), &bytes).expect("write the cache file");
        let o = run_cli(
            &[
                "bake",
                "--shape",
                "sphere",
                "--resolution",
                "4",
                "--levels",
                "1",
                "--out",
                "c.qgraph",
            ],
            &dir,
        );
        assert_clean_exit(&format!("cache/{name}"), &o);
        // A cache file is never fatal: it is loaded or rebuilt.
        assert_eq!(
            o.status.code(),
            Some(0),
            "cache/{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    // Scene strings and argument lists: those the entry point refuses (valid ones render, which
    // the other command-line tests cover) are refused by the command too, before any output.
    let out = dir.join("never.png");
    for (name, data) in corpus("scene_strings") {
        // A NUL cannot be passed in an argument (nor typed in a shell).
        if hostile::run("scene_strings", &data).is_ok() || data.len() < 2 || data.contains(&0) {
            continue;
        }
        let value = String::from_utf8_lossy(&data[1..]).into_owned();
        let mut args = vec![
            "render",
            "--shape",
            "sphere",
            "--resolution",
            "4",
            "--levels",
            "1",
        ];
        let parts: Vec<&str> = value.splitn(3, '|').collect();
        match data[0] % 3 {
            0 => args.extend(["--light", &value]),
            1 => args.extend(["--camera", &value]),
            _ => {
                args.extend(["--sigma-a", parts[0]]);
                if let Some(s) = parts.get(1) {
                    args.extend(["--sigma-s", s]);
                }
                if let Some(eta) = parts.get(2) {
                    args.extend(["--eta", eta]);
                }
            }
        }
        args.extend([
            "--width",
            "8",
            "--height",
            "8",
            "--out",
            out.to_str().expect("utf-8"),
        ]);
        let o = run_cli(&args, &dir);
        assert_clean_exit(&format!("scene_strings/{name}"), &o);
        assert_ne!(o.status.code(), Some(0), "scene_strings/{name} rendered");
        assert!(!out.exists(), "scene_strings/{name} left an image");
    }
    for (name, data) in corpus("render_argv") {
        if hostile::run("render_argv", &data).is_ok() {
            continue;
        }
        let text = String::from_utf8_lossy(&data).into_owned();
        let mut args = vec!["render"];
        args.extend(text.split(['\0', '\n']));
        let o = run_cli(&args, &dir);
        assert_clean_exit(&format!("render_argv/{name}"), &o);
    }
    let _ = std::fs::remove_dir_all(dir_s);
}
