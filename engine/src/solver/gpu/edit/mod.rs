//! Live edits of a [`GpuFrame`] / [`GpuDiffusion`] without a re-bake (paper section 6.4; DESIGN
//! sections 4 and 5): a new material (homogeneous or heterogeneous) and a deformation of the
//! object. Both only stage data on the CPU side; the GPU work is recorded in front of the next
//! solve ([`GpuDiffusion::record_edits`], called by [`GpuFrame::record`] before the shadow and
//! gather passes and by [`GpuDiffusion::record`]), so a host that records into its own command
//! buffers never sees a submission of ours.
//!
//! Material ([`GpuDiffusion::set_material`]):
//! - homogeneous: push constants only (kappa, mu, 2A, q_gain) and the `HOMOGENEOUS = true`
//!   pipelines; nothing is uploaded, no per-node material exists on the GPU.
//! - heterogeneous: kappa and mu sampled at the rest-pose node positions (CPU, validated, a typed
//!   error naming the node), uploaded per level (2 x RGBA32F), then `edit/derive_weights.comp`
//!   rebuilds the per-channel Jacobi weights from the geometric factors (harmonic face kappa for
//!   fv). Switching kinds back and forth just picks the other pipeline variant; the heterogeneous
//!   textures, once created, stay (memory is flat across switches).
//!
//! Deformation ([`GpuDiffusion::deform`], [`GpuFrame::deform`]), per level, on the GPU:
//! 1. tetrahedron vertices: `edit/map_vertices.comp` evaluates `Affine` / `Twist` on the rest
//!    pose; `TetPositions` are uploaded;
//! 2. `edit/deform_nodes.comp`: every node at its barycentric coordinates in its rest tetrahedron
//!    (exact for affine maps), surface normals through that tetrahedron's F^-T, written to the
//!    gather's `surface_position` / `surface_normal`;
//! 3. `edit/deform_geometry.comp`: A_f, V_i, d_ij, delta and d_sk in fp32 -> the geometric
//!    factors;
//! 4. heterogeneous: the weights again (the material path's derivation).
//!
//! The display and shadow-caster meshes (`meshes`) follow through `edit/deform_mesh.comp`: each
//! vertex at barycentric coordinates in the finest-level tetrahedron under its first shading link,
//! normal by F^-T, copied into the mesh's vertex buffer (position and normal only; the exitance
//! stays the solve's). `Identity` restores the baked geometry bit for bit (uploads of the rest
//! texels, not a recomputation). What stays at rest: the Shepard links between levels and the
//! shading weights (their topology and weights are those of the rest pose; for moderate
//! deformations they remain a partition of unity over the same neighbours).
//!
//! Degenerate input: an affine map with det <= 1e-6 |M|^3 (flattening or mirroring), a non-finite
//! value, or `TetPositions` giving any tetrahedron a volume <= 0 is a typed error, and nothing
//! changes. Past those checks the GPU clamps volumes and distances (1e-9 h^3, 1e-6 h for lattice
//! spacing h) so fp32 rounding of a nearly flat tetrahedron cannot produce Inf or NaN.
//!
//! ```no_run
//! # use translucent::solver::gpu::Deformation;
//! # fn f(ctx: &translucent::vk::Context, object: &mut translucent::TranslucentObject,
//! #      jade: &translucent::material::MaterialField) -> Result<(), translucent::Error> {
//! object.set_material(ctx, jade)?; // validated now; uploaded by the next frame's "edits" pass
//! object.deform(ctx, &Deformation::Twist { radians_per_mm: 0.02 })?;
//! // ... record the frame; later:
//! object.deform(ctx, &Deformation::Identity)?; // back to the baked shape
//! # Ok(()) }
//! ```

use std::sync::Arc;

use ash::vk;
use glam::DVec3;

