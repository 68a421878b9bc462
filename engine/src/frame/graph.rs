//! [`FrameGraph`]: passes declare the resources they use and how; the graph records them in order,
//! places every barrier *between* passes from those declarations (synchronization2, one barrier
//! call per pass, each with a "why" generated from the declarations), opens one debug label and
//! one timestamp scope per pass under the pass's `&'static str` name, and says what ran and what
//! was skipped, and why. Barriers *inside* a pass (between Jacobi iterations, around a reduction)
//! stay the pass's job.
//!
//! Resources are ours ([`Use`]: an [`crate::vk::Image`] or [`crate::vk::Buffer`], whose layout
//! and last use the graph reads from and writes back to the resource, so the next frame's first
//! barrier knows what the last frame did) or imported from the host ([`FrameGraph::import`]: a
//! raw image in the state the host hands it over in, and the state it wants it back in).
//!
//! Passes run in the order they are added; a pass's declarations order it after every earlier
//! pass that touched the same resource (the graph checks that nothing is read before it was ever
//! written). A pass whose first use of a resource reads it in the state the last user left it in
//! gets no barrier for it.
//!
//! ```no_run
//! use translucent::frame::FrameGraph;
//! use translucent::vk::{barrier::Use, Access, Buffer, Context, Image};
//! # fn f(ctx: &Context, cb: ash::vk::CommandBuffer, q: &Image, phi: &Image) -> Result<(), translucent::Error> {
//! let mut graph = FrameGraph::new(ctx);
//! graph
//!     .pass("gather_q")
//!     .uses([Use::image(q, Access::ComputeWrite)])
//!     .record(|p| {
//!         // bind + push + dispatch writing q (no barriers: the graph places them)
//!         let _ = (p.ctx, p.cb);
//!         Ok(())
//!     });
//! graph
//!     .pass("diffusion")
//!     .uses([Use::image(q, Access::ComputeRead), Use::image(phi, Access::ComputeReadWrite)])
//!     .record(|p| {
//!         // the Jacobi iterations, with their own barriers between iterations
//!         let _ = p;
//!         Ok(())
//!     });
//! // SAFETY: `cb` is recording outside a rendering scope; q and phi outlive its execution.
//! let run = unsafe { graph.execute(cb, None, false)? };
//! assert_eq!(run.passes, ["gather_q", "diffusion"]);
//! // run.barriers[..].why: "q: diffusion reads (COMPUTE_SHADER) what gather_q wrote: RAW"
//! # Ok(()) }
//! ```

use std::borrow::Cow;

use ash::vk;

use super::report::SkipReason;
use crate::vk::barrier::{self, Resource, Tracked, Use, WRITE_ACCESS};
#[cfg(test)]
use crate::vk::Access;
use crate::vk::{Context, GpuProfiler, ImageState};
use crate::Error;

/// A resource registered with a [`FrameGraph`] (ours, or imported from the host).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ResourceId(usize);

/// What a pass's record closure gets: the command buffer and the profiler, for scopes nested
/// inside the pass (the graph has opened the pass's own label and scope).
pub struct PassCtx<'a> {
    pub ctx: &'a Context,
    pub cb: vk::CommandBuffer,
    profiler: Option<&'a mut GpuProfiler>,
}

impl PassCtx<'_> {
    /// The profiler, for a pass object's `record` that opens nested scopes.
    pub fn profiler(&mut self) -> Option<&mut GpuProfiler> {
        self.profiler.as_deref_mut()
    }

    /// Runs `f` inside a nested debug label and timestamp scope named `name`.
    ///
    /// # Safety
    /// `self.cb` is recording (it is, inside a pass).
    pub unsafe fn scope<R>(&mut self, name: &'static str, f: impl FnOnce(&mut Self) -> R) -> R {
        // SAFETY: the caller's contract.
        unsafe {
            self.ctx.begin_label(self.cb, name);
            if let Some(p) = self.profiler.as_deref_mut() {
                p.begin_scope(self.cb, name);
            }
            let out = f(self);
            if let Some(p) = self.profiler.as_deref_mut() {
                p.end_scope(self.cb);
            }
            self.ctx.end_label(self.cb);
            out
        }
    }
}

