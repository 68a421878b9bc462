//! The bake cache on disk: `translucent cache info|clean`, the size limit and the one function
//! the commands that bake go through ([`bake`]: load or bake, mark used, evict the least
//! recently used bakes beyond the limit).
//!
//! ```text
//! translucent cache info                 # each bake, its size and when it was last used; the total
//! translucent cache clean                # removes every bake (and temporary files of crashed writes)
//! translucent cache clean --keep 500M    # removes least recently used bakes down to 500 MB
//! TRANSLUCENT_CACHE_LIMIT=1G translucent render ...   # the limit after each bake (default 2G)
//! ```

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use anyhow::{bail, Context as _};
use translucent::quadgraph::cache::{self, CacheEntry, CacheOutcome};
use translucent::quadgraph::{BakeParams, BakeStats};
use translucent::QuadGraph;

use crate::object_args::Object;

#[derive(clap::Args, Debug)]
pub struct CacheArgs {
    #[command(subcommand)]
    pub command: CacheCommand,
}

#[derive(clap::Subcommand, Debug)]
pub enum CacheCommand {
    /// Lists the cached bakes (least recently used first), their sizes and the total.
    Info {
        /// The cache directory (default: as `render`).
        #[arg(long, value_name = "DIR")]
        cache_dir: Option<PathBuf>,
        /// One JSON object instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Removes cached bakes: all of them, or with --keep the least recently used ones until
    /// the rest fit in SIZE.
    Clean {
        #[arg(long, value_name = "DIR")]
        cache_dir: Option<PathBuf>,
        /// Keep this much (bytes, or with a suffix K, M, G: 500M, 2G).
        #[arg(long, value_name = "SIZE")]
        keep: Option<String>,
    },
}

/// The environment variable holding the cache's size limit.
pub const LIMIT_VAR: &str = "TRANSLUCENT_CACHE_LIMIT";

/// A size in bytes: a number with an optional suffix K, M, G, T (powers of 1024), e.g. `500M`.
pub fn parse_size(text: &str) -> anyhow::Result<u64> {
    let t = text.trim();
    let (number, unit) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => (&t[..i], c.to_ascii_uppercase()),
        _ => (t, 'B'),
    };
    let scale: f64 = match unit {
        'B' => 1.0,
        'K' => 1024.0,
        'M' => 1024.0 * 1024.0,
        'G' => 1024.0 * 1024.0 * 1024.0,
        'T' => 1024.0 * 1024.0 * 1024.0 * 1024.0,
        _ => bail!("size {text:?}: the suffix must be K, M, G or T"),
    };
    let value: f64 = number
        .trim()
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite() && *v >= 0.0)
        .with_context(|| format!("size {text:?}: expected a number of bytes, e.g. 500M or 2G"))?;
    let bytes = value * scale;
    if bytes > u64::MAX as f64 {
        bail!("size {text:?}: too large");
    }
    Ok(bytes.round() as u64)
}

/// `bytes` for people: `63.2 MB` (powers of 1024, as the limit's suffixes).
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KB", "MB", "GB", "TB"];
    let mut v = bytes as f64;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{v:.1} {}", UNITS[unit])
    }
}

/// The size limit: `TRANSLUCENT_CACHE_LIMIT`, else [`cache::DEFAULT_LIMIT_BYTES`].
pub fn limit_bytes() -> anyhow::Result<u64> {
    match std::env::var(LIMIT_VAR) {
        Ok(v) if !v.trim().is_empty() => parse_size(&v).with_context(|| LIMIT_VAR.to_string()),
        _ => Ok(cache::DEFAULT_LIMIT_BYTES),
    }
}

/// The cache file of `object` baked with `params` in `dir`.
pub fn cache_file(dir: &Path, object: &Object, params: &BakeParams) -> PathBuf {
    let key = cache::cache_key(&object.surface, params);
    dir.join(format!("{}-{key:016x}.{}", object.name, cache::EXTENSION))
}

/// Loads the cached bake of `object` (or bakes and caches it) in `dir` (default: as `render`),
/// marks it used and evicts the least recently used bakes beyond [`limit_bytes`]. Returns the
/// graph, its stats, what happened and the cache file.
pub fn bake(
    object: &Object,
    params: &BakeParams,
    dir: Option<&Path>,
) -> anyhow::Result<(QuadGraph, BakeStats, CacheOutcome, PathBuf)> {
    let limit = limit_bytes()?;
    let dir = dir.map_or_else(crate::render::default_cache_dir, Path::to_path_buf);
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("creating the cache directory {}", dir.display()))?;
    let file = cache_file(&dir, object, params);
    // A progress line on a terminal (hidden otherwise): stage, level and the share of the stage
    // reports done so far (a bake of L levels reports 4L: tetrahedralize and graph per level,
    // links per level but the coarsest, shading once, packing per level).
    let bar = crate::progress::spinner();
    let mut reports = 0usize;
    let mut on_progress = |p: translucent::quadgraph::BakeProgress| {
        let done = reports as f64 / (4 * p.levels.max(1)) as f64;
        reports += 1;
        bar.set_message(format!(
            "baking {}: {} (level {} of {}), {:.0}%",
            object.name,
            p.stage,
            p.level + 1,
            p.levels,
            100.0 * done.min(0.99)
        ));
    };
    let baked = cache::bake_cached_lru(
        &file,
        &object.surface,
        object.solid.as_ref(),
        params,
        limit,
        &mut on_progress,
    );
    bar.finish_and_clear();
    let (graph, stats, outcome, evicted) = baked.map_err(|e| object.explain_bake_error(e))?;
    if let CacheOutcome::Rebuilt(reason) = &outcome {
        eprintln!("warning: {reason}; baked again");
    }
    if !evicted.is_empty() {
        let bytes: u64 = evicted.iter().map(|e| e.bytes).sum();
        eprintln!(
            "cache: removed {} least recently used bake(s), {} (limit {}, {LIMIT_VAR})",
            evicted.len(),
            human(bytes),
            human(limit)
        );
    }
    Ok((graph, stats, outcome, file))
}