use super::{raw_barrier, GpuDiffusion, GpuLevel};
use crate::mesh::{GpuMesh, Vertex};
use crate::solver::operator::Scheme;
use crate::vk::barrier::Use;
use crate::vk::{barrier, Access, Buffer, BufferDesc, Context, GpuProfiler, Image, MemoryUse};
use crate::Error;

mod deform;
mod deformation;
mod material;

pub(crate) use deform::{DeformPipelines, LevelDeform, MeshDeform};
pub use deform::{DerivePush, GeometryPush, MapPush, MeshPush, NodesPush};
pub use deformation::{barycentric, transform_normal, Deformation};

/// Pass names (profiler scopes, debug labels).
pub const PASS_EDIT_UPLOAD: &str = "edit upload";
pub const PASS_DEFORM: &str = "edit deform";
pub const PASS_DEFORM_MESH: &str = "edit deform mesh";
pub const PASS_DERIVE_WEIGHTS: &str = "edit derive weights";

/// Which texture an upload writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Geo,
    Frac,
    Kappa,
    Mu,
    Weight(usize),
    SurfacePosition,
    SurfaceNormal,
}

struct Upload {
    level: usize,
    target: Target,
    staging: Buffer,
    /// First write of a new texture (its layout is still UNDEFINED).
    fresh: bool,
}

/// How the pending deformation moves the tetrahedron vertices.
#[derive(Clone, Copy, Debug)]
enum VertexSource {
    Map(MapPush),
    Uploaded,
}

/// Edits taken for one frame ([`GpuDiffusion::take_edits`]), recorded by
/// [`GpuDiffusion::record_edits`]; dropping it releases the staging buffers after that frame.
pub struct StagedEdits {
    derive: bool,
    uploads: Vec<Upload>,
    vertex_uploads: Vec<(usize, Buffer)>,
    deform: Option<VertexSource>,
    meshes: Vec<Arc<GpuMesh>>,
    mesh_from_rest: bool,
}

impl StagedEdits {
    /// Whether the edits move the display mesh (the shadow caster: the shadow maps must follow).
    pub fn moves_mesh(&self) -> bool {
        !self.meshes.is_empty()
    }
}

/// Edits staged by `set_material` / `deform`, taken by [`GpuDiffusion::take_edits`].
#[derive(Default)]
pub(crate) struct EditState {
    /// Re-derive the heterogeneous weights.
    pub(crate) derive: bool,
    uploads: Vec<Upload>,
    vertex_uploads: Vec<(usize, Buffer)>,
    deform: Option<VertexSource>,
    /// Mesh vertex buffers to rewrite (kept alive here until recorded) and whether from the rest
    /// pose.
    meshes: Vec<Arc<GpuMesh>>,
    mesh_from_rest: bool,
    mesh: Option<MeshDeform>,
    /// The deformation last staged (for reports and tests).
    pub(crate) current: Option<Deformation>,
}

impl EditState {
    /// GPU bytes of the display meshes' deformation data (anchors, rest and deformed vertices).
    pub(crate) fn mesh_bytes(&self) -> u64 {
        self.mesh
            .as_ref()
            .map_or(0, |m| m.anchors.size + m.rest.size + m.out.size)
    }

    fn is_empty(&self) -> bool {
        !self.derive
            && self.uploads.is_empty()
            && self.vertex_uploads.is_empty()
            && self.deform.is_none()
            && self.meshes.is_empty()
    }
}

fn staging<T: bytemuck::Pod>(ctx: &Context, data: &[T]) -> Result<Buffer, Error> {
    Ok(Buffer::with_data(
        ctx,
        "edit staging",
        vk::BufferUsageFlags::TRANSFER_SRC,
        data,
    )?)
}

fn storage<T: bytemuck::Pod>(
    ctx: &Context,
    name: &'static str,
    data: &[T],
) -> Result<Buffer, Error> {
    Ok(Buffer::with_data(
        ctx,
        name,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        data,
    )?)
}