type Record<'g> = Box<dyn FnOnce(&mut PassCtx<'_>) -> Result<(), Error> + 'g>;

enum Kind<'g> {
    Ours(Resource<'g>),
    Host {
        raw: vk::Image,
        format: vk::Format,
        after: Option<ImageState>,
    },
}

struct Entry<'g> {
    name: Cow<'static, str>,
    kind: Kind<'g>,
    handle: u64,
    /// The working state while the graph records (written back to our resources at the end).
    state: Tracked,
    /// First use by a pass (for a host graph's barriers: [`GraphRun::imports`]).
    first_use: Option<ImageState>,
    last_use: Option<ImageState>,
}

struct Decl {
    id: ResourceId,
    first: ImageState,
    last: ImageState,
}

struct Pass<'g> {
    name: &'static str,
    decls: Vec<Decl>,
    record: Record<'g>,
}

/// Builds one pass of a [`FrameGraph`]: its declarations, then its recording.
pub struct PassBuilder<'a, 'g> {
    graph: &'a mut FrameGraph<'g>,
    name: &'static str,
    decls: Vec<Decl>,
}

impl<'g> PassBuilder<'_, 'g> {
    /// Our resources and how the pass uses them.
    pub fn uses(mut self, uses: impl IntoIterator<Item = Use<'g>>) -> Self {
        for u in uses {
            let id = self.graph.register(u.resource);
            self.decls.push(Decl {
                id,
                first: u.first.into(),
                last: u.last.into(),
            });
        }
        self
    }

    /// An imported (host) resource, used in `state` for the whole pass.
    pub fn host(mut self, id: ResourceId, state: impl Into<ImageState>) -> Self {
        let state = state.into();
        self.decls.push(Decl {
            id,
            first: state,
            last: state,
        });
        self
    }

    /// Adds the pass with what it records: bind + push + dispatch or draw, and barriers only
    /// between its own steps.
    pub fn record(self, record: impl FnOnce(&mut PassCtx<'_>) -> Result<(), Error> + 'g) {
        self.graph.passes.push(Pass {
            name: self.name,
            decls: self.decls,
            record: Box::new(record),
        });
    }
}

/// One barrier the graph placed, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BarrierNote {
    /// The pass it was recorded in front of (`"end of frame"` for the hand-back to the host).
    pub before: &'static str,
    pub resource: String,
    /// RAW, WAR, WAW and/or a layout change, e.g. `"WAR+layout GENERAL->TRANSFER_DST_OPTIMAL"`.
    pub hazard: String,
    /// The sentence recorded as a debug label beside the barrier.
    pub why: String,
}

/// How the recorded frame used an imported resource (for a host that places the boundary
/// barriers itself).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImportUse {
    pub name: String,
    /// The state the first pass using it needs (the host's barrier before us goes into it).
    pub first: ImageState,
    /// The state the last pass left it in (the host's barrier after us starts from it).
    pub last: ImageState,
}

