//! Nothing is lost (issue 17): a `translucent bake` killed (SIGKILL) at any point of its bake or of
//! its cache write leaves the old cache entry or none, never a partial file under the real name; the
//! next command loads it or rebuilds it for a reason that is not corruption. And a render that fails
//! late (after the frames are rendered) leaves an existing output image untouched.

mod common;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::{json_of, scratch, translucent};
use translucent::QuadGraph;

/// Bakes large enough (a few MB, one fsync) that a kill can land inside the write.
const BAKE: [&str; 6] = ["--shape", "sphere", "--resolution", "24", "--levels", "2"];

fn spawn_bake(dir: &Path, extra: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_translucent"))
        .arg("bake")
        .args(BAKE)
        .args(extra)
        .args(["--out", "s.qgraph"])
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn translucent bake")
}

/// The temporary files a writer leaves next to `s.qgraph` (`.s.qgraph.tmp-PID`).
fn temporaries(dir: &Path) -> Vec<std::path::PathBuf> {
    std::fs::read_dir(dir)
        .expect("read the scratch dir")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with(".s.qgraph.tmp-"))
        })
        .collect()
}

/// What a later `bake` made of the cache: `loaded`, `baked` or `rebuilt: REASON`.
fn next_outcome(dir: &Path, extra: &[&str]) -> String {
    let cache = dir.join("s.qgraph");
    let mut args = vec!["bake"];
    args.extend(BAKE);
    args.extend(extra);
    args.extend(["--out", cache.to_str().expect("utf-8"), "--json"]);
    let v = json_of(&translucent(&args, dir));
    v["cache_outcome"]
        .as_str()
        .expect("cache_outcome")
        .to_string()
}

#[test]
fn a_bake_killed_at_any_point_leaves_the_old_cache_entry_or_none() {
    let dir = scratch("kill");
    let cache = dir.join("s.qgraph");
    // The old entry: the default K. Every killed run bakes K = 0, so it rewrites the file.
    let mut first = spawn_bake(&dir, &[]);
    assert!(first.wait().expect("first bake").success());
    let old = std::fs::read(&cache).expect("the old entry");
    let mut mid_write = 0;
    let mut mid_bake = 0;
    // Kill delays: from the start of the process (during the bake) and from the moment the
    // temporary file appears (during the write and its fsync).
    let during_bake_ms = [5u64, 30, 80, 150, 300];
    let during_write_us = [0u64, 100, 300, 1000, 2000, 4000, 8000, 15000, 30000, 60000];
    for (round, &(after_temp, delay)) in during_bake_ms
        .iter()
        .map(|&ms| (false, ms * 1000))
        .chain(during_write_us.iter().map(|&us| (true, us)))
        .collect::<Vec<_>>()
        .iter()
        .enumerate()
    {
        let mut child = spawn_bake(&dir, &["-K", "0"]);
        let start = Instant::now();
        if after_temp {
            // Wait for this child's temporary file, or its end.
            while temporaries(&dir).is_empty() && child.try_wait().expect("poll").is_none() {
                assert!(
                    start.elapsed() < Duration::from_secs(120),
                    "round {round}: no write seen"
                );
                std::thread::sleep(Duration::from_micros(100));
            }
        }
        std::thread::sleep(Duration::from_micros(delay));
        let writing = !temporaries(&dir).is_empty();
        let running = child.try_wait().expect("poll").is_none();
        let _ = child.kill();
        let _ = child.wait();
        if running && writing {
            mid_write += 1;
        } else if running {
            mid_bake += 1;
        }
        // The real name holds the old entry, a complete new one, or nothing.
        if let Ok(bytes) = std::fs::read(&cache) {
            if bytes != old {
                QuadGraph::load(&cache, None).unwrap_or_else(|e| {
                    panic!("round {round}: a partial cache file under the real name: {e}")
                });
            }
        }
        // The next command loads it or rebuilds it because it is stale, never because it is
        // corrupt (truncated, checksum, magic, content).
        let outcome = next_outcome(&dir, &["-K", "0"]);
        assert!(
            outcome == "loaded" || outcome == "baked" || outcome.contains("stale"),
            "round {round}: {outcome}"
        );
        // Leftovers of the killed writer are its own temporary files, never read by anyone.
        for tmp in temporaries(&dir) {
            let _ = std::fs::remove_file(tmp);
        }
        std::fs::write(&cache, &old).expect("restore the old entry");
    }
    println!("killed {mid_bake} times while baking, {mid_write} times while writing");
    // The kills must really have landed where they were meant to (else the test proves nothing).
    assert!(mid_bake >= 3, "only {mid_bake} kills during the bake");
    assert!(mid_write >= 3, "only {mid_write} kills during the write");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_render_that_fails_late_leaves_the_existing_output_untouched() {
    let dir = scratch("late-failure");
    let out = dir.join("keep.png");
    let before = b"not really a PNG, but the user's file".to_vec();
    std::fs::write(&out, &before).expect("write the existing output");
    // The trace is written after every frame was rendered and before the image: a trace path in
    // a missing directory fails there, after the GPU work.
    let trace = dir.join("no-such-dir").join("t.json");
    let o = translucent(
        &[
            "render",
            "--shape",
            "sphere",
            "--resolution",
            "8",
            "--levels",
            "1",
            "--width",
            "16",
            "--height",
            "16",
            "--trace",
            trace.to_str().expect("utf-8"),
            "--out",
            out.to_str().expect("utf-8"),
        ],
        &dir,
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("--trace"), "{stderr}");
    assert_eq!(
        std::fs::read(&out).expect("the output is still there"),
        before
    );
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .expect("read dir")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
