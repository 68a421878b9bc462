//! `--report FILE.json`: per frame what the overlay shows (the object's passes, the skipped passes
//! with their reasons, GPU ms per scope, iterations per level once the solve completed, the
//! actions applied), and the final scene as `translucent render` options. Written atomically
//! when the viewer exits.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Context as _;
use serde_json::{json, Value};
use translucent::FrameReport;

/// One frame of the report.
#[derive(Clone, Debug, Default)]
pub struct FrameEntry {
    /// The viewer's frame index (from 0, as in scripts).
    pub index: u64,
    /// The host frame number given to the object (from 1).
    pub host_frame: u64,
    pub extent: [u32; 2],
    pub actions: Vec<String>,
    pub passes: Vec<&'static str>,
    pub skipped: BTreeMap<&'static str, String>,
    pub warm_start: bool,
    /// GPU ms per scope in execution order (known once the frame completed).
    pub gpu_ms: Vec<(String, f64)>,
    /// Iterations per level of this frame's solve (known once it completed).
    pub iterations: Option<Vec<u32>>,
    /// The multigrid schedule's cycles and work units of this frame's solve (known once it
    /// completed; `None` with the cascade, whose counters are `iterations`).
    pub cycles: Option<usize>,
    pub work_units: Option<f64>,
    pub converged: Option<bool>,
    /// Wall-clock ms since the previous frame began recording (what a user feels: with two
    /// frames in flight it includes waiting for the GPU); `None` for the first frame.
    pub interval_ms: Option<f64>,
}

impl FrameEntry {
    pub fn from_report(
        index: u64,
        extent: [u32; 2],
        actions: Vec<String>,
        r: &FrameReport,
    ) -> Self {
        FrameEntry {
            index,
            host_frame: r.frame,
            extent,
            actions,
            passes: r.passes.clone(),
            skipped: r
                .skipped
                .iter()
                .map(|(pass, why)| (*pass, why.to_string()))
                .collect(),
            warm_start: r.warm_start,
            ..FrameEntry::default()
        }
    }

    fn json(&self) -> Value {
        json!({
            "frame": self.index,
            "host_frame": self.host_frame,
            "extent": self.extent,
            "actions": self.actions,
            "passes": self.passes,
            "skipped": self.skipped,
            "warm_start": self.warm_start,
            "gpu_ms": self.gpu_ms.iter().map(|(n, ms)| json!([n, ms])).collect::<Vec<_>>(),
            "iterations": self.iterations,
            "cycles": self.cycles,
            "work_units": self.work_units,
            "converged": self.converged,
            "interval_ms": self.interval_ms,
        })
    }
}

/// Every frame's entry, by host frame.
#[derive(Debug, Default)]
pub struct FrameLog {
    pub frames: BTreeMap<u64, FrameEntry>,
    /// How responsive the window stayed: the longest gap between two event-loop iterations
    /// after the first frame, and how often a frame waited for the GPU (set at exit).
    pub event_loop: Option<Value>,
    /// Each shader hot reload: frame, trigger, outcome, changed shaders, times.
    pub shader_reloads: Vec<Value>,
}

impl FrameLog {
    pub fn push(&mut self, entry: FrameEntry) {
        self.frames.insert(entry.host_frame, entry);
    }

    /// Files the timings of a completed frame.
    pub fn timings(&mut self, host_frame: u64, gpu_ms: Vec<(String, f64)>) {
        if let Some(e) = self.frames.get_mut(&host_frame) {
            e.gpu_ms = gpu_ms;
        }
    }

    /// Files a completed solve's counters.
    pub fn solve(&mut self, solve: &translucent::frame::CompletedSolve) {
        if let Some(e) = self.frames.get_mut(&solve.frame) {
            e.iterations = Some(solve.iterations());
            e.cycles = solve.multigrid.as_ref().map(|m| m.cycles.len());
            e.work_units = solve.multigrid.as_ref().map(|m| m.work_units);
            e.converged = Some(solve.converged());
        }
    }

    /// Writes the report: `device`, `frames`, `final` (the scene), `event_loop`,
    /// `shader_reloads` and `validation_messages`.
    pub fn write(
        &self,
        path: &Path,
        device: &str,
        final_scene: Value,
        validation_messages: usize,
    ) -> anyhow::Result<()> {
        let report = json!({
            "device": device,
            "frames": self.frames.values().map(FrameEntry::json).collect::<Vec<_>>(),
            "final": final_scene,
            "event_loop": self.event_loop,
            "shader_reloads": self.shader_reloads,
            "validation_messages": validation_messages,
        });
        let text = serde_json::to_string_pretty(&report)?;
        translucent::vk::capture::write_atomically(path, |tmp| {
            std::fs::write(tmp, text.as_bytes()).map_err(|e| e.to_string())
        })
        .with_context(|| format!("--report {}", path.display()))
    }
}