/// What [`FrameGraph::execute`] recorded.
#[derive(Clone, Debug, Default)]
pub struct GraphRun {
    /// Passes recorded, in order.
    pub passes: Vec<&'static str>,
    /// Passes left out, each with why.
    pub skipped: Vec<(&'static str, SkipReason)>,
    /// Every barrier the graph placed, in order.
    pub barriers: Vec<BarrierNote>,
    /// The imported resources' first and last uses.
    pub imports: Vec<ImportUse>,
}

/// Why a frame could not be recorded as declared.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    #[error("frame graph: pass {pass:?} reads {resource:?}, which nothing has written (its contents are undefined)")]
    ReadsUndefined {
        pass: &'static str,
        resource: String,
    },
    #[error("frame graph: pass {pass:?} declares {resource:?} twice")]
    DeclaredTwice {
        pass: &'static str,
        resource: String,
    },
    #[error("frame graph: pass {pass:?} uses image {resource:?} in {state:?}, which has no image layout")]
    NoLayout {
        pass: &'static str,
        resource: String,
        state: ImageState,
    },
    #[error("frame graph: pass {pass:?}: {problem}")]
    Invalid { pass: &'static str, problem: String },
}

/// A frame's passes and the resources they use (see the module doc).
pub struct FrameGraph<'g> {
    ctx: &'g Context,
    entries: Vec<Entry<'g>>,
    passes: Vec<Pass<'g>>,
    skipped: Vec<(&'static str, SkipReason)>,
}

impl<'g> FrameGraph<'g> {
    pub fn new(ctx: &'g Context) -> FrameGraph<'g> {
        FrameGraph {
            ctx,
            entries: Vec::new(),
            passes: Vec::new(),
            skipped: Vec::new(),
        }
    }

    /// Imports a host image, handed over in `before` (its last use by the host: the graph's first
    /// barrier waits for it) and wanted back in `after` (`None`: left in our last use's state, for
    /// a host that places its own barriers).
    pub fn import(
        &mut self,
        name: impl Into<Cow<'static, str>>,
        image: vk::Image,
        format: vk::Format,
        before: ImageState,
        after: Option<ImageState>,
    ) -> ResourceId {
        use vk::Handle;
        let mut state = Tracked::after(before, "the host");
        // The host's last use may have been a read: waiting for its stage covers both cases.
        state.read_stage = before.stage;
        self.entries.push(Entry {
            name: name.into(),
            kind: Kind::Host {
                raw: image,
                format,
                after,
            },
            handle: image.as_raw(),
            state,
            first_use: None,
            last_use: None,
        });
        ResourceId(self.entries.len() - 1)
    }

    fn register(&mut self, resource: Resource<'g>) -> ResourceId {
        let handle = resource.handle();
        if let Some(i) = self
            .entries
            .iter()
            .position(|e| e.handle == handle && matches!(e.kind, Kind::Ours(_)))
        {
            return ResourceId(i);
        }
        self.entries.push(Entry {
            name: Cow::Borrowed(resource.name()),
            state: resource.tracked(),
            kind: Kind::Ours(resource),
            handle,
            first_use: None,
            last_use: None,
        });
        ResourceId(self.entries.len() - 1)
    }

    /// Starts a pass named `name` (its debug label and timestamp scope).
    pub fn pass<'a>(&'a mut self, name: &'static str) -> PassBuilder<'a, 'g> {
        PassBuilder {
            graph: self,
            name,
            decls: Vec::new(),
        }
    }

    /// Notes a pass left out of this frame, and why (reported, not recorded).
    pub fn skip(&mut self, name: &'static str, reason: SkipReason) {
        self.skipped.push((name, reason));
    }

    /// Names of the passes added so far, in order.
    pub fn pass_names(&self) -> Vec<&'static str> {
        self.passes.iter().map(|p| p.name).collect()
    }

