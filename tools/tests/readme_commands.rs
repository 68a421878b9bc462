//! Every `translucent ...` command in README.md's code blocks runs, so the README's examples cannot
//! rot (issue 16, item 6).
//!
//! The commands of a block run in order in one scratch directory (a later command may read what an
//! earlier one wrote), with `../shared/meshes` pointing at the test meshes and a scratch bake
//! cache. Conventions, in the README source:
//! - `<!-- readme-test: skip REASON -->` on the line before a code block: its commands are not
//!   run (say why: a window, a path-traced reference, ...). `translucent view` always needs a
//!   window and is covered by view_cli.rs under Xvfb, so it is skipped without a marker.
//! - `<!-- readme-test: slow -->`: the block runs only with `TRANSLUCENT_README_SLOW=1`.
//! - A command with `[`, `|` or `...` is a synopsis, not an example: listed, not run.
//!
//! CI runs the rest with small images and lattices: `render` gets `--width 64 --height 64` and
//! `render`/`bake` get `--resolution 16 --levels 2` unless the command sets them (or `render` reads
//! a `--graph`, which fixes them) (these options
//! change sizes, not what the command exercises). `TRANSLUCENT_README_AS_WRITTEN=1` runs the
//! commands exactly as written (minutes on lavapipe).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// One runnable README command: its line number, the block's kind, and its arguments after
/// `translucent`.
#[derive(Debug)]
struct Example {
    line: usize,
    slow: bool,
    args: Vec<String>,
}

/// What the README parse found.
#[derive(Debug, Default)]
struct Parsed {
    run: Vec<Vec<Example>>,
    /// `line: command (why not run)`.
    not_run: Vec<String>,
}

const MARKER: &str = "<!-- readme-test:";

fn parse(readme: &str) -> Result<Parsed, String> {
    let mut parsed = Parsed::default();
    let mut lines = readme.lines().enumerate();
    let mut marker: Option<String> = None;
    while let Some((_, line)) = lines.next() {
        let trimmed = line.trim();
        if let Some(rest) = trimmed.strip_prefix(MARKER) {
            marker = Some(rest.trim_end_matches("-->").trim().to_string());
            continue;
        }
        if !trimmed.starts_with("```") {
            if !trimmed.is_empty() {
                marker = None;
            }
            continue;
        }
        let lang = trimmed.trim_start_matches('`').trim();
        let shell = matches!(lang, "" | "sh" | "bash" | "shell");
        let block_marker = marker.take();
        let mut block = Vec::new();
        let mut pending = String::new();
        let mut pending_line = 0;
        for (j, body) in lines.by_ref() {
            if body.trim().starts_with("```") {
                break;
            }
            if !shell {
                continue;
            }
            // Join continuation lines.
            if pending.is_empty() {
                pending_line = j + 1;
            }
            let text = body.trim_end();
            if let Some(head) = text.strip_suffix('\\') {
                pending.push_str(head);
                pending.push(' ');
                continue;
            }
            pending.push_str(text);
            let command = std::mem::take(&mut pending);
            let command = command.trim();
            let Some(rest) = command
                .strip_prefix("translucent ")
                .or_else(|| command.strip_prefix("target/release/translucent "))
            else {
                continue;
            };
            // A trailing comment (`  # ...`) is not part of the command.
            let rest = rest.split(" #").next().unwrap_or(rest).trim();
            let why_not = if let Some(m) = block_marker.as_deref().filter(|m| m.starts_with("skip"))
            {
                Some(m.to_string())
            } else if rest.starts_with("view") {
                Some("needs a window (view_cli.rs runs it under Xvfb)".to_string())
            } else if rest.contains('[') || rest.contains('|') || rest.contains("...") {
                Some("a synopsis".to_string())
            } else {
                None
            };
            if let Some(why) = why_not {
                parsed.not_run.push(format!(
                    "README.md:{pending_line}: translucent {rest} ({why})"
                ));
                continue;
            }
            if rest.contains(['"', '\'', '$', '`', '<', '>', ';', '&']) {
                return Err(format!(
                    "README.md:{pending_line}: `translucent {rest}` uses shell syntax this test does not run; mark its block <!-- readme-test: skip REASON -->"
                ));
            }
            block.push(Example {
                line: pending_line,
                slow: block_marker.as_deref() == Some("slow"),
                args: rest.split_whitespace().map(str::to_string).collect(),
            });
        }
        if !block.is_empty() {
            parsed.run.push(block);
        }
    }
    Ok(parsed)
}

/// `args` with the CI sizes added where the command does not set them.
fn small(args: &[String]) -> Vec<String> {
    let mut out = args.to_vec();
    let has = |o: &str| {
        args.iter()
            .any(|a| a == o || a.starts_with(&format!("{o}=")))
    };
    let sub = args.first().map(String::as_str);
    if sub == Some("render") {
        for (o, v) in [("--width", "64"), ("--height", "64")] {
            if !has(o) {
                out.extend([o.to_string(), v.to_string()]);
            }
        }
    }
    // `render --graph FILE` takes the bake's options from the file (giving them is refused).
    if matches!(sub, Some("render" | "bake")) && !has("--graph") {
        for (o, v) in [("--resolution", "16"), ("--levels", "2")] {
            if !has(o) {
                out.extend([o.to_string(), v.to_string()]);
            }
        }
    }
    out
}

