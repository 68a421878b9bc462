//! GPU profiler: named, nestable timestamp scopes, read back without stalling.
//!
//! Each frame in flight has its own slot of queries. A frame's results are read when the host
//! reports the frame complete ([`GpuProfiler::frame_completed`]) or, at the latest, when its slot
//! comes round again in [`GpuProfiler::begin_frame`]; results never make the CPU wait. Where the
//! queue has no timestamps (`timestampValidBits == 0` or `timestampComputeAndGraphics` false) the
//! profiler switches itself off and every call is a no-op.
//!
//! ```no_run
//! # use translucent::vk::{Context, GpuProfiler};
//! # fn f(ctx: &Context, cb: ash::vk::CommandBuffer) -> Result<(), translucent::vk::VkError> {
//! let mut profiler = GpuProfiler::new(ctx, "frame", 64)?;
//! // SAFETY: `cb` is recording outside a rendering scope.
//! unsafe {
//!     profiler.begin_frame(cb, 1);
//!     profiler.begin_scope(cb, "shading");
//!     // ... record the pass ...
//!     profiler.end_scope(cb);
//! }
//! // ... after the host knows frame 1 finished:
//! profiler.frame_completed(1);
//! if let Some(t) = profiler.latest() { println!("{:?}", t.passes()); }
//! # Ok(()) }
//! ```

use std::collections::BTreeMap;
use std::sync::Arc;

use ash::vk;

use super::device::{Device, Retired};
use super::{Context, VkError};

/// One timed scope of a frame.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ScopeTiming {
    pub name: String,
    /// Nesting depth (0 for a top-level pass).
    pub depth: u32,
    /// Start relative to the frame's first timestamp, in ms.
    pub start_ms: f64,
    pub duration_ms: f64,
}

/// The timings of one frame.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FrameTimings {
    pub frame: u64,
    pub scopes: Vec<ScopeTiming>,
}

impl FrameTimings {
    /// Milliseconds per pass name (scopes of the same name summed).
    pub fn passes(&self) -> BTreeMap<String, f64> {
        let mut out = BTreeMap::new();
        for s in &self.scopes {
            *out.entry(s.name.clone()).or_insert(0.0) += s.duration_ms;
        }
        out
    }

    /// The frames as a Chrome trace (`chrome://tracing`, Perfetto): complete events in microseconds.
    pub fn chrome_trace(frames: &[FrameTimings]) -> serde_json::Value {
        let mut events = Vec::new();
        let mut offset_ms = 0.0;
        for f in frames {
            let mut end = 0.0f64;
            for s in &f.scopes {
                events.push(serde_json::json!({
                    "name": s.name, "cat": "gpu", "ph": "X", "pid": 0, "tid": 0,
                    "ts": (offset_ms + s.start_ms) * 1000.0, "dur": s.duration_ms * 1000.0,
                    "args": { "frame": f.frame, "depth": s.depth },
                }));
                end = end.max(s.start_ms + s.duration_ms);
            }
            offset_ms += end;
        }
        serde_json::json!({ "traceEvents": events, "displayTimeUnit": "ms" })
    }
}

struct Scope {
    name: &'static str,
    depth: u32,
    begin: u32,
    end: Option<u32>,
}

#[derive(Default)]
struct Slot {
    frame: Option<u64>,
    scopes: Vec<Scope>,
    used: u32,
}

/// Timestamp scopes per frame in flight.
pub struct GpuProfiler {
    device: Arc<Device>,
    pool: vk::QueryPool,
    enabled: bool,
    period_ns: f64,
    valid_mask: u64,
    queries_per_slot: u32,
    slots: Vec<Slot>,
    current: Option<usize>,
    /// The open scopes, innermost last (`None`: a scope dropped for lack of queries, so its
    /// `end_scope` closes nothing else).
    open: Vec<Option<usize>>,
    completed: u64,
    results: Vec<FrameTimings>,
}

impl GpuProfiler {
    /// A profiler with room for `max_scopes` scopes per frame, one slot per frame in flight.
    pub fn new(ctx: &Context, name: &'static str, max_scopes: u32) -> Result<GpuProfiler, VkError> {
        Self::with_timestamps(ctx, name, max_scopes, true)
    }

    /// A profiler whose calls all do nothing (what [`GpuProfiler::new`] gives on a device without
    /// timestamps); for hosts that want no queries.
    pub fn disabled(ctx: &Context, name: &'static str) -> Result<GpuProfiler, VkError> {
        Self::with_timestamps(ctx, name, 1, false)
    }

    fn with_timestamps(
        ctx: &Context,
        name: &'static str,
        max_scopes: u32,
        wanted: bool,
    ) -> Result<GpuProfiler, VkError> {
        let slots = ctx.frames_in_flight() as usize;
        let queries_per_slot = max_scopes.max(1) * 2;
        let (family, _) = ctx.queue();
        // SAFETY: plain query.
        let families = unsafe {
            ctx.device
                .handles
                .instance()
                .get_physical_device_queue_family_properties(ctx.physical_device())
        };
        let valid_bits = families
            .get(family as usize)
            .map_or(0, |f| f.timestamp_valid_bits);
        let enabled = wanted && ctx.info().timestamps && valid_bits > 0;
        let mut pool = vk::QueryPool::null();
        if enabled {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(queries_per_slot * slots as u32);
            // SAFETY: valid create info on a live device.
            pool = unsafe { ctx.raw().create_query_pool(&info, None) }
                .map_err(VkError::call("vkCreateQueryPool"))?;
            ctx.set_name(pool, name);
        }
        Ok(GpuProfiler {
            device: ctx.device.clone(),
            pool,
            enabled,
            period_ns: f64::from(ctx.limits().timestamp_period),
            valid_mask: if valid_bits >= 64 {
                u64::MAX
            } else {
                (1u64 << valid_bits) - 1
            },
            queries_per_slot,
            slots: (0..slots).map(|_| Slot::default()).collect(),
            current: None,
            open: Vec::new(),
            completed: 0,
            results: Vec::new(),
        })
    }