    /// Records every pass into `cb` with the barriers between them, then hands imported
    /// resources back in their `after` states. With `host_barriers`, the host has put imported
    /// resources into the states of their first use and takes them in the state of their last
    /// (see [`GraphRun::imports`]): no barrier is recorded for them at the boundaries.
    ///
    /// On an error nothing is written back to the resources: the command buffer must not be
    /// submitted.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; every resource (ours and imported)
    /// must outlive its execution and be in the state the graph believes (the last frame's
    /// command buffers were submitted in order on this queue, imports in their `before` state).
    pub unsafe fn execute(
        mut self,
        cb: vk::CommandBuffer,
        mut profiler: Option<&mut GpuProfiler>,
        host_barriers: bool,
    ) -> Result<GraphRun, Error> {
        let ctx = self.ctx;
        let mut run = GraphRun {
            skipped: std::mem::take(&mut self.skipped),
            ..GraphRun::default()
        };
        let passes = std::mem::take(&mut self.passes);
        for pass in passes {
            let mut images = Vec::new();
            let mut buffers = Vec::new();
            let mut notes = Vec::new();
            for (i, d) in pass.decls.iter().enumerate() {
                if pass.decls[..i].iter().any(|e| e.id == d.id) {
                    return Err(FrameError::DeclaredTwice {
                        pass: pass.name,
                        resource: self.entries[d.id.0].name.to_string(),
                    }
                    .into());
                }
                let entry = &mut self.entries[d.id.0];
                let is_image = !matches!(entry.kind, Kind::Ours(Resource::Buffer(_)));
                if is_image && d.first.layout == vk::ImageLayout::UNDEFINED {
                    return Err(FrameError::NoLayout {
                        pass: pass.name,
                        resource: entry.name.to_string(),
                        state: d.first,
                    }
                    .into());
                }
                let writes = d.first.access.intersects(WRITE_ACCESS);
                if is_image && !writes && entry.state.layout == vk::ImageLayout::UNDEFINED {
                    return Err(FrameError::ReadsUndefined {
                        pass: pass.name,
                        resource: entry.name.to_string(),
                    }
                    .into());
                }
                let host_boundary = host_barriers
                    && matches!(entry.kind, Kind::Host { .. })
                    && entry.first_use.is_none();
                entry.first_use.get_or_insert(d.first);
                entry.last_use = Some(d.last);
                let dep = if host_boundary {
                    // The host put it into `first` itself.
                    entry.state = Tracked::after(d.first, "the host");
                    None
                } else {
                    dependency(&entry.state, d.first, is_image)
                };
                if let Some(dep) = &dep {
                    let why = format!(
                        "{}: {} {} in {:?} after {}{}: {}",
                        entry.name,
                        pass.name,
                        if writes { "writes" } else { "reads" },
                        d.first.stage,
                        if entry.state.writer.is_empty() {
                            "creation"
                        } else {
                            entry.state.writer
                        },
                        if entry.state.read_stage.is_empty() {
                            String::new()
                        } else {
                            " and earlier reads".into()
                        },
                        dep.hazard
                    );
                    match entry.kind {
                        Kind::Ours(Resource::Buffer(b)) => buffers.push(
                            vk::BufferMemoryBarrier2::default()
                                .src_stage_mask(dep.src_stage)
                                .src_access_mask(dep.src_access)
                                .dst_stage_mask(dep.dst_stage)
                                .dst_access_mask(dep.dst_access)
                                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                                .buffer(b.raw)
                                .offset(0)
                                .size(vk::WHOLE_SIZE),
                        ),
                        Kind::Ours(Resource::Image(img)) => {
                            images.push(image_dep(img.raw, img.format, dep))
                        }
                        Kind::Host { raw, format, .. } => images.push(image_dep(raw, format, dep)),
                    }
                    notes.push(BarrierNote {
                        before: pass.name,
                        resource: entry.name.to_string(),
                        hazard: dep.hazard.clone(),
                        why,
                    });
                }
                entry.state = after_pass(entry.state, d, dep.is_some(), pass.name, is_image);
            }
            let mut pc = PassCtx {
                ctx,
                cb,
                profiler: profiler.as_deref_mut(),
            };
            // SAFETY: the caller's contract: `cb` is recording outside a rendering scope.
            unsafe {
                if !images.is_empty() || !buffers.is_empty() {
                    if ctx.labels_enabled() {
                        let text: Vec<&str> = notes.iter().map(|n| n.why.as_str()).collect();
                        ctx.insert_label(cb, &format!("why: {}", text.join("; ")));
                    }
                    // why: the hazards listed in `notes` (generated from the declarations).
                    ctx.raw().cmd_pipeline_barrier2(
                        cb,
                        &vk::DependencyInfo::default()
                            .image_memory_barriers(&images)
                            .buffer_memory_barriers(&buffers),
                    );
                }
                run.barriers.append(&mut notes);
                let result = pc.scope(pass.name, |pc| (pass.record)(pc));
                result?;
            }
            run.passes.push(pass.name);
        }
        // Hand imported resources back; write our resources' states back.
        let mut images = Vec::new();
        for entry in &self.entries {
            match &entry.kind {
                Kind::Ours(r) => r.set_tracked(entry.state),
                Kind::Host { raw, format, after } => {
                    if let (Some(first), Some(last)) = (entry.first_use, entry.last_use) {
                        run.imports.push(ImportUse {
                            name: entry.name.to_string(),
                            first,
                            last,
                        });
                    }
                    let Some(after) = after.filter(|_| !host_barriers) else {
                        continue;
                    };
                    let to = after;
                    let mut state = entry.state;
                    // Whatever the host does next, it must wait for our last use.
                    state.read_stage |= state.visible_stage;
                    let dep = Dependency {
                        src_stage: state.write_stage | state.read_stage,
                        src_access: state.write_access,
                        dst_stage: to.stage,
                        dst_access: to.access,
                        old_layout: state.layout,
                        new_layout: to.layout,
                        hazard: "hand-back".into(),
                    };
                    images.push(image_dep(*raw, *format, &dep));
                    run.barriers.push(BarrierNote {
                        before: "end of frame",
                        resource: entry.name.to_string(),
                        hazard: dep.hazard.clone(),
                        why: format!(
                            "{}: handed back to the host in {:?} after {}",
                            entry.name, to.layout, state.writer
                        ),
                    });
                }
            }
        }
        if !images.is_empty() {
            // SAFETY: the caller's contract.
            unsafe {
                // why: the host's next use of its images waits for our last use of them, in the
                // layouts it asked for.
                barrier::record(ctx, cb, &[], &images);
            }
        }
        Ok(run)
    }
}