fn gpu_buffer(ctx: &Context, name: &'static str, size: u64) -> Result<Buffer, Error> {
    Ok(Buffer::new(
        ctx,
        &BufferDesc {
            name,
            size: size.max(16),
            usage: vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            memory: MemoryUse::GpuOnly,
        },
    )?)
}

fn to_f32x4(v: DVec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

impl GpuLevel {
    fn target(&self, target: Target) -> Option<&Image> {
        match target {
            Target::Geo => Some(&self.geo),
            Target::Frac => self.frac.as_ref(),
            Target::Kappa => self.material.as_ref().map(|m| &m[0]),
            Target::Mu => self.material.as_ref().map(|m| &m[1]),
            Target::Weight(c) => self.weights.as_ref().map(|w| &w[c]),
            Target::SurfacePosition => Some(&self.surface_position),
            Target::SurfaceNormal => Some(&self.surface_normal),
        }
    }
    fn deformed(&self) -> bool {
        self.deform.as_ref().is_some_and(|d| d.deformed)
    }
}

impl GpuDiffusion {
    fn stage(
        &mut self,
        ctx: &Context,
        level: usize,
        target: Target,
        bytes: &[u8],
        fresh: bool,
    ) -> Result<(), Error> {
        let staging = staging(ctx, bytes)?;
        // A newer upload of the same texture replaces an unrecorded older one.
        let fresh = fresh
            || self
                .edits
                .uploads
                .iter()
                .any(|u| u.level == level && u.target == target && u.fresh);
        self.edits
            .uploads
            .retain(|u| !(u.level == level && u.target == target));
        self.edits.uploads.push(Upload {
            level,
            target,
            staging,
            fresh,
        });
        Ok(())
    }

    /// Takes the staged edits for recording in this frame (`None` when nothing is staged); the
    /// staging buffers they hold are released once the frame completed.
    pub fn take_edits(&mut self) -> Option<StagedEdits> {
        if self.edits.is_empty() {
            return None;
        }
        let edits = std::mem::take(&mut self.edits);
        let EditState {
            derive,
            uploads,
            vertex_uploads,
            deform,
            meshes,
            mesh_from_rest,
            mesh,
            current,
        } = edits;
        self.edits.mesh = mesh;
        self.edits.current = current;
        Some(StagedEdits {
            derive: derive && !self.homogeneous,
            uploads,
            vertex_uploads,
            deform,
            meshes,
            mesh_from_rest,
        })
    }

    /// What [`Self::record_edits`] of `staged` uses: the textures it uploads (from a transfer
    /// into GENERAL), every texture and buffer the deformation and weight passes read and write,
    /// and the display meshes whose positions and normals it copies in.
    pub fn edit_uses<'a>(&'a self, staged: &'a StagedEdits) -> Vec<Use<'a>> {
        let mut uses: Vec<Use<'a>> = Vec::new();
        let mut seen = std::collections::HashSet::new();
        let mut add = |u: Use<'a>, uses: &mut Vec<Use<'a>>| {
            if seen.insert(u.resource.handle()) {
                uses.push(u);
            }
        };
        for u in &staged.uploads {
            if let Some(img) = self.levels.get(u.level).and_then(|l| l.target(u.target)) {
                add(
                    Use::image_span(img, Access::TransferDst, Access::ComputeReadWrite),
                    &mut uses,
                );
            }
        }
        for (h, _) in &staged.vertex_uploads {
            if let Some(d) = self.levels.get(*h).and_then(|l| l.deform.as_ref()) {
                add(
                    Use::buffer_span(d.vertices(), Access::TransferDst, Access::ComputeReadWrite),
                    &mut uses,
                );
            }
        }
        if staged.deform.is_some() || staged.derive {
            for l in &self.levels {
                let images = [&l.geo, &l.surface_position, &l.surface_normal]
                    .into_iter()
                    .chain(&l.frac)
                    .chain(l.material.iter().flatten())
                    .chain(l.weights.iter().flatten());
                for img in images {
                    add(Use::image(img, Access::ComputeReadWrite), &mut uses);
                }
                for b in l.deform.iter().flat_map(|d| &d.buffers) {
                    add(Use::buffer(b, Access::ComputeReadWrite), &mut uses);
                }
            }
        }
        if let Some(m) = &self.edits.mesh {
            for b in [&m.rest, &m.out] {
                add(Use::buffer(b, Access::ComputeReadWrite), &mut uses);
            }
            for mesh in &staged.meshes {
                add(
                    Use::buffer(mesh.vertex_buffer(), Access::TransferDst),
                    &mut uses,
                );
            }
        }
        uses
    }

    /// Records `staged` (uploads, deformation passes, mesh rewrite, weight derivation), with the
    /// barriers between its own steps; the frame graph orders it against everything else from
    /// [`Self::edit_uses`].
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::edit_uses`] of `staged`; `self` and `staged` must outlive its execution.
    pub unsafe fn record_edits(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        staged: &StagedEdits,
        mut profiler: Option<&mut GpuProfiler>,
    ) {
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let raw = ctx.raw();
        let mut scope = |cb, name: Option<&'static str>| {
            // SAFETY: forwarded contract of `record_edits`.
            unsafe {
                match name {
                    Some(n) => {
                        ctx.begin_label(cb, n);
                        if let Some(p) = profiler.as_deref_mut() {
                            p.begin_scope(cb, n);
                        }
                    }
                    None => {
                        if let Some(p) = profiler.as_deref_mut() {
                            p.end_scope(cb);
                        }
                        ctx.end_label(cb);
                    }
                }
            }
        };
        // SAFETY: the caller's contract; every resource used lives in `self` or `staged`.
        unsafe {
            if !staged.uploads.is_empty() || !staged.vertex_uploads.is_empty() {
                scope(cb, Some(PASS_EDIT_UPLOAD));
                let images: Vec<(&Image, &Upload)> = staged
                    .uploads
                    .iter()
                    .filter_map(|u| {
                        self.levels
                            .get(u.level)
                            .and_then(|l| l.target(u.target))
                            .map(|i| (i, u))
                    })
                    .collect();
                for (img, u) in &images {
                    img.record_upload_from(ctx, cb, &u.staging);
                }
                for (h, buf) in &staged.vertex_uploads {
                    if let Some(d) = self.levels.get(*h).and_then(|l| l.deform.as_ref()) {
                        let size = buf.size.min(d.vertices().size);
                        let region = vk::BufferCopy::default().size(size);
                        raw.cmd_copy_buffer(cb, buf.raw, d.vertices().raw, &[region]);
                    }
                }
                let to_general: Vec<_> = images
                    .iter()
                    .map(|(img, _)| {
                        barrier::image_barrier(img, Access::TransferDst, Access::ComputeReadWrite)
                    })
                    .collect();
                // why: the passes below read the uploaded texels and vertices (RAW), in GENERAL.
                barrier::record(
                    ctx,
                    cb,
                    &[raw_barrier(
                        S::COPY,
                        A::TRANSFER_WRITE,
                        S::COMPUTE_SHADER,
                        A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
                    )],
                    &to_general,
                );
                scope(cb, None);
            }
            if let (Some(source), Some(pipes)) = (staged.deform, &self.pipelines.edit) {
                scope(cb, Some(PASS_DEFORM));
                if let VertexSource::Map(push) = source {
                    for l in &self.levels {
                        if let Some(d) = &l.deform {
                            pipes.map.dispatch(
                                ctx,
                                cb,
                                d.map_set,
                                &MapPush {
                                    count: d.vertex_count,
                                    ..push
                                },
                                [d.vertex_count, 1, 1],
                            );
                        }
                    }
                    // why: the node pass reads the mapped vertices (RAW).
                    barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeRead);
                }
                for l in &self.levels {
                    if let Some(d) = &l.deform {
                        pipes.nodes.dispatch(
                            ctx,
                            cb,
                            d.nodes_set,
                            &NodesPush {
                                size: [l.packing.width as i32, l.packing.height as i32],
                                width: l.packing.width,
                                surface_rows: l.packing.surface_rows,
                            },
                            l.extent(),
                        );
                    }
                }
                if let Some(m) = &self.edits.mesh {
                    pipes.mesh.dispatch(
                        ctx,
                        cb,
                        m.set,
                        &MeshPush { count: m.count },
                        [m.count, 1, 1],
                    );
                }
                // why: the geometry pass reads the neighbours' new positions (RAW), the mesh copy
                // the deformed mesh vertices (RAW at transfer).
                barrier::record(
                    ctx,
                    cb,
                    &[raw_barrier(
                        S::COMPUTE_SHADER,
                        A::SHADER_STORAGE_WRITE,
                        S::COMPUTE_SHADER | S::COPY,
                        A::SHADER_STORAGE_READ | A::TRANSFER_READ,
                    )],
                    &[],
                );
                let paper = u32::from(self.params.scheme == Scheme::Paper);
                for l in &self.levels {
                    if let Some(d) = &l.deform {
                        pipes.geometry.dispatch(
                            ctx,
                            cb,
                            d.geometry_set,
                            &GeometryPush {
                                size: [l.packing.width as i32, l.packing.height as i32],
                                width: l.packing.width,
                                surface_rows: l.packing.surface_rows,
                                paper,
                                min_volume: d.min_volume,
                                min_distance: d.min_distance,
                                pad: 0,
                            },
                            l.extent(),
                        );
                    }
                }
                scope(cb, None);
            }
            if let (false, Some(m)) = (staged.meshes.is_empty(), &self.edits.mesh) {
                scope(cb, Some(PASS_DEFORM_MESH));
                let src = if staged.mesh_from_rest {
                    &m.rest
                } else {
                    &m.out
                };
                let stride = std::mem::size_of::<Vertex>() as u64;
                // Positions and normals only: the exitance (last 12 bytes) is the solve's.
                let span = std::mem::offset_of!(Vertex, exitance) as u64;
                let regions: Vec<vk::BufferCopy> = (0..u64::from(m.count))
                    .map(|v| {
                        vk::BufferCopy::default()
                            .src_offset(v * stride)
                            .dst_offset(v * stride)
                            .size(span)
                    })
                    .collect();
                for mesh in &staged.meshes {
                    let dst = mesh.vertex_buffer();
                    if dst.size >= u64::from(m.count) * stride {
                        raw.cmd_copy_buffer(cb, src.raw, dst.raw, &regions);
                    }
                }
                scope(cb, None);
            }
            if staged.derive {
                if let Some(dp) = &self.pipelines.derive {
                    scope(cb, Some(PASS_DERIVE_WEIGHTS));
                    // why: the derivation reads the geometry and material just written (RAW).
                    barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
                    let push = DerivePush {
                        size: [0, 0],
                        width: 0,
                        surface_rows: 0,
                        paper: u32::from(self.params.scheme == Scheme::Paper),
                        two_a: self.kappa[3],
                        q_gain: self.mu_gain[3],
                        pad: 0,
                    };
                    for l in &self.levels {
                        if let Some(set) = l.derive_set {
                            dp.dispatch(
                                ctx,
                                cb,
                                set,
                                &DerivePush {
                                    size: [l.packing.width as i32, l.packing.height as i32],
                                    width: l.packing.width,
                                    surface_rows: l.packing.surface_rows,
                                    ..push
                                },
                                l.extent(),
                            );
                        }
                    }
                    scope(cb, None);
                }
            }
        }
    }

    /// The deformation staged last (`None`: never deformed).
    pub fn deformation(&self) -> Option<&Deformation> {
        self.edits.current.as_ref()
    }

    /// Whether edits are staged and not recorded yet.
    pub fn edits_pending(&self) -> bool {
        !self.edits.is_empty()
    }
}