fn mesh_dir() -> PathBuf {
    std::env::var_os("TRANSLUCENT_MESH_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes"))
}

#[test]
fn the_parser_finds_commands_continuations_markers_and_synopses() {
    let readme = "text\n```sh\ntranslucent render --out a.png   # note\ntranslucent bake --shape torus \\\n    --levels 2\ncargo build\ntranslucent info [--json]\ntranslucent view\n```\n<!-- readme-test: skip needs a reference -->\n```\ntranslucent render --out b.png\n```\n<!-- readme-test: slow -->\n```bash\ntarget/release/translucent bench --out x\n```\n```rust\ntranslucent render --out c.png\n```\n";
    let parsed = parse(readme).expect("parses");
    let args: Vec<Vec<String>> = parsed
        .run
        .iter()
        .flatten()
        .map(|e| e.args.clone())
        .collect();
    assert_eq!(
        args,
        vec![
            vec!["render", "--out", "a.png"],
            vec!["bake", "--shape", "torus", "--levels", "2"],
            vec!["bench", "--out", "x"],
        ]
    );
    let slow: Vec<bool> = parsed.run.iter().flatten().map(|e| e.slow).collect();
    assert_eq!(slow, [false, false, true]);
    assert_eq!(parsed.run[0][1].line, 4);
    assert_eq!(parsed.not_run.len(), 3, "{:?}", parsed.not_run);
    assert!(parse("```sh\ntranslucent render --out \"a b.png\"\n```\n").is_err());
    assert_eq!(
        small(&["render".into(), "--width".into(), "8".into()]),
        [
            "render",
            "--width",
            "8",
            "--height",
            "64",
            "--resolution",
            "16",
            "--levels",
            "2"
        ]
    );
}

#[test]
fn every_readme_command_runs() {
    let readme_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../README.md");
    let readme = std::fs::read_to_string(&readme_path).expect("README.md");
    let parsed = parse(&readme).unwrap_or_else(|e| panic!("{e}"));
    let as_written = std::env::var_os("TRANSLUCENT_README_AS_WRITTEN").is_some();
    let slow = as_written || std::env::var_os("TRANSLUCENT_README_SLOW").is_some();
    let meshes = mesh_dir();
    if !meshes.is_dir() {
        assert!(
            std::env::var_os("CI").is_none(),
            "test meshes not found at {} (set TRANSLUCENT_MESH_DIR)",
            meshes.display()
        );
        eprintln!("skipped: no test meshes at {}", meshes.display());
        return;
    }
    // scratch/work is the working directory; scratch/shared/meshes -> the test meshes, so the
    // README's `../shared/meshes/X.obj` resolves; scratch/work/tests -> the repository's tests/.
    let scratch = common::scratch("readme");
    let work = scratch.join("work");
    let cache = scratch.join("cache");
    std::fs::create_dir_all(&work).expect("work dir");
    std::fs::create_dir_all(scratch.join("shared")).expect("shared dir");
    std::os::unix::fs::symlink(
        meshes.canonicalize().expect("mesh dir"),
        scratch.join("shared/meshes"),
    )
    .expect("link the meshes");
    // why: the README's commands run from the repository root; its read-only inputs under
    // `tests/` (the path-traced references, their .vol) resolve through a link.
    std::os::unix::fs::symlink(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests")
            .canonicalize()
            .expect("tests dir"),
        work.join("tests"),
    )
    .expect("link tests/");
    for note in &parsed.not_run {
        eprintln!("not run: {note}");
    }
    let mut ran = 0;
    for example in parsed.run.iter().flatten() {
        if example.slow && !slow {
            eprintln!(
                "not run: README.md:{}: translucent {} (slow: TRANSLUCENT_README_SLOW=1)",
                example.line,
                example.args.join(" ")
            );
            continue;
        }
        let args = if as_written {
            example.args.clone()
        } else {
            small(&example.args)
        };
        let started = std::time::Instant::now();
        let out = Command::new(env!("CARGO_BIN_EXE_translucent"))
            .args(&args)
            .current_dir(&work)
            .env("TRANSLUCENT_VALIDATION", "1")
            .env("TRANSLUCENT_DEVICE", "llvmpipe")
            .env("TRANSLUCENT_CACHE_DIR", &cache)
            .output()
            .expect("run the translucent binary");
        assert!(
            out.status.success(),
            "README.md:{}: `translucent {}` exited {:?}\nstdout: {}\nstderr: {}",
            example.line,
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        eprintln!(
            "ran README.md:{} in {:.1} s: translucent {}",
            example.line,
            started.elapsed().as_secs_f64(),
            args.join(" ")
        );
        ran += 1;
    }
    // The README has render, bake, volume and cache examples: finding none means the parse broke.
    assert!(ran >= 5, "only {ran} README commands ran");
    let _ = std::fs::remove_dir_all(&scratch);
}