/// A dependency between the tracked last use and a new first use.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Dependency {
    src_stage: vk::PipelineStageFlags2,
    src_access: vk::AccessFlags2,
    dst_stage: vk::PipelineStageFlags2,
    dst_access: vk::AccessFlags2,
    old_layout: vk::ImageLayout,
    new_layout: vk::ImageLayout,
    hazard: String,
}

fn image_dep(
    raw: vk::Image,
    format: vk::Format,
    d: &Dependency,
) -> vk::ImageMemoryBarrier2<'static> {
    barrier::raw_image_barrier(
        raw,
        format,
        ImageState {
            stage: d.src_stage,
            access: d.src_access,
            layout: d.old_layout,
        },
        ImageState {
            stage: d.dst_stage,
            access: d.dst_access,
            layout: d.new_layout,
        },
    )
}

/// The barrier a first use in `first` needs after `state`, if any.
fn dependency(state: &Tracked, first: ImageState, is_image: bool) -> Option<Dependency> {
    let writes = first.access.intersects(WRITE_ACCESS);
    let layout_change = is_image && state.layout != first.layout;
    let mut hazards = Vec::new();
    if writes || layout_change {
        if !state.read_stage.is_empty() && writes {
            hazards.push("WAR".to_string());
        }
        if !state.write_stage.is_empty() {
            hazards.push(if writes { "WAW" } else { "RAW" }.to_string());
        }
        if layout_change {
            hazards.push(format!("layout {:?}->{:?}", state.layout, first.layout));
        }
        if hazards.is_empty() {
            // First use ever of a buffer: nothing to wait for.
            return None;
        }
        return Some(Dependency {
            src_stage: state.write_stage | state.read_stage | state.visible_stage,
            src_access: state.write_access,
            dst_stage: first.stage,
            dst_access: first.access,
            old_layout: if is_image {
                state.layout
            } else {
                vk::ImageLayout::UNDEFINED
            },
            new_layout: if is_image {
                first.layout
            } else {
                vk::ImageLayout::UNDEFINED
            },
            hazard: hazards.join("+"),
        });
    }
    // A read in the current layout: only the last write matters, unless already made visible here.
    let covered =
        state.visible_stage.contains(first.stage) && state.visible_access.contains(first.access);
    if state.write_stage.is_empty() || covered {
        return None;
    }
    Some(Dependency {
        src_stage: state.write_stage,
        src_access: state.write_access,
        dst_stage: first.stage,
        dst_access: first.access,
        old_layout: state.layout,
        new_layout: state.layout,
        hazard: "RAW".into(),
    })
}