/// The bounce links of `graph` ([`QuadGraph::bounce`]) built with `params`: kept when the graph
/// carries them (loaded with the bake), else built now and, with `store` (the cache file and its
/// key), written back with the bake so that the next command on this mesh casts no ray. Returns
/// the seconds it took and whether they were stored already.
pub fn bounce_links(
    graph: &mut QuadGraph,
    params: &translucent::frame::BounceParams,
    store: Option<(&Path, u64)>,
) -> anyhow::Result<(f64, bool)> {
    let start = std::time::Instant::now();
    let vertices = graph.surface.positions.len();
    if graph
        .bounce
        .as_ref()
        .is_some_and(|b| b.built_with(params) && b.vertex_count() == vertices)
    {
        return Ok((start.elapsed().as_secs_f64(), true));
    }
    graph.bounce = Some(translucent::frame::BounceLinks::build(
        &graph.surface,
        params,
    )?);
    if let Some((file, key)) = store {
        graph
            .save(file, key)
            .with_context(|| format!("storing the bounce links in {}", file.display()))?;
    }
    Ok((start.elapsed().as_secs_f64(), false))
}

/// How long ago `t` was, roughly.
fn ago(t: SystemTime) -> String {
    let s = SystemTime::now()
        .duration_since(t)
        .map_or(0, |d| d.as_secs());
    match s {
        0..=119 => format!("{s} s ago"),
        120..=7199 => format!("{} min ago", s / 60),
        7200..=172_799 => format!("{} h ago", s / 3600),
        _ => format!("{} days ago", s / 86_400),
    }
}

/// Temporary files a crashed cache write left (`.NAME.qgraph.tmp-PID`).
fn stray_temporaries(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let read = match std::fs::read_dir(dir) {
        Ok(r) => r,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e).with_context(|| dir.display().to_string()),
    };
    let mut out = Vec::new();
    for item in read {
        let path = item.with_context(|| dir.display().to_string())?.path();
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        if name.is_some_and(|n| n.starts_with('.') && n.contains(".qgraph.tmp-")) {
            out.push(path);
        }
    }
    Ok(out)
}

pub fn run(args: &CacheArgs) -> anyhow::Result<()> {
    match &args.command {
        CacheCommand::Info { cache_dir, json } => {
            let dir = cache_dir
                .clone()
                .unwrap_or_else(crate::render::default_cache_dir);
            let limit = limit_bytes()?;
            let all = cache::entries(&dir)?;
            let total: u64 = all.iter().map(|e| e.bytes).sum();
            if *json {
                let list: Vec<_> = all
                    .iter()
                    .map(|e: &CacheEntry| {
                        serde_json::json!({
                            "file": e.path.display().to_string(),
                            "bytes": e.bytes,
                            "last_used_unix_s": e.last_used
                                .duration_since(SystemTime::UNIX_EPOCH)
                                .map_or(0, |d| d.as_secs()),
                        })
                    })
                    .collect();
                let out = serde_json::json!({
                    "dir": dir.display().to_string(),
                    "entries": list,
                    "total_bytes": total,
                    "limit_bytes": limit,
                });
                println!("{out}");
                return Ok(());
            }
            println!(
                "cache {}: {} bake(s), {} (limit {}, {LIMIT_VAR})",
                dir.display(),
                all.len(),
                human(total),
                human(limit)
            );
            for e in &all {
                println!(
                    "  {:>12}  {:>10}  {}",
                    ago(e.last_used),
                    human(e.bytes),
                    e.path
                        .file_name()
                        .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
                );
            }
            Ok(())
        }
        CacheCommand::Clean { cache_dir, keep } => {
            let dir = cache_dir
                .clone()
                .unwrap_or_else(crate::render::default_cache_dir);
            let keep = keep
                .as_deref()
                .map(parse_size)
                .transpose()
                .context("--keep")?;
            let removed = cache::evict(&dir, keep.unwrap_or(0), None)?;
            let mut bytes: u64 = removed.iter().map(|e| e.bytes).sum();
            let mut count = removed.len();
            if keep.is_none() {
                for tmp in stray_temporaries(&dir)? {
                    bytes += std::fs::metadata(&tmp).map_or(0, |m| m.len());
                    std::fs::remove_file(&tmp)
                        .with_context(|| format!("removing {}", tmp.display()))?;
                    count += 1;
                }
            }
            let left: u64 = cache::entries(&dir)?.iter().map(|e| e.bytes).sum();
            println!(
                "cache {}: removed {count} file(s), {}; {} left",
                dir.display(),
                human(bytes),
                human(left)
            );
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_suffixes_and_bad_ones_name_the_text() {
        assert_eq!(parse_size("1024").expect("bytes"), 1024);
        assert_eq!(parse_size("2K").expect("k"), 2048);
        assert_eq!(parse_size("1.5m").expect("m"), 3 * 512 * 1024);
        assert_eq!(parse_size("2G").expect("g"), 2 << 30);
        assert_eq!(parse_size("0").expect("zero"), 0);
        for bad in ["", "M", "-1G", "5X", "nanM", "1e30T"] {
            let e = parse_size(bad).expect_err(bad);
            assert!(format!("{e:#}").contains(&format!("{bad:?}")), "{e:#}");
        }
        assert_eq!(human(512), "512 B");
        assert_eq!(human(3 << 20), "3.0 MB");
    }
}