    /// Whether timestamps are supported (otherwise every call does nothing).
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Starts `frame`: reads the results of the frame that last used this slot, resets it.
    ///
    /// # Safety
    /// `cb` must be recording, outside a rendering scope. The frame that used this slot
    /// `frames_in_flight` frames ago must have completed (the usual frames-in-flight contract).
    pub unsafe fn begin_frame(&mut self, cb: vk::CommandBuffer, frame: u64) {
        if !self.enabled {
            return;
        }
        let index = (frame % self.slots.len() as u64) as usize;
        self.read_slot(index, true);
        self.slots[index] = Slot {
            frame: Some(frame),
            scopes: Vec::new(),
            used: 0,
        };
        self.current = Some(index);
        self.open.clear();
        // SAFETY: the caller guarantees `cb` is recording outside rendering; the range is this slot's.
        unsafe {
            self.device.raw().cmd_reset_query_pool(
                cb,
                self.pool,
                index as u32 * self.queries_per_slot,
                self.queries_per_slot,
            )
        };
    }

    /// Opens a scope named `name` (nested inside the open one, if any).
    ///
    /// # Safety
    /// `cb` must be the recording command buffer given to `begin_frame`.
    pub unsafe fn begin_scope(&mut self, cb: vk::CommandBuffer, name: &'static str) {
        let Some(index) = self.current.filter(|_| self.enabled) else {
            return;
        };
        let slot = &mut self.slots[index];
        if slot.used + 2 > self.queries_per_slot {
            // Out of queries: the scope is dropped from the results; its end closes nothing.
            self.open.push(None);
            return;
        }
        let query = index as u32 * self.queries_per_slot + slot.used;
        slot.used += 2;
        slot.scopes.push(Scope {
            name,
            depth: self.open.len() as u32,
            begin: query,
            end: None,
        });
        self.open.push(Some(slot.scopes.len() - 1));
        // SAFETY: `cb` is recording; the query was reset in `begin_frame`.
        unsafe {
            self.device.raw().cmd_write_timestamp2(
                cb,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                query,
            )
        };
    }

    /// Closes the scope opened last.
    ///
    /// # Safety
    /// As [`GpuProfiler::begin_scope`].
    pub unsafe fn end_scope(&mut self, cb: vk::CommandBuffer) {
        let Some(index) = self.current.filter(|_| self.enabled) else {
            return;
        };
        let Some(Some(scope)) = self.open.pop() else {
            return;
        };
        let scope = &mut self.slots[index].scopes[scope];
        let query = scope.begin + 1;
        scope.end = Some(query);
        // SAFETY: as in `begin_scope`.
        unsafe {
            self.device.raw().cmd_write_timestamp2(
                cb,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                query,
            )
        };
    }

    /// The host reports every frame up to `completed` done: reads their results.
    pub fn frame_completed(&mut self, completed: u64) {
        self.completed = self.completed.max(completed);
        for index in 0..self.slots.len() {
            if self.slots[index].frame.is_some_and(|f| f <= self.completed) {
                self.read_slot(index, false);
            }
        }
    }

    /// Results of the most recent frame read back.
    pub fn latest(&self) -> Option<&FrameTimings> {
        self.results.last()
    }

    /// Takes all frames read back so far, oldest first.
    pub fn take_results(&mut self) -> Vec<FrameTimings> {
        std::mem::take(&mut self.results)
    }

    fn read_slot(&mut self, index: usize, slot_reused: bool) {
        let slot = &mut self.slots[index];
        let Some(frame) = slot.frame else { return };
        let closed: Vec<&Scope> = slot.scopes.iter().filter(|s| s.end.is_some()).collect();
        if closed.is_empty() {
            slot.frame = None;
            return;
        }
        let first = index as u32 * self.queries_per_slot;
        let mut raw = vec![0u64; slot.used as usize];
        // SAFETY: the queries of this slot were reset and written by a submitted frame; without
        // WAIT the call returns NOT_READY instead of blocking if they are not available yet.
        let read = unsafe {
            self.device.raw().get_query_pool_results(
                self.pool,
                first,
                &mut raw,
                vk::QueryResultFlags::TYPE_64,
            )
        };
        if read.is_err() {
            if slot_reused {
                slot.frame = None; // the frame's results are lost rather than stalling the CPU.
            }
            return;
        }
        let t0 = closed
            .iter()
            .map(|s| raw[(s.begin - first) as usize] & self.valid_mask)
            .min()
            .unwrap_or(0);
        let to_ms = |ticks: u64| ticks as f64 * self.period_ns * 1e-6;
        let scopes = closed
            .iter()
            .filter_map(|s| {
                let b = raw[(s.begin - first) as usize] & self.valid_mask;
                let e = raw[(s.end? - first) as usize] & self.valid_mask;
                Some(ScopeTiming {
                    name: s.name.to_string(),
                    depth: s.depth,
                    start_ms: to_ms(b.saturating_sub(t0)),
                    duration_ms: to_ms(e.saturating_sub(b)),
                })
            })
            .collect();
        slot.frame = None;
        self.results.push(FrameTimings { frame, scopes });
        if self.results.len() > 256 {
            self.results.remove(0);
        }
    }
}

impl Drop for GpuProfiler {
    fn drop(&mut self) {
        if self.enabled {
            self.device.retire(Retired::QueryPool(self.pool));
        }
    }
}