/// The tracked state after a pass declared `d` (and the graph placed a barrier if `barrier`).
fn after_pass(
    state: Tracked,
    d: &Decl,
    barrier: bool,
    pass: &'static str,
    is_image: bool,
) -> Tracked {
    let writes = (d.first.access | d.last.access).intersects(WRITE_ACCESS);
    let transition = d.first != d.last || (is_image && state.layout != d.first.layout);
    let layout = if is_image {
        d.last.layout
    } else {
        vk::ImageLayout::UNDEFINED
    };
    if writes || transition {
        // A write (or a layout change, which is one): nothing after it sees it yet, except the
        // stages of a read-only last use that the barrier itself made it visible to.
        let read_only_last = !d.last.access.intersects(WRITE_ACCESS);
        Tracked {
            layout,
            write_stage: d.first.stage | d.last.stage,
            write_access: (d.first.access | d.last.access) & WRITE_ACCESS,
            visible_stage: if read_only_last && !writes {
                d.last.stage
            } else {
                vk::PipelineStageFlags2::NONE
            },
            visible_access: if read_only_last && !writes {
                d.last.access
            } else {
                vk::AccessFlags2::NONE
            },
            read_stage: if read_only_last {
                d.last.stage
            } else {
                vk::PipelineStageFlags2::NONE
            },
            writer: pass,
        }
    } else {
        let mut s = state;
        if barrier {
            s.visible_stage |= d.first.stage;
            s.visible_access |= d.first.access;
        }
        s.read_stage |= d.first.stage;
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vk::AccessFlags2 as A;
    use vk::PipelineStageFlags2 as S;

    fn decl(first: Access, last: Access) -> Decl {
        Decl {
            id: ResourceId(0),
            first: first.into(),
            last: last.into(),
        }
    }

    #[test]
    fn a_read_after_a_write_waits_for_it_once() {
        let s = after_pass(
            Tracked::UNUSED,
            &decl(Access::ComputeWrite, Access::ComputeWrite),
            false,
            "writer",
            true,
        );
        let d = dependency(&s, Access::ComputeRead.into(), true).expect("RAW");
        assert_eq!(d.hazard, "RAW");
        assert_eq!(
            (d.src_stage, d.src_access),
            (S::COMPUTE_SHADER, A::SHADER_STORAGE_WRITE)
        );
        let s = after_pass(
            s,
            &decl(Access::ComputeRead, Access::ComputeRead),
            true,
            "r1",
            true,
        );
        // A second reader in the same stage needs nothing more.
        assert!(dependency(&s, Access::ComputeRead.into(), true).is_none());
        // A reader in another stage does.
        let v = dependency(&s, Access::VertexInput.into(), false).expect("RAW for vertex input");
        assert_eq!(v.dst_stage, S::VERTEX_INPUT);
    }

    #[test]
    fn a_write_after_reads_waits_for_the_readers() {
        let s = after_pass(
            Tracked::UNUSED,
            &decl(Access::ComputeWrite, Access::ComputeWrite),
            false,
            "w",
            false,
        );
        let s = after_pass(
            s,
            &decl(Access::VertexInput, Access::VertexInput),
            true,
            "draw",
            false,
        );
        let d = dependency(&s, Access::ComputeWrite.into(), false).expect("WAR");
        assert!(d.hazard.contains("WAR"), "{}", d.hazard);
        assert!(d.src_stage.contains(S::VERTEX_INPUT));
    }

    #[test]
    fn layout_changes_are_barriers_even_for_reads() {
        let s = after_pass(
            Tracked::UNUSED,
            &decl(Access::DepthAttachmentWrite, Access::DepthAttachmentWrite),
            false,
            "shadow_map",
            true,
        );
        let d = dependency(&s, Access::DepthSampledShaders.into(), true).expect("layout");
        assert!(
            d.hazard.contains("RAW") && d.hazard.contains("layout"),
            "{}",
            d.hazard
        );
        assert_eq!(d.new_layout, vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL);
        let s = after_pass(
            s,
            &decl(Access::DepthSampledShaders, Access::DepthSampledShaders),
            true,
            "gather_q",
            true,
        );
        // The gather and the shading both sample it: the second needs no barrier.
        assert!(dependency(&s, Access::DepthSampledShaders.into(), true).is_none());
        // Next frame's shadow pass writes it again: WAR and a layout change.
        let w = dependency(&s, Access::DepthAttachmentWrite.into(), true).expect("WAR");
        assert!(
            w.hazard.contains("WAR") && w.hazard.contains("layout"),
            "{}",
            w.hazard
        );
    }

    #[test]
    fn a_first_buffer_write_needs_nothing_and_a_first_image_use_a_layout() {
        assert!(dependency(&Tracked::UNUSED, Access::ComputeWrite.into(), false).is_none());
        let d = dependency(&Tracked::UNUSED, Access::ComputeWrite.into(), true).expect("layout");
        assert_eq!(d.old_layout, vk::ImageLayout::UNDEFINED);
    }
}
